"""Synthetic laboratory curves: a model's own curves along a path, with noise, written as a
``soilbin calibrate`` data file. They show what a test programme can fix before it is run,
and they are the data of the calibration tests and example."""
import numpy as np

from ..material_point.driver import drive
from .problem import strains_from_leg


def laboratory_csv(model, path_params, path_name, x, y, legs, rng, noise=0.01,
                   leg_column=False, strains_from=""):
    """CSV text of the driver's rows of ``legs`` (the path's leg names a laboratory records),
    columns ``x`` and ``y`` (and ``leg`` first with ``leg_column``); Gaussian noise of
    ``noise`` times its range on each ``y`` column; strains counted from the start of the
    leg ``strains_from`` (from the path's start without it)."""
    result = drive(model, path_params, path_name)
    if not result.converged:
        raise RuntimeError(f"{path_name}: {result.message}")
    columns = (x, *y)
    table = np.array([[row[c] for c in columns] for row in result.rows])
    row_legs = np.array([row["leg"] for row in result.rows])
    if strains_from:
        table = strains_from_leg(table, columns, row_legs, strains_from)
    kept = np.isin(row_legs, legs)
    table, row_legs = table[kept], row_legs[kept]
    for j in range(1, len(columns)):
        table[:, j] += noise * np.ptp(table[:, j]) * rng.standard_normal(len(table))
    lines = [",".join(["leg"] * leg_column + list(columns))] + [
        ",".join([leg] * leg_column + [f"{v:.12g}" for v in values])
        for leg, values in zip(row_legs, table)]
    return "\n".join(lines) + "\n"
