"""The CAD-tool soil bin's gmsh geometry (declaration: :mod:`.cad_tool`): the tool's solid
read, raked and placed, checked against the bin, cut out of it, its faces tagged, and
the mesh size graded from them. Every refusal is an InputError raised before meshing."""
import contextlib
import os
import sys

import gmsh
import numpy as np

from ..errors import InputError
from .builder import MAX_CELLS
from .cad_tool import TOOL_FACES, CadToolParams, Configuration

#: Tetrahedra per cubed element length: a regular tetrahedron of edge h has the volume
#: h^3 / (6 sqrt 2); gmsh's Delaunay cells, measured on the flat blade, come to about
#: two thirds of that count.
CELLS_PER_CUBE = 6.0
#: A face lies on a plane of the bin where its centre does, to this part of the bin's size.
ON_PLANE = 1e-9
#: The tool's group of a face whose normal out of the tool is nearest (axis, positive).
FACING = {(0, True): "tool_front", (0, False): "tool_back", (1, True): "tool_side",
          (1, False): "tool_side", (2, False): "tool_bottom", (2, True): "tool_top"}
#: The meshing options a tool's .geo script may set, put back after it has run.
SCRIPT_OPTIONS = ("Mesh.MeshSizeMin", "Mesh.MeshSizeMax", "Mesh.MeshSizeFactor",
                  "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature",
                  "Mesh.MeshSizeExtendFromBoundary", "Mesh.Algorithm", "Mesh.Algorithm3D",
                  "Mesh.ElementOrder", "Mesh.RecombineAll")


def geometry(p: CadToolParams, simplices: bool):
    occ = gmsh.model.occ
    tool = _read_solid(p.tool_file)
    x0, y0, z0, x1, y1, z1 = _place(tool, p)
    length = p.behind + (x1 - x0) + p.ahead
    configuration = Configuration(p.configuration)
    full = configuration is Configuration.FULL
    y_min = -p.bin_width if full else 0.0
    _check_fits(p, full, (y0, y1), z1)
    if configuration is Configuration.EMBEDDED:
        _check_symmetric(tool, p.tool_file)
    _check_cell_count(p, (x0, y0, z0, x1, y1, z1), length, y_min)
    solid = occ.copy(tool)   # the tool's faces as read, oriented out of it (_facing)
    soil, _ = occ.cut([(3, occ.addBox(0.0, y_min, -p.bin_depth, length, p.bin_width - y_min,
                                      p.bin_depth))], tool)
    occ.synchronize()
    planes = [("back_end", 0, 0.0), ("front_end", 0, length),
              ("side" if full else "symmetry", 1, y_min), ("side", 1, p.bin_width),
              ("base", 2, -p.bin_depth), ("surface", 2, 0.0)]
    boundaries = {name: [] for name in [*TOOL_FACES, *(name for name, _, _ in planes)]}
    tool_faces = []
    for _, face in gmsh.model.getBoundary(soil, oriented=False):
        centre = occ.getCenterOfMass(2, face)
        on = [name for name, axis, value in planes
              if abs(centre[axis] - value) <= ON_PLANE * length]
        if on:
            boundaries[on[0]].append(face)
        else:
            tool_faces.append(face)
    for face, group in zip(tool_faces, _facing(tool_faces, solid)):
        boundaries[group].append(face)
    occ.remove(solid, recursive=True)
    occ.synchronize()
    _grade(p, tool_faces)
    return {"soil": [tag for _, tag in soil]}, boundaries


