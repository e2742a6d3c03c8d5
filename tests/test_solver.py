"""Newton's linear solvers, the condensed B-bar system, the early cut of diverging steps."""
import re

import numpy as np
import pytest
from petsc4py import PETSc

from conftest import make_problem
from soilbin.errors import ConvergenceError
from soilbin.solver import linear_solver
from soilbin.solver.condensation import CellCondensation
from soilbin.solver.newton import CP_TOLERANCE, NewtonFailure
from soilbin.solver.stepping import run_load_steps

# the footing before collapse, plastic under the edge: 4 steps to 0.02 in
SHORT = ("loading.magnitude=0.02", "loading.steps=4")


def curve(*overrides):
    problem = make_problem("strip-footing-von-mises", *SHORT, *overrides)
    result = run_load_steps(problem, 4, 3, lambda r: None)
    assert result.complete
    return problem, np.array([(r.load_factor, r.force) for r in result.steps])


def test_the_symmetry_check_is_numpys_allclose():
    """The compiled check of the tangents' symmetry answers as np.allclose(B, B.T) with the
    same tolerances, block by block: symmetric, perturbed within and beyond them."""
    from mpi4py import MPI
    rng = np.random.default_rng(3)
    blocks = rng.standard_normal((50, 6, 6))
    blocks += blocks.transpose(0, 2, 1)
    scale = np.abs(blocks).max()
    for size in (0.0, 1e-13, 1e-10 * scale, 1e-8 * scale, 1e-3):
        for b in range(len(blocks)):
            bent = blocks.copy()
            bent[b, 1, 4] += size * (1.0 + b)
            expected = np.allclose(bent, bent.transpose(0, 2, 1), rtol=1e-9,
                                   atol=1e-12 * np.abs(bent).max())
            assert linear_solver.all_symmetric(bent, MPI.COMM_SELF) == expected, (size, b)


def test_every_linear_solver_gives_the_same_curve(monkeypatch):
    """Each choice follows LU's curve; ``auto`` takes LDLT here and, above BLR_DOFS unknowns
    (the threshold lowered so that the footing passes it), the block low-rank LU."""
    lu, reference = curve("solver.linear=lu")
    assert lu.newton.linear.description == "MUMPS LU"
    for kind, name in (("cholesky", "MUMPS LDLT"), ("amg", "GMRES + GAMG"), ("auto", "MUMPS LDLT")):
        problem, other = curve(f"solver.linear={kind}")
        assert problem.newton.linear.description.startswith(name)
        assert other[:, 0] == pytest.approx(reference[:, 0], rel=1e-12)
        assert other[:, 1] == pytest.approx(reference[:, 1], rel=1e-6)
    assert problem.newton.linear.stats["unsymmetric_solves"] == 0   # von Mises: symmetric
    monkeypatch.setattr(linear_solver, "BLR_DOFS", 1000)
    problem, other = curve("solver.linear=auto")
    assert problem.newton.linear.description.startswith("MUMPS BLR LU")
    assert other[:, 1] == pytest.approx(reference[:, 1], rel=1e-6)


# the tine on a coarse mesh (tests/test_reliability.py's), over its cap's first yield
COARSE_TINE = ("mesh.element_size=1.5", "mesh.growth=1.6", "mesh.ahead=10.0", "mesh.behind=10.0",
               "mesh.bin_width=10.0", "loading.steps=2", "loading.magnitude=0.025")


def test_blr_gives_the_curve_of_lu_on_the_tine():
    """The block low-rank factor of the condensed system, as the solver, follows LU's curve
    (the cap's unsymmetric tangent, cut steps included): its inexact corrections do not
    change what Newton converges to."""
    curves = {}
    for kind in ("lu", "blr"):
        # the strict residual floor: the scene's 1e-6 leaves 2.6e-6 between the curves
        problem = make_problem("tine-2in-90deg", *COARSE_TINE, f"solver.linear={kind}",
                               "solver.atol=1e-10")
        result = run_load_steps(problem, 2, 3, lambda r: None)
        assert result.complete
        curves[kind] = np.array([(r.load_factor, r.force) for r in result.steps])
    stats = problem.newton.linear.stats
    assert problem.newton.linear.description.startswith("MUMPS BLR LU")
    assert stats["factorisations"] == stats["solves"] and stats["krylov_iterations"] == 0
    assert curves["blr"][:, 0] == pytest.approx(curves["lu"][:, 0], rel=1e-12)
    assert curves["blr"][:, 1] == pytest.approx(curves["lu"][:, 1], rel=1e-6)


def test_auto_takes_lu_in_large_deformation():
    problem = make_problem("tine-2in-90deg", "analysis.large_deformation=true")
    assert problem.newton.linear.description == "MUMPS LU"


