"""The smooth hardening surfaces of the invariant models, per point, compiled:
the cap ellipse of the cap models (eq. B.10) with their failure function
(B.9, B.12) and hardening law (B.11), modified Cam-Clay (B.7) and Cam-Clay
(B.6) with the critical-state hardening (B.8). Compression positive, in
(p, J) with the hardening variable h (see :mod:`.invariant_return`).

A model is a parameter vector ``prm`` (:data:`PRM_SLOTS` floats): the slots every
invariant model has (shear modulus, volumetric law, pressure variable, which surface),
then its own. :func:`smooth_surface`, :func:`hardening_law` and
:func:`surface_admissible` pick the surface by ``prm[SURFACE]``, so the one
compiled local Newton of :mod:`.invariant_return` serves every model.
"""
import math

import numpy as np

from .jit import kernel

# --- the slots of every invariant model's parameter vector -----------------------------
#: shear modulus; bulk modulus of the linear law; 1.0 for the kappa-line law (kappa*, p_min);
#: the pressure variable's shift (p = exp(xi) - shift; NaN: xi is p itself); the surface.
G_, K_, EXPONENTIAL, KAPPA_STAR, P_MIN, LOG_SHIFT, SURFACE = range(7)
#: ``prm[SURFACE]``: the cap ellipse, modified Cam-Clay, Cam-Clay.
CAP_SURFACE, MODIFIED_CAM_CLAY, CAM_CLAY = 0.0, 1.0, 2.0

# --- the cap models' own slots ------------------------------------------------------------
#: A, B, C, beta of F(I1) = A + B I1 - C exp(-beta I1) (B = 0: DiMaggio–Sandler); the cap's
#: R, W, D; the smallest centre L_min; the lowest point (p_lo, J_lo, F'(3 p_lo)) of the
#: failure surface; X(L_min) and max(F(L_min), 0); the dilatancy factor eta_d; 1.0 for the
#: volumetric hardening.
(CAP_A, CAP_B, CAP_C, CAP_BETA, CAP_R, CAP_W, CAP_D, L_MIN, P_LO, J_LO, DF_LO, X_MIN, F_MIN,
 ETA_D, VOLUMETRIC) = range(7, 22)

# --- the critical-state models' own slots ------------------------------------------------
#: M of the critical state line q = M p; theta = (1 + e0) / (lam - kappa) of B.8.
CS_M, CS_THETA = range(7, 9)

#: The length of every invariant model's parameter vector.
PRM_SLOTS = 22


@kernel
def cap_failure(prm, I1):
    """(F, F', F'') of the failure surface sqrt(J2) = F(I1) = A + B I1 - C exp(-beta I1)
    (B.12; B.9 with B = 0), at one I1 (at an array: :func:`.cap.cap_failure_at`)."""
    e = prm[CAP_C] * np.exp(-prm[CAP_BETA] * I1)
    dF, d2F = prm[CAP_B] + prm[CAP_BETA] * e, -prm[CAP_BETA] ** 2 * e
    if prm[CAP_B] == 0.0:
        return prm[CAP_A] - e, dF, d2F
    return prm[CAP_A] + prm[CAP_B] * I1 - e, dF, d2F


@kernel
def cap_compaction(prm, L):
    """(H, dH/dL): the plastic compaction W (1 - exp(-D X(L))) of the cap at L (B.11),
    X(L) = L + R F(L)."""
    F, dF, _ = cap_failure(prm, L)
    return compaction_of(prm, L, F, dF)


@kernel
def compaction_of(prm, L, F, dF):
    """:func:`cap_compaction` given (F, F') at L."""
    e = np.exp(-prm[CAP_D] * (L + prm[CAP_R] * F))
    return prm[CAP_W] * (1.0 - e), prm[CAP_W] * prm[CAP_D] * e * (1.0 + prm[CAP_R] * dF)


