"""Return-mapping parts shared by the isotropic two-invariant soil models
(Cam-Clay, modified Cam-Clay, the DiMaggio–Sandler and modified caps),
per point and compiled (:mod:`soilbin.models.jit`).

Inside these models the geomechanics convention is used, compression positive::

    p = -tr(sigma) / 3,   J = sqrt(J2) = |s| / sqrt2,   I1 = 3 p,   e_v = -tr(deps),

and the stress goes back to the code's tension-positive Mandel vector as::

    sigma = -p I + s_tr J / J_tr = -p I + sqrt2 J n,   n = s_tr / |s_tr|:

an associated return with isotropic elasticity and a yield function of
(p, J) keeps the deviatoric direction of the trial stress, so every local
problem is one in the (p, J) plane.

Elasticity (the parameter vector's volumetric law, :mod:`.yield_surfaces`):
a constant shear modulus G, so J_tr = ``|s_n + 2G dev(deps)|`` / sqrt2, and a
volumetric law written through the elastic volumetric strain E(p; p_n) that
takes the mean stress from p_n to p (linear: (p - p_n)/K; exponential, the
kappa-line of critical-state soil mechanics: kappa* ln((p + p_min)/(p_n + p_min))).
The plastic compaction of a step is then de_v - E(p; p_n), exactly, for
either law.

Local problem on one smooth surface f(p, J, h) = 0 with associated flow and
one scalar hardening variable h (:func:`smooth_return`, backward Euler):

    r_p = E(p; p_n) - de_v + dgamma f_p      volumetric strain split
    r_J = (J - J_tr) / G + dgamma f_J        deviatoric strain split
    r_f = f(p, J, h)                         consistency
    r_h = r_h(h, dgamma f_p)                 hardening driven by the plastic compaction

(dgamma f_p is the plastic compaction, dgamma f_J the plastic shear strain
conjugate to J; dgamma >= 0 at a solution.) The surface and the hardening law
are the model's (:func:`.yield_surfaces.smooth_surface`,
:func:`.yield_surfaces.hardening_law`); the residual and its Jacobian are
:func:`local_residual`'s. It is solved by :func:`local_newton`, a Newton
iteration with a backtracking line search on the scaled residual. The
converged Jacobian gives, by the implicit-function theorem, the sensitivities
of (p, J) to the two inputs (de_v, J_tr), and with them the consistent tangent
(:func:`invariant_tangent`)

    C = p_e I(x)I - sqrt2 G p_J I(x)n - sqrt2 J_e n(x)I + 2G J_J n(x)n
        + 2G (J / J_tr) (P_dev - n(x)n),

p_e = dp/de_v, p_J = dp/dJ_tr, J_e = dJ/de_v, J_J = dJ/dJ_tr, from
dsigma = -dp I + sqrt2 dJ n + sqrt2 J dn, de_v = -I.deps, dJ_tr = sqrt2 G n.deps
and dn = (sqrt2 G / J_tr)(P_dev - n(x)n) deps. Corners and vertices, where
(p, J) is fixed or given by a scalar equation, use the same formula with
their own sensitivities.

Robustness: the Newton iteration is globalised by backtracking on the
residual norm; points where it still fails (a trial state far outside a
strongly nonlinear surface) are solved again by continuation in the fraction
of the strain increment, from the point where the trial path leaves the
elastic domain (:func:`continuation`) - the answer is still the one-step
backward-Euler solution, so the tangent is unchanged. Roots with a negative
multiplier or J < 0 are rejected. Scalar problems (the failure surface of
the caps, the Cam-Clay reduction) use a bracketed Newton-bisection
(:func:`bracketed_root`). A local solve that does not converge is counted; the
model raises :class:`ReturnMapError` naming itself and the number of failing
points (:func:`check_converged`), and the step driver cuts the step.

The per-point local problem travels as a tuple ``lp`` (its slots :data:`P_N` ..
:data:`STRAIN_ROW`); the local solver's limits as the integer array
:func:`local_settings`, read when a model is called (so that a test may shorten them).
"""
import math

import numpy as np

from ..errors import ReturnMapError
from ..tensors import P_DEV, SQRT2
from .jit import kernel
from .yield_surfaces import (EXPONENTIAL, G_, K_, KAPPA_STAR, LOG_SHIFT, P_MIN, hardening_law,
                             smooth_surface, surface_admissible)

