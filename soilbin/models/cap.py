"""Cap models: DiMaggio & Sandler (1971) and the dissertation's modified cap
(app. B.4, eqs. B.9-B.12; Sture et al.'s artificial soil), associated,
with a tension cut-off. Return mapping after Simo, Ju, Pister & Taylor (1988)
and Hofstetter, Simo & Taylor (1993): the trial state's region in the
(I1, sqrt(J2)) plane picks the active surface or corner, and only the cap
needs a local Newton (the failure surface does not harden: a bracketed scalar
equation; corners and cut-off: closed form).

Compression positive inside (see :mod:`.invariant_return`): I1 = 3p = -tr(sigma),
J = sqrt(J2). The two models differ only in the failure function F:

    failure surface  f_F = J - F(I1) <= 0,
        DiMaggio–Sandler (B.9)  F(I1) = A - C exp(-beta I1),
        modified cap (B.12)     F(I1) = A + B I1 - C exp(-beta I1);
    cap (B.10)       f_C = sqrt(((I1 - L)/R)^2 + J^2) - F(L) <= 0  for I1 >= L,
                     an ellipse of axis ratio R through (L, F(L)) and (X, 0),
                     X = L + R F(L);
    cut-off          p <= T  (mean stress, tension positive: I1 >= -3T),
                     the ``tension_cutoff`` of the cone models;
    hardening (B.11) eps_v^p = W (1 - exp(-D X)),

with associated flow on every surface.

How the OCR'd equations were read. The dissertation writes J1 tension
positive in the exponentials: B.9 "fF = sqrt(J2D) - A + C e^{beta J1}" is
sqrt(J2) = A - C exp(-beta I1) with I1 compression positive (the classical
form: strength rising from A - C at I1 = 0 to the von Mises plateau A). B.12
"fF = sqrt(J2D) - A - B J1 + C e^{beta J1}" adds the linear term B I1 with I1
compression positive, since "B defines the failure line at high load level as
a Drucker–Prager line" (the surface tends to sqrt(J2) = A + B I1 at high
pressure and starts at the origin with the slope B + C beta when A = C, the
"two Drucker–Prager failure surfaces connected by a transitional surface" of
ch. IV.3). B.10's ellipse is normalised by (X - L) and F(L); the form used
here, after Simo et al., is the same surface. B.11's "W (1 - e^{-D X})" is
the DiMaggio–Sandler law, and section VII.5's "N = 0.18" is W. The VII.5
parameters (psi): E = 4000, nu = 0.35, A = 5.6, B = 0.11, C = 5.6,
beta = 0.062 /psi, R = 2.0, W = 0.18, D = 0.05 /psi (:data:`SECTION_VII5`).

Hardening. The cap's position L (history ``cap_L``; X in ``cap_X``) moves
only with the plastic compaction produced on the cap, so the cap expands on
loading and never retracts: dilatancy on the failure surface and on the
cut-off does not soften it (the restriction of Sandler & Rubin 1979 that the
cap does not move back), and under hydrostatic loading the plastic
volumetric strain follows eps_v^p = W (1 - exp(-D X)) exactly (measured from
the virgin cap X = 0; from X0 it is W (exp(-D X0) - exp(-D X))). The
initial cap is at X0, or further out where the initial stress lies beyond it
(the cap then passes through the initial stress: app. C, "specifying the
position of the initial cap is at that state"), and at least at the apex.

Regions of the trial state (I1_tr, J_tr), with L = L_n (the failure surface
and the corners are fixed during a step; the cap's normal at its corner
(L, F(L)) is purely deviatoric, so a corner return does not move the cap):

    cap         I1_tr >= L and f_C > 0           local Newton (p, J, dgamma, L)
    cap corner  I1_tr < L, beyond the failure normal at L      (L, F(L))
    failure     between the corners' normal cones              scalar root in p
    corner      beyond the normal cone of the failure surface's lowest point
                p_lo = max(apex, -T): the apex, or its corner with the cut-off
    cut-off     p_tr < p_lo and J_tr < F(3 p_lo)               p = p_lo, s = s_tr

History: ``stress``, ``cap_L``, ``cap_X`` (compression-positive I1),
``eps_p_vol`` (trace of the plastic strain, tension positive), ``eps_p_eq``
and ``yield_state``: 0 elastic, 1 failure surface, 2 apex or corner of
failure surface and cut-off, 3 cut-off, 4 cap, 5 corner of cap and failure
surface (codes of :mod:`.invariant_return`).
"""
import abc
import dataclasses
import math