@kernel
def cap_surface(prm, p, J, kappa):
    """The cap ellipse f = sqrt(((3p - L)/R)^2 + J^2) - (X - L)/R (B.10) at the hardening
    parameter kappa: centre L = max(kappa, L_min), end X = kappa + R F(kappa) (below
    L_min only the end moves). Returns f and its derivatives (see :func:`smooth_surface`)."""
    R, L_min = prm[CAP_R], prm[L_MIN]
    F, dF, _ = cap_failure(prm, kappa)
    free = kappa >= L_min
    L = kappa if free else L_min
    a = (3.0 * p - L) / R
    rho = math.hypot(a, J)
    r3 = rho**3
    height = F if free else (kappa - L_min) / R + F
    f_h = -a / (R * rho) - dF if free else -1.0 / R - dF
    f_ph = -3.0 * J**2 / (R**2 * r3) if free else 0.0
    f_Jh = a * J / (R * r3) if free else 0.0
    return (rho - height, 3.0 * a / (R * rho), J / rho, f_h, 9.0 * J**2 / (R**2 * r3),
            -3.0 * a * J / (R * r3), a**2 / r3, f_ph, f_Jh)


@kernel
def modified_cam_clay_value(prm, p, J, p_c):
    """f = q^2 + M^2 p (p - p_c) (B.7), q^2 = 3 J^2; positive outside."""
    return 3.0 * J**2 + prm[CS_M] ** 2 * p * (p - p_c)


@kernel
def modified_cam_clay_surface(prm, p, J, y, pc_n):
    """The distance form f = sqrt((p - p_c/2)^2 + 3 J^2 / M^2) - p_c / 2 of the B.7 ellipse
    at p_c = pc_n exp(y): it grows linearly far outside, so Newton converges from far
    trial states."""
    M2 = prm[CS_M] ** 2
    pc = pc_n * math.exp(y)
    a = p - 0.5 * pc
    b2 = 3.0 * J**2 / M2
    rho = math.sqrt(a**2 + b2)
    r3 = rho**3
    f_pc = -0.5 * (a / rho + 1.0)
    return (rho - 0.5 * pc, a / rho, 3.0 * J / (M2 * rho), f_pc * pc, b2 / r3,
            -3.0 * a * J / (M2 * r3), 3.0 * a**2 / (M2 * r3), -0.5 * b2 / r3 * pc,
            1.5 * a * J / (M2 * r3) * pc)


@kernel
def cam_clay_value(prm, p, J, p_c):
    """f = q + M p ln(p / p_c) (B.6), q = sqrt3 J; positive outside."""
    return math.sqrt(3.0) * J + prm[CS_M] * p * np.log(p / p_c)


@kernel
def cam_clay_surface(prm, p, J, y, pc_n):
    """B.6 at p_c = pc_n exp(y)."""
    M = prm[CS_M]
    log_ratio = math.log(p / pc_n) - y
    return (math.sqrt(3.0) * J + M * p * log_ratio, M * (log_ratio + 1.0), math.sqrt(3.0),
            -M * p, M / p, 0.0, 0.0, -M, 0.0)


@kernel
def smooth_surface(prm, p, J, h, pc_n):
    """(f, f_p, f_J, f_h, f_pp, f_pJ, f_JJ, f_ph, f_Jh) of the model's smooth surface at
    (p, J) and hardening variable h: the cap's kappa, or the critical-state models'
    y = ln(p_c / pc_n)."""
    kind = prm[SURFACE]
    if kind == CAP_SURFACE:
        return cap_surface(prm, p, J, h)
    if kind == MODIFIED_CAM_CLAY:
        return modified_cam_clay_surface(prm, p, J, h, pc_n)
    return cam_clay_surface(prm, p, J, h, pc_n)


@kernel
def hardening_law(prm, h, compaction, H_n):
    """(r_h, dr_h/dh, dr_h/dc) of the hardening residual for the step's plastic compaction
    c: the cap's W (1 - exp(-D X(kappa))) - H_n - c (B.11, H_n the compaction at the step's
    start), or the critical state's y / theta - c (B.8 integrated over the step)."""
    if prm[SURFACE] == CAP_SURFACE:
        H, dH = cap_compaction(prm, h)
        return H - H_n - compaction, dH, -1.0
    return h / prm[CS_THETA] - compaction, 1.0 / prm[CS_THETA], -1.0


@kernel
def surface_admissible(prm, p, J, h):
    """Where the local Newton's iterates may go, beyond the volumetric law's range: a cap of
    positive size (X(kappa) >= L_min with the retreating cap, else kappa >= L_min); p > 0
    on Cam-Clay (exp(xi) may underflow)."""
    kind = prm[SURFACE]
    if kind == CAP_SURFACE:
        if prm[VOLUMETRIC] == 1.0:
            return h + prm[CAP_R] * cap_failure(prm, h)[0] >= prm[L_MIN]
        return h >= prm[L_MIN]
    if kind == CAM_CLAY:
        return p > 0.0
    return True
