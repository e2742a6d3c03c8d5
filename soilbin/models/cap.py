"""Cap models: DiMaggio & Sandler (1971) and the dissertation's modified cap
(app. B.4, eqs. B.9-B.12; Sture et al.'s artificial soil), associated by
default, optionally with less dilatancy on the failure surface, and with a
tension cut-off. Return mapping after Simo, Ju, Pister & Taylor (1988)
and Hofstetter, Simo & Taylor (1993): the trial state's region in the
(I1, sqrt(J2)) plane picks the active surface or corner, and only the cap
needs a local Newton (the failure surface does not harden: a bracketed scalar
equation; corners and cut-off: closed form).

Compression positive inside (see :mod:`.invariant_return`): I1 = 3p = -tr(sigma),
J = sqrt(J2). The two models differ only in the failure function F::

    failure surface  f_F = J - F(I1) <= 0,
        DiMaggio–Sandler (B.9)  F(I1) = A - C exp(-beta I1),
        modified cap (B.12)     F(I1) = A + B I1 - C exp(-beta I1);
    cap (B.10)       f_C = sqrt(((I1 - L)/R)^2 + J^2) - F(L) <= 0  for I1 >= L,
                     an ellipse of axis ratio R through (L, F(L)) and (X, 0),
                     X = L + R F(L);
    cut-off          p <= T  (mean stress, tension positive: I1 >= -3T),
                     the ``tension_cutoff`` of the cone models;
    hardening (B.11) eps_v^p = W (1 - exp(-D X)),

with associated flow on the cap and the cut-off, and on the failure surface
the flow potential::

    g_F = J - eta_d F(I1),   0 <= eta_d <= 1   (``dilatancy``),

eta_d = 1 (the default) associated, the dissertation's; eta_d = 0 isochoric.

Dilatancy (``dilatancy``). The failure surface is curved: its slope F'(I1),
and with it the dilatancy of associated flow, falls with the confinement (for
DiMaggio–Sandler to zero on the von Mises plateau). A dilation angle, a
fixed slope of the potential, would dilate more than associated flow where
the surface flattens; the factor eta_d instead scales the surface's own
slope: the plastic strain on the failure surface is dgamma dg_F/dsigma, its
volume change (dilation) over its shear strain sqrt2 ``|dev deps^p|`` is
3 eta_d F'(I1), a fraction eta_d of the associated flow's at every
confinement (on the modified cap's high-pressure line Drucker–Prager's
3 alpha_psi with alpha_psi = eta_d B). The cap stays associated (B.10).
Where eta_d < 1 changes the return (the regions below): the trial lies
from the returned stress along C:m, in the (I1, J) plane the direction
(-9 K eta_d F', G) of the potential instead of the surface's normal
(-9 K F', G); the normal cones of the corners become the cones spanned by
the return directions of the two surfaces there. The apex (or its corner
with the cut-off) takes the trials beyond the failure potential's direction
from it, and, as for Drucker–Prager (.cone), the apex acts as the corner with
a cut-off p <= p_lo that takes the rest of the volumetric strain, direction
(-1, 0) (with eta_d = 0 every trial with p_tr < p_lo returns to it:
isochoric flow cannot bring it back). The cap corner's cone, between the
cap's vertical (0, G) and (-9 K eta_d F'(L), G), narrows to the vertical
above the corner for eta_d = 0. The failure return's tangent is unsymmetric
(dp/dJ_tr = 3 eta_d F' / (G g') against dJ/de_v = 3 F' / g'). The hardening:
with ``volumetric`` the cap retreats by the failure surface's (smaller)
dilation, not at all for eta_d = 0; with ``cap_compaction`` the cap does not
feel the failure surface, and less dilatancy only changes the stress path on
it (with eta_d = 0 the mean stress stays the trial's, so shear alone no
longer drives a point up the surface into the cap corner, the vertex without
bulk stiffness) and the plastic volume (history ``eps_p_vol``).

How the OCR'd equations are read. The dissertation writes J1 tension
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

Hardening (``hardening``). The cap's end X (history ``cap_X``) is the
hardening variable of B.11, eps_v^p = W (1 - exp(-D X)), through Sandler &
Rubin's parameter kappa, X = kappa + R F(kappa), and the cap's centre is
L = max(kappa, L_min) (``cap_L``), L_min = max(0, 3 p_lo): the centre never
goes onto the tension side (Sandler & Rubin 1979: L = max(kappa, 0)); below
L_min only the end moves, not below L_min (the cap is then the point L_min),
and the cap, centred at L_min, is lower than the failure surface there,
(X - L)/R < F(L). With ``volumetric``
eps_v^p is the plastic volumetric strain of every surface, as in DiMaggio &
Sandler (1971) and Sandler & Rubin (1979): the cap retreats when the soil
dilates on the failure surface, at the apex and on the cut-off. This is the
dissertation's model: ch. IV.2 "a cap which can expand or contract depending
on loading or unloading conditions", app. C "the cap model is capable of
handling unloading situation by contraction", and B.11 with the algorithm of
its refs. [21, 60] (DiMaggio & Sandler, Sandler & Rubin). The default is
``cap_compaction``: with ``volumetric`` the tine's first load step needs more
Newton iterations and, on the coarse tine of tests/test_soil_bin.py, meets
Newton iterates with more compaction than W, at which no return exists. With
``cap_compaction`` only the compaction produced on the cap moves it: it never
retreats, and its centre may start on the tension side (L_min = 3 p_lo); its
corner with the failure surface is then a perfectly plastic vertex with no
bulk stiffness. Under hydrostatic loading
either way eps_v^p = W (1 - exp(-D X)) exactly (measured from the virgin cap
X = 0; from X0 it is W (exp(-D X0) - exp(-D X))). The initial cap ends at X0
(with ``cap_compaction`` at least at the apex), or further out where the
initial stress lies beyond it (the cap then passes through the initial
stress: app. C, "specifying the position of the initial cap is at that
state").

Regions of the trial state (I1_tr, J_tr), with L = L_n (the failure surface
is fixed; the cap's normal at its corner (L, F(L)) is purely deviatoric; the
failure surface's "normal" is the return direction along its potential)::

    cap         I1_tr > L and f_C > 0            local Newton (p, J, dgamma, kappa)
    cap corner  I1_tr <= L, beyond the failure return at L      (L, F(L)), L moving
                back with the dilation (a bracketed root; fixed with cap_compaction)
    failure     between the corners' normal cones              scalar root in p,
                then the cap retreats (and where it passes the stress: cap corner)
    corner      beyond the normal cone of the failure surface's lowest point
                p_lo = max(apex, -T): the apex, or its corner with the cut-off
    cut-off     p_tr < p_lo and J_tr < F(3 p_lo)               p = p_lo, s = s_tr

History: ``stress``, ``cap_L``, ``cap_X`` (compression-positive I1),
``eps_p_vol`` (trace of the plastic strain, tension positive), ``eps_p_eq``
and ``yield_state``: 0 elastic, 1 failure surface, 2 apex or corner of
failure surface and cut-off, 3 cut-off, 4 cap, 5 corner of cap and failure
surface (codes of :mod:`.base`).
"""
import abc
import dataclasses
import enum

