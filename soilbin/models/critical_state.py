"""Cam-Clay and modified Cam-Clay (dissertation app. B.3, eqs. B.3-B.8, after
Roscoe & Schofield 1963 and Roscoe & Burland 1968; Wood 1990, ch. 4-7), with
the implicit return mapping of Borja & Lee (1990) and Borja (1991).

Compression positive inside (see :mod:`.invariant_return`): p = -tr(sigma)/3,
q = sqrt(3 J2). Critical state line q = M p (B.3) with M = 6 sin(phi) /
(3 - sin(phi)), the triaxial-compression match to Mohr–Coulomb. Yield
surfaces through the preconsolidation pressure p_c, their tip on the p axis:

    Cam-Clay (B.6)           f = q + M p ln(p / p_c)    critical state at p = p_c / e
    modified Cam-Clay (B.7)  f = q^2 + M^2 p (p - p_c)  critical state at p = p_c / 2

(The OCR's "p_i is the initial mean pressure ... p_u = p_i / 2.7182" is the
tip p_c and the critical-state point p_c / e of the Cam-Clay locus.)
Associated flow. (The modified Cam-Clay return works with the distance form
f = sqrt((p - p_c/2)^2 + q^2/M^2) - p_c/2 of the same ellipse, which grows
linearly far outside it, so that Newton converges from distant trial states.)
Hardening (B.8), e - ln p lines of slopes lam (normal
compression) and kappa (unloading), in natural logarithms:

    d p_c / p_c = theta d eps_v^p,  theta = (1 + e0) / (lam - kappa),

integrated exactly over a step, p_c = p_c,n exp(theta d eps_v^p), with the
plastic compaction d eps_v^p of the step (compression positive).

Elasticity (``elasticity``):

* ``"linear"`` (the default): constant K and G from E and nu. The
  dissertation lists E = 4000 psi and nu = 0.35 for every model of its
  footing comparison (VII.5) together with lam, kappa, e0, so its critical
  state model used them for the elastic part and kappa only through
  lam - kappa; with its kappa = 0.001 a kappa-line bulk modulus
  (1 + e0) p / kappa would be 1650 p, about zero at the free surface, and a
  constant K keeps the finite element tangent regular at zero stress.
* ``"pressure_dependent"``: the kappa-line K = (1 + e0)(p + p_min) / kappa
  with the constant shear modulus G = E / (2 (1 + nu)) of Borja & Lee (1990),
  integrated exactly over a step. The textbook closed forms (drained
  e - ln p lines; undrained p/p0 = (1 + eta^2/M^2)^-(1 - kappa/lam)) hold for
  this law. p_min >= 0 (default 0) shifts the law so that the bulk modulus
  at zero stress is (1 + e0) p_min / kappa; with p_min = 0 every point needs
  a compressive initial stress.

Initial preconsolidation pressure (:meth:`initial_state`): the larger of
``p_c0`` and ``ocr`` times the p_c of the yield surface through the initial
stress (normally consolidated at the in-situ stress for ocr = 1, the
dissertation's "p_i is the initial mean pressure"); ``p_c0`` governs where
the initial stress is low, as at a free surface.

Tension: both yield surfaces pass through the origin and enclose only
0 <= p <= p_c, so the mean stress never becomes tensile and no cut-off is
needed. Modified Cam-Clay is smooth there; the Cam-Clay locus has two
vertices, handled as their own modes: the tip (p = p_c, q = 0; its normal
cone spans (M, +-1) in (p, q), so isotropic compression is purely
volumetric) and the origin, which takes the tensile trial states whose
smooth return would lie closer to the origin than exp(-700) p_c (sigma = 0).

History: ``stress``, ``p_c`` (compression positive), ``eps_p_vol`` (trace
of the plastic strain, tension positive as every strain in the code),
``eps_p_eq`` (sqrt(2/3) ``|eps_p|`` accumulated) and ``yield_state``: 0
elastic, 1 on the yield surface dry of critical (dilating), 2 at the origin
(Cam-Clay), 4 on the yield surface wet of critical (compacting), 6 at the
Cam-Clay tip (codes of :mod:`.base`).
"""
import dataclasses
import enum
import functools
import math
from typing import ClassVar

import numpy as np

