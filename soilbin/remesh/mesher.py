"""The deformed soil meshed afresh by gmsh.

Two-dimensional (:func:`mesh_outline`): the outline's polygon, each of its
edges a line of one segment (two with quadrilaterals: Blossom's full-quad recombination meshes
at twice the size and splits every cell in four, and needs an even boundary; the remesher
samples the outline accordingly, :meth:`.outline.Outline.resampled`), element
sizes those the soil was built with where it now is (a post-processing view of the old cells,
carrying each node's initial element size), and the element's cells: triangles, or
quadrilaterals by Blossom's full-quad recombination (plain Blossom leaves triangles).

gmsh's compound curves would let the new boundary drop old nodes, but gmsh 4.8 then reports the
compound's elements for each of its curves, and DOLFINx's reader crashes on the repeats.

Three-dimensional (:func:`mesh_surface`, tetrahedra): the boundary's triangles become discrete
surfaces, one per patch of one facet group between folds of more than :data:`CREASE` (the
tool's faces, the bin's sides), with the curves where they meet found here
(:meth:`~.surface.Surface.borders`: gmsh's ``createTopology`` numbers them in an order that
changes from run to run, and the mesh changes with it), which gmsh maps onto a plane each
(``createGeometry``: a patch must be a topological disc) and meshes afresh with the volume
they close, at the sizes of the background field: by Delaunay (0.05 s for the patches of the
tine's soil), and again by MeshAdapt (0.46 s) where Delaunay fails or leaves a tetrahedron
below the scene's ``remesh.min_quality`` or :data:`FRESH_QUALITY` (on the mapped patches of
the tine's soil Frontal-Delaunay once left hundreds of inverted triangles), whose mesh is then
kept unless it holds a flat tetrahedron (:data:`FLAT`) or, its nodes moved by
:mod:`.smoothing`, one below half ``remesh.min_quality``; where neither is kept, both again on
patches cut only at larger folds (:data:`WIDER_CREASES`). gmsh's own
``classifySurfaces`` does not cut at a group's border where the boundary is flat (the footing
beside the free surface).

A cavity cut out of the soil's mesh (:func:`mesh_cavity`, for :mod:`.local`) is meshed the same
way, but for the patches that are to stay: they keep their triangles, and the curves around
them their edges (gmsh maps and meshes only the others, then the volume).

gmsh meshes a three-dimensional soil or cavity in a forked child process (:func:`_in_child`):
gmsh 4.8 has died of a bus error on a cavity, and a crash there is a remesh that failed."""
import dataclasses
import math
import os
import pickle
import re
import signal

import gmsh
import numpy as np

from ..meshes.tagged import check_cells, distribute, generate_logged
from ..problem.mesh_quality import simplex_quality
from .smoothing import smoothed


#: Where the boundary folds by more than this (radians), gmsh cuts it into patches.
CREASE = math.radians(40.0)
#: The folds a fresh mesh's patches are cut at, in turn, where gmsh fails on those cut at
#: :data:`CREASE`: the clay's heap beside the blade, a patch of 9-17 triangles cut from the
#: free surface by a sharp crest, overlapped it once both were meshed afresh (on the 0.35-in
#: mesh at 2.03 in the two are one patch at 50 degrees, which gmsh meshes; on the 1.5-in mesh
#: at 4.3 in gmsh meshes them at 70 degrees and more, one triangle moved between them).
WIDER_CREASES = (math.radians(60.0), math.radians(90.0))

#: gmsh's surface algorithms for the patches of a 3D remesh, in the order tried (module doc).
DELAUNAY, MESH_ADAPT = 5, 1
#: gmsh's element types of the 3-node triangle and the 4-node tetrahedron.
TRIANGLE, TETRAHEDRON = 2, 4

#: The least scaled Jacobian a Delaunay remesh must pass whatever the scene's min_quality: on
#: the footing's thin slab (remeshed by count) it once left a sliver of 7e-6, around which
#: the re-equilibration ran for minutes.
FRESH_QUALITY = 0.02
#: The least scaled Jacobian any remesh must pass: below it a tetrahedron is flat (gmsh made
#: one of 5e-17 on three collinear boundary nodes of the clay's soil after 4.2 in of travel,
#: by either surface algorithm, and the mean-dilatation pressure of its zero volume was nan).
FLAT = 1e-6


