"""Least-squares fit of a model's parameters to laboratory curves, and what the fit
says about them.

Each test's model curve is the material-point driver's own (:func:`drive`) along the
test's path; it is interpolated at the measured ``x`` and each compared column is
scaled by its measured range, so that stresses and strains weigh alike. All tests form
one residual vector for ``scipy.optimize.least_squares`` (trust-region reflective,
bounds). Columns are those of path.csv: compression positive.
"""
import dataclasses
import time

import numpy as np
from scipy.optimize import least_squares

from ..errors import ConvergenceError, InputError, ReturnMapError
from ..material_point.driver import drive

#: Scaled residual of every point of a test whose model curve cannot be computed at
#: the trial parameters (the driver fails, or the model refuses them): large against
#: the scaled misfit of a curve, about 1, so the trust region steps back.
FAILED_RESIDUAL = 1.0e3
#: A singular value of the Jacobian scaled to unit columns below this fraction of the
#: largest one, or a correlation above CORRELATION_MAX: the data do not fix the parameter.
SINGULAR_RTOL = 1.0e-4
CORRELATION_MAX = 0.99
#: The tests that fix a parameter, by its name (said next to an unidentified parameter).
FIXED_BY = {
    "E": "the initial slope of a triaxial test (q against eps_axial)",
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


#: What leaves a test without a model curve at trial parameters: the driver's failures and
#: a parameter set the model refuses (e.g. psi > phi, lam <= kappa).
CURVE_FAILURES = (CurveFailed, ConvergenceError, ReturnMapError, InputError)


def model_curve(model, test):
    """(x, (n, len(y)) columns) of the driver's rows along the test's path."""
    result = drive(model, test.path_params, test.path_name)
    if not result.converged:
        raise CurveFailed(result.message)
    table = np.array([[row[c] for c in (test.x, *test.y)] for row in result.rows])
    return table[:, 0], table[:, 1:]


def fitted_columns(model, test):
    """(n, len(y)) model values at the measured x."""
    return at_measured(test, *model_curve(model, test))


def at_measured(test, x, columns):
    """The model curve (x, columns) at the measured x; the curve's x must increase."""
    if np.any(np.diff(x) < 0):
        raise CurveFailed(f"{test.x} of the model curve does not increase along the path")
    at = test.measured[test.x]
    return np.column_stack([np.interp(at, x, columns[:, j]) for j in range(columns.shape[1])])


def measured_columns(test):
    return np.column_stack([test.measured[c] for c in test.y])


def curve_residuals(model, test):
    """The test's scaled, weighted residuals (fitted - measured), FAILED_RESIDUAL where
    its model curve cannot be computed."""
    measured = measured_columns(test)
    if model is None:
        return np.full(measured.size, FAILED_RESIDUAL)
    try:
        fitted = fitted_columns(model, test)
    except CURVE_FAILURES:
        return np.full(measured.size, FAILED_RESIDUAL)
    return (test.weight * (fitted - measured) / test.scale).ravel()


def residuals(values, calibration):
    """The residual vector of all tests at the fitted parameter ``values``."""
    try:
        model = calibration.model(values)
    except InputError:   # e.g. psi > phi, lam <= kappa at a trial point
        model = None
    return np.concatenate([curve_residuals(model, t) for t in calibration.tests])


@dataclasses.dataclass
class Fit:
    values: np.ndarray
    converged: bool
    message: str
    nfev: int
    njev: int
    residuals: np.ndarray
    jacobian: np.ndarray
    wall_s: float


def fit(calibration):
    """Least squares from the start values within the bounds."""
    start = time.perf_counter()
    result = least_squares(residuals, calibration.start, args=(calibration,), method="trf",
                           bounds=(calibration.lower, calibration.upper), x_scale="jac")
    return Fit(result.x, result.status > 0, result.message, int(result.nfev),
               int(result.njev or 0), result.fun, result.jac, time.perf_counter() - start)


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