from ..errors import InputError
from ..params import MAGNITUDE, magnitude_param, param
from ..tensors import IDENTITY
from .base import APEX, CAP, ELASTIC, FAILURE, SHEAR, TIP, Sample
from .elastic import IsotropicElasticity
from .invariant_return import (YIELD_TOL, bracketed_root, bulk_compliance, bulk_pressure,
                               bulk_strain, bulk_strains, check_converged, finish, fixed_ratio,
                               invariants, local_settings, pressure_variable, smooth_return,
                               solved_ratio, strain_row, trial_split)
from .jit import kernel
from .yield_surfaces import (CAM_CLAY, CS_M, CS_THETA, EXPONENTIAL, G_, K_, KAPPA_STAR,
                             LOG_SHIFT, MODIFIED_CAM_CLAY, P_MIN, PRM_SLOTS, SURFACE,
                             cam_clay_value, modified_cam_clay_value)

SQRT3 = math.sqrt(3.0)
#: No Newton start (the vertices), or no fallback start of the smooth return.
NO_START = (math.nan, math.nan, math.nan, math.nan)
#: Tensile trials whose smooth Cam-Clay return has p / p_c below exp(-ORIGIN_EXPONENT)
#: go to the origin.
ORIGIN_EXPONENT = 700.0


class CriticalStateElasticity(enum.Enum):
    #: Constant K, G from E, nu (the dissertation's parameters).
    LINEAR = "linear"
    #: K = (1 + e0)(p + p_min) / kappa, G = E / (2 (1 + nu)) (Borja & Lee 1990).
    PRESSURE_DEPENDENT = "pressure_dependent"


# --- the return map of one point, compiled ------------------------------------------------

@kernel
def outside(prm, p_tr, J_tr, pc_n, scale):
    """Whether the trial state lies outside the yield surface. Cam-Clay: p <= 0 is outside
    except at the origin itself (the limit f = 0 of the locus)."""
    tol = YIELD_TOL * scale
    if prm[SURFACE] == MODIFIED_CAM_CLAY:
        return modified_cam_clay_value(prm, p_tr, J_tr, pc_n) > tol * scale
    if p_tr <= 0.0:
        return p_tr < -tol or J_tr > tol
    return cam_clay_value(prm, p_tr, J_tr, pc_n) > tol


@kernel
def critical_pressure(prm, p_c):
    """p on the critical state line of the surface p_c (wet side: p above it)."""
    return 0.5 * p_c if prm[SURFACE] == MODIFIED_CAM_CLAY else p_c / math.e


@kernel
def ell(xi, args):
    """Cam-Clay's reduction (:func:`cam_clay_start`): (l, E'(p) p, p) at xi = ln p."""
    prm, log_pcn, de_v, p_n, _ = args
    p = math.exp(xi)
    c = bulk_compliance(prm, p)
    return xi - log_pcn - prm[CS_THETA] * (de_v - bulk_strain(prm, p, p_n)), c * p, p


@kernel
def tip_equation(xi, args):
    """l(xi) = 0 at the tip, increasing in xi."""
    l, cp, _ = ell(xi, args)
    return l, 1.0 + args[0][CS_THETA] * cp


tip_root = bracketed_root(tip_equation)


@kernel
def phi_equation(xi, args):
    """phi(xi) = E(p) - de_v + dgamma M (l + 1) and its slope (:func:`cam_clay_start`)."""
    prm, _, de_v, p_n, J_tr = args
    G, M, theta = prm[G_], prm[CS_M], prm[CS_THETA]
    l, cp, p = ell(xi, args)
    dl = 1.0 + theta * cp
    dgamma = (SQRT3 * J_tr + M * p * l) / (3.0 * G)
    d_dgamma = M * p * (l + dl) / (3.0 * G)
    value = bulk_strain(prm, p, p_n) - de_v + dgamma * M * (l + 1.0)
    return value, cp + M * ((l + 1.0) * d_dgamma + dgamma * dl)


phi_root = bracketed_root(phi_equation)


