"""Compare tool shapes: studies/tool-shapes.toml, its table and figure in docs/user-guide.md.

Runs `soilbin study studies/tool-shapes.toml` (resumable), then reads each case's
summary.json, curve.csv and the last frame of fields.xdmf, and writes between the
tool-shapes markers of docs/user-guide.md (--page), per tool: cells, unknowns, the
mesh and set-up time, Newton iterations and steps, the wall time, the travel at 36, 72
and 108 lb of draft, where the run ended, and the soil it disturbed there: the volume
of the cells whose equivalent plastic strain passed DISTURBED and the largest rise of the
ground surface (both for the whole tool: an embedded half counted twice). In this
normally consolidated soil every cell the tool compresses reaches its cap, so "yielded"
alone would be most of the bin. Copies the study's tool-shapes.png into
docs/figures (--figures DIR). Loads in lb, lengths in in.
"""
import shutil

import meshio
import numpy as np

from soilbin.app.study import Outcome, draw_figures, load_study
from doc_tables import ROOT, write_between_markers
from study_tables import arguments, finished, run_study, travel_at

STUDY = ROOT / "studies" / "tool-shapes.toml"
LOADS = (36.0, 72.0, 108.0)
#: The equivalent plastic strain above which a cell counts as disturbed.
DISTURBED = 0.01


def disturbance(folder, share):
    """(volume of the disturbed cells, largest rise of the ground surface z = 0) at the
    last frame of fields.xdmf, for the whole tool (the mesh holds ``share`` of it)."""
    reader = meshio.xdmf.TimeSeriesReader(str(folder / "fields.xdmf"))
    points, cells = reader.read_points_cells()
    _, point_data, cell_data = reader.read_data(reader.num_steps - 1)
    corners = points[cells[0].data[:, :4]]
    edges = corners[:, 1:] - corners[:, :1]
    volume = np.abs(np.linalg.det(edges)) / 6.0
    disturbed = cell_data["plastic_strain"][0].ravel() > DISTURBED
    surface = np.isclose(points[:, 2], 0.0)
    heave = point_data["displacement"][surface, 2].max()
    return volume[disturbed].sum() / share, heave


def shown(value, form=".3g"):
    return "–" if value is None else f"{value:{form}}"


def table(results, folder):
    lines = ["| tool | cells | unknowns | mesh and set-up (s) | Newton (steps) | wall (s) | "
             f"travel at 36 / 72 / 108 lb [in] | end | soil strained plastically over "
             f"{DISTURBED:.0%} [in³] | "
             "largest heave [in] |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for case, summary, rows in results:
        volume, heave = disturbance(folder / case.name, case.scene.mesh.tool_share)
        travels = " / ".join(shown(travel_at(rows, load)) for load in LOADS)
        end = (f"{summary['status']} at {rows[-1]['force']:.3g} lb, "
               f"{rows[-1]['displacement']:.3g} in")
        lines.append(f"| {case.label} | {summary['n_cells']} | {summary['n_dofs']} | "
                     f"{summary['setup_s']:.1f} | {summary['newton_iterations']} "
                     f"({summary['n_steps']}) | {summary['wall_s']:.0f} | {travels} | {end} | "
                     f"{volume:.3g} | {heave:.3g} |")
    return "\n".join(lines)


def main():
    args = arguments(__doc__, "tool-shapes", "user-guide.md")
    run_study(STUDY, args)
    study = load_study(STUDY)
    results = list(finished(study, args.out))
    if not results:
        raise SystemExit(f"{args.out}: no finished case")
    text = table(results, args.out) + "\n"
    print(text)
    draw_figures(study, [Outcome(case, summary["status"], summary, ran=False)
                         for case, summary, _ in results], args.out)
    shutil.copy(args.out / "tool-shapes.png", args.figures / "tool-shapes.png")
    write_between_markers(args.page, "tool-shapes", text)


if __name__ == "__main__":
    main()
