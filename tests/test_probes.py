"""The probes of a cell: a value at its centroid."""
import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI

from soilbin.problem.probes import CellValue


@pytest.mark.parametrize("cell_type", [mesh.CellType.tetrahedron, mesh.CellType.hexahedron])
def test_a_cell_value_is_taken_at_the_cell_centroid(cell_type):
    """div u of u = (x², 0, 0) is 2x: at a tetrahedron's centroid the mean of its corners'
    x (the front volumetric strain of the tet10 tines was read outside its cell)."""
    domain = mesh.create_unit_cube(MPI.COMM_WORLD, 2, 2, 2, cell_type)
    u = fem.Function(fem.VectorFunctionSpace(domain, ("Lagrange", 2)))
    u.interpolate(lambda x: np.stack([x[0] ** 2, 0.0 * x[0], 0.0 * x[0]]))
    n_owned = domain.topology.index_map(3).size_local
    for cell in range(n_owned):
        corners = domain.geometry.x[domain.geometry.dofmap.links(cell)]
        value = CellValue(domain, ufl.div(u), cell)
        assert value() == pytest.approx(2.0 * corners[:, 0].mean(), abs=1e-12)
