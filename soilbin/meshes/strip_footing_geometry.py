"""The strip-footing builder's gmsh geometry (declaration: :mod:`.strip_footing`):
quadrilaterals graded from the footing edge, extruded to one layer of hexahedra."""
import gmsh

from .blocks import entities_within
from .strip_footing import StripFootingParams


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


def geometry(p: StripFootingParams):
    b = p.footing_width / 2.0
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