#: Trial states with f_tr below this fraction of the stress scale are elastic.
YIELD_TOL = 1e-12
#: Local Newton: tolerance on the scaled residual, iterations, line-search halvings.
NEWTON_TOL = 1e-12
MAX_ITERATIONS = 60
MAX_HALVINGS = 40
#: Residual a stalled line search still accepts as converged (rounding floor).
STALL_TOL = 1e-10
#: Continuation: numbers of equal parts of the plastic part of the step tried in turn.
CONTINUATION_PARTS = (4, 16, 64, 256)

#: Slots of the local problem ``lp`` of one point: the step's start p_n, its volumetric
#: strain de_v and trial J_tr, the committed hardening variable h_n, the stress scale, the
#: surface's and the hardening law's per-point constants (p_c,n; H_n), the strain
#: residuals' scale.
P_N, DE_V, J_TR, H_N, SCALE, PC_N, H_COMMITTED, STRAIN_ROW = range(8)


def local_settings():
    """The local solver's limits: iterations, halvings, then the continuation's parts."""
    return np.array((MAX_ITERATIONS, MAX_HALVINGS) + CONTINUATION_PARTS, dtype=np.int64)


# --- the volumetric law and the pressure variable -----------------------------------------

@kernel
def bulk_pressure(prm, p_n, e):
    """p after the elastic volumetric strain e from p_n."""
    if prm[EXPONENTIAL] == 1.0:
        return (p_n + prm[P_MIN]) * math.exp(min(e / prm[KAPPA_STAR], 700.0)) - prm[P_MIN]
    return p_n + prm[K_] * e


@kernel
def bulk_strain(prm, p, p_n):
    """E(p; p_n): the elastic volumetric strain taking p_n to p."""
    if prm[EXPONENTIAL] == 1.0:
        return prm[KAPPA_STAR] * np.log((p + prm[P_MIN]) / (p_n + prm[P_MIN]))
    return (p - p_n) / prm[K_]


@kernel
def bulk_strains(prm, p, p_n, out):
    """:func:`bulk_strain` at every point: out[i] = E(p[i]; p_n[i])."""
    for i in range(len(p)):
        out[i] = bulk_strain(prm, p[i], p_n[i])


@kernel
def bulk_compliance(prm, p):
    """dE/dp = 1 / K(p)."""
    if prm[EXPONENTIAL] == 1.0:
        return prm[KAPPA_STAR] / (p + prm[P_MIN])
    return 1.0 / prm[K_]


@kernel
def bulk_admissible(prm, p):
    if prm[EXPONENTIAL] == 1.0:
        return p + prm[P_MIN] > 0.0
    return np.isfinite(p)


@kernel
def pressure(prm, xi):
    """(p, dp/dxi) of the local Newton's pressure variable: p = exp(xi) - shift, or xi."""
    if math.isnan(prm[LOG_SHIFT]):
        return xi, 1.0
    e = math.exp(xi)
    return e - prm[LOG_SHIFT], e


@kernel
def pressure_variable(prm, p):
    """xi of p (the inverse of :func:`pressure`)."""
    if math.isnan(prm[LOG_SHIFT]):
        return p
    return math.log(p + prm[LOG_SHIFT])


# --- the elastic predictor and the response -------------------------------------------------

@kernel
def trial_split(prm, deps, stress_n, s_n, s_tr, n):
    """The elastic predictor in invariants: fills the deviators s_n, s_tr and the unit
    direction n (zero where s_tr = 0); returns (p_n, de_v, J_tr), compression positive."""
    G = prm[G_]
    p = (stress_n[0] + stress_n[1] + stress_n[2]) / 3.0
    e = (deps[0] + deps[1] + deps[2]) / 3.0
    norm2 = 0.0
    for k in range(6):
        s_n[k] = stress_n[k] - p if k < 3 else stress_n[k]
        s_tr[k] = s_n[k] + 2.0 * G * (deps[k] - e if k < 3 else deps[k])
        norm2 += s_tr[k] ** 2
    norm = math.sqrt(norm2)
    for k in range(6):
        n[k] = s_tr[k] / norm if norm > 0.0 else s_tr[k]
    return -p, -(deps[0] + deps[1] + deps[2]), norm / SQRT2


