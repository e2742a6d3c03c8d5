"""Least-squares fit of a model's parameters to laboratory curves, and what the fit
says about them.

Each test's model curve is the material-point driver's own along the test's path (the
paths of one trial driven together, :func:`drive_all`); it is interpolated at the measured
``x``, leg by leg, and each compared column is scaled by its measured range, so that
stresses and strains weigh alike. All tests form one residual vector for
``scipy.optimize.least_squares`` (trust-region reflective, bounds) with a forward-difference
Jacobian (:func:`jacobian`) whose trials may run in several processes. Columns are those of
path.csv: compression positive.
"""
import contextlib
import dataclasses
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from scipy.optimize import least_squares

from ..errors import InputError
from ..launcher import mpi_world
from ..material_point.driver import drive_all
from .problem import strains_from_leg

#: Scaled residual of every point of a test whose model curve cannot be computed at
#: the trial parameters (the driver fails, or the model refuses them): large against
#: the scaled misfit of a curve, about 1, so the trust region steps back.
FAILED_RESIDUAL = 1.0e3
#: A singular value of the Jacobian scaled to unit columns below this fraction of the
#: largest one, or a correlation above CORRELATION_MAX: the data do not fix the parameter.
SINGULAR_RTOL = 1.0e-4
CORRELATION_MAX = 0.99
#: Relative step of the Jacobian's finite differences: the model curves are converged to
#: a relative 1e-10 (the driver's RTOL), so their derivatives to about 1e-4.
DIFF_STEP = 1.0e-6
#: The fit stops when the parameters are within about this many standard errors of the
#: optimum (:func:`relative_ftol`): closer is below what the data say.
FTOL_SE = 0.1
#: The tests that fix a parameter, by its name (said next to an unidentified parameter).
FIXED_BY = {
    "E": "the slope of an unloading leg, or the elastic start of a triaxial test",
    "nu": "a triaxial test with its eps_v, or an oedometer test (with E)",
    "c": "triaxial tests at two or more confining pressures (q at failure)",
    "phi": "triaxial tests at two or more confining pressures (q at failure)",
    "psi": "the eps_v of a triaxial test after failure (dilatancy)",
    "A": "triaxial tests at three or more confining pressures (q at failure)",
    "C": "triaxial tests at three or more confining pressures (q at failure)",
    "beta": "triaxial tests at three or more confining pressures (q at failure)",
    "R": "a triaxial test at a high confining pressure (its eps_v) with a hydrostatic test",
    "W": "a hydrostatic test to a high pressure (W and D)",
    "D": "a hydrostatic test (W and D)",
    "lam": "an isotropic compression test (eps_v against ln p)",
    "kappa": "an isotropic test with unloading",
    "M": "a triaxial test to the critical state",
}


class CurveFailed(Exception):
    """The model curve of a test cannot be computed at the trial parameters."""


@dataclasses.dataclass(frozen=True)
class Curve:
    """A test's model curve: the driver's rows along its path, each with its leg."""
    legs: np.ndarray     # (n,) leg of each row ('initial' first)
    x: np.ndarray        # (n,)
    columns: np.ndarray  # (n, len(y))

    def leg(self, name):
        """(x, columns) of the leg ``name`` from the row it starts at (the last one of the
        leg before); the whole curve for ''."""
        rows = np.flatnonzero(self.legs == name) if name else np.arange(self.legs.size)
        rows = np.concatenate([[rows[0] - 1], rows]) if rows.size and rows[0] > 0 else rows
        return self.x[rows], self.columns[rows]


def model_curves(model, tests):
    """The :class:`Curve` of every test at ``model`` (a :class:`CurveFailed` where the
    driver fails): all paths driven together (:func:`drive_all`)."""
    try:
        results = drive_all(model, [(t.path_params, t.path_name) for t in tests])
    except InputError as err:   # the model cannot start from a test's initial state
        return [CurveFailed(str(err))] * len(tests)
    curves = []
    for test, result in zip(tests, results):
        if not result.converged:
            curves.append(CurveFailed(result.message))
            continue
        columns = (test.x, *test.y)
        table = np.array([[row[c] for c in columns] for row in result.rows])
        legs = np.array([row["leg"] for row in result.rows])
        if test.strains_from:
            table = strains_from_leg(table, columns, legs, test.strains_from)
        curves.append(Curve(legs, table[:, 0], table[:, 1:]))
    return curves


