"""The gmsh-file builder's declaration: a user's mesh, read from a ``.msh`` file.

``[mesh] builder = "gmsh", file = "part.msh"`` (relative to the scene's folder).
Its regions are the file's named 3D physical groups and its boundaries the
named 2D ones, read from the ``$PhysicalNames`` section without gmsh (records
level), so the scene is checked against them before anything is built: a
region, support, load or tool face naming a group the file lacks is an error
naming the file and its groups. Cells must be 8-node hexahedra or 4-node tetrahedra,
as the scene's element needs.
"""
import dataclasses
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from ..params import Params, param
from .builder import Builder


@dataclass(frozen=True)
class GmshFileParams(Params):
    file: str = param(doc="gmsh .msh file (format 2 or 4, ASCII or binary), relative to the "
                          "scene's folder; named physical groups: volumes = regions, surfaces = "
                          "boundaries")


def physical_names(path):
    """(dimension, tag, name) of every named physical group of a .msh file."""
    try:
        data = Path(path).read_bytes()
    except OSError as err:
        raise InputError(f"mesh.file = {str(path)!r}: cannot read it ({err.strerror})") from None
    start, end = data.find(b"$PhysicalNames"), data.find(b"$EndPhysicalNames")
    if not data.startswith(b"$MeshFormat"):
        raise InputError(f"mesh.file = {str(path)!r}: not a gmsh .msh file")
    if start < 0 or end < start:
        raise InputError(f"mesh.file = {str(path)!r}: the file names no physical groups; name "
                         "the soil's volumes and the boundary surfaces (gmsh physical groups)")
    groups = []
    for line in data[start:end].decode("utf-8", "replace").splitlines()[2:]:
        dim, tag, name = line.split(maxsplit=2)
        groups.append((int(dim), int(tag), name.strip().strip('"')))
    return groups


@dataclass(frozen=True)
class FileBuilder(Builder):
    """A builder whose groups are those of the file it reads."""

    def locate(self, params, folder):
        return dataclasses.replace(params, file=str((Path(folder) / params.file).resolve()))

    def groups(self, params):
        names = physical_names(params.file)
        regions = tuple(name for dim, _, name in names if dim == 3)
        if not regions:
            raise InputError(f"mesh.file = {params.file!r}: no named 3D physical group (region)")
        return regions, tuple(name for dim, _, name in names if dim == 2), ()

    def label(self, params):
        return f"mesh file {params.file}"

    def build(self, params, comm, simplices=False):
        from .gmsh_file_geometry import read_tagged_mesh
        regions, boundaries, _ = self.groups(params)
        return read_tagged_mesh(comm, params.file, regions, boundaries, simplices)


GMSH_FILE = FileBuilder(
    name="gmsh", params=GmshFileParams, summary="a gmsh .msh file with named physical groups",
    regions=(), boundaries=(), contact=(), geometry="gmsh_file_geometry")
