"""Synthetic laboratory curves: a model's own curves along a path, with noise, written as a
``soilbin calibrate`` data file. They show what a test programme can fix before it is run,
and they are the data of the calibration tests and example."""
import numpy as np

from ..material_point.driver import drive


def laboratory_csv(model, path_params, path_name, x, y, legs, rng, noise=0.01,
                   leg_column=False):
    """CSV text of the driver's rows of ``legs`` (the path's leg names a laboratory records),
    columns ``x`` and ``y`` (and ``leg`` first with ``leg_column``); Gaussian noise of
    ``noise`` times its range on each ``y`` column."""
    result = drive(model, path_params, path_name)
    if not result.converged:
        raise RuntimeError(f"{path_name}: {result.message}")
    rows = [row for row in result.rows if row["leg"] in legs]
    columns = {c: np.array([row[c] for row in rows]) for c in (x, *y)}
    for c in y:
        columns[c] = columns[c] + noise * np.ptp(columns[c]) * rng.standard_normal(len(rows))
    header = ["leg"] * leg_column + [x, *y]
    lines = [",".join(header)] + [
        ",".join([row["leg"]] * leg_column + [f"{columns[c][k]:.12g}" for c in (x, *y)])
        for k, row in enumerate(rows)]
    return "\n".join(lines) + "\n"
