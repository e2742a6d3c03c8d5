"""The soil against itself: a point of its boundary pressing a facing triangle of it.

Where the soil's boundary folds over (the heap beside a tool rolling onto the furrow
behind it) one part of it meets another; without a contact the soil passes through itself
and the fold check (``remesh.surface``) stops the run. The contact points of the faces
``[soil_contact] faces`` are their mesh nodes and the middles of their facets' edges (an
edge of soil crossing another, its ends outside, is held by its middle). At every commit
each point is paired with every triangle of those faces (a quadrilateral facet cut in two)
near it that

- has none of the point's nodes as a corner,
- faces it: its outward normal n and that of one of the point's own triangles (a node's,
  or the one or two with the edge whose middle it is) more than 120 degrees apart
  (:data:`FACING`; a point on a crease faces what either of its sides faces),
- holds the point's projection (barycentric λ >= -:data:`EDGE_TOLERANCE`) within
  -:data:`BAND_INSIDE` h .. :data:`BAND_OUTSIDE` h of its plane, h its longest edge,

and the pair's λ and n are kept over the step: node-to-segment penalty contact (Wriggers
2006, Computational Contact Mechanics) with the projection frozen for a step.
With x the nodes' positions (the mesh's node plus the unknown there), the point
x_p = (x_a + x_b)/2 (a node is a = b) and the standoff δ, the gap

    g = (x_p - Σ λ_i x_i) . n - δ = (Σ_k c_k x_k) . n - δ,
    c = (1/2, 1/2, -λ_1, -λ_2, -λ_3),

gives the penalty force f = k_n A max(-g, 0) on the point along n and -λ_i f on the
triangle's corners (action and reaction). A is the point's area (a facet's goes half to its
corners, half to its edges' middles, which hand theirs on to their ends half and half: a
node gets a third of a triangle's, a quarter of a quadrilateral's, the nodal forces of a
uniform pressure) divided among the point's pairs. Residual (internal - external) += -f c_k
n at the pair's five nodes; Jacobian += k_n A (c c^T) ⊗ (n n^T) where g < 0 (symmetric).
It couples nodes of different cells, anywhere in the mesh and on any rank: the Newton
matrix is made anew with those entries whenever the pairs change (``version``). Both
faces' points are paired (two passes), so two faces in contact are held by 2 k_n per area.
Frictionless and stateless: a checkpoint, a resume or a remesh pairs anew. Only the mesh's
vertices move the points (the mesh moves with them; the mid-edge nodes of quadratic
elements carry none of the force), and a supported dof takes none.
"""
import numpy as np
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc
from scipy.spatial import cKDTree

from ..meshes.tagged import outward_corners

#: The cosine of the least angle between a point's normal and a triangle's that it presses.
FACING = -0.5
#: How far (of its longest edge) past a triangle's edges a point's projection still pairs.
EDGE_TOLERANCE = 0.05
#: The band about a triangle's plane (of its longest edge) in which a point pairs with it:
#: inside the soil and outside. Inside it is thin: a point comes to a face from outside
#: and the penalty holds it there, while a point beyond the band's inside is one of the
#: far side of a thin sheet of soil (0.25 paired the top of a 1-in roof of soil over the
#: tine's furrow with its underside, and Newton diverged).
BAND_INSIDE, BAND_OUTSIDE = 0.05, 0.5
#: The triangles whose centroids are nearest a point that it is tried against.
CANDIDATES = 16