def _facing(faces, solid):
    """The group of each of the soil's faces on the tool: the axis and sense nearest the
    normal out of the tool (+x front, -x back, +-y side, -z bottom, +z top) at the point of
    the tool's surface nearest the face's centre (its centre of mass, moved onto it: a curved
    face's lies off it, nearer the tool's other side for a thin curved tine). The normal is
    the tool ``solid``'s, as read (a copy kept through the cut): the cut turns some faces it
    keeps whole, so that their normals point into the tool (the blade's bottom against the
    glass wall)."""
    model, occ = gmsh.model, gmsh.model.occ
    surface = [tag for _, tag in model.getBoundary(solid, oriented=False)]
    groups = []
    for face in faces:
        centre = model.getClosestPoint(2, face, occ.getCenterOfMass(2, face))[0]
        nearest = [model.getClosestPoint(2, tag, centre) for tag in surface]
        k = int(np.argmin([np.linalg.norm(np.subtract(x, centre)) for x, _ in nearest]))
        normal = model.getNormal(surface[k], nearest[k][1])
        axis = int(np.argmax(np.abs(normal)))
        groups.append(FACING[axis, normal[axis] > 0.0])
    return groups


def _read_solid(path):
    """The file's solid (its volumes fused into one); an InputError if gmsh cannot read it
    or it holds no closed solid."""
    occ = gmsh.model.occ
    try:
        with _c_stdout_silenced():
            shapes = _run_script(path) if path.lower().endswith(".geo") else occ.importShapes(path)
    except InputError:
        raise
    except Exception as err:   # gmsh raises a bare Exception with its logger's last error
        raise InputError(f"mesh.tool_file = {path!r}: gmsh cannot read it ({err}); accepted: "
                         "a STEP, IGES or BREP file holding one closed solid, or a .geo "
                         "script building one") from None
    volumes = [s for s in shapes if s[0] == 3]
    if not volumes:
        raise InputError(f"mesh.tool_file = {path!r}: holds no closed solid (only "
                         f"{len(shapes)} surfaces, curves or points); export the tool as a solid")
    if len(volumes) > 1:
        volumes, _ = occ.fuse(volumes[:1], volumes[1:])
    occ.remove([s for s in shapes if s[0] < 3], recursive=True)
    occ.synchronize()
    return volumes


def _run_script(path):
    """The OpenCASCADE entities a gmsh .geo script builds in the (empty) model. Its physical
    groups are dropped (the builder names the soil's) and its options do not outlive it; a
    script on gmsh's built-in kernel is refused (no boolean cut of the bin by it)."""
    options = {name: gmsh.option.getNumber(name) for name in SCRIPT_OPTIONS}
    try:
        gmsh.merge(path)
    finally:
        for name, value in options.items():
            gmsh.option.setNumber(name, value)
    gmsh.model.removePhysicalGroups()
    shapes = gmsh.model.occ.getEntities()
    if not shapes and gmsh.model.getEntities(3):
        raise InputError(f"mesh.tool_file = {path!r}: the script builds its solid on gmsh's "
                         'built-in kernel; begin it with SetFactory("OpenCASCADE");')
    return shapes


@contextlib.contextmanager
def _c_stdout_silenced():
    """OpenCASCADE's STEP and IGES readers print to the C stdout, past gmsh's logger: a
    run's stdout (its --json line) stays the run's."""
    sys.stdout.flush()
    saved = os.dup(1)
    with open(os.devnull, "wb") as null:
        os.dup2(null.fileno(), 1)
    try:
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def _place(tool, p: CadToolParams):
    """Scale and rake the solid, put it in the bin; its bounding box there."""
    occ = gmsh.model.occ
    occ.dilate(tool, 0.0, 0.0, 0.0, p.tool_scale, p.tool_scale, p.tool_scale)
    if p.rotation:
        occ.rotate(tool, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, p.rotation)
    x0, y0, z0, x1, y1, z1 = _bounds(tool)
    dy = -y0 if Configuration(p.configuration) is Configuration.SIDE_WALL else -0.5 * (y0 + y1)
    occ.translate(tool, p.behind - x0, dy, -p.tool_depth - z0)
    return _bounds(tool)


def _bounds(tool):
    """The solid's bounding box (x0, y0, z0, x1, y1, z1). OpenCASCADE's is wider by its
    tolerance; where an extreme lies within that tolerance of a vertex, the vertex's
    coordinate is the bound (exact for a flat-faced tool), else OpenCASCADE's (the
    extreme of a curved face)."""
    occ = gmsh.model.occ
    occ.synchronize()
    box = np.array(occ.getBoundingBox(*tool[0]))
    points = np.array([gmsh.model.getValue(0, t, []) for _, t in
                       gmsh.model.getBoundary(tool, combined=False, recursive=True)])
    tolerance = 1e-6 * np.ptp(box.reshape(2, 3), axis=0).max()
    vertex = np.concatenate([points.min(axis=0), points.max(axis=0)])
    return tuple(np.where(np.abs(vertex - box) <= tolerance, vertex, box))