def at_measured(test, curve):
    """(n, len(y)) model values at the measured x, leg by leg; raises the curve's
    CurveFailed, or one where its x is not monotone along a measured leg."""
    if isinstance(curve, CurveFailed):
        raise curve
    fitted = np.empty((test.legs.size, len(test.y)))
    for leg in np.unique(test.legs):
        x, columns = curve.leg(leg)
        if np.all(np.diff(x) <= 0):   # an unloading leg: x decreases
            x, columns = x[::-1], columns[::-1]
        if x.size < 2 or np.any(np.diff(x) < 0):
            raise CurveFailed(f"{test.x} of the model curve is not monotone along leg {leg!r}"
                              if leg else
                              f"{test.x} of the model curve is not monotone along the path; "
                              f"give the data a 'leg' column naming each row's leg of it")
        at = test.measured[test.x][test.legs == leg]
        fitted[test.legs == leg] = np.column_stack([np.interp(at, x, columns[:, j])
                                                    for j in range(columns.shape[1])])
    return fitted


def measured_columns(test):
    return np.column_stack([test.measured[c] for c in test.y])


def curve_residuals(test, curve):
    """The test's scaled, weighted residuals (fitted - measured), FAILED_RESIDUAL where
    its model curve cannot be computed."""
    measured = measured_columns(test)
    try:
        fitted = at_measured(test, curve)
    except CurveFailed:
        return np.full(measured.size, FAILED_RESIDUAL)
    return (test.weight * (fitted - measured) / test.scale).ravel()


def trial_curves(values, calibration):
    """The model curves of every test at the fitted parameter ``values``."""
    try:
        model = calibration.model(values)
    except InputError as err:   # e.g. psi > phi, lam <= kappa at a trial point
        return [CurveFailed(str(err))] * len(calibration.tests)
    return model_curves(model, calibration.tests)


def residuals(values, calibration):
    """The residual vector of all tests at the fitted parameter ``values``."""
    return np.concatenate([curve_residuals(t, c) for t, c in
                           zip(calibration.tests, trial_curves(values, calibration))])


def check_start(calibration):
    """InputError naming the first test whose model curve cannot be compared with its
    data at the start values: the fit would have nothing to start from."""
    for test, curve in zip(calibration.tests, trial_curves(calibration.start, calibration)):
        try:
            at_measured(test, curve)
        except CurveFailed as err:
            raise InputError(f"{calibration.file}: test {test.name!r} at the start values: "
                             f"{err}") from None


@dataclasses.dataclass
class Fit:
    values: np.ndarray
    converged: bool
    message: str
    nfev: int
    njev: int
    evaluations: int   # of every test's model curve: the fit's and its Jacobians'
    jobs: int          # processes (or MPI ranks) of the Jacobian's evaluations
    residuals: np.ndarray
    jacobian: np.ndarray
    wall_s: float


def fit(calibration, jobs=1):
    """Least squares from the start values within the bounds; the Jacobian's columns
    evaluated by ``jobs`` processes, or by the MPI ranks under an MPI launcher. The fit stops when the cost falls by less than a
    change of FTOL_SE standard errors in the parameters would make it fall."""
    start = time.perf_counter()
    last = {"evaluations": 0}   # the residuals at the last trial: the base of its Jacobian

    def fun(values):
        last["values"], last["r"] = values.copy(), residuals(values, calibration)
        last["evaluations"] += 1
        return last["r"]

    comm = mpi_world()
    jobs = comm.size if comm is not None else min(jobs, len(calibration.fitted))
    with _trial_map(jobs) as trial_map:
        def jac(values):
            r = last["r"] if np.array_equal(values, last.get("values")) else fun(values)
            J, evaluations = jacobian(values, r, calibration, trial_map)
            last["evaluations"] += evaluations
            return J

        result = least_squares(fun, calibration.start, jac=jac, method="trf",
                               bounds=(calibration.lower, calibration.upper), x_scale="jac",
                               ftol=relative_ftol(calibration),
                               max_nfev=calibration.max_evaluations)
    return Fit(result.x, result.status > 0, result.message, int(result.nfev),
               int(result.njev or 0), last["evaluations"], jobs, result.fun, result.jac,
               time.perf_counter() - start)


def relative_ftol(calibration):
    """ftol of least_squares (a relative fall of the cost F = r.r / 2): near the optimum a
    change d of the parameters lowers F by F sum((d / se)^2) / (m - n), with m residuals, n
    parameters and se their standard errors; F then falls by less than FTOL_SE^2 F / (m - n)
    when the parameters are within about FTOL_SE standard errors of it."""
    return FTOL_SE ** 2 / max(calibration.residual_count - len(calibration.fitted), 1)


