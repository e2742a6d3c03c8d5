"""What ``soilbin calibrate`` writes: summary.json, material.toml, fit.csv, fit-TEST.png.
Every column is compression positive (the convention of ``soilbin point``'s path.csv)."""
import csv
import json
import re
import time
from pathlib import Path

import numpy as np

from ..app.outdir import writable_on_rank0
from ..launcher import mpi_world
from ..material_point.driver import CONVENTION
from ..plotting import pyplot
from ..records.toml_out import dumps
from . import fit as fitting
from .problem import read_calibration

#: Axis labels of path.csv's columns; STRESS marks those in stress units.
STRESS = "stress"
LABELS = {
    "eps_axial": ("axial strain", None), "eps_v": ("volumetric strain", None),
    "gamma": ("shear strain", None), "p": ("mean stress", STRESS),
    "q": ("deviatoric stress", STRESS), "sigma_axial": ("axial stress", STRESS),
    "sigma_lateral": ("lateral stress", STRESS), "tau": ("shear stress", STRESS),
    "sigma1": ("major principal stress", STRESS), "sigma2": ("intermediate principal stress", STRESS),
    "sigma3": ("minor principal stress", STRESS),
}


def axis_label(column, stress_unit):
    words, kind = LABELS[column]
    return f"{words} {column} [{stress_unit if kind == STRESS else '-'}]"


def material_name(calibration):
    return re.sub(r"\W", "_", calibration.file.stem) or "calibrated"


def summarize(calibration, result):
    """The summary: status, parameters, their standard errors and correlation, rms."""
    names = calibration.fitted
    variance = fitting.residual_variance(result.residuals, len(names))
    cov, identified = fitting.covariance(result.jacobian, variance)
    corr = fitting.correlation(cov)
    errors = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return {
        "status": "converged" if result.converged else "not converged",
        "message": result.message,
        "model": calibration.model_name,
        "material": material_name(calibration),
        "parameters": calibration.table(result.values),
        "fitted": list(names),
        "tied": dict(calibration.tied),
        "standard_errors": {n: (float(e) if ok else None)
                            for n, e, ok in zip(names, errors, identified)},
        "correlation": {n: {m: round(float(corr[i, j]), 6) for j, m in enumerate(names)}
                        for i, n in enumerate(names)},
        "unidentified": fitting.unidentified(names, identified, corr),
        "rms": {"overall": fitting.rms(result.residuals),
                **fitting.rms_per_test(calibration, result.residuals)},
        "residual_variance": variance,
        "nfev": result.nfev,
        "njev": result.njev,
        "evaluations": result.evaluations,
        "wall_s": round(result.wall_s, 3),
        "jobs": result.jobs,
        "convention": CONVENTION,
        "residual_scale": "each compared column divided by its measured range, times the "
                          "test's weight",
    }


def write_material(calibration, values, path):
    table = {"model": calibration.model_name, **calibration.table(values)}
    path.write_text(f"# {calibration.file.name}: fitted by soilbin calibrate\n"
                    + dumps({"materials": {material_name(calibration): table}}))


def fitted_rows(calibration, values):
    """(test, measured (n, k), model curve or None, fitted (n, k) or None) of every test at
    the fitted ``values``: the paths driven once."""
    for test, curve in zip(calibration.tests, fitting.trial_curves(values, calibration)):
        try:
            fitted = fitting.at_measured(test, curve)
        except fitting.CurveFailed:   # the driver fails at the optimum: nothing to show
            fitted = None
        yield (test, fitting.measured_columns(test),
               None if isinstance(curve, fitting.CurveFailed) else curve, fitted)


def write_fit_csv(rows, path):
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["test", "leg", "x_column", "x", "column", "measured", "fitted"])
        for test, measured, _, fitted in rows:
            x = test.measured[test.x]
            for j, column in enumerate(test.y):
                model = fitted[:, j] if fitted is not None else np.full(x.size, np.nan)
                writer.writerows([test.name, leg, test.x, f"{a:.12g}", column, f"{b:.12g}",
                                  f"{c:.12g}"]
                                 for leg, a, b, c in zip(test.legs, x, measured[:, j], model))


def plot_test(calibration, test, measured, curve, path):
    """One panel per compared column: the measured points and the fitted model curve."""
    plt = pyplot()
    fig, axes = plt.subplots(1, len(test.y), figsize=(4.5 * len(test.y), 3.8), squeeze=False)
    for j, (ax, column) in enumerate(zip(axes[0], test.y)):
        ax.plot(test.measured[test.x], measured[:, j], "o", ms=3, label="measured")
        if curve is not None:
            for leg in np.unique(test.legs):
                x, columns = curve.leg(leg)
                ax.plot(x, columns[:, j], "-", color="C1",
                        label="fitted model" if leg == test.legs[0] else None)
        ax.set_xlabel(axis_label(test.x, calibration.stress_unit))
        ax.set_ylabel(axis_label(column, calibration.stress_unit))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    title = test.name if test.name == test.path_name else f"{test.name}: {test.path_name}"
    fig.suptitle(f"{title} (compression positive)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def calibrate(file, out=None, jobs=1):
    """Read, fit (the Jacobian by ``jobs`` processes, or by the MPI ranks) and write ``out``
    (default runs/calibrate-<stem>; rank 0 writes); returns the summary."""
    start = time.perf_counter()
    calibration = read_calibration(file)
    fitting.check_start(calibration)
    out = Path(out or Path("runs") / f"calibrate-{calibration.file.stem}")
    comm = mpi_world()
    writer = comm is None or comm.rank == 0
    writable_on_rank0(comm, out)
    result = fitting.fit(calibration, jobs)
    summary = summarize(calibration, result)
    summary["files"] = (["summary.json", "material.toml", "fit.csv"]
                        + [f"fit-{t.name}.png" for t in calibration.tests])
    summary["out"] = str(out)
    if writer:
        rows = list(fitted_rows(calibration, result.values))
        write_material(calibration, result.values, out / "material.toml")
        write_fit_csv(rows, out / "fit.csv")
        for test, measured, curve, _ in rows:
            plot_test(calibration, test, measured, curve, out / f"fit-{test.name}.png")
        summary["total_wall_s"] = round(time.perf_counter() - start, 3)
        (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary
