"""Plane-strain slab of soil behind a rigid wall (passive translation): one hex layer in y.

The soil fills x in [0, length], z in [-depth, 0] (z up, ground surface
z = 0); the wall is x = 0 for z in [-wall_height, 0], and below its toe x = 0
is the separate group ``below_wall``. So that every mesh has the same groups,
the soil must reach below the toe (wall_height < depth). Elements are at most
element_size long at the wall, its toe and the surface, and grow by the
factor growth away from the wall, and up and down from the toe; refine then
splits each of them into refine^2 in the x-z plane.
"""
from dataclasses import dataclass

from mpi4py import MPI

from ..errors import InputError
from ..params import Params, param
from .blocks import Segment, entities_within, extruded_grid
from .tagged import TaggedMesh, build_tagged_mesh


@dataclass(frozen=True)
class RetainingWallParams(Params):
    wall_height: float = param(10.0, lo=0.0, lo_open=True, doc="height H of the wall, down from the surface")
    length: float = param(30.0, lo=0.0, lo_open=True, doc="extent of the soil in x, from the wall")
    depth: float = param(15.0, lo=0.0, lo_open=True, doc="depth of the soil (> wall_height)")
    thickness: float = param(1.0, lo=0.0, lo_open=True, doc="thickness of the slab in y (one element)")
    element_size: float = param(0.5, lo=0.0, lo_open=True,
                                doc="length of the elements at the wall, its toe and the surface")
    growth: float = param(1.1, lo=1.0, hi=2.0, doc="ratio of neighbouring element lengths away from them")
    refine: int = param(1, lo=1, doc="splits every element into refine^2 in x-z "
                                     "(nested; refine = 2 gives 4x the cells)")

    def __post_init__(self):
        super().__post_init__()
        if self.wall_height >= self.depth:
            raise InputError(f"wall_height = {self.wall_height!r} must be less than depth = {self.depth!r} "
                             "(the soil reaches below the wall's toe)")


def build_retaining_wall(p: RetainingWallParams, comm: MPI.Comm) -> TaggedMesh:
    """Cell group ``soil``; facet groups ``wall below_wall surface far base front back``."""
    toe, middle = -p.wall_height, -p.wall_height / 2.0

    def segment(start, end):
        return Segment.growing(start, end, p.element_size, p.growth).refined(p.refine)

    def geometry():
        zs = [segment(toe, -p.depth), segment(toe, middle), segment(0.0, middle)]
        extruded_grid([segment(0.0, p.length)], zs, p.thickness, 1)
        boundaries = {
            "wall": entities_within(2, x=0.0, z=(toe, 0.0)),
            "below_wall": entities_within(2, x=0.0, z=(-p.depth, toe)),
            "surface": entities_within(2, z=0.0),
            "far": entities_within(2, x=p.length),
            "base": entities_within(2, z=-p.depth),
            "front": entities_within(2, y=0.0),
            "back": entities_within(2, y=p.thickness),
        }
        return {"soil": entities_within(3)}, boundaries

    return build_tagged_mesh(comm, "retaining_wall", geometry)
