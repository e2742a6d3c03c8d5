"""Mesh builders, by name: ``b = BUILDERS[name]; p = from_table(b.params, table, "mesh"); tm = b.build(p, comm)``."""
from dataclasses import dataclass
from typing import Callable

from mpi4py import MPI

from ..params import Params
from .box import BoxParams, build_box
from .retaining_wall import RetainingWallParams, build_retaining_wall
from .soil_bin import SoilBinParams, build_soil_bin
from .strip_footing import StripFootingParams, build_strip_footing
from .tagged import TaggedMesh


@dataclass(frozen=True)
class Builder:
    params: type                                     # a Params record
    build: Callable[[Params, MPI.Comm], TaggedMesh]
    summary: str
    regions: tuple[str, ...]                         # cell groups of every mesh it builds
    boundaries: tuple[str, ...]                      # facet groups of every mesh it builds


BUILDERS: dict[str, Builder] = {
    "box": Builder(
        BoxParams, build_box, "rectangular soil box [0,lx]x[0,ly]x[0,lz], z up",
        ("soil",), ("xmin", "xmax", "ymin", "ymax", "base", "top")),
    "strip_footing": Builder(
        StripFootingParams, build_strip_footing,
        "plane-strain half slab (one hex layer in y) under a strip footing, graded toward its edge",
        ("soil",), ("footing", "surface", "symmetry", "far", "base", "front", "back")),
    "soil_bin": Builder(
        SoilBinParams, build_soil_bin,
        "soil bin around the cavity of a rigid thin blade (tool, not meshed) at a rake angle, "
        "graded toward the blade; the contact surface is the four tool_* groups",
        ("soil",), ("tool_front", "tool_back", "tool_side", "tool_bottom", "surface", "base", "symmetry",
                    "side", "front_end", "back_end")),
    "retaining_wall": Builder(
        RetainingWallParams, build_retaining_wall,
        "plane-strain slab (one hex layer in y) behind a rigid wall x = 0 down to its toe, graded toward "
        "the wall, its toe and the surface",
        ("soil",), ("wall", "below_wall", "surface", "far", "base", "front", "back")),
}

__all__ = ["BUILDERS", "Builder", "TaggedMesh", "BoxParams", "StripFootingParams", "SoilBinParams",
           "RetainingWallParams"]