@kernel
def cam_clay_start(prm, p_n, de_v, J_tr, p_tr, pc_n):
    """Cam-Clay's plastic point by a scalar reduction in xi = ln p: with
    f_J = sqrt3 constant, the hardening y = theta (de_v - E(p)) and the
    consistency condition give dgamma and J as functions of p,

        l = ln(p / p_c) = xi - ln p_c,n - theta (de_v - E(p)),
        dgamma = (sqrt3 J_tr + M p l) / (3 G),   J = J_tr - sqrt3 G dgamma,

    and the volumetric split leaves phi(xi) = E(p) - de_v + dgamma M (l + 1) = 0
    on xi < xi_tip (l < 0, J > 0), xi_tip the tip l = 0. phi(xi_tip) <= 0
    is the tip vertex (the deviator fits its normal cone); phi > 0 still
    700 below xi_tip is the origin (sigma = 0 to rounding); otherwise the
    bracketed root starts the Newton of the full system (which gives the tangent).
    Returns (code: TIP, APEX (the origin) or FAILURE (smooth), p, y, p_e, the Newton start
    (xi, J, dgamma, y), converged)."""
    G, M, theta = prm[G_], prm[CS_M], prm[CS_THETA]
    log_pcn = math.log(pc_n)
    args = (prm, log_pcn, de_v, p_n, J_tr)
    # The tip: l(xi) = 0, increasing in xi; p_tip lies between p_tr and p_c,n.
    lo = math.log(min(p_tr, pc_n)) if p_tr > 0.0 else log_pcn - ORIGIN_EXPONENT
    hi = math.log(max(p_tr, pc_n))
    xi_tip, converged = tip_root(args, lo, hi, hi)
    xi_lo = xi_tip - ORIGIN_EXPONENT
    if phi_equation(xi_tip, args)[0] <= 0.0:
        # Tip: p = p_c, J = 0, dp/de_v = 1 / (E'(p) + 1 / (theta p)); one Newton step
        # in p itself removes the rounding of the logarithmic variable.
        p = math.exp(xi_tip)
        g = bulk_strain(prm, p, p_n) + math.log(p / pc_n) / theta - de_v
        p_new = p - g / (bulk_compliance(prm, p) + 1.0 / (theta * p))
        if np.isfinite(p_new) and p_new > 0.0:
            p = p_new
        return (TIP, p, math.log(p / pc_n), 1.0 / (bulk_compliance(prm, p) + 1.0 / (theta * p)),
                NO_START, converged)
    if phi_equation(xi_lo, args)[0] >= 0.0:
        # Origin: sigma = 0 and the compaction de_v - E(0) (a dilation) softens p_c.
        return APEX, 0.0, theta * (de_v - bulk_strain(prm, 0.0, p_n)), 0.0, NO_START, converged
    xi, ok = phi_root(args, xi_lo, xi_tip, xi_tip)
    l, _, p = ell(xi, args)
    dgamma = (SQRT3 * J_tr + M * p * l) / (3.0 * G)
    x0 = (xi, J_tr - SQRT3 * G * dgamma, dgamma, theta * (de_v - bulk_strain(prm, p, p_n)))
    return FAILURE, p, 0.0, 0.0, x0, converged and ok


@kernel
def critical_state_point(prm, deps, stress_n, pc_n, settings, sigma, C, s_n, s_tr, n):
    """The return map of one point: writes sigma and C; returns (p_c, plastic compaction,
    equivalent plastic strain increment, yield_state, converged)."""
    p_n, de_v, J_tr = trial_split(prm, deps, stress_n, s_n, s_tr, n)
    p_tr = bulk_pressure(prm, p_n, de_v)
    scale = pc_n + abs(p_tr) + J_tr
    # The elastic response, overwritten by the return mode.
    p, J, y, code, ratio, converged = p_tr, J_tr, 0.0, ELASTIC, 1.0, True   # y = ln(p_c / p_c,n)
    sens = (1.0 / bulk_compliance(prm, p_tr), 0.0, 0.0, 1.0)
    if outside(prm, p_tr, J_tr, pc_n, scale):
        code = FAILURE
        x0 = (pressure_variable(prm, p_tr), J_tr, 0.0, 0.0)
        if prm[SURFACE] == CAM_CLAY:   # its vertices first, and a bracketed start
            code, p, y, p_e, x0, converged = cam_clay_start(prm, p_n, de_v, J_tr, p_tr, pc_n)
            J, sens = 0.0, (p_e, 0.0, 0.0, 0.0)
        if code == FAILURE:
            lp = (p_n, de_v, J_tr, 0.0, scale, pc_n, 0.0, strain_row(prm, p_tr, scale))
            p, J, _, y, sens, ok = smooth_return(prm, lp, s_n, s_tr, x0, NO_START, settings)
            converged = converged and ok
            code = CAP if p >= critical_pressure(prm, pc_n * math.exp(y)) else FAILURE
            ratio = solved_ratio(J, J_tr, sens[3])
        else:
            ratio = fixed_ratio(J, J_tr)
    compaction, eq = finish(prm, p, ratio, sens, code != ELASTIC, s_tr, n, p_n, de_v, J_tr,
                            sigma, C)
    return pc_n * math.exp(y), compaction, eq, code, converged


