"""What the README-table scripts of a study share: their command line, the study run,
the finished cases' results, and the text between a pair of README markers."""
import argparse
import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SOILBIN = Path(sys.executable).with_name("soilbin")


def arguments(doc, name):
    """--out (default runs/NAME), --jobs, --readme, --figures, --no-run."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / name)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--readme", type=Path, help="write the tables into this file")
    parser.add_argument("--figures", type=Path, help="copy the README's figures into this folder")
    parser.add_argument("--no-run", action="store_true",
                        help="only the tables, from the cases finished so far")
    return parser.parse_args()


def run_study(study, args, out=None):
    """`soilbin study` into ``out`` (default: --out; resumable), unless --no-run."""
    if not args.no_run:
        subprocess.run([SOILBIN, "study", study, "--out", out or args.out, "--jobs", str(args.jobs)],
                       cwd=ROOT, env={**os.environ, "OMP_NUM_THREADS": "1"})


def write_between_markers(readme, name, text):
    """Replace what lies between <!-- NAME:start --> and <!-- NAME:end --> in ``readme``."""
    markers = re.compile(rf"(<!-- {name}:start -->\n).*?(<!-- {name}:end -->)", re.S)
    content = readme.read_text()
    if not markers.search(content):
        sys.exit(f"{readme}: no {name} markers")
    readme.write_text(markers.sub(lambda m: m[1] + text + m[2], content))


def finished(study, folder):
    """(case, summary, curve rows) of every case of the study, in its order, that left the
    summary of a run that was not interrupted in its folder (of this code or an earlier
    one: the study itself decides what to run again)."""
    for case in study.cases:
        run = folder / case.name
        try:
            summary = json.loads((run / "summary.json").read_text())
        except OSError:
            continue
        if summary["status"] == "interrupted":
            continue
        with open(run / "curve.csv") as f:
            rows = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
        yield case, summary, rows
