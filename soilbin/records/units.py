"""The force and length units of a scene, read off its ``units`` text for the figures' axes.

A scene states its units as free text whose leading "FORCE, LENGTH" names them:
"lb, in (stresses in psi, unit weight in pci)", "lb, ft (stresses in psf)",
"kN, m". Text that does not start so ("any consistent units (length L, force
F): ...") gives the symbols F and L. A stress is force over length squared,
named where it has a name (psi, psf, kPa, ...); "forces per inch of strip" (a
plane-strain scene) makes the curve's forces per unit length.
"""
import dataclasses
import re

FORCES = ("lb", "lbf", "kip", "N", "kN", "MN", "kgf")
LENGTHS = ("in", "ft", "yd", "mm", "cm", "m")
#: (force, length) -> the stress unit's name; others read FORCE/LENGTH^2.
STRESSES = {("lb", "in"): "psi", ("lbf", "in"): "psi", ("lb", "ft"): "psf", ("lbf", "ft"): "psf",
            ("kip", "in"): "ksi", ("kip", "ft"): "ksf", ("N", "m"): "Pa", ("kN", "m"): "kPa",
            ("MN", "m"): "MPa", ("N", "mm"): "MPa"}
LEADING = re.compile(r"\s*([A-Za-z]+)\s*,\s*([A-Za-z]+)\b")
PER_LENGTH = re.compile(r"\bforces? per (?:unit length|[a-z]+ of)\b", re.IGNORECASE)


@dataclasses.dataclass(frozen=True)
class Units:
    force: str             # "lb", or the symbol "F"
    length: str            # "in", or the symbol "L"
    per_length: bool = False   # the curve's forces are per unit length (plane strain)

    @property
    def stress(self):
        return STRESSES.get((self.force, self.length), f"{self.force}/{self.length}²")

    @property
    def curve_force(self):
        """The unit of a force on the curve: per unit length in a plane-strain scene."""
        return f"{self.force}/{self.length}" if self.per_length else self.force


SYMBOLS = Units("F", "L")


def read_units(text):
    """The Units of a scene's ``units`` text; F and L where it names no known pair."""
    leading = LEADING.match(text)
    per_length = PER_LENGTH.search(text) is not None
    if leading is None or leading[1] not in FORCES or leading[2] not in LENGTHS:
        return dataclasses.replace(SYMBOLS, per_length=per_length)
    return Units(leading[1], leading[2], per_length)
