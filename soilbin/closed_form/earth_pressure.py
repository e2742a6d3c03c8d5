"""Passive earth pressure on a vertical wall translated into soil with a horizontal ground
surface: the classical coefficients the retaining-wall scene (dissertation VII.3) is checked
against.

Here, as in geomechanics, stresses are positive in compression: the wall's normal stress
at depth z is σ_n = Kp γ z (+ the cohesion term), and Kp = P_n / (γ H² / 2) for the normal
(horizontal) force P_n on a wall of height H per unit length. δ is the wall friction
angle: the soil's shear stress on the wall is σ_n tan δ, downward on the soil (it rises
along the wall in passive translation).
"""
import math


def rankine_passive(phi):
    """Rankine's Kp = tan²(45° + φ/2) of a smooth wall (δ = 0), φ in degrees."""
    return math.tan(math.radians(45.0 + phi / 2.0)) ** 2


def cohesion_term(phi, c, unit_weight, wall_height):
    """What cohesion c adds to Kp of a smooth wall: Bell's σ_n = Kp γ z + 2 c √Kp gives
    P_n = Kp γ H²/2 + 2 c √Kp H, that is 4 c √Kp / (γ H) on the coefficient."""
    return 4.0 * c * math.sqrt(rankine_passive(phi)) / (unit_weight * wall_height)


def lancellotta_passive(phi, delta):
    """Lower bound Kp (normal component) of a wall with friction δ <= φ, in degrees:
    Lancellotta (2002), "Analytical solution of passive earth pressure", Géotechnique 52(8),
    617–619, eqs 1–2: Kp = cos δ / (1 − sin φ) (cos δ + √(sin²φ − sin²δ)) exp(2θ tan φ),
    2θ = asin(sin δ / sin φ) + δ; close to Sokolovski's characteristics values (his fig. 1),
    below the log-spiral ones of Caquot–Kérisel (upper bounds). δ = 0 gives Rankine."""
    if not 0.0 <= delta <= phi:
        raise ValueError(f"delta = {delta!r} must be in [0, phi = {phi!r}]")
    p, d = math.radians(phi), math.radians(delta)
    two_theta = math.asin(math.sin(d) / math.sin(p)) + d
    root = math.sqrt(max(math.sin(p) ** 2 - math.sin(d) ** 2, 0.0))
    return (math.cos(d) / (1.0 - math.sin(p)) * (math.cos(d) + root)
            * math.exp(two_theta * math.tan(p)))


def coulomb_passive(phi, delta):
    """Coulomb's plane-wedge Kp (normal component) of a vertical wall with friction δ under a
    horizontal surface, φ and δ in degrees: the thrust Kp_C γH²/2 acts at δ to the normal,
    Kp_C = cos²φ / (cos δ (1 − √(sin(φ + δ) sin φ / cos δ))²) (Müller-Breslau's closed form
    for a vertical back and level ground), so Kp = Kp_C cos δ. A rigid wedge is a mechanism:
    an upper bound, unsafe for δ > φ/3, where the failure surface curves (Caquot–Kérisel's
    log spiral). δ = 0 gives Rankine."""
    p, d = math.radians(phi), math.radians(delta)
    root = math.sqrt(math.sin(p + d) * math.sin(p) / math.cos(d))
    return math.cos(p) ** 2 / (1.0 - root) ** 2
