"""The CAD-tool soil bin's declaration: a rigid tool of any shape, read from a CAD file, in
a soil bin of tetrahedra graded toward it.

``[mesh] builder = "soil_bin_cad", tool_file = "chisel.step", tool_scale = 0.03937``. The
file (STEP, IGES or BREP, read by gmsh's OpenCASCADE kernel, or a gmsh ``.geo`` script
that builds its solid with ``SetFactory("OpenCASCADE")``; relative to the scene's folder)
holds one closed solid, drawn upright: z up, travel along +x. STEP and IGES arrive in
millimetres (OpenCASCADE converts the file's own unit), BREP and ``.geo`` in their bare
numbers; ``tool_scale`` turns them into the scene's length unit. The builder turns
the solid about y by 90° − ``rake_angle`` (the top back), puts its lowest point at
``tool_depth`` below the ground surface z = 0, its rearmost point ``behind`` from the
bin's back end, and in y either its low side on the glass wall y = 0 (``side_wall``),
or its middle on the symmetry plane y = 0 (``embedded``: half of a tool symmetric
about its mid-plane, refused if it is not), or its middle at y = 0 in a bin reaching
``bin_width`` to either side (``full``: a tool of any shape, no symmetry plane, both
sides the group ``side``). The tool is not meshed: the soil is the bin minus the
solid, and every soil face that is not on the bin's planes is a contact face, in the group
of the way it faces (:data:`TOOL_FACES`: the axis and sense nearest its normal out of the
tool, as the built-in blade's faces; a group no face of the tool takes stays empty), so
that a node on the edge between a front and a side face is a contact point of each, with
its normal. Elements are ``element_size`` long at the tool and grow
linearly with the distance d from it, h = element_size + (growth − 1) d (the size of
a mesh whose neighbouring elements differ by the factor ``growth``), up to a
quarter of the bin's depth.
"""
import dataclasses
import enum
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..params import Params, param
from .builder import Builder, check_proportions, length_param


class Configuration(enum.Enum):
    SIDE_WALL = "side_wall"    # the whole tool, against the bin's glass wall y = 0
    EMBEDDED = "embedded"      # half a symmetric tool, y = 0 its mid-plane and a symmetry plane
    FULL = "full"              # the whole tool in the middle of a bin twice bin_width wide


#: The contact groups, by the way a face of the tool faces: along +x (the travel), -x, +-y,
#: -z, +z.
TOOL_FACES = ("tool_front", "tool_back", "tool_side", "tool_bottom", "tool_top")
#: The files gmsh's OpenCASCADE kernel reads, by suffix, and gmsh's own scripts.
CAD_SUFFIXES = (".step", ".stp", ".iges", ".igs", ".brep", ".brp", ".geo")
#: Default length of soil ahead of and behind the tool, in tool depths (the flat blade
#: of chapter VIII: 18 in, 9 widths of the 2-in tool 6 in deep).
END_DEPTHS = 3.0
#: The largest element, as a part of the bin's depth.
FAR_SIZE = 0.25


