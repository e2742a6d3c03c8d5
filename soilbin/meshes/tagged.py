"""A DOLFINx mesh with named cell and facet groups, meshed by gmsh on rank 0."""
import itertools
from dataclasses import dataclass
from typing import Callable

import dolfinx.cpp.mesh
import dolfinx.mesh
import gmsh
import numpy as np
from dolfinx.cpp.mesh import entities_to_geometry
from dolfinx.io import gmshio
from mpi4py import MPI

from ..errors import InputError

#: gmsh's name of the cell of a mesh of each (dimension, simplices).
GMSH_CELLS = {(3, False): "Hexahedron", (2, False): "Quadrangle", (3, True): "Tetrahedron",
              (2, True): "Triangle"}
#: Their words in messages, and the elements that use them.
CELL_WORDS = {(3, False): ("8-node hexahedra", "hex8, hex27"),
              (2, False): ("4-node quadrilaterals", "quad4, quad9"),
              (3, True): ("4-node tetrahedra", "tet10"), (2, True): ("3-node triangles", "tri6")}
#: Group name -> gmsh entity tags (volumes for regions, surfaces for boundaries; in a
#: two-dimensional mesh surfaces and curves).
Groups = dict[str, list[int]]


@dataclass(frozen=True)
class TaggedMesh:
    """A mesh, its cell and facet tags, and the tag of each named group."""

    mesh: dolfinx.mesh.Mesh
    cell_tags: dolfinx.cpp.mesh.MeshTags_int32
    facet_tags: dolfinx.cpp.mesh.MeshTags_int32
    regions: dict[str, int]     # cell group name -> tag
    boundaries: dict[str, int]  # facet group name -> tag


def build_tagged_mesh(comm: MPI.Comm, name: str, geometry: Callable[[], tuple[Groups, Groups]], *,
                      regions: tuple[str, ...], boundaries: tuple[str, ...],
                      dimension: int = 3, simplices: bool = False,
                      may_be_empty: tuple[str, ...] = ()) -> TaggedMesh:
    """Mesh the gmsh model made by ``geometry`` on rank 0 and distribute it.

    ``geometry`` builds and synchronizes the model and returns the entities of
    ``dimension`` of each region and those one dimension lower of each
    boundary; they must be exactly the declared ``regions`` and ``boundaries``,
    none empty but those of ``may_be_empty`` (named, tagged, without facets). Groups are
    tagged 1, 2, ... in the declared order, regions first, so no two groups share a tag. A
    two-dimensional geometry is built and meshed in the x-z plane, as the scene sees it.
    Its cells must be tetrahedra (triangles) where ``simplices``, else hexahedra
    (quadrilaterals).
    """
    def model():
        gmsh.model.add(name)
        made_regions, made_boundaries = geometry()
        return _mesh_cells(name, _as_declared(name, "regions", regions, made_regions),
                           _as_declared(name, "boundaries", boundaries, made_boundaries), dimension,
                           simplices, may_be_empty)
    return distribute(comm, name, model, dimension)


def distribute(comm: MPI.Comm, name: str, model: Callable[[], tuple[dict, dict]],
               dimension: int = 3) -> TaggedMesh:
    """Run ``model()`` on rank 0 (it makes the meshed gmsh model and returns the tag of each
    region and boundary) and distribute the mesh. If it fails, every rank raises: an
    InputError as the same InputError, anything else as a RuntimeError."""
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        if comm.rank == 0:
            groups, failure = None, (RuntimeError, f"gmsh failed to mesh {name!r} on rank 0")
            try:
                groups = model()
            except InputError as err:
                failure = (InputError, str(err))
                raise
            finally:
                comm.bcast((groups, failure), root=0)
        else:
            groups, (kind, message) = comm.bcast(None, root=0)
            if groups is None:
                raise kind(message)
        model = gmsh.model if dimension == 3 else _InPlane(gmsh.model)
        mesh, cell_tags, facet_tags = gmshio.model_to_mesh(model, comm, 0, gdim=dimension)
    finally:
        gmsh.finalize()
    return TaggedMesh(mesh, cell_tags, facet_tags, *groups)


class _InPlane:
    """gmsh.model as DOLFINx reads a mesh from it, with the nodes of the x-z plane seen in
    the x-y plane ((x, 0, z) as (x, z, 0)): a two-dimensional mesh's axes are x and z."""

    def __init__(self, model):
        self._model = model
        self.mesh = _InPlaneNodes(model.mesh)

    def __getattr__(self, name):
        return getattr(self._model, name)


class _InPlaneNodes:
    def __init__(self, mesh):
        self._mesh = mesh

    def __getattr__(self, name):
        return getattr(self._mesh, name)

    def getNodes(self, *args, **kwargs):
        tags, x, parametric = self._mesh.getNodes(*args, **kwargs)
        return tags, x.reshape(-1, 3)[:, [0, 2, 1]].ravel(), parametric