@dataclasses.dataclass(frozen=True)
class Sizes:
    """The element sizes asked for: linear over the simplices ``cells`` (m, d + 1, d; d = 2:
    the x-z plane) from the ``values`` (m, d + 1) at their corners."""
    cells: np.ndarray
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
        _size_field(sizes)
        if not simplices:
            gmsh.option.setNumber("Mesh.RecombineAll", 1)
        _generate(2)
        check_cells(RuntimeError, "the remesher made", 2, simplices)
        _write(path)
        return regions, dict(boundaries)
    return distribute(comm, "remesh", model, dimension=2)


def mesh_surface(comm, surface, sizes, regions, boundaries, path, min_quality=0.0):
    """The TaggedMesh of tetrahedra inside the closed :class:`~.surface.Surface` ``surface``
    (rank 0; None elsewhere), distributed and written to the gmsh file ``path``; ``sizes``,
    ``regions``, ``boundaries`` as :func:`mesh_outline`'s. A Delaunay mesh is kept if its
    least scaled Jacobian is above ``min_quality`` and :data:`FRESH_QUALITY`, else MeshAdapt's
    if it is above :data:`FLAT` and half ``min_quality``, its nodes moved where that lifts it
    there (:func:`_lifted`); where neither is, both again with the boundary cut into
    patches at each of :data:`WIDER_CREASES` in turn, unless the surface passes through
    itself (on patches of wider folds gmsh has meshed such a one); the last failure raised
    (module doc). gmsh meshes in a child process, which writes the file that is read here
    (:func:`_in_child`): a crash of gmsh is a RuntimeError, not the end of the run."""
    def model():
        if _in_child(_written_tetrahedra, surface, sizes, regions, boundaries, path,
                     min_quality) is None:
            raise RuntimeError("gmsh died meshing the deformed soil afresh")
        gmsh.open(str(path))
        return regions, dict(boundaries)
    return distribute(comm, "remesh", model, dimension=3)


def _written_tetrahedra(surface, sizes, regions, boundaries, path, min_quality):
    """:func:`mesh_surface`'s tetrahedra written to ``path``, in this process's gmsh
    session; True."""
    for crease in (CREASE, *WIDER_CREASES):
        try:
            _tetrahedra(surface, sizes, regions, boundaries, min_quality, crease)
            break
        except RuntimeError:
            if crease == WIDER_CREASES[-1] or surface.folded(boundaries):
                raise   # a soil through itself would be meshed as a wrong one
            gmsh.clear()
    check_cells(RuntimeError, "the remesher made", 3, True)
    _write(path)
    return True


def _tetrahedra(surface, sizes, regions, boundaries, min_quality, crease):
    """The gmsh model of :func:`mesh_surface`'s tetrahedra, the boundary cut into patches
    at folds of more than ``crease``; RuntimeError where gmsh fails on them."""
    for attempt, algorithm in enumerate((DELAUNAY, MESH_ADAPT)):
        if attempt:
            gmsh.model.remove()
            gmsh.view.remove(view)
        view, groups, _ = _surface_model(surface, sizes, regions, boundaries, crease=crease)
        gmsh.option.setNumber("Mesh.Algorithm", algorithm)
        try:
            _generate(3)
            outside = boundary_nodes_outside()
            if outside:
                raise RuntimeError(f"gmsh's mesh of the deformed soil leaves {outside} nodes of "
                                   "its boundary out of its tetrahedra")
            least = _least_quality()
            if least > max(min_quality, FRESH_QUALITY):
                return
            if attempt and least < FLAT:
                raise RuntimeError(f"gmsh's mesh of the deformed soil holds a flat "
                                   f"tetrahedron (scaled Jacobian {least:.2g})")
            if attempt and least <= min_quality / 2.0:
                least = _lifted(groups, min_quality)
                if least <= min_quality / 2.0:
                    raise RuntimeError(f"gmsh's mesh of the deformed soil holds a tetrahedron "
                                       f"of scaled Jacobian {least:.2g} however its nodes "
                                       "move, below half remesh.min_quality")
        except RuntimeError as err:
            if attempt:
                folded = surface.folded(boundaries)
                raise RuntimeError(f"{err}{patch_groups(str(err), groups, boundaries)}"
                                   f"{folded and ': ' + folded}") from None


def boundary_nodes_outside():
    """How many nodes of the model's boundary triangles no tetrahedron of it has: gmsh may
    leave some where it does not recover the boundary, and DOLFINx's reader then crashes the
    process (a segmentation fault distributing the facet tags: the tine's 1-in soil
    remeshed below 0.06 at 8.43 in left 3 of 802 out)."""
    _, _, cells = gmsh.model.mesh.getElements(3)
    _, _, facets = gmsh.model.mesh.getElements(2)
    if not facets:
        return 0
    return np.setdiff1d(np.concatenate(facets), np.concatenate(cells or [[]])).size


