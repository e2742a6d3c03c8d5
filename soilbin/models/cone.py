"""Perfectly plastic models with a circular cone as yield surface,

    f = sqrt(J2) + eta p - k,   p = I1 / 3   (tension positive),

which is Drucker–Prager (dissertation eq. B.2, eta = 3 alpha) and, for
eta = 0, von Mises (eq. B.1), and the flow potential

    g = sqrt(J2) + eta_g p,   0 <= eta_g <= eta

(eta_g = eta: associated flow, the dissertation's; eta_g < eta: less
dilatancy, eta_g = 0: isochoric flow). Closed-form return mapping and
consistent tangent after de Souza Neto et al. (2008), sections 7.3-7.4 and
8.3 (the non-associated cone, its apex and the unsymmetric tangent, box 8.8).

The apex. With eta_g < eta the potential's apex is not the yield surface's:
a trial stress beyond the cone's apex p = k/eta cannot always be brought
back by flow normal to g (for eta_g = 0 none can: the flow is isochoric).
The apex is therefore the corner of the cone with a cut-off p <= k/eta that
absorbs the extra volumetric plastic strain (associated on the cut-off);
the stress is the apex when the trial lies in the corner's normal cone,
spanned in the trial (p, sqrt(J2)) plane by the return directions (K eta_g, G)
of the cone and (K, 0) of the cut-off:

    G (p_tr - k/eta) > K eta_g sqrt(J2_tr),

which for eta_g = eta is exactly the associated apex region (the cone
return would give sqrt(J2) < 0), and for eta_g = 0 is p_tr > k/eta.

Optionally with a tension cut-off on the mean stress (soil that cannot carry
tension, dissertation sec. VI.4; as the tension cut-off of the cap models of
DiMaggio & Sandler 1971):

    f_t = p - T <= 0,   T >= 0,

associated as well. It is active when T < k / eta (below the apex; always
for eta = 0), and then the return has three plastic regions in the trial
(sqrt(J2), p) plane, separated by the flow directions at the corner
(p = T, sqrt(J2) = J_c = k - eta T): the cone, (G, K eta_g), and the cut-off, (0, K):

    cone     J_tr > J_c,  G (p_tr - T) <  eta_g K (J_tr - J_c)   (and f_tr > 0),
    corner   J_tr > J_c,  G (p_tr - T) >= eta_g K (J_tr - J_c),
    cut-off  J_tr <= J_c, p_tr > T.

The corner replaces the apex; with T >= k / eta the cut-off is inactive and
the return is exactly that of the plain cone.

Compiled per point (:mod:`soilbin.models.jit`): :func:`return_map` is the return of one
point from its trial stress, :func:`cone_update` the loop over the points
that :meth:`ConeModel.integrate` calls once, on the elastic predictor of
:meth:`.elastic.IsotropicElasticity.trial` (elastic points return it exactly).
"""
import abc
import dataclasses
import math

import numpy as np

from ..params import param
from ..tensors import IDENTITY, P_DEV, P_VOL, SQRT2
from .base import APEX, CUTOFF, ELASTIC, FAILURE, SHEAR, Sample
from .elastic import IsotropicElasticity
from .invariant_return import YIELD_TOL
from .jit import kernel


def tension_cutoff_param():
    """The ``tension_cutoff`` field shared by the cone models."""
    return param(math.inf, lo=0.0, hi=math.inf,
                 doc="largest mean stress p = I1/3 the soil carries (tension positive); "
                     "inf (the default) or at least the cone's apex: no cut-off")


@kernel
def cutoff_active(eta, k, tension_cutoff):
    """True when the cut-off p <= T cuts the cone (T below the apex k / eta)."""
    return math.isfinite(tension_cutoff) and eta * tension_cutoff < k


# --- one point ------------------------------------------------------------------------------
#
# ``prm`` is the model's (K, G, eta, k, T, eta_g) (:attr:`ConeModel.prm`); a point's trial
# stress travels as (p_tr, J_tr = sqrt(J2_tr)), its deviator s and the direction n of s.

@kernel
def trial_invariants(sigma_tr, s, n):
    """(p_tr, J_tr) of the trial stress sigma_tr = sigma_n + C_e : deps; its deviator
    into s and the direction n = s / ``|s|`` (zero where s = 0) into n."""
    p = (sigma_tr[0] + sigma_tr[1] + sigma_tr[2]) / 3.0
    ss = 0.0
    for i in range(6):
        s[i] = sigma_tr[i] - p if i < 3 else sigma_tr[i]
        ss += s[i] * s[i]
    norm = math.sqrt(ss)
    for i in range(6):
        n[i] = s[i] / norm if norm > 0.0 else 0.0
    return p, norm / SQRT2


@kernel
def stress_from(s, ratio, p, sigma):
    """sigma = ratio s + p I."""
    for i in range(6):
        sigma[i] = s[i] * ratio + (p if i < 3 else 0.0)


