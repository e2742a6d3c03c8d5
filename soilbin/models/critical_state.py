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
import math

import numpy as np

from ..errors import InputError
from ..params import MAGNITUDE, magnitude_param, param
from ..tensors import IDENTITY
from .base import APEX, CAP, ELASTIC, FAILURE, SHEAR, TIP, Sample
from .elastic import ExponentialBulk, IsotropicElasticity, LinearBulk
from .invariant_return import (YIELD_TOL, Response, Surface, Trial, check_converged, invariants,
                               scalar_root, smooth_return)

SQRT3 = math.sqrt(3.0)
#: Tensile trials whose smooth Cam-Clay return has p / p_c below exp(-ORIGIN_EXPONENT)
#: go to the origin.
ORIGIN_EXPONENT = 700.0


class CriticalStateElasticity(enum.Enum):
    #: Constant K, G from E, nu (the dissertation's parameters).
    LINEAR = "linear"
    #: K = (1 + e0)(p + p_min) / kappa, G = E / (2 (1 + nu)) (Borja & Lee 1990).
    PRESSURE_DEPENDENT = "pressure_dependent"


@dataclasses.dataclass(frozen=True)
class CriticalStateModel(IsotropicElasticity):
    """Base of Cam-Clay and modified Cam-Clay (module doc); a subclass gives
    its yield function in (p, J), J = q / sqrt3."""

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

    @property
    def log_shift(self):
        """The local Newton's pressure variable: ln(p + shift), or p itself for None."""
        if self.elasticity is CriticalStateElasticity.PRESSURE_DEPENDENT:
            return self.p_min   # the volumetric residual is linear in ln(p + p_min)
        return None

    @property
    def bulk(self):
        """The volumetric elastic law (``elasticity``)."""
        if self.elasticity is CriticalStateElasticity.LINEAR:
            return LinearBulk(self.K)
        return ExponentialBulk(self.kappa / (1.0 + self.e0), self.p_min)

    # --- the yield function, in (p, J) with p_c = p_c,n exp(y) -------------------

    def yield_value(self, p, J, p_c):
        """f(p, J; p_c), positive outside."""
        raise NotImplementedError

    def surface(self, p, J, y, pc_n, f_scale):
        """The :class:`.invariant_return.Surface` at p_c = pc_n exp(y) (h = y)."""
        raise NotImplementedError

    def yield_pressure(self, p, J):
        """p_c of the yield surface through (p, J), p > 0."""
        raise NotImplementedError

    def critical_pressure(self, p_c):
        """p on the critical state line of the surface p_c (wet side: p above it)."""
        raise NotImplementedError

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

    def integrate(self, deps, state, guess=None):
        G, bulk, theta = self.G, self.bulk, self.theta
        n = len(deps)
        trial = Trial.split(deps, state["stress"], G)
        pc_n = state["p_c"]
        p_tr = bulk.pressure(trial.p_n, trial.de_v)
        J_tr = trial.J_tr
        response = Response(trial, bulk, p_tr)
        scale = pc_n + np.abs(p_tr) + J_tr
        remaining = self.outside(p_tr, J_tr, pc_n, scale)
        y = np.zeros(n)   # ln(p_c / p_c,n)
        idx, x0 = self.prepare(trial, bulk, p_tr, pc_n, response, y, remaining)
        if idx.size:
            pcn, sc = pc_n[idx], scale[idx]

            def surface(p, J, yy, k):
                return self.surface(p, J, yy, pcn[k], sc[k])

            def hardening(yy, compaction, k):   # ln(p_c / p_c,n) = theta compaction
                return yy / theta - compaction, np.full_like(yy, 1.0 / theta), -np.ones_like(yy)

            p, J, _, yy, sens, converged = smooth_return(
                surface, hardening, bulk, G, trial, idx, p_tr[idx], np.zeros(idx.size), x0,
                sc, log_shift=self.log_shift, admissible=self.admissible)
            check_converged(self, converged, n)
            compacting = p >= self.critical_pressure(pcn * np.exp(yy))
            response.solved(idx, p, J, *sens, np.where(compacting, CAP, FAILURE))
            y[idx] = yy

        sigma, tangent, compaction, eq = response.finish(bulk, G)
        new_state = {"stress": sigma, "p_c": pc_n * np.exp(y),
                     "eps_p_vol": state["eps_p_vol"] - compaction,
                     "eps_p_eq": state["eps_p_eq"] + eq, "yield_state": response.code}
        return sigma, tangent, new_state

    def outside(self, p_tr, J_tr, pc_n, scale):
        """Trial states outside the yield surface."""
        raise NotImplementedError

    def admissible(self, p, J, y, k):
        """Where the local Newton's iterates may go (beyond the elastic law's own range)."""
        return np.ones(len(p), dtype=bool)

    def prepare(self, trial, bulk, p_tr, pc_n, response, y, plastic):
        """The points for the smooth return and their Newton start (xi, J, dgamma, y):
        here every plastic point, from its trial state. (Cam-Clay first takes its
        vertices out and starts from a bracketed scalar solution.)"""
        idx = np.flatnonzero(plastic)
        xi = p_tr[idx] if self.log_shift is None else np.log(p_tr[idx] + self.log_shift)
        return idx, np.stack([xi, trial.J_tr[idx], np.zeros(idx.size), np.zeros(idx.size)],
                             axis=1)


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

    @classmethod
    def conformance_samples(cls):
        return critical_state_samples(("wet", CAP), ("dry", FAILURE))

    def yield_value(self, p, J, p_c):
        return 3.0 * J**2 + self.M**2 * p * (p - p_c)

    def surface(self, p, J, y, pc_n, f_scale):
        # The distance form f = sqrt((p - p_c/2)^2 + 3 J^2 / M^2) - p_c / 2 of the same
        # ellipse: it grows linearly far outside, so Newton converges from far trial states.
        M2 = self.M**2
        pc = pc_n * np.exp(y)
        a = p - 0.5 * pc
        b2 = 3.0 * J**2 / M2
        rho = np.sqrt(a**2 + b2)
        r3 = rho**3
        f_pc = -0.5 * (a / rho + 1.0)
        return Surface(f=rho - 0.5 * pc, f_p=a / rho, f_J=3.0 * J / (M2 * rho), f_h=f_pc * pc,
                       f_pp=b2 / r3, f_pJ=-3.0 * a * J / (M2 * r3), f_JJ=3.0 * a**2 / (M2 * r3),
                       f_ph=-0.5 * b2 / r3 * pc, f_Jh=1.5 * a * J / (M2 * r3) * pc,
                       scale=f_scale)

    def yield_pressure(self, p, J):
        return p + 3.0 * J**2 / (self.M**2 * p)

    def critical_pressure(self, p_c):
        return 0.5 * p_c

    def outside(self, p_tr, J_tr, pc_n, scale):
        return self.yield_value(p_tr, J_tr, pc_n) > YIELD_TOL * scale**2