@kernel
def point_invariants(stress):
    """(p, J) of one Mandel stress, compression-positive p, J = sqrt(s:s / 2)."""
    p = (stress[0] + stress[1] + stress[2]) / 3.0
    ss = 0.0
    for k in range(6):
        ss += (stress[k] - p) ** 2 if k < 3 else stress[k] ** 2
    return -p, math.sqrt(0.5 * ss)


@kernel
def invariants_into(stress, p, J):
    for i in range(stress.shape[0]):
        p[i], J[i] = point_invariants(stress[i])


def invariants(stress):
    """(p, J) of (n, 6) stresses (:func:`point_invariants`): the initial states' numbers."""
    p, J = np.empty(len(stress)), np.empty(len(stress))
    invariants_into(np.ascontiguousarray(stress, dtype=float), p, J)
    return p, J


@kernel
def solved_ratio(J, J_tr, J_J):
    """J / J_tr of a local solve: as J_tr -> 0 on a smooth surface it tends to dJ/dJ_tr."""
    return J / J_tr if J_tr > 0.0 else J_J


@kernel
def fixed_ratio(J, J_tr):
    """J / J_tr where (p, J) is fixed by the geometry (apex, corner, vertex)."""
    return J / J_tr if J_tr > 0.0 else 0.0


@kernel
def invariant_tangent(p_e, p_J, J_e, J_J, ratio, n, G, C):
    """The consistent tangent of the module doc from the (p, J) sensitivities, into C (6, 6)."""
    two_g_ratio = 2.0 * G * ratio
    I_n, n_I = SQRT2 * G * p_J, SQRT2 * J_e      # I (x) n, n (x) I
    n_n = 2.0 * G * J_J - two_g_ratio            # n (x) n
    for i in range(6):
        for j in range(6):
            c = two_g_ratio * P_DEV[i, j]
            if i < 3 and j < 3:
                c += p_e
            if i < 3:
                c -= I_n * n[j]
            if j < 3:
                c -= n_I * n[i]
            C[i, j] = c + n_n * n[i] * n[j]


@kernel
def finish(prm, p, ratio, sens, plastic, s_tr, n, p_n, de_v, J_tr, sigma, C):
    """Write the stress sigma = s_tr J / J_tr - p I and the tangent C of a point from its
    response (p, ratio J / J_tr, sensitivities (p_e, p_J, J_e, J_J)); returns the plastic
    compaction de_v - E(p; p_n) and the equivalent plastic strain increment (zero unless
    ``plastic``)."""
    G = prm[G_]
    for k in range(6):
        sigma[k] = s_tr[k] * ratio - (p if k < 3 else 0.0)
    invariant_tangent(sens[0], sens[1], sens[2], sens[3], ratio, n, G, C)
    if not plastic:
        return 0.0, 0.0
    # Plastic strain: compaction de_v - E(p; p_n) and deviator (s_tr - s) / 2G.
    compaction = de_v - bulk_strain(prm, p, p_n)
    shear = J_tr * (1.0 - ratio) / (SQRT2 * G)
    return compaction, math.sqrt(2.0 / 3.0) * math.sqrt(compaction**2 / 3.0 + shear**2)


# --- small dense solves, on tuples -----------------------------------------------------
#
# The local problem's vectors and its 4 x 4 Jacobian are tuples (rows of 4-tuples): values
# the compiled code keeps in registers, where small arrays would cost an allocation or the
# reference counting of a view at every call.

@kernel
def row_less(row, factor, pivot):
    """row - factor pivot, rows of 6."""
    return (row[0] - factor * pivot[0], row[1] - factor * pivot[1], row[2] - factor * pivot[2],
            row[3] - factor * pivot[3], row[4] - factor * pivot[4], row[5] - factor * pivot[5])


@kernel
def over(value, pivot):
    """value / pivot; zero for a zero pivot (the unknown of a singular column)."""
    return value / pivot if pivot != 0.0 else 0.0


@kernel
def eliminated(row, pivot, k):
    """row less the multiple of the pivot row that zeroes its entry k."""
    return row_less(row, over(row[k], pivot[k]), pivot)


@kernel
def back_substitute(a0, a1, a2, a3, b):
    """x of the upper-triangular rows a0 .. a3 and the right-hand side b."""
    x3 = over(b[3], a3[3])
    x2 = over(b[2] - a2[3] * x3, a2[2])
    x1 = over(b[1] - a1[2] * x2 - a1[3] * x3, a1[1])
    x0 = over(b[0] - a0[1] * x1 - a0[2] * x2 - a0[3] * x3, a0[0])
    return x0, x1, x2, x3


