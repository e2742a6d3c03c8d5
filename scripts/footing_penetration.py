"""The rough strip footing pushed half its width into Tresca soil in large deformation with
remeshing, against the mesh: studies/footing-penetration.toml, its tables in
docs/verification.md.

Runs `soilbin study studies/footing-penetration.toml` (resumable), then reads each case's
summary.json, curve.csv and remeshes.csv and writes between the footing-penetration markers
of docs/verification.md (--page): per edge size, the bearing pressure and q/c at
settlements of 0.0175 (where the small-strain curve reaches its plateau), 0.05, 0.125,
0.25 and 0.5 B against the finest mesh's, and the cost (cells,
remeshes, steps, Newton iterations, CPU time, the seconds of a remesh and of a Newton
iteration) with what the remeshes changed (largest residual after the transfer, volume and
plastic-work changes, force drop). Copies the study's figure into docs/figures and draws
the finest case's soil at the end (footing-penetration-soil.png).
Pressures in psi, lengths in in.
"""
import shutil
from xml.etree import ElementTree

import h5py
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.colors import LogNorm

from soilbin.app.study import Outcome, draw_figures, load_study
from soilbin.records.scene import load_scene
from doc_tables import ROOT, write_between_markers
from study_tables import arguments, at, finished, remeshes, run_study

SIZE = "mesh.edge_size"
FRACTIONS = (0.0175, 0.05, 0.125, 0.25, 0.5)   # settlement / B; 0.035 in: the small-strain plateau


#: How far short of a settlement the curve may stop and still be read there: the settlement
#: read off the transferred displacement drifts by about 1e-8 in a remesh.
SLACK = 1e-5


def pressure_at(rows, settlement):
    return at(rows, "pressure", settlement, SLACK)


def tables(results, out, width, c):
    results = sorted(results, key=lambda r: -r[0].values[SIZE])
    finest = results[-1][2]
    reference = {f: pressure_at(finest, f * width) for f in FRACTIONS}
    heads = " | ".join(f"d/B = {f:g}: q [psi], q/c, vs finest" for f in FRACTIONS)
    pressure = [f"| edge size [in] | cells at the start | {heads} |",
                "| --- | --- |" + " --- |" * len(FRACTIONS)]
    cost = ["| edge size [in] | remeshes | steps (cut) | Newton | CPU [s] | a remesh [s] | "
            "a Newton iteration [s] | largest residual after transfer | largest volume change | "
            "largest plastic-work change | largest force drop |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for case, summary, rows in results:
        size = case.values[SIZE]
        cells = []
        for f in FRACTIONS:
            q = pressure_at(rows, f * width)
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
                    f"{worst('plastic_work_change'):.3f} | {100 * drop:.1f}% |")
    return "\n".join(pressure) + "\n\n" + "\n".join(cost) + "\n"


def last_frame(folder):
    """(points (n, 3) where the soil started, cells, displacement, plastic strain) of the last
    frame of a run folder's fields.xdmf (each grid names its own mesh file)."""
    grid = list(ElementTree.parse(folder / "fields.xdmf").getroot().iter("Grid"))[-1]

    def read(item):
        name, dataset = item.text.strip().split(":")
        with h5py.File(folder / name, "r") as f:
            return f[dataset][()]
    return (read(grid.find("Geometry/DataItem")), read(grid.find("Topology/DataItem")),
            read(grid.find("Attribute[@Name='displacement']/DataItem")),
            read(grid.find("Attribute[@Name='plastic_strain']/DataItem")))


def deformed_figure(folder, path, width):
    """The soil round the footing at the end: the deformed cells coloured by their equivalent
    plastic strain (log scale), the footing drawn."""
    points, cells, displacement, plastic = last_frame(folder)
    x = (points + displacement)[:, [0, 2]]
    figure, axes = plt.subplots(figsize=(7.5, 4.2))
    polygons = PolyCollection(x[cells], array=np.maximum(plastic, 1e-4), cmap="viridis",
                              norm=LogNorm(1e-3, max(plastic.max(), 1e-2)), edgecolors="0.3",
                              linewidths=0.2)
    axes.add_collection(polygons)
    settlement = -displacement[:, 2].min()
    axes.fill([0, width / 2, width / 2, 0], [-settlement, -settlement, 1.0, 1.0], color="0.55")
    axes.set_xlim(0.0, 4.0)
    axes.set_ylim(-3.0, 0.8)
    axes.set_aspect("equal")
    axes.set_xlabel("x [in]")
    axes.set_ylabel("z [in]")
    axes.set_title(f"Soil beside the footing at {settlement:.2g} in of settlement (B/2), "
                   "remeshed")
    figure.colorbar(polygons, ax=axes, label="equivalent plastic strain [-]", shrink=0.8)
    figure.tight_layout()
    figure.savefig(path, dpi=150)
    plt.close(figure)


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
    finest = min(results, key=lambda r: r[0].values[SIZE])[0]
    deformed_figure(args.out / finest.name, args.figures / "footing-penetration-soil.png",
                    scene.mesh.footing_width)
    write_between_markers(args.page, "footing-penetration", text)


if __name__ == "__main__":
    main()