@kernel
def elastic_tangent(K, G, C):
    """C = C_e = 3K P_vol + 2G P_dev."""
    for i in range(6):
        for j in range(6):
            C[i, j] = 3.0 * K * P_VOL[i, j] + 2.0 * G * P_DEV[i, j]


@kernel
def add_turn(factor, n, C):
    """C += factor (P_dev - n x n): the deviator's turn with its direction n."""
    for i in range(6):
        for j in range(6):
            C[i, j] += factor * (P_DEV[i, j] - n[i] * n[j])


@kernel
def consistent_tangent(K, G, eta, eta_g, n, ratio, C):
    """Algorithmic tangent on the cone (de Souza Neto et al. 2008, sec. 8.3,
    box 8.8 for non-associated flow):

        C = C_e - 2G ratio (P_dev - n x n) - b_g x b_f / (G + K eta eta_g),
        b_g = sqrt2 G n + eta_g K I  (the plastic correction's direction),
        b_f = sqrt2 G n + eta K I    (d f_tr / d eps),

    with n = ``s_tr / |s_tr|`` (6,) and ratio = G dgamma / sqrt(J2_tr), into C;
    unsymmetric unless eta_g = eta.
    """
    elastic_tangent(K, G, C)
    add_turn(-(2.0 * G * ratio), n, C)
    d = G + K * eta * eta_g
    for i in range(6):
        b_g = SQRT2 * G * n[i] + (eta_g * K if i < 3 else 0.0)
        for j in range(6):
            b_f = SQRT2 * G * n[j] + (eta * K if j < 3 else 0.0)
            C[i, j] -= b_g * b_f / d


@kernel
def cone_return(prm, p_tr, J_tr, f_tr, s, n, sigma, C):
    """The return onto the cone along the potential g (de Souza Neto et al. 2008,
    box 8.8): dgamma = f_tr / (G + K eta eta_g), s = s_tr (1 - G dgamma / J_tr),
    p = p_tr - K eta_g dgamma; writes sigma and the :func:`consistent_tangent` C."""
    K, G, eta, k, T, eta_g = prm
    dgamma = f_tr / (G + K * eta * eta_g)
    ratio = G * dgamma / J_tr
    stress_from(s, 1.0 - ratio, p_tr - K * eta_g * dgamma, sigma)
    consistent_tangent(K, G, eta, eta_g, n, ratio, C)


@kernel
def return_map(prm, p_tr, J_tr, s, n, sigma, C):
    """The return of one point from its trial stress (sigma holds it, elastic points keep
    it) for the cone (eta, k) with the flow potential's slope eta_g, optionally cut off
    at the mean stress p = T: writes sigma and the tangent C, returns the yield_state."""
    K, G, eta, k, T, eta_g = prm
    f_tr = J_tr + eta * p_tr - k
    plastic = f_tr > YIELD_TOL * (k + J_tr + eta * abs(p_tr))
    if cutoff_active(eta, k, T):
        return cutoff_return_map(prm, p_tr, J_tr, f_tr, plastic, s, n, sigma, C)
    if not plastic:
        elastic_tangent(K, G, C)
        return ELASTIC
    # The apex: the trial beyond the corner normal cone (module doc); for
    # eta_g > 0 the same as sqrt(J2) = J_tr - G dgamma < 0 on the cone.
    if eta > 0.0 and G * (p_tr - k / eta) > K * eta_g * J_tr:
        stress_from(s, 0.0, k / eta, sigma)   # sigma = (k/eta) I
        C[:] = 0.0   # perfect plasticity: the apex stress k/eta is fixed
        return APEX
    cone_return(prm, p_tr, J_tr, f_tr, s, n, sigma, C)
    return FAILURE


@kernel
def cutoff_return_map(prm, p_tr, J_tr, f_tr, plastic, s, n, sigma, C):
    """:func:`return_map` with an active cut-off p <= T (regions: module doc)."""
    K, G, eta, k, T, eta_g = prm
    plastic = plastic or p_tr - T > YIELD_TOL * (k + J_tr + abs(p_tr))
    J_c = k - eta * T   # sqrt(J2) at the corner, > 0
    if not plastic:
        elastic_tangent(K, G, C)
        return ELASTIC
    if J_tr > J_c and G * (p_tr - T) >= eta_g * K * (J_tr - J_c):
        # Corner: p = T and sqrt(J2) = J_c are fixed, only the direction n of s turns.
        stress_from(s, J_c / J_tr, T, sigma)
        C[:] = 0.0
        add_turn(2.0 * G * (J_c / J_tr), n, C)
        return APEX
    if J_tr <= J_c:
        stress_from(s, 1.0, T, sigma)
        elastic_tangent(0.0, G, C)   # p = T is fixed, s = s_tr: 2G P_dev
        return CUTOFF
    cone_return(prm, p_tr, J_tr, f_tr, s, n, sigma, C)   # here f_tr > 0 and the return has p < T
    return FAILURE


