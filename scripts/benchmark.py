"""Run time against error for the scenes with a closed-form answer.

Each case is one serial `soilbin run --json` subprocess; the error is taken
against the closed form evaluated from the resolved scene (run folder's scene.toml):

* strip footing and strip load (von Mises, plane strain): (2 + pi) c
* elastic column: top settlement p L / M, M = E (1 - nu) / ((1 + nu) (1 - 2 nu));
  in large deformation the pressure M ln(L / (L - w)) at the final settlement w
* Drucker-Prager block: uniaxial strength 2 c cos(phi) / (1 - sin(phi))
Small- and large-deformation runs of the same scene give the cost of the
updated Lagrangian option.

`--readme PATH` replaces the text between the benchmark markers in PATH.
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
import tomllib
from datetime import date
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SOILBIN = Path(sys.executable).with_name("soilbin")
FOOTING = "scenes/strip-footing-von-mises.toml"
COLUMN = "scenes/column-elastic.toml"
COLUMN_LARGE = "scenes/column-elastic-large.toml"
BLOCK = "scenes/block-drucker-prager.toml"
STRIP_LOAD = "scenes/strip-load-von-mises.toml"
MARKERS = re.compile(r"(<!-- benchmark:start -->\n).*?(<!-- benchmark:end -->)", re.S)


def footing_error(summary, scene):
    exact = (2 + math.pi) * scene["materials"]["clay"]["c"]
    return summary["limit_pressure"] / exact - 1


def strip_load_error(summary, scene):
    return summary["collapse_pressure"] / ((2 + math.pi) * scene["materials"]["clay"]["c"]) - 1


def block_error(summary, scene):
    soil = scene["materials"]["soil"]
    phi = math.radians(soil["phi"])
    return summary["collapse_stress"] / (2 * soil["c"] * math.cos(phi) / (1 - math.sin(phi))) - 1


def column_large_error(summary, scene):
    soil = scene["materials"]["soil"]
    E, nu, L = soil["E"], soil["nu"], scene["mesh"]["lz"]
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    return summary["pressure"] / (M * math.log(L / (L - summary["top_settlement"]))) - 1


def column_error(summary, scene):
    soil = scene["materials"]["soil"]
    E, nu = soil["E"], soil["nu"]
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    exact = scene["loading"]["magnitude"] * scene["mesh"]["lz"] / M
    return summary["top_settlement"] / exact - 1


def cases(quick):
    refines = (1, 2) if quick else (1, 2, 3, 4)
    for r in refines:
        yield f"strip footing, refine={r}", FOOTING, [f"mesh.refine={r}"], footing_error
    for r in (1,) if quick else (1, 2):  # hex27-bbar at refine=2 takes minutes
        yield (f"strip footing, refine={r}", FOOTING,
               [f"mesh.refine={r}", "analysis.element=hex27-bbar"], footing_error)
    yield "strip footing, refine=1", FOOTING, ["mesh.refine=1", "analysis.element=hex8"], footing_error
    for nz in (6, 24) if quick else (6, 24, 96):
        yield f"column, nz={nz}", COLUMN, [f"mesh.nz={nz}"], column_error
    yield "column, large deformation to w/L = 0.3", COLUMN_LARGE, [], column_large_error
    for large in ("false", "true"):
        kind = "large" if large == "true" else "small"
        yield f"block, {kind} deformation", BLOCK, [f"analysis.large_deformation={large}"], block_error
        yield (f"strip load to collapse, {kind} deformation", STRIP_LOAD,
               [f"analysis.large_deformation={large}"], strip_load_error)


def run_case(name, scene_file, sets, error):
    with tempfile.TemporaryDirectory() as out:
        cmd = [SOILBIN, "run", scene_file, "--out", out, "--json"]
        for s in sets:
            cmd += ["--set", s]
        start = time.perf_counter()
        proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True,
                              env={**os.environ, "OMP_NUM_THREADS": "1"})
        total = time.perf_counter() - start
        if proc.returncode not in (0, 1):  # 1: stopped short of the full load, summary still printed
            sys.exit(f"{name} {sets} failed:\n{proc.stderr}")
        summary = json.loads(proc.stdout.strip().splitlines()[-1])
        scene = tomllib.loads((Path(out) / "scene.toml").read_text())
    err = f"{100 * error(summary, scene):+.3g}" if summary["converged"] else summary["status"]
    if summary.get("status") == "collapse":   # force control: the last converged step
        err += " (collapse)"
    return [name, scene["analysis"]["element"], summary["n_cells"], summary["n_dofs"],
            summary["n_steps"], summary["newton_iterations"], f"{summary['wall_s']:.2f}",
            f"{total:.2f}", err]


def table(rows):
    head = ["case", "element", "cells", "dofs", "load steps", "Newton iterations",
            "wall (s)", "total (s)", "error (%)"]
    lines = [head, ["---"] * len(head), *rows]
    return "\n".join("| " + " | ".join(map(str, line)) + " |" for line in lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--readme", type=Path, help="write the table into this file")
    parser.add_argument("--quick", action="store_true", help="refine 1-2 (hex27-bbar: 1) and nz 6, 24 only")
    args = parser.parse_args()

    rows = []
    for case in cases(args.quick):
        rows.append(run_case(*case))
        print(" | ".join(map(str, rows[-1])), file=sys.stderr, flush=True)
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo")
                if line.startswith("model name")), "unknown CPU")
    command = " ".join(["OMP_NUM_THREADS=1 python", *sys.argv])
    text = (f"{table(rows)}\n\nwall = the run's own `wall_s` (meshing, setup and solve, without "
            f"Python start-up; includes form compilation if the FFCx cache is cold); total = "
            f"elapsed time of the whole `soilbin run` process.\n"
            f"Machine: nproc {len(os.sched_getaffinity(0))}, {cpu}, {date.today()}; "
            f"command: `{command}`\n")
    print(text)
    if args.readme:
        readme = args.readme.read_text()
        if not MARKERS.search(readme):
            sys.exit(f"{args.readme}: no benchmark markers")
        args.readme.write_text(MARKERS.sub(lambda m: m[1] + text + m[2], readme))


if __name__ == "__main__":
    main()