class SoilContact:
    def __init__(self, settings, tagged, disc, w, bcs):
        """``settings``: the scene's [soil_contact]; ``w`` the unknown (the total displacement
        or, in updated Lagrangian, the increment since the last commit)."""
        mesh = disc.mesh
        self.comm = mesh.comm
        self._k, self._standoff = settings.k_n, settings.standoff
        self._w = w
        nodal = fem.VectorFunctionSpace(mesh, ("Lagrange", 1))
        nodes_map = nodal.dofmap.index_map
        n_cells = mesh.topology.index_map(3).size_local + mesh.topology.index_map(3).num_ghosts
        node_of_geometry = np.empty(len(mesh.geometry.x), dtype=np.int32)
        node_of_geometry[mesh.geometry.dofmap.array] = nodal.dofmap.list.array.reshape(
            n_cells, -1).ravel()
        self._geometry_of_node = np.empty_like(node_of_geometry)
        self._geometry_of_node[node_of_geometry] = np.arange(len(node_of_geometry))
        node_ids = nodes_map.local_to_global(
            np.arange(nodes_map.size_local + nodes_map.num_ghosts, dtype=np.int32))
        self._dofs = disc.vertex_dofs(nodal)                       # local, (nodes, 3)
        space_map, bs = disc.space.dofmap.index_map, disc.space.dofmap.index_map_bs
        global_dofs = space_map.local_to_global(
            (self._dofs // bs).ravel()).reshape(self._dofs.shape) * bs + self._dofs % bs
        fixed = np.zeros(len(w.x.array), dtype=bool)
        for bc in bcs:
            fixed[bc.dof_indices()[0]] = True
        tags = tagged.facet_tags
        keep = ((tags.indices < mesh.topology.index_map(2).size_local)
                & np.isin(tags.values, [tagged.boundaries[face] for face in settings.faces]))
        facets = node_of_geometry[outward_corners(mesh, tags.indices[keep])]
        # the faces gathered on every rank, their nodes in the order of their first positions
        # (any partition pairs alike): global ids, dofs and supported flags, and the facets
        nodes = np.unique(facets)
        rows = np.concatenate(self.comm.allgather(np.column_stack([
            node_ids[nodes], mesh.geometry.x[self._geometry_of_node[nodes]],
            global_dofs[nodes], fixed[self._dofs[nodes]]])))
        ids, first = np.unique(rows[:, 0].astype(np.int64), return_index=True)
        order = np.lexsort(rows[first, 3:0:-1].T)
        rows, ids = rows[first][order], ids[order]
        by_id = np.argsort(ids)
        corner_ids = np.concatenate(self.comm.allgather(node_ids[facets]))
        facets = by_id[np.searchsorted(ids[by_id], corner_ids)]
        self._facets = facets[np.lexsort(np.sort(facets, axis=1).T[::-1])]
        self._ids = ids
        self._global_dofs = rows[:, 4:7].astype(PETSc.IntType)
        self._fixed = rows[:, 7:10] > 0.5
        self._points = _contact_points(self._facets)
        n_corners = self._facets.shape[1]   # a quadrilateral facet cut in two
        self._triangles = (self._facets if n_corners == 3 else
                           self._facets[:, [[0, 1, 3], [0, 3, 2]]].reshape(-1, 3))
        self._point_triangles = _point_triangles(self._triangles, self._points)
        # the faces' nodes this rank owns (local numbers), and every rank's in gathered order
        owned_ids = node_ids[:nodes_map.size_local]
        self._owned = np.isin(ids, owned_ids)
        mine = np.flatnonzero(self._owned)
        self._mine_local = np.searchsorted(owned_ids, ids[mine])
        self._gathered_order = np.concatenate(self.comm.allgather(mine))
        self._mesh_x = mesh.geometry.x
        self.version = 0
        self._pairs, self._force = None, np.zeros(0)
        #: The total force of the soil pressing on itself at the last commit.
        self.committed_force = 0.0
        self.pair()

    # -- pairing, at every commit -----------------------------------------------------------
    def pair(self):
        """Pair the contact points this rank owns with the triangles they face, from the
        current positions (collective)."""
        self.committed_force = self.force()
        facets, points, dofs, fixed = self._facets, self._points, self._global_dofs, self._fixed
        self._x_mesh = self._gathered(self._mesh_x[self._geometry_of_node[self._mine_local]])
        x = self._x_mesh + self._nodal_unknown()
        triangles = self._triangles
        corners = x[triangles]
        normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        area = np.linalg.norm(normal, axis=1) / 2.0
        normal /= 2.0 * area[:, None]
        point_area = _point_areas(facets, points, area.reshape(len(facets), -1).sum(axis=1))
        longest = np.max([np.linalg.norm(corners[:, k] - corners[:, k - 1], axis=1)
                          for k in range(3)], axis=0)

        mine = np.flatnonzero(self._owned[points.min(axis=1)])   # a point is its lesser node's
        count = min(CANDIDATES, len(triangles))
        p = x[points[mine]].mean(axis=1)
        candidates = (cKDTree(corners.mean(axis=1)).query(p, k=count)[1].reshape(
            len(mine), count) if len(mine) and count else np.zeros((len(mine), 0), dtype=int))
        a, b, c = (corners[candidates, k] for k in range(3))
        n_c = normal[candidates]
        s = np.einsum("pkj,pkj->pk", p[:, None, :] - a, n_c)         # signed distance
        weights = _barycentric(p[:, None, :] - s[..., None] * n_c, a, b, c)
        h = longest[candidates]
        apart = ~(triangles[candidates][:, :, :, None] == points[mine][:, None, None, :]).any(
            axis=(2, 3))
        own = self._point_triangles[mine]                               # (p, m), -1: none
        cosine = np.einsum("pmj,pkj->pmk", normal[own], n_c)
        facing = np.where(own[:, :, None] >= 0, cosine, np.inf).min(axis=1) < FACING
        valid = (apart & facing
                 & (weights >= -EDGE_TOLERANCE).all(axis=2)
                 & (s > -BAND_INSIDE * h) & (s < BAND_OUTSIDE * h))
        point, which = np.nonzero(valid)
        chosen = candidates[point, which]
        lam = np.clip(weights[point, which], 0.0, None)
        lam /= lam.sum(axis=1, keepdims=True)
        self._lambda, self._normal = lam, normal[chosen]
        # a point's area shared by its pairs: on a flat face the pairs of a point over a
        # corner press as one; in a valley each of its sides takes a share
        self._area = point_area[mine[point]] / np.bincount(point, minlength=len(mine))[point]
        self._c = np.column_stack([np.full((len(lam), 2), 0.5), -lam])         # (pairs, 5)
        self._pair_nodes = np.column_stack([points[mine[point]], triangles[chosen]])
        size = 3 * self._pair_nodes.shape[1]
        pair_dofs = dofs[self._pair_nodes].reshape(len(lam), size)
        pair_fixed = fixed[self._pair_nodes].reshape(len(lam), size)
        self._entry_rows = np.broadcast_to(pair_dofs[:, :, None], (len(lam), size, size))
        self._entry_columns = np.broadcast_to(pair_dofs[:, None, :], (len(lam), size, size))
        self._entries = ~pair_fixed[:, :, None] & ~pair_fixed[:, None, :]
        self._pair_dofs = pair_dofs
        signature = self._ids[self._pair_nodes]
        changed = self._pairs is None or not np.array_equal(signature, self._pairs)
        if self.comm.allreduce(changed, op=MPI.LOR):
            self.version += 1
        self._pairs = signature
        self._force = np.zeros(len(lam))

    def _gathered(self, values):
        """The values (n_mine, 3) at the faces' nodes this rank owns, gathered from every rank
        into the faces' node order (n, 3)."""
        gathered = np.empty((len(self._ids), 3))
        gathered[self._gathered_order] = np.concatenate(self.comm.allgather(values)).reshape(-1, 3)
        return gathered

    def _nodal_unknown(self):
        """The unknown at every node of the faces (n, 3)."""
        return self._gathered(self._w.x.array[self._dofs[self._mine_local]])

    # -- the Newton solver's coupled term ---------------------------------------------------
    def update(self):
        """The penalty forces at the current iterate (call once per iterate; collective)."""
        x = self._x_mesh + self._nodal_unknown()
        # c = (1/2, 1/2, -λ): the point (a node twice, or an edge's middle) less the triangle's
        apart = np.einsum("pk,pkj->pj", self._c, x[self._pair_nodes])
        gap = np.einsum("pj,pj->p", apart, self._normal) - self._standoff
        self._force = self._k * self._area * np.maximum(-gap, 0.0)

    def add_residual(self, b):
        """Residual += -f c_i n at the pair's point's nodes and triangle's corners
        (collective)."""
        values = -self._force[:, None, None] * self._c[:, :, None] * self._normal[:, None, :]
        b.setValues(self._pair_dofs.ravel(), values.ravel(), addv=PETSc.InsertMode.ADD_VALUES)
        b.assemblyBegin()
        b.assemblyEnd()

    def coupling_entries(self):
        """The Jacobian's entries of the pairs (global rows, columns): the point's nodes' and
        its triangle's corners' dofs, supported ones left out."""
        return self._entry_rows[self._entries], self._entry_columns[self._entries]

    def coupling_values(self):
        """The values of :meth:`coupling_entries` at the current iterate."""
        stiffness = self._k * self._area * (self._force > 0.0)
        cc = self._c[:, :, None] * self._c[:, None, :]
        nn = self._normal[:, :, None] * self._normal[:, None, :]
        blocks = (stiffness[:, None, None, None, None] * cc[:, :, None, :, None]
                  * nn[:, None, :, None, :]).reshape(len(self._c), *self._entries.shape[1:])
        return blocks[self._entries]

    def force(self):
        """The total penalty force pressing the soil's faces together (summed over ranks)."""
        return self.comm.allreduce(float(self._force.sum()), op=MPI.SUM)

    def touching(self):
        """The number of pairs whose point presses its triangle (summed over ranks)."""
        return self.comm.allreduce(int((self._force > 0.0).sum()), op=MPI.SUM)


def _barycentric(q, a, b, c):
    """The barycentric coordinates (..., 3) of the points q in the triangles a b c (..., 3)
    whose plane they lie in."""
    v0, v1, v2 = b - a, c - a, q - a
    d00, d01, d11 = (np.einsum("...j,...j->...", u, v) for u, v in ((v0, v0), (v0, v1), (v1, v1)))
    d20, d21 = (np.einsum("...j,...j->...", v2, v) for v in (v0, v1))
    denominator = d00 * d11 - d01 * d01
    second = (d11 * d20 - d01 * d21) / denominator
    third = (d00 * d21 - d01 * d20) / denominator
    return np.stack([1.0 - second - third, second, third], axis=-1)


def _contact_points(facets):
    """The contact points of the facets (m, 3 or 4 corners): each node (twice: (n, n)) and
    each facet edge's middle ((a, b), a < b), (k, 2) node pairs in lexicographic order."""
    nodes = np.unique(facets)
    return np.unique(np.concatenate([np.column_stack([nodes, nodes]), _edges(facets)]), axis=0)


def _point_triangles(triangles, points):
    """The triangles (t, 3) of each contact point (k, 2), (k, m) padded with -1: those with
    the node as a corner, or with both ends of the edge whose middle the point is."""
    corner = triangles.ravel()
    order = np.argsort(corner, kind="stable")
    corner, owner = corner[order], order // 3
    start = np.searchsorted(corner, points[:, 0])
    stop = np.searchsorted(corner, points[:, 0], side="right")
    width = int((stop - start).max(initial=0))
    at = start[:, None] + np.arange(width)
    mine = at < stop[:, None]
    candidate = owner[np.minimum(at, len(owner) - 1)] if len(owner) else np.zeros_like(at)
    both = (triangles[candidate] == points[:, 1, None, None]).any(axis=2)
    return np.where(mine & both, candidate, -1)


def _edges(facets):
    """The edges of each facet in turn, (m * corners, 2) node pairs, each pair sorted."""
    around = [0, 1, 2] if facets.shape[1] == 3 else [0, 1, 3, 2]
    return np.sort(np.stack([facets[:, around], facets[:, np.roll(around, -1)]], axis=2),
                   axis=2).reshape(-1, 2)


def _point_areas(facets, points, facet_area):
    """The area of each contact point (k,): a facet's goes half to its corners and half to its
    edges' middles, which hand it on half and half to their ends: a node's share with its
    edges' is a third of a triangle's, a quarter of a quadrilateral's, the nodal forces of a
    uniform pressure."""
    n_corners = facets.shape[1]
    share = np.repeat(facet_area / (2 * n_corners), n_corners)   # per facet corner and edge
    n = points.max() + 1 if len(points) else 0
    key = points[:, 0] * n + points[:, 1]        # sorted, as the points are
    nodes = facets.reshape(-1, 1)
    area = np.zeros(len(points))
    for pair in (np.hstack([nodes, nodes]), _edges(facets)):
        np.add.at(area, np.searchsorted(key, pair[:, 0] * n + pair[:, 1]), share)
    return area
