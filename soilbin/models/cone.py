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
"""
import abc
import dataclasses
import math

import numpy as np

from ..params import param
from ..tensors import IDENTITY, P_DEV, SQRT2
from .base import APEX, CUTOFF, ELASTIC, FAILURE, SHEAR, Sample, stress_invariants
from .elastic import IsotropicElasticity, elastic_stiffness

#: Trial states with f_tr below this fraction of the stress scale are elastic.
YIELD_TOL = 1e-12


def tension_cutoff_param():
    """The ``tension_cutoff`` field shared by the cone models."""
    return param(math.inf, lo=0.0, hi=math.inf,
                 doc="largest mean stress p = I1/3 the soil carries (tension positive); "
                     "inf (the default) or at least the cone's apex: no cut-off")


def cutoff_active(eta, k, tension_cutoff):
    """True when the cut-off p <= T cuts the cone (T below the apex k / eta)."""
    return math.isfinite(tension_cutoff) and eta * tension_cutoff < k


def return_map(sigma_tr, K, G, eta, k, tension_cutoff=math.inf, eta_g=None):
    """(sigma, C_tan, yield_state) from trial stresses (n, 6) for the cone
    (eta, k) with the flow potential's slope ``eta_g`` (default eta: associated),
    optionally cut off at the mean stress p = ``tension_cutoff``."""
    eta_g = eta if eta_g is None else eta_g
    p_tr, s_tr, s_norm = stress_invariants(sigma_tr)
    J_tr = s_norm / SQRT2
    f_tr = J_tr + eta * p_tr - k
    plastic = f_tr > YIELD_TOL * (k + J_tr + eta * np.abs(p_tr))
    if cutoff_active(eta, k, tension_cutoff):
        return _cutoff_return_map(sigma_tr, p_tr, s_tr, s_norm, J_tr, f_tr, plastic,
                                  K, G, eta, k, tension_cutoff, eta_g)
    dgamma = np.where(plastic, f_tr, 0.0) / (G + K * eta * eta_g)
    # The apex: the trial beyond the corner normal cone (module doc); for
    # eta_g > 0 the same as sqrt(J2) = J_tr - G dgamma < 0 on the cone.
    if eta > 0.0:
        apex = plastic & (G * (p_tr - k / eta) > K * eta_g * J_tr)
    else:
        apex = np.zeros_like(plastic)
    cone = plastic & ~apex

    sigma = sigma_tr.copy()
    sigma[cone] = (s_tr[cone] * (1.0 - G * dgamma[cone] / J_tr[cone])[:, None]
                   + np.outer(p_tr[cone] - K * eta_g * dgamma[cone], IDENTITY))
    if apex.any():   # only when eta > 0
        sigma[apex] = (k / eta) * IDENTITY

    tangent = np.repeat(elastic_stiffness(K, G)[None], len(sigma), axis=0)
    tangent[cone] = consistent_tangent(s_tr[cone] / s_norm[cone, None],
                                       G * dgamma[cone] / J_tr[cone], K, G, eta, eta_g)
    tangent[apex] = 0.0   # perfect plasticity: the apex stress k/eta is fixed

    yield_state = np.where(apex, APEX, np.where(cone, FAILURE, ELASTIC))
    return sigma, tangent, yield_state


def _cutoff_return_map(sigma_tr, p_tr, s_tr, s_norm, J_tr, f_tr, plastic, K, G, eta, k, T,
                       eta_g):
    """:func:`return_map` with an active cut-off p <= T (regions: module doc)."""
    plastic = plastic | (p_tr - T > YIELD_TOL * (k + J_tr + np.abs(p_tr)))
    J_c = k - eta * T   # sqrt(J2) at the corner, > 0
    corner = plastic & (J_tr > J_c) & (G * (p_tr - T) >= eta_g * K * (J_tr - J_c))
    cut = plastic & ~corner & (J_tr <= J_c)
    cone = plastic & ~corner & ~cut   # here f_tr > 0 and the cone return has p < T
    dgamma = np.where(cone, f_tr, 0.0) / (G + K * eta * eta_g)

    sigma = sigma_tr.copy()
    sigma[cone] = (s_tr[cone] * (1.0 - G * dgamma[cone] / J_tr[cone])[:, None]
                   + np.outer(p_tr[cone] - K * eta_g * dgamma[cone], IDENTITY))
    sigma[corner] = s_tr[corner] * (J_c / J_tr[corner])[:, None] + T * IDENTITY
    sigma[cut] = s_tr[cut] + T * IDENTITY

    tangent = np.repeat(elastic_stiffness(K, G)[None], len(sigma), axis=0)
    tangent[cone] = consistent_tangent(s_tr[cone] / s_norm[cone, None],
                                       G * dgamma[cone] / J_tr[cone], K, G, eta, eta_g)
    # Corner: p = T and sqrt(J2) = J_c are fixed, only the direction n of s turns.
    n = s_tr[corner] / s_norm[corner, None]
    tangent[corner] = (2.0 * G * (J_c / J_tr[corner])[:, None, None]
                       * (P_DEV - n[:, :, None] * n[:, None, :]))
    tangent[cut] = 2.0 * G * P_DEV   # p = T is fixed, s = s_tr

    yield_state = np.select([cone, corner, cut], [FAILURE, APEX, CUTOFF], ELASTIC)
    return sigma, tangent, yield_state


def consistent_tangent(n, ratio, K, G, eta, eta_g=None):
    """Algorithmic tangent on the cone (de Souza Neto et al. 2008, sec. 8.3,
    box 8.8 for non-associated flow):

        C = C_e - 2G ratio (P_dev - n x n) - b_g x b_f / (G + K eta eta_g),
        b_g = sqrt2 G n + eta_g K I  (the plastic correction's direction),
        b_f = sqrt2 G n + eta K I    (d f_tr / d eps),

    with n = ``s_tr / |s_tr|`` (m, 6) and ratio = G dgamma / sqrt(J2_tr) (m,);
    unsymmetric unless eta_g = eta.
    """
    eta_g = eta if eta_g is None else eta_g
    b_f = SQRT2 * G * n + eta * K * IDENTITY
    b_g = SQRT2 * G * n + eta_g * K * IDENTITY
    nn = n[:, :, None] * n[:, None, :]
    return (elastic_stiffness(K, G)
            - 2.0 * G * ratio[:, None, None] * (P_DEV - nn)
            - b_g[:, :, None] * b_f[:, None, :] / (G + K * eta * eta_g))


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

    def integrate(self, deps, state, guess=None):
        stress_n = state["stress"]
        eta, k = self.cone
        sigma, tangent, yield_state = return_map(self.trial(deps, stress_n), self.K, self.G,
                                                 eta, k, self.tension_cutoff, self.flow_slope)
        eps_p_eq = state["eps_p_eq"] + np.where(
            yield_state > ELASTIC, self.equivalent_plastic_strain(deps, sigma - stress_n), 0.0)
        return sigma, tangent, {"stress": sigma, "eps_p_eq": eps_p_eq,
                                "yield_state": yield_state}