@kernel
def dense_solve(jac, b0, b1):
    """(x0, x1) with jac x0 = b0 and jac x1 = b1 (jac: 4 rows of 4): Gaussian elimination
    with partial pivoting (column by column, the largest entry of the rows below swapped
    up), on rows [jac | b0 | b1]. A zero pivot (a singular column) sets its unknown to zero,
    as MUMPS does with a null pivot."""
    a0 = (jac[0][0], jac[0][1], jac[0][2], jac[0][3], b0[0], b1[0])
    a1 = (jac[1][0], jac[1][1], jac[1][2], jac[1][3], b0[1], b1[1])
    a2 = (jac[2][0], jac[2][1], jac[2][2], jac[2][3], b0[2], b1[2])
    a3 = (jac[3][0], jac[3][1], jac[3][2], jac[3][3], b0[3], b1[3])
    if abs(a1[0]) > abs(a0[0]):
        a0, a1 = a1, a0
    if abs(a2[0]) > abs(a0[0]):
        a0, a2 = a2, a0
    if abs(a3[0]) > abs(a0[0]):
        a0, a3 = a3, a0
    a1, a2, a3 = eliminated(a1, a0, 0), eliminated(a2, a0, 0), eliminated(a3, a0, 0)
    if abs(a2[1]) > abs(a1[1]):
        a1, a2 = a2, a1
    if abs(a3[1]) > abs(a1[1]):
        a1, a3 = a3, a1
    a2, a3 = eliminated(a2, a1, 1), eliminated(a3, a1, 1)
    if abs(a3[2]) > abs(a2[2]):
        a2, a3 = a3, a2
    a3 = eliminated(a3, a2, 2)
    return (back_substitute(a0, a1, a2, a3, (a0[4], a1[4], a2[4], a3[4])),
            back_substitute(a0, a1, a2, a3, (a0[5], a1[5], a2[5], a3[5])))


ZERO4 = (0.0, 0.0, 0.0, 0.0)
IDENTITY4 = ((1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0),
             (0.0, 0.0, 0.0, 1.0))
ZERO44 = (ZERO4, ZERO4, ZERO4, ZERO4)


@kernel
def newton_step(jac, r):
    """-jac^-1 r."""
    x = dense_solve(jac, r, ZERO4)[0]
    return -x[0], -x[1], -x[2], -x[3]


@kernel
def moved(x, step, dx):
    """x + step dx."""
    return x[0] + step * dx[0], x[1] + step * dx[1], x[2] + step * dx[2], x[3] + step * dx[3]


# --- the local problem on one smooth surface ------------------------------------------------

@kernel
def local_residual(prm, lp, de_in, J_in, x):
    """(r, jac): the scaled residual (4,) and Jacobian (4 rows of 4) of the local problem
    (module doc) at x = (xi, J, dgamma, h), for the inputs de_in, J_in."""
    G = prm[G_]
    xi, J, dg, h = x
    p, dp = pressure(prm, xi)
    f, f_p, f_J, f_h, f_pp, f_pJ, f_JJ, f_ph, f_Jh = smooth_surface(prm, p, J, h, lp[PC_N])
    dg_p = dg * f_p
    rh, rh_h, rh_c = hardening_law(prm, h, dg_p, lp[H_COMMITTED])
    c = bulk_compliance(prm, p)
    dg_pp, dg_pJ, dg_ph = dg * f_pp, dg * f_pJ, dg * f_ph
    row, f_row = lp[STRAIN_ROW], 1.0 / lp[SCALE]     # residuals as relative strains
    r = (row * (bulk_strain(prm, p, lp[P_N]) - de_in + dg_p),
         row * ((J - J_in) / G + dg * f_J),
         f_row * f,
         row * rh)
    jac = ((row * ((c + dg_pp) * dp), row * dg_pJ, row * f_p, row * dg_ph),
           (row * (dg_pJ * dp), row * (1.0 / G + dg * f_JJ), row * f_J, row * (dg * f_Jh)),
           (f_row * (f_p * dp), f_row * f_J, 0.0, f_row * f_h),
           (row * (rh_c * dg * f_pp * dp), row * (rh_c * dg * f_pJ), row * (rh_c * f_p),
            row * (rh_h + rh_c * dg * f_ph)))
    return r, jac


