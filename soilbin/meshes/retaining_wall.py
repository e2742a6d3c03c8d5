"""The retaining-wall builder's declaration: a plane-strain slab of soil behind a rigid wall
(passive translation), one hex layer in y, or (``dimension = 2``) its quadrilaterals in the
x-z plane.

The soil fills x in [0, length], z in [-depth, 0] (z up, ground surface
z = 0); the wall is x = 0 for z in [-wall_height, 0], and below its toe x = 0
is the separate group ``below_wall``. So that every mesh has the same groups,
the soil must reach below the toe (wall_height < depth). The elements are at
most element_size long at the toe, where the moving wall meets the held soil below
it, and grow by the factor growth away from it: in x from the wall, in z up
to the surface and down to the base (growth = 1, the default, is a uniform
mesh). refine then splits each of them into refine^2 in the x-z plane
(nested: element_size / refine at the toe).
"""
from dataclasses import dataclass

from ..errors import InputError
from ..params import Params, param
from .builder import (Builder, check_cell_count, check_proportions, dimension_param, length_param,
                      refine_param)
from .segments import Segment


@dataclass(frozen=True)
class RetainingWallParams(Params):
    wall_height: float = length_param(10.0, "height H of the wall, down from the surface")
    length: float = length_param(30.0, "extent of the soil in x, from the wall")
    depth: float = length_param(15.0, "depth of the soil (> wall_height)")
    thickness: float = length_param(1.0, "thickness of the slab in y (one element; dimension = 3)")
    element_size: float = length_param(1.0, "largest length of the elements at the wall's toe")
    growth: float = param(1.0, lo=1.0, hi=2.0, doc="ratio of neighbouring element lengths away from the toe")
    refine: int = refine_param("splits every element into refine^2 in x-z "
                               "(nested; refine = 2 gives 4x the cells)")
    dimension: int = dimension_param()

    def __post_init__(self):
        super().__post_init__()
        if self.wall_height >= self.depth:
            raise InputError(f"wall_height = {self.wall_height!r} must be less than depth = {self.depth!r} "
                             "(the soil reaches below the wall's toe)")
        check_proportions(self.lengths)
        check_cell_count(self.cells, "element_size, growth, refine")

    @property
    def lengths(self):
        """The extents of the mesh and the lengths in it that gmsh must resolve: key -> value."""
        lengths = {"length": self.length, "depth": self.depth, "wall_height": self.wall_height,
                   "depth - wall_height": self.depth - self.wall_height,
                   "element_size / refine": self.element_size / self.refine}
        if self.dimension == 3:
            lengths["thickness"] = self.thickness
        return lengths

    @property
    def cells(self) -> int:
        """Number of cells (hexahedra of the one layer, or quadrilaterals)."""
        xs, zs = self.segments()
        return sum(s.n for s in xs) * sum(s.n for s in zs)

    def segments(self):
        """The x and the z divisions (ascending) of the slab, graded from the toe."""
        toe = -self.wall_height

        def segment(start, end):
            return Segment.growing(start, end, self.element_size, self.growth).refined(self.refine)

        return [segment(0.0, self.length)], [segment(toe, -self.depth), segment(toe, 0.0)]


RETAINING_WALL = Builder(
    name="retaining_wall", params=RetainingWallParams,
    summary="plane-strain slab (one hex layer in y, or 2D) behind a rigid wall x = 0 down to its "
            "toe, graded toward its toe",
    regions=("soil",), boundaries=("wall", "below_wall", "surface", "far", "base", "front", "back"),
    contact=(), geometry="retaining_wall_geometry", slab_faces=("front", "back"))
