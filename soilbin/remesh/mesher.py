"""The deformed soil meshed afresh by gmsh (two-dimensional): the outline's polygon, each of its
edges a line of one segment (two with quadrilaterals: Blossom's full-quad recombination meshes
at twice the size and splits every cell in four, and needs an even boundary; the remesher
samples the outline accordingly, :meth:`.outline.Outline.resampled`), element
sizes those the soil was built with where it now is (a post-processing view of the old cells,
carrying each node's initial element size), and the element's cells: triangles, or
quadrilaterals by Blossom's full-quad recombination (plain Blossom leaves triangles).

gmsh's compound curves would let the new boundary drop old nodes, but gmsh 4.8 then reports the
compound's elements for each of its curves, and DOLFINx's reader crashes on the repeats."""
import dataclasses

import gmsh
import numpy as np

from ..meshes.tagged import check_cells, distribute


@dataclasses.dataclass(frozen=True)
class Sizes:
    """The element sizes asked for: linear over ``triangles`` (m, 3, 2) from the ``values``
    (m, 3) at their corners."""
    triangles: np.ndarray
    values: np.ndarray


def mesh_outline(comm, outline, sizes, regions, boundaries, simplices, path):
    """The TaggedMesh of the polygon ``outline`` (rank 0; None elsewhere), distributed, and
    written to the gmsh file ``path`` (for a resumed run, :func:`read_mesh`).

    ``sizes``: the :class:`Sizes` (rank 0);
    ``regions``: the one region's name -> tag; ``boundaries``: group name -> tag (the outline's
    edge tags; a group the outline lacks stays named, with no facets)."""
    def model():
        gmsh.model.add("remesh")
        geo = gmsh.model.geo
        points = [geo.addPoint(x, 0.0, z) for x, z in outline.vertices]
        n = len(points)
        lines = [geo.addLine(points[i], points[(i + 1) % n]) for i in range(n)]
        for line in lines:   # full-quad recombination halves and splits: two segments
            geo.mesh.setTransfiniteCurve(line, 2 if simplices else 3)
        surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.synchronize()
        groups = {}
        for tag, first, last in outline.runs():
            groups.setdefault(tag, []).extend(lines[first:last])
        (name, region), = regions.items()
        gmsh.model.addPhysicalGroup(2, [surface], region)
        gmsh.model.setPhysicalName(2, region, name)
        for group, tag in boundaries.items():
            if tag in groups:
                gmsh.model.addPhysicalGroup(1, groups[tag], tag)
                gmsh.model.setPhysicalName(1, tag, group)
        _size_field(sizes.triangles, sizes.values)
        if not simplices:
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
        _generate()
        check_cells(RuntimeError, "the remesher made", 2, simplices)
        path.parent.mkdir(parents=True, exist_ok=True)
        gmsh.option.setNumber("Mesh.Binary", 1)   # the coordinates to the last bit
        gmsh.write(str(path))
        return regions, {g: t for g, t in boundaries.items()}
    return distribute(comm, "remesh", model, dimension=2)


def read_mesh(comm, path, regions, boundaries):
    """The TaggedMesh a remesh wrote to ``path``; ``regions``, ``boundaries``: group name ->
    tag, as the mesh was made with."""
    def model():
        gmsh.open(str(path))
        return dict(regions), dict(boundaries)
    return distribute(comm, str(path), model, dimension=2)


def _size_field(triangles, node_sizes):
    """The background size: linear over the old cells (triangles in the x-z plane)."""
    view = gmsh.view.add("initial element size")
    m = len(triangles)
    x = triangles[:, :, 0]
    zeros = np.zeros_like(x)
    z = triangles[:, :, 1]
    data = np.hstack([x, zeros, z, node_sizes]).ravel()   # per triangle: xs, ys, zs, values
    gmsh.view.addListData(view, "ST", m, data.tolist())
    fields = gmsh.model.mesh.field
    field = fields.add("PostView")
    fields.setNumber(field, "ViewTag", view)
    fields.setAsBackgroundMesh(field)
    for option, value in {"Mesh.MeshSizeExtendFromBoundary": 0, "Mesh.MeshSizeFromPoints": 0,
                          "Mesh.MeshSizeFromCurvature": 0,
                          "Mesh.Algorithm": 6,          # Frontal-Delaunay (8 crashes in 4.8)
                          "Mesh.RecombinationAlgorithm": 3}.items():   # Blossom full-quad
        gmsh.option.setNumber(option, value)


def _generate():
    """Mesh; gmsh's errors (logged, General.AbortOnError = 1) raised as a RuntimeError."""
    gmsh.option.setNumber("General.AbortOnError", 1)
    gmsh.logger.start()
    try:
        gmsh.model.mesh.generate(2)
        errors = [line for line in gmsh.logger.get() if line.startswith("Error")]
    finally:
        gmsh.logger.stop()
    if errors:
        raise RuntimeError(f"gmsh cannot mesh the deformed soil ({errors[0]})")
