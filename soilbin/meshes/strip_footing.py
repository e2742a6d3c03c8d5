"""Plane-strain slab for a strip footing on a half-space: half model, one hex layer in y.

The problem's plane is x-z: the symmetry plane is x = 0, the ground surface
z = 0 and the footing covers x in [0, b], b = footing_width / 2. Elements
shrink geometrically toward the footing edge (x = b, z = 0), where the stress
is singular. Element sizes are a tensor product of the x and z spacings, so
the largest aspect ratio is about the size ratio of the largest to the
smallest element; the defaults keep it below 10 (768 elements).
"""
from dataclasses import dataclass

from mpi4py import MPI

from ..errors import InputError
from ..params import Params, param
from .blocks import Segment, entities_within, extruded_grid
from .tagged import TaggedMesh, build_tagged_mesh


@dataclass(frozen=True)
class StripFootingParams(Params):
    footing_width: float = param(2.0, lo=0.0, lo_open=True,
                                 doc="full width B of the strip footing; the half model carries B/2")
    width: float = param(10.0, lo=0.0, lo_open=True,
                         doc="extent of the half model in x, from the symmetry plane (> B/2)")
    depth: float = param(10.0, lo=0.0, lo_open=True, doc="depth of soil below the ground surface")
    thickness: float = param(0.1, lo=0.0, lo_open=True, doc="thickness of the slab in y (one element)")
    n_footing: int = param(8, lo=1, doc="elements across the half footing, x in [0, B/2]")
    n_beside: int = param(24, lo=1, doc="elements beside the footing, x in [B/2, width]")
    n_depth: int = param(24, lo=1, doc="elements in depth")
    growth: float = param(1.08, lo=1.0, hi=2.0,
                          doc="size ratio of neighbouring elements, growing away from the footing edge")
    refine: int = param(1, lo=1, doc="multiplies every element count; growth becomes growth**(1/refine)")

    def __post_init__(self):
        super().__post_init__()
        if self.footing_width >= 2.0 * self.width:
            raise InputError(f"footing_width = {self.footing_width!r} must be less than "
                             f"twice width = {self.width!r}")


def build_strip_footing(p: StripFootingParams, comm: MPI.Comm) -> TaggedMesh:
    """Cell group ``soil``; facet groups ``footing surface symmetry far base front back``."""
    b, k = p.footing_width / 2.0, p.refine
    ratio = p.growth ** (1.0 / k)

    def geometry():
        extruded_grid(
            [Segment(0.0, b, k * p.n_footing, 1.0 / ratio), Segment(b, p.width, k * p.n_beside, ratio)],
            [Segment(-p.depth, 0.0, k * p.n_depth, 1.0 / ratio)],
            p.thickness, 1)
        boundaries = {
            "footing": entities_within(2, x=(0.0, b), z=0.0),
            "surface": entities_within(2, x=(b, p.width), z=0.0),
            "symmetry": entities_within(2, x=0.0),
            "far": entities_within(2, x=p.width),
            "base": entities_within(2, z=-p.depth),
            "front": entities_within(2, y=0.0),
            "back": entities_within(2, y=p.thickness),
        }
        return {"soil": entities_within(3)}, boundaries

    return build_tagged_mesh(comm, "strip_footing", geometry)
