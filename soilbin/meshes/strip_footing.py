"""Plane-strain slab for a strip footing on a half-space: half model, one hex layer in y.

The problem's plane is x-z: the symmetry plane is x = 0, the ground surface
z = 0 and the footing covers x in [0, b], b = footing_width / 2. The stress
is singular at the footing edge (x = b, z = 0) and the collapse mechanism
(Prandtl's wedge, fan and passive zone) spreads from it, so the in-plane
mesh is unstructured quadrilaterals whose size grows linearly with the
distance r from the edge, h(r) = min(edge_size + size_growth * r, far_size),
extruded to one layer of hexahedra. All sizes scale with 1/refine.
"""
from dataclasses import dataclass

import gmsh
from mpi4py import MPI

from ..errors import InputError
from ..params import Params, param
from .blocks import entities_within
from .tagged import TaggedMesh, build_tagged_mesh


@dataclass(frozen=True)
class StripFootingParams(Params):
    footing_width: float = param(2.0, lo=0.0, lo_open=True,
                                 doc="full width B of the strip footing; the half model carries B/2")
    width: float = param(10.0, lo=0.0, lo_open=True,
                         doc="extent of the half model in x, from the symmetry plane (> B/2)")
    depth: float = param(10.0, lo=0.0, lo_open=True, doc="depth of soil below the ground surface")
    thickness: float = param(1.0, lo=0.0, lo_open=True, doc="thickness of the slab in y (one element)")
    edge_size: float = param(0.02, lo=0.0, lo_open=True, doc="element size at the footing edge")
    far_size: float = param(1.0, lo=0.0, lo_open=True, doc="largest element size, far from the footing")
    size_growth: float = param(0.15, lo=0.0, hi=2.0, lo_open=True,
                               doc="increase of element size per unit distance from the footing edge")
    refine: int = param(1, lo=1, doc="divides every element size (refine = 2 gives about 4x the cells)")

    def __post_init__(self):
        super().__post_init__()
        if self.footing_width >= 2.0 * self.width:
            raise InputError(f"footing_width = {self.footing_width!r} must be less than "
                             f"twice width = {self.width!r}")
        if self.edge_size > self.far_size:
            raise InputError(f"edge_size = {self.edge_size!r} must not exceed "
                             f"far_size = {self.far_size!r}")


def graded_quadrilaterals(corner, p):
    """Size field h(r) = min(edge_size + size_growth r, far_size) / refine around ``corner``."""
    fields = gmsh.model.mesh.field
    distance = fields.add("Distance")
    fields.setNumbers(distance, "NodesList", [corner])   # "PointsList" from gmsh 4.9 on
    size = fields.add("Threshold")
    fields.setNumber(size, "InField", distance)
    fields.setNumber(size, "SizeMin", p.edge_size / p.refine)
    fields.setNumber(size, "SizeMax", p.far_size / p.refine)
    fields.setNumber(size, "DistMin", 0.0)
    fields.setNumber(size, "DistMax", (p.far_size - p.edge_size) / p.size_growth)
    fields.setAsBackgroundMesh(size)
    for option, value in {"Mesh.MeshSizeExtendFromBoundary": 0, "Mesh.MeshSizeFromPoints": 0,
                          "Mesh.MeshSizeFromCurvature": 0,
                          "Mesh.Algorithm": 6,                 # Frontal-Delaunay (8 crashes in 4.8)
                          "Mesh.RecombinationAlgorithm": 1}.items():  # Blossom: all quadrilaterals
        gmsh.option.setNumber(option, value)


def build_strip_footing(p: StripFootingParams, comm: MPI.Comm) -> TaggedMesh:
    """Cell group ``soil``; facet groups ``footing surface symmetry far base front back``."""
    b = p.footing_width / 2.0

    def geometry():
        geo = gmsh.model.geo
        corners = [(0.0, -p.depth), (p.width, -p.depth), (p.width, 0.0), (b, 0.0), (0.0, 0.0)]
        points = [geo.addPoint(x, 0.0, z) for x, z in corners]
        lines = [geo.addLine(points[i], points[(i + 1) % len(points)]) for i in range(len(points))]
        section = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.mesh.setRecombine(2, section)
        geo.extrude([(2, section)], 0.0, p.thickness, 0.0, numElements=[1], recombine=True)
        geo.synchronize()
        graded_quadrilaterals(points[3], p)
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
