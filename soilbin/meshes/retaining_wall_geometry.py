"""The retaining-wall builder's gmsh geometry (declaration: :mod:`.retaining_wall`)."""
from .blocks import entities_within, extruded_grid, plane_strain_groups
from .retaining_wall import RetainingWallParams


def geometry(p: RetainingWallParams, simplices: bool):
    toe, facet = -p.wall_height, p.dimension - 1
    extruded_grid(*p.segments(), p.thickness, 1, p.dimension, simplices)
    boundaries = {
        "wall": entities_within(facet, x=0.0, z=(toe, 0.0)),
        "below_wall": entities_within(facet, x=0.0, z=(-p.depth, toe)),
        "surface": entities_within(facet, z=0.0),
        "far": entities_within(facet, x=p.length),
        "base": entities_within(facet, z=-p.depth),
    }
    return plane_strain_groups(boundaries, p.dimension, p.thickness)
