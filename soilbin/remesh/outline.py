"""The soil as it stands after a converged step, gathered on rank 0 for the remesher: its
boundary as one closed polygon of tagged edges, and its cells' sizes as they were built."""
import dataclasses

import numpy as np
from dolfinx.cpp.mesh import entities_to_geometry

from ..layout import gather_rows


class OutlineError(RuntimeError):
    """The tagged boundary edges do not close into one polygon."""


@dataclasses.dataclass(frozen=True)
class Outline:
    """One closed polygon, counter-clockwise in the x-z plane: ``vertices`` (n, 2) and the
    facet group tag of the edge from vertex i to vertex i + 1 (``tags``, n)."""
    vertices: np.ndarray
    tags: np.ndarray

    def runs(self):
        """[(tag, first edge, last edge + 1)]: the polygon cut where the tag changes, the first
        run starting at edge 0 (:func:`gather_outline` starts the polygon at a change)."""
        change = np.flatnonzero(self.tags != np.roll(self.tags, 1))
        if not len(change):
            return [(int(self.tags[0]), 0, len(self.tags))]
        ends = list(change[1:]) + [len(self.tags)]
        return [(int(self.tags[a]), int(a), int(b)) for a, b in zip(change, ends)]

    def resampled(self, sizes, corner_angle=30.0):
        """The polygon with new vertices about ``sizes`` apart (the size at each vertex, linear
        along each edge): the ends of each run of one tag and the vertices where the
        boundary turns by more than ``corner_angle`` degrees stay; the others are dropped and
        new ones placed on the old edges, so the boundary's shape changes only where a chord
        cuts across a dropped vertex."""
        n = len(self.vertices)
        ahead = np.roll(self.vertices, -1, axis=0) - self.vertices
        behind = self.vertices - np.roll(self.vertices, 1, axis=0)
        cosine = np.einsum("ij,ij->i", ahead, behind) / (
            np.linalg.norm(ahead, axis=1) * np.linalg.norm(behind, axis=1))
        kept = (cosine < np.cos(np.radians(corner_angle))) | (self.tags != np.roll(self.tags, 1))
        kept[0] = True
        anchors = list(np.flatnonzero(kept)) + [n]
        vertices, tags = [], []
        for a, b in zip(anchors[:-1], anchors[1:]):
            stretch = np.arange(a, b + 1) % n            # vertices a..b along the polygon
            x = self.vertices[stretch]
            h = sizes[stretch]
            length = np.linalg.norm(np.diff(x, axis=0), axis=1)
            s = np.concatenate([[0.0], np.cumsum(length)])
            t = np.concatenate([[0.0], np.cumsum(2.0 * length / (h[:-1] + h[1:]))])
            count = max(1, int(np.rint(t[-1])))
            at = np.interp(np.linspace(0.0, t[-1], count + 1)[:-1], t, s)
            vertices.append(np.column_stack([np.interp(at, s, x[:, 0]), np.interp(at, s, x[:, 1])]))
            tags.append(np.full(count, self.tags[a]))
        return Outline(np.concatenate(vertices), np.concatenate(tags))


def gather_outline(tagged):
    """The tagged boundary edges of a two-dimensional mesh chained into an :class:`Outline`, on
    rank 0 (None elsewhere; collective). OutlineError if they do not make one closed polygon
    (a boundary edge in no facet group, or a domain with a hole)."""
    mesh = tagged.mesh
    owned = mesh.topology.index_map(1).size_local
    keep = tagged.facet_tags.indices < owned
    facets = tagged.facet_tags.indices[keep].astype(np.int32)
    nodes = entities_to_geometry(mesh._mesh, 1, facets, False)   # 0.5: the C++ mesh
    x = mesh.geometry.x[nodes[:, :2]][:, :, :2]
    rows = gather_rows(mesh.comm, np.column_stack([x.reshape(-1, 4),
                                                   tagged.facet_tags.values[keep]]))
    return None if rows is None else chain(rows[:, :4].reshape(-1, 2, 2), rows[:, 4].astype(int))


def chain(edges, tags):
    """Edges (n, 2, 2) with tags in any order and direction, as an :class:`Outline`."""
    points, ends = np.unique(edges.reshape(-1, 2), axis=0, return_inverse=True)
    ends = ends.reshape(-1, 2)
    edges_at = [[] for _ in points]
    for e, (a, b) in enumerate(ends):
        edges_at[a].append(e)
        edges_at[b].append(e)
    if any(len(at) != 2 for at in edges_at):
        raise OutlineError("the tagged boundary edges do not form one closed polygon (a boundary "
                           "edge in no facet group, or a vertex where more than two meet)")
    order, vertex, edge = [], ends[0, 0], 0
    for _ in range(len(ends)):
        order.append((vertex, edge))
        vertex = ends[edge, 1] if ends[edge, 0] == vertex else ends[edge, 0]
        edge = next(e for e in edges_at[vertex] if e != edge)
    if vertex != ends[0, 0] or len({e for _, e in order}) != len(ends):
        raise OutlineError("the tagged boundary edges make more than one polygon (a hole in the "
                           "soil)")
    vertices = points[[v for v, _ in order]]
    edge_tags = tags[[e for _, e in order]]
    x, z = vertices.T
    if np.dot(x, np.roll(z, -1)) - np.dot(np.roll(x, -1), z) < 0.0:   # clockwise: turn it round
        vertices, edge_tags = vertices[::-1], np.roll(edge_tags[::-1], -1)
    # start at the run start (or vertex) lowest in x, then z: the same polygon whatever the
    # order the edges came in (ranks gather them in another)
    starts = np.flatnonzero(edge_tags != np.roll(edge_tags, 1))
    if not len(starts):
        starts = np.arange(len(vertices))
    shift = int(starts[np.lexsort(vertices[starts].T[::-1])[0]])
    return Outline(np.roll(vertices, -shift, axis=0), np.roll(edge_tags, -shift))


def initial_sizes(initial, simplices):
    """Each cell's element size as built, from its corners at the start (n, k, d): √A of a
    quadrilateral, the side of the equilateral triangle of its area, the edge of the regular
    tetrahedron of its volume, (6√2 V)^(1/3)."""
    if initial.shape[2] == 3:
        if not simplices:
            raise ValueError("a three-dimensional remesh takes tetrahedra")
        edges = initial[:, 1:] - initial[:, :1]
        volume = np.abs(np.linalg.det(edges)) / 6.0
        return np.cbrt(6.0 * np.sqrt(2.0) * volume)
    x, z = initial[..., 0], initial[..., 1]
    if simplices:
        area = 0.5 * np.abs((x[:, 1] - x[:, 0]) * (z[:, 2] - z[:, 0])
                            - (x[:, 2] - x[:, 0]) * (z[:, 1] - z[:, 0]))
        return np.sqrt(4.0 * area / np.sqrt(3.0))
    ring = [0, 1, 3, 2]   # DOLFINx numbers a quadrilateral's corners tensor-wise
    xr, zr = x[:, ring], z[:, ring]
    area = 0.5 * np.abs(np.sum(xr * np.roll(zr, -1, axis=1) - np.roll(xr, -1, axis=1) * zr, axis=1))
    return np.sqrt(area)
