"""The box builder's gmsh geometry (declaration: :mod:`.box`): uniform hexahedra (or each
split into six tetrahedra)."""
from .blocks import entities_within, extruded_grid
from .box import BoxParams
from .segments import Segment


def geometry(p: BoxParams, simplices: bool):
    extruded_grid([Segment(0.0, p.lx, p.nx)], [Segment(0.0, p.lz, p.nz)], p.ly, p.ny,
                  simplices=simplices)
    boundaries = {
        "xmin": entities_within(2, x=0.0),
        "xmax": entities_within(2, x=p.lx),
        "ymin": entities_within(2, y=0.0),
        "ymax": entities_within(2, y=p.ly),
        "base": entities_within(2, z=0.0),
        "top": entities_within(2, z=p.lz),
    }
    return {"soil": entities_within(3)}, boundaries
