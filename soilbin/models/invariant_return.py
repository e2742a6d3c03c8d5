"""Return-mapping parts shared by the isotropic two-invariant soil models
(Cam-Clay, modified Cam-Clay, the DiMaggio–Sandler and modified caps).

Inside these models the geomechanics convention is used, compression positive::

    p = -tr(sigma) / 3,   J = sqrt(J2) = |s| / sqrt2,   I1 = 3 p,   e_v = -tr(deps),

and the stress goes back to the code's tension-positive Mandel vector as::

    sigma = -p I + s_tr J / J_tr = -p I + sqrt2 J n,   n = s_tr / |s_tr|:

an associated return with isotropic elasticity and a yield function of
(p, J) keeps the deviatoric direction of the trial stress, so every local
problem is one in the (p, J) plane.

Elasticity (the model's ``bulk``: :class:`.elastic.LinearBulk`,
:class:`.elastic.ExponentialBulk`): a constant shear modulus G, so J_tr = ``|s_n + 2G dev(deps)|`` / sqrt2, and a volumetric
law written through the elastic volumetric strain E(p; p_n) that takes the
mean stress from p_n to p (linear: (p - p_n)/K; exponential, the
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
conjugate to J; dgamma >= 0 at a solution.) A model gives f and its
derivatives as a :class:`Surface`; the residual and its Jacobian are those of
:class:`LocalProblem`. It is solved by :func:`newton`, a Newton iteration with
a backtracking line search on the scaled residual, vectorised over points.
The converged Jacobian gives, by the implicit-function theorem, the
sensitivities of (p, J) to the two inputs (de_v, J_tr), and with them the
consistent tangent (:func:`invariant_tangent`)

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
elastic domain (:func:`_continuation`) - the answer is still the one-step
backward-Euler solution, so the tangent is unchanged. Roots with a negative
multiplier or J < 0 are rejected. Scalar problems (the failure surface of
the caps, the Cam-Clay reduction) use a bracketed Newton-bisection
(:func:`scalar_root`). A local solve that does not converge raises
:class:`ReturnMapError` naming the model and the number of failing points;
the step driver then cuts the step.
"""
import dataclasses

import numpy as np

from ..errors import ReturnMapError
from ..tensors import IDENTITY, P_DEV, SQRT2, deviator, trace
from .base import ELASTIC, stress_invariants

#: Trial states with f_tr below this fraction of the stress scale are elastic.
YIELD_TOL = 1e-12
#: Local Newton: tolerance on the scaled residual, iterations, line-search halvings.
NEWTON_TOL = 1e-12
MAX_ITERATIONS = 60
MAX_HALVINGS = 40
#: Residual a stalled line search still accepts as converged (rounding floor).
STALL_TOL = 1e-10


@dataclasses.dataclass
class Trial:
    """The elastic predictor in invariants (see the module doc)."""

    p_n: np.ndarray      # mean stress at the start of the step
    de_v: np.ndarray     # volumetric strain increment, compression positive
    s_n: np.ndarray      # deviator at the start of the step (n, 6)
    s_tr: np.ndarray     # trial deviator (n, 6)
    J_tr: np.ndarray     # sqrt(J2) of the trial deviator
    n: np.ndarray        # s_tr / |s_tr| (zero where s_tr = 0)

    @classmethod
    def split(cls, deps, stress_n, G):
        p_n, s_n, _ = stress_invariants(stress_n)
        s_tr = s_n + 2.0 * G * deviator(deps)
        s_norm = np.linalg.norm(s_tr, axis=-1)
        n = s_tr / np.where(s_norm > 0.0, s_norm, 1.0)[:, None]
        return cls(-p_n, -trace(deps), s_n, s_tr, s_norm / SQRT2, n)


def invariants(stress):
    """(p, J) of (n, 6) stresses, compression-positive p (J as sqrt(s:s / 2), the
    initial states' numbers)."""
    p, s, _ = stress_invariants(stress)
    return -p, np.sqrt(0.5 * np.sum(s * s, axis=-1))


