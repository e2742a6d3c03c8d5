"""The three-dimensional soil as it stands after a converged step, gathered on rank 0 for the
remesher: its boundary as one closed surface of tagged triangles, each turned outward."""
import dataclasses

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..layout import gather_rows
from ..meshes.tagged import outward_corners
from .outline import OutlineError


#: The times a patch that is not a topological disc is cut again (:meth:`Surface.patches`).
MAX_CUTS = 4
#: A patch of at most this many triangles joins a neighbour of its group (:meth:`Surface.patches`).
CRUMPLE = 3


@dataclasses.dataclass(frozen=True)
class Surface:
    """A closed surface: ``points`` (n, 3), ``triangles`` (m, 3) into them, each numbered
    counter-clockwise seen from outside, and the facet group tag of each (``tags``, m)."""
    points: np.ndarray
    triangles: np.ndarray
    tags: np.ndarray

    @classmethod
    def of(cls, corners, tags):
        """The surface of the triangles ``corners`` (m, 3, 3), outward, with ``tags``: shared
        corners made one point, the triangles in an order of their own (not that in which
        ranks gathered them). OutlineError unless every edge joins exactly two triangles."""
        points, index = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
        triangles = index.reshape(-1, 3)
        order = np.lexsort(np.sort(triangles, axis=1).T[::-1])
        surface = cls(points, triangles[order], np.asarray(tags)[order])
        _, count = np.unique(surface.edges(), axis=0, return_counts=True)
        if (count != 2).any():
            raise OutlineError("the tagged boundary facets do not close the soil (a boundary "
                               "facet in no facet group)")
        return surface

    def edges(self):
        """The three edges of each triangle in turn, (3 m, 2) point pairs, each pair sorted."""
        return edges_of(self.triangles)

    def shared_edges(self):
        """Each edge once, (k, 2) point pairs, with its two triangles (k,) and (k,)."""
        edges = self.edges()
        order = np.lexsort(edges.T[::-1])
        owner = order // 3          # edges() lists each triangle's three edges in turn
        return edges[order[0::2]], owner[0::2], owner[1::2]

    def patches(self, crease):
        """The patch of each triangle (m,): the surface cut along the borders of its facet
        groups and where it folds by more than ``crease`` (radians) between two triangles,
        and a patch that is then not a topological disc (gmsh maps each patch onto a plane)
        cut again, through a hole, up to :data:`MAX_CUTS` times: the tine's soil after 4 in
        had a triangle of the free surface folded past the crease by the heave, one corner on
        the tool, and the patch around it passed twice through that corner. Before that, a
        crumple (a patch of at most :data:`CRUMPLE` triangles, folded past the crease from its
        neighbours) joins a larger neighbouring patch of its group: the heave beside the blade
        after 4 in crumpled into patches of 1, 2 and 3 triangles, and gmsh's fresh mesh of
        the patch around one of them overlapped it."""
        a, b, c = (self.points[self.triangles[:, k]] for k in range(3))
        normal = np.cross(b - a, c - a)
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        _, first, second = self.shared_edges()
        smooth = ((self.tags[first] == self.tags[second])
                  & (np.einsum("ij,ij->i", normal[first], normal[second]) > np.cos(crease)))
        m = len(self.triangles)

        def joined(piece):
            keep = smooth & (piece[first] == piece[second])
            graph = coo_matrix((np.ones(keep.sum()), (first[keep], second[keep])), shape=(m, m))
            return connected_components(graph, directed=False)[1]
        patch_of = joined(np.zeros(m, dtype=int))
        while (crumpled := self._crumpled(patch_of, first, second) & ~smooth).any():
            smooth |= crumpled
            patch_of = joined(np.zeros(m, dtype=int))
        for _ in range(MAX_CUTS):
            holed = np.flatnonzero(euler_characteristic(self.triangles, patch_of) != 1)
            if len(holed) == 0:
                break
            piece = patch_of.copy()
            for patch in holed:
                beyond = self._beyond_a_hole(patch_of == patch)
                piece[beyond] = piece.max() + 1
            patch_of = joined(piece)
        return patch_of

    def _crumpled(self, patch_of, first, second):
        """The edges (a mask over ``first``, ``second``: the triangles on either side of each
        edge) across which each crumple (a patch of at most :data:`CRUMPLE` triangles) joins
        the larger patch of its group it shares most edges with (a cube's faces of two
        triangles each stay apart)."""
        across = (patch_of[first] != patch_of[second]) & (self.tags[first] == self.tags[second])
        a, b = patch_of[first][across], patch_of[second][across]
        pairs, shared = np.unique(np.column_stack([np.concatenate([a, b]), np.concatenate([b, a])]),
                                  axis=0, return_counts=True)
        size = np.bincount(patch_of)
        into = (size[pairs[:, 0]] <= CRUMPLE) & (size[pairs[:, 1]] > size[pairs[:, 0]])
        pairs, shared = pairs[into], shared[into]
        pairs = pairs[np.lexsort((-shared, pairs[:, 0]))]   # per crumple, its widest first
        joins = pairs[np.r_[True, pairs[1:, 0] != pairs[:-1, 0]]] if len(pairs) else pairs
        key = np.sort(joins, axis=1)
        edge = np.sort(np.column_stack([patch_of[first], patch_of[second]]), axis=1)
        return across & (edge[:, None, :] == key[None]).all(axis=2).any(axis=1)

    def _beyond_a_hole(self, inside):
        """The triangles of the patch ``inside`` (a mask) on one side of a plane across its
        longest extent: through the centre of its shortest border loop (a hole), or of its
        triangles where it has no border (a closed surface)."""
        triangles = self.triangles[inside]
        centroids = self.points[triangles].mean(axis=1)
        centre = centroids.mean(axis=0)
        edges, count = np.unique(edges_of(triangles), axis=0, return_counts=True)
        rim = edges[count == 1]
        if len(rim):
            n = len(self.points)
            graph = coo_matrix((np.ones(len(rim)), (rim[:, 0], rim[:, 1])), shape=(n, n))
            loop = connected_components(graph, directed=False)[1][rim[:, 0]]
            labels, size = np.unique(loop, return_counts=True)
            centre = self.points[rim[loop == labels[np.argmin(size)]].ravel()].mean(axis=0)
        axis = np.argmax(np.ptp(centroids, axis=0))
        beyond = np.zeros(len(self.triangles), dtype=bool)
        beyond[np.flatnonzero(inside)[centroids[:, axis] > centre[axis]]] = True
        return beyond

    def borders(self, patch_of):
        """The :class:`Borders` of the patches ``patch_of`` (m,), found in an order of their
        own: gmsh's ``createTopology`` numbers the curves it finds in an order that changes
        from run to run (the process's memory), and with it the mesh gmsh makes."""
        edge, first, second = self.shared_edges()
        pair = np.sort(np.column_stack([patch_of[first], patch_of[second]]), axis=1)
        border = pair[:, 0] != pair[:, 1]
        edge, pair = edge[border], pair[border]
        corners = _junctions(edge, pair)
        curves, between = [], []
        for key in sorted(set(map(tuple, pair.tolist()))):
            for chain in _chains(edge[(pair == key).all(axis=1)].tolist(), corners):
                curves.append(chain)
                between.append(key)
        bounding = [[k for k, key in enumerate(between) if patch in key]
                    for patch in range(patch_of.max() + 1)]
        return Borders(np.array(sorted(corners), dtype=int), curves, bounding)

    def crossings(self):
        """Where an edge of the surface passes through a triangle it does not touch (a soil
        folded onto itself): the points (k, 3) and the tags of
        the edge's triangle and of the triangle crossed (k, 2)."""
        corners = self.points[self.triangles]
        a, b = _overlapping_boxes(corners.min(axis=1), corners.max(axis=1))
        a, b = np.concatenate([a, b]), np.concatenate([b, a])
        apart = ~(self.triangles[a, :, None] == self.triangles[b, None, :]).any(axis=(1, 2))
        a, b = a[apart], b[apart]
        points, tags = [], []
        for k in range(3):
            x, through = _through(corners[a, k], corners[a, (k + 1) % 3], corners[b])
            points.append(x[through])
            tags.append(np.column_stack([self.tags[a], self.tags[b]])[through])
        return np.concatenate(points), np.concatenate(tags).astype(int)

    def folded(self, boundaries):
        """Where the soil has folded onto itself (its boundary passes through itself), in
        words, or '' (``boundaries``: group name -> tag)."""
        points, tags = self.crossings()
        if len(points) == 0:
            return ""
        name = {tag: group for group, tag in boundaries.items()}
        x, y, z = points[0]
        a, b = (name.get(int(t), str(t)) for t in tags[0])
        return (f"the soil has folded onto itself, its boundary {a} passing "
                f"through {b} at ({x:.4g}, {y:.4g}, {z:.4g}), {len(points)} crossing(s)")

    def on_grid(self, grain):
        """The surface with its points rounded to a grid of ``grain``."""
        return Surface.of(np.round(self.points[self.triangles] / grain) * grain, self.tags)