@kernel
def equivalent_plastic_strain(K, G, deps, stress_n, sigma):
    """sqrt(2/3) ``|deps_p|`` with deps_p = deps - C_e^-1 : (sigma - sigma_n),
    C_e^-1 = P_vol / 3K + P_dev / 2G."""
    dp = ((sigma[0] - stress_n[0]) + (sigma[1] - stress_n[1]) + (sigma[2] - stress_n[2])) / 3.0
    ss = 0.0
    for i in range(6):
        ds = sigma[i] - stress_n[i]
        e = deps[i] - ((ds - dp) / (2.0 * G) + dp / (3.0 * K) if i < 3 else ds / (2.0 * G))
        ss += e * e
    return math.sqrt(2.0 / 3.0) * math.sqrt(ss)


# --- every point ----------------------------------------------------------------------------

@kernel
def cone_update(prm, deps, stress_n, eps_p_eq_n, sigma, C, eps_p_eq, yield_state, scratch):
    """:func:`return_map` at every point from the committed stress_n; sigma holds the
    trial stresses and gets the returned ones. Writes C and the history, eps_p_eq (grown
    by :func:`equivalent_plastic_strain` where plastic) and yield_state; ``scratch`` (2, 6)."""
    K, G = prm[0], prm[1]
    s, n = scratch[0], scratch[1]
    for i in range(deps.shape[0]):
        p_tr, J_tr = trial_invariants(sigma[i], s, n)
        code = return_map(prm, p_tr, J_tr, s, n, sigma[i], C[i])
        yield_state[i], eps_p_eq[i] = code, eps_p_eq_n[i]
        if code > ELASTIC:
            eps_p_eq[i] += equivalent_plastic_strain(K, G, deps[i], stress_n[i], sigma[i])


def cone_samples(tables, cut_tables, apex=True):
    """Conformance samples of a cone model from its parameter tables: ``tables``
    without a cut-off (and with an ``apex``: eta > 0), ``cut_tables`` with one below the apex."""
    n, I, stressed, free = SHEAR, IDENTITY, -200.0 * IDENTITY, np.zeros(6)
    inside = [("elastic", stressed, 1e-4 * n - 1e-4 * I, ELASTIC),
              ("cone", stressed, 2e-2 * n - 1e-3 * I, FAILURE)]
    beyond = [("apex", free, 5e-2 * I + 1e-4 * n, APEX)] if apex else []
    cut = [("cut-off", free, 3e-3 * I + 1e-4 * n, CUTOFF),
           ("corner", free, 5e-2 * I + 2e-2 * n, APEX)]
    cases = ([(t, inside + beyond) for t in tables]
             + [(t, inside + cut) for t in cut_tables])
    return [Sample(mode, t, stress, deps, code, fd_step=1e-9)
            for t, modes in cases for mode, stress, deps, code in modes]


@dataclasses.dataclass(frozen=True)
class ConeModel(IsotropicElasticity):
    """Base of the cone models; a subclass gives its ``cone`` (eta, k) and may
    declare the field ``tension_cutoff: float = tension_cutoff_param()`` after
    its fields without a default (else it has no cut-off).

    History ``yield_state`` (codes of :mod:`.base`): FAILURE on the cone, APEX at
    the apex or at the corner of cone and tension cut-off, CUTOFF on the cut-off p = T.
    """

    history = {"stress": (6,), "eps_p_eq": (), "yield_state": ()}
    tension_cutoff = math.inf   # no cut-off unless a subclass declares the field

    @property
    @abc.abstractmethod
    def cone(self):
        """(eta, k) of f = sqrt(J2) + eta p - k."""

    @property
    def flow_slope(self):
        """eta_g of the flow potential g = sqrt(J2) + eta_g p (default: associated)."""
        return self.cone[0]

    @property
    def prm(self):
        """(K, G, eta, k, T, eta_g) as plain floats, as the compiled return reads them."""
        eta, k = self.cone
        return (float(self.K), float(self.G), float(eta), float(k), float(self.tension_cutoff),
                float(self.flow_slope))

    def integrate(self, deps, state, guess, tangent):
        m = len(deps)
        deps, stress_n = np.ascontiguousarray(deps), np.ascontiguousarray(state["stress"])
        sigma = self.trial(deps, stress_n)   # the elastic predictor, returned in place
        eps_p_eq, yield_state = np.empty(m), np.empty(m)
        cone_update(self.prm, deps, stress_n, np.ascontiguousarray(state["eps_p_eq"]), sigma,
                    tangent, eps_p_eq, yield_state, np.empty((2, 6)))
        return sigma, {"stress": sigma, "eps_p_eq": eps_p_eq, "yield_state": yield_state}
