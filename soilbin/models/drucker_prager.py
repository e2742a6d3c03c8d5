"""Perfectly plastic Drucker–Prager (dissertation eq. B.2), associated by default,
with a dilation angle psi for non-associated flow."""
import dataclasses
import math

import numpy as np

from ..errors import InputError
from ..params import magnitude_param, param
from ..tensors import IDENTITY
from .base import APEX, CUTOFF, ELASTIC, FAILURE, SHEAR, Sample
from .cone import ConeModel, cone_samples, tension_cutoff_param
from .matching import Matching


@dataclasses.dataclass(frozen=True)
class DruckerPrager(ConeModel):
    """f = alpha I1 + sqrt(J2) - k, with alpha, k matched to Mohr–Coulomb c, phi;
    flow potential g = alpha_psi I1 + sqrt(J2), alpha_psi matched to psi as alpha
    to phi (psi = phi, the default: associated flow); optionally the tension
    cut-off p = I1/3 <= tension_cutoff (see .cone)."""

    c: float = magnitude_param(zero=True, doc="Mohr–Coulomb cohesion")
    phi: float = param(lo=0.0, hi=90.0, hi_open=True,
                       doc="Mohr–Coulomb friction angle [degrees]")
    matching: Matching = param(doc="fit of the cone to Mohr–Coulomb: "
                                   + " or ".join(m.value for m in Matching))
    tension_cutoff: float = tension_cutoff_param()
    psi: float = param(math.nan, doc="dilation angle [degrees], in [0, phi]; "
                                     "nan (the default) means psi = phi: associated flow")

    def __post_init__(self):
        if math.isnan(self.psi):
            object.__setattr__(self, "psi", self.phi)
        super().__post_init__()
        if not 0.0 <= self.psi <= self.phi:
            raise InputError(f"psi = {self.psi!r} is outside the accepted range "
                             f"[0, phi = {self.phi:g}]")

    @property
    def cone(self):
        alpha, k = self.matching.coefficients(self.c, self.phi)
        return 3.0 * alpha, k

    @property
    def flow_slope(self):
        return 3.0 * self.matching.coefficients(self.c, self.psi)[0]

    @classmethod
    def conformance_samples(cls):
        # The apex k / eta = 866 for either matching; cut-offs below it.
        compression, plane = ({"E": 1.0e5, "nu": 0.3, "c": 500.0, "phi": 30.0, "matching": m.value}
                              for m in Matching)
        return (cone_samples([compression, plane], [{**compression, "tension_cutoff": 100.0},
                                                    {**plane, "tension_cutoff": 0.0}])
                + dilatancy_samples())


def dilatancy_samples():
    """Conformance samples of non-associated flow at a low confinement: psi = 0,
    10 and phi with either matching, psi = 0 and 10 with a cut-off below the apex."""
    n, I, low, free = SHEAR, IDENTITY, -2.0 * IDENTITY, np.zeros(6)
    soil = {"E": 4000.0, "nu": 0.35, "c": 0.5, "phi": 33.0}
    cone = ("cone", low, 2e-3 * n - 1e-4 * I, FAILURE)
    plain = [("elastic", low, 1e-5 * n - 1e-5 * I, ELASTIC), cone,
             ("cone near the apex", low, 2e-3 * n + 2e-4 * I, FAILURE),
             ("apex", free, 2e-3 * I + 1e-5 * n, APEX)]
    cut = [cone, ("cut-off", free, 3e-4 * I + 1e-6 * n, CUTOFF),
           ("corner", free, 3e-3 * I + 3e-3 * n, APEX)]
    cases = ([({**soil, "matching": m.value, "psi": psi}, plain)
              for psi in (0.0, 10.0, soil["phi"]) for m in Matching]
             + [({**soil, "matching": Matching.COMPRESSION_CONE.value, "psi": psi,
                  "tension_cutoff": 0.1}, cut) for psi in (0.0, 10.0)])
    return [Sample(mode, t, stress, deps, code, fd_step=1e-10)
            for t, modes in cases for mode, stress, deps, code in modes]
