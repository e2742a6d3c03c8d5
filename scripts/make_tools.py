"""Write the tools of scenes/tools/ as STEP files, with gmsh's OpenCASCADE kernel, in
millimetres, drawn upright: z up from the tool's lowest point, travel along +x, the
front of the shank at x = 0. Each is drawn in inches below and scaled on writing.

- ``blade-2in``: the flat vertical blade of chapter VIII, 2 in wide, 0.5 in thick,
  8 in tall (scenes/tine-2in-cad.toml puts 6 in of it in the soil).
- ``winged-chisel``: a shank 2 in long and 0.75 in thick on a chisel foot 1.5 in wide,
  with a pair of wings 6 in across pitched up 15° toward their rear edge.
- ``sweep``: a duckfoot: a V-shaped blade 10 in across, swept back at 55° from its point
  and pitched up 10°, under a shank 1.4 in long standing on the V's point.
- ``curved-tine``: a tine 2 in wide and 0.5 in thick whose lower 6 in follow a quarter
  circle of 6 in radius, vertical at the top and pointing forward at the tip.
- ``bent-leg``: a subsoiler leg 2 in long and 0.75 in thick, vertical for its lowest 3 in
  and bent sideways at 45° over the next 3 in, on a chisel foot: not symmetric about
  any plane y = const (configuration = "full").

The first four are symmetric about y = 0.

    python scripts/make_tools.py [FOLDER]
"""
import math
import sys
from pathlib import Path

import gmsh

FOLDER = Path(__file__).resolve().parent.parent / "scenes" / "tools"
INCH = 25.4   # mm
SHANK = (2.0, 0.75)   # in: the shank's length along the travel and its thickness


def shank(occ, bottom, top):
    """The straight shank from z = bottom to z = top, its front at x = 0."""
    length, thickness = SHANK
    return (3, occ.addBox(-length, -thickness / 2, bottom, length, thickness, top - bottom))


def plate(occ, outline, thickness, z, pitch, pivot):
    """A flat plate of this (x, y) outline and thickness on z, turned about the y axis
    through ``pivot`` (x) by ``pitch`` degrees, its rear edge up."""
    points = [occ.addPoint(x, y, z) for x, y in outline]
    lines = [occ.addLine(a, b) for a, b in zip(points, points[1:] + points[:1])]
    face = occ.addPlaneSurface([occ.addCurveLoop(lines)])
    solid = occ.extrude([(2, face)], 0.0, 0.0, thickness)
    volume = [d for d in solid if d[0] == 3]
    occ.rotate(volume, pivot, 0.0, z, 0.0, 1.0, 0.0, math.radians(pitch))
    return volume


def blade(occ):
    return [(3, occ.addBox(0.0, -1.0, 0.0, 0.5, 2.0, 8.0))]


def winged_chisel(occ):
    foot = (3, occ.addBox(-2.0, -0.75, 0.0, 3.0, 1.5, 0.5))
    wings = plate(occ, [(-0.5, 0.0), (-2.5, 3.0), (-3.2, 3.0), (-3.2, -3.0), (-2.5, -3.0)],
                  0.4, 0.5, 15.0, -0.5)
    return [foot, shank(occ, 0.5, 10.0), *wings]


def sweep(occ):
    wing = plate(occ, [(1.0, 0.0), (-2.5, 5.0), (-3.3, 5.0), (-0.9, 0.6), (-0.9, -0.6),
                       (-3.3, -5.0), (-2.5, -5.0)], 0.3, 0.0, 10.0, 1.0)
    root = (3, occ.addBox(-0.8, -SHANK[1] / 2, 0.1, 1.4, SHANK[1], 9.9))   # on the V's point
    return [*wing, root]


def curved_tine(occ):
    radius, thickness, width = 6.0, 0.5, 2.0
    outer = occ.addCylinder(radius, -width / 2, radius, 0.0, width, 0.0, radius + thickness)
    inner = occ.addCylinder(radius, -width / 2, radius, 0.0, width, 0.0, radius)
    ring, _ = occ.cut([(3, outer)], [(3, inner)])
    quadrant = occ.addBox(-thickness, -width, -thickness, radius + thickness, 2 * width,
                          radius + thickness)
    arc, _ = occ.intersect(ring, [(3, quadrant)])
    top = (3, occ.addBox(-thickness, -width / 2, radius, thickness, width, 6.0))
    return [*arc, top]


def bent_leg(occ):
    length, thickness = SHANK
    foot = (3, occ.addBox(-length, -0.75, 0.0, length + 1.0, 1.5, 0.5))
    legs, joint = [], (0.0, 0.5)
    for y, z in [(0.0, 3.0), (3.0 / math.sqrt(2), 3.0 + 3.0 / math.sqrt(2)),
                 (3.0 / math.sqrt(2), 10.0)]:
        dy, dz = y - joint[0], z - joint[1]
        leg = occ.addBox(-length, -thickness / 2, 0.0, length, thickness, math.hypot(dy, dz))
        occ.rotate([(3, leg)], 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -math.atan2(dy, dz))
        occ.translate([(3, leg)], 0.0, *joint)
        legs.append((3, leg))
        legs.append((3, occ.addCylinder(-length, y, z, length, 0.0, 0.0, thickness / 2)))
        joint = (y, z)
    return [foot, *legs[:-1]]


TOOLS = {"blade-2in": blade, "winged-chisel": winged_chisel, "sweep": sweep,
         "curved-tine": curved_tine, "bent-leg": bent_leg}


def write(folder):
    folder.mkdir(parents=True, exist_ok=True)
    for name, shape in TOOLS.items():
        gmsh.initialize(readConfigFiles=False)
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.model.add(name)
            occ = gmsh.model.occ
            parts = shape(occ)
            solid, _ = occ.fuse(parts[:1], parts[1:]) if len(parts) > 1 else (parts, None)
            occ.dilate(solid, 0.0, 0.0, 0.0, INCH, INCH, INCH)
            occ.synchronize()
            gmsh.write(str(folder / f"{name}.step"))
        finally:
            gmsh.finalize()


if __name__ == "__main__":
    write(Path(sys.argv[1]) if len(sys.argv) > 1 else FOLDER)