def test_condensed_system_reproduces_the_mixed_solution():
    """Eliminating θ and p cell by cell and solving for u gives the mixed system's solution."""
    problem = make_problem("strip-footing-von-mises", "loading.magnitude=0.004", "loading.steps=1")
    newton = problem.newton
    problem.set_load_factor(1.0)
    newton.solve()                   # a plastic state
    A = newton.matrix
    newton.residual(newton._b)
    newton.jacobian()
    rhs = A.createVecLeft()
    rhs.setRandom()
    exact, condensed = A.createVecRight(), A.createVecRight()
    lu = PETSc.KSP().create(problem.comm)
    lu.setType("preonly")
    lu.getPC().setType("lu")
    lu.getPC().setFactorSolverType("mumps")
    lu.setOperators(A)
    lu.solve(rhs, exact)
    condensation = CellCondensation(problem.disc)
    S = condensation.condense(A)
    cells = problem.mesh.topology.index_map(problem.mesh.topology.dim)
    assert S.getSize()[0] == A.getSize()[0] - 2 * cells.size_global
    lu_s = PETSc.KSP().create(problem.comm)
    lu_s.setType("preonly")
    lu_s.getPC().setType("lu")
    lu_s.getPC().setFactorSolverType("mumps")
    lu_s.setOperators(S)
    condensation.solve(lu_s, rhs, condensed)
    condensed.axpy(-1.0, exact)
    assert condensed.norm() < 1e-9 * exact.norm()


def test_a_diverging_step_is_cut_early():
    """The whole settlement in one full-Newton step diverges; it is cut long before the
    iteration limit (25), and the stepper records the iterations it cost. (On edge cells
    of 0.02: on the scene's 0.005 full Newton needs steps below the 1/32 of the settlement
    that 5 cuts reach.)"""
    problem = make_problem("strip-footing-von-mises", "loading.steps=1", "mesh.edge_size=0.02",
                           "solver.line_search=basic")
    problem.set_load_factor(1.0)
    with pytest.raises(NewtonFailure) as failure:
        problem.solve()
    assert isinstance(failure.value, ConvergenceError)
    assert 1 <= failure.value.iterations <= 6
    assert "diverged" in str(failure.value) or "stagnated" in str(failure.value)
    assert problem.newton.stats["failed_iterations"] == failure.value.iterations
    problem.roll_back()
    result = run_load_steps(problem, 1, 5, lambda r: None)   # cut until a step converges
    assert result.steps[0].cuts >= 1 and result.steps[0].failed_iterations >= failure.value.iterations


def test_a_step_at_its_iteration_limit_says_how_far_its_residual_came_and_what_set_its_target():
    """The whole settlement in one step with three iterations allowed: the failure names the
    least residual, the target and the key that set it (rtol times the step's first
    residual; with a larger atol, atol times the force scale)."""
    pattern = (r"iteration limit reached\) after 3 iterations; the residual (\S+) at least "
               r"against the target (\S+), (solver\.\w+) (\S+) x the (step's first residual|"
               r"force scale) (\S+)$")
    for atol, key in ((1e-10, "solver.rtol"), (1e-3, "solver.atol")):
        problem = make_problem("strip-footing-von-mises", "loading.steps=1",
                               "solver.max_iterations=3", "solver.line_search=cp",
                               f"solver.atol={atol}")
        problem.set_load_factor(1.0)
        with pytest.raises(NewtonFailure) as failure:
            problem.solve()
        least, target, named, factor, _, base = re.search(pattern, str(failure.value)).groups()
        assert named == key and float(least) > float(target)
        assert float(target) == pytest.approx(float(factor) * float(base), rel=2e-3)


def test_the_critical_point_line_search_stops_where_the_energy_is_stationary():
    """From the start of a step that full Newton cannot take (the whole settlement at once),
    the cp step ends where g(λ) = R(x + λ dx)·dx is within CP_TOLERANCE of g(0) = R(x)·dx,
    or at the full step while the energy still falls; the step then converges."""
    # edge cells of 0.02: on the scene's 0.005 the whole settlement in one step takes more
    # than 25 iterations
    problem = make_problem("strip-footing-von-mises", "loading.steps=1", "mesh.edge_size=0.02",
                           "solver.line_search=cp")
    newton = problem.newton
    problem.set_load_factor(1.0)
    x = problem.w.vector.copy()
    newton.residual(newton._b)
    newton._newton_step()
    g0 = -newton._b.dot(newton._dx)
    assert g0 < 0.0                                     # a descent direction of the energy
    full = x.copy()
    full.axpy(1.0, newton._dx)
    newton._critical_point(x, 0.0, 0.0)
    g = newton._b.dot(newton._dx)
    took_full_step = np.allclose(problem.w.vector.array, full.array, rtol=0, atol=1e-14)
    assert abs(g) <= CP_TOLERANCE * abs(g0) or (g < 0.0 and took_full_step)
    problem.roll_back()
    assert problem.solve().iterations <= 25


