"""A 3D picture of a tool run: the deformed soil coloured by the equivalent plastic strain,
with the tool drawn, made off screen with pyvista (EGL or OSMesa; no X server).

VTK runs in its own process (``python -m soilbin.app.figures_3d DATA.npz OUT.png LENGTH
TO_SCALE``): in the process that has loaded DOLFINx, VTK's C++ runtime clashes with it
(std::regex aborts), and a crash of the renderer must not end a run. A picture that cannot
be drawn is a warning, not a failed run.
"""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

#: Largest displacement drawn, as a fraction of the mesh's extent (the scale is printed).
DRAWN_DISPLACEMENT = 0.03
#: Equivalent plastic strain above which a cell is drawn as yielded soil (a tenth of the
#: largest where that is smaller).
YIELDED = 0.01
#: pyvista's cell of a soil cell and of a tool face, by their number of nodes.
SOLIDS = {8: "HEXAHEDRON", 4: "TETRA"}
FACES = {4: "QUAD", 3: "TRIANGLE"}


def drawn_scale(points, u, to_scale):
    """The factor the displacements ``u`` are drawn with on the mesh ``points``: 1 (the
    deformed soil as it is) if ``to_scale`` (large deformation, where the displacement is
    the soil's motion: the heave, the furrow), else the largest drawn as
    :data:`DRAWN_DISPLACEMENT` of the mesh's extent (small strain)."""
    largest = np.abs(u).max()
    if to_scale or largest == 0:
        return 1.0
    return DRAWN_DISPLACEMENT * np.ptp(points, axis=0).max() / largest


def soil_3d_png(soil, tool, length, path, to_scale=False):
    """``soil``: (points, hexahedra or tetrahedra, point data, cell data) of the last frame
    (displacement on the nodes, plastic_strain on the cells); ``tool``: (points,
    quadrilaterals or triangles, its displacement (3,)); drawn on the initial mesh warped by
    the factor of :func:`drawn_scale` (stated in the picture); ``length``: the coordinates'
    unit."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")   # skip X
    import pyvista as pv
    points, cells, point_data, cell_data = soil
    u = point_data["displacement"]
    scale = drawn_scale(points, u, to_scale)
    grid = pv.UnstructuredGrid({getattr(pv.CellType, SOLIDS[cells.shape[1]]): cells}, points)
    grid.point_data["displacement"] = u
    strain = cell_data["plastic_strain"]
    grid.cell_data["plastic_strain"] = strain
    soil = grid.warp_by_vector("displacement", factor=scale)
    plotter = pv.Plotter(off_screen=True, window_size=(1000, 650))
    plotter.add_mesh(soil.extract_surface(algorithm="dataset_surface"), color="lightgray",
                     opacity=0.2)
    drawn = min(YIELDED, strain.max() / 10)
    yielded = soil.threshold(drawn, scalars="plastic_strain") if drawn > 0 else None
    if yielded is not None and yielded.n_cells:
        plotter.add_mesh(yielded, scalars="plastic_strain", cmap="viridis", log_scale=True,
                         clim=(drawn, strain.max()), show_edges=True, edge_color="dimgray",
                         scalar_bar_args={"title": "plastic strain", "vertical": True,
                                          "position_x": 0.88, "position_y": 0.2, "fmt": "%.2g",
                                          "title_font_size": 16, "label_font_size": 14})
    tool_points, faces, tool_u = tool
    plotter.add_mesh(pv.UnstructuredGrid({getattr(pv.CellType, FACES[faces.shape[1]]): faces},
                                         tool_points + scale * tool_u),
                     color="firebrick", show_edges=True, label="tool")
    plotter.show_bounds(xtitle=f"x (travel) [{length}]", ytitle=f"y [{length}]",
                        ztitle=f"z [{length}]", font_size=9, location="outer")
    drawing = "drawn to scale" if to_scale else f"drawn x{scale:.3g}"
    plotter.add_text(f"soil that yielded (equivalent plastic strain >= {drawn:.2g}), the rest grey; "
                     f"displacements {drawing}; tool in red", font_size=9)
    plotter.view_vector((0.5, -1.0, 0.6))
    plotter.camera.zoom(1.3)
    plotter.screenshot(str(path))
    plotter.close()


def draw_in_subprocess(soil, tool, length, path, to_scale=False):
    """Draw :func:`soil_3d_png` in a child process; returns '' or why it was not drawn."""
    path = Path(path)
    data = path.with_suffix(".npz")
    (points, cells, point_data, cell_data), (tool_points, quads, tool_u) = soil, tool
    np.savez(data, points=points, cells=cells, displacement=point_data["displacement"],
             plastic_strain=cell_data["plastic_strain"], tool_points=tool_points, quads=quads,
             tool_u=tool_u)
    try:
        done = subprocess.run([sys.executable, "-m", __name__, str(data), str(path), length,
                               str(int(to_scale))],
                              capture_output=True, text=True, timeout=300)
    except (OSError, subprocess.TimeoutExpired) as err:
        return str(err)
    finally:
        data.unlink(missing_ok=True)
    lines = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])
    return "" if done.returncode == 0 and path.is_file() else lines[-1]


def _main(data, path, length, to_scale):
    d = np.load(data)
    soil_3d_png((d["points"], d["cells"], {"displacement": d["displacement"]},
                 {"plastic_strain": d["plastic_strain"]}),
                (d["tool_points"], d["quads"], d["tool_u"]), length, path, to_scale == "1")


if __name__ == "__main__":
    _main(*sys.argv[1:5])
