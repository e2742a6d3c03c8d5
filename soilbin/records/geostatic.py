"""The in-situ state of a scene: gravity and the K0 initial stress (records level).

``K0`` is a number or ``"jaky"``: Jaky's K0 = 1 - sin(phi) of the friction
angle of the soil's material, resolved when the scene is read (so a
``--set materials.soil.phi=...`` moves K0 with it) and written as a number
in the resolved scene. The models with a friction angle ``phi`` (Drucker–
Prager, Cam-Clay, modified Cam-Clay) have one; the cap models have none
(the modified cap's high-pressure line B would give 15° for the VII.5 soil,
far from its measured 33°), so there K0 must be given as a number.
"""
import dataclasses
import math

import numpy as np

from ..errors import InputError
from ..meshes.builder import MAX_LENGTH
from ..params import Params, from_table, magnitude_param, param

#: The K0 that follows the friction angle.
JAKY = "jaky"


@dataclasses.dataclass(frozen=True)
class Geostatic(Params):
    """Gravity and the K0 initial stress, in equilibrium before the first step:
    σ_v = γ (z − z_s), σ_h = K0 σ_v (tension positive: compressive below the surface)."""
    unit_weight: float = magnitude_param(zero=True, doc="unit weight γ of the soil (force/volume)")
    K0: float = param(lo=0.0, hi=10.0, doc="coefficient of earth pressure at rest, or 'jaky': 1 − sin φ "
                                           "of the soil's friction angle")
    surface: float = param(0.0, lo=-MAX_LENGTH, hi=MAX_LENGTH, doc="z of the ground surface")

    def stress(self, x):
        """Initial stress (n, 6), Mandel, at the points x (n, 3)."""
        vertical = self.unit_weight * (x[:, 2] - self.surface)
        sigma = np.zeros((len(x), 6))
        sigma[:, 0] = sigma[:, 1] = self.K0 * vertical
        sigma[:, 2] = vertical
        return sigma


def read_geostatic(table, soil):
    """The [geostatic] record; ``soil``: material name -> model of the scene's regions."""
    if isinstance(table, dict) and table.get("K0") == JAKY:
        table = {**table, "K0": jaky_K0(soil)}
    elif isinstance(table, dict) and isinstance(table.get("K0"), str):
        raise InputError(f"geostatic.K0: expected a number or {JAKY!r}, got {table['K0']!r}")
    return from_table(Geostatic, table, "geostatic")


def jaky_K0(soil):
    """1 − sin φ of the one friction angle of the materials ``soil`` (name -> model)."""
    angles = {}
    for name, model in soil.items():
        if not hasattr(model, "phi"):
            raise InputError(f"geostatic.K0 = {JAKY!r}: materials.{name} ({type(model).__name__}) has no "
                             "friction angle phi; give K0 as a number in [0, 10]")
        angles[name] = model.phi
    if len(set(angles.values())) != 1:
        raise InputError(f"geostatic.K0 = {JAKY!r}: the regions' materials have different friction "
                         f"angles {angles}; give K0 as a number in [0, 10]")
    return 1.0 - math.sin(math.radians(next(iter(angles.values()))))