@kernel
def critical_state_update(prm, deps, stress, pc_n, settings, sigma, C, p_c, compaction, eq,
                          code, scratch):
    """:func:`critical_state_point` at every point (``scratch`` (3, 6)); returns the
    number of points whose local solve did not converge."""
    s_n, s_tr, n = scratch[0], scratch[1], scratch[2]
    failed = 0
    for i in range(deps.shape[0]):
        p_c[i], compaction[i], eq[i], code[i], ok = critical_state_point(
            prm, deps[i], stress[i], pc_n[i], settings, sigma[i], C[i], s_n, s_tr, n)
        failed += 0 if ok else 1
    return failed


@dataclasses.dataclass(frozen=True)
class CriticalStateModel(IsotropicElasticity):
    """Base of Cam-Clay and modified Cam-Clay (module doc); a subclass names its
    yield surface (``surface``) and the p_c of the surface through a stress."""

    phi: float = param(lo=0.0, hi=90.0, lo_open=True, hi_open=True,
                       doc="critical-state friction angle [degrees]: "
                           "M = 6 sin(phi) / (3 - sin(phi))")
    lam: float = magnitude_param(doc="slope lambda of the normal compression line, e against ln p")
    kappa: float = magnitude_param(doc="slope kappa of the unloading-reloading line, e against "
                                       "ln p (less than lam)")
    e0: float = magnitude_param(doc="initial void ratio")
    p_c0: float = magnitude_param(doc="preconsolidation pressure (compression positive) where "
                                      "the initial stress is lower; stress units")
    ocr: float = param(1.0, lo=1.0, hi=MAGNITUDE.hi,
                       doc="overconsolidation ratio: p_c starts at ocr times the p_c of the yield "
                           "surface through the initial stress (at least p_c0)")
    elasticity: CriticalStateElasticity = param(
        CriticalStateElasticity.LINEAR,
        doc="linear (K, G from E, nu) or pressure_dependent (K = (1+e0)(p+p_min)/kappa, "
            "G from E, nu)")
    p_min: float = magnitude_param(0.0, zero=True, doc="pressure_dependent only: "
                                                       "K = (1+e0)(p+p_min)/kappa; stress units")

    history = {"stress": (6,), "p_c": (), "eps_p_vol": (), "eps_p_eq": (), "yield_state": ()}
    #: ``prm[SURFACE]`` of the subclass.
    surface: ClassVar[float]

    def __post_init__(self):
        if isinstance(self.elasticity, str):   # direct construction with the TOML word
            try:
                object.__setattr__(self, "elasticity", CriticalStateElasticity(self.elasticity))
            except ValueError:
                raise InputError(f"elasticity = {self.elasticity!r} is not one of "
                                 + ", ".join(e.value for e in CriticalStateElasticity)) from None
        super().__post_init__()
        if not self.kappa < self.lam:
            raise InputError(f"lam = {self.lam!r} must be larger than kappa = {self.kappa!r}")

    @property
    def M(self):
        """Slope of the critical state line in (p, q)."""
        s = math.sin(math.radians(self.phi))
        return 6.0 * s / (3.0 - s)

    @property
    def theta(self):
        """(1 + e0) / (lam - kappa): d ln p_c / d eps_v^p."""
        return (1.0 + self.e0) / (self.lam - self.kappa)

    @functools.cached_property
    def prm(self):
        """The parameters as the compiled return reads them (:mod:`.yield_surfaces`): the
        volumetric law (``elasticity``) and the local Newton's pressure variable, ln(p + p_min)
        with the kappa-line (the volumetric residual is then linear in it), ln p on Cam-Clay
        (its flow direction is singular at p = 0), else p itself."""
        prm = np.zeros(PRM_SLOTS)
        exponential = self.elasticity is CriticalStateElasticity.PRESSURE_DEPENDENT
        shift = self.p_min if exponential else math.nan
        if self.surface == CAM_CLAY:
            shift = self.p_min if exponential else 0.0
        prm[[G_, K_, EXPONENTIAL, KAPPA_STAR, P_MIN, LOG_SHIFT, SURFACE, CS_M, CS_THETA]] = (
            self.G, self.K, float(exponential), self.kappa / (1.0 + self.e0), self.p_min, shift,
            self.surface, self.M, self.theta)
        return prm

    def yield_pressure(self, p, J):
        """p_c of the yield surface through (p, J), p > 0."""
        raise NotImplementedError

    def volumetric_elastic_strain(self, p, p_n):
        """The ``elasticity``'s volume strain from p_n to p (the kappa-line's integrated)."""
        out = np.empty(len(p))
        bulk_strains(self.prm, p, p_n, out)
        return out

    # --- driver interface -----------------------------------------------------------

    def initial_state(self, n, stress0=None):
        state = super().initial_state(n, stress0)
        p, J = invariants(state["stress"])
        if (self.elasticity is CriticalStateElasticity.PRESSURE_DEPENDENT and self.p_min == 0.0
                and np.any(p <= 0.0)):
            raise InputError("p_min = 0.0: pressure_dependent elasticity with p_min = 0 needs a "
                             f"compressive initial stress; {np.count_nonzero(p <= 0.0)} of {n} "
                             "points have p <= 0 (set p_min > 0 or an initial stress)")
        through = np.zeros(n)
        inside = p > 0.0
        with np.errstate(over="ignore"):
            through[inside] = self.yield_pressure(p[inside], J[inside])
        state["p_c"] = np.maximum(self.p_c0, self.ocr * through)
        return state

    def integrate(self, deps, state, guess, tangent):
        m = len(deps)
        sigma = np.empty((m, 6))
        p_c, compaction, eq, code = (np.empty(m) for _ in range(4))
        failed = critical_state_update(self.prm, np.ascontiguousarray(deps), state["stress"],
                                       state["p_c"], local_settings(), sigma, tangent, p_c,
                                       compaction, eq, code, np.empty((3, 6)))
        check_converged(self, failed, m)
        new_state = {"stress": sigma, "p_c": p_c, "eps_p_vol": state["eps_p_vol"] - compaction,
                     "eps_p_eq": state["eps_p_eq"] + eq, "yield_state": code}
        return sigma, new_state