def test_the_tangent_floor_moves_newtons_matrix_and_not_its_solution():
    """solver.tangent_floor = ε: every cap point's tangent in the forms is C_tan + ε C_el,
    the residual at an iterate is the same to the bit, and the curve is the same to the
    residual floor (the floor changes the path of Newton's iterates only)."""
    floor = 1e-4
    tangents, curves, residuals = {}, {}, {}
    for eps in (0.0, floor):
        problem = make_problem("tine-2in-90deg", *COARSE_TINE, "solver.atol=1e-10",
                               f"solver.tangent_floor={eps}")
        rng = np.random.default_rng(5)
        problem.w.x.array[:] = 1e-3 * rng.standard_normal(len(problem.w.x.array))
        for bc in problem.bcs:   # an iterate that meets the supports: no lifting by the matrix
            problem.w.x.array[bc.dof_indices()[0]] = 0.0
        b = problem.w.vector.duplicate()
        problem.newton.residual(b)
        residuals[eps] = b.array.copy()
        tangents[eps] = problem.points._tangent.copy()
        problem.w.x.array[:] = 0.0
        result = run_load_steps(problem, 2, 3, lambda r: None)
        assert result.complete
        curves[eps] = np.array([(r.load_factor, r.force) for r in result.steps])
    assert np.array_equal(residuals[floor], residuals[0.0])
    (model,) = problem.points.models.values()
    lifted = tangents[floor] - tangents[0.0]
    assert np.allclose(lifted, floor * model.stiffness, rtol=1e-6, atol=1e-9 * np.abs(model.stiffness).max())
    assert curves[floor][:, 0] == pytest.approx(curves[0.0][:, 0], rel=1e-12)
    assert curves[floor][:, 1] == pytest.approx(curves[0.0][:, 1], rel=1e-6)
    # raised during a run (a remesh's re-equilibration), the floor lifts the last converged
    # tangent too, which the next step's first iterate takes
    converged = problem.points._converged_tangent.copy()
    problem.points.floor_tangent(3 * floor)
    assert np.allclose(problem.points._converged_tangent - converged, 2 * floor * model.stiffness,
                       rtol=1e-6, atol=1e-9 * np.abs(model.stiffness).max())


def test_regions_of_interleaved_cells_update_as_one_region():
    """The soil's cells split into two regions of alternate cells (updated through index
    arrays) give the stress and tangent of the one region (updated through a slice), to the
    bit, at a plastic iterate."""
    from soilbin.solver.quadrature import MaterialPoints
    problem = make_problem("block-drucker-prager")
    one = problem.points
    (name, model), = one.models.items()
    cells = np.unique(one.index[name] // one.points_per_cell)
    split = {"even": cells[0::2], "odd": cells[1::2]}
    two = MaterialPoints(problem.disc, problem.w, problem.w_committed,
                         problem.kinematics.strain_increment(), split,
                         {"even": model, "odd": model})
    two.start()
    assert isinstance(one._parts[name], slice)
    assert all(isinstance(part, np.ndarray) for part in two._parts.values())
    rng = np.random.default_rng(3)
    problem.w.x.array[:] = 2e-2 * rng.standard_normal(len(problem.w.x.array))
    one.update()
    two.update()
    assert np.any(one.trial[name]["yield_state"] > 0.0)   # some points returned
    assert np.array_equal(one._stress, two._stress)
    assert np.array_equal(one._tangent, two._tangent)


@pytest.mark.parametrize("scene, element", [("strip-footing-von-mises", "quad4-bbar"),
                                            ("strip-footing-von-mises", "tri6"),
                                            ("block-drucker-prager", "hex8-bbar"),
                                            ("block-drucker-prager", "tet10-bbar")])
def test_the_strain_increment_is_the_difference_evaluated_at_once_to_the_bit(scene, element):
    """ε̄(w) − ε̄(w_n) at the points, ε̄(w_n) evaluated once a step, is FFCx's evaluation of the
    difference to the bit, and follows w_n when it changes."""
    from dolfinx import fem
    problem = make_problem(scene, f"analysis.element={element}")
    points, (strain, strain_n) = problem.points, problem.kinematics.strain_increment()
    difference = fem.Expression(strain - strain_n, points._points)
    rng = np.random.default_rng(5)
    w, w_n = problem.w.x.array, problem.w_committed.x.array
    for _ in range(2):   # a step's two iterates, then the next step's
        w_n[:] = 1e-3 * rng.standard_normal(len(w_n))
        for _ in range(2):
            w[:] = w_n + 1e-4 * rng.standard_normal(len(w))
            assert np.array_equal(points.strain_increment(), points.evaluate(difference))
