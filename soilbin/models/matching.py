"""Drucker–Prager cones fitted to Mohr–Coulomb c, phi (dissertation app. B,
after Chen & Mizuno 1990): coefficients of f = alpha I1 + sqrt(J2) - k (eq. B.2)."""
import enum
import math


class Matching(enum.Enum):
    #: Through the compressive meridian of Mohr–Coulomb (triaxial compression).
    COMPRESSION_CONE = "compression_cone"
    #: Same collapse load as Mohr–Coulomb in plane strain (associated flow).
    PLANE_STRAIN = "plane_strain"

    def coefficients(self, c, phi):
        """(alpha, k) for cohesion ``c`` and friction angle ``phi`` in degrees."""
        phi = math.radians(phi)
        if self is Matching.COMPRESSION_CONE:
            d = math.sqrt(3.0) * (3.0 - math.sin(phi))
            return 2.0 * math.sin(phi) / d, 6.0 * c * math.cos(phi) / d
        d = math.sqrt(9.0 + 12.0 * math.tan(phi) ** 2)
        return math.tan(phi) / d, 3.0 * c / d