def _as_declared(name: str, kind: str, declared: tuple[str, ...], made: Groups) -> Groups:
    """The groups the geometry made, in the declared order; exactly the declared ones."""
    if set(made) != set(declared):
        raise RuntimeError(f"{name}: the geometry made {kind} {sorted(made)}; declared: {sorted(declared)}")
    return {group: made[group] for group in declared}


def _mesh_cells(name: str, regions: Groups, boundaries: Groups, dimension: int,
                simplices: bool, may_be_empty=()) -> tuple[dict[str, int], dict[str, int]]:
    """Add the physical groups, mesh, and check the cells."""
    unassigned = {t for _, t in gmsh.model.getEntities(dimension)} - set().union(*regions.values())
    if unassigned:
        raise RuntimeError(f"entities {sorted(unassigned)} of dimension {dimension} are in no "
                           "region; their cells would be lost")
    numbers = itertools.count(1)
    tags = (_add_physical_groups(dimension, regions, numbers),
            _add_physical_groups(dimension - 1, boundaries, numbers, may_be_empty))
    _generate(name, dimension)
    check_cells(RuntimeError, "gmsh made", dimension, simplices)
    return tags


def _generate(name: str, dimension: int):
    """Mesh the model; an error of gmsh's mesher (a size or a shape it cannot honour) is an
    InputError."""
    errors = generate_logged(dimension)
    if errors:
        raise InputError(f"mesh builder {name!r}: gmsh cannot mesh the geometry of [mesh] "
                         f"({errors[0]}); change its lengths or sizes")


def generate_logged(dimension: int):
    """Mesh the model up to ``dimension``; returns gmsh's error lines (none: it meshed). gmsh
    4.8 throws its errors (General.AbortOnError = 2, the API's default) from inside its
    OpenMP region, where nothing can catch them and the process aborts; with 1 it logs the
    error and stops meshing."""
    gmsh.option.setNumber("General.AbortOnError", 1)
    gmsh.logger.start()
    try:
        gmsh.model.mesh.generate(dimension)
        return [line for line in gmsh.logger.get() if line.startswith("Error")]
    finally:
        gmsh.logger.stop()


def check_cells(error, source, dimension=3, simplices=False):
    """Raise ``error`` unless the model's elements of ``dimension`` are all of the one kind
    expected: 8-node hexahedra (4-node quadrilaterals in 2D), or 4-node tetrahedra (3-node
    triangles) where ``simplices``."""
    types = list(gmsh.model.mesh.getElementTypes(dimension))
    if types != [gmsh.model.mesh.getElementType(GMSH_CELLS[dimension, simplices], 1)]:
        made = ", ".join(gmsh.model.mesh.getElementProperties(t)[0] for t in types)
        only, elements = CELL_WORDS[dimension, simplices]
        raise error(f"{source} {dimension}D elements [{made}]; analysis.element ({elements}) "
                    f"needs {only} only")


def _add_physical_groups(dim: int, groups: Groups, numbers, may_be_empty=()) -> dict[str, int]:
    """One named physical group per entry, numbered by ``numbers``; name -> tag (a group of
    ``may_be_empty`` without entities takes its number, and no physical group)."""
    tags = {}
    for group, entities in groups.items():
        if not entities and group in may_be_empty:
            tags[group] = next(numbers)
            continue
        if not entities:
            raise RuntimeError(f"physical group {group!r} has no entities")
        tags[group] = gmsh.model.addPhysicalGroup(dim, entities, next(numbers))
        gmsh.model.setPhysicalName(dim, tags[group], group)
    return tags


def outward_corners(mesh, facets):
    """The geometry nodes of the corners of the boundary ``facets`` of a three-dimensional
    mesh, each facet's seen from outside counter-clockwise: (k, 3) triangles, or (k, 4)
    quadrilaterals in DOLFINx's tensor order (around: 0, 1, 3, 2)."""
    facets = np.asarray(facets, dtype=np.int32)
    x = mesh.geometry.x
    n_corners = 4 if mesh.topology.cell_type == dolfinx.mesh.CellType.hexahedron else 3
    nodes = entities_to_geometry(mesh._mesh, 2, facets, False)[:, :n_corners]   # 0.5: C++ mesh
    corners = x[nodes]
    mesh.topology.create_connectivity(2, 3)
    to_cell = mesh.topology.connectivity(2, 3)
    cells = to_cell.array[to_cell.offsets[facets]]       # a boundary facet's one cell
    inside = x[entities_to_geometry(mesh._mesh, 3, cells, False)].mean(axis=1)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    inward = np.einsum("ij,ij->i", normal, corners[:, 0] - inside) < 0.0
    nodes[inward] = nodes[inward][:, [0, 2, 1, 3][:n_corners]]
    return nodes