@contextlib.contextmanager
def _trial_map(jobs):
    """map(residuals at trial values): over the MPI ranks (each one's share, then gathered
    by all: every rank goes on with the same Jacobian), over ``jobs`` forked processes, or
    in this one."""
    comm = mpi_world()
    if comm is not None:
        def over_ranks(calibration, trials):
            mine = [residuals(t, calibration) for t in trials[comm.rank::comm.size]]
            shares = comm.allgather(mine)
            return [shares[k % comm.size][k // comm.size] for k in range(len(trials))]
        yield over_ranks
    elif jobs <= 1:
        yield lambda calibration, trials: [residuals(t, calibration) for t in trials]
    else:
        with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork")) as pool:
            yield lambda calibration, trials: list(pool.map(residuals, trials,
                                                            [calibration] * len(trials)))


def jacobian(values, r, calibration, trial_map):
    """Forward differences of the residuals ``r`` at ``values``, each step of DIFF_STEP
    times the parameter's size; backwards where the forward step leaves the bounds or a
    model curve fails there (a parameter on the edge of the set the model accepts, e.g.
    C = A of a cohesionless cap, whose curves cannot start beyond it). A column whose
    curves fail on both sides is zero: the parameter is reported unidentified. The
    trials of each side go to ``trial_map`` together. Returns (Jacobian, evaluations)."""
    h = DIFF_STEP * np.maximum(np.abs(values), 1e-3 * (calibration.upper - calibration.lower))
    columns, todo, evaluations = np.zeros((r.size, values.size)), list(range(values.size)), 0
    for sign in (1.0, -1.0):
        tried = [i for i in todo
                 if calibration.lower[i] <= values[i] + sign * h[i] <= calibration.upper[i]]
        trials = [values + sign * h[i] * np.eye(values.size)[i] for i in tried]
        for i, r_step in zip(tried, trial_map(calibration, trials)):
            if not np.any(r_step == FAILED_RESIDUAL):
                columns[:, i] = (r_step - r) / (sign * h[i])
                todo.remove(i)
        evaluations += len(trials)
    return columns, evaluations


def residual_variance(r, n_parameters):
    return float(r @ r) / max(r.size - n_parameters, 1)


def covariance(jacobian, variance):
    """(covariance, identified) from the Jacobian's singular values: s^2 (J^T J)^+ over the
    singular values above SINGULAR_RTOL of the largest; ``identified`` per parameter is
    False for those in the span of a dropped singular vector. Computed on the Jacobian
    with unit column norms, so the threshold does not depend on the parameters' units."""
    scale = np.linalg.norm(jacobian, axis=0)
    scale[scale == 0] = 1.0
    _, s, vt = np.linalg.svd(jacobian / scale, full_matrices=False)
    kept = s > SINGULAR_RTOL * s[0] if s.size and s[0] > 0 else np.zeros(s.size, bool)
    v = vt[kept].T / s[kept]
    cov = variance * (v @ v.T) / np.outer(scale, scale)
    identified = np.all(np.abs(vt[~kept]) < 0.1, axis=0)
    return cov, identified


def correlation(cov):
    sd = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(np.outer(sd, sd) > 0, cov / np.outer(sd, sd), 0.0)


def unidentified(names, identified, corr):
    """{name: reason} of the parameters the data do not fix."""
    found = {}
    for i, name in enumerate(names):
        partners = [names[j] for j in range(len(names))
                    if j != i and abs(corr[i, j]) > CORRELATION_MAX]
        if not identified[i]:
            reason = "near-zero singular value of the scaled Jacobian"
        elif partners:
            reason = f"correlation above {CORRELATION_MAX} with {', '.join(partners)}"
        else:
            continue
        hint = FIXED_BY.get(name)
        found[name] = reason + (f"; fixed by {hint}" if hint else "")
    return found


def rms(r):
    return float(np.sqrt(np.mean(r ** 2))) if r.size else 0.0


def rms_per_test(calibration, r):
    """{test name: rms of its scaled residuals}."""
    sizes = [measured_columns(t).size for t in calibration.tests]
    parts = np.split(r, np.cumsum(sizes)[:-1])
    return {t.name: rms(p) for t, p in zip(calibration.tests, parts)}
