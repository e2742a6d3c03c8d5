"""Soil-structure meshes: the soil bin around a rigid blade and the slab behind a retaining wall."""
import dataclasses
import functools
import math
import re

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx.mesh import CellType
from mpi4py import MPI

from soilbin.errors import InputError
from soilbin.meshes import BUILDERS, RetainingWallParams, SoilBinParams
from soilbin.meshes.soil_bin import TOOL_FACES, tool_faces
from soilbin.params import from_table
from test_meshes import assert_faces_on, face_areas, num_cells, total

COMM = MPI.COMM_WORLD
ENDS = ("front_end", "back_end", "side")


@functools.cache
def built(name, **values):
    builder = BUILDERS[name]
    return builder.build(from_table(builder.params, values, "mesh"), COMM)


def volume(tm):
    return total(fem.Constant(tm.mesh, 1.0) * ufl.dx(domain=tm.mesh))


def cell_volumes(tm):
    v = ufl.TestFunction(fem.FunctionSpace(tm.mesh, ("DG", 0)))
    return fem.assemble_vector(fem.form(v * ufl.dx)).array[:tm.mesh.topology.index_map(3).size_local]


def min_corner_jacobian(tm):
    """Smallest Jacobian determinant at the corners of the owned hexahedra (vertices in
    tensor-product order: vertex c sits at the reference corner with coordinates the bits of c)."""
    owned = tm.mesh.topology.index_map(3).size_local
    x = tm.mesh.geometry.x[tm.mesh.geometry.dofmap.array.reshape(-1, 8)[:owned]]
    dets = []
    for c in range(8):
        edges = [(x[:, c ^ (1 << a)] - x[:, c]) * (-1 if c >> a & 1 else 1) for a in range(3)]
        dets.append(np.einsum("ij,ij->i", edges[0], np.cross(edges[1], edges[2])))
    return COMM.allreduce(np.min(dets, initial=np.inf), op=MPI.MIN)


def cells_touching(tm, groups):
    """Owned cells with a vertex on a facet of the groups."""
    topology = tm.mesh.topology
    topology.create_connectivity(2, 0)
    topology.create_connectivity(0, 3)

    def neighbours(entities, connectivity):
        return np.unique(np.concatenate([connectivity.links(e) for e in entities] + [np.empty(0, np.int32)]))
    facets = np.concatenate([tm.facet_tags.find(tm.boundaries[g]) for g in groups])
    cells = neighbours(neighbours(facets, topology.connectivity(2, 0)), topology.connectivity(0, 3))
    return cells[cells < topology.index_map(3).size_local]


def smallest(values):
    return COMM.allreduce(np.min(values, initial=np.inf), op=MPI.MIN)


def largest(values):
    return COMM.allreduce(np.max(values, initial=-np.inf), op=MPI.MAX)


CASES = [(rake, configuration) for rake in (30.0, 60.0, 90.0) for configuration in ("side_wall", "embedded")]


@pytest.mark.parametrize("rake, configuration", CASES)
def test_soil_bin_volume_faces_and_positive_jacobians(rake, configuration):
    tm = built("soil_bin", rake_angle=rake, configuration=configuration)
    p = SoilBinParams(rake_angle=rake)
    a = math.radians(rake)
    w = p.tool_width if configuration == "side_wall" else p.tool_width / 2
    t, d, ahead, behind = p.tool_thickness, p.tool_depth, p.ahead, p.behind
    blade = t / math.sin(a)                                  # the blade's thickness along x
    tip = behind + d / math.tan(a) + blade                   # x of the blade's lower front edge
    length, width, depth = tip + ahead, p.bin_width, p.bin_depth
    assert tm.mesh.topology.cell_type == CellType.hexahedron
    assert min_corner_jacobian(tm) > 1e-3
    assert volume(tm) == pytest.approx(length * width * depth - w * t * d / math.sin(a), rel=1e-12)
    assert face_areas(tm) == pytest.approx({
        "tool_front": w * d / math.sin(a), "tool_back": w * d / math.sin(a), "tool_side": blade * d,
        "tool_bottom": w * blade, "surface": length * width - w * blade, "base": length * width,
        "symmetry": length * depth - blade * d, "side": length * depth,
        "front_end": width * depth, "back_end": width * depth}, rel=1e-12)
    tol = 1e-9
    front = lambda x: np.isclose(x[0], tip - (x[2] + d) / math.tan(a))  # noqa: E731
    assert_faces_on(tm, {
        "tool_front": lambda x: front(x) & (x[1] <= w + tol) & (x[2] >= -d - tol),
        "tool_back": lambda x: np.isclose(x[0], tip - blade - (x[2] + d) / math.tan(a)) & (x[2] >= -d - tol),
        "tool_side": lambda x: np.isclose(x[1], w) & (x[2] >= -d - tol),
        "tool_bottom": lambda x: np.isclose(x[2], -d) & (x[1] <= w + tol),
        "surface": lambda x: np.isclose(x[2], 0.0), "base": lambda x: np.isclose(x[2], -depth),
        "symmetry": lambda x: np.isclose(x[1], 0.0), "side": lambda x: np.isclose(x[1], width),
        "front_end": lambda x: np.isclose(x[0], length), "back_end": lambda x: np.isclose(x[0], 0.0)})


