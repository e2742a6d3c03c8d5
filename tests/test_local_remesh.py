"""Meshing a distorted tetrahedral mesh afresh around its poor cells alone
(:mod:`soilbin.remesh.local`, ``remesh.local_first``)."""
import numpy as np
import pytest

from conftest import kuhn_cube, volume
from soilbin.problem.mesh_quality import simplex_quality
from soilbin.remesh.local import FACES, remeshed_around
from soilbin.remesh.mesher import Sizes


def quality(points, cells):
    return np.abs(simplex_quality(points[cells]))


def rows(points, cells):
    """Each cell as the set of its corners' coordinates (a comparable key)."""
    return {tuple(sorted(map(tuple, points[cell]))) for cell in cells}


def remeshed_cube(points, cells, triangles, tags, target):
    """The Kuhn cube (distorted) meshed afresh around its cells below ``target``, checked:
    every cell above ``target``, conforming, its volume kept."""
    sizes = Sizes(points[cells], np.full(cells.shape, 0.25))
    new_points, new_cells, new_triangles, new_tags = remeshed_around(points, cells, triangles,
                                                                     tags, sizes, target)
    assert quality(new_points, new_cells).min() >= target
    check_mesh(new_points, new_cells, new_triangles)
    assert volume(new_points, new_cells) == pytest.approx(1.0, rel=1e-12)
    return new_points, new_cells, new_triangles, new_tags


def check_mesh(points, cells, triangles):
    """Each face of the cells joins two of them but the boundary triangles, each of which
    bounds one, turned outward (seen from its cell's fourth corner)."""
    faces = np.sort(cells[:, FACES].reshape(-1, 3), axis=1)
    unique, count = np.unique(faces, axis=0, return_counts=True)
    assert count.max() <= 2
    assert np.array_equal(unique[count == 1], np.unique(np.sort(triangles, axis=1), axis=0))
    a, b, c = (points[triangles[:, k]] for k in range(3))
    outward = np.cross(b - a, c - a)
    assert (np.einsum("ij,ij->i", outward, a - 0.5) > 0.0).all()   # the cube is convex


def test_an_interior_node_pushed_toward_a_face_is_meshed_afresh_around_it_alone():
    """The 4 x 4 x 4 Kuhn cube's node (0.5, 0.5, 0.5) pushed to z = 0.27 flattens the cells
    around it below the target; the cells around them are meshed afresh and lifted above
    it, the cells two layers away stay as they were, and the cube keeps its volume and its
    boundary."""
    points, cells, triangles, tags = kuhn_cube(4)
    best = quality(points, cells).min()
    centre = np.flatnonzero((points == 0.5).all(axis=1))[0]
    points[centre, 2] = 0.27
    target = 0.3 * best
    poor = quality(points, cells) < target
    assert poor.any()
    new_points, new_cells, new_triangles, new_tags = remeshed_cube(points, cells, triangles,
                                                                   tags, target)
    near = np.isin(cells, cells[np.isin(cells, cells[poor]).any(axis=1)]).any(axis=1)
    far = ~np.isin(cells, cells[near]).any(axis=1)
    assert rows(points, cells[far]) <= rows(new_points, new_cells)
    assert rows(points, triangles[:, [0, 1, 2, 0]]) == rows(new_points,
                                                            new_triangles[:, [0, 1, 2, 0]])
    assert np.array_equal(np.sort(new_tags), np.sort(tags))


