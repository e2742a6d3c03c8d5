"""The retaining-wall builder's gmsh geometry (declaration: :mod:`.retaining_wall`)."""
from .blocks import entities_within, extruded_grid
from .retaining_wall import RetainingWallParams


def geometry(p: RetainingWallParams):
    toe = -p.wall_height
    extruded_grid(*p.segments(), p.thickness, 1)
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
