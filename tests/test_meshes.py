"""Mesh builders: volumes, face areas, face locations, element counts and grading."""
import dataclasses

import gmsh
import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx.mesh import locate_entities
from mpi4py import MPI

from soilbin.errors import InputError
from soilbin.meshes import BUILDERS, StripFootingParams
from soilbin.meshes.blocks import entities_within
from soilbin.meshes.tagged import build_tagged_mesh
from soilbin.params import from_table

COMM = MPI.COMM_WORLD
SLAB = StripFootingParams()
B = SLAB.footing_width / 2


def build(name, **values):
    builder = BUILDERS[name]
    return builder.build(from_table(builder.params, values, "mesh"), COMM)


@pytest.fixture(scope="module")
def box():
    return build("box", lx=2.0, ly=3.0, lz=4.0, nx=2, ny=3, nz=5)


@pytest.fixture(scope="module")
def slab():
    return build("strip_footing")


@pytest.fixture(scope="module")
def slab2():
    return build("strip_footing", refine=2)


def total(form):
    return COMM.allreduce(fem.assemble_scalar(fem.form(form)), op=MPI.SUM)


def num_cells(tm):
    return COMM.allreduce(tm.mesh.topology.index_map(3).size_local, op=MPI.SUM)


def face_areas(tm):
    ds = ufl.Measure("ds", domain=tm.mesh, subdomain_data=tm.facet_tags)
    one = fem.Constant(tm.mesh, 1.0)
    return {name: total(one * ds(tag)) for name, tag in tm.boundaries.items()}


def cell_boxes(tm):
    """Lower corner and extent in x, y, z of each owned cell (all cells are axis-aligned boxes)."""
    owned = tm.mesh.topology.index_map(3).size_local
    nodes = tm.mesh.geometry.x[tm.mesh.geometry.dofmap.array.reshape(-1, 8)[:owned]]
    return nodes.min(axis=1), np.ptp(nodes, axis=1)


def assert_faces_on(tm, where):
    """Every facet of each group has all its vertices where ``where[group]`` says."""
    for name, marker in where.items():
        located = locate_entities(tm.mesh, 2, marker)
        tagged = tm.facet_tags.find(tm.boundaries[name])
        assert COMM.allreduce(len(tagged), op=MPI.SUM) > 0, name
        assert np.isin(tagged, located).all(), name


def test_box_volume_faces_and_cells(box):
    assert list(box.regions) == ["soil"]
    volume = total(fem.Constant(box.mesh, 1.0) * ufl.dx(domain=box.mesh))
    assert volume == pytest.approx(24.0)
    assert face_areas(box) == pytest.approx(
        {"xmin": 12.0, "xmax": 12.0, "ymin": 8.0, "ymax": 8.0, "base": 6.0, "top": 6.0})
    assert num_cells(box) == 2 * 3 * 5
    owned = box.mesh.topology.index_map(3).size_local
    soil = box.cell_tags.find(box.regions["soil"])
    assert COMM.allreduce(np.count_nonzero(soil < owned), op=MPI.SUM) == 30
    assert_faces_on(box, {
        "xmin": lambda x: np.isclose(x[0], 0.0), "xmax": lambda x: np.isclose(x[0], 2.0),
        "ymin": lambda x: np.isclose(x[1], 0.0), "ymax": lambda x: np.isclose(x[1], 3.0),
        "base": lambda x: np.isclose(x[2], 0.0), "top": lambda x: np.isclose(x[2], 4.0)})


def test_box_defaults_are_a_column():
    assert num_cells(build("box")) == 4