@kernel
def local_admissible(prm, x):
    p = pressure(prm, x[0])[0]
    return bulk_admissible(prm, p) and surface_admissible(prm, p, x[1], x[3])


@kernel
def max_abs(r):
    return max(abs(r[0]), abs(r[1]), abs(r[2]), abs(r[3]))


@kernel
def merit(r):
    """``|r|^2 / 2``."""
    return 0.5 * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3])


@kernel
def all_finite(jac):
    for i in range(4):
        for j in range(4):
            if not np.isfinite(jac[i][j]):
                return False
    return True


@kernel
def line_search(prm, lp, de_in, J_in, x, dx, r, halvings):
    """The Newton step dx from x (residual r there), halved until the merit ``|r|^2 / 2``
    decreases (Armijo) at an admissible point. Returns (moved, x, r, jac) there."""
    m0 = merit(r)
    step = 1.0
    for _ in range(halvings):
        x_try = moved(x, step, dx)
        r_try, jac_try = local_residual(prm, lp, de_in, J_in, x_try)
        m = merit(r_try)
        if (local_admissible(prm, x_try) and np.isfinite(m) and all_finite(jac_try)
                and m <= (1.0 - 1e-4 * step) * m0):
            return True, x_try, r_try, jac_try
        step *= 0.5
    return False, x, r, ZERO44


@kernel
def local_newton(prm, lp, de_in, J_in, x, settings):
    """Line-searched Newton from x. A converged point gets one more full step (to
    rounding accuracy) where that does not increase the residual. Returns (x, the
    Jacobian there (zero if not converged), converged)."""
    r, jac = local_residual(prm, lp, de_in, J_in, x)
    converged = False
    for _ in range(settings[0]):
        norm = max_abs(r)
        if norm <= NEWTON_TOL:
            converged = True
            break
        ok, x_try, r_try, jac_try = line_search(prm, lp, de_in, J_in, x, newton_step(jac, r),
                                                r, settings[1])
        if not ok:
            converged = norm <= STALL_TOL     # stalled at the rounding floor
            break
        x, r, jac = x_try, r_try, jac_try
    if not converged:
        return x, ZERO44, False
    # Polish with one more full step.
    x_try = moved(x, 1.0, newton_step(jac, r))
    r_try, jac_try = local_residual(prm, lp, de_in, J_in, x_try)
    norm_t = max_abs(r_try)
    if local_admissible(prm, x_try) and np.isfinite(norm_t) and norm_t <= max_abs(r):
        return x_try, jac_try, True
    return x, jac, True


@kernel
def is_solution(prm, lp, x):
    """A root that is a solution: J >= 0 and dgamma >= 0 up to rounding."""
    return (x[1] >= -NEWTON_TOL * lp[SCALE]
            and x[2] >= -NEWTON_TOL * (abs(lp[DE_V]) + lp[J_TR] / prm[G_]))


@kernel
def trial_path(prm, lp, s_n, s_tr, t):
    """(de_v, J_tr, xi_tr) at the fraction t of the step."""
    ss = 0.0
    for k in range(6):
        ss += (s_n[k] + t * (s_tr[k] - s_n[k])) ** 2
    p = bulk_pressure(prm, lp[P_N], t * lp[DE_V])
    return t * lp[DE_V], math.sqrt(ss) / SQRT2, pressure_variable(prm, p)


@kernel
def f_path(prm, lp, s_n, s_tr, t):
    """f at the fraction t of the trial path, with the committed hardening."""
    _, J, xi = trial_path(prm, lp, s_n, s_tr, t)
    return smooth_surface(prm, pressure(prm, xi)[0], J, lp[H_N], lp[PC_N])[0]


