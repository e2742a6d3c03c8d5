"""The mesh's quality as the soil deforms (updated Lagrangian: the mesh moves with it).

The scaled Jacobian of a hexahedron (a quadrilateral in plane strain) at a corner is the
determinant of its three (two) edge vectors from that corner over the product of their
lengths (Knupp 2000, "Achieving finite element mesh quality via optimization of the
Jacobian matrix norm and associated quantities", the corner condition): 1 where the edges
are orthogonal, sin of the angle between them in a sheared cell, 0 where they lie in a
plane and negative where the cell has folded over. A cell's quality is the least over its
corners, signed by the cell's orientation in the mesh as built (gmsh may number a cell
either way round); the mesh's is the least over its cells.
"""
import numpy as np
from mpi4py import MPI


class MeshQuality:
    """The quality of this rank's owned cells of ``mesh``, from its current coordinates.
    Built on the undeformed mesh, which fixes each cell's orientation."""

    def __init__(self, mesh):
        self.mesh = mesh
        dim = mesh.topology.dim
        owned = mesh.topology.index_map(dim).size_local
        nodes = mesh.geometry.dofmap.array.reshape(-1, mesh.geometry.dofmap.offsets[1])
        self._corners = nodes[:owned, :2 ** dim]   # vertices first, tensor-product order
        self._orientation = np.sign(np.linalg.det(self._centre_jacobian()))

    def _coordinates(self):
        dim = self.mesh.topology.dim
        return self.mesh.geometry.x[self._corners][:, :, :dim]

    def _centre_jacobian(self):
        """(n, dim, dim) derivative of the (bi/tri)linear map at the cell's centre: the mean
        of its edges along each reference axis."""
        x, dim = self._coordinates(), self.mesh.topology.dim
        low = [[v for v in range(2 ** dim) if not v >> axis & 1] for axis in range(dim)]
        return np.stack([np.mean([x[:, v | 1 << axis] - x[:, v] for v in low[axis]], axis=0)
                         for axis in range(dim)], axis=-1)

    def cells(self):
        """(n,) the least scaled Jacobian over each owned cell's corners."""
        x, dim = self._coordinates(), self.mesh.topology.dim
        least = np.full(len(x), np.inf)
        for v in range(2 ** dim):
            # the edges from corner v along each reference axis, pointing the axis's way
            edges = np.stack([(x[:, v ^ 1 << axis] - x[:, v]) * (1 - 2 * (v >> axis & 1))
                              for axis in range(dim)], axis=-1)
            lengths = np.prod(np.linalg.norm(edges, axis=1), axis=-1)
            least = np.minimum(least, np.linalg.det(edges) / lengths)
        return least * self._orientation

    def minimum(self):
        """The least cell quality of the whole mesh; collective."""
        local = self.cells().min(initial=np.inf)
        return float(self.mesh.comm.allreduce(local, op=MPI.MIN))
