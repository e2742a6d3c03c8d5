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
docs/figures (--figures DIR). Between the tine-cad-blade markers of docs/chapter8.md (beside
--page) it compares the flat blade's travel at those drafts with the built-in hexahedral
blade's, `soilbin run tine-2in-108lb` (`make run`; run into runs/tine-2in-108lb if that
folder has no curve). Loads in lb, lengths in in.
"""
import csv
import shutil
import subprocess

import meshio
import numpy as np

from soilbin.app.study import Outcome, draw_figures, load_study
from doc_tables import ROOT, write_between_markers
from study_tables import SOILBIN, arguments, finished, run_study

STUDY = ROOT / "studies" / "tool-shapes.toml"
HEX_BLADE = ROOT / "runs" / "tine-2in-108lb"
LOADS = (36.0, 72.0, 108.0)
#: The equivalent plastic strain above which a cell counts as disturbed.
DISTURBED = 0.01


def travel_at(rows, load):
    """The travel at this draft, interpolated along the curve; None past its end."""
    forces = [r["force"] for r in rows]
    if not forces or forces[-1] < load * (1.0 - 1e-9):
        return None
    return float(np.interp(load, forces, [r["displacement"] for r in rows]))


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


def blade_table(results):
    """The flat blade's travel at each load against the built-in hexahedral blade's."""
    if not (HEX_BLADE / "summary.json").is_file():
        subprocess.run([SOILBIN, "run", "tine-2in-108lb", "--out", HEX_BLADE], cwd=ROOT, check=True)
    with open(HEX_BLADE / "curve.csv") as f:
        hexahedral = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    case, summary, rows = results[0]
    lines = [f"| draft [lb] | travel, `tine-2in-108lb` (soil_bin, hex8-bbar) [in] | travel, "
             f"{case.label} from STEP (tet10-bbar) [in] | difference |",
             "| --- | --- | --- | --- |"]
    for load in LOADS:
        ours, theirs = travel_at(rows, load), travel_at(hexahedral, load)
        difference = ("–" if None in (ours, theirs) else f"{100 * (ours / theirs - 1):+.1f}%")
        lines.append(f"| {load:g} | {shown(theirs, '.4g')} | {shown(ours, '.4g')} | {difference} |")
    return "\n".join(lines) + "\n"


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
    write_between_markers(args.page.parent / "chapter8.md", "tine-cad-blade", blade_table(results))


if __name__ == "__main__":
    main()