def _lifted(groups, target):
    """Moves the model's nodes to lift its cells toward the least scaled Jacobian ``target``
    (:func:`~.smoothing.smoothed`; ``groups``: each patch's facet group) and returns the least
    then. A MeshAdapt mesh below half min_quality cannot be brought back to equilibrium
    (its first solution is refused, :meth:`~soilbin.problem.SoilProblem.solve`): the clay's
    0.5-in mesh at 2.74 in of travel held one of 0.0132 against 0.045, four remeshes in a row,
    and the run stopped."""
    nodes, points, cells, triangles, tags = _model_mesh(groups)
    moved, least = smoothed(points, cells, triangles, tags, target)
    for k in np.flatnonzero((moved != points).any(axis=1)):
        gmsh.model.mesh.setNode(int(nodes[k]), moved[k].tolist(), [])
    return least


def mesh_cells(comm, points, cells, triangles, tags, regions, boundaries, path):
    """The TaggedMesh of the tetrahedra ``cells`` (m, 4) on the ``points`` (n, 3), with the
    boundary ``triangles`` (k, 3) in the facet groups ``tags`` (k,) (rank 0; None elsewhere):
    an old mesh with its nodes moved (:mod:`.smoothing`) or meshed afresh in part
    (:mod:`.local`), distributed and written to the gmsh file ``path``; ``regions``,
    ``boundaries`` as :func:`mesh_outline`'s."""
    def model():
        gmsh.model.add("smoothed")
        volume = gmsh.model.addDiscreteEntity(3)
        gmsh.model.mesh.addNodes(3, volume, np.arange(1, len(points) + 1), points.ravel())
        gmsh.model.mesh.addElementsByType(volume, TETRAHEDRON, [], cells.ravel() + 1)
        (name, region), = regions.items()
        gmsh.model.addPhysicalGroup(3, [volume], region)
        gmsh.model.setPhysicalName(3, region, name)
        for group, tag in boundaries.items():
            if (tags == tag).any():
                patch = gmsh.model.addDiscreteEntity(2)
                gmsh.model.mesh.addElementsByType(patch, TRIANGLE, [],
                                                  triangles[tags == tag].ravel() + 1)
                gmsh.model.addPhysicalGroup(2, [patch], tag)
                gmsh.model.setPhysicalName(2, tag, group)
        _write(path)
        return dict(regions), dict(boundaries)
    return distribute(comm, "remesh", model, dimension=3)


def mesh_cavity(surface, sizes, keep, least):
    """The tetrahedra inside the closed :class:`~.surface.Surface` ``surface`` (a cavity cut
    out of a mesh, :mod:`.local`), the patches made of its triangles ``keep`` (a mask) alone
    kept as they are, the others meshed afresh by Delaunay at the ``sizes``: (the points
    (n, 3), the tetrahedra (m, 4) into them, the fresh patches' triangles (k, 3) and their
    tags (k,)), or None where gmsh fails, leaves a tetrahedron below ``least`` or crashes
    (rank 0 alone: gmsh is started and stopped in a child process, :func:`_in_child`)."""
    return _in_child(_cavity_tetrahedra, surface, sizes, keep, least)


def _in_child(function, *args):
    """``function(*args)`` in a forked child process, its result (or the exception it
    raised, raised again here) sent back pickled; None where the child dies. gmsh 4.8's 3D
    Delaunay of one cavity of the clay (the 0.75-in mesh remeshed below 0.04, at 2.2 in of
    travel) died of a bus error in the run, and of a segmentation fault in a fresh process
    given the same cavity, and the run with it. The child has the parent's gmsh session as
    it was (a copy): a change it makes there is not seen here."""
    read, write = os.pipe()
    child = os.fork()
    if child == 0:   # no MPI and no exit handlers here: the parent's, not the child's
        os.close(read)
        for fault in (signal.SIGSEGV, signal.SIGBUS):   # PETSc's handler would abort MPI
            signal.signal(fault, signal.SIG_DFL)
        try:
            try:
                sent = (True, function(*args))
            except Exception as err:
                sent = (False, err)
            with os.fdopen(write, "wb") as pipe:
                pickle.dump(sent, pipe)
        finally:
            os._exit(0)
    os.close(write)
    with os.fdopen(read, "rb") as pipe:
        sent = pipe.read()
    _, status = os.waitpid(child, 0)
    if status != 0 or not sent:
        return None
    returned, value = pickle.loads(sent)
    if not returned:
        raise value
    return value