import numpy as np

from ..params import magnitude_param, param
from ..tensors import IDENTITY
from .base import APEX, CAP, CAP_CORNER, CUTOFF, ELASTIC, FAILURE, SHEAR, Sample
from .cone import tension_cutoff_param
from .elastic import IsotropicElasticity
from .invariant_return import (YIELD_TOL, Response, Surface, Trial, check_converged, invariants,
                               scalar_root, smooth_return)

#: Section VII.5's artificial soil (psi, 1/psi): the modified cap's parameters.
SECTION_VII5 = {"E": 4000.0, "nu": 0.35, "A": 5.6, "B": 0.11, "C": 5.6, "beta": 0.062,
                "R": 2.0, "W": 0.18, "D": 0.05}
#: McCormick Ranch sand (ksi, 1/ksi; Sandler & Rubin 1979): K = 66.67, G = 40.
MCCORMICK_RANCH = {"E": 100.0, "nu": 0.25, "A": 0.25, "C": 0.18, "beta": 0.67, "R": 2.5,
                   "W": 0.066, "D": 0.67}


class CapHardening(enum.Enum):
    """What moves the cap (module doc, *Hardening*)."""
    #: The plastic volumetric strain of every surface (B.11, DiMaggio & Sandler 1971,
    #: Sandler & Rubin 1979): the cap retreats when the soil dilates, L >= max(0, apex).
    VOLUMETRIC = "volumetric"
    #: Only the cap's own compaction: the cap never retreats, L >= apex.
    CAP_COMPACTION = "cap_compaction"


