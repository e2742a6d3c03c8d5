"""The soil-bin builder's declaration: a rigid thin blade (tillage tool) in a soil bin,
the soil around a blade-shaped cavity.

x is the direction of travel, y across, z up; the ground surface is z = 0.
The blade is a parallelepiped: tool_thickness thick, tool_depth deep, its
faces inclined at the rake angle to the x axis and leaning back, so its lower
tip is its most forward point. It is not meshed; the four faces of the
cavity it leaves in the soil, :data:`TOOL_FACES` (the builder's contact
groups), carry the soil-tool interface, and :func:`tool_faces` gives their
planes. A facet carries one tag, so there is no group of their union:
integrate over ds(all four tags). The blade lies against y = 0: the glass
side wall of the bin ("side_wall", the full tool) or the symmetry plane of a
tool in the middle of the bin ("embedded", half the tool). The bin reaches
:data:`END_DISTANCE` tool widths ahead of and behind the blade unless the
scene says otherwise (section VIII: "about 9 times the width of the tool").

The mesh is a grid of structured blocks in (xi, y, z) without the blade's
block, mapped by x = xi + shear(z) blend(xi): shear(z) = -(z + d) / tan(rake)
above the tip depth d and 0 below it, blend = 1 across the blade and falling
linearly to 0 at the bin's ends, which stay vertical planes. The map is
bilinear in each block, so the blocks keep planar faces. Elements are
at most element_size long next to the blade (in x, y and z) and grow by the
factor growth toward the ends, the side and the base of the bin; refine then
splits each of them into refine^3.
"""
import enum
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..params import Params, param
from .builder import (MAX_LENGTH, Builder, check_cell_count, check_proportions, length_param,
                      refine_param)
from .segments import Segment

#: Default length of soil ahead of and behind the blade, in tool widths.
END_DISTANCE = 9.0


class Configuration(enum.Enum):
    SIDE_WALL = "side_wall"    # the whole tool, against the bin's glass wall y = 0
    EMBEDDED = "embedded"      # half a tool in the middle of the bin, symmetric about y = 0


def _end_param(doc):
    """A length of soil beyond the blade; not given: END_DISTANCE tool widths."""
    return param(None, lo=0.0, hi=MAX_LENGTH, lo_open=True, doc=f"{doc}; default {END_DISTANCE:g} tool widths")