#: A lightly overconsolidated clay (kPa): M = 1.2, the conformance samples' parameters.
SAMPLE_CLAY = {"E": 1.0e4, "nu": 0.3, "phi": 30.0, "lam": 0.2, "kappa": 0.04, "e0": 1.0,
               "p_c0": 1.0}


def critical_state_samples(tip, tension):
    """Conformance samples with p_c,n = 100 for either elasticity; ``tip`` and
    ``tension`` are the (mode, yield_state) of a trial beyond the tip and, with
    linear elasticity (the kappa-line with p_min = 0 carries no tension), of a
    tensile trial: Cam-Clay's vertices."""
    n, I = SHEAR, IDENTITY
    # (mode, compression-positive p_n, deps, yield_state)
    cases = [("elastic", 60.0, 1e-4 * n - 1e-4 * I, ELASTIC),
             ("wet", 100.0, -2e-3 * I + 1e-2 * n, CAP),          # compacting
             ("dry", 30.0, 1e-2 * n + 1e-4 * I, FAILURE),        # dilating
             (tip[0], 100.0, -5e-3 * I + 2e-5 * n, tip[1])]
    tensile = [(tension[0], 10.0, 5e-2 * I + 1e-7 * n, tension[1])]
    linear = CriticalStateElasticity.LINEAR
    return [Sample(mode, {**SAMPLE_CLAY, "elasticity": e.value}, -p * I, deps, code,
                   {"p_c": 100.0})
            for e in CriticalStateElasticity
            for mode, p, deps, code in cases + (tensile if e is linear else [])]


@dataclasses.dataclass(frozen=True)
class ModifiedCamClay(CriticalStateModel):
    """Modified Cam-Clay, f = q^2 + M^2 p (p - p_c) (eq. B.7; module doc)."""

    surface = MODIFIED_CAM_CLAY

    @classmethod
    def conformance_samples(cls):
        return critical_state_samples(("wet", CAP), ("dry", FAILURE))

    def yield_pressure(self, p, J):
        return p + 3.0 * J**2 / (self.M**2 * p)


@dataclasses.dataclass(frozen=True)
class CamClay(CriticalStateModel):
    """Original Cam-Clay, f = q + M p ln(p / p_c) (eq. B.6; module doc), with
    its vertices at the tip (p_c, 0) and at the origin."""

    surface = CAM_CLAY

    @classmethod
    def conformance_samples(cls):
        return critical_state_samples(("tip", TIP), ("origin", APEX))

    def yield_pressure(self, p, J):
        return p * np.exp(np.minimum(SQRT3 * J / (self.M * p), 700.0))
