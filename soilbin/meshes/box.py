"""The box builder's declaration: a rectangular soil box [0, lx] x [0, ly] x [0, lz], z up.

It serves the constrained column and the soil block alike; the scene sets the
boundary conditions on the named faces.
"""
from dataclasses import dataclass

from ..params import Params, param
from .builder import Builder, check_cell_count, check_proportions, length_param


@dataclass(frozen=True)
class BoxParams(Params):
    lx: float = length_param(1.0, "length in x")
    ly: float = length_param(1.0, "length in y")
    lz: float = length_param(1.0, "height in z (vertical, up)")
    nx: int = param(1, lo=1, doc="number of elements in x")
    ny: int = param(1, lo=1, doc="number of elements in y")
    nz: int = param(4, lo=1, doc="number of elements in z")

    def __post_init__(self):
        super().__post_init__()
        check_cell_count(self.cells, "nx, ny, nz")
        check_proportions({"lx": self.lx, "ly": self.ly, "lz": self.lz, "lx / nx": self.lx / self.nx,
                           "ly / ny": self.ly / self.ny, "lz / nz": self.lz / self.nz})

    @property
    def cells(self) -> int:
        return self.nx * self.ny * self.nz


BOX = Builder(
    name="box", params=BoxParams, summary="rectangular soil box [0,lx]x[0,ly]x[0,lz], z up",
    regions=("soil",), boundaries=("xmin", "xmax", "ymin", "ymax", "base", "top"), contact=(),
    geometry="box_geometry")
