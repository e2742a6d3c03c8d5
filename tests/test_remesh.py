"""Remeshing a large-deformation run (scene ``[remesh]``): the deformed soil's outline, the
transfer of the state to the new mesh, and a run that remeshes and resumes."""
import csv
import os
import subprocess
from xml.etree import ElementTree

import gmsh
import meshio
import numpy as np
import pytest
from dolfinx.cpp.mesh import entities_to_geometry

from conftest import ROOT, SCENES, SOILBIN
from soilbin.app.run import run_scene
from soilbin.errors import ConvergenceError, InputError
from soilbin.records.scene import load_scene
from soilbin.remesh.outline import OutlineError, chain
from soilbin.remesh.surface import Surface
from soilbin.remesh.transfer import OldCells
from test_checkpoint import curve, stop_and_resume

#: The footing pushed 0.06 in into the soil on a coarse mesh, remeshed every 3 steps and
#: where the mesh's quality falls below 0.3.
FOOTING = ("mesh.edge_size=0.05", "loading.magnitude=0.06", "loading.steps=6",
           "loading.first_cuts=0", "remesh.every=3")

#: The Drucker–Prager block on tetrahedra compressed by a tenth of its height in large
#: deformation, remeshed every 4 steps.
BLOCK_3D = ("analysis.element=tet10-bbar", "analysis.large_deformation=true", "remesh.every=4",
            "loading.magnitude=0.1", "loading.steps=10")

#: The rough wall pushed 0.05 in into sand in large deformation, remeshed every 3 steps.
WALL = ("analysis.large_deformation=true", "loading.magnitude=0.05", "loading.steps=5",
        "remesh.every=3")


def distorted_quadrilaterals():
    """Corners (n, 4, 2) of a sheared, graded 4 x 3 grid of quadrilaterals (DOLFINx order)."""
    xs, zs = np.array([0.0, 0.3, 0.7, 1.2, 2.0]), np.array([0.0, 0.4, 0.9, 1.5])
    cells = []
    for j in range(3):
        for i in range(4):
            corners = [(xs[i + a] + 0.2 * zs[j + b] ** 2, zs[j + b] + 0.1 * xs[i + a])
                       for b in (0, 1) for a in (0, 1)]
            cells.append(corners)
    return np.array(cells)


def test_a_linear_field_is_transferred_exactly():
    """The cell-wise linear fit through the quadrature points and the nodal interpolation both
    reproduce a linear field at any point of the old mesh."""
    corners = distorted_quadrilaterals()
    old = OldCells(corners, simplex=False)
    field = lambda x: np.stack([1.0 + 2.0 * x[..., 0] - 3.0 * x[..., 1],
                                0.5 * x[..., 0] + x[..., 1]], axis=-1)
    weights = np.array([[0.2, 0.3, 0.1, 0.4], [0.6, 0.1, 0.2, 0.1], [0.1, 0.1, 0.4, 0.4],
                        [0.3, 0.3, 0.3, 0.1]])   # four points inside each cell
    samples = np.einsum("pk,nkd->npd", weights, corners)
    rng = np.random.default_rng(1)
    targets = np.einsum("mk,mkd->md", rng.dirichlet(np.ones(4), 200),
                        corners[rng.integers(0, len(corners), 200)])
    located = old.locate(targets)
    assert np.allclose(old.at_points(samples, located)(field(samples)), field(targets),
                       rtol=0.0, atol=1e-12)
    assert np.allclose(old.at_nodes(field(corners), located), field(targets), rtol=0.0,
                       atol=1e-12)


def test_a_linear_field_is_transferred_exactly_between_tetrahedra():
    """As in the plane: the linear fit through four points of each old tetrahedron and the
    nodal interpolation over the old tetrahedra reproduce a linear field."""
    cube = np.array([[i, j, k] for k in (0, 1) for j in (0, 1) for i in (0, 1)], dtype=float)
    cube = cube + 0.1 * cube[:, [1, 2, 0]] ** 2                      # distorted
    # the six tetrahedra around the cube's diagonal 0-7
    corners = cube[[[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7],
                    [0, 4, 6, 7]]]
    old = OldCells(corners, simplex=True)
    field = lambda x: np.stack([1.0 + 2.0 * x[..., 0] - 3.0 * x[..., 1] + x[..., 2],
                                0.5 * x[..., 2]], axis=-1)
    rng = np.random.default_rng(2)
    samples = np.einsum("nqk,nkd->nqd", rng.dirichlet(np.ones(4), (6, 4)), corners)
    targets = np.einsum("mk,mkd->md", rng.dirichlet(np.ones(4), 100),
                        corners[rng.integers(0, 6, 100)])
    located = old.locate(targets)
    assert np.allclose(old.at_points(samples, located)(field(samples)), field(targets),
                       rtol=0.0, atol=1e-12)
    assert np.allclose(old.at_nodes(field(corners), located), field(targets), rtol=0.0,
                       atol=1e-12)


def box_surface(tags):
    """The closed surface of the unit cube, two triangles a face, the six faces tagged
    ``tags`` (xmin, xmax, ymin, ymax, zmin, zmax), each triangle listed in any order."""
    corners = []
    for axis in range(3):
        for side in (0.0, 1.0):
            u, v = [a for a in range(3) if a != axis]
            square = np.zeros((4, 3))
            square[:, axis] = side
            square[:, u], square[:, v] = [0, 1, 1, 0], [0, 0, 1, 1]
            corners += [square[[0, 1, 2]], square[[0, 2, 3]]]
    return np.array(corners), np.repeat(tags, 2)


def test_the_surface_is_cut_into_patches_at_folds_and_at_group_borders():
    corners, tags = box_surface([1, 2, 3, 4, 5, 6])
    one_group = np.ones(12, dtype=int)

    def patches(tags, crease):
        return len(np.unique(Surface.of(corners, tags).patches(np.radians(crease))))
    assert patches(tags, 40.0) == 6
    assert patches(one_group, 40.0) == 6
    assert patches(one_group, 100.0) == 2   # one closed patch: not a disc, cut in two
    split = tags.copy()
    split[11] = 7   # one triangle of the top face in a group of its own: a border on a flat face
    assert patches(split, 40.0) == 7
    with pytest.raises(OutlineError, match="do not close"):
        Surface.of(corners[:-1], tags[:-1])


