"""Cap models: DiMaggio & Sandler (1971) and the dissertation's modified cap
(app. B.4, eqs. B.9-B.12; Sture et al.'s artificial soil), associated by
default, optionally with less dilatancy on the failure surface, and with a
tension cut-off. Return mapping after Simo, Ju, Pister & Taylor (1988)
and Hofstetter, Simo & Taylor (1993): the trial state's region in the
(I1, sqrt(J2)) plane picks the active surface or corner, and only the cap
needs a local Newton (the failure surface does not harden: a bracketed scalar
equation; corners and cut-off: closed form), on a free cap in two unknowns
(:func:`cap_equations`: linear elasticity gives the stress in closed form).

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

    cap         I1_tr > L and f_C > 0            local Newton in (dgamma / rho, kappa), or
                (p, J, dgamma, kappa) where that fails or the cap has retreated;
                where it has no root (the trial above the corner of a cap that can
                hardly harden any more), the cap corner (L, F(L)), L moving ahead
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
import dataclasses
import enum
import functools
import math
from typing import ClassVar

import numpy as np

from ..params import magnitude_param, param
from ..tensors import IDENTITY
from .base import APEX, CAP, CAP_CORNER, CUTOFF, ELASTIC, FAILURE, SHEAR, Sample
from .cone import tension_cutoff_param
from .elastic import IsotropicElasticity
from .invariant_return import (NEWTON_TOL, STALL_TOL, YIELD_TOL, bracketed_root,
                               bulk_compliance, bulk_pressure, bulk_strain, check_converged,
                               finish, invariants, local_settings, point_invariants,
                               smooth_return, solved_ratio, strain_row, trial_split)
from .jit import kernel
from .yield_surfaces import (CAP_A, CAP_B, CAP_BETA, CAP_C, CAP_D, CAP_R, CAP_SURFACE, CAP_W,
                             DF_LO, ETA_D, EXPONENTIAL, F_MIN, G_, J_LO, K_, L_MIN, LOG_SHIFT,
                             P_LO, PRM_SLOTS, SURFACE, VOLUMETRIC, X_MIN, cap_compaction,
                             cap_failure, compaction_of, smooth_surface)

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


# --- the return map of one point (module doc, *Regions*), compiled ------------------------

@kernel
def failure_split(prm, p, F, dF, p_n, de_v, J_tr):
    """g(p) = E(p; p_n) - de_v - 3 eta_d F' (J_tr - F) / G with (F, F') at I1 = 3p:
    the volumetric strain left by a return onto the failure surface at p along
    its potential, dgamma = (J_tr - F) / G (module doc); g = 0 at the return."""
    return bulk_strain(prm, p, p_n) - de_v - 3.0 * prm[ETA_D] * dF * (J_tr - F) / prm[G_]


@kernel
def failure_slope(prm, p, J_tr, F, dF, d2F):
    """dg/dp of :func:`failure_split`: 1/K(p) + 9 eta_d (F'^2 - F'' (J_tr - F)) / G,
    at least 1/K(p) where J_tr >= F (F'' <= 0)."""
    return bulk_compliance(prm, p) + 9.0 * prm[ETA_D] * (dF**2 - d2F * (J_tr - F)) / prm[G_]


@kernel
def failure_sensitivities(prm, p, J_tr, F, dF, d2F):
    """(p_e, p_J, J_e, J_J) of the failure return at p (implicit-function theorem
    on g(p) = 0, J = F(3p)): p_e = 1/g', p_J = 3 eta_d F' / (G g'), J_e = 3 F' p_e,
    J_J = 3 F' p_J; G p_J != J_e (unsymmetric tangent) unless eta_d = 1."""
    dg = failure_slope(prm, p, J_tr, F, dF, d2F)
    p_e, p_J = 1.0 / dg, 3.0 * prm[ETA_D] * dF / (prm[G_] * dg)
    return p_e, p_J, 3.0 * dF * p_e, 3.0 * dF * p_J


@kernel
def failure_equation(p, args):
    """(g, g') of the return onto the failure surface at p (:func:`failure_split`)."""
    prm, p_n, de_v, J_tr = args
    F, dF, d2F = cap_failure(prm, 3.0 * p)
    return failure_split(prm, p, F, dF, p_n, de_v, J_tr), failure_slope(prm, p, J_tr, F, dF, d2F)


failure_root = bracketed_root(failure_equation)


@kernel
def position_equation(k, args):
    """X(k) - X and its slope: the cap's end X(k) = k + R F(k) is increasing."""
    prm, X = args
    F, dF, _ = cap_failure(prm, k)
    return k + prm[CAP_R] * F - X, 1.0 + prm[CAP_R] * dF


position_root = bracketed_root(position_equation)


@kernel
def kappa_of(prm, X):
    """The hardening parameter kappa with X(kappa) = X: the cap centre is
    L = max(kappa, L_min) (Sandler & Rubin 1979). X(k) >= k above L_min (F >= 0) and
    X(k) <= k + R F(L_min) below it. Returns (kappa, converged)."""
    if X >= prm[X_MIN]:
        lo, hi = prm[L_MIN], X
    else:
        lo, hi = X - prm[CAP_R] * prm[F_MIN], prm[L_MIN]
    return position_root((prm, X), lo, hi, math.nan)


@kernel
def kappa_at(prm, H):
    """kappa whose compaction W (1 - exp(-D X(kappa))) is H < W (B.11), the cap's
    end X not below L_min (there the cap is the point L_min)."""
    return kappa_of(prm, max(-math.log1p(-H / prm[CAP_W]) / prm[CAP_D], prm[L_MIN]))


@kernel
def corner_equation(L, args):
    """(g, g') of the corner's volumetric split g(L) = E(L/3; p_n) - de_v + H(L) - H_n."""
    prm, p_n, de_v, H_n = args
    H, dH = cap_compaction(prm, L)
    return (bulk_strain(prm, L / 3.0, p_n) - de_v + H - H_n,
            bulk_compliance(prm, L / 3.0) / 3.0 + dH)


corner_root = bracketed_root(corner_equation)


@kernel
def corner_return(prm, p_n, de_v, kappa_n):
    """The stress at the corner (L, F(L)) of a retreating cap: the plastic strain
    is that of the failure surface (compaction H(L) - H(kappa_n) <= 0) plus
    deviatoric flow on the cap (its normal at the corner), so the volumetric split

        g(L) = E(L/3; p_n) - de_v + H(L) - H(kappa_n) = 0

    is a monotone scalar equation on [L_min, kappa_n] (g(kappa_n) > 0 here): a
    bracketed root, and dp/de_v = 1 / (3 g'(L)) > 0. Where g(L_min) >= 0 the
    corner stays at L_min (p, J fixed; the apex if F(L_min) = 0) and kappa
    follows the compaction below L_min. Returns (kappa, p, J, (p_e, p_J, J_e, J_J), code,
    converged)."""
    L_min = prm[L_MIN]
    args = (prm, p_n, de_v, cap_compaction(prm, kappa_n)[0])
    g_min = corner_equation(L_min, args)[0]
    at_min = g_min >= 0.0      # always where kappa_n < L_min (I1_tr <= L_n here)
    if at_min:   # the compaction left at L_min: H(kappa) = H(L_min) - g(L_min)
        kappa, converged = kappa_at(prm, cap_compaction(prm, L_min)[0] - g_min)
    else:
        kappa, converged = corner_root(args, L_min, kappa_n, math.nan)
    L = max(kappa, L_min)
    F, dF, _ = cap_failure(prm, L)
    L_e = 0.0 if at_min else 1.0 / corner_equation(L, args)[1]
    code = APEX if at_min and F <= 0.0 else CAP_CORNER
    return kappa, L / 3.0, max(F, 0.0), (L_e / 3.0, 0.0, dF * L_e, 0.0), code, converged


@kernel
def advancing_corner(prm, p_n, de_v, kappa_n, L_n, I1_tr, J_tr):
    """The stress at the corner (L, F(L)) of an advancing cap where its smooth part has no
    return (module doc, *Regions*): the cap's normal at its corner is deviatoric, and a cap
    whose compaction has nearly reached W (5e-7 short of it, dH/dL ~ 3e-8 per psi, at
    L = 202 psi on the tine's soil) can only move by a corner return. The centre L is the
    root of the corner's volumetric split g(L) = E(L/3; p_n) - de_v + H(L) - H(kappa_n)
    (:func:`corner_equation`) on [L_n, I1_tr]: g <= 0 at L_n (the trial is past it), >= 0
    at I1_tr (the elastic part alone reaches it). A solution only where the trial's J is
    at least F(L), the deviatoric flow outward. Returns as :func:`corner_return`."""
    args = (prm, p_n, de_v, cap_compaction(prm, kappa_n)[0])
    kappa, converged = corner_root(args, L_n, I1_tr, math.nan)
    F, dF, _ = cap_failure(prm, kappa)
    L_e = 1.0 / corner_equation(kappa, args)[1]
    converged = converged and corner_equation(L_n, args)[0] <= 0.0 and F <= J_tr
    return kappa, kappa / 3.0, F, (L_e / 3.0, 0.0, dF * L_e, 0.0), CAP_CORNER, converged


@kernel
def warm_start(prm, p_n, de_v, J_tr, guess_stress, guess_L):
    """(p, J, dgamma, kappa) of the cap return from a ``guess`` state on a free cap: its
    stress and cap centre, and the multiplier that best splits this step's strain along
    the flow direction there, dgamma = (c f_p + s f_J) / (f_p^2 + f_J^2),
    c = de_v - E(p; p_n), s = (J_tr - J) / G."""
    p, J = point_invariants(guess_stress)
    f_p, f_J = smooth_surface(prm, p, J, guess_L, 0.0)[1:3]
    c = de_v - bulk_strain(prm, p, p_n)
    shear = (J_tr - J) / prm[G_]
    return p, J, max((c * f_p + shear * f_J) / (f_p**2 + f_J**2), 0.0), guess_L


#: How close to the cap (relative to its height) a root of :func:`cap_return` must be.
ON_CAP = 1e-10


@kernel
def cap_equations(prm, p_tr, J_tr, H_n, mu, kappa):
    """The cap's return reduced to two unknowns, mu = dgamma / rho and kappa, on a free cap
    (L = kappa) with linear elasticity. The two strain splits of the local problem
    (:mod:`.invariant_return`, f_p = 3a / (R rho), f_J = J / rho) give the stress::

        J = J_tr / (1 + G mu),   a = (3p - kappa) / R = R (3 p_tr - kappa) / (R^2 + 9 K mu),

    rho = sqrt(a^2 + J^2), and leave the consistency and the hardening (B.10, B.11)::

        g_f = rho - F(kappa),   g_h = H(kappa) - H_n - 3 mu a / R

    (3 mu a / R = dgamma f_p, the step's plastic compaction). Returns (g_f, g_h), their
    Jacobian in (mu, kappa) (4 numbers, row by row) and (a, J, rho, 1 / (R^2 + 9 K mu))."""
    K, G, R = prm[K_], prm[G_], prm[CAP_R]
    c = 1.0 / (R * R + 9.0 * K * mu)
    a, J = R * (3.0 * p_tr - kappa) * c, J_tr / (1.0 + G * mu)
    rho = math.hypot(a, J)
    F, dF, _ = cap_failure(prm, kappa)
    H, dH = compaction_of(prm, kappa, F, dF)
    a_mu, a_k, J_mu = -9.0 * K * a * c, -R * c, -G * J / (1.0 + G * mu)
    return ((rho - F, H - H_n - 3.0 * mu * a / R),
            ((a * a_mu + J * J_mu) / rho, a * a_k / rho - dF,
             -3.0 * (a + mu * a_mu) / R, dH - 3.0 * mu * a_k / R),
            (a, J, rho, c))


@kernel
def cap_admissible(prm, mu, kappa):
    """Where the iterates of :func:`cap_return` may go: the free cap, 1 + G mu > 0 and
    R^2 + 9 K mu > 0."""
    return kappa >= prm[L_MIN] and mu > -1.0 / (prm[G_] + 9.0 * prm[K_] / prm[CAP_R]**2)


@kernel
def cap_solve(jac, b0, b1):
    """(mu, kappa) solving the 2 x 2 ``jac`` (row by row) times them = (b0, b1)."""
    det = jac[0] * jac[3] - jac[1] * jac[2]
    return (jac[3] * b0 - jac[1] * b1) / det, (jac[0] * b1 - jac[2] * b0) / det


@kernel
def cap_norm(g, scale, row):
    """The largest residual of :func:`cap_equations`, scaled as the general local problem's:
    the consistency by the stress scale, the hardening as a strain."""
    return max(abs(g[0]) / scale, abs(g[1]) * row)


@kernel
def norm_merit(g, scale, row):
    """``|g|^2 / 2`` of the scaled residuals of :func:`cap_equations`."""
    return 0.5 * ((g[0] / scale)**2 + (g[1] * row)**2)


@kernel
def cap_return(prm, p_tr, J_tr, H_n, mu, kappa, scale, row, settings):
    """The return onto a free cap of a soil with linear elasticity: Newton on the two
    unknowns of :func:`cap_equations` from (mu, kappa), with the general local Newton's
    tolerance, backtracking and polishing step
    (:func:`~.invariant_return.local_newton`): the same backward-Euler solution as
    :func:`~.invariant_return.smooth_return`, a 2 x 2 system instead of 4 x 4. Where it fails
    (an iterate off the free cap, dgamma < 0 at the root, no convergence) the caller solves
    the general local problem. Returns (p, J, kappa, (p_e, p_J, J_e, J_J), converged)."""
    failed = (0.0, 0.0, kappa, (0.0, 0.0, 0.0, 0.0), False)
    if not cap_admissible(prm, mu, kappa):
        return failed
    g, jac, stress = cap_equations(prm, p_tr, J_tr, H_n, mu, kappa)
    converged = False
    for _ in range(settings[0]):
        norm = cap_norm(g, scale, row)
        if norm <= NEWTON_TOL:
            converged = True
            break
        d_mu, d_k = cap_solve(jac, -g[0], -g[1])
        merit, step, moved = norm_merit(g, scale, row), 1.0, False
        for _ in range(settings[1]):
            mu_t, kappa_t = mu + step * d_mu, kappa + step * d_k
            if cap_admissible(prm, mu_t, kappa_t):
                g_t, jac_t, stress_t = cap_equations(prm, p_tr, J_tr, H_n, mu_t, kappa_t)
                merit_t = norm_merit(g_t, scale, row)
                if np.isfinite(merit_t) and merit_t <= (1.0 - 1e-4 * step) * merit:
                    mu, kappa, g, jac, stress, moved = mu_t, kappa_t, g_t, jac_t, stress_t, True
                    break
            step *= 0.5
        if not moved:
            converged = norm <= STALL_TOL     # stalled at the rounding floor
            break
    if not converged:
        return failed
    # Polish with one more full step.
    d_mu, d_k = cap_solve(jac, -g[0], -g[1])
    if cap_admissible(prm, mu + d_mu, kappa + d_k):
        g_t, jac_t, stress_t = cap_equations(prm, p_tr, J_tr, H_n, mu + d_mu, kappa + d_k)
        norm_t = cap_norm(g_t, scale, row)
        if np.isfinite(norm_t) and norm_t <= cap_norm(g, scale, row):
            mu, kappa, g, jac, stress = mu + d_mu, kappa + d_k, g_t, jac_t, stress_t
    K, G, R = prm[K_], prm[G_], prm[CAP_R]
    a, J, rho, c = stress
    # a root with dgamma >= 0 on the cap's half of the ellipse (3p >= L), on it to ON_CAP of
    # its height: the tolerance scaled by the trial's stress is loose where the trial is
    # far out (a shear of 1e15 G put a point 1e5 times above a cap 5.6 psi high)
    if mu < 0.0 or a < 0.0 or not abs(g[0]) <= ON_CAP * (rho - g[0]):
        return failed
    # The sensitivities by the implicit-function theorem on g(mu, kappa; p_tr, J_tr) = 0,
    # with dp_tr/de_v = K: d(mu, kappa) = -jac^-1 dg/dq for q = p_tr, J_tr.
    a_p, J_J0 = 3.0 * R * c, 1.0 / (1.0 + G * mu)
    a_mu, a_k, J_mu = -9.0 * K * a * c, -R * c, -G * J * J_J0
    mu_p, k_p = cap_solve(jac, -a * a_p / rho, 3.0 * mu * a_p / R)
    mu_J, k_J = cap_solve(jac, -J * J_J0 / rho, 0.0)
    p_p = (k_p + R * (a_p + a_mu * mu_p + a_k * k_p)) / 3.0
    p_J = (k_J + R * (a_mu * mu_J + a_k * k_J)) / 3.0
    return ((kappa + R * a) / 3.0, J, kappa,
            (K * p_p, p_J, K * J_mu * mu_p, J_J0 + J_mu * mu_J), True)


@kernel
def cap_point(prm, deps, stress_n, L_n, X_n, last, guess_stress, guess_L, settings,
              sigma, C, s_n, s_tr, n):
    """The return map of one point (module doc, *Regions*): writes sigma and C; returns
    (L, X, plastic compaction, equivalent plastic strain increment, yield_state,
    converged). ``last`` is the yield_state of the last iterate (ELASTIC if none), whose
    cap state ``guess_stress``, ``guess_L`` may start the cap's Newton."""
    R, L_min = prm[CAP_R], prm[L_MIN]
    p_n, de_v, J_tr = trial_split(prm, deps, stress_n, s_n, s_tr, n)
    p_tr = bulk_pressure(prm, p_n, de_v)
    p_lo, J_lo, dF_lo = prm[P_LO], prm[J_LO], prm[DF_LO]
    F_L, dF_L, _ = cap_failure(prm, L_n)
    # kappa = L but where the cap has retreated past L_min (module doc).
    kappa_n, height, converged = L_n, F_L, True
    if X_n < L_n + R * F_L:       # X_n < X(L_n)
        kappa_n, converged = kappa_of(prm, X_n)
        height = (X_n - L_n) / R   # of the cap at L: (X - L) / R
    scale = 3.0 * abs(p_tr) + J_tr + abs(X_n) + prm[CAP_C]
    tol = YIELD_TOL * scale

    f_fail = J_tr - cap_failure(prm, 3.0 * p_tr)[0]
    cap_side = 3.0 * p_tr > L_n
    cap = cap_side and math.hypot((3.0 * p_tr - L_n) / R, J_tr) - height > tol
    low = not cap_side and (f_fail > tol or p_lo - p_tr > tol)
    # Wedges of the fixed corners: the failure return's volumetric split g(p)
    # (failure_split) >= 0 at p_lo, <= 0 at L/3 puts the trial in the normal cone
    # of the corner, spanned by the return directions of its surfaces.
    corner = low and J_tr >= J_lo and failure_split(prm, p_lo, J_lo, dF_lo, p_n, de_v, J_tr) >= 0.0
    cut = low and not corner and J_tr < J_lo and p_tr < p_lo
    cap_corner = (low and not corner and not cut
                  and failure_split(prm, L_n / 3.0, F_L, dF_L, p_n, de_v, J_tr) <= 0.0)
    fail = low and not corner and not cut and not cap_corner
    volumetric = prm[VOLUMETRIC] == 1.0

    # The elastic response, overwritten by the return mode.
    p, J, code, kappa = p_tr, J_tr, ELASTIC, kappa_n
    sens = (1.0 / bulk_compliance(prm, p_tr), 0.0, 0.0, 1.0)
    ratio = 1.0
    if corner or (cap_corner and not volumetric):
        # The fixed vertices: the failure surface's lowest point (apex, or its corner with
        # the cut-off), the corner (L, F(L)) of a cap that never retreats. A vertex's own
        # tangent has no bulk stiffness (every trial in its normal cone returns to it). At
        # the foot of a short stretch of failure surface between the two vertices (a point
        # near the surface of a soil without strength at zero stress, where L is small) a
        # point under those tangents goes from one vertex to the other in every Newton
        # iterate, past the solution on the stretch between them, and the load step
        # stalls. A point that was at the other vertex at the last iterate therefore gets
        # the tangent of that stretch, the failure return's at the vertex.
        p = p_lo if corner else L_n / 3.0
        F, dF, d2F = cap_failure(prm, 3.0 * p)
        sens = (0.0, 0.0, 0.0, 0.0)
        if (corner and last == CAP_CORNER) or (cap_corner and last == APEX):
            sens = failure_sensitivities(prm, p, J_tr, F, dF, d2F)
        J, code = max(F, 0.0), APEX if corner else CAP_CORNER
    elif cut:
        p, sens, code = p_lo, (0.0, 0.0, 0.0, 1.0), CUTOFF
    elif fail:
        # Onto the failure surface (perfectly plastic) along its potential:
        # dgamma = (J_tr - J)/G, J = F(3p) and the volumetric split leave g(p) = 0.
        p, ok = failure_root((prm, p_n, de_v, J_tr), p_lo, L_n / 3.0, math.nan)
        converged = converged and ok
        F, dF, d2F = cap_failure(prm, 3.0 * p)
        J, sens, code = F, failure_sensitivities(prm, p, J_tr, F, dF, d2F), FAILURE
    elif cap:
        # Onto the hardening cap: in two unknowns on a free cap (cap_return), else the
        # general local problem (smooth_return with h = kappa, the cap centre
        # L = max(kappa, L_min)); from the trial state or, where the last iterate was on a
        # free cap, from it (there J = J_tr / (1 + G mu) gives mu).
        H_n, row = cap_compaction(prm, kappa_n)[0], strain_row(prm, p_tr, scale)
        mu0, k0 = 0.0, kappa_n
        if last == CAP and guess_L > L_min:
            J_g = point_invariants(guess_stress)[1]
            if J_g > 0.0:
                mu0, k0 = max((J_tr / J_g - 1.0) / prm[G_], 0.0), guess_L
        p, J, kappa, sens, ok = cap_return(prm, p_tr, J_tr, H_n, mu0, k0, scale, row,
                                           settings)
        if not ok:
            lp = (p_n, de_v, J_tr, kappa_n, scale, 0.0, H_n, row)
            cold = (p_tr, J_tr, 0.0, kappa_n)
            x0 = cold
            if last == CAP and guess_L > L_min:
                x0 = warm_start(prm, p_n, de_v, J_tr, guess_stress, guess_L)
            p, J, _, kappa, sens, ok = smooth_return(prm, lp, s_n, s_tr, x0, cold, settings)
        code = CAP
        if not ok:
            kappa, p, J, sens, code, ok = advancing_corner(prm, p_n, de_v, kappa_n, L_n,
                                                           3.0 * p_tr, J_tr)
        converged = converged and ok
    if volumetric and (corner or cut or fail or cap_corner):
        # The cap follows the plastic volumetric strain back (B.11); where its centre
        # L = max(kappa, L_min) would pass the stress (I1 > L), and beyond the failure
        # surface's normal at the corner, the stress is the corner.
        behind = cap_corner
        if not cap_corner:
            compaction = de_v - bulk_strain(prm, p, p_n)
            kappa, ok = kappa_at(prm, cap_compaction(prm, kappa_n)[0] + compaction)
            converged = converged and ok
            behind = 3.0 * p > max(kappa, L_min)
        if behind:
            kappa, p, J, sens, code, ok = corner_return(prm, p_n, de_v, kappa_n)
            converged = converged and ok
    if code != ELASTIC:
        ratio = solved_ratio(J, J_tr, sens[3])
    compaction, eq = finish(prm, p, ratio, sens, code != ELASTIC, s_tr, n, p_n, de_v, J_tr,
                            sigma, C)
    if kappa == kappa_n:
        return L_n, X_n, compaction, eq, code, converged
    return (max(kappa, L_min), kappa + R * cap_failure(prm, kappa)[0], compaction, eq, code,
            converged)


@kernel
def cap_update(prm, deps, stress, L_n, X_n, last, guess_stress, guess_L, settings,
               sigma, C, L, X, compaction, eq, code, scratch):
    """:func:`cap_point` at every point (``scratch`` (3, 6)); returns the number of points
    whose local solve did not converge."""
    s_n, s_tr, n = scratch[0], scratch[1], scratch[2]
    failed = 0
    for i in range(deps.shape[0]):
        L[i], X[i], compaction[i], eq[i], code[i], ok = cap_point(
            prm, deps[i], stress[i], L_n[i], X_n[i], last[i], guess_stress[i], guess_L[i],
            settings, sigma[i], C[i], s_n, s_tr, n)
        failed += 0 if ok else 1
    return failed


@kernel
def through_equation(L, args):
    """F(L)^2 - ((I1 - L)/R)^2 - J^2 and its slope."""
    prm, I1, J = args
    F, dF, _ = cap_failure(prm, L)
    R = prm[CAP_R]
    return F**2 - ((I1 - L) / R) ** 2 - J**2, 2.0 * F * dF + 2.0 * (I1 - L) / R**2


through_root = bracketed_root(through_equation)


@kernel
def cap_through(prm, I1, J, L, height):
    """The initial cap centres: where the stress (I1, J) lies beyond the cap of centre L
    and height (X0 - L)/R, the cap through it, F(L)^2 = ((I1 - L)/R)^2 + J^2 on [L, I1]
    (increasing in L); I1 itself where the stress is beyond failure. L in place."""
    R = prm[CAP_R]
    for i in range(I1.shape[0]):
        if I1[i] > L[i] and ((I1[i] - L[i]) / R) ** 2 + J[i] ** 2 > height[i] ** 2:
            if cap_failure(prm, I1[i])[0] >= J[i]:
                L[i] = through_root((prm, I1[i], J[i]), L[i], I1[i],
                                   math.nan)[0]
            else:
                L[i] = I1[i]




@kernel
def cap_failure_at(prm, I1, out):
    """:func:`cap_failure` at every I1, into the columns of out (n, 3)."""
    for i in range(I1.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = cap_failure(prm, I1[i])


@kernel
def cap_compaction_at(prm, L, out):
    """:func:`cap_compaction` at every L, into the columns of out (n, 2)."""
    for i in range(L.shape[0]):
        out[i, 0], out[i, 1] = cap_compaction(prm, L[i])


def at_every(function_at, prm, x, n_values):
    """The ``n_values`` values of a point function at a number (a tuple of numbers) or at
    every entry of an array (a tuple of arrays of its shape), through its compiled loop
    ``function_at(prm, x, out)``."""
    x = np.asarray(x, dtype=float)
    out = np.empty((x.size, n_values))
    function_at(prm, np.ascontiguousarray(x.ravel()), out)
    if x.ndim == 0:
        return tuple(out[0])
    return tuple(column.reshape(x.shape) for column in out.T)


@kernel
def kappa_array(prm, X, kappa):
    """:func:`kappa_of` at every X, into kappa; returns the number not converged."""
    failed = 0
    for i in range(X.shape[0]):
        kappa[i], ok = kappa_of(prm, X[i])
        failed += 0 if ok else 1
    return failed


@kernel
def apex_of(prm):
    """I1 where F = 0 (F is increasing and concave: Newton from 0 converges monotonically)."""
    x = 0.0
    for _ in range(200):
        F, dF, _ = cap_failure(prm, x)
        step = F / dF
        x -= step
        if abs(step) <= 1e-15 * (1.0 + abs(x)):
            break
    return x


@dataclasses.dataclass(frozen=True, kw_only=True)
class CapModel(IsotropicElasticity):
    """Base of the cap models (module doc); a subclass gives the failure function's
    parameters A and B (B = 0: DiMaggio–Sandler)."""

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

    # --- the parameter vector of the compiled return ------------------------------------

    @functools.cached_property
    def prm(self):
        """The parameters as the compiled return reads them (:mod:`.yield_surfaces`)."""
        prm = np.zeros(PRM_SLOTS)
        prm[[G_, K_, EXPONENTIAL, LOG_SHIFT, SURFACE]] = self.G, self.K, 0.0, math.nan, CAP_SURFACE
        prm[[CAP_A, CAP_B, CAP_C, CAP_BETA, CAP_R, CAP_W, CAP_D, ETA_D, VOLUMETRIC]] = (
            self.A, self.B, self.C, self.beta, self.R, self.W, self.D, self.dilatancy,
            float(self.hardening is CapHardening.VOLUMETRIC))
        # The failure surface's lowest point, from F alone (the slots above).
        p_lo, J_lo, dF_lo = self._lowest(prm)
        L_min = 3.0 * p_lo
        if self.hardening is CapHardening.VOLUMETRIC:
            L_min = max(L_min, 0.0)
        F_min = float(cap_failure(prm, L_min)[0])
        prm[[P_LO, J_LO, DF_LO, L_MIN, X_MIN, F_MIN]] = (p_lo, J_lo, dF_lo, L_min,
                                                         L_min + self.R * F_min, max(F_min, 0.0))
        return prm

    def _lowest(self, prm):
        """(p_lo, J_lo, F'(3 p_lo)): the mean stress where the elastic domain ends in
        tension (the apex, or the cut-off if that comes first) and sqrt(J2) there. The
        apex is where F = 0 (:func:`apex_of`)."""
        p_apex = apex_of(prm) / 3.0
        if -self.tension_cutoff > p_apex:
            p = -self.tension_cutoff
            F, dF, _ = cap_failure(prm, 3.0 * p)
            return p, F, dF
        return p_apex, 0.0, cap_failure(prm, 3.0 * p_apex)[1]

    # --- geometry ------------------------------------------------------------------------

    def failure(self, I1):
        """(F, F', F'') of the failure surface sqrt(J2) = F(I1), I1 compression positive."""
        return at_every(cap_failure_at, self.prm, I1, 3)

    @property
    def apex(self):
        """I1 where F = 0."""
        return apex_of(self.prm)

    @property
    def lowest(self):
        """(p_lo, J_lo, F'(3 p_lo)) (see :meth:`_lowest`)."""
        return tuple(float(v) for v in self.prm[[P_LO, J_LO, DF_LO]])

    @property
    def L_min(self):
        """The smallest cap centre L: the apex (or the cut-off), and with the
        volumetric hardening not on the tension side (Sandler & Rubin: L = max(kappa, 0))."""
        return float(self.prm[L_MIN])

    def X(self, L):
        """Cap position X(L) = L + R F(L)."""
        return L + self.R * self.failure(L)[0]

    def kappa(self, X):
        """The hardening parameter kappa with X(kappa) = X (:func:`kappa_of`)."""
        X = np.ascontiguousarray(X, dtype=float)
        kappa = np.empty_like(X)
        check_converged(self, kappa_array(self.prm, X, kappa), len(X))
        return kappa

    def compaction(self, L):
        """(H, dH/dL): the plastic compaction W (1 - exp(-D X(L))) of the cap at L (B.11)."""
        return at_every(cap_compaction_at, self.prm, L, 2)

    # --- driver interface ----------------------------------------------------------------

    def initial_state(self, n, stress0=None):
        state = super().initial_state(n, stress0)
        X0 = max(self.X0, self.L_min)
        if self.hardening is CapHardening.CAP_COMPACTION:
            X0 = max(X0, float(self.X(self.L_min)))
        kappa0 = float(self.kappa(np.array([X0]))[0])
        L = np.full(n, max(kappa0, self.L_min))
        p, J = invariants(state["stress"])
        cap_through(self.prm, 3.0 * p, J, L, (X0 - L) / self.R)   # F(L), or less (kappa < L_min)
        state["cap_L"] = L
        # X(L), but X0 itself where the cap has retreated past L_min (kappa0 < L_min).
        state["cap_X"] = self.X(L)
        if kappa0 < self.L_min:
            state["cap_X"][L == self.L_min] = X0
        return state

    def consistent_history(self, state):
        """The cap's end not below L_min, and its centre from it, L = max(kappa(X), L_min): a
        transfer that fits L and X one by one leaves X a little off X(L) where the cap has
        not retreated, a cap behind its centre, and beside a point at L_min takes X below
        it; the return takes neither (its local Newton does not converge)."""
        X = np.maximum(state["cap_X"], self.L_min)
        return {**state, "cap_X": X, "cap_L": np.maximum(self.kappa(X), self.L_min)}

    def integrate(self, deps, state, guess, tangent):
        m = len(deps)
        guess = state if guess is None else guess
        last = guess["yield_state"] if guess is not state else np.full(m, ELASTIC)
        sigma = np.empty((m, 6))
        L, X, compaction, eq, code = (np.empty(m) for _ in range(5))
        failed = cap_update(self.prm, np.ascontiguousarray(deps), state["stress"],
                            state["cap_L"], state["cap_X"], last, guess["stress"],
                            guess["cap_L"], local_settings(), sigma, tangent, L, X, compaction, eq,
                            code, np.empty((3, 6)))
        check_converged(self, failed, m)
        new_state = {"stress": sigma, "cap_L": L, "cap_X": X,
                     "eps_p_vol": state["eps_p_vol"] - compaction,
                     "eps_p_eq": state["eps_p_eq"] + eq, "yield_state": code}
        return sigma, new_state


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


def saturated_samples(table):
    """A cap that can hardly harden any more (its initial end X0 = 257.68 psi in the tine's
    soil: its compaction 5e-7 short of W, as ahead of the blade after 5 in of travel), the
    trial just above its corner: the advancing corner (:func:`advancing_corner`), with
    either hardening."""
    return [Sample(f"cap corner ahead of a saturated cap, {hardening.value}",
                   {**table, "X0": 257.68, "hardening": hardening.value}, -67.0 * IDENTITY,
                   0.014 * SHEAR - 3e-4 * IDENTITY, CAP_CORNER)
            for hardening in CapHardening]


@dataclasses.dataclass(frozen=True)
class DiMaggioSandler(CapModel):
    """DiMaggio–Sandler cap: F(I1) = A - C exp(-beta I1) (eq. B.9; module doc)."""

    A: float = magnitude_param(doc="failure surface: the von Mises plateau sqrt(J2) = A, "
                                   "stress units")
    #: no linear term: the failure surface tends to the von Mises plateau
    B: ClassVar[float] = 0.0

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

    @classmethod
    def conformance_samples(cls):
        table = {**SECTION_VII5, "X0": 20.0}
        return (cap_samples(table, {**table, "A": 8.0, "tension_cutoff": 0.5})
                + saturated_samples(table))
