"""The strip-footing builder's declaration: a plane-strain slab for a strip footing on a
half-space, half model, one hex layer in y.

The problem's plane is x-z: the symmetry plane is x = 0, the ground surface
z = 0 and the footing covers x in [0, b], b = footing_width / 2. The stress
is singular at the footing edge (x = b, z = 0) and the collapse mechanism
(Prandtl's wedge, fan and passive zone) spreads from it, so the in-plane
mesh is unstructured quadrilaterals whose size grows linearly with the
distance r from the edge, h(r) = min(edge_size + size_growth * r, far_size),
extruded to one layer of hexahedra, or (``dimension = 2``) left as the
plane-strain mesh itself. All sizes scale with 1/refine.

Optionally (``corner_size`` > 0) the rectangle [b − a, b + a] x [−a, 0], a = 3
corner_size, around the edge is a grid of 6 x 3 squares of side corner_size,
whatever ``refine``. In large deformation a rigid footing turns the soil
around its edge (Prandtl's fan is centred there): the material at distance r
from the edge rotates by about settlement / r, so the cells at the edge fold
once the settlement reaches a few cell sizes, however they are shaped (on
the VII.4 footing: unstructured cells of 0.02 at 3.6 sizes, squares of 0.02
at 4.1). A footing that settles by w needs cells of about w / 2 there.
"""
import math
from dataclasses import dataclass

from ..errors import InputError
from ..params import Params, param
from .builder import (Builder, check_cell_count, check_proportions, dimension_param, length_param,
                      refine_param)


@dataclass(frozen=True)
class StripFootingParams(Params):
    footing_width: float = length_param(2.0, "full width B of the strip footing; the half model carries B/2")
    width: float = length_param(10.0, "extent of the half model in x, from the symmetry plane (> B/2)")
    depth: float = length_param(10.0, "depth of soil below the ground surface")
    thickness: float = length_param(1.0, "thickness of the slab in y (one element; dimension = 3)")
    edge_size: float = length_param(0.02, "element size at the footing edge")
    far_size: float = length_param(1.0, "largest element size, far from the footing")
    size_growth: float = param(0.15, lo=0.01, hi=2.0,
                               doc="increase of element size per unit distance from the footing edge")
    corner_size: float = param(0.0, lo=0.0, doc="side of the 6 x 3 squares around the footing edge, "
                                                "not divided by refine (0: none)")
    refine: int = refine_param("divides every element size (refine = 2 gives about 4x the cells)")
    dimension: int = dimension_param()

    def __post_init__(self):
        super().__post_init__()
        if self.footing_width >= 2.0 * self.width:
            raise InputError(f"footing_width = {self.footing_width!r} must be less than "
                             f"twice width = {self.width!r}")
        if self.edge_size > self.far_size:
            raise InputError(f"edge_size = {self.edge_size!r} must not exceed "
                             f"far_size = {self.far_size!r}")
        if 3.0 * self.corner_size >= min(self.footing_width / 2.0,
                                         self.width - self.footing_width / 2.0, self.depth):
            raise InputError(f"corner_size = {self.corner_size!r}: three of them must fit in the "
                             f"footing's half-width, the soil beside it and the depth")
        check_proportions(self.lengths)
        check_cell_count(self.cells, "edge_size, far_size, size_growth, refine")

    @property
    def lengths(self):
        """The extents of the mesh and the lengths in it that gmsh must resolve: key -> value."""
        lengths = {"width": self.width, "depth": self.depth,
                   "footing_width / 2": self.footing_width / 2.0,
                   "width - footing_width / 2": self.width - self.footing_width / 2.0,
                   "edge_size / refine": self.edge_size / self.refine}
        if self.corner_size > 0.0:
            lengths["corner_size"] = self.corner_size
        if self.dimension == 3:
            lengths["thickness"] = self.thickness
        return lengths

    @property
    def cells(self):
        """About as many cells as gmsh makes (442 for its 473 on the defaults): the integral
        of 1/h(r)^2 over a half disc about the footing edge with the slab's area."""
        e, f, g = self.edge_size, self.far_size, self.size_growth
        radius = math.sqrt(2.0 * self.width * self.depth / math.pi)
        graded = min(radius, (f - e) / g)     # where h(r) reaches far_size
        u = g * graded / e
        inner = math.pi / g**2 * (math.log1p(u) - u / (1.0 + u))
        outer = math.pi * (radius**2 - graded**2) / (2.0 * f**2)
        return (inner + outer) * self.refine**2


STRIP_FOOTING = Builder(
    name="strip_footing", params=StripFootingParams,
    summary="plane-strain half slab (one hex layer in y, or 2D) under a strip footing, graded "
            "toward its edge",
    regions=("soil",), boundaries=("footing", "surface", "symmetry", "far", "base", "front", "back"),
    contact=(), geometry="strip_footing_geometry", slab_faces=("front", "back"))