def test_slab_volume_faces_and_cells(slab):
    w, d, t = SLAB.width, SLAB.depth, SLAB.thickness
    volume = total(fem.Constant(slab.mesh, 1.0) * ufl.dx(domain=slab.mesh))
    assert volume == pytest.approx(w * d * t)
    assert face_areas(slab) == pytest.approx({
        "footing": B * t, "surface": (w - B) * t, "symmetry": d * t, "far": d * t,
        "base": w * t, "front": w * d, "back": w * d})
    assert num_cells(slab) == (SLAB.n_footing + SLAB.n_beside) * SLAB.n_depth == 768
    tol = 1e-9
    assert_faces_on(slab, {
        "footing": lambda x: np.isclose(x[2], 0.0) & (x[0] <= B + tol),
        "surface": lambda x: np.isclose(x[2], 0.0) & (x[0] >= B - tol),
        "symmetry": lambda x: np.isclose(x[0], 0.0), "far": lambda x: np.isclose(x[0], w),
        "base": lambda x: np.isclose(x[2], -d),
        "front": lambda x: np.isclose(x[1], 0.0), "back": lambda x: np.isclose(x[1], t)})


def test_refine_quadruples_cells_and_halves_sizes(slab, slab2):
    assert num_cells(slab2) == 4 * num_cells(slab)
    smallest = [COMM.allreduce(cell_boxes(tm)[1][:, 0].min(), op=MPI.MIN) for tm in (slab, slab2)]
    # first size of a geometric progression: refining by 2 scales it by 1 / (1 + sqrt(growth))
    assert smallest[1] / smallest[0] == pytest.approx(1.0 / (1.0 + np.sqrt(SLAB.growth)))


@pytest.mark.parametrize("tm_name", ["slab", "slab2"])
def test_slab_is_graded_toward_footing_edge(tm_name, request):
    corner, size = cell_boxes(request.getfixturevalue(tm_name))
    area = size[:, 0] * size[:, 2]
    at_edge = np.isclose(corner[:, 2] + size[:, 2], 0.0) & (
        np.isclose(corner[:, 0], B) | np.isclose(corner[:, 0] + size[:, 0], B))
    smallest_at_edge = COMM.allreduce(area[at_edge].min(initial=np.inf), op=MPI.MIN)
    smallest_elsewhere = COMM.allreduce(area[~at_edge].min(initial=np.inf), op=MPI.MIN)
    assert smallest_at_edge < smallest_elsewhere
    aspect = COMM.allreduce((size[:, [0, 2]].max(axis=1) / size[:, [0, 2]].min(axis=1)).max(), op=MPI.MAX)
    assert aspect < 10.0


@pytest.mark.parametrize("name, values, culprit", [
    ("strip_footing", {"width": -1.0}, "mesh.width"),
    ("strip_footing", {"growth": 0.9}, "mesh.growth"),
    ("strip_footing", {"refine": 0}, "mesh.refine"),
    ("strip_footing", {"footing_width": 30.0}, "mesh.footing_width"),
    ("box", {"lz": 0.0}, "mesh.lz"),
    ("box", {"nx": 0}, "mesh.nx"),
])
def test_out_of_range_parameter_is_named(name, values, culprit):
    with pytest.raises(InputError, match=culprit):
        from_table(BUILDERS[name].params, values, "mesh")


def test_builders_declare_their_groups_and_document_parameters(box, slab):
    for name, tm in [("box", box), ("strip_footing", slab)]:
        builder = BUILDERS[name]
        assert (tuple(tm.regions), tuple(tm.boundaries)) == (builder.regions, builder.boundaries)
        assert builder.summary
        for f in dataclasses.fields(builder.params):
            assert f.metadata["doc"], f.name


def test_non_hexahedra_are_refused_and_gmsh_is_finalized(monkeypatch):
    finalize, calls = gmsh.finalize, []
    monkeypatch.setattr(gmsh, "finalize", lambda: calls.append(finalize()))

    def tetrahedra():
        gmsh.model.occ.addBox(0.0, 0.0, 0.0, 1.0, 1.0, 1.0)
        gmsh.model.occ.synchronize()
        return {"soil": entities_within(3)}, {}

    message = "only 8-node hexahedra" if COMM.rank == 0 else "failed to mesh 'tetrahedra' on rank 0"
    with pytest.raises(RuntimeError, match=message):
        build_tagged_mesh(COMM, "tetrahedra", tetrahedra)
    assert len(calls) == 1