@dataclasses.dataclass(frozen=True, kw_only=True)
class CapModel(IsotropicElasticity):
    """Base of the cap models (module doc); a subclass gives the failure function and
    its parameters (A, and B for the modified cap)."""

    C: float = magnitude_param(doc="failure surface: C of -C exp(-beta I1), stress units")
    beta: float = magnitude_param(doc="failure surface: beta of exp(-beta I1), 1 / stress units")
    R: float = magnitude_param(doc="cap ellipse axis ratio, (X - L) / F(L)")
    W: float = magnitude_param(doc="hardening: largest plastic compaction, "
                                   "eps_v^p = W (1 - exp(-D X))")
    D: float = magnitude_param(doc="hardening: D of eps_v^p = W (1 - exp(-D X)), 1 / stress units")
    X0: float = magnitude_param(0.0, zero=True,
                                doc="initial cap position X (compression-positive I1); moved out "
                                    "to pass through the initial stress where that lies beyond it")
    tension_cutoff: float = tension_cutoff_param()
    dilatancy: float = param(
        1.0, lo=0.0, hi=1.0,
        doc="dilatancy factor eta_d of the failure surface's flow potential "
            "g = sqrt(J2) - eta_d F(I1): the plastic dilation a fraction eta_d of the "
            "associated flow's; 1 (the default) associated, 0 isochoric; the cap stays "
            "associated")
    hardening: CapHardening = param(
        CapHardening.CAP_COMPACTION,
        doc="what moves the cap: cap_compaction (only the cap's own compaction: the cap never "
            "retreats) or volumetric (the plastic volumetric strain of every surface, B.11: "
            "the cap retreats when the soil dilates, its centre L >= 0; Sandler & Rubin 1979, "
            "the dissertation's)")

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

    @property
    def L_min(self):
        """The smallest cap centre L: the apex (or the cut-off), and with the
        volumetric hardening not on the tension side (Sandler & Rubin: L = max(kappa, 0))."""
        L = 3.0 * self.lowest[0]
        return max(L, 0.0) if self.hardening is CapHardening.VOLUMETRIC else L

    def X(self, L):
        """Cap position X(L) = L + R F(L)."""
        return L + self.R * self.failure(L)[0]

    def kappa(self, X):
        """The hardening parameter kappa with X(kappa) = X (X is increasing): the cap
        centre is L = max(kappa, L_min) (Sandler & Rubin 1979)."""
        X = np.asarray(X, dtype=float)
        L_min = self.L_min
        X_min = float(self.X(np.array(L_min)))
        F_min = max(float(self.failure(np.array(L_min))[0]), 0.0)
        # X(k) >= k above L_min (F >= 0) and X(k) <= k + R F(L_min) below it.
        lo = np.where(X >= X_min, L_min, X - self.R * F_min)
        hi = np.where(X >= X_min, X, L_min)

        def position(k, idx):
            F, dF, _ = self.failure(k)
            return k + self.R * F - X[idx], 1.0 + self.R * dF

        kappa, converged = scalar_root(position, lo, hi)
        check_converged(self, converged, len(X))
        return kappa

    def compaction(self, L):
        """(H, dH/dL): the plastic compaction W (1 - exp(-D X(L))) of the cap at L (B.11)."""
        F, dF, _ = self.failure(L)
        e = np.exp(-self.D * (L + self.R * F))
        return self.W * (1.0 - e), self.W * self.D * e * (1.0 + self.R * dF)

    # --- driver interface ----------------------------------------------------------------

    def initial_state(self, n, stress0=None):
        state = super().initial_state(n, stress0)
        X0 = max(self.X0, self.L_min)
        if self.hardening is CapHardening.CAP_COMPACTION:
            X0 = max(X0, float(self.X(np.array(self.L_min))))
        kappa0 = float(self.kappa(np.array([X0]))[0])
        L = np.full(n, max(kappa0, self.L_min))
        p, J = invariants(state["stress"])
        I1 = 3.0 * p
        height = (X0 - L) / self.R     # F(L), or less where kappa < L_min
        beyond = np.flatnonzero((I1 > L) & (((I1 - L) / self.R) ** 2 + J**2 > height**2))
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
        # X(L), but X0 itself where the cap has retreated past L_min (kappa0 < L_min).
        state["cap_X"] = self.X(L)
        if kappa0 < self.L_min:
            state["cap_X"][L == self.L_min] = X0
        return state

    def integrate(self, deps, state, guess=None):
        G, R = self.G, self.R
        bulk = self.bulk
        trial = Trial.split(deps, state["stress"], G)
        p_n, de_v, J_tr = trial.p_n, trial.de_v, trial.J_tr
        L_n, X_n = state["cap_L"], state["cap_X"]
        p_tr = bulk.pressure(p_n, de_v)
        response = Response(trial, bulk, p_tr)
        p_lo, J_lo, dF_lo = self.lowest
        F_L, dF_L, _ = self.failure(L_n)
        # kappa = L but where the cap has retreated past L_min (module doc).
        kappa_n = L_n.copy()
        shrunk = np.flatnonzero(X_n < L_n + R * F_L)       # X_n < X(L_n)
        kappa_n[shrunk] = self.kappa(X_n[shrunk])
        height = F_L.copy()        # of the cap at L: (X - L) / R
        height[shrunk] = (X_n[shrunk] - L_n[shrunk]) / R
        scale = 3.0 * np.abs(p_tr) + J_tr + np.abs(state["cap_X"]) + self.C
        tol = YIELD_TOL * scale

        with np.errstate(over="ignore", invalid="ignore"):
            f_fail = J_tr - self.failure(3.0 * p_tr)[0]
        cap_side = 3.0 * p_tr > L_n
        f_cap = np.hypot((3.0 * p_tr - L_n) / R, J_tr) - height
        cap = cap_side & (f_cap > tol)
        low = ~cap_side & ((f_fail > tol) | (p_lo - p_tr > tol))
        # Wedges of the fixed corners: the failure return's volumetric split g(p)
        # (_failure_split) >= 0 at p_lo, <= 0 at L/3 puts the trial in the normal cone
        # of the corner, spanned by the return directions of its surfaces.
        g_lo = self._failure_split(bulk, p_lo, J_lo, dF_lo, p_n, de_v, J_tr)
        corner = low & (J_tr >= J_lo) & (g_lo >= 0.0)
        cut = low & ~corner & (J_tr < J_lo) & (p_tr < p_lo)
        g_cap = self._failure_split(bulk, L_n / 3.0, F_L, dF_L, p_n, de_v, J_tr)
        cap_corner = low & ~corner & ~cut & (g_cap <= 0.0)
        fail = low & ~corner & ~cut & ~cap_corner

        last = guess["yield_state"] if guess is not None else response.code
        fixed_cap_corner = cap_corner & (self.hardening is CapHardening.CAP_COMPACTION)
        self._fixed_vertices(trial, bulk, corner, fixed_cap_corner, L_n, last, response)
        it = np.flatnonzero(cut)
        zero = np.zeros(it.size)
        response.solved(it, np.full(it.size, p_lo), J_tr[it], zero, zero, zero, zero + 1.0, CUTOFF)

        ifail = np.flatnonzero(fail)
        if ifail.size:
            self._failure_return(trial, bulk, ifail, p_lo, L_n[ifail] / 3.0, response)

        kappa = kappa_n.copy()
        icap = np.flatnonzero(cap)
        if icap.size:
            kappa[icap] = self._cap_return(trial, bulk, icap, p_tr[icap], kappa_n[icap],
                                           scale[icap], response, guess)
        if self.hardening is CapHardening.VOLUMETRIC:
            self._retreat(trial, bulk, np.flatnonzero(corner | cut | fail),
                          np.flatnonzero(cap_corner), kappa_n, kappa, response)

        sigma, tangent, compaction, eq = response.finish(bulk, G)
        moved = np.flatnonzero(kappa != kappa_n)
        L, X = L_n.copy(), X_n.copy()
        L[moved] = np.maximum(kappa[moved], self.L_min)
        X[moved] = self.X(kappa[moved])
        new_state = {"stress": sigma, "cap_L": L, "cap_X": X,
                     "eps_p_vol": state["eps_p_vol"] - compaction,
                     "eps_p_eq": state["eps_p_eq"] + eq, "yield_state": response.code}
        return sigma, tangent, new_state

    def _fixed_vertices(self, trial, bulk, apex, cap_corner, L_n, last, response):
        """The stress at the fixed vertices: the failure surface's lowest point (apex, or
        corner with the cut-off) at the points ``apex``, the corner (L, F(L)) with a cap
        that never retreats at the points ``cap_corner``.

        A vertex's own tangent has no bulk stiffness (every trial in its normal cone
        returns to it). At the foot of a short stretch of failure surface between the two
        vertices (a point near the surface of a soil without strength at zero stress,
        where L is small) a point under those tangents goes from one vertex to the other
        in every Newton iterate, past the solution on the stretch between them, and the
        load step stalls. A point that was at the other vertex at the last iterate
        (``last``: yield states) therefore gets the tangent of that stretch, the failure
        surface's (:meth:`_failure_return`'s sensitivities at the vertex); a point that
        stays at its vertex has the vertex's own."""
        p = np.where(apex, self.lowest[0], L_n / 3.0)
        F, dF, d2F = self.failure(3.0 * p)
        crossed = (apex & (last == CAP_CORNER)) | (cap_corner & (last == APEX))
        with np.errstate(all="ignore"):
            sens = self._failure_sensitivities(bulk, p, trial.J_tr, F, dF, d2F)
        sens = [np.where(crossed, s, 0.0) for s in sens]
        for at, code in ((apex, APEX), (cap_corner, CAP_CORNER)):
            k = np.flatnonzero(at)
            response.solved(k, p[k], np.maximum(F[k], 0.0), *(s[k] for s in sens), code)

    def _failure_split(self, bulk, p, F, dF, p_n, de_v, J_tr):
        """g(p) = E(p; p_n) - de_v - 3 eta_d F' (J_tr - F) / G with (F, F') at I1 = 3p:
        the volumetric strain left by a return onto the failure surface at p along
        its potential, dgamma = (J_tr - F) / G (module doc); g = 0 at the return."""
        return bulk.strain(p, p_n) - de_v - 3.0 * self.dilatancy * dF * (J_tr - F) / self.G

    def _failure_slope(self, bulk, p, J_tr, F, dF, d2F):
        """dg/dp of :meth:`_failure_split`: 1/K(p) + 9 eta_d (F'^2 - F'' (J_tr - F)) / G,
        at least 1/K(p) where J_tr >= F (F'' <= 0)."""
        return bulk.compliance(p) + 9.0 * self.dilatancy * (dF**2 - d2F * (J_tr - F)) / self.G

    def _failure_sensitivities(self, bulk, p, J_tr, F, dF, d2F):
        """(p_e, p_J, J_e, J_J) of the failure return at p (implicit-function theorem
        on g(p) = 0, J = F(3p)): p_e = 1/g', p_J = 3 eta_d F' / (G g'), J_e = 3 F' p_e,
        J_J = 3 F' p_J; G p_J != J_e (unsymmetric tangent) unless eta_d = 1."""
        dg = self._failure_slope(bulk, p, J_tr, F, dF, d2F)
        p_e, p_J = 1.0 / dg, 3.0 * self.dilatancy * dF / (self.G * dg)
        return p_e, p_J, 3.0 * dF * p_e, 3.0 * dF * p_J

    def _failure_return(self, trial, bulk, idx, p_lo, p_hi, response):
        """Return onto the failure surface (perfectly plastic) along its potential:
        dgamma = (J_tr - J)/G, J = F(3p) and the volumetric split leave g(p) = 0
        (:meth:`_failure_split`) on [p_lo, p_hi]."""
        p_n, de_v, J_tr = trial.p_n[idx], trial.de_v[idx], trial.J_tr[idx]

        def g(p, k):
            F, dF, d2F = self.failure(3.0 * p)
            return (self._failure_split(bulk, p, F, dF, p_n[k], de_v[k], J_tr[k]),
                    self._failure_slope(bulk, p, J_tr[k], F, dF, d2F))

        p, converged = scalar_root(g, np.full(idx.size, p_lo), p_hi)
        check_converged(self, converged, len(trial.p_n))
        F, dF, d2F = self.failure(3.0 * p)
        response.solved(idx, p, F, *self._failure_sensitivities(bulk, p, J_tr, F, dF, d2F),
                        FAILURE)

    def _retreat(self, trial, bulk, idx, ic, kappa_n, kappa, response):
        """The cap of the points ``idx`` (apex, cut-off, failure surface: dilating)
        follows their plastic volumetric strain back (B.11); where its centre
        L = max(kappa, L_min) would pass the stress (I1 > L), and at the points
        ``ic`` (beyond the failure surface's normal at the corner), the stress is the
        corner (:meth:`_corner_return`). Sets ``kappa`` and ``response`` there."""
        compaction = trial.de_v[idx] - bulk.strain(response.p[idx], trial.p_n[idx])
        kappa[idx] = self._kappa_at(self.compaction(kappa_n[idx])[0] + compaction)
        behind = 3.0 * response.p[idx] > np.maximum(kappa[idx], self.L_min)
        corner = np.concatenate([ic, idx[behind]])
        if corner.size:
            kappa[corner] = self._corner_return(trial, bulk, corner, kappa_n[corner], response)

    def _kappa_at(self, H):
        """kappa whose compaction W (1 - exp(-D X(kappa))) is H < W (B.11), the cap's
        end X not below L_min (there the cap is the point L_min)."""
        return self.kappa(np.maximum(-np.log1p(-H / self.W) / self.D, self.L_min))

    def _corner_return(self, trial, bulk, idx, kappa_n, response):
        """The stress at the corner (L, F(L)) of a retreating cap: the plastic strain
        is that of the failure surface (compaction H(L) - H(kappa_n) <= 0) plus
        deviatoric flow on the cap (its normal at the corner), so the volumetric split

            g(L) = E(L/3; p_n) - de_v + H(L) - H(kappa_n) = 0

        is a monotone scalar equation on [L_min, kappa_n] (g(kappa_n) > 0 here): a
        bracketed root, and dp/de_v = 1 / (3 g'(L)) > 0. Where g(L_min) >= 0 the
        corner stays at L_min (p, J fixed; the apex if F(L_min) = 0) and kappa
        follows the compaction below L_min. Returns kappa."""
        p_n, de_v = trial.p_n[idx], trial.de_v[idx]
        H_n = self.compaction(kappa_n)[0]
        L_min = self.L_min
        every = np.arange(idx.size)

        def g(L, k):
            H, dH = self.compaction(L)
            return (bulk.strain(L / 3.0, p_n[k]) - de_v[k] + H - H_n[k],
                    bulk.compliance(L / 3.0) / 3.0 + dH)

        g_min = g(np.full(idx.size, L_min), every)[0]
        at_min = g_min >= 0.0      # always where kappa_n < L_min (I1_tr <= L_n here)
        kappa = np.full(idx.size, L_min)
        moving = np.flatnonzero(~at_min)
        if moving.size:
            kappa[moving], converged = scalar_root(lambda L, k: g(L, moving[k]),
                                                   np.full(moving.size, L_min),
                                                   kappa_n[moving].copy())
            check_converged(self, converged, len(trial.p_n))
        fixed = np.flatnonzero(at_min)
        if fixed.size:   # the compaction left at L_min: H(kappa) = H(L_min) - g(L_min)
            kappa[fixed] = self._kappa_at(self.compaction(np.array(L_min))[0] - g_min[fixed])
        L = np.maximum(kappa, L_min)
        F, dF, _ = self.failure(L)
        L_e = np.where(at_min, 0.0, 1.0 / g(L, every)[1])
        zero = np.zeros(idx.size)
        code = np.where(at_min & (F <= 0.0), APEX, CAP_CORNER)
        for c in np.unique(code):
            k = code == c
            response.solved(idx[k], L[k] / 3.0, np.maximum(F[k], 0.0), L_e[k] / 3.0, zero[k],
                            dF[k] * L_e[k], zero[k], c)
        return kappa

    def _warm_start(self, trial, bulk, idx, guess, surface, k):
        """(p, J, dgamma, kappa) of the cap return from the ``guess`` state at the points
        ``idx`` (``k``: their positions in the return): its stress and cap centre, and
        the multiplier that best splits this step's strain along the flow direction there,
        dgamma = (c f_p + s f_J) / (f_p^2 + f_J^2), c = de_v - E(p; p_n), s = (J_tr - J) / G."""
        p, J = invariants(guess["stress"][idx])
        kappa = guess["cap_L"][idx]
        s = surface(p, J, kappa, k)
        c = trial.de_v[idx] - bulk.strain(p, trial.p_n[idx])
        shear = (trial.J_tr[idx] - J) / self.G
        dgamma = np.maximum((c * s.f_p + shear * s.f_J) / (s.f_p**2 + s.f_J**2), 0.0)
        return np.stack([p, J, dgamma, kappa], axis=1)

    def _cap_return(self, trial, bulk, idx, p_tr, kappa_n, scale, response, guess=None):
        """Return onto the hardening cap (smooth_return with h = kappa, the cap centre
        L = max(kappa, L_min): below L_min only the cap's end X(kappa) moves, and its
        height (X - L) / R falls short of F(L)), from the trial state or, where the
        ``guess`` state is on a free cap, from it; returns kappa."""
        R, L_min = self.R, self.L_min
        volumetric = self.hardening is CapHardening.VOLUMETRIC

        def surface(p, J, kappa, k):
            F, dF, _ = self.failure(kappa)
            free = kappa >= L_min
            L = np.where(free, kappa, L_min)
            a = (3.0 * p - L) / R
            rho = np.hypot(a, J)
            r3 = rho**3
            height = np.where(free, F, (kappa - L_min) / R + F)
            f_h = np.where(free, -a / (R * rho) - dF, -1.0 / R - dF)
            return Surface(f=rho - height, f_p=3.0 * a / (R * rho), f_J=J / rho, f_h=f_h,
                           f_pp=9.0 * J**2 / (R**2 * r3), f_pJ=-3.0 * a * J / (R * r3),
                           f_JJ=a**2 / r3, f_ph=np.where(free, -3.0 * J**2 / (R**2 * r3), 0.0),
                           f_Jh=np.where(free, a * J / (R * r3), 0.0), scale=scale[k])

        def admissible(p, J, kappa, k):
            # A cap of positive size; without the retreat kappa never goes below L_min.
            return self.X(kappa) >= L_min if volumetric else kappa >= L_min

        # Hardening (B.11): W (1 - exp(-D X(kappa))) - W (1 - exp(-D X(kappa_n))) = compaction.
        H_n = self.compaction(kappa_n)[0]

        def hardening(kappa, compaction, k):
            H, dH = self.compaction(kappa)
            return H - H_n[k] - compaction, dH, -np.ones_like(kappa)

        cold = np.stack([p_tr, trial.J_tr[idx], np.zeros(idx.size), kappa_n], axis=1)
        x0 = cold.copy()
        if guess is not None:
            k = np.flatnonzero((guess["yield_state"][idx] == CAP) & (guess["cap_L"][idx] > L_min))
            x0[k] = self._warm_start(trial, bulk, idx[k], guess, surface, k)
        p, J, _, kappa, sens, converged = smooth_return(
            surface, hardening, bulk, self.G, trial, idx, p_tr, kappa_n, x0, scale,
            admissible=admissible, fallback=cold)
        check_converged(self, converged, len(trial.p_n))
        response.solved(idx, p, J, *sens, CAP)
        return kappa


