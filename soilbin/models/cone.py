"""Perfectly plastic, associated models with a circular cone as yield surface,

    f = sqrt(J2) + eta p - k,   p = I1 / 3   (tension positive),

which is Drucker–Prager (dissertation eq. B.2, eta = 3 alpha) and, for
eta = 0, von Mises (eq. B.1). Closed-form return mapping and consistent
tangent after de Souza Neto et al. (2008), sections 7.3-7.4 and 8.3.
"""
import abc
import dataclasses

import numpy as np

from ..tensors import IDENTITY, P_DEV, SQRT2, deviator, trace
from .elastic import IsotropicElasticity, elastic_stiffness

#: yield_state values.
ELASTIC, SURFACE, APEX = 0.0, 1.0, 2.0
#: Trial states with f_tr below this fraction of the stress scale are elastic.
YIELD_TOL = 1e-12


def return_map(sigma_tr, K, G, eta, k):
    """(sigma, C_tan, yield_state) from trial stresses (n, 6) for the cone (eta, k)."""
    p_tr = trace(sigma_tr) / 3.0
    s_tr = deviator(sigma_tr)
    s_norm = np.linalg.norm(s_tr, axis=-1)
    J_tr = s_norm / SQRT2
    f_tr = J_tr + eta * p_tr - k
    plastic = f_tr > YIELD_TOL * (k + J_tr + eta * np.abs(p_tr))
    dgamma = np.where(plastic, f_tr, 0.0) / (G + K * eta**2)
    # The cone return is valid while sqrt(J2) = J_tr - G dgamma stays >= 0.
    apex = plastic & (J_tr < G * dgamma) & (eta > 0.0)
    cone = plastic & ~apex

    sigma = sigma_tr.copy()
    sigma[cone] = (s_tr[cone] * (1.0 - G * dgamma[cone] / J_tr[cone])[:, None]
                   + np.outer(p_tr[cone] - K * eta * dgamma[cone], IDENTITY))
    if apex.any():   # only when eta > 0
        sigma[apex] = (k / eta) * IDENTITY

    tangent = np.repeat(elastic_stiffness(K, G)[None], len(sigma), axis=0)
    tangent[cone] = consistent_tangent(s_tr[cone] / s_norm[cone, None],
                                       G * dgamma[cone] / J_tr[cone], K, G, eta)
    tangent[apex] = 0.0   # perfect plasticity: the apex stress k/eta is fixed

    yield_state = np.where(apex, APEX, np.where(cone, SURFACE, ELASTIC))
    return sigma, tangent, yield_state


def consistent_tangent(n, ratio, K, G, eta):
    """Algorithmic tangent on the cone (de Souza Neto et al. 2008, sec. 8.3):

        C = C_e - 2G ratio (P_dev - n x n) - b x b / (G + K eta^2),
        b = sqrt2 G n + eta K I,

    with n = s_tr / |s_tr| (m, 6) and ratio = G dgamma / sqrt(J2_tr) (m,).
    """
    b = SQRT2 * G * n + eta * K * IDENTITY
    nn = n[:, :, None] * n[:, None, :]
    return (elastic_stiffness(K, G)
            - 2.0 * G * ratio[:, None, None] * (P_DEV - nn)
            - b[:, :, None] * b[:, None, :] / (G + K * eta**2))


@dataclasses.dataclass(frozen=True)
class ConeModel(IsotropicElasticity):
    """Base of the cone models; a subclass gives its ``cone`` (eta, k)."""

    history = {"stress": (6,), "eps_p_eq": (), "yield_state": ()}

    @property
    @abc.abstractmethod
    def cone(self):
        """(eta, k) of f = sqrt(J2) + eta p - k."""

    def integrate(self, deps, state):
        stress_n = state["stress"]
        eta, k = self.cone
        sigma, tangent, yield_state = return_map(self.trial(deps, stress_n),
                                                 self.K, self.G, eta, k)
        eps_p_eq = state["eps_p_eq"] + np.where(
            yield_state > ELASTIC, self.equivalent_plastic_strain(deps, sigma - stress_n), 0.0)
        return sigma, tangent, {"stress": sigma, "eps_p_eq": eps_p_eq,
                                "yield_state": yield_state}
