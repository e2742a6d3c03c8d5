"""The deformed soil's tetrahedra meshed afresh around its poor cells alone, the rest kept.

Where moving nodes (:mod:`.smoothing`) does not mend a soil below ``remesh.min_quality``, a
fresh mesh of the whole soil moves every Gauss point's state onto other cells, and the
re-equilibration relaxes a share of the whole stress: 10-30% of the tine's draft (2-8% of an
elastic soil's force, docs/chapter8.md). Here only a cavity is meshed afresh: the cells below
the target and the cells that share a node with them, grown by such layers up to
:data:`LAYERS` times until the mesh reaches the target. The cavity's faces against the kept
cells stay as they are (the new cells meet the old conformingly); its faces on the soil's
boundary stay too, but for the patches that hold a face of a cell below the target, which
gmsh meshes afresh (a cell is often poor by its boundary triangle). gmsh's Delaunay
tetrahedra of a cavity leave slivers between its fixed nodes (0.014-0.02 around the tine's
blade), so the whole mesh is then smoothed as :mod:`.smoothing` smooths the old one. The kept
cells whose nodes did not move keep their Gauss points, where the transfer's cell-wise fit
gives back each value as it was.
"""
import numpy as np

from ..problem.mesh_quality import simplex_quality
from .mesher import mesh_cavity
from .outline import OutlineError
from .smoothing import smoothed
from .surface import Surface

#: Layers of neighbouring cells a cavity is grown by, at most (each tried in turn).
LAYERS = 3
#: A tetrahedron's faces, each opposite the vertex of its position.
FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
#: The least scaled Jacobian of a cavity's fresh mesh before it is smoothed.
CAVITY_QUALITY = 0.01
#: The tag of a cavity's faces against the kept cells.
INNER = -1


def remeshed_around(points, cells, triangles, tags, sizes, target):
    """(points, cells, triangles, tags) of the mesh with the cells of the ``points`` (n, 3)
    and ``cells`` (m, 4) near those below ``target`` meshed afresh (module doc), or None
    where no cavity of up to :data:`LAYERS` layers reaches ``target``; ``triangles`` (k, 3)
    and ``tags`` (k,) are the boundary's facets and their groups, ``sizes`` the
    :class:`~.mesher.Sizes` of the fresh cells."""
    quality = np.abs(simplex_quality(points[cells]))
    poor_faces = _keys(np.sort(cells[quality < target][:, FACES].reshape(-1, 3), axis=1),
                       len(points))
    boundary = _keys(np.sort(triangles, axis=1), len(points))
    cavity = quality < target
    for _ in range(LAYERS):
        cavity = np.isin(cells, cells[cavity]).any(axis=1)
        try:
            surface, keep, on_boundary = _cavity_surface(points, cells[cavity], triangles,
                                                         tags, boundary, poor_faces)
        except OutlineError:   # the cavity's boundary is not a closed 2-manifold
            continue
        fresh = mesh_cavity(surface, sizes, keep, CAVITY_QUALITY)
        if fresh is None:
            continue
        mesh = _merged(points, cells[~cavity], triangles, tags, surface, on_boundary, fresh)
        if not _conforming(*mesh[1:3], len(mesh[0])):
            continue
        moved, least = smoothed(*mesh, target)
        if least >= target:
            return (moved, *mesh[1:])
    return None


def _cavity_surface(points, cavity, triangles, tags, boundary, poor_faces):
    """(the :class:`~.surface.Surface` of the ``cavity``'s cells, outward, its faces on the
    soil's boundary in their groups and the others :data:`INNER`; the mask of its triangles
    that may stay; the mask of those on the soil's boundary); ``boundary`` and
    ``poor_faces``: the keys of the soil's boundary triangles and of the poor cells' faces."""
    n = len(points)
    faces = cavity[:, FACES].reshape(-1, 3)
    key = _keys(np.sort(faces, axis=1), n)
    unique, count = np.unique(key, return_counts=True)
    once = np.isin(key, unique[count == 1])
    inward = np.repeat(simplex_quality(points[cavity]) < 0.0, 4)[once]
    faces, key = faces[once], key[once]
    faces[inward] = faces[inward][:, ::-1]
    order = np.argsort(boundary)
    at = order[np.minimum(np.searchsorted(boundary[order], key), len(order) - 1)]
    face_tags = np.where(boundary[at] == key, tags[at], INNER)
    surface = Surface.of(points[faces], face_tags)
    mine = _keys(np.sort(_numbers(surface.points, points)[surface.triangles], axis=1), n)
    on_boundary = np.isin(mine, boundary)
    return surface, ~(on_boundary & np.isin(mine, poor_faces)), on_boundary


def _merged(points, kept_cells, triangles, tags, surface, on_boundary, fresh):
    """The kept cells and the cavity's ``fresh`` mesh (:func:`~.mesher.mesh_cavity`) on one
    set of points, with the boundary's triangles: the old ones but those of the cavity's
    patches meshed afresh (no face of a new cell), and those patches' new ones."""
    new_points, new_cells, new_triangles, new_tags = fresh
    merged, index = np.unique(np.concatenate([points, new_points]), axis=0,
                              return_inverse=True)
    old, new = index[:len(points)], index[len(points):]
    n = len(merged)
    faces = _keys(np.sort(new[new_cells][:, FACES].reshape(-1, 3), axis=1), n)
    on_surface = np.sort(_numbers(surface.points, merged)[surface.triangles[on_boundary]],
                         axis=1)
    gone = on_surface[~np.isin(_keys(on_surface, n), faces)]
    replaced = np.isin(_keys(np.sort(old[triangles], axis=1), n), _keys(gone, n))
    triangles = np.concatenate([old[triangles][~replaced], new[new_triangles]])
    # a fresh patch may make a triangle as it was: once
    _, once = np.unique(_keys(np.sort(triangles, axis=1), n), return_index=True)
    cells = np.concatenate([old[kept_cells], new[new_cells]])
    used, cells = np.unique(cells, return_inverse=True)   # the cavity's old inner nodes go
    number = np.full(n, -1)
    number[used] = np.arange(len(used))
    return (merged[used], cells.reshape(-1, 4), number[triangles[np.sort(once)]],
            np.concatenate([tags[~replaced], new_tags])[np.sort(once)])


def _conforming(cells, triangles, n):
    """Whether each face of the ``cells`` (m, 4) joins two of them but those of the boundary
    ``triangles`` (k, 3), each of which bounds one (points numbered below ``n``)."""
    faces, count = np.unique(_keys(np.sort(cells[:, FACES].reshape(-1, 3), axis=1), n),
                             return_counts=True)
    boundary = np.sort(_keys(np.sort(triangles, axis=1), n))
    return (count <= 2).all() and np.array_equal(faces[count == 1], boundary)


def _numbers(rows, within):
    """The position in ``within`` (n, 3) of each of the ``rows`` (k, 3), each one of them."""
    _, index = np.unique(np.concatenate([within, rows]), axis=0, return_inverse=True)
    position = np.empty(index.max() + 1, dtype=int)
    position[index[:len(within)]] = np.arange(len(within))
    return position[index[len(within):]]


def _keys(rows, n):
    """One integer per row of point numbers (k, 3), each below ``n``."""
    return rows @ np.array([n * n, n, 1])
