"""A DOLFINx mesh with named cell and facet groups, meshed by gmsh on rank 0."""
import itertools
from dataclasses import dataclass
from typing import Callable

import dolfinx.cpp.mesh
import dolfinx.mesh
import gmsh
from dolfinx.io import gmshio
from mpi4py import MPI

from ..elements import CELL
from ..errors import InputError

#: Group name -> gmsh entity tags (volumes for regions, surfaces for boundaries).
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
                      regions: tuple[str, ...], boundaries: tuple[str, ...]) -> TaggedMesh:
    """Mesh the gmsh model made by ``geometry`` on rank 0 and distribute it.

    ``geometry`` builds and synchronizes the model and returns the volumes of
    each region and the surfaces of each boundary; they must be exactly the
    declared ``regions`` and ``boundaries``, none empty. Groups are tagged
    1, 2, ... in the declared order, regions first, so no two groups share a tag.
    """
    def model():
        gmsh.model.add(name)
        made_regions, made_boundaries = geometry()
        return _mesh_hexahedra(_as_declared(name, "regions", regions, made_regions),
                               _as_declared(name, "boundaries", boundaries, made_boundaries))
    return distribute(comm, name, model)


def distribute(comm: MPI.Comm, name: str, model: Callable[[], tuple[dict, dict]]) -> TaggedMesh:
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
        mesh, cell_tags, facet_tags = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=3)
    finally:
        gmsh.finalize()
    return TaggedMesh(mesh, cell_tags, facet_tags, *groups)


def _as_declared(name: str, kind: str, declared: tuple[str, ...], made: Groups) -> Groups:
    """The groups the geometry made, in the declared order; exactly the declared ones."""
    if set(made) != set(declared):
        raise RuntimeError(f"{name}: the geometry made {kind} {sorted(made)}; declared: {sorted(declared)}")
    return {group: made[group] for group in declared}


def _mesh_hexahedra(regions: Groups, boundaries: Groups) -> tuple[dict[str, int], dict[str, int]]:
    """Add the physical groups, mesh in 3D, and check that only hexahedra were made."""
    unassigned = {t for _, t in gmsh.model.getEntities(3)} - set().union(*regions.values())
    if unassigned:
        raise RuntimeError(f"volumes {sorted(unassigned)} are in no region; their cells would be lost")
    numbers = itertools.count(1)
    tags = _add_physical_groups(3, regions, numbers), _add_physical_groups(2, boundaries, numbers)
    gmsh.model.mesh.generate(3)
    check_hexahedra(RuntimeError, "gmsh made")
    return tags


def check_hexahedra(error, source):
    """Raise ``error`` unless the model's 3D elements are all 8-node hexahedra."""
    types = list(gmsh.model.mesh.getElementTypes(3))
    if types != [gmsh.model.mesh.getElementType(CELL, 1)]:
        made = ", ".join(gmsh.model.mesh.getElementProperties(t)[0] for t in types)
        raise error(f"{source} 3D elements [{made}]; only 8-node hexahedra are supported")


def _add_physical_groups(dim: int, groups: Groups, numbers) -> dict[str, int]:
    """One named physical group per entry, numbered by ``numbers``; name -> tag."""
    tags = {}
    for group, entities in groups.items():
        if not entities:
            raise RuntimeError(f"physical group {group!r} has no entities")
        tags[group] = gmsh.model.addPhysicalGroup(dim, entities, next(numbers))
        gmsh.model.setPhysicalName(dim, tags[group], group)
    return tags