def _check_fits(p: CadToolParams, full, span, top):
    """The tool, placed (``span`` in y, its ``top``), within the bin's width (to both sides
    if ``full``), and reaching up through the surface."""
    reach = max(span[1], -span[0]) if full else span[1]
    if reach >= p.bin_width:
        raise InputError(f"mesh.tool_file = {p.tool_file!r}: the tool reaches |y| = "
                         f"{reach:.4g}, beyond the bin's side: mesh.bin_width = "
                         f"{p.bin_width:g} must be more")
    if top <= 0.0:
        raise InputError(f"mesh.tool_file = {p.tool_file!r}: the tool's top lies "
                         f"{-top:.4g} below the surface: a tool of height "
                         f"{top + p.tool_depth:.4g} (tool_scale = {p.tool_scale:g}) must reach "
                         f"up through it from mesh.tool_depth = {p.tool_depth:g}")


def _check_symmetric(tool, path):
    """An embedded tool is its own mirror image about y = 0 (to 1e-6 of its volume)."""
    occ = gmsh.model.occ
    volume = occ.getMass(*tool[0])
    mirror = occ.copy(tool)
    occ.mirror(mirror, 0.0, 1.0, 0.0, 0.0)
    common, _ = occ.intersect(tool, mirror, removeObject=False, removeTool=True)
    shared = sum(occ.getMass(*c) for c in common)
    occ.remove(common, recursive=True)
    occ.synchronize()
    if abs(shared - volume) > 1e-6 * volume:
        raise InputError(f"mesh.tool_file = {path!r}: the tool is not symmetric about its "
                         f"mid-plane in y ({100 * (1 - shared / volume):.3g}% of its volume "
                         "has no mirror image); configuration = 'side_wall' holds it whole")


def _check_cell_count(p: CadToolParams, box, length, y_min):
    """Refuse, before meshing, a mesh of more than MAX_CELLS tetrahedra: the size field
    integrated over the bin on a grid, with the distance from the tool's bounding box."""
    x0, y0, z0, x1, y1, z1 = box
    n = 40
    x, y, z = np.meshgrid(*(np.linspace(lo, hi, n) for lo, hi in
                            [(0.0, length), (y_min, p.bin_width), (-p.bin_depth, 0.0)]),
                          indexing="ij")
    distance = np.sqrt(sum(np.maximum(np.maximum(lo - c, c - hi), 0.0) ** 2
                           for c, lo, hi in [(x, x0, x1), (y, y0, y1), (z, z0, z1)]))
    cells = CELLS_PER_CUBE * np.mean(p.size(distance) ** -3.0) * length * (p.bin_width - y_min) * p.bin_depth
    if cells > MAX_CELLS:
        raise InputError(f"mesh.element_size = {p.element_size:g} and growth = {p.growth:g} "
                         f"give about {cells:.3g} tetrahedra; accepted: at most {MAX_CELLS:g}")


def _grade(p: CadToolParams, faces):
    """The element size: p.size(distance from the tool's faces), nothing else."""
    field = gmsh.model.mesh.field
    distance = field.add("Distance")
    field.setNumbers(distance, "SurfacesList", faces)
    threshold = field.add("Threshold")
    field.setNumber(threshold, "InField", distance)
    field.setNumber(threshold, "SizeMin", p.element_size)
    field.setNumber(threshold, "SizeMax", p.far_size)
    field.setNumber(threshold, "DistMin", 0.0)
    field.setNumber(threshold, "DistMax", (p.far_size - p.element_size) / (p.growth - 1.0))
    field.setAsBackgroundMesh(threshold)
    for option in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{option}", 0)