@pytest.mark.parametrize("rake, configuration", CASES[::3])
def test_tool_faces_are_the_cavity_planes_with_normals_into_the_tool(rake, configuration):
    tm = built("soil_bin", rake_angle=rake, configuration=configuration)
    p = from_table(SoilBinParams, {"rake_angle": rake, "configuration": configuration}, "mesh")
    faces = tool_faces(p)
    assert tuple(faces) == TOOL_FACES
    a = math.radians(rake)
    tip = p.behind + p.tool_depth / math.tan(a) + p.tool_thickness / math.sin(a)
    point, normal = faces["tool_front"]
    assert np.allclose(normal, [-math.sin(a), 0.0, -math.cos(a)]) and np.isclose(np.linalg.norm(normal), 1)
    assert np.isclose(np.dot(np.array([tip, 0.0, -p.tool_depth]) - point, normal), 0.0)
    ds = ufl.Measure("ds", domain=tm.mesh, subdomain_data=tm.facet_tags)
    n = ufl.FacetNormal(tm.mesh)                             # out of the soil, so into the tool
    for name, (point, normal) in faces.items():
        tag = tm.boundaries[name]
        c = ufl.as_vector(normal.tolist())
        assert total(ufl.dot(n - c, n - c) * ds(tag)) < 1e-20, name
        gap = ufl.dot(ufl.SpatialCoordinate(tm.mesh) - ufl.as_vector(point.tolist()), c)
        assert total(gap ** 2 * ds(tag)) < 1e-20, name


def test_soil_bin_size_refine_2_gives_8x_and_smallest_cells_are_next_to_the_blade():
    coarse, fine = built("soil_bin"), built("soil_bin", refine=2)
    assert 2000 <= num_cells(coarse) <= 6000
    assert num_cells(fine) == 8 * num_cells(coarse)
    assert num_cells(coarse) == SoilBinParams().cells   # counted before gmsh runs
    for tm in (coarse, fine, built("soil_bin", rake_angle=30.0, configuration="embedded")):
        v = cell_volumes(tm)
        near, least = v[cells_touching(tm, TOOL_FACES)], smallest(v)
        assert smallest(near) == least
        assert largest(near) < smallest(v[cells_touching(tm, ENDS)])
        assert smallest(v[cells_touching(tm, ["base"])]) > 2 * least
        assert largest(v) > 100 * least


@pytest.mark.parametrize("values", [{}, {"wall_height": 4.0, "depth": 6.0, "length": 9.0, "thickness": 0.5}],
                         ids=["defaults", "odd"])
