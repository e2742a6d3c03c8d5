"""Perfectly plastic, associated Drucker–Prager (dissertation eq. B.2)."""
import dataclasses
import math

from ..params import param
from .cone import ConeModel, tension_cutoff_param
from .matching import Matching


@dataclasses.dataclass(frozen=True)
class DruckerPrager(ConeModel):
    """f = alpha I1 + sqrt(J2) - k, with alpha, k matched to Mohr–Coulomb c, phi,
    and optionally the tension cut-off p = I1/3 <= tension_cutoff (see .cone)."""

    c: float = param(lo=0.0, hi=math.inf, hi_open=True, doc="Mohr–Coulomb cohesion")
    phi: float = param(lo=0.0, hi=90.0, hi_open=True,
                       doc="Mohr–Coulomb friction angle [degrees]")
    matching: Matching = param(doc="fit of the cone to Mohr–Coulomb: "
                                   + " or ".join(m.value for m in Matching))
    tension_cutoff: float = tension_cutoff_param()

    @property
    def cone(self):
        alpha, k = self.matching.coefficients(self.c, self.phi)
        return 3.0 * alpha, k
