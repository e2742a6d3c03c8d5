"""Perfectly plastic, associated Drucker–Prager (dissertation eq. B.2)."""
import dataclasses
import math

from ..params import param
from .cone import ConeModel
from .matching import Matching


@dataclasses.dataclass(frozen=True)
class DruckerPrager(ConeModel):
    """f = alpha I1 + sqrt(J2) - k, with alpha, k matched to Mohr–Coulomb c, phi."""

    c: float = param(lo=0.0, hi=math.inf, hi_open=True, doc="Mohr–Coulomb cohesion")
    phi: float = param(lo=0.0, hi=90.0, hi_open=True,
                       doc="Mohr–Coulomb friction angle [degrees]")
    matching: Matching = param(doc="fit of the cone to Mohr–Coulomb: "
                                   + " or ".join(m.value for m in Matching))

    @property
    def cone(self):
        alpha, k = self.matching.coefficients(self.c, self.phi)
        return 3.0 * alpha, k