class Response:
    """(p, J), their sensitivities and the yield_state at every point; starts
    as the elastic response to the trial and is overwritten mode by mode."""

    def __init__(self, trial, bulk, p_tr):
        m = len(p_tr)
        self.trial = trial
        self.p = p_tr.copy()
        self.J = trial.J_tr.copy()
        with np.errstate(all="ignore"):
            self.p_e = 1.0 / bulk.compliance(p_tr)
        self.p_J = np.zeros(m)
        self.J_e = np.zeros(m)
        self.J_J = np.ones(m)
        self.ratio = np.ones(m)      # J / J_tr
        self.code = np.full(m, ELASTIC)

    def fixed(self, idx, p, J, code):
        """(p, J) fixed by the geometry (apex, corner, vertex): only n turns."""
        J_tr = self.trial.J_tr[idx]
        J = np.broadcast_to(np.asarray(J, dtype=float), J_tr.shape)
        self.p[idx], self.J[idx] = p, J
        self.p_e[idx] = self.p_J[idx] = self.J_e[idx] = self.J_J[idx] = 0.0
        self.ratio[idx] = np.divide(J, J_tr, out=np.zeros_like(J_tr), where=J_tr > 0.0)
        self.code[idx] = code

    def solved(self, idx, p, J, p_e, p_J, J_e, J_J, code):
        """(p, J) from a local solve with its sensitivities to (de_v, J_tr)."""
        self.p[idx], self.J[idx] = p, J
        self.p_e[idx], self.p_J[idx], self.J_e[idx], self.J_J[idx] = p_e, p_J, J_e, J_J
        J_tr = self.trial.J_tr[idx]
        # As J_tr -> 0 on a smooth surface J / J_tr tends to dJ/dJ_tr.
        self.ratio[idx] = np.where(J_tr > 0.0, J / np.where(J_tr > 0.0, J_tr, 1.0), J_J)
        self.code[idx] = code

    def finish(self, bulk, G):
        """(sigma, C_tan, plastic compaction, equivalent plastic strain increment)."""
        t = self.trial
        sigma = t.s_tr * self.ratio[:, None] - np.outer(self.p, IDENTITY)
        tangent = invariant_tangent(self.p_e, self.p_J, self.J_e, self.J_J, self.ratio, t.n, G)
        plastic = self.code != ELASTIC
        # Plastic strain: compaction de_v - E(p; p_n) and deviator (s_tr - s) / 2G.
        with np.errstate(all="ignore"):
            compaction = np.where(plastic, t.de_v - bulk.strain(self.p, t.p_n), 0.0)
        shear = np.where(plastic, t.J_tr * (1.0 - self.ratio) / (SQRT2 * G), 0.0)
        eq = np.sqrt(2.0 / 3.0) * np.sqrt(compaction**2 / 3.0 + shear**2)
        return sigma, tangent, compaction, eq


def invariant_tangent(p_e, p_J, J_e, J_J, ratio, n, G):
    """The consistent tangent of the module doc from the (p, J) sensitivities, (m, 6, 6).

    Built entry by entry on rows of m contiguous values (a (6, 6, m) array: NumPy is
    slow on the short inner loops of (m, 6, 6) blocks) and returned as a
    (m, 6, 6) view of them; each entry takes the terms in the order of the module doc."""
    m = len(ratio)
    two_g_ratio = 2.0 * G * ratio
    I_n, n_I = SQRT2 * G * p_J, SQRT2 * J_e      # I (x) n, n (x) I
    n_n = 2.0 * G * J_J - two_g_ratio            # n (x) n
    n = np.ascontiguousarray(n.T)
    C = np.empty((6, 6, m))
    for i in range(6):
        n_n_i = n_n * n[i]
        for j in range(6):
            c = np.multiply(two_g_ratio, P_DEV[i, j], out=C[i, j])
            if i < 3 and j < 3:
                c += p_e
            if i < 3:
                c -= I_n * n[j]
            if j < 3:
                c -= n_I * n[i]
            c += n_n_i * n[j]
    return C.reshape(36, m).T.reshape(m, 6, 6)


def _solve(jac, rhs):
    """Batched solve jac x = rhs of the systems along the last axis: jac (k, k, m), rhs
    (k, m) or (k, c, m). Gaussian elimination with partial pivoting on rows of m
    values (NumPy's batched LAPACK costs ~0.5 us a 4x4 system); the pseudo-inverse
    everywhere if a matrix is singular (a zero pivot)."""
    k = len(jac)
    vector = rhs.ndim == 2
    a = np.concatenate([jac, rhs[:, None] if vector else rhs], axis=1)   # [jac | rhs]
    for c in range(k):
        for r in range(c + 1, k):      # the largest |a[:, c]| of rows c.. to row c
            swap = np.flatnonzero(np.abs(a[r, c]) > np.abs(a[c, c]))
            if swap.size:
                top, row = a[c, c:], a[r, c:]
                top[:, swap], row[:, swap] = row[:, swap], top[:, swap]
        if not a[c, c].all():
            return _pinv_solve(jac, rhs)
        for r in range(c + 1, k):
            a[r, c + 1:] -= (a[r, c] / a[c, c]) * a[c, c + 1:]
    x = a[:, k:]
    for r in range(k - 1, -1, -1):
        for j in range(r + 1, k):
            x[r] -= a[r, j] * x[j]
        x[r] /= a[r, r]
    return x[:, 0] if vector else x


