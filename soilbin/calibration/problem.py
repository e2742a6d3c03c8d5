"""The calibration file (``soilbin calibrate FILE.toml``), read and checked before any fit.

Every measured column carries the name of a column of ``soilbin point``'s path.csv
(``eps_axial``, ``eps_v``, ``p``, ``q``, ``sigma_axial``, ...): compression positive, the
driver's convention, in the units of the scene the material is meant for.
"""
import csv
import dataclasses
import math
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..material_point.driver import BASE_COLUMNS, build_model, build_path
from ..models import MODELS
from ..records.toml_in import read_toml
from ..records.units import read_units

#: Columns a test may compare or place its points at (path.csv's numeric columns).
COLUMNS = tuple(c for c in BASE_COLUMNS if c not in ("step", "leg"))
TOP_KEYS = ("model", "units", "max_evaluations", "fit", "fixed", "tied", "test")
TEST_KEYS = ("path", "set", "data", "x", "y", "weight", "strains_from")
#: The strain columns (shifted to zero at the start of a test's ``strains_from`` leg).
STRAINS = ("eps_axial", "eps_v", "gamma")


def strains_from_leg(table, columns, legs, leg):
    """(n, len(columns)) ``table`` of a path's rows (their ``legs``) with its strain columns
    counted from the start of ``leg`` (the last row before its first one), as a
    laboratory counts a triaxial test's strains from the start of shearing."""
    start = max(int(np.argmax(legs == leg)) - 1, 0)
    return table - np.where(np.isin(columns, STRAINS), table[start], 0.0)


@dataclasses.dataclass(frozen=True)
class LabTest:
    """One laboratory curve: the path that reproduces it and its measured columns."""
    name: str          # the data file's stem (unique within the calibration)
    path_name: str
    path_params: object
    x: str
    y: tuple
    measured: dict     # column -> (n,) array, in the file's order
    legs: np.ndarray   # (n,) the path's leg of each point ('' without a leg column)
    weight: float
    strains_from: str  # the leg at whose start the strains are zero ('': the path's start)

    @property
    def scale(self):
        """(len(y),) range of each compared column: stresses and strains weigh alike."""
        return np.array([np.ptp(self.measured[c]) or 1.0 for c in self.y])


@dataclasses.dataclass(frozen=True)
class Calibration:
    file: Path
    model_name: str
    fitted: tuple      # names of the fitted parameters
    lower: np.ndarray
    start: np.ndarray
    upper: np.ndarray
    fixed: dict
    tied: dict         # parameter -> the fitted or fixed parameter whose value it takes
    tests: tuple
    stress_unit: str   # from the file's ``units``, as a scene's (records.units)
    max_evaluations: int | None   # of the residual vector by the fit (None: scipy's 100 n)

    @property
    def residual_count(self):
        """Measured values compared: the length of the residual vector."""
        return sum(t.legs.size * len(t.y) for t in self.tests)

    def table(self, values):
        """The model's parameter table at the fitted ``values``."""
        table = {**self.fixed, **{k: float(v) for k, v in zip(self.fitted, values)}}
        return {**table, **{k: table[v] for k, v in self.tied.items()}}

    def model(self, values):
        """The model record at ``values`` (InputError where the model refuses them)."""
        return build_model(self.model_name, self.table(values))