def test_a_face_node_slid_toward_an_edge_has_its_face_meshed_afresh_around_it():
    """The node (0.5, 0.5, 0) of the cube's face z = 0 slid along it to (0.5, 0.06, 0) makes
    cells poor by their boundary triangles: the face's triangles around them are meshed
    afresh on the face, the new triangles in its group, and the cube keeps its shape."""
    points, cells, triangles, tags = kuhn_cube(4)
    best = quality(points, cells).min()
    node = np.flatnonzero((points == [0.5, 0.5, 0.0]).all(axis=1))[0]
    points[node] = [0.5, 0.06, 0.0]
    new_points, new_cells, new_triangles, new_tags = remeshed_cube(points, cells, triangles,
                                                                   tags, 0.3 * best)
    bottom = new_triangles[new_tags == 5]
    assert np.allclose(new_points[bottom][:, :, 2], 0.0)
    a, b, c = (new_points[bottom[:, k]] for k in range(3))
    assert np.linalg.norm(np.cross(b - a, c - a), axis=1).sum() / 2.0 == pytest.approx(1.0)
    assert not rows(points, triangles[tags == 5][:, [0, 1, 2, 0]]) <= rows(
        new_points, bottom[:, [0, 1, 2, 0]])


def test_a_cavity_that_cannot_reach_the_target_gives_none():
    """Asked for a quality no tetrahedron of the cube reaches, it gives up (the remesher
    then meshes the whole soil afresh)."""
    points, cells, triangles, tags = kuhn_cube(3)
    sizes = Sizes(points[cells], np.full(cells.shape, 0.3))
    assert remeshed_around(points, cells, triangles, tags, sizes, 1.01) is None


def test_gmsh_dying_on_a_cavity_fails_the_cavity_not_the_run(monkeypatch):
    """gmsh 4.8 once died of a bus error meshing a cavity of the clay's soil, and the run
    with it: a cavity is meshed in a child process, whose death gives no mesh (the remesher
    then grows the cavity or meshes the soil afresh), while the child's mesh is the one gmsh
    makes in this process and an error of the child's is raised here."""
    import os
    import signal
    from soilbin.remesh import mesher
    points, cells, triangles, tags = kuhn_cube(4)
    target = 0.3 * quality(points, cells).min()
    points[np.flatnonzero((points == 0.5).all(axis=1))[0], 2] = 0.27
    sizes = Sizes(points[cells], np.full(cells.shape, 0.25))
    calls = []

    def in_child(*args):
        calls.append((args, mesher.mesh_cavity(*args)))
        return calls[-1][1]
    monkeypatch.setattr("soilbin.remesh.local.mesh_cavity", in_child)
    assert remeshed_around(points, cells, triangles, tags, sizes, target) is not None
    args, child = calls[0]
    assert all(np.array_equal(a, b) for a, b in zip(child, mesher._cavity_tetrahedra(*args)))
    monkeypatch.setattr(mesher, "_cavity_tetrahedra",
                        lambda *args: os.kill(os.getpid(), signal.SIGBUS))
    assert remeshed_around(points, cells, triangles, tags, sizes, target) is None
    monkeypatch.setattr(mesher, "_cavity_tetrahedra", lambda *args: 1 / 0)   # a bug is one
    with pytest.raises(ZeroDivisionError):
        remeshed_around(points, cells, triangles, tags, sizes, target)


def test_a_fresh_patch_that_makes_a_triangle_as_it_was_bounds_the_mesh_once():
    """gmsh's fresh mesh of a cavity's patch can give back one of its old triangles: the
    merged mesh lists it once (twice, it was refused as not conforming and the soil was
    meshed afresh throughout)."""
    from soilbin.remesh.local import _conforming, _merged
    from soilbin.remesh.surface import Surface
    points, cells, triangles, tags = kuhn_cube(2)
    surface = Surface.of(points[triangles], tags)
    again = tags == 1    # the face x = 0 "meshed afresh" into its own triangles
    fresh = (points, cells, triangles[again], tags[again])
    new_points, new_cells, new_triangles, new_tags = _merged(
        points, cells[:0], triangles, tags, surface, np.ones(len(triangles), bool), fresh)
    assert len(new_triangles) == len(triangles)
    assert np.array_equal(np.bincount(new_tags), np.bincount(tags))
    assert _conforming(new_cells, new_triangles, len(new_points))
