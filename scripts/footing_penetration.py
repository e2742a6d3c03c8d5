"""The rough strip footing pushed half its width into Tresca soil in large deformation with
remeshing, against the mesh: studies/footing-penetration.toml, its tables in
docs/verification.md.

Runs `soilbin study studies/footing-penetration.toml` (resumable), then reads each case's
summary.json, curve.csv and remeshes.csv and writes between the footing-penetration markers
of docs/verification.md (--page): per edge size, the bearing pressure and q/c at
settlements of 0.05, 0.125, 0.25 and 0.5 B against the finest mesh's, and the cost (cells,
remeshes, steps, Newton iterations, CPU time, the seconds of a remesh and of a Newton
iteration) with what the remeshes changed (largest residual after the transfer, volume and
plastic-strain changes, force drop). Copies the study's figure into docs/figures.
Pressures in psi, lengths in in.
"""
import csv
import shutil

import numpy as np

from soilbin.app.study import Outcome, draw_figures, load_study
from soilbin.records.scene import load_scene
from doc_tables import ROOT, write_between_markers
from study_tables import arguments, finished, run_study

SIZE = "mesh.edge_size"
FRACTIONS = (0.05, 0.125, 0.25, 0.5)   # settlement / B


def at(rows, settlement):
    """The pressure at this settlement (a step ends there), or None if not reached."""
    settlements = [r["displacement"] for r in rows]
    if settlements[-1] < settlement * (1.0 - 1e-9):
        return None
    return float(np.interp(settlement, settlements, [r["pressure"] for r in rows]))


def remeshes(folder):
    path = folder / "remeshes.csv"
    if not path.exists():
        return []
    with open(path) as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


def tables(results, out, width, c):
    results = sorted(results, key=lambda r: -r[0].values[SIZE])
    finest = results[-1][2]
    reference = {f: at(finest, f * width) for f in FRACTIONS}
    heads = " | ".join(f"d/B = {f:g}: q [psi], q/c, vs finest" for f in FRACTIONS)
    pressure = [f"| edge size [in] | cells at the start | {heads} |",
                "| --- | --- |" + " --- |" * len(FRACTIONS)]
    cost = ["| edge size [in] | remeshes | steps (cut) | Newton | CPU [s] | a remesh [s] | "
            "a Newton iteration [s] | largest residual after transfer | largest volume change | "
            "largest plastic-strain change | largest force drop |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for case, summary, rows in results:
        size = case.values[SIZE]
        cells = []
        for f in FRACTIONS:
            q = at(rows, f * width)
            vs = ("finest" if rows is finest else "–" if q is None or reference[f] is None
                  else f"{100 * (q / reference[f] - 1):+.1f}%")
            cells.append("–" if q is None else f"{q:.2f}, {q / c:.3f}, {vs}")
        done = remeshes(out / case.name)
        start = int(done[0]["cells_before"]) if done else summary["n_cells"]
        pressure.append(f"| {size:g} | {start} | " + " | ".join(cells) + " |")
        remesh_s = sum(r["wall_s"] for r in done)
        newton = summary["newton_iterations"] + summary["failed_newton_iterations"]
        per_iteration = (summary["wall_s"] - remesh_s) / max(newton, 1)
        worst = lambda key: max((abs(r[key]) for r in done), default=0.0)
        drop = max((1.0 - r["force_after"] / r["force_before"] for r in done), default=0.0)
        cost.append(f"| {size:g} | {len(done)} | {summary['n_steps']} ({summary['cuts']}) | "
                    f"{summary['newton_iterations']} | {summary['cpu_s']:.0f} | "
                    f"{remesh_s / max(len(done), 1):.2f} | {per_iteration:.3f} | "
                    f"{worst('residual_transferred'):.3f} | {worst('volume_change'):.1e} | "
                    f"{worst('plastic_strain_change'):.3f} | {100 * drop:.1f}% |")
    return "\n".join(pressure) + "\n\n" + "\n".join(cost) + "\n"


def main():
    args = arguments(__doc__, "footing-penetration", "verification.md")
    path = ROOT / "studies" / "footing-penetration.toml"
    run_study(path, args)
    study = load_study(path)
    results = [r for r in finished(study, args.out) if r[1]["status"] == "complete"]
    if not results:
        raise SystemExit(f"{args.out}: no finished case")
    scene = load_scene(study.scene_path)
    text = tables(results, args.out, scene.mesh.footing_width,
                  scene.materials[scene.regions["soil"]].c)
    print(text)
    draw_figures(study, [Outcome(case, summary["status"], summary, ran=False)
                         for case, summary, _ in results], args.out)
    shutil.copy(args.out / "footing-penetration.png", args.figures / "footing-penetration.png")
    write_between_markers(args.page, "footing-penetration", text)


if __name__ == "__main__":
    main()