def read_calibration(path):
    """The checked :class:`Calibration` of ``path``; every problem is an InputError naming
    the file, the test, the column or row and what is accepted."""
    path = Path(path)
    doc = read_toml(path, "calibration")
    where = str(path)
    _known_keys(doc, TOP_KEYS, where)
    model_name = doc.get("model")
    if model_name not in MODELS:
        raise InputError(f"{where}: model = {model_name!r}; known: {', '.join(MODELS)}")
    fitted, bounds = _fit_table(doc.get("fit"), where)
    fixed = doc.get("fixed", {})
    if not isinstance(fixed, dict):
        raise InputError(f"{where}: [fixed] must be a table of parameter = value")
    both = sorted(set(fitted) & set(fixed))
    if both:
        raise InputError(f"{where}: {both[0]!r} is both in [fit] and in [fixed]; give it in one")
    tied = _tied_table(doc.get("tied", {}), fitted, fixed, where)
    _all_parameters(model_name, fitted, {**fixed, **tied}, where)
    tests = _tests(doc.get("test"), path)
    points = sum(t.legs.size * len(t.y) for t in tests)
    if points < len(fitted):
        raise InputError(f"{where}: {points} measured values for {len(fitted)} fitted "
                         f"parameters; accepted: at least as many values as parameters")
    units = doc.get("units", "lb, in")
    if not isinstance(units, str):
        raise InputError(f"{where}: units = {units!r}; accepted: a scene's units text, e.g. 'lb, in'")
    max_evaluations = doc.get("max_evaluations")
    if max_evaluations is not None and (not isinstance(max_evaluations, int)
                                        or isinstance(max_evaluations, bool)
                                        or max_evaluations < 1):
        raise InputError(f"{where}: max_evaluations = {max_evaluations!r}; accepted: a "
                         f"positive integer")
    lower, start, upper = bounds.T
    calibration = Calibration(path, model_name, tuple(fitted), lower, start, upper, dict(fixed),
                              tied, tests, read_units(units).stress, max_evaluations)
    try:
        calibration.model(start)
    except InputError as err:
        raise InputError(f"{where}: at the start values: {err}") from None
    return calibration


def _known_keys(table, keys, where):
    unknown = sorted(set(table) - set(keys))
    if unknown:
        raise InputError(f"{where}: unknown key {unknown[0]!r}; accepted keys: {', '.join(keys)}")


def _fit_table(fit, where):
    """(names, (n, 3) array of lower, start, upper) of the [fit] table."""
    if not isinstance(fit, dict) or not fit:
        raise InputError(f"{where}: [fit] must name at least one parameter = [lower, start, upper]")
    rows = []
    for name, value in fit.items():
        ok = (isinstance(value, list) and len(value) == 3
              and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                      and math.isfinite(v) for v in value))
        if not ok:
            raise InputError(f"{where}: fit.{name} = {value!r}; accepted: [lower, start, upper], "
                             f"three finite numbers")
        lower, start, upper = value
        if not lower < upper:
            raise InputError(f"{where}: fit.{name}: lower {lower!r} is not below upper {upper!r}")
        if not lower <= start <= upper:
            raise InputError(f"{where}: fit.{name}: start {start!r} is outside "
                             f"[{lower!r}, {upper!r}]")
        rows.append([float(v) for v in value])
    return list(fit), np.array(rows)


def _tied_table(tied, fitted, fixed, where):
    """{parameter: the fitted or fixed parameter it equals} of the [tied] table."""
    if not isinstance(tied, dict):
        raise InputError(f"{where}: [tied] must be a table of parameter = \"PARAMETER\"")
    for name, other in tied.items():
        if name in fitted or name in fixed:
            raise InputError(f"{where}: {name!r} is in [tied] and in [fit] or [fixed]; give it in one")
        if other not in fitted and other not in fixed:
            raise InputError(f"{where}: tied.{name} = {other!r}; accepted: the name of a "
                             f"parameter in [fit] or [fixed] ({', '.join([*fitted, *fixed])})")
    return dict(tied)


def _all_parameters(model_name, fitted, fixed, where):
    """Every parameter the model needs is in [fit] or [fixed] (or [tied]); none is unknown."""
    fields = {f.name: f for f in dataclasses.fields(MODELS[model_name]) if f.init}
    given = set(fitted) | set(fixed)
    unknown = sorted(given - set(fields))
    if unknown:
        raise InputError(f"{where}: {unknown[0]!r} is not a parameter of {model_name}; "
                         f"accepted: {', '.join(fields)}")
    missing = [n for n, f in fields.items() if n not in given and f.default is dataclasses.MISSING]
    if missing:
        raise InputError(f"{where}: {', '.join(map(repr, missing))} missing from both [fit] "
                         f"and [fixed]; {model_name} needs it")


def _tests(tables, file):
    if not isinstance(tables, list) or not tables or not all(isinstance(t, dict) for t in tables):
        raise InputError(f"{file}: no [[test]]; accepted: one or more [[test]] tables")
    tests = [_test(t, file, f"{file}: test {i}") for i, t in enumerate(tables, 1)]
    names = [t.name for t in tests]
    if len(set(names)) < len(names):
        tests = [dataclasses.replace(t, name=f"{i}-{t.name}") for i, t in enumerate(tests, 1)]
    return tuple(tests)


