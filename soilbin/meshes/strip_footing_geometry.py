"""The strip-footing builder's gmsh geometry (declaration: :mod:`.strip_footing`):
quadrilaterals (or triangles) graded from the footing edge in the x-z plane, extruded to one
layer of hexahedra (or tetrahedra) unless the mesh is two-dimensional."""
import gmsh

from .blocks import entities_within, plane_strain_groups
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


def corner_grid(geo, b, p):
    """Squares of side corner_size filling [b - a, b + a] x [-a, 0], a = 3 corner_size (two
    transfinite surfaces); returns the surfaces, the patch's top corners (b - a, 0) and
    (b + a, 0), its rim (the curves from (b - a, 0) down, across and up to (b + a, 0)) and
    the edge point (b, 0)."""
    n = 3
    a = n * p.corner_size
    point = {(i, k): geo.addPoint(b + i * a, 0.0, -k * a) for i in (-1, 0, 1) for k in (0, 1)}
    line = {}
    for start, end in [((-1, 0), (-1, 1)), ((0, 0), (0, 1)), ((1, 0), (1, 1)),
                       ((-1, 1), (0, 1)), ((0, 1), (1, 1)), ((-1, 0), (0, 0)), ((0, 0), (1, 0))]:
        line[start, end] = geo.addLine(point[start], point[end])
        geo.mesh.setTransfiniteCurve(line[start, end], n + 1)
    squares = []
    for left, right in [(-1, 0), (0, 1)]:
        loop = [line[(left, 0), (right, 0)], line[(right, 0), (right, 1)],
                -line[(left, 1), (right, 1)], -line[(left, 0), (left, 1)]]
        squares.append(geo.addPlaneSurface([geo.addCurveLoop(loop)]))
        geo.mesh.setTransfiniteSurface(squares[-1])
    rim = [line[(-1, 0), (-1, 1)], line[(-1, 1), (0, 1)], line[(0, 1), (1, 1)],
           -line[(1, 0), (1, 1)]]
    return squares, (point[-1, 0], point[1, 0]), rim, point[0, 0]


def geometry(p: StripFootingParams, simplices: bool):
    b = p.footing_width / 2.0
    geo = gmsh.model.geo
    corner = [geo.addPoint(x, 0.0, z) for x, z in [(0.0, -p.depth), (p.width, -p.depth),
                                                     (p.width, 0.0)]]
    if p.corner_size > 0.0:
        squares, (patch_left, patch_right), rim, edge = corner_grid(geo, b, p)
        ends = [patch_right, patch_left]
    else:
        squares, rim = [], []
        edge = geo.addPoint(b, 0.0, 0.0)
        ends = [edge, edge]
    top_left = geo.addPoint(0.0, 0.0, 0.0)
    outline = corner + [ends[0]]
    lines = [geo.addLine(outline[i], outline[i + 1]) for i in range(len(outline) - 1)]
    # the rim of the patch from (b + a, 0) back to (b - a, 0), then the rest of the surface
    lines += [-tag for tag in reversed(rim)]
    lines += [geo.addLine(ends[1], top_left), geo.addLine(top_left, corner[0])]
    sections = [geo.addPlaneSurface([geo.addCurveLoop(lines)])] + squares
    if not simplices:
        for section in sections:
            geo.mesh.setRecombine(2, section)
    if p.dimension == 3:
        geo.extrude([(2, s) for s in sections], 0.0, p.thickness, 0.0, numElements=[1],
                    recombine=not simplices)
    geo.synchronize()
    graded_quadrilaterals(edge, p)
    if squares:   # Blossom leaves triangles beside the squares after Frontal-Delaunay
        gmsh.model.mesh.setAlgorithm(2, sections[0], 5)   # Delaunay
    facet = p.dimension - 1
    boundaries = {
        "footing": entities_within(facet, x=(0.0, b), z=0.0),
        "surface": entities_within(facet, x=(b, p.width), z=0.0),
        "symmetry": entities_within(facet, x=0.0),
        "far": entities_within(facet, x=p.width),
        "base": entities_within(facet, z=-p.depth),
    }
    return plane_strain_groups(boundaries, p.dimension, p.thickness)