@dataclass(frozen=True)
class SoilBinParams(Params):
    tool_width: float = length_param(2.0, "width of the blade (across, in y)")
    tool_thickness: float = length_param(0.5, "thickness of the blade, normal to its faces")
    tool_depth: float = length_param(6.0, "depth of the blade's tip below the surface")
    rake_angle: float = param(90.0, lo=30.0, hi=90.0,
                              doc="angle [degrees] between the blade and the direction of travel "
                                  "(90 = vertical; below 90 the blade leans back, its tip forward)")
    configuration: Configuration = param(
        Configuration.SIDE_WALL, doc="side_wall (the tool against the glass wall y = 0, full width) or "
                                     "embedded (half of a tool in the middle of the bin, y = 0 symmetry)")
    bin_depth: float = length_param(12.0, "depth of the soil (> tool_depth)")
    bin_width: float = length_param(18.0, "extent of the soil in y from y = 0 (> the tool's span in y)")
    ahead: float = _end_param("length of soil in front of the blade's tip (its most forward point)")
    behind: float = _end_param("length of soil behind the top of the blade's back face (its rearmost point)")
    element_size: float = length_param(0.75, "length of the elements next to the blade, in x, y and z")
    growth: float = param(1.3, lo=1.0, hi=2.0,
                          doc="ratio of neighbouring element lengths away from the blade")
    refine: int = refine_param("splits every element into refine^3 (nested; refine = 2 gives 8x the cells)")

    def __post_init__(self):
        for end in ("ahead", "behind"):
            if getattr(self, end) is None:
                object.__setattr__(self, end, END_DISTANCE * self.tool_width)
        super().__post_init__()
        if self.tool_depth >= self.bin_depth:
            raise InputError(f"tool_depth = {self.tool_depth!r} must be less than "
                             f"bin_depth = {self.bin_depth!r}")
        if self.span >= self.bin_width:
            raise InputError(f"tool_width = {self.tool_width!r} leaves no soil beside the tool: its span "
                             f"{self.span!r} in y must be less than bin_width = {self.bin_width!r}")
        check_proportions(self.lengths)
        check_cell_count(self.cells, "element_size, growth, refine and the extents")

    @property
    def span(self) -> float:
        """Extent of the cavity in y."""
        embedded = Configuration(self.configuration) is Configuration.EMBEDDED
        return self.tool_width / 2.0 if embedded else self.tool_width

    @property
    def tool_share(self) -> float:
        """The part of the whole tool the mesh holds: half across the symmetry plane."""
        return 0.5 if Configuration(self.configuration) is Configuration.EMBEDDED else 1.0

    @property
    def run(self) -> float:
        """How far the top of the blade lies behind its tip."""
        return self.tool_depth / math.tan(math.radians(self.rake_angle))

    @property
    def blade(self) -> float:
        """Thickness of the blade measured in x."""
        return self.tool_thickness / math.sin(math.radians(self.rake_angle))

    @property
    def tip(self) -> float:
        """x of the blade's tip (the front face at z = -tool_depth)."""
        return self.behind + self.run + self.blade

    @property
    def length(self) -> float:
        """Length of the bin in x."""
        return self.tip + self.ahead

    @property
    def lengths(self):
        """The extents of the mesh and the lengths in it that gmsh must resolve: key -> value."""
        return {"the bin's length": self.length, "bin_width": self.bin_width,
                "bin_depth": self.bin_depth, "tool_width": self.tool_width,
                "tool_thickness": self.tool_thickness, "tool_depth": self.tool_depth,
                "bin_depth - tool_depth": self.bin_depth - self.tool_depth,
                "bin_width - the tool's span": self.bin_width - self.span,
                "ahead": self.ahead, "behind": self.behind,
                "element_size / refine": self.element_size / self.refine}

    @property
    def cells(self) -> int:
        """Number of hexahedra: the block grid's without the blade's block."""
        xs, ys, zs = self.segments()
        return math.prod(sum(s.n for s in axis) for axis in (xs, ys, zs)) - xs[1].n * ys[0].n * zs[1].n

    def segments(self):
        """The (xi, y, z) divisions of the block grid, each list ascending; the blade's block
        is (1, 0, 1)."""
        d, back = self.tool_depth, self.tip - self.blade

        def segment(start, end, growth=self.growth):
            return Segment.growing(start, end, self.element_size, growth).refined(self.refine)

        return ([segment(back, 0.0), segment(back, self.tip, 1.0), segment(self.tip, self.length)],
                [segment(0.0, self.span, 1.0), segment(self.span, self.bin_width)],
                [segment(-d, -self.bin_depth), segment(-d, 0.0, 1.0)])


#: Facet groups of the cavity's faces: the contact surface.
TOOL_FACES = ("tool_front", "tool_back", "tool_side", "tool_bottom")


def tool_faces(p: SoilBinParams) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Face name -> (a point of it, its unit normal from the soil into the tool), mesh coordinates."""
    rake = math.radians(p.rake_angle)
    forward_up = np.array([math.sin(rake), 0.0, math.cos(rake)])
    tip = np.array([p.tip, 0.0, -p.tool_depth])
    heel = tip - [p.blade, 0.0, 0.0]
    return {"tool_front": (tip, -forward_up), "tool_back": (heel, forward_up),
            "tool_side": (heel + [0.0, p.span, 0.0], np.array([0.0, -1.0, 0.0])),
            "tool_bottom": (heel, np.array([0.0, 0.0, 1.0]))}


SOIL_BIN = Builder(
    name="soil_bin", params=SoilBinParams,
    summary="soil bin around the cavity of a rigid thin blade (tool, not meshed) at a rake angle, "
            "graded toward the blade; the contact surface is the four tool_* groups",
    regions=("soil",),
    boundaries=TOOL_FACES + ("surface", "base", "symmetry", "side", "front_end", "back_end"),
    contact=TOOL_FACES, geometry="soil_bin_geometry")