def _pinv_solve(jac, rhs):
    """:func:`_solve` by pseudo-inverses."""
    vector = rhs.ndim == 2
    b = (rhs[:, None] if vector else rhs).transpose(2, 0, 1)
    x = (np.linalg.pinv(jac.transpose(2, 0, 1)) @ b).transpose(1, 2, 0)
    return x[:, 0] if vector else x


def newton(evaluate, admissible, x0, tol=NEWTON_TOL):
    """Line-searched Newton for many small systems at once, one system a column:
    NumPy is fast along the long rows of m values.

    ``evaluate(x, idx)`` gives the scaled residuals (k, m) and Jacobians
    (k, k, m) of the systems ``idx`` at ``x`` (k, m); ``admissible(x, idx)``
    (m,) says where an iterate may go. Each step is halved until the merit
    ``|r|^2 / 2`` decreases (Armijo) at an admissible point. A converged point
    gets one more full step (to rounding accuracy) where it does not increase
    the residual. Returns (x, Jacobian at x, converged).
    """
    x = np.array(x0, dtype=float, order="C")
    k, m = x.shape
    converged = np.zeros(m, dtype=bool)
    # The residual and Jacobian where each point converged, for the polish.
    r_at, jac_at = np.empty((k, m)), np.empty((k, k, m))
    idx = np.arange(m)
    r, jac = evaluate(x, idx)
    for _ in range(MAX_ITERATIONS):
        norm = np.abs(r).max(axis=0)
        done = norm <= tol
        if done.any():
            converged[idx[done]] = True
            r_at[:, idx[done]], jac_at[..., idx[done]] = r[:, done], jac[..., done]
            idx, r, jac, norm = idx[~done], r[:, ~done], jac[..., ~done], norm[~done]
        if idx.size == 0:
            break
        moved, x_new, r_new, jac_new = _line_search(evaluate, admissible, x[:, idx],
                                                    -_solve(jac, r), r, idx)
        # A stalled line search at the rounding floor counts as converged.
        stalled = np.flatnonzero(~moved & (norm <= STALL_TOL))
        converged[idx[stalled]] = True
        r_at[:, idx[stalled]], jac_at[..., idx[stalled]] = r[:, stalled], jac[..., stalled]
        idx, r, jac = idx[moved], r_new, jac_new
        x[:, idx] = x_new
    # Polish the converged points with one more full step.
    idx = np.flatnonzero(converged)
    full_jac = np.zeros((k, k, m))
    if idx.size:
        r, jac = r_at[:, idx], jac_at[..., idx]
        xt = x[:, idx] - _solve(jac, r)
        rt, jt = evaluate(xt, idx)
        norm_t = np.abs(rt).max(axis=0)
        better = admissible(xt, idx) & np.isfinite(norm_t) & (norm_t <= np.abs(r).max(axis=0))
        x[:, idx[better]] = xt[:, better]
        jac[..., better] = jt[..., better]
        full_jac[..., idx] = jac
    return x, full_jac, converged


