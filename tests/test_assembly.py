"""The element assembler (soilbin.solver.assembly) against DOLFINx's own: the same matrix,
to the bit."""
import numpy as np
import pytest
from dolfinx import fem
from petsc4py import PETSc

from conftest import make_problem


def dolfinx_jacobian(newton):
    """The Newton matrix as DOLFINx 0.5 assembles it (Dirichlet rows and columns zeroed, one
    on their diagonal), with the tool's nodal terms."""
    A = fem.petsc.create_matrix(newton._a)
    fem.petsc.assemble_matrix(A, newton._a, bcs=newton._bcs)
    A.assemble(PETSc.Mat.AssemblyType.FLUSH)
    for term in newton._nodal_terms:
        term.add_jacobian(A)
    A.assemble()
    return A


@pytest.mark.parametrize("scene, overrides", [
    # a mixed (B-bar) space with a follower load: cell and exterior-facet integrals
    ("strip-load-von-mises", ["analysis.large_deformation=true"]),
    # a blocked vector space (3 dofs a node) with Dirichlet conditions on every face
    ("block-drucker-prager", []),
    # the tool's nodal interface terms added to the assembled matrix
    ("retaining-wall-passive-rough", []),
])
def test_the_element_assembler_gives_dolfinx_matrix(scene, overrides):
    problem = make_problem(scene, *overrides)
    problem.set_load_factor(0.7)
    rng = np.random.default_rng(1)
    problem.w.x.array[:] += 1e-4 * rng.standard_normal(len(problem.w.x.array))
    problem.w.x.scatter_forward()
    newton = problem.newton
    newton.residual(newton._b.duplicate())
    newton.jacobian()
    expected = dolfinx_jacobian(newton)
    assert newton.matrix.getInfo()["nz_used"] == expected.getInfo()["nz_used"]
    difference = newton.matrix.copy()
    difference.axpy(-1.0, expected, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    # the same element matrices, each entry's contributions added in the same order
    assert difference.norm(PETSc.NormType.NORM_INFINITY) == 0.0
    # and again at another iterate: the values are replaced, not added to
    problem.w.x.array[:] *= 0.5
    newton.residual(newton._b.duplicate())
    newton.jacobian()
    again = dolfinx_jacobian(newton)
    again.axpy(-1.0, newton.matrix, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    assert again.norm(PETSc.NormType.NORM_INFINITY) == 0.0