def _cavity_tetrahedra(surface, sizes, keep, least):
    """:func:`mesh_cavity`'s tetrahedra, in this process."""
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        _, groups, kept = _surface_model(surface, sizes, {"cavity": 1}, {}, keep)
        gmsh.option.setNumber("Mesh.Algorithm", DELAUNAY)
        _generate(3)
        if _least_quality() < least:
            return None
        _, points, cells, triangles, tags = _model_mesh(
            {patch: tag for patch, tag in groups.items() if patch not in kept})
        return points, cells, triangles, tags
    except RuntimeError:
        return None
    finally:
        gmsh.finalize()


def patch_groups(message, groups, boundaries):
    """The facet groups of the patches that a gmsh ``message`` names ("surface 4"), as
    "; gmsh's surface 4 is a patch of tool_front, 9 of surface" ('' if it names none);
    ``groups``: patch (gmsh surface) -> facet group tag, ``boundaries``: name -> tag."""
    names = {tag: name for name, tag in boundaries.items()}
    patches = [int(n) for n in dict.fromkeys(re.findall(r"surface (\d+)", message))]
    named = [(patch, names[groups[patch]]) for patch in patches
             if groups.get(patch) in names]
    if not named:
        return ""
    (first, group), *rest = named
    return (f"; gmsh's surface {first} is a patch of {group}"
            + "".join(f", {patch} of {group}" for patch, group in rest))


def _surface_model(surface, sizes, regions, boundaries, keep=None, crease=CREASE):
    """The gmsh model of the volume inside ``surface``, its groups and its background size,
    ready to mesh, the boundary cut into patches at folds of more than ``crease``, those made
    of the triangles ``keep`` (a mask, or None) alone keeping theirs; returns the size's
    view, each patch's (gmsh surface's) facet group tag and the set of the patches kept."""
    gmsh.model.add("remesh")
    groups, kept = _discrete_model(surface, keep, crease)
    fresh = [(2, patch) for patch in groups if patch not in kept]
    around = {abs(curve) for _, curve in gmsh.model.getBoundary([(2, p) for p in kept],
                                                                 oriented=False)}
    fresh += sorted({(1, abs(curve)) for _, curve in gmsh.model.getBoundary(fresh, oriented=False)
                     if abs(curve) not in around})
    try:
        if fresh or not kept:   # createGeometry([]) maps every discrete entity
            gmsh.model.mesh.createGeometry(fresh if kept else [])
    except Exception as err:   # gmsh raises a bare Exception with its last error
        raise RuntimeError(f"gmsh cannot map the deformed soil's boundary patches onto "
                           f"planes ({err}): a patch is no longer a topological "
                           "disc") from None
    faces = [entity for _, entity in gmsh.model.getEntities(2)]
    volume = gmsh.model.geo.addVolume([gmsh.model.geo.addSurfaceLoop(faces)])
    gmsh.model.geo.synchronize()
    (name, region), = regions.items()
    gmsh.model.addPhysicalGroup(3, [volume], region)
    gmsh.model.setPhysicalName(3, region, name)
    for group, tag in boundaries.items():
        members = [patch for patch, of in groups.items() if of == tag]
        if members:
            gmsh.model.addPhysicalGroup(2, members, tag)
            gmsh.model.setPhysicalName(2, tag, group)
    return _size_field(sizes), groups, kept


