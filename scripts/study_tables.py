"""What the scripts that write a study's tables into the documentation share: their
command line, the study run and the finished cases' results."""
import argparse
import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from doc_tables import FIGURES, ROOT, add_page_argument

SOILBIN = Path(sys.executable).with_name("soilbin")


def arguments(doc, name, page, studies=()):
    """--out (default runs/NAME), --jobs, --page (default docs/PAGE), --figures (default
    docs/figures), --no-run; with ``studies``, --study (one of them, default NAME), and
    --out defaults to runs/STUDY."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--out", type=Path)
    if studies:
        parser.add_argument("--study", choices=studies, default=name,
                            help=f"the study to run and tabulate (default {name})")
    parser.add_argument("--jobs", type=int, default=1)
    add_page_argument(parser, page)
    parser.add_argument("--figures", type=Path, default=FIGURES,
                        help="copy the page's figures into this folder (default docs/figures)")
    parser.add_argument("--no-run", action="store_true",
                        help="only the tables, from the cases finished so far")
    args = parser.parse_args()
    args.out = args.out or ROOT / "runs" / getattr(args, "study", name)
    return args


def run_study(study, args, out=None):
    """`soilbin study` into ``out`` (default: --out; resumable), unless --no-run."""
    if not args.no_run:
        subprocess.run([SOILBIN, "study", study, "--out", out or args.out, "--jobs", str(args.jobs)],
                       cwd=ROOT, env={**os.environ, "OMP_NUM_THREADS": "1"})


def finished(study, folder, interrupted=False):
    """(case, summary, curve rows) of every case of the study, in its order, that left the
    summary of a run in its folder (of this code or an earlier one: the study itself decides
    what to run again), unless the run was interrupted and ``interrupted`` is false."""
    for case in study.cases:
        run = folder / case.name
        try:
            summary = json.loads((run / "summary.json").read_text())
        except OSError:
            continue
        if summary["status"] == "interrupted" and not interrupted:
            continue
        with open(run / "curve.csv") as f:
            rows = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
        yield case, summary, rows


def at(rows, column, displacement, slack=1e-9):
    """A curve.csv column at this displacement (a step ends there), or None if the curve
    stops more than ``slack`` of it short."""
    reached = [r["displacement"] for r in rows]
    if not reached or reached[-1] < displacement * (1.0 - slack):
        return None
    return float(np.interp(displacement, reached, [r[column] for r in rows]))


def travel_at(rows, load):
    """The travel at this draft (force control), interpolated along the curve; None past
    its end."""
    forces = [r["force"] for r in rows]
    if not forces or forces[-1] < load * (1.0 - 1e-9):
        return None
    return float(np.interp(load, forces, [r["displacement"] for r in rows]))


def remeshes(folder):
    """The rows of a run's remeshes.csv, as numbers (none if it never remeshed)."""
    try:
        with open(folder / "remeshes.csv") as f:
            return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    except OSError:
        return []