def cap_samples(table, cohesive):
    """Conformance samples of a cap model from its parameter tables with X0 = 20:
    ``table`` with the apex at I1 = 0 (A = C) and no cut-off, ``cohesive`` with
    the apex in tension and a cut-off below it; each with both hardenings, and
    in the modes that non-associated flow changes also with the dilatancy
    factors 0.5 and 0 (the cap corner only with 0.5: with 0 its normal cone is
    the vertical above it)."""
    n, I = SHEAR, IDENTITY
    every, associated, reduced = (1.0, 0.5, 0.0), (1.0,), (1.0, 0.5)
    # (mode, compression-positive p_n, deps, yield_state, dilatancy factors)
    plain = [("elastic", 3.0, 1e-5 * n - 1e-5 * I, ELASTIC, associated),
             ("failure", 3.0, 2e-3 * n, FAILURE, every),
             ("apex", 0.5, 1e-2 * I + 1e-4 * n, APEX, every),
             # p_lo - p_tr = 2.75 J_tr: associated flow returns to the failure surface
             ("apex, beyond the failure potential", 0.5, 8.5e-5 * I + 1.1e-4 * n, APEX,
              (0.5, 0.0)),
             ("cap", 5.0, -3e-3 * I + 5e-4 * n, CAP, associated),
             ("cap corner", 3.85, 1e-2 * n, CAP_CORNER, reduced)]   # I1_n = 11.55 just below L
    cut = [("elastic", 3.0, 1e-5 * n - 1e-5 * I, ELASTIC, associated),
           ("failure", 1.0, 2e-3 * n, FAILURE, every),
           ("cut-off", 0.0, 3e-4 * I + 1e-5 * n, CUTOFF, every),
           ("corner", 0.0, 3e-3 * I + 3e-3 * n, APEX, every),        # failure surface / cut-off
           # between the wedges of half and of full dilatancy for both cohesive tables
           ("corner, beyond the failure potential", 0.0, 2.8e-4 * I + 1.2e-3 * n, APEX,
            (0.5, 0.0)),
           ("cap", 5.0, -3e-3 * I + 5e-4 * n, CAP, associated),
           ("cap corner", 2.8, 1e-2 * n, CAP_CORNER, reduced)]
    return [Sample(*dilated(mode, {**t, "hardening": h.value}, eta), -p * I, deps, code)
            for h in CapHardening for t, cases in ((table, plain), (cohesive, cut))
            for mode, p, deps, code, etas in cases for eta in etas]