def _discrete_model(surface, keep, crease):
    """The surface as gmsh's discrete entities, numbered in the order of its own
    :meth:`~.surface.Surface.borders` (gmsh's ``createTopology`` numbers them differently from
    run to run): a point per corner, a curve per border, a surface per patch (cut at folds
    of more than ``crease``), each holding its nodes and elements. Returns each surface
    entity's facet group tag and the set of those made of the triangles ``keep`` (a mask, or
    None: none) alone."""
    model, mesh = gmsh.model, gmsh.model.mesh
    patch_of = surface.patches(crease)
    borders = surface.borders(patch_of)
    corner = {int(c): model.addDiscreteEntity(0) for c in borders.corners}
    curves = [model.addDiscreteEntity(1, -1, [corner[c[0]], corner[c[-1]]])
              for c in borders.curves]
    patches = [model.addDiscreteEntity(2, -1, [curves[k] for k in bounding])
               for bounding in borders.bounding]
    # each node on the entity of least dimension that holds it
    home = np.full(len(surface.points), -1)
    home[surface.triangles.ravel()] = np.repeat(patch_of, 3)
    for c, entity in corner.items():
        mesh.addNodes(0, entity, [c + 1], surface.points[c])
        home[c] = -2
    for chain, entity in zip(borders.curves, curves):
        inner = np.array(chain[1:-1], dtype=int)
        mesh.addNodes(1, entity, inner + 1, surface.points[inner].ravel())
        home[inner] = -2
        mesh.addElementsByType(entity, 1, [], np.column_stack([chain[:-1], chain[1:]]).ravel() + 1)
    for patch, entity in enumerate(patches):
        nodes = np.flatnonzero(home == patch)
        mesh.addNodes(2, entity, nodes + 1, surface.points[nodes].ravel())
    for patch, entity in enumerate(patches):
        triangles = surface.triangles[patch_of == patch] + 1
        mesh.addElementsByType(entity, 2, [], triangles.ravel())
    groups = {entity: surface.tags[patch_of == patch][0] for patch, entity in enumerate(patches)}
    if keep is None:
        return groups, set()
    fresh = np.bincount(patch_of, weights=~keep, minlength=len(patches))
    return groups, {entity for patch, entity in enumerate(patches) if fresh[patch] == 0}


def read_mesh(comm, path, regions, boundaries, dimension=2):
    """The TaggedMesh a remesh wrote to ``path``; ``regions``, ``boundaries``: group name ->
    tag, as the mesh was made with."""
    def model():
        gmsh.open(str(path))
        return dict(regions), dict(boundaries)
    return distribute(comm, str(path), model, dimension=dimension)


def _write(path):
    path.parent.mkdir(parents=True, exist_ok=True)
    gmsh.option.setNumber("Mesh.Binary", 1)   # the coordinates to the last bit
    gmsh.write(str(path))


def _size_field(sizes):
    """The background size: linear over the old cells' simplices (in 2D triangles in the x-z
    plane); returns its view."""
    view = gmsh.view.add("initial element size")
    cells = sizes.cells
    m, k, d = cells.shape
    x = [cells[:, :, 0], cells[:, :, 1] if d == 3 else np.zeros((m, k)), cells[:, :, d - 1]]
    data = np.hstack([*x, sizes.values]).ravel()   # per simplex: xs, ys, zs, values
    gmsh.view.addListData(view, "SS" if d == 3 else "ST", m, data.tolist())
    fields = gmsh.model.mesh.field
    field = fields.add("PostView")
    fields.setNumber(field, "ViewTag", view)
    fields.setAsBackgroundMesh(field)
    for option, value in {"Mesh.MeshSizeExtendFromBoundary": 0, "Mesh.MeshSizeFromPoints": 0,
                          "Mesh.MeshSizeFromCurvature": 0,
                          "Mesh.Algorithm": 6,          # Frontal-Delaunay (8 crashes in 4.8)
                          "Mesh.RecombinationAlgorithm": 3}.items():   # Blossom full-quad
        gmsh.option.setNumber(option, value)
    return view


def _least_quality():
    """The least scaled Jacobian of the model's tetrahedra (gmsh orients each positively)."""
    _, points, cells, _, _ = _model_mesh({})
    return float(simplex_quality(points[cells]).min())


def _model_mesh(groups):
    """The gmsh model's mesh as arrays: (its node tags (n,), their points (n, 3), the
    tetrahedra (m, 4) and the triangles (k, 3) of the patches ``groups`` (gmsh surface ->
    facet group tag) as rows of the points, each triangle's group (k,))."""
    nodes, coordinates, _ = gmsh.model.mesh.getNodes()
    number = np.zeros(int(nodes.max()) + 1, dtype=int)
    number[nodes] = np.arange(len(nodes))
    _, _, corners = gmsh.model.mesh.getElements(3)
    triangles, tags = [np.zeros((0, 3), int)], [np.zeros(0, int)]
    for patch, tag in groups.items():
        _, _, on_patch = gmsh.model.mesh.getElements(2, patch)
        triangles.append(number[np.concatenate(on_patch).reshape(-1, 3)])
        tags.append(np.full(len(triangles[-1]), tag))
    return (nodes, coordinates.reshape(-1, 3), number[np.concatenate(corners).reshape(-1, 4)],
            np.concatenate(triangles), np.concatenate(tags))


def _generate(dimension):
    """Mesh; gmsh's errors (:func:`~soilbin.meshes.tagged.generate_logged`) raised as a
    RuntimeError."""
    errors = generate_logged(dimension)
    if errors:
        raise RuntimeError(f"gmsh cannot mesh the deformed soil ({errors[0]})")