def _line_search(evaluate, admissible, x, dx, r, idx):
    """The Newton step dx from x (the systems ``idx``, residuals r there), halved until
    the merit |r|^2 / 2 decreases (Armijo) at an admissible point. Returns (moved,
    x, r, Jacobian), the last three at the points that moved."""
    merit = 0.5 * np.sum(r * r, axis=0)
    step = np.ones(len(idx))
    todo = np.arange(len(idx))
    moved = np.zeros(len(idx), dtype=bool)
    for halving in range(MAX_HALVINGS):
        xt = x[:, todo] + step[todo] * dx[:, todo]
        rt, jt = evaluate(xt, idx[todo])
        mt = 0.5 * np.sum(rt * rt, axis=0)
        good = (admissible(xt, idx[todo]) & np.isfinite(mt) & np.isfinite(jt).all(axis=(0, 1))
                & (mt <= (1.0 - 1e-4 * step[todo]) * merit[todo]))
        if halving == 0:        # todo is every point: the full step's values in place
            new_x, new_r, new_jac = xt, rt, jt
        else:
            g = todo[good]
            new_x[:, g], new_r[:, g], new_jac[..., g] = xt[:, good], rt[:, good], jt[..., good]
        moved[todo[good]] = True
        todo = todo[~good]
        if todo.size == 0:
            break
        step[todo] *= 0.5
    if moved.all():
        return moved, new_x, new_r, new_jac
    return moved, new_x[:, moved], new_r[:, moved], new_jac[..., moved]


def scalar_root(fun, lo, hi, x0=None):
    """Roots of scalar equations g(x) = 0 at many points, g(lo) <= 0 <= g(hi):
    Newton steps kept inside the shrinking bracket, bisection otherwise.
    ``fun(x, idx)`` -> (g, g') for the points ``idx``. Returns (x, converged)."""
    lo, hi = np.array(lo, dtype=float), np.array(hi, dtype=float)
    x = 0.5 * (lo + hi) if x0 is None else np.clip(x0, lo, hi)
    converged = np.zeros(len(x), dtype=bool)
    active = np.arange(len(x))
    eps = np.finfo(float).eps
    for _ in range(300):
        g, dg = fun(x[active], active)
        xa = x[active]
        zero = g == 0.0
        neg = g < 0.0
        lo[active[neg]] = xa[neg]
        hi[active[~neg & ~zero]] = xa[~neg & ~zero]
        with np.errstate(all="ignore"):
            xn = xa - g / dg
        inside = np.isfinite(xn) & (xn > lo[active]) & (xn < hi[active])
        xn = np.where(inside, xn, 0.5 * (lo[active] + hi[active]))
        xn = np.where(zero, xa, xn)
        scale = np.abs(lo[active]) + np.abs(hi[active])
        done = (zero | (np.abs(xn - xa) <= 4.0 * eps * scale)
                | (hi[active] - lo[active] <= 4.0 * eps * scale))
        x[active] = xn
        converged[active[done]] = True
        active = active[~done]
        if active.size == 0:
            break
    return x, converged


@dataclasses.dataclass(frozen=True)
class Surface:
    """A smooth yield surface f(p, J, h) (and, the flow being associated, the flow
    potential) at some points: its value and the derivatives the local Newton
    needs in p, J and the hardening variable h, and the stress scale of f."""

    f: np.ndarray
    f_p: np.ndarray
    f_J: np.ndarray
    f_h: np.ndarray
    f_pp: np.ndarray
    f_pJ: np.ndarray
    f_JJ: np.ndarray
    f_ph: np.ndarray
    f_Jh: np.ndarray
    scale: np.ndarray


