"""Write the tools of scenes/tools/ as STEP files, with gmsh's OpenCASCADE kernel, in
millimetres, drawn upright (z up, travel along +x, symmetric about y = 0):

- ``blade-2in.step``: the flat vertical blade of chapter VIII, 2 in wide, 0.5 in thick,
  8 in tall (6 in of it in the soil in scenes/tine-2in-cad.toml).

    python scripts/make_tools.py [FOLDER]
"""
import sys
from pathlib import Path

import gmsh

FOLDER = Path(__file__).resolve().parent.parent / "scenes" / "tools"
INCH = 25.4   # mm


def blade(occ):
    """The flat blade: a box 0.5 x 2 x 8 in, its bottom at z = 0."""
    return occ.addBox(0.0, -1.0 * INCH, 0.0, 0.5 * INCH, 2.0 * INCH, 8.0 * INCH)


TOOLS = {"blade-2in": blade}


def write(folder):
    folder.mkdir(parents=True, exist_ok=True)
    for name, shape in TOOLS.items():
        gmsh.initialize(readConfigFiles=False)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.model.add(name)
            shape(gmsh.model.occ)
            gmsh.model.occ.synchronize()
            gmsh.write(str(folder / f"{name}.step"))
        finally:
            gmsh.finalize()


if __name__ == "__main__":
    write(Path(sys.argv[1]) if len(sys.argv) > 1 else FOLDER)