def test_the_patches_borders_are_the_cubes_edges_and_a_closed_border_gets_a_corner():
    corners, tags = box_surface([1, 2, 3, 4, 5, 6])
    surface = Surface.of(corners, tags)
    borders = surface.borders(surface.patches(np.radians(40.0)))
    assert len(borders.corners) == 8 and len(borders.curves) == 12
    assert [len(b) for b in borders.bounding] == [4] * 6
    ends = {tuple(sorted((c[0], c[-1]))) for c in borders.curves}
    lengths = [np.linalg.norm(np.subtract(*surface.points[list(e)])) for e in ends]
    assert np.allclose(lengths, 1.0)      # the twelve edges of the cube, from corner to corner
    # a square in the middle of the top face a patch of its own: its border meets no other
    fine = Surface.of(*refined_box_surface(4))
    patch_of = fine.patches(np.radians(40.0))
    top = patch_of[np.argmax(fine.points[fine.triangles].mean(axis=1)[:, 2])]
    centre = np.abs(fine.points[fine.triangles].mean(axis=1)[:, :2] - 0.5).max(axis=1) < 0.25
    patch_of[centre & (patch_of == top)] = patch_of.max() + 1
    borders = fine.borders(patch_of)
    assert len(borders.curves) == 13 and len(borders.corners) == 9
    loop, = (c for c in borders.curves if c[0] == c[-1])
    assert len(loop) == 9    # the square's eight edges, closed at its least point


def refined_box_surface(n):
    """The unit cube's surface, each face an n x n grid of squares cut in two triangles,
    tagged by face as :func:`box_surface`."""
    corners, tags = [], []
    grid = np.linspace(0.0, 1.0, n + 1)
    for face, (axis, side) in enumerate((a, s) for a in range(3) for s in (0.0, 1.0)):
        u, v = [a for a in range(3) if a != axis]
        for i in range(n):
            for j in range(n):
                square = np.zeros((4, 3))
                square[:, axis] = side
                square[:, u] = grid[[i, i + 1, i + 1, i]]
                square[:, v] = grid[[j, j, j + 1, j + 1]]
                corners += [square[[0, 1, 2]], square[[0, 2, 3]]]
                tags += [face + 1] * 2
    return np.array(corners), np.array(tags)