@dataclass(frozen=True)
class CadToolParams(Params):
    tool_file: str = param(doc="the tool's closed solid: a STEP, IGES or BREP file or a gmsh "
                               ".geo script on the OpenCASCADE kernel, relative to the "
                               "scene's folder, drawn upright (z up, travel along +x)")
    tool_scale: float = param(doc="the scene's length units per unit of the file's numbers "
                                  "(STEP and IGES arrive in millimetres: 0.03937 for a scene "
                                  "in inches, 0.001 for one in metres; BREP and .geo in "
                                  "their own numbers)",
                              lo=0.0, hi=1.0e6, lo_open=True)
    tool_depth: float = length_param(6.0, "depth of the tool's lowest point below the surface")
    rake_angle: float = param(90.0, lo=30.0, hi=90.0,
                              doc="the tool as drawn is turned about y by 90 - rake_angle "
                                  "[degrees], its top back (90: as drawn)")
    configuration: Configuration = param(
        Configuration.SIDE_WALL, doc="side_wall (the tool's low side on the glass wall y = 0), "
                                     "embedded (half of a tool symmetric about its mid-plane, "
                                     "which is the symmetry plane y = 0) or full (the whole "
                                     "tool in a bin from -bin_width to bin_width)")
    bin_depth: float = length_param(12.0, "depth of the soil (> tool_depth)")
    bin_width: float = length_param(18.0, "extent of the soil in y from y = 0, to either side "
                                          "when full (> the tool's)")
    ahead: float = param(None, lo=0.0, hi=1.0e6, lo_open=True,
                         doc=f"soil ahead of the tool's foremost point; default {END_DEPTHS:g} "
                             "tool depths")
    behind: float = param(None, lo=0.0, hi=1.0e6, lo_open=True,
                          doc=f"soil behind the tool's rearmost point; default {END_DEPTHS:g} "
                              "tool depths")
    element_size: float = length_param(1.0, "length of the elements at the tool")
    growth: float = param(1.5, lo=1.0, hi=2.0, lo_open=True,
                          doc="ratio of neighbouring element lengths away from the tool")

    def __post_init__(self):
        for end in ("ahead", "behind"):
            if getattr(self, end) is None:
                object.__setattr__(self, end, END_DEPTHS * self.tool_depth)
        super().__post_init__()
        if Path(self.tool_file).suffix.lower() not in CAD_SUFFIXES:
            raise InputError(f"tool_file = {self.tool_file!r}: not a CAD file gmsh reads; "
                             f"accepted: {', '.join(CAD_SUFFIXES)}")
        if self.tool_depth >= self.bin_depth:
            raise InputError(f"tool_depth = {self.tool_depth!r} must be less than "
                             f"bin_depth = {self.bin_depth!r}")
        check_proportions({"bin_depth": self.bin_depth, "bin_width": self.bin_width,
                           "tool_depth": self.tool_depth, "ahead": self.ahead,
                           "behind": self.behind, "element_size": self.element_size})

    @property
    def tool_share(self) -> float:
        """The part of the whole tool the mesh holds: half across the symmetry plane."""
        return 0.5 if Configuration(self.configuration) is Configuration.EMBEDDED else 1.0

    @property
    def rotation(self) -> float:
        """The turn about +y [radians] that rakes the upright tool, its top back (-x)."""
        return -math.radians(90.0 - self.rake_angle)

    def size(self, distance):
        """The element length at ``distance`` (an array) from the tool."""
        return np.minimum(self.element_size + (self.growth - 1.0) * distance, self.far_size)

    @property
    def far_size(self) -> float:
        return max(FAR_SIZE * self.bin_depth, self.element_size)


@dataclass(frozen=True)
class CadToolBuilder(Builder):
    """The builder of tools from files: the file is found relative to the scene, and its
    tetrahedra need a simplex element."""

    def locate(self, params, folder):
        path = (Path(folder) / params.tool_file).resolve()
        if not path.is_file():
            raise InputError(f"mesh.tool_file = {str(path)!r}: no such file")
        return dataclasses.replace(params, tool_file=str(path))

    def groups(self, params):
        regions, boundaries, contact = super().groups(params)
        if Configuration(params.configuration) is Configuration.FULL:
            boundaries = tuple(b for b in boundaries if b != "symmetry")
        return regions, boundaries, contact

    def check_element(self, params, element):
        if not element.simplex:
            raise InputError(f"analysis.element = {element.value!r}: mesh builder {self.name!r} "
                             "meshes tetrahedra; use tet10-bbar (or tet10)")


SOIL_BIN_CAD = CadToolBuilder(
    name="soil_bin_cad", params=CadToolParams,
    summary="soil bin (tetrahedra) around a rigid tool of any shape read from a STEP, IGES or "
            "BREP file, graded toward it; the contact surface is the tool_* groups (by the "
            "way each face of the tool faces)",
    regions=("soil",),
    boundaries=TOOL_FACES + ("surface", "base", "symmetry", "side", "front_end", "back_end"),
    contact=TOOL_FACES, may_be_empty=TOOL_FACES, geometry="cad_tool_geometry")
