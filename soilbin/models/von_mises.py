"""Perfectly plastic von Mises, sqrt(J2) = c (dissertation eq. B.1): the
Drucker–Prager cone with eta = 0, so in plane strain the Tresca strength is c."""
import dataclasses

from ..params import magnitude_param
from .cone import ConeModel, cone_samples, tension_cutoff_param


@dataclasses.dataclass(frozen=True)
class VonMises(ConeModel):
    """f = sqrt(J2) - c, optionally with the tension cut-off p <= tension_cutoff (see .cone)."""

    c: float = magnitude_param(doc="undrained shear strength")
    tension_cutoff: float = tension_cutoff_param()

    @property
    def cone(self):
        return 0.0, self.c

    @classmethod
    def conformance_samples(cls):
        table = {"E": 1.0e5, "nu": 0.3, "c": 100.0}
        return cone_samples([table], [{**table, "tension_cutoff": 20.0}], apex=False)
