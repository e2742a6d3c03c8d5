"""Chapter VIII: run studies/chapter8.toml and write its tables (and figure list) into the README.

Runs `soilbin study studies/chapter8.toml` (resumable), then reads each case's
summary.json and curve.csv and prints, or with --readme writes between the
chapter8 markers:
- per case: the travel at 36, 72 and 108 lb of draft, the lift at the last
  step, the McKyes & Ali estimate, Newton iterations and wall time;
- the volume-change table of chapter VIII: the incremental volumetric strain
  (x 10^3, negative in compression) of the soil element in front of the
  embedded 2-in vertical tool with the interface, per 12-lb load step, small
  against large deformation.
Loads and travel in lb and in; the dissertation's figures 8.2-8.9 are the
study's figure-8.*.png, figures 8.10-8.12 each case's sections-*.png.
"""
import argparse
import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
STUDY = ROOT / "studies" / "chapter8.toml"
SOILBIN = Path(sys.executable).with_name("soilbin")
MARKERS = re.compile(r"(<!-- chapter8:start -->\n).*?(<!-- chapter8:end -->)", re.S)
LOADS = (36.0, 72.0, 108.0)
KEYS = ("mesh.configuration", "mesh.tool_width", "mesh.rake_angle", "tool.bonded",
        "analysis.large_deformation")


def cases(folder):
    """(overrides dict, summary, curve rows) of every case that has a summary."""
    for summary_file in sorted(folder.glob("*/summary.json")):
        summary = json.loads(summary_file.read_text())
        values = dict(item.split("=", 1) for item in summary["overrides"])
        with open(summary_file.parent / "curve.csv") as f:
            rows = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
        yield {k: values[k].strip('"') for k in KEYS}, summary, rows


def travel_at(rows, load):
    row = next((r for r in rows if abs(r["force"] - load) < 1e-6 * load), None)
    return f"{row['displacement']:.4g}" if row else "–"


def case_table(results):
    lines = ["| tool | interface | deformation | travel at 36 / 72 / 108 lb [in] | lift at the "
             "last step [lb] | estimate [lb] | status | Newton | wall (s) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for values, summary, rows in results:
        tool = (f"{values['mesh.tool_width']}-in, {values['mesh.rake_angle']}°, "
                f"{values['mesh.configuration'].replace('_', ' ')}")
        estimate = summary.get("draft_estimate")
        lines.append(" | ".join([
            f"| {tool}", "no" if values["tool.bonded"] == "true" else "yes",
            "large" if values["analysis.large_deformation"] == "true" else "small",
            " / ".join(travel_at(rows, load) for load in LOADS),
            f"{rows[-1]['lift']:.3g}" if rows else "–",
            f"{estimate['draft']:.3g}" if estimate else "–", summary["status"],
            str(summary["newton_iterations"]), f"{summary['wall_s']:.0f} |"]))
    return "\n".join(lines)


def volume_change_table(results):
    """Increments of the front element's volumetric strain per 12-lb step, x 10^3."""
    picked = {values["analysis.large_deformation"]: rows for values, _, rows in results
              if values["mesh.configuration"] == "embedded" and values["mesh.tool_width"] == "2"
              and values["mesh.rake_angle"] == "90" and values["tool.bonded"] == "false"}
    lines = ["| load [lb] | small deformation | large deformation |", "| --- | --- | --- |"]
    for k in range(7):
        load = 12.0 * (k + 1)
        cells = []
        for large in ("false", "true"):
            rows = picked.get(large, [])
            if len(rows) > k:
                before = rows[k - 1]["front_volumetric_strain"] if k else 0.0
                cells.append(f"{1e3 * (rows[k]['front_volumetric_strain'] - before):.3g}")
            else:
                cells.append("–")
        lines.append(f"| {load:g} | {cells[0]} | {cells[1]} |")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "chapter8")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--readme", type=Path, help="write the tables into this file")
    args = parser.parse_args()
    subprocess.run([SOILBIN, "study", STUDY, "--out", args.out, "--jobs", str(args.jobs)],
                   cwd=ROOT, env={**os.environ, "OMP_NUM_THREADS": "1"})
    results = list(cases(args.out))
    text = (case_table(results) + "\n\nVolume change of the soil element in front of the embedded "
            "2-in vertical tool with the interface: incremental volumetric strain × 10³ per 12-lb "
            "step (negative in compression; dissertation: small −0.54, −1.53, −1.31, −1.19, −2.70, "
            "−3.03, −3.18; large −0.57, −1.47, −1.98, −2.88, −2.58, −4.87, −3.34):\n\n"
            + volume_change_table(results) + "\n")
    print(text)
    if args.readme:
        readme = args.readme.read_text()
        if not MARKERS.search(readme):
            sys.exit(f"{args.readme}: no chapter8 markers")
        args.readme.write_text(MARKERS.sub(lambda m: m[1] + text + m[2], readme))


if __name__ == "__main__":
    main()