def cube_sizes(size):
    """:class:`~soilbin.remesh.mesher.Sizes` of ``size`` over the unit cube."""
    from soilbin.remesh.mesher import Sizes
    kuhn = [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]]
    cube = np.array([[i & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], dtype=float)
    return Sizes(cube[kuhn], np.full((6, 4), size))


def test_a_patch_pinched_at_a_point_is_cut_into_discs_and_meshed(tmp_path):
    """gmsh maps each patch onto a plane, so each must be a topological disc. A piece cut out
    of a patch that touches the patch's border at one point (the tine's soil after 4 in: a
    triangle of the free surface folded past the crease, one corner on the tool) leaves
    the patch's border passing twice through that point, and gmsh cannot map it: the patch
    is cut through the piece."""
    from mpi4py import MPI
    from soilbin.remesh.mesher import CREASE, mesh_surface
    from soilbin.remesh.surface import euler_characteristic
    corners, tags = refined_box_surface(4)
    centroid = corners.mean(axis=1)
    # the top's triangle (0, 0.25), (0.25, 0.25), (0.25, 0.5): one corner on its edge x = 0
    piece = (tags == 6) & np.isclose(centroid[:, 0], 1 / 6) & np.isclose(centroid[:, 1], 1 / 3)
    tags[piece] = 7
    surface = Surface.of(corners, tags)
    patch_of = surface.patches(CREASE)
    assert (euler_characteristic(surface.triangles, patch_of) == 1).all()
    assert len(np.unique(patch_of[surface.tags == 6])) > 1
    mesh_surface(MPI.COMM_SELF, surface, cube_sizes(0.3), {"soil": 1},
                 {f"face{k}": k for k in range(1, 8)}, tmp_path / "pinched.msh")
    mesh = meshio.read(tmp_path / "pinched.msh")
    assert sum(len(c) for c in mesh.cells_dict.values()) > 0


def test_a_soil_folded_onto_itself_is_named_where_gmsh_cannot_fill_it(tmp_path):
    """A boundary that passes through itself (the heave beside the tine after 5.6 in curled
    onto the soil's face at the tool's side) cannot be filled with
    tetrahedra; the remesh's message says where it crosses, between which groups."""
    from mpi4py import MPI
    from soilbin.remesh.mesher import mesh_surface
    corners, tags = refined_box_surface(4)
    for x in (0.25, 0.5, 0.75):          # the top's middle pushed down through the bottom
        for y in (0.25, 0.5, 0.75):
            middle = (corners == [x, y, 1.0]).all(axis=2)
            corners[middle] = [x, y, -0.5]
    surface = Surface.of(corners, tags)
    points, crossed = surface.crossings()
    assert len(points) > 0 and np.allclose(points[:, 2], 0.0)
    assert {tuple(t) for t in crossed} <= {(6, 5), (5, 6)}
    assert len(Surface.of(*refined_box_surface(4)).crossings()[0]) == 0
    with pytest.raises(RuntimeError, match=r"folded onto itself, its "
                                           r"boundary (top|bottom) passing through (bottom|top) at"):
        mesh_surface(MPI.COMM_SELF, surface, cube_sizes(0.3), {"soil": 1},
                     {"bottom": 5, "top": 6, **{f"face{k}": k for k in range(1, 5)}},
                     tmp_path / "folded.msh")


def test_gmsh_s_surfaces_in_a_failed_remesh_are_named_by_their_groups():
    """gmsh names the patches it could not mesh by its own surface numbers ("Invalid boundary
    mesh (overlapping facets) on surface 4 surface 9": the tine's heap in clay at 4.65 in
    coming too close to the soil's face); the message names their groups."""
    from soilbin.remesh.mesher import patch_groups
    groups = {1: 5, 4: 7, 9: 1}
    boundaries = {"surface": 1, "base": 5, "tool_front": 7}
    message = "Error: Invalid boundary mesh (overlapping facets) on surface 4 surface 9"
    assert (patch_groups(message, groups, boundaries)
            == "; gmsh's surface 4 is a patch of tool_front, 9 of surface")
    assert patch_groups("surface 4 surface 4", groups, boundaries).count("surface 4") == 1
    assert patch_groups("Error: PLC Error: A segment and a facet intersect", groups,
                        boundaries) == ""


def test_a_crumple_of_the_surface_joins_a_larger_patch_of_its_group():
    """A patch of at most CRUMPLE triangles folded past the crease (the heave beside the blade
    after 4 in: gmsh's fresh mesh of the patch around overlapped it) joins its widest larger
    neighbour of the same group; a cube's faces of two triangles each stay six patches."""
    from soilbin.remesh.surface import CRUMPLE
    corners, tags = refined_box_surface(4)
    # one triangle of the top next to its border tented up steeply: three patches of one
    # triangle, one of which borders the side and its two neighbours only
    top = np.flatnonzero(tags == 6)[0]
    a, b, c = corners[top]
    apex = (a + b + c) / 3.0 + [0.0, 0.0, 0.3]
    tent = np.array([[a, b, apex], [b, c, apex], [c, a, apex]])
    corners = np.concatenate([np.delete(corners, top, axis=0), tent])
    tags = np.concatenate([np.delete(tags, top), [6, 6, 6]])
    surface = Surface.of(corners, tags)
    patch_of = surface.patches(np.radians(40.0))
    assert len(np.unique(patch_of)) == 6 and 3 <= CRUMPLE
    assert len(np.unique(patch_of[surface.tags == 6])) == 1


def test_a_run_stops_at_the_first_step_where_its_soil_folds_onto_itself(tmp_path):
    """After every converged step a remeshing 3D run checks that the soil's boundary does not
    pass through itself (the scene has no [soil_contact], gmsh could not fill it): the block as
    built passes; with one corner of its top pushed down through its bottom, the check says
    where, as a RemeshError (which ends the run with its steps on disk)."""
    from types import SimpleNamespace

    from conftest import make_problem
    from soilbin.remesh.remesher import RemeshError, Remeshing
    problem = make_problem("block-drucker-prager", *BLOCK_3D)
    remeshing = Remeshing(problem.scene, tmp_path)
    step = SimpleNamespace(step=3)
    remeshing.check_folding(problem, step)
    mesh = problem.tagged.mesh
    x = mesh.geometry.x
    vertices = entities_to_geometry(mesh._mesh, 0, np.arange(len(x), dtype=np.int32)[
        :mesh.topology.index_map(0).size_local], False).ravel()      # not mid-edge nodes
    top, bottom = x[:, 2].max(), x[:, 2].min()
    centre = x[:, :2].mean(axis=0)
    on_top = vertices[np.isclose(x[vertices, 2], top)]
    inner = on_top[np.argmin(np.linalg.norm(x[on_top, :2] - centre, axis=1))]
    x[inner, 2] = bottom - (top - bottom)
    with pytest.raises(RemeshError, match=r"after step 3 the soil has folded onto itself, its "
                                          r"boundary .* passing through .*\(no \[soil_contact\]"):
        remeshing.check_folding(problem, step)


def test_a_surface_is_meshed_the_same_way_every_time(tmp_path):
    """The mesh of a surface depends on the surface alone, not on what the process did before
    (gmsh's own createTopology numbered the curves in an order that changed from run to run,
    and the tetrahedra with it)."""
    from mpi4py import MPI
    from soilbin.remesh.mesher import mesh_surface
    surface = Surface.of(*refined_box_surface(3))
    sizes = cube_sizes(0.3)
    meshes = []
    for attempt in range(3):
        junk = [np.empty(1000 + 997 * attempt * k) for k in range(50)]   # another heap
        mesh_surface(MPI.COMM_SELF, surface, sizes, {"soil": 1},
                     {f"face{k}": k for k in range(1, 7)}, tmp_path / f"{attempt}.msh")
        del junk
        mesh = meshio.read(tmp_path / f"{attempt}.msh")
        meshes.append((mesh.points, mesh.cells_dict["tetra"]))
    for points, cells in meshes[1:]:
        assert np.array_equal(points, meshes[0][0]) and np.array_equal(cells, meshes[0][1])


@pytest.mark.slow
def test_a_remeshing_run_repeats_itself_to_the_bit_in_another_process(tmp_path):
    """The blade through the clay on its coarsest mesh, meshed afresh every second step, run
    by two processes of different hash seeds: the same curve and the same meshes, so that a
    long run's path of remeshes is the code's, not the process's (the clay scene's 4 in, 39
    remeshes, came out so to the bit; the study tables rest on it)."""
    runs = []
    for seed in ("1", "2"):
        out = tmp_path / seed
        done = subprocess.run(
            [str(SOILBIN), "run", "tine-2in-long-clay", "--out", str(out),
             "--set", "mesh.element_size=1.5", "--set", "loading.magnitude=0.2",
             "--set", "loading.steps=8", "--set", "remesh.every=2", "--set", "output.at=[]"],
            capture_output=True, text=True, timeout=600, cwd=ROOT,
            env=dict(os.environ, OMP_NUM_THREADS="1", PYTHONHASHSEED=seed))
        assert done.returncode == 0, done.stderr
        runs.append(out)
    first, second = (curve(out) for out in runs)
    assert len(first) >= 8 and first == second
    meshes = [sorted((out / "meshes").iterdir()) for out in runs]
    assert len(meshes[0]) >= 4 and [m.name for m in meshes[0]] == [m.name for m in meshes[1]]
    assert all(a.read_bytes() == b.read_bytes() for a, b in zip(*meshes))


def test_the_sections_after_a_remesh_are_drawn_from_the_soil_on_the_new_mesh(tmp_path,
                                                                             monkeypatch):
    """The sections at a stop of ``output.at`` after a remesh show the soil where the tool now
    is (they were drawn from the problem on the scene's mesh, as it was at the first remesh)."""
    from soilbin.app import section_figures
    drawn = []
    monkeypatch.setattr(section_figures, "sections_png",
                        lambda problem, scene, load, path: drawn.append(
                            (load, problem.tool.travel, problem.mesh)))
    summary = run_scene(load_scene(SCENES / "tine-2in-long-clay.toml", [
        "mesh.element_size=1.5", "loading.magnitude=0.1", "loading.steps=4", "remesh.every=2",
        "output.at=[0.05, 0.1]"]), tmp_path)
    assert summary["status"] == "complete" and summary["remeshes"] >= 2
    (first, first_travel, first_mesh), (last, last_travel, last_mesh) = drawn
    assert (first, last) == (0.05, 0.1)
    assert first_travel == pytest.approx(0.05) and last_travel == pytest.approx(0.1)
    assert last_mesh is not first_mesh


def test_a_surface_is_meshed_by_delaunay_unless_its_tetrahedra_are_below_min_quality(
        tmp_path, monkeypatch):
    """The patches are meshed by Delaunay (ten times faster than MeshAdapt on the tine's
    soil); where its tetrahedra fall below min_quality the model is built again and meshed
    by MeshAdapt, whose mesh it then is to the bit."""
    from mpi4py import MPI
    from soilbin.problem.mesh_quality import simplex_quality
    from soilbin.remesh import mesher
    surface = Surface.of(*refined_box_surface(3))

    def tetrahedra(name, min_quality):
        mesher.mesh_surface(MPI.COMM_SELF, surface, cube_sizes(0.3), {"soil": 1},
                            {f"face{k}": k for k in range(1, 7)}, tmp_path / name, min_quality)
        mesh = meshio.read(tmp_path / name)
        return mesh.points, mesh.cells_dict["tetra"]
    points, cells = tetrahedra("delaunay.msh", 0.0)
    least = simplex_quality(points[cells]).min()
    assert 0.0 < least < 1.0
    fallen_back = tetrahedra("fallen-back.msh", least)
    monkeypatch.setattr(mesher, "DELAUNAY", mesher.MESH_ADAPT)
    mesh_adapt = tetrahedra("mesh-adapt.msh", 0.0)
    assert all(np.array_equal(a, b) for a, b in zip(fallen_back, mesh_adapt))
    assert len(cells) != len(mesh_adapt[1]) or not np.array_equal(points, mesh_adapt[0])


def test_where_gmsh_fails_on_the_patches_they_are_cut_again_at_wider_folds(tmp_path,
                                                                           monkeypatch):
    """A fresh mesh whose patches cut at CREASE gmsh cannot mesh (the clay's heap beside the
    blade: two patches that overlapped once meshed afresh) is made of patches cut at each
    of WIDER_CREASES in turn; where all fail, the run hears why."""
    from mpi4py import MPI
    from soilbin.remesh import mesher
    tried = []
    tetrahedra = mesher._tetrahedra

    def failing_at(*creases):
        def attempt(*args):
            tried.append(args[-1])
            if args[-1] in creases:
                raise RuntimeError(f"gmsh cannot mesh the patches cut at {args[-1]:.2f}")
            return tetrahedra(*args)
        return attempt
    surface, groups = Surface.of(*refined_box_surface(3)), {f"face{k}": k for k in range(1, 7)}
    first, (second, last) = mesher.CREASE, mesher.WIDER_CREASES
    monkeypatch.setattr(mesher, "_tetrahedra", failing_at(first, second))
    gmsh.initialize(readConfigFiles=False)   # in this process: the child's calls are not seen
    try:
        mesher._written_tetrahedra(surface, cube_sizes(0.3), {"soil": 1}, groups,
                                   tmp_path / "wide.msh", 0.0)
    finally:
        gmsh.finalize()
    assert tried == [first, second, last] and len(meshio.read(tmp_path / "wide.msh").cells)
    monkeypatch.setattr(mesher, "_tetrahedra", failing_at(first, second, last))
    with pytest.raises(RuntimeError, match=f"cut at {last:.2f}"):   # the child's, raised here
        mesher.mesh_surface(MPI.COMM_SELF, surface, cube_sizes(0.3), {"soil": 1}, groups,
                            tmp_path / "none.msh")


def test_gmsh_dying_on_a_fresh_mesh_fails_the_remesh_not_the_run(tmp_path, monkeypatch):
    """gmsh meshes the soil afresh in a child process: a crash there is a RuntimeError here
    (the remesh failed, and the run tries again after the next step)."""
    import signal
    from mpi4py import MPI
    from soilbin.remesh import mesher
    monkeypatch.setattr(mesher, "_written_tetrahedra",
                        lambda *args: os.kill(os.getpid(), signal.SIGBUS))
    with pytest.raises(RuntimeError, match="gmsh died meshing the deformed soil afresh"):
        mesher.mesh_surface(MPI.COMM_SELF, Surface.of(*refined_box_surface(3)),
                            cube_sizes(0.3), {"soil": 1}, {f"face{k}": k for k in range(1, 7)},
                            tmp_path / "died.msh")


def test_a_fresh_mesh_with_a_flat_tetrahedron_is_a_failed_remesh(tmp_path, monkeypatch):
    """Where Delaunay's tetrahedra are below min_quality and MeshAdapt's below
    :data:`~soilbin.remesh.mesher.FLAT` (here raised to 1: every tetrahedron), the mesher
    raises (gmsh made a flat one on three collinear nodes of the clay's soil, and the
    re-equilibration's residual was nan)."""
    from mpi4py import MPI
    from soilbin.remesh import mesher
    monkeypatch.setattr(mesher, "FLAT", 1.0)
    with pytest.raises(RuntimeError, match=r"holds a flat tetrahedron \(scaled Jacobian 0\.\d+"):
        mesher.mesh_surface(MPI.COMM_SELF, Surface.of(*refined_box_surface(3)),
                            cube_sizes(0.3), {"soil": 1}, {f"face{k}": k for k in range(1, 7)},
                            tmp_path / "flat.msh", 0.99)
    assert not (tmp_path / "flat.msh").exists()


def test_a_mesh_adapt_mesh_below_half_min_quality_has_its_nodes_moved(tmp_path, monkeypatch):
    """On the cube Delaunay's least scaled Jacobian is 0.27 and MeshAdapt's 0.285: asked for
    0.6, MeshAdapt's mesh (below 0.3, where the re-equilibration's first solution would be
    refused) is smoothed above it, the soil's shape kept; where moving nodes cannot lift it,
    the remesh fails with that message (the clay's 0.5-in run stopped on four such meshes)."""
    from mpi4py import MPI
    from soilbin.problem.mesh_quality import simplex_quality
    from soilbin.remesh import mesher
    surface, groups = Surface.of(*refined_box_surface(3)), {f"face{k}": k for k in range(1, 7)}
    mesher.mesh_surface(MPI.COMM_SELF, surface, cube_sizes(0.3), {"soil": 1}, groups,
                        tmp_path / "lifted.msh", 0.6)
    mesh = meshio.read(tmp_path / "lifted.msh")
    corners = mesh.points[mesh.cells_dict["tetra"]]
    assert simplex_quality(corners).min() > 0.3
    assert np.abs(np.linalg.det(corners[:, 1:] - corners[:, :1])).sum() / 6.0 == pytest.approx(
        np.prod(np.ptp(mesh.points, axis=0)), rel=1e-12)
    monkeypatch.setattr(mesher, "smoothed", lambda points, cells, *_: (
        points, simplex_quality(points[cells]).min()))
    with pytest.raises(RuntimeError, match="however its nodes move, below half"):
        mesher.mesh_surface(MPI.COMM_SELF, surface, cube_sizes(0.3), {"soil": 1}, groups,
                            tmp_path / "not-lifted.msh", 0.6)


def test_the_fine_cells_at_a_tool_go_with_it(tmp_path):
    """A bar of tetrahedra built fine at the tool (x < 1) and coarse beyond, the tool moved 2
    along x: a cell takes the least of the size built where its soil started and the size
    built at the place that lay where the cell now lies relative to the tool."""
    from soilbin.remesh.remesher import Remeshing
    kuhn = [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]]
    unit = np.array([[i & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], dtype=float)
    edges = np.array([0.0, 0.25, 0.5, 0.75, 1.0, 2.0, 3.0, 4.0])
    corners = np.concatenate([unit[kuhn] * [b - a, 1.0, 1.0] + [a, 0.0, 0.0]
                              for a, b in zip(edges[:-1], edges[1:])])
    state = {"kinematics/mesh_x": (None, corners.copy()),
             "kinematics/total_displacement": (None, np.zeros_like(corners))}
    remeshing = Remeshing(load_scene(SCENES / "block-drucker-prager.toml", BLOCK_3D), tmp_path)
    _, sizes = remeshing._mesher_input(state, Surface.of(*box_surface(np.arange(1, 7))), True,
                                       3, np.array([2.0, 0.0, 0.0]))
    size = sizes.values[:, 0]
    centre = corners.mean(axis=1)[:, 0]
    fine, coarse = size[centre < 0.25].max(), size[centre > 3.0].min()
    assert fine == pytest.approx(np.cbrt(6.0 * np.sqrt(2.0) * 0.25 / 6.0), rel=1e-6)
    assert coarse == pytest.approx(np.cbrt(6.0 * np.sqrt(2.0) / 6.0), rel=1e-6)
    assert np.allclose(size[centre < 1.0], fine)                 # its own: x - 2 is no soil
    now_at_tool = (centre > 2.0) & (centre < 3.0)
    assert now_at_tool.sum() == 6 and np.allclose(size[now_at_tool], fine)
    assert np.allclose(size[centre > 3.0], coarse)               # x - 2 was coarse as well


def test_a_remeshed_homogeneous_block_keeps_its_state_exactly_in_3d(tmp_path):
    """The Drucker–Prager block in uniaxial compression on tetrahedra, in large deformation,
    remeshed twice: a uniform state is moved over exactly (no Newton iteration to
    re-equilibrate), and the block carries its collapse stress 2c cos φ / (1 − sin φ) to the
    end."""
    scene = load_scene(SCENES / "block-drucker-prager.toml", BLOCK_3D)
    summary = run_scene(scene, tmp_path)
    assert summary["status"] == "complete" and summary["remeshes"] == 2
    with open(tmp_path / "remeshes.csv") as f:
        reports = list(csv.DictReader(f))
    for report in reports:
        assert float(report["residual_transferred"]) < 1e-12
        assert int(report["newton_iterations"]) == 0
        for force in ("force_transferred", "force_after"):
            assert float(report[force]) == pytest.approx(float(report["force_before"]),
                                                         rel=1e-12)
        assert abs(float(report["volume_change"])) < 1e-8            # the grid's rounding
        assert abs(float(report["plastic_work_change"])) < 1e-8
        assert int(report["cells_after"]) > 0
    assert summary["collapse_stress"] == pytest.approx(2 * 500.0 * np.cos(np.radians(30.0))
                                                       / (1 - np.sin(np.radians(30.0))), rel=1e-9)
    files = sorted((tmp_path / "meshes").iterdir())
    assert all(set(meshio.read(name).cells_dict) == {"tetra", "triangle"} for name in files)


def test_one_point_per_cell_is_transferred_as_its_cell_value():
    """A reduced rule (one Gauss point) fits no gradient: a new point takes its cell's value."""
    corners = distorted_quadrilaterals()
    old = OldCells(corners, simplex=False)
    samples = corners.mean(axis=1, keepdims=True)
    values = np.arange(len(corners), dtype=float)[:, None, None] * np.ones((1, 1, 2))
    targets = np.einsum("k,nkd->nd", [0.1, 0.2, 0.3, 0.4], corners)   # one inside each cell
    moved = old.at_points(samples, old.locate(targets))(values)
    assert np.array_equal(moved, values[:, 0])


def test_the_outline_is_one_counter_clockwise_polygon_cut_where_its_group_changes():
    square = np.array([[0, 0], [1, 0], [2, 0], [2, 1], [1, 1], [0, 1]], dtype=float)
    edges = np.stack([square, np.roll(square, -1, axis=0)], axis=1)
    tags = np.array([5, 5, 6, 7, 7, 8])
    order = np.random.default_rng(0).permutation(6)
    edges = edges[order]
    edges[::2] = edges[::2, ::-1]   # some edges the other way round
    outline = chain(edges, tags[order])
    x, z = outline.vertices.T
    assert 0.5 * (np.dot(x, np.roll(z, -1)) - np.dot(np.roll(x, -1), z)) == pytest.approx(2.0)
    runs = outline.runs()
    assert sorted(tag for tag, _, _ in runs) == [5, 6, 7, 8]
    assert sum(last - first for _, first, last in runs) == 6
    for tag, first, last in runs:   # each run's edges lie on its side of the rectangle
        assert (outline.tags[first:last] == tag).all()


def test_resampling_keeps_the_corners_and_the_area_of_a_straight_sided_outline():
    square = np.array([[0, 0], [1, 0], [2, 0], [2, 1], [1, 1], [0, 1]], dtype=float)
    edges = np.stack([square, np.roll(square, -1, axis=0)], axis=1)
    outline = chain(edges, np.array([5, 5, 6, 7, 7, 8]))
    fine = outline.resampled(np.full(6, 0.1))
    assert len(fine.vertices) == 60
    for corner in ([0, 0], [2, 0], [2, 1], [0, 1]):
        assert np.isclose(fine.vertices, corner).all(axis=1).any()
    x, z = fine.vertices.T
    assert 0.5 * (np.dot(x, np.roll(z, -1)) - np.dot(np.roll(x, -1), z)) == pytest.approx(2.0)
    coarse = outline.resampled(np.full(6, 10.0))   # a vertex kept at every corner
    assert len(coarse.vertices) == 4


@pytest.mark.parametrize("element", [
    "quad4-bbar", pytest.param("tri6-bbar", marks=pytest.mark.slow)])
def test_a_remeshed_footing_comes_back_to_equilibrium_with_its_state(tmp_path, element):
    scene = load_scene(SCENES / "strip-footing-penetration.toml",
                       [*FOOTING, f"analysis.element={element}"])
    summary = run_scene(scene, tmp_path)
    assert summary["status"] == "complete" and summary["remeshes"] >= 2
    with open(tmp_path / "remeshes.csv") as f:
        reports = list(csv.DictReader(f))
    assert len(reports) == summary["remeshes"]
    for report in reports:
        assert float(report["residual_transferred"]) < 0.1          # of the force scale
        assert float(report["residual_equilibrated"]) <= 1e-6        # the scene's floor
        assert abs(float(report["volume_change"])) < 1e-4
        assert abs(float(report["plastic_strain_change"])) < 0.02
        assert abs(float(report["plastic_work_change"])) < 0.02
        assert float(report["quality_after"]) > 0.5                  # a good mesh again
        assert float(report["force_after"]) == pytest.approx(float(report["force_before"]),
                                                            rel=0.03)
    pressures = [row["pressure"] for row in curve(tmp_path)]
    assert 80.0 < pressures[-1] < 100.0   # near (2 + pi) c = 89.98 at 3% of B


def test_a_re_equilibration_that_fails_goes_in_stages_to_the_same_equilibrium(tmp_path,
                                                                             monkeypatch):
    """Where Newton from the transferred state fails, the transfer's out-of-balance is
    released in stages from the same committed history: the same equilibrium."""
    from soilbin.remesh import remesher
    scene = load_scene(SCENES / "strip-footing-penetration.toml", FOOTING)
    run_scene(scene, tmp_path / "direct")
    equilibrated = remesher._equilibrated

    def failing_first(problem):
        solve = problem.solve

        def fails_once():
            problem.solve = solve
            raise ConvergenceError("a test's failure")
        problem.solve = fails_once
        return equilibrated(problem)
    monkeypatch.setattr(remesher, "_equilibrated", failing_first)
    run_scene(scene, tmp_path / "staged")
    reports = []
    for run in ("direct", "staged"):
        with open(tmp_path / run / "remeshes.csv") as f:
            reports.append(list(csv.DictReader(f)))
    assert len(reports[0]) == len(reports[1]) >= 2
    for direct, staged in zip(*reports):
        assert int(staged["newton_iterations"]) >= remesher.RELEASE_STAGES
        assert float(staged["residual_equilibrated"]) <= 1e-6
        assert float(staged["residual_transferred"]) == pytest.approx(
            float(direct["residual_transferred"]), rel=1e-6)
        assert float(staged["force_after"]) == pytest.approx(float(direct["force_after"]),
                                                             rel=1e-6)
    for mine, theirs in zip(curve(tmp_path / "staged"), curve(tmp_path / "direct")):
        assert mine["force"] == pytest.approx(theirs["force"], rel=1e-5)


def test_a_re_equilibration_failing_in_stages_is_tried_again_on_a_floored_matrix(tmp_path,
                                                                                monkeypatch):
    """Where Newton fails from the transferred state and in stages too, both are tried again
    with Newton's matrix floored at EQUILIBRIUM_FLOOR of the elastic stiffness: the same
    equilibrium (the floor leaves the residual alone), and the scene's floor after it."""
    from soilbin.remesh import remesher
    scene = load_scene(SCENES / "strip-footing-penetration.toml", FOOTING)
    run_scene(scene, tmp_path / "direct")
    equilibrated = remesher._equilibrated
    floors = []

    def floored_only(problem):
        solve = problem.solve

        def solve_if_floored():
            floors.append(problem.points.tangent_floor)
            if problem.points.tangent_floor < remesher.EQUILIBRIUM_FLOOR:
                raise ConvergenceError("a test's failure")
            return solve()
        problem.solve = solve_if_floored
        try:
            return equilibrated(problem)
        finally:
            problem.solve = solve
            assert problem.points.tangent_floor == 0.0
    monkeypatch.setattr(remesher, "_equilibrated", floored_only)
    run_scene(scene, tmp_path / "floored")
    assert floors[:3] == [0.0, 0.0, remesher.EQUILIBRIUM_FLOOR]   # direct, a stage, floored
    reports = []
    for run in ("direct", "floored"):
        with open(tmp_path / run / "remeshes.csv") as f:
            reports.append(list(csv.DictReader(f)))
    # the first remesh's equilibrium and the step after it; then the floored tangent that step
    # started from took other iterations, and the step rule other steps
    direct, floored = (report[0] for report in reports)
    assert float(floored["residual_equilibrated"]) <= 1e-6
    assert float(floored["force_after"]) == pytest.approx(float(direct["force_after"]), rel=1e-6)
    after = int(direct["step"]) + 1
    for mine, theirs in zip(curve(tmp_path / "floored")[:after], curve(tmp_path / "direct")[:after]):
        assert mine["load_factor"] == theirs["load_factor"]
        assert mine["force"] == pytest.approx(theirs["force"], rel=1e-5)


def test_a_remeshed_soil_against_a_rough_wall_keeps_its_contact(tmp_path):
    """The rough wall pushed 0.05 in into Drucker–Prager sand in large deformation, remeshed
    every 3 steps: the interface's state moves with the soil (the tool's normals, the slip,
    the jump at rest), the soil comes back to equilibrium, and the passive force at the end
    is that of the run that never remeshed to 1%."""
    never = run_scene(load_scene(SCENES / "retaining-wall-passive-rough.toml", WALL[:-1]),
                      tmp_path / "never")
    summary = run_scene(load_scene(SCENES / "retaining-wall-passive-rough.toml", WALL),
                        tmp_path / "remeshed")
    assert summary["status"] == "complete" and summary["remeshes"] == 2
    with open(tmp_path / "remeshed" / "remeshes.csv") as f:
        for report in csv.DictReader(f):
            assert float(report["residual_equilibrated"]) <= 1e-6
            assert float(report["force_after"]) == pytest.approx(float(report["force_before"]),
                                                                rel=0.04)
    assert summary["passive_coefficient"] == pytest.approx(never["passive_coefficient"],
                                                           rel=0.01)


def the_same_mesh(monkeypatch):
    """Make the remesher "remesh" a three-dimensional soil onto its own mesh as it stands:
    the state's transfer alone, without a new discretisation."""
    from soilbin.remesh import remesher
    from soilbin.remesh.mesher import mesh_cells
    old = {}
    transferred = remesher.Remeshing._transferred

    def keeping_the_old_mesh(self, problem, step, smooth):
        old["tagged"] = problem.tagged
        return transferred(self, problem, step, smooth)

    def same_mesh(comm, surface, sizes, regions, boundaries, path, min_quality):
        mesh, facets = old["tagged"].mesh, old["tagged"].facet_tags
        triangles = entities_to_geometry(mesh._mesh, 2, facets.indices, False)[:, :3]
        return mesh_cells(comm, mesh.geometry.x, mesh.geometry.dofmap.array.reshape(-1, 4),
                          triangles, facets.values, regions, boundaries, path)
    monkeypatch.setattr(remesher.Remeshing, "_transferred", keeping_the_old_mesh)
    monkeypatch.setattr(remesher, "mesh_surface", same_mesh)


@pytest.mark.slow
def test_remeshing_onto_the_same_mesh_changes_nothing(tmp_path, monkeypatch):
    """The tine from a STEP file in large deformation (tet10, modified cap, the tool's
    interface), "remeshed" onto its own mesh after each of its two steps: the stress and
    history at the points and the contact state move over unchanged (to the fit's round-off
    and the grid of the remesher's rounding), so the soil stays in equilibrium and the draft
    is the same: what a real remesh changes (5-15% of the draft on this mesh) is the new
    mesh's."""
    the_same_mesh(monkeypatch)
    scene = load_scene(SCENES / "tine-2in-cad.toml", [
        "analysis.element=tet10", "analysis.large_deformation=true",
        "loading.control=displacement", "loading.magnitude=0.002", "loading.steps=2",
        "loading.first_cuts=0", "loading.max_cuts=0", "loading.until_collapse=false",
        "output.at=[]", "output.fields=[]", "mesh.element_size=1.5", "mesh.growth=1.8",
        "remesh.every=1"])
    summary = run_scene(scene, tmp_path)
    assert summary["status"] == "complete" and summary["remeshes"] == 2
    with open(tmp_path / "remeshes.csv") as f:
        for report in csv.DictReader(f):
            assert int(report["cells_after"]) == int(report["cells_before"])
            assert float(report["residual_transferred"]) < 1e-5        # of the force scale
            assert int(report["newton_iterations"]) <= 2
            assert float(report["force_after"]) == pytest.approx(float(report["force_before"]),
                                                                rel=1e-3)


def test_a_problem_a_remesh_replaced_frees_its_matrix_and_factors(tmp_path, monkeypatch):
    """Python's collection left a replaced problem's matrix and MUMPS's factors in memory (90
    MB a remesh on the tine's 1-in mesh); the run destroys them, and the problem it goes on
    with keeps its own. Each problem also left two options in PETSc's database, which is
    full at 512 (the clay's 0.35-in mesh stopped so after some 250 remeshes)."""
    from soilbin.remesh.remesher import Remeshing
    problems = []
    remesh = Remeshing.remesh

    def recorded(self, problem, record):
        problems.append(remesh(self, problem, record))
        return problems[-1]
    monkeypatch.setattr(Remeshing, "remesh", recorded)
    summary = run_scene(load_scene(SCENES / "strip-footing-penetration.toml", FOOTING), tmp_path)
    assert summary["remeshes"] == len(problems) >= 2

    def handles(problem):
        return problem.newton.matrix.handle, problem.newton.linear._lu.handle
    assert all(handle == 0 for problem in problems[:-1] for handle in handles(problem))
    assert all(handle != 0 for handle in handles(problems[-1]))
    # nor do its mean-pressure projections leave options in PETSc's database (512 at most)
    from petsc4py import PETSc
    assert not [key for key in PETSc.Options().getAll() if key.startswith("dolfinx_solve_")]


def test_each_mesh_is_a_grid_of_fields_xdmf_and_a_gmsh_file(tmp_path):
    summary = run_scene(load_scene(SCENES / "strip-footing-penetration.toml",
                                   [*FOOTING, "output.every=1"]), tmp_path)
    grids = ElementTree.parse(tmp_path / "fields.xdmf").getroot().iter("Grid")
    meshes = set()
    for grid in grids:
        if grid.get("GridType") != "Uniform":
            continue
        points = grid.find("Geometry/DataItem")
        displacement = grid.find("Attribute[@Name='displacement']/DataItem")
        assert points.get("Dimensions") == displacement.get("Dimensions")
        meshes.add(points.text)
    assert len(meshes) == summary["remeshes"] + 1
    files = sorted((tmp_path / "meshes").iterdir())
    assert len(files) == summary["remeshes"]
    assert all(set(meshio.read(name).cells_dict) == {"quad", "line"} for name in files)


@pytest.mark.parametrize("name, overrides, step", [
    ("strip-footing-penetration", FOOTING, 4),
    ("block-drucker-prager", BLOCK_3D, 5),
    # a tool's contact state; the soil risen above its ground level (no in-situ check)
    ("retaining-wall-passive-rough", WALL, 4)])
def test_a_run_stopped_after_a_remesh_resumes_on_the_new_mesh(tmp_path, name, overrides, step):
    (whole, whole_curve), (resumed, resumed_curve) = stop_and_resume(
        tmp_path, name, overrides, step)
    assert resumed["status"] == whole["status"] == "complete"
    assert resumed["remeshes"] == whole["remeshes"]
    assert resumed["newton_iterations"] == whole["newton_iterations"]
    for mine, theirs in zip(resumed_curve, whole_curve):
        assert mine == pytest.approx(theirs, rel=1e-12, abs=1e-14)


@pytest.mark.parametrize("overrides, words", [
    (["analysis.large_deformation=false"], "needs analysis.large_deformation = true"),
    (["mesh.dimension=3", "analysis.element=hex8-bbar"], "or tetrahedra"),
    (["remesh.min_quality=1.5"], "remesh.min_quality"),
])
def test_remeshing_a_scene_it_cannot_is_refused_on_reading(overrides, words):
    with pytest.raises(InputError, match=words):
        load_scene(SCENES / "strip-footing-penetration.toml", overrides)


def test_a_surface_gmsh_cannot_map_ends_the_run_with_its_steps_on_disk(tmp_path, monkeypatch):
    """gmsh's own error while mapping the patches (a bare Exception: the tine's soil after 4 in
    of travel) is a failed remesh, not an internal error: status failed, steps on disk."""
    def unmappable(dim_tags=()):
        raise Exception("Wrong topology of boundary mesh for parametrization")
    monkeypatch.setattr(gmsh.model.mesh, "createGeometry", unmappable)
    summary = run_scene(load_scene(SCENES / "block-drucker-prager.toml",
                                   BLOCK_3D + ("remesh.retries=0",)), tmp_path)
    assert summary["status"] == "failed" and summary["n_steps"] == 4
    assert "remeshing after step 4 failed: gmsh cannot map" in summary["message"]
    assert "Wrong topology" in summary["message"]
    assert len(curve(tmp_path)) == 4


def test_a_remesh_that_fails_again_after_the_retries_ends_the_run_with_its_steps_on_disk(
        tmp_path, monkeypatch, capsys):
    """gmsh failing on the deformed soil after step 3 and again after step 4, with
    ``remesh.retries = 1``: the run goes on on the old mesh once, then stops: status failed,
    the message says where, every converged step and the last good mesh's checkpoint stay."""
    from soilbin.remesh import remesher

    def failing(*args, **kwargs):
        raise RuntimeError("gmsh cannot mesh the deformed soil (a test's failure)")
    monkeypatch.setattr(remesher, "mesh_outline", failing)
    summary = run_scene(load_scene(SCENES / "strip-footing-penetration.toml",
                                   FOOTING + ("remesh.retries=1",)), tmp_path)
    assert summary["status"] == "failed" and summary["n_steps"] == 4
    assert (summary["remeshes"], summary["remeshes_failed"]) == (0, 2)
    assert "remeshing after step 4 failed: gmsh cannot mesh" in summary["message"]
    assert "after step 3 failed: gmsh cannot mesh the deformed soil (a test's failure); the run " \
           "goes on on the old mesh" in capsys.readouterr().err
    assert len(curve(tmp_path)) == 4
    assert (tmp_path / "checkpoint" / "state.npz").exists()
    assert not (tmp_path / "remeshes.csv").exists()


def test_after_a_remesh_that_failed_the_run_goes_on_and_remeshes_after_the_next_step(
        tmp_path, monkeypatch):
    """The re-equilibration after the remesh of step 3 not converging: the run goes on on
    the old mesh, the mesh made after step 3 is not kept, and the next step's remesh works."""
    from soilbin.remesh import remesher
    equilibrated = remesher._equilibrated
    failed = []

    def first_fails(problem):
        if not failed:
            failed.append(True)
            raise ConvergenceError("a test's failure")
        return equilibrated(problem)
    monkeypatch.setattr(remesher, "_equilibrated", first_fails)
    summary = run_scene(load_scene(SCENES / "strip-footing-penetration.toml", FOOTING), tmp_path)
    assert summary["status"] == "complete" and summary["remeshes_failed"] == 1
    with open(tmp_path / "remeshes.csv") as f:
        steps = [int(row["step"]) for row in csv.DictReader(f)]
    assert steps[0] == 4 and len(steps) == summary["remeshes"]
    assert (sorted(p.name for p in (tmp_path / "meshes").iterdir())
            == [f"remesh-{step:04d}.msh" for step in steps])


@pytest.mark.parametrize("stray", [False, True])
def test_a_boundary_node_no_tetrahedron_has_is_counted(stray):
    """gmsh's mesh whose boundary triangles have a node no tetrahedron has is refused before
    DOLFINx reads it (its reader crashed the process on one): a tetrahedron and its faces,
    one face's corner moved to a node of its own where ``stray``."""
    from soilbin.remesh.mesher import boundary_nodes_outside
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("tetrahedron")
        volume = gmsh.model.addDiscreteEntity(3)
        surface = gmsh.model.addDiscreteEntity(2)
        corners = [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1]
        gmsh.model.mesh.addNodes(3, volume, [1, 2, 3, 4, 5], corners)
        gmsh.model.mesh.addElementsByType(volume, 4, [1], [1, 2, 3, 4])
        faces = [1, 3, 2, 1, 2, 4, 1, 4, 3, 2, 3, 5 if stray else 4]
        gmsh.model.mesh.addElementsByType(surface, 2, [2, 3, 4, 5], faces)
        assert boundary_nodes_outside() == (1 if stray else 0)
    finally:
        gmsh.finalize()