def test_retaining_wall_volume_faces_and_cells(values):
    tm, p = built("retaining_wall", **values), RetainingWallParams(**values)
    h, length, depth, t = p.wall_height, p.length, p.depth, p.thickness
    assert min_corner_jacobian(tm) > 1e-3
    assert volume(tm) == pytest.approx(length * depth * t, rel=1e-12)
    assert face_areas(tm) == pytest.approx({
        "wall": h * t, "below_wall": (depth - h) * t, "surface": length * t, "far": depth * t,
        "base": length * t, "front": length * depth, "back": length * depth}, rel=1e-12)
    tol = 1e-9
    assert_faces_on(tm, {
        "wall": lambda x: np.isclose(x[0], 0.0) & (x[2] >= -h - tol),
        "below_wall": lambda x: np.isclose(x[0], 0.0) & (x[2] <= -h + tol),
        "surface": lambda x: np.isclose(x[2], 0.0), "far": lambda x: np.isclose(x[0], length),
        "base": lambda x: np.isclose(x[2], -depth),
        "front": lambda x: np.isclose(x[1], 0.0), "back": lambda x: np.isclose(x[1], t)})
    assert np.isclose(tm.mesh.geometry.x[:, 1], 0.0).sum() * 2 == len(tm.mesh.geometry.x)  # one layer


def test_retaining_wall_size_refine_and_grading_toward_the_toe():
    coarse, fine = built("retaining_wall"), built("retaining_wall", refine=2)
    assert 200 <= num_cells(coarse) <= 1000
    assert num_cells(fine) == 4 * num_cells(coarse)
    assert num_cells(coarse) == RetainingWallParams().cells
    assert smallest(cell_volumes(coarse)) == pytest.approx(largest(cell_volumes(coarse)))  # uniform
    graded = built("retaining_wall", element_size=0.25, growth=1.3)
    v = cell_volumes(graded)
    toe = np.intersect1d(cells_touching(graded, ["wall"]), cells_touching(graded, ["below_wall"]))
    assert largest(v[toe]) <= 0.25**2 and smallest(v) == smallest(v[toe])   # at most 0.25 at the toe
    assert largest(v[toe]) < smallest(v[cells_touching(graded, ["surface", "far", "base"])])


@pytest.mark.parametrize("name, values, culprit", [
    ("soil_bin", {"rake_angle": 20.0}, "rake_angle"),
    ("soil_bin", {"rake_angle": 95.0}, "rake_angle"),
    ("soil_bin", {"tool_width": -2.0}, "tool_width"),
    ("soil_bin", {"tool_thickness": 0.0}, "tool_thickness"),
    ("soil_bin", {"tool_depth": -1.0}, "tool_depth"),
    ("soil_bin", {"tool_depth": 12.0}, "tool_depth"),                         # = bin_depth
    ("soil_bin", {"tool_depth": 8.0, "bin_depth": 7.0}, "tool_depth"),
    ("soil_bin", {"bin_depth": -12.0}, "bin_depth"),
    ("soil_bin", {"bin_width": 0.0}, "bin_width"),
    ("soil_bin", {"tool_width": 18.0}, "tool_width"),                         # span = bin_width
    ("soil_bin", {"tool_width": 40.0, "configuration": "embedded"}, "tool_width"),
    ("soil_bin", {"ahead": 0.0}, "ahead"),
    ("soil_bin", {"behind": -1.0}, "behind"),
    ("soil_bin", {"element_size": 0.0}, "element_size"),
    ("soil_bin", {"growth": 0.9}, "growth"),
    ("soil_bin", {"refine": 0}, "refine"),
    ("soil_bin", {"configuration": "middle"}, "configuration"),
    ("retaining_wall", {"wall_height": 15.0}, "wall_height"),                # = depth
    ("retaining_wall", {"wall_height": -1.0}, "wall_height"),
    ("retaining_wall", {"length": 0.0}, "length"),
    ("retaining_wall", {"thickness": -1.0}, "thickness"),
    ("retaining_wall", {"growth": 2.5}, "growth"),
])
def test_out_of_range_parameter_is_named(name, values, culprit):
    with pytest.raises(InputError, match=rf"^mesh\.{re.escape(culprit)}( = |: )"):
        from_table(BUILDERS[name].params, values, "mesh")


@pytest.mark.parametrize("name", ["soil_bin", "retaining_wall"])
def test_builders_declare_their_groups_and_document_parameters(name):
    builder, tm = BUILDERS[name], built(name)
    assert (tuple(tm.regions), tuple(tm.boundaries)) == (builder.regions, builder.boundaries)
    assert builder.summary
    for f in dataclasses.fields(builder.params):
        assert f.metadata["doc"], f.name
