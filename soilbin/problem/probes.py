"""Where things are on the initial mesh: the cell in front of a point, and a value
evaluated in one cell (on whichever rank owns it)."""
import basix
import numpy as np
from mpi4py import MPI
from dolfinx import fem
from dolfinx.mesh import compute_midpoints

from ..elements import embedding


def cell_ahead(mesh, point, direction):
    """The local index of the cell whose midpoint lies ahead of ``point`` along ``direction``
    (both in the scene's three components) and nearest to it, on the one rank that holds it
    (-1 on the others)."""
    n_owned = mesh.topology.index_map(mesh.topology.dim).size_local
    cells = np.arange(n_owned, dtype=np.int32)
    dim = mesh.geometry.dim
    midpoints = compute_midpoints(mesh, mesh.topology.dim, cells)[:, :dim] @ embedding(dim).T
    ahead = (midpoints - point) @ direction > 0.0
    distance = np.linalg.norm(midpoints - point, axis=1)
    distance[~ahead] = np.inf
    local = int(np.argmin(distance)) if len(cells) else -1
    best = (distance[local] if local >= 0 else np.inf, mesh.comm.rank)
    winner = mesh.comm.allreduce(best, op=MPI.MIN)
    return local if winner[1] == mesh.comm.rank else -1


class CellValue:
    """A scalar UFL expression at the centroid of one cell, returned on every rank (of a
    quadratic tetrahedron's P1 divergence, the cell's mean)."""

    def __init__(self, mesh, expression, cell):
        self._expression = fem.Expression(expression, reference_centroid(mesh))
        self._cell, self._comm = cell, mesh.comm

    def __call__(self):
        local = (float(self._expression.eval(np.array([self._cell], dtype=np.int32)).ravel()[0])
                 if self._cell >= 0 else 0.0)
        return self._comm.allreduce(local, op=MPI.SUM)


def reference_centroid(mesh):
    """(1, dim): the centroid of the mesh's reference cell (of a tetrahedron a quarter along
    each axis; (0.5, 0.5, 0.5) lies outside it)."""
    corners = basix.geometry(getattr(basix.CellType, mesh.topology.cell_type.name))
    return corners.mean(axis=0, keepdims=True)
