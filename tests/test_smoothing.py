"""Mending a distorted tetrahedral mesh by moving its nodes before meshing it afresh
(:mod:`soilbin.remesh.smoothing`, ``remesh.smooth_first``)."""
import csv

import numpy as np
import pytest
from mpi4py import MPI

from conftest import SCENES, kuhn_cube, volume
from soilbin.app.run import run_scene
from soilbin.problem.mesh_quality import simplex_quality
from soilbin.records.scene import load_scene
from soilbin.remesh.mesher import Sizes, mesh_cells, read_mesh
from soilbin.remesh.remesher import FRESH, LOCAL, MOVED, SMOOTHED, Remeshing
from soilbin.remesh.smoothing import on_triangles, smoothed
from soilbin.remesh.surface import Surface

def least_quality(points, cells, orientation):
    return (orientation * simplex_quality(points[cells])).min()


def test_an_interior_node_pushed_toward_a_face_goes_back_to_the_centre():
    """The cube's centre pushed to z = 0.1 flattens the tetrahedra below it to under a third
    of the undistorted cube's least quality; smoothing lifts it to 0.8 of it, and the cube
    keeps its shape and volume."""
    points, cells, triangles, tags = kuhn_cube()
    orientation = np.sign(simplex_quality(points[cells]))
    best = least_quality(points, cells, orientation)
    centre = np.flatnonzero((points == 0.5).all(axis=1))[0]
    distorted = points.copy()
    distorted[centre] = [0.5, 0.5, 0.1]
    assert least_quality(distorted, cells, orientation) < 0.3 * best
    moved, least = smoothed(distorted, cells, triangles, tags, 0.8 * best)
    assert least >= 0.8 * best
    assert least == pytest.approx(least_quality(moved, cells, orientation), rel=1e-14)
    faces = np.unique(triangles)
    assert (np.isin(moved[faces], [0.0, 1.0]).sum(axis=1) >= 1).all()   # still on a face
    assert volume(moved, cells) == pytest.approx(1.0, rel=1e-12)


def test_a_node_in_a_flat_face_slides_in_it_and_the_edges_stay():
    """The centre of the cube's face z = 0 pushed along it to y = 0.9: smoothing slides it
    back within the face (z stays 0 to the bit), the cube's edges and corners stay, and
    the cube's volume is unchanged."""
    points, cells, triangles, tags = kuhn_cube()
    orientation = np.sign(simplex_quality(points[cells]))
    best = least_quality(points, cells, orientation)
    face_centre = np.flatnonzero((points == [0.5, 0.5, 0.0]).all(axis=1))[0]
    distorted = points.copy()
    distorted[face_centre] = [0.5, 0.9, 0.0]
    assert least_quality(distorted, cells, orientation) < 0.3 * best
    moved, least = smoothed(distorted, cells, triangles, tags, 0.8 * best)
    assert least >= 0.8 * best
    assert moved[face_centre, 2] == 0.0
    on_edges = (np.isin(points, [0.0, 1.0]).sum(axis=1) >= 2)   # two coordinates on a face
    assert np.array_equal(moved[on_edges], points[on_edges])
    assert volume(moved, cells) == pytest.approx(1.0, rel=1e-12)


def test_a_node_where_two_groups_meet_stays_even_if_its_cells_stay_bad():
    """The middle of the cube's edge y = z = 0 pulled into the cube leaves its cells bad; two
    groups meet there, so it stays (the soil's shape and its groups' borders are kept), and
    the least quality is reported as it is."""
    points, cells, triangles, tags = kuhn_cube()
    orientation = np.sign(simplex_quality(points[cells]))
    edge_middle = np.flatnonzero((points == [0.5, 0.0, 0.0]).all(axis=1))[0]
    assert len(np.unique(tags[(triangles == edge_middle).any(axis=1)])) == 2
    distorted = points.copy()
    distorted[edge_middle] = [0.5, 0.45, 0.45]
    moved, least = smoothed(distorted, cells, triangles, tags, 0.5)
    assert np.array_equal(moved[edge_middle], distorted[edge_middle])
    assert least < 0.5
    assert least == pytest.approx(least_quality(moved, cells, orientation), rel=1e-14)


def test_a_point_is_projected_onto_the_triangle_under_it():
    triangles = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                          [[1.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.0, 1.0, 0.0]]])
    assert np.array_equal(on_triangles(np.array([0.2, 0.3, 0.5]), triangles), [0.2, 0.3, 0.0])
    assert on_triangles(np.array([2.0, 2.0, 0.0]), triangles[:1]) is None


