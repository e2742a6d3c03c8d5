"""The soil's state moved from the old mesh to the new one, on rank 0.

Quadrature data: each old cell's values at its points become one linear polynomial of the
current coordinates, fitted by least squares through them (three terms through the 2 x 2
Gauss points of a quadrilateral, the three of a quadratic triangle's rule, four through the
four points of a quadratic tetrahedron's; the one point of a reduced rule gives the cell's
value); a new point takes the polynomial of the old cell it lies in, evaluated there: the
cell-wise recovery of the RITSS method (Hu and Randolph 1998, "A practical numerical approach
for large deformation problems in soil", IJNAMG 22, 327-350), which keeps a field's gradient
inside a cell and smooths nothing across cells. Nodal data (the total displacement): linear
interpolation of the old nodes' values over the old cells cut into simplices (exact at the
old nodes, continuous). A point is found in the old cells cut into simplices (triangles;
tetrahedra are their own: affine, so no inverse map of a distorted quadrilateral can fail); a
point that no old cell holds (round-off at the boundary) takes its nearest cell. Fields that a
return map keeps on a yield surface are not kept there by the fit: the re-equilibration
(:mod:`.remesher`) returns them.
"""
import numpy as np
import ufl
from dolfinx import fem, geometry
from dolfinx.mesh import create_mesh
from mpi4py import MPI

#: A DOLFINx quadrilateral's corners as two triangles.
QUADRILATERAL_TRIANGLES = ((0, 1, 3), (0, 3, 2))
#: The simplex of each dimension, as UFL names it.
SIMPLEX = {2: "triangle", 3: "tetrahedron"}


def cell_simplices(simplex, dimension=2):
    """The corners of a cell's simplices: the simplex itself, or a quadrilateral's two
    triangles (hexahedra are not cut: a three-dimensional remesh takes tetrahedra)."""
    if simplex:
        return (tuple(range(dimension + 1)),)
    if dimension != 2:
        raise ValueError("hexahedra are not cut into simplices")
    return QUADRILATERAL_TRIANGLES


class OldCells:
    """The old mesh on rank 0 alone, cut into simplices, to find points in: ``corners``
    (n, k, d), the old cells' corners in the DOLFINx order, in the input cell order
    (d = 2: the x-z plane)."""

    def __init__(self, corners, simplex):
        self._dim = dim = corners.shape[2]
        split = cell_simplices(simplex, dim)
        self._pieces = len(split)
        flat = corners.reshape(-1, dim)
        self._nodes, inverse = np.unique(flat, axis=0, return_inverse=True)
        self._node_of = inverse.reshape(corners.shape[:2])
        # simplex j of cell c is row c * pieces + j
        pieces = np.stack([self._node_of[:, list(t)] for t in split], axis=1).reshape(-1, dim + 1)
        domain = ufl.Mesh(ufl.VectorElement("Lagrange", SIMPLEX[dim], 1))
        self.mesh = create_mesh(MPI.COMM_SELF, pieces.astype(np.int64), self._nodes, domain)
        #: the old cell (input number) of each simplex of :attr:`mesh`
        self.parent = np.asarray(self.mesh.topology.original_cell_index) // self._pieces
        self._tree = geometry.BoundingBoxTree(self.mesh, dim)
        self._midpoints = None

    def holding(self, points):
        """(points as 3-vectors, the simplex of :attr:`mesh` holding each point (m, d), -1
        where none does)."""
        x = np.column_stack([points, np.zeros((len(points), 3 - self._dim))])
        candidates = geometry.compute_collisions(self._tree, x)
        colliding = geometry.compute_colliding_cells(self.mesh, candidates, x)
        offsets = colliding.offsets
        found = offsets[1:] > offsets[:-1]
        cells = np.full(len(points), -1, dtype=np.int32)
        cells[found] = colliding.array[offsets[:-1][found]]
        return x, cells

    def locate(self, points):
        """As :meth:`holding`, but the nearest simplex where none holds the point."""
        x, cells = self.holding(points)
        missing = cells < 0
        if missing.any():
            if self._midpoints is None:
                self._midpoints = geometry.create_midpoint_tree(
                    self.mesh, self._dim, np.arange(len(self.parent), dtype=np.int32))
            cells[missing] = geometry.compute_closest_entity(self._tree, self._midpoints,
                                                             self.mesh, x[missing])
        return x, cells

    def at_points(self, samples, located):
        """The move of quadrature data to ``located`` (:meth:`locate`'s): a function of the
        values (n, q, ...) of every old cell at its points ``samples`` (n, q, d), each cell's
        fitted linearly (module doc), giving their values there (m, ...). The fit depends on
        the points only, so it is solved once for all the fields."""
        n, q = samples.shape[:2]
        centre = samples.mean(axis=1, keepdims=True)
        basis = np.concatenate([np.ones((n, q, 1)), samples - centre], axis=2)   # (n, q, 1 + d)
        normal = np.einsum("nqa,nqb->nab", basis, basis)
        # least squares, or the cell's value with no gradient where one point (a reduced rule):
        # the coefficients of a cell's polynomial are fit @ its values
        fit = np.linalg.pinv(normal) @ basis.transpose(0, 2, 1)                 # (n, 1 + d, q)
        x, simplices = located
        cell = self.parent[simplices]
        local = np.concatenate([np.ones((len(x), 1)), x[:, :self._dim] - centre[cell, 0]], axis=1)
        weights = np.einsum("ma,maq->mq", local, fit[cell])

        def moved(values):
            flat = values.reshape(n, q, -1)[cell]
            return np.einsum("mq,mqk->mk", weights, flat).reshape((len(x),) + values.shape[2:])
        return moved

    def at_nodes(self, values, located):
        """Values (n, k, ...) at every old cell's corners, interpolated linearly over the
        simplices and evaluated at ``located``; (m, ...)."""
        shape = values.shape[2:]
        k = int(np.prod(shape, dtype=int))
        per_node = np.empty((len(self._nodes), k))
        per_node[self._node_of.ravel()] = values.reshape(-1, k)
        space = (fem.VectorFunctionSpace(self.mesh, ("Lagrange", 1), dim=k) if k > 1 else
                 fem.FunctionSpace(self.mesh, ("Lagrange", 1)))
        field = fem.Function(space)
        geometry_nodes = self.mesh.geometry.dofmap.array.reshape(-1, self._dim + 1)
        node = np.asarray(self.mesh.geometry.input_global_indices)[geometry_nodes]
        dofs = space.dofmap.list.array.reshape(-1, self._dim + 1)
        field.x.array.reshape(-1, k)[dofs] = per_node[node]
        x, cells = located
        return field.eval(x, cells).reshape((len(x),) + shape)
