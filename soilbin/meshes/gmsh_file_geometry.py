"""The gmsh-file builder's reading (declaration: :mod:`.gmsh_file`): the file's mesh and
named physical groups, hexahedra or tetrahedra, distributed like a built mesh."""
import gmsh

from ..errors import InputError
from .tagged import check_cells, distribute


def read_tagged_mesh(comm, path, regions, boundaries, simplices):
    """The TaggedMesh of a .msh file; ``regions``, ``boundaries``: its named groups; its cells
    tetrahedra where ``simplices``, else hexahedra."""
    def model():
        try:
            gmsh.open(path)
        except Exception as err:
            raise InputError(f"mesh.file = {path!r}: gmsh cannot read it ({err})") from None
        check_cells(InputError, f"mesh.file = {path!r} has", 3, simplices)
        tags = {(dim, gmsh.model.getPhysicalName(dim, tag)): tag
                for dim, tag in gmsh.model.getPhysicalGroups()}
        return ({name: tags[3, name] for name in regions},
                {name: tags[2, name] for name in boundaries})
    return distribute(comm, path, model)