@dataclasses.dataclass(frozen=True)
class CamClay(CriticalStateModel):
    """Original Cam-Clay, f = q + M p ln(p / p_c) (eq. B.6; module doc), with
    its vertices at the tip (p_c, 0) and at the origin."""

    @classmethod
    def conformance_samples(cls):
        return critical_state_samples(("tip", TIP), ("origin", APEX))

    @property
    def log_shift(self):
        return 0.0   # ln p: the flow direction is singular at p = 0

    def admissible(self, p, J, y, k):
        return p > 0.0   # exp(xi) may underflow

    def yield_value(self, p, J, p_c):
        return SQRT3 * J + self.M * p * np.log(p / p_c)

    def surface(self, p, J, y, pc_n, f_scale):
        M = self.M
        log_ratio = np.log(p / pc_n) - y
        zero = np.zeros_like(p)
        return Surface(f=SQRT3 * J + M * p * log_ratio, f_p=M * (log_ratio + 1.0),
                       f_J=np.full_like(p, SQRT3), f_h=-M * p, f_pp=M / p, f_pJ=zero, f_JJ=zero,
                       f_ph=np.full_like(p, -M), f_Jh=zero, scale=f_scale)

    def yield_pressure(self, p, J):
        return p * np.exp(np.minimum(SQRT3 * J / (self.M * p), 700.0))

    def critical_pressure(self, p_c):
        return p_c / math.e

    def outside(self, p_tr, J_tr, pc_n, scale):
        # p <= 0 is outside except at the origin itself (the limit f = 0 of the locus).
        tol = YIELD_TOL * scale
        out = (p_tr <= 0.0) & ((p_tr < -tol) | (J_tr > tol))
        pos = p_tr > 0.0
        out[pos] = self.yield_value(p_tr[pos], J_tr[pos], pc_n[pos]) > tol[pos]
        return out

    def prepare(self, trial, bulk, p_tr, pc_n, response, y, plastic):
        """Cam-Clay's plastic points by a scalar reduction in xi = ln p: with
        f_J = sqrt3 constant, the hardening y = theta (de_v - E(p)) and the
        consistency condition give dgamma and J as functions of p,

            l = ln(p / p_c) = xi - ln p_c,n - theta (de_v - E(p)),
            dgamma = (sqrt3 J_tr + M p l) / (3 G),   J = J_tr - sqrt3 G dgamma,

        and the volumetric split leaves phi(xi) = E(p) - de_v + dgamma M (l + 1) = 0
        on xi < xi_tip (l < 0, J > 0), xi_tip the tip l = 0. phi(xi_tip) <= 0
        is the tip vertex (the deviator fits its normal cone); phi > 0 still
        700 below xi_tip is the origin (sigma = 0 to rounding); otherwise the
        bracketed root starts the Newton of the full system (which gives the tangent)."""
        G, M, theta = self.G, self.M, self.theta
        idx = np.flatnonzero(plastic)
        if idx.size == 0:
            return idx, np.zeros((0, 4))
        de_v, J_tr, p_n, pcn = trial.de_v[idx], trial.J_tr[idx], trial.p_n[idx], pc_n[idx]
        log_pcn = np.log(pcn)

        def ell(xi, k):
            p = np.exp(xi)
            c = bulk.compliance(p)
            return xi - log_pcn[k] - theta * (de_v[k] - bulk.strain(p, p_n[k])), c * p, p

        # The tip: l(xi) = 0, increasing in xi; p_tip lies between p_tr and p_c,n.
        ptr = p_tr[idx]
        lo = np.where(ptr > 0.0, np.log(np.minimum(np.where(ptr > 0.0, ptr, 1.0), pcn)),
                      log_pcn - ORIGIN_EXPONENT)
        hi = np.log(np.maximum(ptr, pcn))

        def tip_equation(xi, k):
            l, cp, _ = ell(xi, k)
            return l, 1.0 + theta * cp

        with np.errstate(all="ignore"):
            xi_tip, ok = scalar_root(tip_equation, lo, hi, x0=hi)
        check_converged(self, ok, len(p_tr))

        def phi(xi, k):
            l, cp, p = ell(xi, k)
            dl = 1.0 + theta * cp
            dgamma = (SQRT3 * J_tr[k] + M * p * l) / (3.0 * G)
            d_dgamma = M * p * (l + dl) / (3.0 * G)
            value = bulk.strain(p, p_n[k]) - de_v[k] + dgamma * M * (l + 1.0)
            return value, cp + M * ((l + 1.0) * d_dgamma + dgamma * dl)

        every = np.arange(idx.size)
        with np.errstate(all="ignore"):
            phi_tip = phi(xi_tip, every)[0]
            xi_lo = xi_tip - ORIGIN_EXPONENT
            phi_lo = phi(xi_lo, every)[0]
        tip = phi_tip <= 0.0
        origin = ~tip & (phi_lo >= 0.0)
        smooth = ~tip & ~origin

        # Tip: p = p_c, J = 0, dp/de_v = 1 / (E'(p) + 1 / (theta p)); one Newton step
        # in p itself removes the rounding of the logarithmic variable.
        it = idx[tip]
        p = np.exp(xi_tip[tip])
        with np.errstate(all="ignore"):
            g = bulk.strain(p, p_n[tip]) + np.log(p / pcn[tip]) / theta - de_v[tip]
            p_new = p - g / (bulk.compliance(p) + 1.0 / (theta * p))
        p = np.where(np.isfinite(p_new) & (p_new > 0.0), p_new, p)
        response.fixed(it, p, 0.0, TIP)
        response.p_e[it] = 1.0 / (bulk.compliance(p) + 1.0 / (theta * p))
        y[it] = np.log(p / pcn[tip])
        # Origin: sigma = 0 and the compaction de_v - E(0) (a dilation) softens p_c.
        io = idx[origin]
        response.fixed(io, 0.0, 0.0, APEX)
        with np.errstate(divide="ignore"):
            y[io] = theta * (de_v[origin] - bulk.strain(np.zeros(io.size), p_n[origin]))

        sm = np.flatnonzero(smooth)
        with np.errstate(all="ignore"):
            xi, ok = scalar_root(lambda x, k: phi(x, sm[k]), xi_lo[sm], xi_tip[sm], x0=xi_tip[sm])
        check_converged(self, ok, len(p_tr))
        l, _, p = ell(xi, sm)
        dgamma = (SQRT3 * J_tr[sm] + M * p * l) / (3.0 * G)
        x0 = np.stack([xi, J_tr[sm] - SQRT3 * G * dgamma, dgamma,
                       theta * (de_v[sm] - bulk.strain(p, p_n[sm]))], axis=1)
        return idx[sm], x0

