"""The deformed soil's tetrahedra mended by moving their nodes, before meshing it afresh.

A fresh mesh of the deformed soil takes 10-30% off the tine's draft at each remesh, and 2-8%
off the force of an elastic soil (docs/chapter8.md): the stress moved onto other cells is not
in their discrete equilibrium, and the re-equilibration relaxes it. The loss grows with how far
the new cells are from the old: with the old mesh's interior nodes moved at random by a tenth
of their shortest edge, the same elastic soil loses 0.2%. Where the few cells below the target
can be mended by moving nodes, the remesher keeps the cells and moves the nodes
(:func:`smoothed`), and the state moves a short way.

Each sweep visits the movable nodes of the cells below the target, those of the worst cells
first, and puts each where the least scaled Jacobian of its cells is highest among: toward
the centroid of its neighbours by :data:`LAPLACIAN_STEPS` of the way (smart Laplacian
smoothing, Freitag & Ollivier-Gooch 1997, "Tetrahedral mesh improvement using swapping and
smoothing", IJNME 40, 3979-4002), or, where none of those raises it, up the gradient of its
worst cell's quality by :data:`GRADIENT_STEPS` of its shortest edge; it stays where nothing
raises it. An interior node
moves freely. A boundary node inside one facet group's patch (its boundary triangles all of
one group, none folded more than :data:`SLIDE` from another) slides on its boundary triangles
as they were before the sweeps (a move that leaves them is not taken), so that the soil keeps
its shape; the other boundary nodes (where groups meet, at folds) stay.
"""
import math

import numpy as np

from ..problem.mesh_quality import simplex_quality

#: Sweeps over the nodes of the cells below the target, at most.
SWEEPS = 20
#: The shares of the way to the neighbours' centroid a node is tried at.
LAPLACIAN_STEPS = (1.0, 0.6, 0.3, 0.1)
#: The moves up the worst cell's quality gradient tried, in shortest edges of the node.
GRADIENT_STEPS = (0.3, 0.1, 0.03, 0.01)
#: A boundary node slides where its boundary triangles fold by less than this between any two.
SLIDE = math.radians(20.0)


def smoothed(points, cells, triangles, tags, target):
    """(the ``points`` (n, 3) moved, the least scaled Jacobian of the ``cells`` (m, 4) then):
    the nodes of the cells below ``target`` moved (module doc); ``triangles`` (k, 3) and
    ``tags`` (k,) are the boundary's facets and their groups. Each cell keeps its orientation."""
    x = np.array(points, dtype=float)
    orientation = np.sign(simplex_quality(x[cells]))
    incident = _incidence(cells, len(x))
    umbrella = _sliding(x, triangles, tags)
    on_boundary = np.zeros(len(x), dtype=bool)
    on_boundary[triangles.ravel()] = True
    movable = ~on_boundary
    movable[list(umbrella)] = True

    def quality(some):
        return orientation[some] * simplex_quality(x[cells[some]])

    for _ in range(SWEEPS):
        every = quality(slice(None))
        nodes = np.unique(cells[every < target])
        nodes = nodes[movable[nodes]]
        worst = np.array([every[incident[node]].min() for node in nodes])
        nodes = nodes[np.argsort(worst, kind="stable")]
        moved = [_improve(x, node, incident[node], cells, quality, umbrella.get(node))
                 for node in nodes]
        if not any(moved):
            break
    return x, quality(slice(None)).min()


def _improve(x, node, around, cells, quality, umbrella):
    """Move ``node`` (module doc) in ``x``, given the ``cells`` ``around`` it; whether it
    moved. ``quality(cells)`` is their qualities at the current ``x``."""
    start, best, best_quality = x[node].copy(), None, quality(around).min()
    neighbours = np.setdiff1d(cells[around], node)
    shortest = np.linalg.norm(x[neighbours] - start, axis=1).min()

    def tried(candidates):
        nonlocal best, best_quality
        for candidate in candidates:
            if umbrella is not None:
                candidate = on_triangles(candidate, umbrella)
                if candidate is None:
                    continue
            x[node] = candidate
            least = quality(around).min()
            if least > best_quality:
                best, best_quality = candidate, least
        x[node] = start if best is None else best

    centroid = x[neighbours].mean(axis=0)
    tried(start + share * (centroid - start) for share in LAPLACIAN_STEPS)
    if best is None:
        worst = around[[np.argmin(quality(around))]]
        gradient = _gradient(x, node, worst, quality, 1e-4 * shortest)
        norm = np.linalg.norm(gradient)
        if norm > 0.0:
            tried(start + step * shortest * gradient / norm for step in GRADIENT_STEPS)
    return best is not None


def _gradient(x, node, cell, quality, h):
    """The gradient of the quality of ``cell`` (an array of one) in ``node``'s position, by
    central differences."""
    gradient = np.zeros(3)
    for k in range(3):
        x[node, k] += h
        ahead = quality(cell)[0]
        x[node, k] -= 2.0 * h
        gradient[k] = (ahead - quality(cell)[0]) / (2.0 * h)
        x[node, k] += h
    return gradient


def on_triangles(p, triangles):
    """The point ``p`` (3,) projected onto the plane of one of the ``triangles`` (k, 3, 3):
    of the nearest plane among those it projects into the triangle of; None if there is
    none."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    height = np.einsum("ij,ij->i", p - a, normal)
    q = p - height[:, None] * normal
    inside = np.ones(len(triangles), dtype=bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v - u, q - u), normal) >= 0.0
    if not inside.any():
        return None
    return q[inside][np.argmin(np.abs(height[inside]))]


def _incidence(cells, n):
    """The cells around each of the ``n`` nodes: a list of arrays."""
    order = np.argsort(cells.ravel(), kind="stable") // cells.shape[1]
    return np.split(order, np.cumsum(np.bincount(cells.ravel(), minlength=n))[:-1])


def _sliding(x, triangles, tags):
    """The boundary nodes that may slide: node -> its boundary triangles' corners (j, 3, 3)."""
    a, b, c = (x[triangles[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    around = _incidence(triangles, len(x))
    umbrella = {}
    for node in np.unique(triangles):
        mine = around[node]
        if len(np.unique(tags[mine])) == 1 and (normal[mine] @ normal[mine].T
                                                 >= math.cos(SLIDE)).all():
            umbrella[int(node)] = x[triangles[mine]]
    return umbrella
