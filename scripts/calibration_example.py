"""The calibration example: the section VII.5 soil "measured" on the appendix C paths,
fitted by `soilbin calibrate`, and the fitted material run in the default tine scene.

1. The laboratory curves (examples/calibration-vii5/*.csv) are the material-point
   driver's along each path at the VII.5 parameters of the modified cap, with Gaussian
   noise of 1% of each compared column's range (seed SEED).
2. `soilbin calibrate examples/calibration-vii5/vii5.toml` fits E, A, beta, R, W, D
   (nu and B fixed, C tied to A) into runs/calibrate-vii5, with the machine's cores, and again with
   one process into runs/calibrate-vii5-serial: the fit's wall time both ways. The fitted
   material.toml is copied to examples/calibration-vii5/fitted.toml.
3. `soilbin study studies/calibrated-tine.toml` runs the default scene (force control to
   108 lb) with the VII.5 parameters and with the fitted material.
4. The calibration-example table of docs/user-guide.md (--page): each parameter true,
   fitted and its standard error; then the tool travel at 36, 72 and 108 lb of both
   materials; the calibration table of docs/performance.md: the fit's cost and error.
   The fit figures go to docs/figures (--figures). Stresses in psi, loads in lb, travel
   in in.
"""
import json
import os
import shutil
import subprocess

import numpy as np

from soilbin.app.study import load_study
from soilbin.calibration.synthetic import laboratory_csv
from soilbin.material_point.driver import build_model, build_path
from soilbin.models.cap import SECTION_VII5
from doc_tables import DOCS, ROOT, write_between_markers
from study_tables import SOILBIN, arguments, finished, run_study

EXAMPLE = ROOT / "examples" / "calibration-vii5"
STUDY = ROOT / "studies" / "calibrated-tine.toml"
FIT_OUT = ROOT / "runs" / "calibrate-vii5"
#: The fit's material.toml, shipped: studies/calibrated-tine.toml reads it.
FITTED = EXAMPLE / "fitted.toml"
SEED = 31
NOISE = 0.01
#: data file: (path, its keys, x, compared columns). Every test starts from a seating
#: pressure of 1 psi; the triaxial and simple-shear tests unload (their elastic slope).
TESTS = {
    "hydrostatic": ("hydrostatic", {"pressure": 30.0}, "p", ("eps_v",)),
    "ctc2": ("triaxial-compression", {"confining": 2.0, "unload": True}, "eps_axial", ("q", "eps_v")),
    "ctc10": ("triaxial-compression", {"confining": 10.0, "unload": True}, "eps_axial", ("q", "eps_v")),
    "ctc20": ("triaxial-compression", {"confining": 20.0, "unload": True}, "eps_axial", ("q", "eps_v")),
    "simple-shear": ("simple-shear", {"confining": 10.0, "unload": True}, "gamma", ("tau", "eps_v")),
}
COMMON = {"p_initial": 1.0, "steps": 10}
#: The legs a laboratory records: not the initial state nor the confining leg.
RECORDED = ("load", "shear", "unload")
PARAMETERS = ("E", "A", "C", "beta", "R", "W", "D")   # fitted, or tied to one fitted
LOADS = (36.0, 72.0, 108.0)


def write_data():
    """The noisy curves, one CSV per test with its leg column; strains from the start of
    shearing but in the hydrostatic test (as vii5.toml's strains_from says)."""
    rng = np.random.default_rng(SEED)
    model = build_model("modified_cap", dict(SECTION_VII5))
    for name, (path, keys, x, y) in TESTS.items():
        text = laboratory_csv(model, build_path(path, {**COMMON, **keys}), path, x, y,
                              RECORDED, rng, NOISE, leg_column=True,
                              strains_from="" if path == "hydrostatic" else "shear")
        (EXAMPLE / f"{name}.csv").write_text(text)


def calibrate(out, jobs):
    """`soilbin calibrate` of the example into ``out`` with ``jobs`` processes; its summary."""
    subprocess.run([SOILBIN, "calibrate", EXAMPLE / "vii5.toml", "--out", out, "--jobs",
                    str(jobs), "--json"], cwd=ROOT, check=False, capture_output=True,
                   env={**os.environ, "OMP_NUM_THREADS": "1"})
    return json.loads((out / "summary.json").read_text())