@dataclasses.dataclass(frozen=True)
class LocalProblem:
    """The local problem of the module doc at the points ``idx`` (see
    :func:`smooth_return` for the arguments); positions ``sel``, ``k`` are in ``idx``."""

    surface: object
    hardening: object
    bulk: object
    G: float
    trial: Trial
    idx: np.ndarray
    h_n: np.ndarray
    stress_scale: np.ndarray
    strain_row: np.ndarray      # strain residual -> relative
    h_row: np.ndarray
    log_shift: object = None
    admissible: object = None

    def pressure(self, xi):
        """(p, dp/dxi) of the Newton's pressure variable."""
        if self.log_shift is not None:
            e = np.exp(xi)
            return e - self.log_shift, e
        return xi, np.ones_like(xi)

    def system(self, de_in, J_in, sel):
        """(evaluate, admissible) of :func:`newton` for the points sel with the
        inputs de_in, J_in (aligned with sel)."""
        t, bulk, G = self.trial, self.bulk, self.G
        p_n = t.p_n[self.idx]

        def evaluate(x, kk):
            k = sel[kk]
            xi, J, dg, h = x
            p, dp = self.pressure(xi)
            s = self.surface(p, J, h, k)
            dg_p = dg * s.f_p
            rh, rh_h, rh_c = self.hardening(h, dg_p, k)
            c = bulk.compliance(p)
            dg_pp, dg_pJ, dg_ph = dg * s.f_pp, dg * s.f_pJ, dg * s.f_ph
            r, jac = np.empty((4, len(k))), np.empty((4, 4, len(k)))
            r[0] = bulk.strain(p, p_n[k]) - de_in[kk] + dg_p
            r[1] = (J - J_in[kk]) / G + dg * s.f_J
            r[2] = s.f
            r[3] = rh
            rows = (((c + dg_pp) * dp, dg_pJ, s.f_p, dg_ph),
                    (dg_pJ * dp, 1.0 / G + dg * s.f_JJ, s.f_J, dg * s.f_Jh),
                    (s.f_p * dp, s.f_J, 0.0, s.f_h),
                    (rh_c * dg * s.f_pp * dp, rh_c * dg * s.f_pJ, rh_c * s.f_p,
                     rh_h + rh_c * dg * s.f_ph))
            for i, row in enumerate(rows):
                for j, entry in enumerate(row):
                    jac[i, j] = entry
            scale = np.empty((4, len(k)))
            scale[0] = scale[1] = self.strain_row[k]
            scale[2] = 1.0 / s.scale
            scale[3] = self.h_row[k]
            r *= scale
            jac *= scale[:, None]
            return r, jac

        def ok(x, kk):
            xi, J, _, h = x
            p = self.pressure(xi)[0]
            good = bulk.admissible(p)
            return good if self.admissible is None else good & self.admissible(p, J, h, sel[kk])
        return evaluate, ok

    def solution(self, x, sel):
        """Roots that are solutions: J >= 0 and dgamma >= 0 up to rounding."""
        t, i = self.trial, self.idx[sel]
        return ((x[1] >= -NEWTON_TOL * self.stress_scale[sel])
                & (x[2] >= -NEWTON_TOL * (np.abs(t.de_v[i]) + t.J_tr[i] / self.G)))

    def trial_path(self, t, sel):
        """(de_v, J_tr, xi_tr) of the points sel at the fraction t of the step."""
        tr, i = self.trial, self.idx[sel]
        s = tr.s_n[i] + t[:, None] * (tr.s_tr[i] - tr.s_n[i])
        p = self.bulk.pressure(tr.p_n[i], t * tr.de_v[i])
        xi = p if self.log_shift is None else np.log(p + self.log_shift)
        return t * tr.de_v[i], np.linalg.norm(s, axis=1) / SQRT2, xi

    def f_path(self, t, sel):
        """f at the fraction t of the trial path, with the committed hardening."""
        _, J, xi = self.trial_path(t, sel)
        return self.surface(self.pressure(xi)[0], J, self.h_n[sel], sel).f


def smooth_return(surface, hardening, bulk, G, trial, idx, p_tr, h_n, x0, stress_scale,
                  log_shift=None, admissible=None, hardening_row=None, fallback=None):
    """Backward-Euler return of the points ``idx`` onto one smooth hardening
    surface (the local problem of the module doc).

    ``surface(p, J, h, k)`` -> :class:`Surface` for the points ``idx[k]``;
    ``hardening(h, c, k)`` -> (r_h, dr_h/dh, dr_h/dc), the hardening residual
    with the compaction c = dgamma f_p of the step; ``x0`` (m, 4) the starting
    (xi, J, dgamma, h), where p = exp(xi) - log_shift if ``log_shift`` is a
    number (a logarithmic pressure variable: Cam-Clay's ln p, or ln(p + p_min)
    of the exponential bulk law, in which the volumetric residual is linear)
    and p = xi if it is None; ``admissible(p, J, h, k)`` where iterates may go
    (beyond the bulk law's range); ``stress_scale`` (m,) scales the strain
    residuals, ``hardening_row`` (m,) the hardening residual (default: as a
    strain). Points where Newton fails from ``x0`` start again from ``fallback``
    (m, 4), if given (x0 then a warm start from a nearby solution, fallback the trial
    state), and where it fails from there too are solved by continuation
    (:func:`_continuation`); a root with dgamma < 0 or J < 0 is no solution.
    Returns (p, J, dgamma, h, (p_e, p_J, J_e, J_J), converged).
    """
    m = len(idx)
    with np.errstate(all="ignore"):
        K_ref = np.where(bulk.admissible(p_tr), 1.0 / bulk.compliance(p_tr), 0.0)
    strain_row = np.maximum(K_ref, G) / stress_scale
    problem = LocalProblem(surface, hardening, bulk, G, trial, idx, h_n, stress_scale,
                           strain_row, strain_row if hardening_row is None else hardening_row,
                           log_shift, admissible)
    every = np.arange(m)
    with np.errstate(all="ignore"):
        x, jac, converged = newton(*problem.system(trial.de_v[idx], trial.J_tr[idx], every),
                                   x0.T)
        converged &= problem.solution(x, every)
        failed = np.flatnonzero(~converged)
        if failed.size and fallback is not None:
            sub = problem.system(trial.de_v[idx[failed]], trial.J_tr[idx[failed]], failed)
            xf, jf, cf = newton(*sub, fallback[failed].T)
            x[:, failed], jac[..., failed] = xf, jf
            converged[failed] = cf & problem.solution(xf, failed)
            failed = np.flatnonzero(~converged)
        if failed.size:
            xf, jf, cf = _continuation(problem, failed)
            x[:, failed], jac[..., failed] = xf, jf
            converged[failed] = cf & problem.solution(xf, failed)
    xi, J, dgamma, h = x
    # Iterates may cross J = 0 or dgamma = 0; a solution may not, beyond rounding.
    J, dgamma = np.maximum(J, 0.0), np.maximum(dgamma, 0.0)
    p, dp = problem.pressure(xi)
    # Implicit-function theorem: the inputs de_v, J_tr enter r_p as -de_v and r_J as -J_tr / G.
    rhs = np.zeros((4, 2, m))
    rhs[0, 0] = strain_row
    rhs[1, 1] = strain_row / G
    jac[..., ~converged] = np.eye(4)[..., None]
    with np.errstate(all="ignore"):
        dx = _solve(jac, rhs)
    sens = (dp * dx[0, 0], dp * dx[0, 1], dx[1, 0], dx[1, 1])
    return p, J, dgamma, h, sens, converged