def dilated(mode, table, dilatancy):
    """(mode, table) of a sample with the dilatancy factor ``dilatancy`` (named in
    both unless associated)."""
    if dilatancy == 1.0:
        return mode, table
    return f"{mode}, dilatancy {dilatancy:g}", {**table, "dilatancy": dilatancy}


def retreating_samples(cls):
    """Conformance samples of the retreating cap at the sand's scale (ksi), from
    the cap end X_n (the centre L = max(kappa(X_n), 0)): the return modes the
    retreat adds, and where the failure surface dilates, those with half its
    dilatancy."""
    table = {**MCCORMICK_RANCH, "X0": 1.0, "hardening": CapHardening.VOLUMETRIC.value}
    sand = cls(**{**table, "hardening": CapHardening.VOLUMETRIC})
    n, I = SHEAR, IDENTITY
    # (mode, compression-positive p_n, deps, X_n, yield_state, dilatancy factors)
    cases = [("failure, the cap retreating", 0.1, 2e-5 * I + 2e-3 * n, 1.0, FAILURE, (1.0, 0.5)),
             ("moving cap corner", 0.01, 1e-4 * I + 3e-3 * n, 0.2, CAP_CORNER, (1.0, 0.5)),
             ("cap corner held at L = 0", 0.01, 5e-4 * I + 1e-2 * n, 0.2, CAP_CORNER, (1.0,)),
             ("shrunken cap, kappa < 0", 0.01, -3e-4 * I + 1e-4 * n, 0.1, CAP, (1.0,)),
             ("apex, lifted", 0.01, 1e-3 * I, 0.1, APEX, (1.0,))]
    return [Sample(*dilated(mode, table, eta), -p * I, deps, code,
                   {"cap_L": max(float(sand.kappa(np.array([X]))[0]), sand.L_min), "cap_X": X},
                   fd_step=1e-9)
            for mode, p, deps, X, code, etas in cases for eta in etas]


