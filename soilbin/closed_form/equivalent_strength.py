"""Mohr–Coulomb c, phi of a curved failure surface at the stress level of a tool's wedge.

The cap models' failure surface sqrt(J2) = F(I1) (I1 compression positive; app. B,
B.9 and B.12) is curved: steep at low confinement, flat at high. A limit-equilibrium
draft estimate needs one straight envelope, so F is linearised where the soil in front
of the tool fails: at I1*, the first invariant of the Rankine passive state at the
tool's mid-depth z = d/2 (plane strain, the intermediate stress the mean of the other
two; compression positive):

 (1) sigma_v = gamma z,  sigma_h = Kp sigma_v,  sigma_2 = (sigma_v + sigma_h) / 2,
     I1* = 3/2 (1 + Kp) gamma z,  Kp = tan^2(45 + phi/2) (Rankine);
 (2) the tangent cone sqrt(J2) = alpha I1 + k: alpha = F'(I1*), k = F(I1*) - alpha I1*;
 (3) Mohr–Coulomb through the cone's compression meridian (the inverse of
     Matching.COMPRESSION_CONE, app. B eq. B.2 after Chen & Mizuno 1990):
     sin phi = 3 sqrt(3) alpha / (2 + sqrt(3) alpha),
     c = sqrt(3) (3 - sin phi) k / (6 cos phi).

phi depends on I1* and I1* on phi: (1)-(3) are iterated from I1* = 0 to a fixed point.
F concave and increasing makes k >= F(0) >= 0, so c >= 0.
"""
import math
from dataclasses import dataclass

from .earth_pressure import rankine_passive

SQRT3 = math.sqrt(3.0)


@dataclass(frozen=True)
class EquivalentStrength:
    phi: float   # degrees
    c: float     # stress units
    I1: float    # where the failure surface was linearised (compression positive)


def mohr_coulomb_of_compression_cone(alpha, k):
    """(phi [degrees], c) of the Mohr–Coulomb envelope whose compression meridian is the
    Drucker–Prager cone sqrt(J2) = alpha I1 + k, eq. (3)."""
    sin_phi = 3.0 * SQRT3 * alpha / (2.0 + SQRT3 * alpha)
    if not 0.0 <= sin_phi < 1.0:
        raise ValueError(f"cone slope alpha = {alpha!r} has no Mohr–Coulomb compression "
                         f"meridian: it must be in [0, 1/sqrt(3))")
    phi = math.asin(sin_phi)
    return math.degrees(phi), SQRT3 * (3.0 - sin_phi) * k / (6.0 * math.cos(phi))


def passive_wedge_strength(failure, unit_weight, depth, iterations=100, rtol=1e-12):
    """EquivalentStrength of the failure surface ``failure(I1) -> (F, F', ...)`` linearised
    at the Rankine passive state at depth/2 under ``unit_weight``, eqs. (1)-(3)."""
    sigma_v = 0.5 * unit_weight * depth
    I1 = 0.0
    for _ in range(iterations):
        F, dF = (float(v) for v in failure(I1)[:2])
        phi, c = mohr_coulomb_of_compression_cone(dF, F - dF * I1)     # (2), (3)
        I1_next = 1.5 * (1.0 + rankine_passive(phi)) * sigma_v               # (1)
        if abs(I1_next - I1) <= rtol * I1_next:
            return EquivalentStrength(phi, c, I1)
        I1 = I1_next
    raise ValueError(f"the passive stress level did not settle in {iterations} iterations "
                     f"(last I1 = {I1!r})")