@dataclasses.dataclass(frozen=True)
class Borders:
    """Where a surface's patches meet: the ``corners`` (point numbers where borders meet, and
    one on each closed border that meets none), the ``curves`` (chains of point numbers from
    corner to corner, each between two patches) and the curves ``bounding`` each patch."""
    corners: np.ndarray
    curves: list
    bounding: list


def euler_characteristic(triangles, patch_of):
    """V - E + F of each patch of the ``triangles`` (m, 3), ``patch_of`` (m,): 1 for a
    topological disc, less with a hole or a border that passes twice through a point."""
    n = patch_of.max() + 1
    of_three = np.repeat(patch_of, 3)
    vertices = np.unique(np.column_stack([of_three, triangles.ravel()]), axis=0)
    edges = np.unique(np.column_stack([of_three, edges_of(triangles)]), axis=0)
    return (np.bincount(vertices[:, 0], minlength=n) - np.bincount(edges[:, 0], minlength=n)
            + np.bincount(patch_of, minlength=n))


def edges_of(triangles):
    """The three edges of each triangle in turn, (3 m, 2) point pairs, each pair sorted."""
    return np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)


def _overlapping_boxes(lo, hi):
    """The pairs (a, b), a before b in x, of boxes (lo, hi) (n, 3) that overlap: sweep and
    prune along x."""
    order = np.argsort(lo[:, 0], kind="stable")
    start = np.arange(1, len(order) + 1)
    stop = np.searchsorted(lo[order, 0], hi[order, 0], side="right")
    count = np.maximum(stop - start, 0)
    first = np.repeat(np.arange(len(order)), count)
    second = np.repeat(start - np.cumsum(count) + count, count) + np.arange(count.sum())
    a, b = order[first], order[second]
    overlap = ((lo[a] <= hi[b]) & (lo[b] <= hi[a])).all(axis=1)
    return a[overlap], b[overlap]


