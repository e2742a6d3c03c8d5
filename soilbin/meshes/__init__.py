"""The mesh builder catalogue (records level: no gmsh, no DOLFINx, no MPI).

``b = BUILDERS[name]; p = from_table(b.params, table, "mesh"); tm = b.build(p, comm)``;
a scene's mesh: ``scene_mesh(scene, comm)``.
Each builder is declared in its module (:class:`.builder.Builder`: parameters,
regions, boundaries, contact groups) and meshed by the gmsh ``geometry`` of
its ``*_geometry`` module, imported only by :meth:`.builder.Builder.build`.
"""
from .box import BOX, BoxParams
from .builder import Builder
from .cad_tool import SOIL_BIN_CAD, CadToolParams
from .gmsh_file import GMSH_FILE, GmshFileParams
from .retaining_wall import RETAINING_WALL, RetainingWallParams
from .soil_bin import SOIL_BIN, SoilBinParams
from .strip_footing import STRIP_FOOTING, StripFootingParams

BUILDERS: dict[str, Builder] = {b.name: b for b in (BOX, STRIP_FOOTING, SOIL_BIN, SOIL_BIN_CAD,
                                                     RETAINING_WALL, GMSH_FILE)}


def scene_mesh(scene, comm):
    """The TaggedMesh of a scene: its builder's mesh, of the cells its element needs."""
    return BUILDERS[scene.mesh_builder].build(scene.mesh, comm,
                                              simplices=scene.analysis.element.simplex)


__all__ = ["BUILDERS", "Builder", "scene_mesh", "BoxParams", "StripFootingParams", "SoilBinParams",
           "CadToolParams", "RetainingWallParams", "GmshFileParams"]