@kernel
def continuation(prm, lp, s_n, s_tr, settings):
    """Solve the one-step problem by continuation in the fraction t of the strain
    increment: from the elastic fraction t_e (where the trial path meets the surface and
    the solution is the trial state with dgamma = 0) to t = 1 in N equal parts, each
    Newton solve starting from the last; N grows over the settings' parts while it fails.
    The answer is the one-step backward-Euler solution itself (the intermediate problems
    only lead Newton to it), so the tangent is unchanged. Returns (x, jac, converged)."""
    # Elastic fraction by bisection (t_e = 0 if the step starts outside the surface).
    lo, hi = 0.0, 1.0
    inside = f_path(prm, lp, s_n, s_tr, lo) <= 0.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if f_path(prm, lp, s_n, s_tr, mid) > 0.0:
            hi = mid
        else:
            lo = mid
    t_e = lo if inside else 0.0
    x = ZERO4
    for parts in settings[2:]:
        _, J0, xi0 = trial_path(prm, lp, s_n, s_tr, t_e)
        x = (xi0, J0, 0.0, lp[H_N])
        for k in range(1, parts + 1):
            t = t_e + (1.0 - t_e) * k / parts
            de_in, J_in, _ = trial_path(prm, lp, s_n, s_tr, t)
            x, jac, ok = local_newton(prm, lp, de_in, J_in, x, settings)
            if not ok:
                break
            if k == parts:
                return x, jac, True
    return x, ZERO44, False


@kernel
def smooth_return(prm, lp, s_n, s_tr, x0, fallback, settings):
    """Backward-Euler return onto the model's smooth hardening surface (the local problem
    of the module doc) from x0 = (xi, J, dgamma, h): a Newton solve, again from
    ``fallback`` where it fails (x0 then a warm start from a nearby solution, the fallback
    the trial state; NaN in its first entry: none), then by :func:`continuation`; a root
    with dgamma < 0 or J < 0 is no solution. Returns (p, J, dgamma, h, (p_e, p_J, J_e,
    J_J), converged)."""
    G = prm[G_]
    x, jac, converged = local_newton(prm, lp, lp[DE_V], lp[J_TR], x0, settings)
    converged = converged and is_solution(prm, lp, x)
    if not converged and not math.isnan(fallback[0]):
        x, jac, converged = local_newton(prm, lp, lp[DE_V], lp[J_TR], fallback, settings)
        converged = converged and is_solution(prm, lp, x)
    if not converged:
        x, jac, converged = continuation(prm, lp, s_n, s_tr, settings)
        converged = converged and is_solution(prm, lp, x)
    # Iterates may cross J = 0 or dgamma = 0; a solution may not, beyond rounding.
    J, dgamma = max(x[1], 0.0), max(x[2], 0.0)
    p, dp = pressure(prm, x[0])
    # Implicit-function theorem: the inputs de_v, J_tr enter r_p as -de_v and r_J as -J_tr / G.
    row = lp[STRAIN_ROW]
    d_e, d_J = dense_solve(jac if converged else IDENTITY4, (row, 0.0, 0.0, 0.0),
                           (0.0, row / G, 0.0, 0.0))
    return p, J, dgamma, x[3], (dp * d_e[0], dp * d_J[0], d_e[1], d_J[1]), converged


@kernel
def strain_row(prm, p_tr, stress_scale):
    """The scale of the strain residuals: max(K(p_tr), G) / stress scale."""
    K_ref = 1.0 / bulk_compliance(prm, p_tr) if bulk_admissible(prm, p_tr) else 0.0
    return max(K_ref, prm[G_]) / stress_scale


def bracketed_root(equation):
    """The compiled root finder of the scalar equation g(x) = 0, ``equation(x, args)`` ->
    (g, g'): ``root(args, lo, hi, x0)`` with g(lo) <= 0 <= g(hi) takes Newton steps kept
    inside the shrinking bracket, bisection otherwise, from x0 (NaN: the bracket's middle);
    it returns (x, converged)."""
    @kernel
    def root(args, lo, hi, x0):
        x = 0.5 * (lo + hi) if math.isnan(x0) else min(max(x0, lo), hi)
        eps = np.finfo(np.float64).eps
        for _ in range(300):
            g, dg = equation(x, args)
            if g < 0.0:
                lo = x
            elif g != 0.0:     # NaN too
                hi = x
            xn = x - g / dg
            if not (np.isfinite(xn) and lo < xn < hi):
                xn = 0.5 * (lo + hi)
            if g == 0.0:
                xn = x
            scale = abs(lo) + abs(hi)
            done = g == 0.0 or abs(xn - x) <= 4.0 * eps * scale or hi - lo <= 4.0 * eps * scale
            x = xn
            if done:
                return x, True
        return x, False
    return root


def check_converged(model, failed, total):
    """Raise ReturnMapError naming the model and the number of failing points."""
    if failed:
        raise ReturnMapError(f"{type(model).__name__}: local return mapping did not converge "
                             f"at {failed} of {total} points")
