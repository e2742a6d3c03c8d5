"""Write an example user mesh for the gmsh-file builder: a 1 x 1 x 1 block of 2 x 2 x 2
hexahedra with named physical groups (volume "soil"; surfaces "base", "top", "xmin",
"ymin"), as scenes/meshes/block.msh (or the path given). scenes/block-gmsh-file.toml runs it.
With --tetrahedra the block is gmsh's unstructured tetrahedra (cells up to 0.6 long) instead.

    python scripts/make_user_mesh.py [OUT.msh] [--tetrahedra]
"""
import sys
from pathlib import Path

import gmsh

OUT = Path(__file__).resolve().parent.parent / "scenes" / "meshes" / "block.msh"


def block(path, n=2, tetrahedra=False):
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("block")
        box = gmsh.model.occ.addBox(0.0, 0.0, 0.0, 1.0, 1.0, 1.0)
        gmsh.model.occ.synchronize()
        if tetrahedra:
            gmsh.option.setNumber("Mesh.MeshSizeMax", 0.6)
        else:
            for _, curve in gmsh.model.getEntities(1):
                gmsh.model.mesh.setTransfiniteCurve(curve, n + 1)
            for _, surface in gmsh.model.getEntities(2):
                gmsh.model.mesh.setTransfiniteSurface(surface)
                gmsh.model.mesh.setRecombine(2, surface)
            gmsh.model.mesh.setTransfiniteVolume(box)
        gmsh.model.addPhysicalGroup(3, [box], 1)
        gmsh.model.setPhysicalName(3, 1, "soil")
        for tag, (name, box_min, box_max) in enumerate([
                ("base", (-1, -1, -1e-6), (2, 2, 1e-6)), ("top", (-1, -1, 1 - 1e-6), (2, 2, 2)),
                ("xmin", (-1e-6, -1, -1), (1e-6, 2, 2)), ("ymin", (-1, -1e-6, -1), (2, 1e-6, 2))],
                start=2):
            faces = [t for _, t in gmsh.model.getEntitiesInBoundingBox(*box_min, *box_max, 2)]
            gmsh.model.addPhysicalGroup(2, faces, tag)
            gmsh.model.setPhysicalName(2, tag, name)
        gmsh.model.mesh.generate(3)
        path.parent.mkdir(parents=True, exist_ok=True)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    paths = [a for a in sys.argv[1:] if a != "--tetrahedra"]
    block(Path(paths[0]) if paths else OUT, tetrahedra="--tetrahedra" in sys.argv[1:])