#: Continuation: numbers of equal parts of the plastic part of the step tried in turn.
CONTINUATION_PARTS = (4, 16, 64, 256)


def _continuation(problem, sel):
    """Solve the one-step problems of the points ``sel`` (positions in the
    :class:`LocalProblem`'s points) by continuation in the fraction t of the
    strain increment: from the elastic fraction t_e (where the trial path meets
    the surface and the solution is the trial state with dgamma = 0) to t = 1
    in N equal parts, each Newton solve starting from the last; N grows over
    :data:`CONTINUATION_PARTS` for the points that still fail. The answer is
    the one-step backward-Euler solution itself (the intermediate problems only
    lead Newton to it), so the tangent is unchanged. Returns (x (4, m), Jacobian
    (4, 4, m), converged) aligned with ``sel``."""
    m = len(sel)
    # Elastic fraction by bisection (t_e = 0 if the step starts outside the surface).
    lo, hi = np.zeros(m), np.ones(m)
    inside = problem.f_path(lo, sel) <= 0.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        out = problem.f_path(mid, sel) > 0.0
        hi = np.where(out, mid, hi)
        lo = np.where(out, lo, mid)
    t_e = np.where(inside, lo, 0.0)
    x = np.zeros((4, m))
    jac = np.zeros((4, 4, m))
    converged = np.zeros(m, dtype=bool)
    todo = np.arange(m)
    for parts in CONTINUATION_PARTS:
        _, J0, xi0 = problem.trial_path(t_e[todo], sel[todo])
        xk = np.stack([xi0, J0, np.zeros(todo.size), problem.h_n[sel[todo]]])
        alive = np.ones(todo.size, dtype=bool)
        for k in range(1, parts + 1):
            live = np.flatnonzero(alive)
            t = t_e[todo[live]] + (1.0 - t_e[todo[live]]) * k / parts
            de_in, J_in, _ = problem.trial_path(t, sel[todo[live]])
            xs, js, cs = newton(*problem.system(de_in, J_in, sel[todo[live]]), xk[:, live])
            xk[:, live] = xs
            alive[live[~cs]] = False
            if k == parts:
                done = live[cs]
                x[:, todo[done]], jac[..., todo[done]] = xs[:, cs], js[..., cs]
                converged[todo[done]] = True
        todo = todo[~alive]
        if todo.size == 0:
            break
    return x, jac, converged


def check_converged(model, converged, total):
    """Raise ReturnMapError naming the model and the failing points."""
    failed = np.count_nonzero(~converged)
    if failed:
        raise ReturnMapError(f"{type(model).__name__}: local return mapping did not converge "
                             f"at {failed} of {total} points")