def _test(table, file, where):
    _known_keys(table, TEST_KEYS, where)
    path_table = table.get("set", {})
    if not isinstance(path_table, dict):
        raise InputError(f"{where}: set must be a table of path keys, e.g. {{ confining = 5.0 }}")
    try:
        path_params = build_path(table.get("path"), path_table)
    except InputError as err:
        raise InputError(f"{where}: {err}") from None
    x, y = table.get("x"), table.get("y")
    y = [y] if isinstance(y, str) else y
    if not isinstance(y, list) or not y:
        raise InputError(f"{where}: y = {y!r}; accepted: a column or a list of columns, "
                         f"of {', '.join(COLUMNS)}")
    for column in [x, *y]:
        if column not in COLUMNS:
            raise InputError(f"{where}: column {column!r} (x, y); accepted: {', '.join(COLUMNS)}")
    weight = table.get("weight", 1.0)
    if isinstance(weight, bool) or not isinstance(weight, (int, float)) or not weight > 0:
        raise InputError(f"{where}: weight = {weight!r}; accepted: a positive number")
    data = table.get("data")
    if not isinstance(data, str):
        raise InputError(f"{where}: data = {data!r}; accepted: a CSV file relative to {file}")
    path_legs = [leg.name for leg in path_params.legs()]
    strains_from = table.get("strains_from", "")
    if strains_from and strains_from not in path_legs:
        raise InputError(f"{where}: strains_from = {strains_from!r}; accepted: a leg of the "
                         f"path: {', '.join(path_legs)}")
    measured, legs = _read_curve(file.parent / data, x, y, path_legs, where)
    return LabTest(Path(data).stem, table["path"], path_params, x, tuple(y), measured, legs,
                   float(weight), strains_from)


def _read_curve(csv_path, x, y, path_legs, where):
    """({column: array}, legs) of the measured columns in the file's order; x strictly
    monotone along each leg (the whole file without a ``leg`` column)."""
    where = f"{where}: {csv_path}"
    if not csv_path.is_file():
        raise InputError(f"{where}: no such data file")
    with open(csv_path, newline="") as f:
        reader = csv.reader(f)
        header = [h.strip() for h in next(reader, [])]
        rows = [row for row in reader if row]
    missing = [c for c in [x, *y] if c not in header]
    if missing:
        raise InputError(f"{where}: no column {missing[0]!r}; the file has: {', '.join(header)}")
    columns = {c: _numbers(rows, header.index(c), c, where) for c in [x, *y]}
    legs = _legs(rows, header, path_legs, where)
    for leg in np.unique(legs):
        at = np.flatnonzero(legs == leg)
        steps = np.diff(columns[x][at])
        if not (np.all(steps > 0) or np.all(steps < 0)):
            k = int(np.argmax(steps <= 0) if steps[0] > 0 else np.argmax(steps >= 0))
            along = f" along leg {leg!r}" if leg else ""
            raise InputError(f"{where}: column {x!r} (x) is not strictly monotone{along} at "
                             f"row {at[k + 1] + 2}; accepted: strictly increasing or decreasing "
                             f"values (along each leg of a 'leg' column naming the path's legs: "
                             f"{', '.join(path_legs)})")
    return columns, legs


def _legs(rows, header, path_legs, where):
    """(n,) leg of each row: its ``leg`` column, '' (the whole path) without one."""
    if "leg" not in header:
        return np.full(len(rows), "")
    index = header.index("leg")
    legs = [row[index].strip() if index < len(row) else "" for row in rows]
    for k, leg in enumerate(legs, 2):
        if leg not in path_legs:
            raise InputError(f"{where}: row {k}, column 'leg': {leg!r} is not a leg of the path; "
                             f"accepted: {', '.join(path_legs)}")
    return np.array(legs)


def _numbers(rows, index, column, where):
    """The column's finite values; row numbers count the header as row 1."""
    values = []
    for k, row in enumerate(rows, 2):
        try:
            value = float(row[index])
        except (ValueError, IndexError):
            value = math.nan
        if not math.isfinite(value):
            raise InputError(f"{where}: row {k}, column {column!r}: "
                             f"{row[index] if index < len(row) else ''!r} is not a finite number")
        values.append(value)
    if len(values) < 2:
        raise InputError(f"{where}: column {column!r} has {len(values)} rows; accepted: at least 2")
    return np.array(values)
