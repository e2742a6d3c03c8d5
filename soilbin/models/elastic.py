"""Elastic parts: isotropic linear elasticity, C_e = 3K P_vol + 2G P_dev, and the plastic
work a return dissipates, from the elastic strain of the stress change."""
import dataclasses

import numpy as np

from ..params import magnitude_param, param
from ..tensors import IDENTITY, P_DEV, P_VOL
from .base import ELASTIC, SHEAR, Model, Sample


def elastic_stiffness(K, G):
    """6x6 Mandel stiffness 3K P_vol + 2G P_dev."""
    return 3.0 * K * P_VOL + 2.0 * G * P_DEV


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
    def stiffness(self):
        return elastic_stiffness(self.K, self.G)

    def trial(self, deps, stress):
        """Elastic predictor sigma_n + C_e : deps."""
        return stress + deps @ self.stiffness

    def volumetric_elastic_strain(self, p, p_n):
        """The elastic volume strain (compression positive) taking the mean pressure p_n to
        p (compression positive), (n,): constant K."""
        return (p - p_n) / self.K

    def elastic_strain(self, stress_n, stress):
        """The elastic strain (n, 6) taking ``stress_n`` to ``stress``: the deviator's change
        over 2G, the volume's from :meth:`volumetric_elastic_strain`."""
        p_n, p = (-s[:, :3].sum(axis=1) / 3.0 for s in (stress_n, stress))
        return ((stress - stress_n) @ P_DEV / (2.0 * self.G)
                - self.volumetric_elastic_strain(p, p_n)[:, None] * IDENTITY / 3.0)

    def plastic_work(self, deps, stress_n, stress):
        """The plastic work per unit volume of the increment ``deps`` from ``stress_n`` to
        the returned ``stress`` (n,): sigma : deps_p with deps_p = deps - deps_e, the
        dissipation of the backward-Euler return (its flow direction is taken at the
        returned stress)."""
        return np.einsum("ij,ij->i", stress, deps - self.elastic_strain(stress_n, stress))


@dataclasses.dataclass(frozen=True)
class LinearElastic(IsotropicElasticity):
    """Isotropic linear elastic material."""

    linear = True

    def integrate(self, deps, state, guess, tangent):
        sigma = self.trial(deps, state["stress"])
        tangent[:] = self.stiffness
        return sigma, {"stress": sigma}

    @classmethod
    def conformance_samples(cls):
        return [Sample("elastic", {"E": 1.0e5, "nu": 0.3}, -200.0 * IDENTITY,
                       2e-2 * SHEAR + 5e-2 * IDENTITY, ELASTIC, fd_step=1e-9)]