@dataclasses.dataclass(frozen=True)
class DiMaggioSandler(CapModel):
    """DiMaggio–Sandler cap: F(I1) = A - C exp(-beta I1) (eq. B.9; module doc)."""

    A: float = magnitude_param(doc="failure surface: the von Mises plateau sqrt(J2) = A, "
                                   "stress units")

    def failure(self, I1):
        e = self.C * np.exp(-self.beta * I1)
        return self.A - e, self.beta * e, -self.beta**2 * e

    @classmethod
    def conformance_samples(cls):
        table = {k: v for k, v in SECTION_VII5.items() if k != "B"} | {"X0": 20.0}
        return (cap_samples(table, {**table, "A": 8.0, "tension_cutoff": 1.0})
                + retreating_samples(cls))


@dataclasses.dataclass(frozen=True)
class ModifiedCap(CapModel):
    """The dissertation's modified cap: F(I1) = A + B I1 - C exp(-beta I1)
    (eq. B.12; module doc): Drucker–Prager sqrt(J2) = A + B I1 at high pressure."""

    A: float = magnitude_param(doc="failure surface: intercept of the high-pressure line "
                                   "A + B I1, stress units")
    B: float = magnitude_param(zero=True, doc="failure surface: slope of the high-pressure "
                                              "Drucker–Prager line sqrt(J2) = A + B I1")

    def failure(self, I1):
        e = self.C * np.exp(-self.beta * I1)
        return self.A + self.B * I1 - e, self.B + self.beta * e, -self.beta**2 * e

    @classmethod
    def conformance_samples(cls):
        table = {**SECTION_VII5, "X0": 20.0}
        return cap_samples(table, {**table, "A": 8.0, "tension_cutoff": 0.5})
