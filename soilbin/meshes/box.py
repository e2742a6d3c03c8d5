"""A rectangular soil box [0, lx] x [0, ly] x [0, lz], z vertical (up).

It serves the constrained column and the soil block alike; the scene sets the
boundary conditions on the named faces.
"""
from dataclasses import dataclass

from mpi4py import MPI

from ..params import Params, param
from .blocks import Segment, entities_within, extruded_grid
from .tagged import TaggedMesh, build_tagged_mesh


@dataclass(frozen=True)
class BoxParams(Params):
    lx: float = param(1.0, lo=0.0, lo_open=True, doc="length in x")
    ly: float = param(1.0, lo=0.0, lo_open=True, doc="length in y")
    lz: float = param(1.0, lo=0.0, lo_open=True, doc="height in z (vertical, up)")
    nx: int = param(1, lo=1, doc="number of elements in x")
    ny: int = param(1, lo=1, doc="number of elements in y")
    nz: int = param(4, lo=1, doc="number of elements in z")


def build_box(p: BoxParams, comm: MPI.Comm) -> TaggedMesh:
    """Uniform hexahedra; cell group ``soil``, facet groups ``xmin xmax ymin ymax base top``."""
    def geometry():
        extruded_grid([Segment(0.0, p.lx, p.nx)], [Segment(0.0, p.lz, p.nz)], p.ly, p.ny)
        boundaries = {
            "xmin": entities_within(2, x=0.0),
            "xmax": entities_within(2, x=p.lx),
            "ymin": entities_within(2, y=0.0),
            "ymax": entities_within(2, y=p.ly),
            "base": entities_within(2, z=0.0),
            "top": entities_within(2, z=p.lz),
        }
        return {"soil": entities_within(3)}, boundaries

    return build_tagged_mesh(comm, "box", geometry)
