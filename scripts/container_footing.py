"""VII.5: the container footing solved with every material of the scene, on one figure.

Runs `soilbin run scenes/container-footing.toml --set regions.soil=NAME` for
each [materials.NAME] of the scene (serial subprocesses), plots the
pressure-settlement curves on one PNG (copied into docs/figures, --figures)
and prints, and writes between the container markers of docs/verification.md
(--page), a table of the pressure at three settlements, stiffest first: the dissertation reports Drucker-Prager the
stiffest and the caps closest to the test.
"""
import argparse
import csv
import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from doc_tables import FIGURES, ROOT, add_page_argument, write_between_markers  # noqa: E402

SCENE = ROOT / "scenes" / "container-footing.toml"
SOILBIN = Path(sys.executable).with_name("soilbin")
#: The scene's materials in words, for the legend and the table.
MODEL_WORDS = {"drucker_prager": "Drucker–Prager", "modified_cap": "modified cap",
               "dimaggio_sandler": "DiMaggio–Sandler cap", "modified_cam_clay": "modified Cam-Clay",
               "cam_clay": "Cam-Clay"}


def run(material, out):
    proc = subprocess.run([SOILBIN, "run", SCENE, "--set", f"regions.soil={material}", "--out", out,
                           "--json"], capture_output=True, text=True, cwd=ROOT,
                          env={**os.environ, "OMP_NUM_THREADS": "1"})
    if proc.returncode not in (0, 1):
        sys.exit(f"{material}: {proc.stderr.strip()}")
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    with open(Path(out) / "curve.csv") as f:
        rows = [(float(r["displacement"]), float(r["pressure"])) for r in csv.DictReader(f)]
    return summary, rows


def pressure_at(rows, settlement):
    for (w0, p0), (w1, p1) in zip([(0.0, 0.0)] + rows, rows):
        if w0 <= settlement <= w1:
            return p0 + (p1 - p0) * (settlement - w0) / (w1 - w0)
    return float("nan")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "container-footing-models")
    add_page_argument(parser, "verification.md")
    parser.add_argument("--figures", type=Path, default=FIGURES,
                        help="copy the figure into this folder (default docs/figures)")
    args = parser.parse_args()
    materials = list(tomllib.loads(SCENE.read_text())["materials"])
    results = {m: run(m, args.out / m) for m in materials}

    fig, ax = plt.subplots(figsize=(6, 4.2))
    for material, (summary, rows) in results.items():
        ax.plot([0] + [w for w, _ in rows], [0] + [p for _, p in rows], "o-", ms=3,
                label=MODEL_WORDS.get(material, material)
                + ("" if summary["status"] == "complete" else f" ({summary['status']})"))
    ax.set_xlabel("footing settlement [in]")
    ax.set_ylabel("footing pressure [psi] (compression +)")
    ax.set_title("VII.5 strip footing in the container", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    args.out.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out / "container-footing.png", dpi=120)
    shutil.copy(args.out / "container-footing.png", args.figures / "container-footing.png")

    settlements = (0.05, 0.2, 0.4)
    order = sorted(results, key=lambda m: -pressure_at(results[m][1], settlements[-1]))
    head = ["model"] + [f"pressure at {w} in [psi]" for w in settlements] + ["Newton", "CPU (s)"]
    lines = [head, ["---"] * len(head)]
    for m in order:
        summary, rows = results[m]
        lines.append([MODEL_WORDS.get(m, m)] + [f"{pressure_at(rows, w):.3g}" for w in settlements]
                     + [summary["newton_iterations"], f"{summary['cpu_s']:.1f}"])
    text = "\n".join("| " + " | ".join(map(str, line)) + " |" for line in lines) + "\n"
    print(text)
    write_between_markers(args.page, "container", text)


if __name__ == "__main__":
    main()
