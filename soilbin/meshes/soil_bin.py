"""A rigid thin blade (tillage tool) in a soil bin: the soil around a blade-shaped cavity.

x is the direction of travel, y across, z up; the ground surface is z = 0.
The blade is a parallelepiped: tool_thickness thick, tool_depth deep, its
faces inclined at the rake angle to the x axis and leaning back, so its lower
tip is its most forward point. It is not meshed; the four faces of the
cavity it leaves in the soil, :data:`TOOL_FACES`, carry the soil-tool
interface, and :func:`tool_faces` gives their planes. A facet carries one
tag, so there is no group of their union: integrate over ds(all four tags).
The blade lies against y = 0: the glass side wall of the bin ("side_wall",
the full tool) or the symmetry plane of a tool in the middle of the bin
("embedded", half the tool).

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
from mpi4py import MPI

from ..errors import InputError
from ..params import Params, param
from .blocks import Segment, block_grid, entities_within, on_plane
from .tagged import TaggedMesh, build_tagged_mesh


class Configuration(enum.Enum):
    SIDE_WALL = "side_wall"    # the whole tool, against the bin's glass wall y = 0
    EMBEDDED = "embedded"      # half a tool in the middle of the bin, symmetric about y = 0


@dataclass(frozen=True)
class SoilBinParams(Params):
    tool_width: float = param(2.0, lo=0.0, lo_open=True, doc="width of the blade (across, in y)")
    tool_thickness: float = param(0.5, lo=0.0, lo_open=True,
                                  doc="thickness of the blade, normal to its faces")
    tool_depth: float = param(6.0, lo=0.0, lo_open=True, doc="depth of the blade's tip below the surface")
    rake_angle: float = param(90.0, lo=30.0, hi=90.0,
                              doc="angle [degrees] between the blade and the direction of travel "
                                  "(90 = vertical; below 90 the blade leans back, its tip forward)")
    configuration: Configuration = param(
        Configuration.SIDE_WALL, doc="side_wall (the tool against the glass wall y = 0, full width) or "
                                     "embedded (half of a tool in the middle of the bin, y = 0 symmetry)")
    bin_depth: float = param(12.0, lo=0.0, lo_open=True, doc="depth of the soil (> tool_depth)")
    bin_width: float = param(18.0, lo=0.0, lo_open=True,
                             doc="extent of the soil in y from y = 0 (> the tool's span in y)")
    ahead: float = param(18.0, lo=0.0, lo_open=True,
                         doc="length of soil in front of the blade's tip (its most forward point)")
    behind: float = param(18.0, lo=0.0, lo_open=True,
                          doc="length of soil behind the top of the blade's back face (its rearmost point)")
    element_size: float = param(0.75, lo=0.0, lo_open=True,
                                doc="length of the elements next to the blade, in x, y and z")
    growth: float = param(1.3, lo=1.0, hi=2.0,
                          doc="ratio of neighbouring element lengths away from the blade")
    refine: int = param(1, lo=1, doc="splits every element into refine^3 "
                                     "(nested; refine = 2 gives 8x the cells)")

    def __post_init__(self):
        super().__post_init__()
        if self.tool_depth >= self.bin_depth:
            raise InputError(f"tool_depth = {self.tool_depth!r} must be less than "
                             f"bin_depth = {self.bin_depth!r}")
        if self.span >= self.bin_width:
            raise InputError(f"tool_width = {self.tool_width!r} leaves no soil beside the tool: its span "
                             f"{self.span!r} in y must be less than bin_width = {self.bin_width!r}")

    @property
    def span(self) -> float:
        """Extent of the cavity in y."""
        embedded = Configuration(self.configuration) is Configuration.EMBEDDED
        return self.tool_width / 2.0 if embedded else self.tool_width

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


def soil_blocks(p: SoilBinParams) -> None:
    """The (xi, y, z) block grid without the blade's block, mapped to x = xi + shear(z) blend(xi)."""
    d, back = p.tool_depth, p.tip - p.blade

    def segment(start, end, growth=p.growth):
        return Segment.growing(start, end, p.element_size, growth).refined(p.refine)

    xs = [segment(back, 0.0), segment(back, p.tip, 1.0), segment(p.tip, p.length)]
    ys = [segment(0.0, p.span, 1.0), segment(p.span, p.bin_width)]
    zs = [segment(-d, -p.bin_depth), segment(-d, 0.0, 1.0)]

    def mapping(xi, y, z):
        blend = min(xi / back, 1.0, (p.length - xi) / p.ahead)
        return xi - max(z + d, 0.0) / d * p.run * blend, y, z

    block_grid(xs, ys, zs, keep=lambda i, j, k: (i, j, k) != (1, 0, 1), mapping=mapping)


def build_soil_bin(p: SoilBinParams, comm: MPI.Comm) -> TaggedMesh:
    """Cell group ``soil``; facet groups: see BUILDERS["soil_bin"]."""
    def geometry():
        soil_blocks(p)
        cavity = entities_within(2, x=(p.behind, p.tip), y=(0.0, p.span), z=(-p.tool_depth, 0.0))
        boundaries = {name: on_plane(2, cavity, *plane) for name, plane in tool_faces(p).items()}
        boundaries |= {
            "surface": entities_within(2, z=0.0),
            "base": entities_within(2, z=-p.bin_depth),
            "symmetry": entities_within(2, y=0.0),
            "side": entities_within(2, y=p.bin_width),
            "front_end": entities_within(2, x=p.length),
            "back_end": entities_within(2, x=0.0),
        }
        return {"soil": entities_within(3)}, boundaries

    return build_tagged_mesh(comm, "soil_bin", geometry)