def _through(p, q, triangle):
    """Where each segment p q (n, 3) passes through the plane of its ``triangle`` (n, 3, 3)
    (n, 3), and whether that point is inside the triangle (n,)."""
    a, b, c = triangle.transpose(1, 0, 2)
    normal = np.cross(b - a, c - a)
    above_p = np.einsum("ij,ij->i", p - a, normal)
    above_q = np.einsum("ij,ij->i", q - a, normal)
    across = above_p * above_q < 0.0
    share = np.divide(above_p, above_p - above_q, out=np.zeros_like(above_p), where=across)
    x = p + share[:, None] * (q - p)
    inside = across
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, x - u), normal) > 0.0
    return x, inside


def _junctions(edge, pair):
    """The points where the borders (``edge`` (k, 2) between the patches ``pair`` (k, 2)) of
    more than one pair of patches meet, or where a border does not simply pass (it touches
    itself): a set."""
    pairs_at = {}
    for point, key in zip(edge.ravel().tolist(), np.repeat(pair, 2, axis=0).tolist()):
        pairs_at.setdefault(point, []).append(tuple(key))
    return {point for point, keys in pairs_at.items() if len(keys) != 2 or keys[0] != keys[1]}


def _chains(edges, corners):
    """The border ``edges`` (pairs of points) cut into chains from corner to corner, each from
    its least corner on, along its least neighbour first; a closed chain without a corner
    starts at its least point, added to ``corners``."""
    next_to = {}
    for a, b in edges:
        next_to.setdefault(a, []).append(b)
        next_to.setdefault(b, []).append(a)
    unused = {tuple(sorted(e)) for e in edges}
    starts = sorted(p for p in next_to if p in corners)
    chains = []
    while unused:
        if not starts:
            starts = [min(p for e in unused for p in e)]
            corners.add(starts[0])
        chain = [starts[0]]
        while True:
            step = [q for q in sorted(next_to[chain[-1]])
                    if tuple(sorted((chain[-1], q))) in unused]
            if not step:
                break
            unused.discard(tuple(sorted((chain[-1], step[0]))))
            chain.append(step[0])
            if step[0] in corners:
                break
        if len(chain) > 1:
            chains.append(chain)
        else:
            starts.pop(0)
    return chains


def gather_surface(tagged):
    """The tagged boundary facets of a three-dimensional mesh as a :class:`Surface`, on rank 0
    (None elsewhere; collective)."""
    mesh = tagged.mesh
    owned = mesh.topology.index_map(2).size_local
    keep = tagged.facet_tags.indices < owned
    corners = mesh.geometry.x[outward_corners(mesh, tagged.facet_tags.indices[keep])]
    rows = gather_rows(mesh.comm, np.column_stack([corners.reshape(-1, 9),
                                                   tagged.facet_tags.values[keep]]))
    return None if rows is None else Surface.of(rows[:, :9].reshape(-1, 3, 3),
                                                rows[:, 9].astype(int))