def test_a_remesh_below_min_quality_keeps_the_cells_where_smoothing_mends_them(tmp_path):
    """The remesher's path (rank 0's gathered corners and surface): the distorted cube
    mended to SMOOTHED min_quality, its cells and facets kept and distributed as a mesh with
    the six facet groups; with min_quality above what moving nodes or meshing afresh around
    the poor cells can reach, None (the soil is meshed afresh)."""
    points, cells, triangles, tags = kuhn_cube()
    centre = np.flatnonzero((points == 0.5).all(axis=1))[0]
    points[centre] = [0.5, 0.5, 0.1]
    state = {"kinematics/mesh_x": (None, points[cells])}
    surface = Surface.of(points[triangles], tags)
    scene = load_scene(SCENES / "block-drucker-prager.toml",
                       ["analysis.element=tet10", "analysis.large_deformation=true",
                        "remesh.min_quality=0.3"])
    sizes = Sizes(points[cells], np.full(cells.shape, 0.5))
    (moved, kept_cells, kept_triangles, kept_tags), how = Remeshing(scene, tmp_path)._mended(
        state, surface, sizes)
    assert how == MOVED
    assert np.array_equal(kept_cells, cells)             # the nodes numbered as they sort
    assert moved[centre, 2] > 0.2 and volume(moved, cells) == pytest.approx(1.0, rel=1e-12)
    orientation = np.sign(simplex_quality(points[cells]))
    assert least_quality(moved, cells, orientation) >= SMOOTHED * 0.3
    assert np.array_equal(np.sort(np.sort(kept_triangles, axis=1), axis=0),
                          np.sort(np.sort(triangles, axis=1), axis=0))
    boundaries = {f"face{k}": k for k in range(1, 7)}
    tagged = mesh_cells(MPI.COMM_SELF, moved, kept_cells, kept_triangles, kept_tags,
                        {"soil": 7}, boundaries, tmp_path / "smoothed.msh")
    assert tagged.mesh.topology.index_map(3).size_local == 48
    assert sorted(np.bincount(tagged.facet_tags.values)[1:].tolist()) == [8] * 6
    again = read_mesh(MPI.COMM_SELF, tmp_path / "smoothed.msh", {"soil": 7}, boundaries, 3)
    assert np.array_equal(np.sort(again.mesh.geometry.x, axis=0),
                          np.sort(tagged.mesh.geometry.x, axis=0))    # what --resume reads
    assert np.array_equal(np.bincount(again.facet_tags.values),
                          np.bincount(tagged.facet_tags.values))
    strict = load_scene(SCENES / "block-drucker-prager.toml",
                        ["analysis.element=tet10", "analysis.large_deformation=true",
                         "remesh.min_quality=0.9"])
    assert Remeshing(strict, tmp_path)._mended(state, surface, sizes) == (None, FRESH)


@pytest.mark.slow
def test_a_tine_s_soil_below_min_quality_is_smoothed_and_loses_less_draft(tmp_path):
    """The coarse tine from a STEP file in large deformation: its first step leaves the least
    scaled Jacobian at 0.046, below min_quality = 0.05. Smoothing keeps the cells and lifts
    it above 1.15 min_quality; the draft the remesh takes off is less than half what a fresh
    mesh of the same soil takes (5.5% against 24.6%). Without smoothing, the soil meshed
    afresh around its poor cells alone (``remesh.local_first``) loses less than a fresh mesh
    (11.4%)."""
    overrides = ["analysis.element=tet10", "analysis.large_deformation=true",
                 "loading.control=displacement", "loading.magnitude=0.002", "loading.steps=2",
                 "loading.first_cuts=0", "loading.max_cuts=0", "loading.until_collapse=false",
                 "output.at=[]", "output.fields=[]", "mesh.element_size=1.5",
                 "mesh.growth=1.8", "remesh.min_quality=0.05"]
    lost = {}
    for how, smooth, local in ((MOVED, "true", "false"), (LOCAL, "false", "true"),
                               (FRESH, "false", "false")):
        folder = tmp_path / how
        scene = load_scene(SCENES / "tine-2in-cad.toml", overrides + [
            f"remesh.smooth_first={smooth}", f"remesh.local_first={local}"])
        assert run_scene(scene, folder)["status"] == "complete"
        with open(folder / "remeshes.csv") as f:
            first = next(csv.DictReader(f))
        assert int(first["step"]) == 1
        assert (int(first["smoothed"]), int(first["local"])) == (how == MOVED, how == LOCAL)
        assert (first["cells_after"] == first["cells_before"]) == (how == MOVED)
        if how != FRESH:
            assert float(first["quality_after"]) >= SMOOTHED * 0.05
        if how == MOVED:
            assert abs(float(first["volume_change"])) < 1e-6
        lost[how] = 1.0 - float(first["force_after"]) / float(first["force_before"])
    assert 0.0 < lost[MOVED] < 0.5 * lost[FRESH]
    assert 0.0 < lost[LOCAL] < 0.6 * lost[FRESH]