def parameter_table(summary):
    lines = ["| parameter | section VII.5 | fitted | standard error | fitted / true − 1 |",
             "|---|---:|---:|---:|---:|"]
    for name in PARAMETERS:
        true, fitted = SECTION_VII5[name], summary["parameters"][name]
        if name in summary["tied"]:
            se = f"tied to {summary['tied'][name]}"
        else:
            se = summary["standard_errors"][name]
            se = "unidentified" if se is None else f"{se:.2g}"
        lines.append(f"| {name} | {true:g} | {fitted:.4g} | {se} | "
                     f"{100 * (fitted / true - 1):+.2f}% |")
    lines += ["", f"Fit: {summary['status']}, {summary['evaluations']} evaluations of the five "
              f"curves, {summary['wall_s']:.0f} s with {summary['jobs']} processes; scaled rms "
              f"{summary['rms']['overall']:.4f} (the noise is 0.01)."]
    return lines


def travel_at(rows, load):
    forces = [r["force"] for r in rows]
    return float(np.interp(load, forces, [r["displacement"] for r in rows])) \
        if forces and forces[-1] >= load * (1 - 1e-9) else None


def tine_table(results):
    """Travel at each load of the VII.5 material and the fitted one."""
    travels = {case.label: [travel_at(rows, load) for load in LOADS]
               for case, _, rows in results}
    reference = travels.get("section VII.5 parameters")
    lines = ["| material | " + " | ".join(f"travel at {load:g} lb [in]" for load in LOADS) + " |",
             "|---|" + "---:|" * len(LOADS)]
    for label, values in travels.items():
        cells = []
        for value, ref in zip(values, reference or [None] * len(LOADS)):
            cell = "–" if value is None else f"{value:.4f}"
            if value is not None and ref is not None and label != "section VII.5 parameters":
                cell += f" ({100 * (value / ref - 1):+.2f}%)"
            cells.append(cell)
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return lines


def errors(summary):
    """(largest |fitted / true - 1|, largest |fitted - true| / standard error)."""
    fitted = summary["parameters"]
    relative = max(abs(fitted[k] / SECTION_VII5[k] - 1) for k in PARAMETERS)
    standard = max(abs(fitted[k] - SECTION_VII5[k]) / summary["standard_errors"][k]
                   for k in summary["fitted"] if summary["standard_errors"][k])
    return relative, standard


def cost_table(fits):
    """The fit's cost with each number of processes, and its error."""
    lines = ["| fit | curves | values compared | processes | evaluations | wall time [s] | largest error | largest error / standard error |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for summary in fits:
        relative, standard = errors(summary)
        points = sum(1 for _ in open(FIT_OUT / "fit.csv")) - 1
        lines.append(f"| modified cap, {', '.join(summary['fitted'])} (VII.5 example) | {len(TESTS)} | "
                     f"{points} | {summary['jobs']} | {summary['evaluations']} | "
                     f"{summary['wall_s']:.0f} | {100 * relative:.1f}% | {standard:.1f} |")
    return lines


def main():
    args = arguments(__doc__, "calibrated-tine", "user-guide.md")
    serial_out = FIT_OUT.with_name(FIT_OUT.name + "-serial")
    if not args.no_run:
        write_data()
        calibrate(FIT_OUT, os.cpu_count() or 1)
        shutil.copy(FIT_OUT / "material.toml", FITTED)
        calibrate(serial_out, 1)
        run_study(STUDY, args)
    fits = [json.loads((out / "summary.json").read_text()) for out in (serial_out, FIT_OUT)]
    results = list(finished(load_study(STUDY), args.out))
    lines = parameter_table(fits[1]) + [""] + tine_table(results)
    write_between_markers(args.page, "calibration-example", "\n".join(lines) + "\n")
    write_between_markers(DOCS / "performance.md", "calibration", "\n".join(cost_table(fits)) + "\n")
    for name in ("ctc10", "hydrostatic"):
        shutil.copy(FIT_OUT / f"fit-{name}.png", args.figures / f"calibration-{name}.png")
    print("\n".join(lines + [""] + cost_table(fits)))


if __name__ == "__main__":
    main()
