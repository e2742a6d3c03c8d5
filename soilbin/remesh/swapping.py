"""Tetrahedra below a target reconnected by face and edge swaps, where moving nodes cannot
mend them (a cell whose four nodes all sit where facet groups meet: :mod:`.smoothing`).

Two swaps, each replacing the tetrahedra around an interior face or edge by others over the
same polyhedron (Freitag & Ollivier-Gooch 1997, "Tetrahedral mesh improvement using swapping
and smoothing", IJNME 40, 3979-4002; Shewchuk 2002, "Two discrete optimization algorithms for
the topological improvement of tetrahedral meshes"):

- the 2-3 face swap: the two tetrahedra on an interior face (a, b, c) with apexes d and e
  become the three around the edge d-e;
- edge removal: the n tetrahedra around an interior edge d-e (3 <= n <= :data:`MAX_RING`)
  become the 2(n - 2) joining d and e to each triangle of the best triangulation of the ring
  of their other nodes (3-2 for n = 3).

A new set is valid where its tetrahedra fill the old polyhedron once: the sum of their
absolute volumes is the old one's (an inverted or overlapping tetrahedron adds to it). A swap is
taken where it raises the least scaled Jacobian of the cells it replaces (by more
than :data:`GAIN` of it); the boundary's
triangles are never touched, so that every facet group holds on the new cells.
"""
import functools
import itertools

import numpy as np

from ..problem.mesh_quality import simplex_quality

#: The most tetrahedra around an edge that edge removal tries (42 triangulations of 7 nodes).
MAX_RING = 7
#: Passes over the cells below the target, at most (each applies disjoint swaps).
PASSES = 10
#: The share of the old polyhedron's volume its new tetrahedra may differ by (rounding).
VOLUME_RTOL = 1e-9
#: The least share by which a swap must raise the least quality (not rounding's churn).
GAIN = 1e-6

#: A tetrahedron's six edges and its four faces (face k opposite node k).
EDGES = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))
FACES = ((1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2))


def swapped(x, cells, target):
    """(the ``cells`` (m, 4) on the points ``x`` (n, 3) with faces and edges of those below
    ``target`` swapped (module doc), how many swaps). Each new cell takes the orientation of
    the cells it replaces."""
    cells = np.array(cells)
    done = 0
    for _ in range(PASSES):
        quality = simplex_quality(x[cells])
        orientation = np.sign(quality)
        quality *= orientation
        incident = incidence(cells, len(x))
        candidates = []
        for cell in np.flatnonzero(quality < target):
            best = _best_swap(x, cells, cell, incident, quality)
            if best is not None:
                candidates.append(best)
        candidates.sort(key=lambda c: c[0] - quality[c[1]].min(), reverse=True)
        used = np.zeros(len(cells), dtype=bool)
        removed, added = [], []
        for _, old, new in candidates:
            if used[old].any():
                continue
            used[old] = True
            removed.extend(old)
            added.append(_oriented(x, new, orientation[old[0]]))
        if not added:
            break
        done += len(added)
        cells = np.concatenate([np.delete(cells, removed, axis=0), *added])
    return cells, done


def _best_swap(x, cells, cell, incident, quality):
    """(least quality of the new cells, the cells replaced, the new cells) of the best swap
    of a face or an edge of ``cell`` that raises the least quality of those it replaces;
    None if there is none."""
    nodes = cells[cell]
    best = None
    options = [_face_swap(x, cells, cell, [nodes[k] for k in face], incident)
               for face in FACES]
    options += [_edge_removal(x, cells, nodes[i], nodes[j], incident) for i, j in EDGES]
    for option in options:
        if option is None:
            continue
        least, old, new = option
        if least > (1.0 + GAIN) * quality[old].min() and (best is None or least > best[0]):
            best = option
    return best


def _face_swap(x, cells, cell, face, incident):
    """The 2-3 swap of ``face`` (three nodes) of ``cell``: (least quality, the two cells, the
    three new ones); None on the boundary or where the three do not fill the two."""
    sharing = functools.reduce(np.intersect1d, (incident[node] for node in face))
    if len(sharing) != 2:
        return None
    d = np.setdiff1d(cells[sharing[0]], face)[0]
    e = np.setdiff1d(cells[sharing[1]], face)[0]
    a, b, c = face
    new = np.array([[a, b, d, e], [b, c, d, e], [c, a, d, e]])
    return _filled(x, cells[sharing], new, sharing)


def _edge_removal(x, cells, d, e, incident):
    """Edge removal of the edge d-e: (least quality, the cells around it, the new ones) of the
    best triangulation of its ring; None on the boundary (an open ring), for more than
    :data:`MAX_RING` cells, or where no triangulation fills them."""
    around = np.intersect1d(incident[d], incident[e])
    if not 3 <= len(around) <= MAX_RING:
        return None
    ring = _ring([np.setdiff1d(cells[c], (d, e)) for c in around])
    if ring is None:
        return None
    best = None
    for triangles in triangulations(len(ring)):
        corners = ring[np.array(triangles)]
        new = np.concatenate([np.column_stack([corners, np.full(len(corners), d)]),
                              np.column_stack([corners, np.full(len(corners), e)])])
        option = _filled(x, cells[around], new, around)
        if option is not None and (best is None or option[0] > best[0]):
            best = option
    return best


def _ring(pairs):
    """The nodes of the ``pairs`` (each the two other nodes of a cell around an edge) in
    their cyclic order; None unless they close one ring."""
    pairs = [tuple(int(v) for v in pair) for pair in pairs]
    ring = list(pairs[0])
    rest = pairs[1:]
    while rest:
        follow = [p for p in rest if ring[-1] in p]
        if len(follow) != 1:
            return None
        rest.remove(follow[0])
        ring.append(follow[0][1] if follow[0][0] == ring[-1] else follow[0][0])
    if ring[-1] != ring[0] or len(set(ring[:-1])) != len(pairs):
        return None
    return np.array(ring[:-1])


@functools.lru_cache(maxsize=None)
def triangulations(n):
    """Every triangulation of a polygon of ``n`` nodes 0..n-1, each a tuple of (i, j, k)."""
    def of(i, j):
        if j - i < 2:
            return [()]
        return [((i, k, j),) + left + right
                for k in range(i + 1, j) for left, right in itertools.product(of(i, k), of(k, j))]
    return tuple(of(0, n - 1))


def _filled(x, old_cells, new, old):
    """(least quality of ``new``, ``old``, ``new``) where the tetrahedra ``new`` fill the
    polyhedron of ``old_cells`` once (module doc), else None."""
    volume = np.abs(_volumes(x[old_cells])).sum()
    volumes = np.abs(_volumes(x[new]))
    if volumes.min() <= 0.0 or abs(volumes.sum() - volume) > VOLUME_RTOL * volume:
        return None
    return np.abs(simplex_quality(x[new])).min(), old, new


def _volumes(corners):
    """Six times the signed volumes of tetrahedra (k, 4, 3)."""
    return np.linalg.det(corners[:, 1:] - corners[:, :1])


def _oriented(x, new, sign):
    """The tetrahedra ``new`` with their first two nodes exchanged where their orientation is
    not ``sign``."""
    new = np.array(new)
    flip = np.sign(_volumes(x[new])) != sign
    new[flip, :2] = new[flip, 1::-1]
    return new


def incidence(cells, n):
    """The cells around each of the ``n`` nodes: a list of arrays."""
    order = np.argsort(cells.ravel(), kind="stable") // cells.shape[1]
    return np.split(order, np.cumsum(np.bincount(cells.ravel(), minlength=n))[:-1])
