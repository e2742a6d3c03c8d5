"""Face and edge swaps of tetrahedra below a target (:mod:`soilbin.remesh.swapping`)."""
import numpy as np
import pytest

from soilbin.problem.mesh_quality import simplex_quality
from soilbin.remesh.swapping import swapped, triangulations

#: Two apexes above and below a unit triangle's plane: the two tetrahedra on the triangle,
#: the three around the edge joining the apexes (the triangle's nodes 0, 1, 2, apexes 3, 4).
TWO = np.array([[0, 1, 2, 3], [0, 2, 1, 4]])
THREE = np.array([[0, 1, 3, 4], [1, 2, 3, 4], [2, 0, 3, 4]])


def bipyramid(height, apex=(0.1, 0.05)):
    """The triangle's three nodes on the unit circle and the apexes at (apex, height) and
    (0, 0, -height)."""
    angles = np.radians([90.0, 210.0, 330.0])
    ring = [[np.cos(t), np.sin(t), 0.0] for t in angles]
    return np.array(ring + [[*apex, height], [0.0, 0.0, -height]])


def least(x, cells):
    return np.abs(simplex_quality(x[cells])).min()


def volume(x, cells):
    return np.abs(np.linalg.det(x[cells][:, 1:] - x[cells][:, :1])).sum() / 6.0


def oriented(x, cells):
    return np.sign(simplex_quality(x[cells]))


def test_two_flat_tetrahedra_on_a_face_become_the_three_around_their_apexes_edge():
    """At height 0.3 the three around the apexes' edge are better (0.361) than the two on
    the face (0.319): the 2-3 swap, the volume kept, every cell in the old orientation."""
    x = bipyramid(0.3)
    assert least(x, THREE) > least(x, TWO)
    cells, swaps = swapped(x, TWO, 0.34)
    assert swaps == 1 and len(cells) == 3
    assert least(x, cells) == pytest.approx(least(x, THREE), rel=1e-14)
    assert volume(x, cells) == pytest.approx(volume(x, TWO), rel=1e-14)
    assert (oriented(x, cells) == oriented(x, TWO)[0]).all()


def test_three_needles_around_an_edge_become_two_tetrahedra_on_the_ring():
    """At height 1.5 the two on the ring's triangle are far better (0.937 against 0.335):
    the edge is removed (3-2)."""
    x = bipyramid(1.5)
    cells, swaps = swapped(x, THREE, 0.5)
    assert swaps == 1 and len(cells) == 2
    assert least(x, cells) == pytest.approx(least(x, TWO), rel=1e-14)
    assert volume(x, cells) == pytest.approx(volume(x, THREE), rel=1e-14)


def test_no_swap_where_the_new_tetrahedra_would_leave_the_old_polyhedron():
    """An apex beside the triangle (the apexes' edge passes outside it): the three around
    that edge overlap, so the two stay, even below the target."""
    x = bipyramid(0.3, apex=(1.5, 1.5))
    assert np.abs(volume(x, THREE) - volume(x, TWO)) > 1e-3
    cells, swaps = swapped(x, TWO, 0.99)
    assert swaps == 0 and np.array_equal(cells, TWO)


def test_cells_above_the_target_are_left_alone():
    x = bipyramid(0.3)
    cells, swaps = swapped(x, TWO, 0.3)
    assert swaps == 0 and np.array_equal(cells, TWO)


def test_a_ring_of_n_nodes_has_the_catalan_number_of_triangulations():
    assert [len(triangulations(n)) for n in range(3, 8)] == [1, 2, 5, 14, 42]
    for n in range(3, 8):
        for triangles in triangulations(n):
            assert len(triangles) == n - 2
            edges = {tuple(sorted(e)) for t in triangles for e in ((t[0], t[1]), (t[1], t[2]),
                                                                   (t[0], t[2]))}
            assert {(k, (k + 1) % n) if k + 1 < n else (0, n - 1) for k in range(n)} <= edges


def test_four_needles_around_an_edge_become_four_on_the_ring_s_shorter_diagonal():
    """An octahedron of four tetrahedra around its long axis (poles at z = +-2, the ring a
    rhombus of diagonals 2 and 2.6): edge removal triangulates the ring by its shorter
    diagonal, the least quality 0.345 -> 0.617; at z = +-1 the two ways are as good and
    nothing is swapped."""
    for height, swaps_expected in ((2.0, 1), (1.0, 0)):
        x = np.array([[1.0, 0.0, 0.0], [0.0, 1.3, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.3, 0.0],
                      [0.0, 0.0, height], [0.0, 0.0, -height]])
        four = np.array([[k, (k + 1) % 4, 4, 5] for k in range(4)])
        cells, swaps = swapped(x, four, 0.99)
        assert swaps == swaps_expected and len(cells) == 4
        if swaps:
            assert least(x, cells) > 1.7 * least(x, four)
            assert all(0 in cell and 2 in cell for cell in cells)   # the diagonal 0-2
            assert volume(x, cells) == pytest.approx(volume(x, four), rel=1e-14)