import numpy as np

from ..params import param
from .cone import tension_cutoff_param
from .elastic import IsotropicElasticity
from .invariant_return import (APEX, CAP, CAP_CORNER, CUTOFF, FAILURE, YIELD_TOL, LinearBulk,
                               Response, Trial, check_converged, invariants, scalar_root,
                               smooth_return)

#: Section VII.5's artificial soil (psi, 1/psi): the modified cap's parameters.
SECTION_VII5 = {"E": 4000.0, "nu": 0.35, "A": 5.6, "B": 0.11, "C": 5.6, "beta": 0.062,
                "R": 2.0, "W": 0.18, "D": 0.05}


def _positive(doc):
    return param(lo=0.0, hi=math.inf, lo_open=True, hi_open=True, doc=doc)


@dataclasses.dataclass(frozen=True, kw_only=True)
class CapModel(IsotropicElasticity):
    """Base of the cap models (module doc); a subclass gives the failure function and
    its parameters (A, and B for the modified cap)."""

    C: float = _positive("failure surface: C of -C exp(-beta I1), stress units")
    beta: float = _positive("failure surface: beta of exp(-beta I1), 1 / stress units")
    R: float = _positive("cap ellipse axis ratio, (X - L) / F(L)")
    W: float = _positive("hardening: largest plastic compaction, eps_v^p = W (1 - exp(-D X))")
    D: float = _positive("hardening: D of eps_v^p = W (1 - exp(-D X)), 1 / stress units")
    X0: float = param(0.0, lo=0.0, hi=math.inf, hi_open=True,
                      doc="initial cap position X (compression-positive I1); moved out to pass "
                          "through the initial stress where that lies beyond it")
    tension_cutoff: float = tension_cutoff_param()

    history = {"stress": (6,), "cap_L": (), "cap_X": (), "eps_p_vol": (), "eps_p_eq": (),
               "yield_state": ()}

    @abc.abstractmethod
    def failure(self, I1):
        """(F, F', F'') of the failure surface sqrt(J2) = F(I1), I1 compression positive."""

    # --- geometry --------------------------------------------------------------------

    @property
    def apex(self):
        """I1 where F = 0 (F is increasing and concave: Newton from 0 converges monotonically)."""
        x = 0.0
        for _ in range(200):
            F, dF, _ = (float(v) for v in self.failure(np.array(x)))
            step = F / dF
            x -= step
            if abs(step) <= 1e-15 * (1.0 + abs(x)):
                break
        return x

    @property
    def lowest(self):
        """(p_lo, J_lo, F'(3 p_lo)): the mean stress where the elastic domain ends in
        tension (the apex, or the cut-off if that comes first) and sqrt(J2) there."""
        p_apex = self.apex / 3.0
        if -self.tension_cutoff > p_apex:
            p = -self.tension_cutoff
            F, dF, _ = (float(v) for v in self.failure(np.array(3.0 * p)))
            return p, F, dF
        return p_apex, 0.0, float(self.failure(np.array(3.0 * p_apex))[1])

    def X(self, L):
        """Cap position X(L) = L + R F(L)."""
        return L + self.R * self.failure(L)[0]

    def compaction(self, L):
        """(H, dH/dL): the plastic compaction W (1 - exp(-D X(L))) of the cap at L (B.11)."""
        F, dF, _ = self.failure(L)
        e = np.exp(-self.D * (L + self.R * F))
        return self.W * (1.0 - e), self.W * self.D * e * (1.0 + self.R * dF)

    # --- driver interface ----------------------------------------------------------------

    def initial_state(self, n, stress0=None):
        state = super().initial_state(n, stress0)
        L_min = 3.0 * self.lowest[0]
        X0 = max(self.X0, float(self.X(np.array(L_min))))

        def position(L, k):
            F, dF, _ = self.failure(L)
            return L + self.R * F - X0, 1.0 + self.R * dF

        L, _ = scalar_root(position, np.full(1, L_min), np.full(1, X0))
        L = np.full(n, L[0])
        p, J = invariants(state["stress"])
        I1 = 3.0 * p
        F, _, _ = self.failure(L)
        beyond = np.flatnonzero((I1 > L) & (((I1 - L) / self.R) ** 2 + J**2 > F**2))
        if beyond.size:
            # The cap through the initial stress: F(L)^2 = ((I1 - L)/R)^2 + J^2 on
            # [L, I1] (increasing in L); I1 itself where the stress is beyond failure.
            I1b, Jb = I1[beyond], J[beyond]

            def through(Lb, k):
                F, dF, _ = self.failure(Lb)
                return (F**2 - ((I1b[k] - Lb) / self.R) ** 2 - Jb[k] ** 2,
                        2.0 * F * dF + 2.0 * (I1b[k] - Lb) / self.R**2)

            admissible = self.failure(I1b)[0] >= Jb
            Lb, _ = scalar_root(through, L[beyond], I1b)
            L[beyond] = np.where(admissible, Lb, I1b)
        state["cap_L"] = L
        state["cap_X"] = self.X(L)
        return state

    def integrate(self, deps, state):
        G, K, R = self.G, self.K, self.R
        bulk = LinearBulk(K)
        trial = Trial.split(deps, state["stress"], G)
        p_n, de_v, J_tr = trial.p_n, trial.de_v, trial.J_tr
        L_n = state["cap_L"]
        p_tr = bulk.pressure(p_n, de_v)
        response = Response(trial, bulk, p_tr)
        p_lo, J_lo, dF_lo = self.lowest
        F_L, dF_L, _ = self.failure(L_n)
        scale = 3.0 * np.abs(p_tr) + J_tr + np.abs(state["cap_X"]) + self.C
        tol = YIELD_TOL * scale

        with np.errstate(over="ignore", invalid="ignore"):
            f_fail = J_tr - self.failure(3.0 * p_tr)[0]
        cap_side = 3.0 * p_tr > L_n
        f_cap = np.hypot((3.0 * p_tr - L_n) / R, J_tr) - F_L
        cap = cap_side & (f_cap > tol)
        low = ~cap_side & ((f_fail > tol) | (p_lo - p_tr > tol))
        # Wedges of the fixed corners: g(p) = E(p) - de_v - 3 F'(3p) (J_tr - F(3p)) / G is
        # the failure surface's return equation; g >= 0 at p_lo, g <= 0 at L/3 put the
        # trial in the normal cone of the corner.
        g_lo = (p_lo - p_n) / K - de_v - 3.0 * dF_lo * (J_tr - J_lo) / G
        corner = low & (J_tr >= J_lo) & (g_lo >= 0.0)
        cut = low & ~corner & (J_tr < J_lo) & (p_tr < p_lo)
        g_cap = (L_n / 3.0 - p_n) / K - de_v - 3.0 * dF_L * (J_tr - F_L) / G
        cap_corner = low & ~corner & ~cut & (g_cap <= 0.0)
        fail = low & ~corner & ~cut & ~cap_corner

        response.fixed(np.flatnonzero(corner), p_lo, J_lo, APEX)
        ic = np.flatnonzero(cap_corner)
        response.fixed(ic, L_n[ic] / 3.0, F_L[ic], CAP_CORNER)
        it = np.flatnonzero(cut)
        zero = np.zeros(it.size)
        response.solved(it, np.full(it.size, p_lo), J_tr[it], zero, zero, zero, zero + 1.0, CUTOFF)

        ifail = np.flatnonzero(fail)
        if ifail.size:
            self._failure_return(trial, bulk, ifail, p_lo, L_n[ifail] / 3.0, response)

        L = L_n.copy()
        icap = np.flatnonzero(cap)
        if icap.size:
            L[icap] = self._cap_return(trial, bulk, icap, p_tr[icap], L_n[icap], scale[icap],
                                       3.0 * p_lo, response)

        sigma, tangent, compaction, eq = response.finish(bulk, G)
        new_state = {"stress": sigma, "cap_L": L, "cap_X": np.where(cap, self.X(L), state["cap_X"]),
                     "eps_p_vol": state["eps_p_vol"] - compaction,
                     "eps_p_eq": state["eps_p_eq"] + eq, "yield_state": response.code}
        return sigma, tangent, new_state

    def _failure_return(self, trial, bulk, idx, p_lo, p_hi, response):
        """Return onto the failure surface (perfectly plastic): dgamma = (J_tr - J)/G,
        J = F(3p) and the volumetric split leave g(p) = 0 (see integrate) on [p_lo, p_hi]."""
        G = self.G
        p_n, de_v, J_tr = trial.p_n[idx], trial.de_v[idx], trial.J_tr[idx]

        def g(p, k):
            F, dF, d2F = self.failure(3.0 * p)
            over = J_tr[k] - F
            return (bulk.strain(p, p_n[k]) - de_v[k] - 3.0 * dF * over / G,
                    bulk.compliance(p) + 9.0 * (dF**2 - d2F * over) / G)

        p, converged = scalar_root(g, np.full(idx.size, p_lo), p_hi)
        check_converged(self, converged, len(trial.p_n))
        F, dF, _ = self.failure(3.0 * p)
        dg = g(p, np.arange(idx.size))[1]
        p_e, p_J = 1.0 / dg, 3.0 * dF / (G * dg)
        response.solved(idx, p, F, p_e, p_J, 3.0 * dF * p_e, 3.0 * dF * p_J, FAILURE)

    def _cap_return(self, trial, bulk, idx, p_tr, L_n, scale, L_min, response):
        """Return onto the hardening cap (smooth_return with h = L); returns L."""
        R = self.R

        def surface(p, J, L, k):
            F, dF, _ = self.failure(L)
            a = (3.0 * p - L) / R
            rho = np.hypot(a, J)
            r3 = rho**3
            return (rho - F, 3.0 * a / (R * rho), J / rho, -a / (R * rho) - dF,
                    9.0 * J**2 / (R**2 * r3), -3.0 * a * J / (R * r3), a**2 / r3,
                    -3.0 * J**2 / (R**2 * r3), a * J / (R * r3), scale[k])

        def admissible(p, J, L, k):
            return L >= L_min

        # Hardening (B.11): W (1 - exp(-D X(L))) - W (1 - exp(-D X(L_n))) = compaction.
        H_n = self.compaction(L_n)[0]

        def hardening(L, compaction, k):
            H, dH = self.compaction(L)
            return H - H_n[k] - compaction, dH, -np.ones_like(L)

        x0 = np.stack([p_tr, trial.J_tr[idx], np.zeros(idx.size), L_n], axis=1)
        p, J, _, L, sens, converged = smooth_return(
            surface, hardening, bulk, self.G, trial, idx, p_tr, L_n, x0, scale,
            admissible=admissible)
        check_converged(self, converged, len(trial.p_n))
        response.solved(idx, p, J, *sens, CAP)
        return L


@dataclasses.dataclass(frozen=True)
class DiMaggioSandler(CapModel):
    """DiMaggio–Sandler cap: F(I1) = A - C exp(-beta I1) (eq. B.9; module doc)."""

    A: float = _positive("failure surface: the von Mises plateau sqrt(J2) = A, stress units")

    def failure(self, I1):
        e = self.C * np.exp(-self.beta * I1)
        return self.A - e, self.beta * e, -self.beta**2 * e


@dataclasses.dataclass(frozen=True)
class ModifiedCap(CapModel):
    """The dissertation's modified cap: F(I1) = A + B I1 - C exp(-beta I1)
    (eq. B.12; module doc): Drucker–Prager sqrt(J2) = A + B I1 at high pressure."""

    A: float = _positive("failure surface: intercept of the high-pressure line A + B I1, "
                         "stress units")
    B: float = param(lo=0.0, hi=math.inf, hi_open=True,
                     doc="failure surface: slope of the high-pressure Drucker–Prager line "
                         "sqrt(J2) = A + B I1")

    def failure(self, I1):
        e = self.C * np.exp(-self.beta * I1)
        return self.A + self.B * I1 - e, self.B + self.beta * e, -self.beta**2 * e
