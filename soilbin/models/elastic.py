"""Elastic parts: isotropic linear elasticity, C_e = 3K P_vol + 2G P_dev, and the
volumetric laws (compression positive) of the invariant models, a constant
bulk modulus (:class:`LinearBulk`) or the kappa-line (:class:`ExponentialBulk`)."""
import dataclasses

import numpy as np

from ..params import magnitude_param, param
from ..tensors import IDENTITY, P_DEV, P_VOL
from .base import ELASTIC, SHEAR, Model, Sample


def elastic_stiffness(K, G):
    """6x6 Mandel stiffness 3K P_vol + 2G P_dev."""
    return 3.0 * K * P_VOL + 2.0 * G * P_DEV


class LinearBulk:
    """p = p_n + K e: constant bulk modulus."""

    def __init__(self, K):
        self.K = K

    def pressure(self, p_n, e):
        return p_n + self.K * e

    def strain(self, p, p_n):
        """Elastic volumetric strain (compression positive) taking p_n to p."""
        return (p - p_n) / self.K

    def compliance(self, p):
        """dE/dp = 1 / K(p)."""
        return np.full(np.shape(p), 1.0 / self.K)

    def admissible(self, p):
        return np.isfinite(p)


class ExponentialBulk:
    """K = (p + p_min) / kappa_star, integrated exactly over a step:
    p + p_min = (p_n + p_min) exp(e / kappa_star)."""

    def __init__(self, kappa_star, p_min):
        self.kappa_star, self.p_min = kappa_star, p_min

    def pressure(self, p_n, e):
        return (p_n + self.p_min) * np.exp(np.minimum(e / self.kappa_star, 700.0)) - self.p_min

    def strain(self, p, p_n):
        return self.kappa_star * np.log((p + self.p_min) / (p_n + self.p_min))

    def compliance(self, p):
        return self.kappa_star / (p + self.p_min)

    def admissible(self, p):
        return p + self.p_min > 0.0


@dataclasses.dataclass(frozen=True)
class IsotropicElasticity(Model):
    """Base of every model whose elastic part is isotropic and linear."""

    E: float = magnitude_param(doc="Young's modulus")
    nu: float = param(lo=-1.0, hi=0.5, lo_open=True, hi_open=True, doc="Poisson's ratio")

    @property
    def K(self):
        """Bulk modulus."""
        return self.E / (3.0 * (1.0 - 2.0 * self.nu))

    @property
    def G(self):
        """Shear modulus."""
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def bulk(self):
        """The volumetric elastic law of the invariant models (compression positive)."""
        return LinearBulk(self.K)

    @property
    def stiffness(self):
        return elastic_stiffness(self.K, self.G)

    @property
    def compliance(self):
        return P_VOL / (3.0 * self.K) + P_DEV / (2.0 * self.G)

    def trial(self, deps, stress):
        """Elastic predictor sigma_n + C_e : deps."""
        return stress + deps @ self.stiffness


@dataclasses.dataclass(frozen=True)
class LinearElastic(IsotropicElasticity):
    """Isotropic linear elastic material."""

    linear = True

    def integrate(self, deps, state, guess=None):
        sigma = self.trial(deps, state["stress"])
        tangent = np.repeat(self.stiffness[None], len(sigma), axis=0)
        return sigma, tangent, {"stress": sigma}

    @classmethod
    def conformance_samples(cls):
        return [Sample("elastic", {"E": 1.0e5, "nu": 0.3}, -200.0 * IDENTITY,
                       2e-2 * SHEAR + 5e-2 * IDENTITY, ELASTIC, fd_step=1e-9)]
