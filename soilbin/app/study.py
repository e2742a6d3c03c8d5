"""Studies: one base scene solved for many cases, a case being a set of overrides.

A study file names a scene, the overrides of every case (``[set]``), the
cases (``[[case]]`` tables, a ``[product]`` of value lists, or both), the
collected table and overlay figures. Every case is checked by loading its
scene before anything runs. A key ``materials.NAME.from = "FILE.toml[:NAME]"``
replaces the scene's material NAME whole by a file's (the ``material.toml`` of
``soilbin calibrate``, or a material of a scene file). Each case is
``soilbin run SCENE --set ...`` in its own process and in its own folder, named
after its overrides; a case whose folder holds the summary of an earlier run of
exactly that case is not run again, so an interrupted study resumes where it
stopped.
"""
import csv
import dataclasses
import enum
import hashlib
import itertools
import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
import tomllib
from pathlib import Path

from ..errors import InputError
from ..params import Params, describe, from_table, param
from ..records.toml_out import _scalar as toml_value
from .cli import SCENES_DIR, folder
from .outdir import writable

DONE = ("complete", "collapse")   # statuses of a case that reached its end
#: Keys of every run summary (soilbin/app/run.py); a scene adds its headline keys.
SUMMARY_KEYS = ("scene", "title", "units", "overrides", "status", "converged", "message",
                "n_cells", "n_dofs", "n_ranks", "n_steps", "load_factor", "newton_iterations",
                "failed_newton_iterations", "cuts", "linear_solver", "setup_s", "wall_s", "cpu_s")
TABLE_TAIL = ("n_dofs", "newton_iterations", "wall_s")   # last columns of the default table
TOP_LEVEL = ("title", "scene", "set", "case", "product", "run", "table", "figures")
MAX_NAME = 64        # longest folder name before it is shortened and ends in a hash
POLL_S = 0.2         # how often running cases are looked at
STOP_S = 10.0        # how long a stopped case may take to end before it is killed
PACKAGE_ROOT = Path(__file__).resolve().parents[2]   # the cases run this same soilbin


class FigureKind(enum.Enum):
    CURVES = "curves"   # two curve.csv columns of the cases, overlaid
    SWEEP = "sweep"     # a summary value against a swept key, a line per value of another


@dataclasses.dataclass(frozen=True)
class Figure(Params):
    name: str = param(doc="the PNG's file name in the study folder, without .png")
    kind: FigureKind = param(FigureKind.CURVES, doc="curves or sweep")
    x: str = param("displacement", doc="curves: a curve.csv column; sweep: a swept key")
    y: str = param("force", doc="curves: a curve.csv column; sweep: a summary key "
                                "(a headline result, n_dofs, wall_s, ...)")
    lines: str = param("", doc="sweep: a swept key, one line per value")
    title: str = param("", doc="default: the study's title")
    select: tuple = param((), doc="only the cases with these values, e.g. "
                                  "select = {mesh.tool_width = 2}")


@dataclasses.dataclass(frozen=True)
class RunOptions(Params):
    jobs: int = param(1, lo=1, hi=64, doc="cases solved at a time, each in its own process")
    mpi_ranks: int = param(1, lo=1, hi=1024, doc="MPI ranks of each case (mpirun -n)")


@dataclasses.dataclass(frozen=True)
class Table(Params):
    columns: tuple[str, ...] = param((), doc="override keys and summary keys; default: the swept "
                                             "keys, status, the headline results, "
                                             + ", ".join(TABLE_TAIL))


@dataclasses.dataclass(frozen=True)
class Case:
    name: str          # its folder name, from the values it sets
    overrides: tuple   # 'dotted.key=value' for --set: the study's [set], then the case's own
    values: dict       # dotted key -> value, every override
    scene: object      # the loaded, checked Scene
    label: str = ""    # its [[case]] table's label: its name in legends and table.md
    named: tuple = ()  # the keys its label stands for (its [[case]] table's)


@dataclasses.dataclass(frozen=True)
class Study:
    path: Path
    title: str
    scene_path: Path
    run: RunOptions
    cases: tuple
    short: dict        # swept dotted key -> its shortest unambiguous suffix
    columns: tuple     # of the collected table
    figures: tuple

    @property
    def name(self):
        return self.path.stem

    @property
    def units(self):
        return self.cases[0].scene.units


@dataclasses.dataclass(frozen=True)
class Outcome:
    case: Case
    status: str        # complete, collapse, failed (its summary's), error (it left no summary),
                       # unfinished (the study was stopped before it ended)
    summary: dict      # None for an error
    ran: bool          # False: found in its folder, from an earlier run


class Interrupted(Exception):
    """SIGINT or SIGTERM reached the study: the running cases were stopped."""

    def __init__(self, signum):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


# ---------------------------------------------------------------- the study file

def label(value):
    """A value as it reads in folder names, tables and legends."""
    return value if isinstance(value, str) else toml_value(value)


def _dotted(table, where):
    """A TOML table, nested by dotted keys, as {'dotted.key': value}."""
    if not isinstance(table, dict):
        raise InputError(f"{where}: expected a table, got {table!r}")
    flat = {}
    for key, value in table.items():
        if isinstance(value, dict):
            flat.update({f"{key}.{k}": v for k, v in _dotted(value, f"{where}.{key}").items()})
        else:
            flat[key] = value
    return flat


def _tables(raw, key):
    tables = raw.get(key, [])
    if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
        raise InputError(f"{key}: expected an array of tables [[{key}]]")
    return tables


def _own_values(raw):
    """(own values, label, the keys the label names) of each case: every [[case]] table with
    every combination of [product]."""
    product = _dotted(raw.get("product", {}), "product")
    for key, values in product.items():
        if not isinstance(values, list) or not values:
            raise InputError(f"product.{key}: expected a non-empty list of values")
    combinations = [dict(zip(product, c)) for c in itertools.product(*product.values())]
    cases = []
    for i, table in enumerate(_tables(raw, "case") or [{}]):
        table = dict(table)
        case_label = table.pop("label", "")
        if not isinstance(case_label, str):
            raise InputError(f"case[{i}].label: expected a string, got {case_label!r}")
        own = _dotted(table, f"case[{i}]")
        both = sorted(set(own) & set(product))
        if both:
            raise InputError(f"case[{i}].{both[0]}: the key is also swept in [product]")
        named = tuple(own) if case_label else ()
        cases += [({**own, **combination}, case_label, named) for combination in combinations]
    return cases


def _short_names(keys):
    """Each dotted key's shortest suffix that no other key shares (rake_angle, soil.E)."""
    def tail(key, n):
        return ".".join(key.split(".")[-n:])

    def short(key):
        return next((tail(key, n) for n in range(1, key.count(".") + 1)
                     if all(tail(other, n) != tail(key, n) for other in keys if other != key)), key)
    return {key: short(key) for key in keys}


def folder_name(own, short):
    """'rake_angle=45,tool_width=2': filesystem-safe; a long or altered name ends in a hash."""
    if not own:
        return "base"
    text = ",".join(f"{short[key]}={label(own[key])}" for key in short if key in own)
    safe = re.sub(r"[^A-Za-z0-9._=,+-]", "_", text)
    if safe == text and len(text) <= MAX_NAME:
        return text
    return f"{safe[:MAX_NAME - 9]}-{hashlib.sha1(text.encode()).hexdigest()[:8]}"


def _override(key, value, base):
    """The --set item of a study key; materials.NAME.from is the material read from its file,
    as one table that replaces the scene's material NAME whole."""
    material = _replaced_material(key)
    try:
        if material is not None:
            table = _material_from_file(key, value, base)
            return f"materials.{material}={_inline_table(table)}"
        return f"{key}={toml_value(value)}"
    except TypeError:
        raise InputError(f"{key}: {value!r} cannot be given to --set") from None


def _inline_table(table):
    """{model = "elastic", E = 9000.0}: a TOML inline table, a --set value."""
    return "{" + ", ".join(f"{key} = {toml_value(value)}" for key, value in table.items()) + "}"


FROM_ACCEPTED = ('"FILE.toml" (a file holding one [materials.NAME] table, such as the '
                 'material.toml of soilbin calibrate) or "FILE.toml:NAME"; FILE relative to '
                 'the study file\'s folder')


def _replaced_material(key):
    """NAME of a key materials.NAME.from (the whole material read from a file), else None."""
    parts = key.split(".")
    return parts[1] if len(parts) == 3 and parts[0] == "materials" and parts[2] == "from" else None


def _material_from_file(key, spec, base):
    """{model, parameters} of the material ``spec`` names: FILE.toml (its only material) or
    FILE.toml:NAME, FILE relative to ``base``; the model and its parameters checked."""
    from ..models import MODELS
    from ..records.toml_in import read_scene_tables
    where = f"{key} = {spec!r}"
    if not isinstance(spec, str):
        raise InputError(f"{where}: expected {FROM_ACCEPTED}")
    file, sep, name = spec.rpartition(":")
    if not sep:
        file, name = spec, None
    if not file or name == "":
        raise InputError(f"{where}: expected {FROM_ACCEPTED}")
    path = base / file
    if not path.is_file():
        raise InputError(f"{where}: no such file {path}; expected {FROM_ACCEPTED}")
    try:
        materials = read_scene_tables(path).get("materials")
    except InputError as err:
        raise InputError(f"{where}: {err}") from None
    if not isinstance(materials, dict) or not materials:
        raise InputError(f"{where}: {path} has no [materials.NAME] table; expected "
                         f"{FROM_ACCEPTED}")
    if name is None and len(materials) > 1:
        raise InputError(f"{where}: {path} holds {len(materials)} materials "
                         f"({', '.join(materials)}): name one as \"{file}:NAME\"")
    name = name or next(iter(materials))
    if not isinstance(materials.get(name), dict):
        raise InputError(f"{where}: {path} has no material {name!r}; its materials: "
                         f"{', '.join(materials)}")
    parameters = dict(materials[name])
    model = parameters.pop("model", None)
    if not isinstance(model, str) or model not in MODELS:
        raise InputError(f"{where}: {path}: materials.{name}.model = {model!r} is not a model "
                         f"of soilbin; known: {', '.join(MODELS)}")
    try:
        from_table(MODELS[model], parameters, f"materials.{name}")
    except InputError as err:
        raise InputError(f"{where}: {path}: {err}") from None
    return {"model": model, **parameters}


def _check_replaced(values, scene):
    """Each material a case reads from a file is one of the scene's regions'."""
    used = dict.fromkeys(scene.regions.values())
    for key in values:
        material = _replaced_material(key)
        if material is not None and material not in used:
            raise InputError(f"{key}: no region of the scene has the material {material!r}; "
                             f"its regions' materials: {', '.join(used)}")


def _case_values(common, own):
    """[set]'s values, then the case's own. A material the case reads from a file
    (materials.NAME.from) is the file's: what [set] says of it is left out."""
    replaced = tuple(f"materials.{name}." for name in map(_replaced_material, own) if name)
    return {**{key: value for key, value in common.items() if not key.startswith(replaced)},
            **own}


def _case(scene_path, base, common, own, short, case_label, named):
    """A case; a material read from a file (materials.NAME.from) is set before the other
    keys, so that keys of its parameters beside it change the file's values."""
    from ..records.scene import load_scene
    name = folder_name(own, short)
    values = _case_values(common, own)
    ordered = sorted(values.items(), key=lambda item: _replaced_material(item[0]) is None)
    try:
        overrides = tuple(_override(key, value, base) for key, value in ordered)
        scene = load_scene(scene_path, overrides)
        _check_replaced(values, scene)
    except InputError as err:
        raise InputError(f"case {case_label or name}: {err}") from None
    return Case(name, overrides, values, scene, case_label, named)


def _scene_file(raw, base):
    scene = _text(raw, "scene")
    path = base / scene
    return path if path.suffix == ".toml" or path.exists() else SCENES_DIR / f"{scene}.toml"


def _text(raw, key):
    if not isinstance(raw.get(key), str) or not raw[key]:
        raise InputError(f"{key}: expected a non-empty string")
    return raw[key]


def _figure(table, where, swept, summary_keys):
    from .output import CURVE_COLUMNS
    table = dict(table)
    select = _dotted(table.pop("select", {}), f"{where}.select")
    figure = dataclasses.replace(from_table(Figure, table, where), select=tuple(select.items()))
    if not re.fullmatch(r"[\w.-]+", figure.name) or set(figure.name) == {"."}:
        raise InputError(f"{where}.name = {figure.name!r}: expected a file name in the study "
                         "folder (letters, digits, '_', '-', '.'; no folders)")
    if figure.kind is FigureKind.CURVES:
        accepted = {"x": CURVE_COLUMNS, "y": CURVE_COLUMNS, "lines": ("",)}
    else:
        accepted = {"x": swept, "y": summary_keys, "lines": ("", *swept)}
    for key, choices in accepted.items():
        value = getattr(figure, key)
        if value not in choices:
            raise InputError(f"{where}.{key} = {value!r}: expected one of "
                             f"{', '.join(c for c in choices if c) or 'nothing (curves)'}")
    for key, _ in figure.select:
        if key not in swept:
            raise InputError(f"{where}.select.{key}: no case sets this key")
    return figure


def _columns(raw, keys, swept, summary_keys, headline):
    columns = from_table(Table, raw.get("table", {}), "table").columns
    for i, column in enumerate(columns):
        if column not in keys and column not in summary_keys:
            raise InputError(f"table.columns[{i}] = {column!r}: neither an override key nor a "
                             f"summary key ({', '.join(summary_keys)})")
    return columns or (*swept, "status", *headline, *TABLE_TAIL)


def _parse(raw, path):
    unknown = sorted(set(raw) - set(TOP_LEVEL))
    if unknown:
        raise InputError(f"unknown key {unknown[0]!r}; top-level keys: {', '.join(TOP_LEVEL)}")
    title = _text(raw, "title")
    scene_path = _scene_file(raw, path.parent)
    common = _dotted(raw.get("set", {}), "set")
    own_values = _own_values(raw)
    swept = tuple(dict.fromkeys(key for own, _, _ in own_values for key in own))
    short = _short_names(swept)
    cases = tuple(_case(scene_path, path.parent, common, own, short, case_label, named)
                  for own, case_label, named in own_values)
    names = [case.name for case in cases]
    twice = next((name for name in names if names.count(name) > 1), None)
    if twice:
        raise InputError(f"case {twice}: listed twice")
    headline = tuple(dict.fromkeys(key for case in cases for key in case.scene.headline))
    summary_keys = (*SUMMARY_KEYS, *headline)
    figures = tuple(_figure(table, f"figures[{i}]", swept, summary_keys)
                    for i, table in enumerate(_tables(raw, "figures")))
    return Study(path=path, title=title, scene_path=scene_path,
                 run=from_table(RunOptions, raw.get("run", {}), "run"), cases=cases, short=short,
                 columns=_columns(raw, (*common, *swept), swept, summary_keys, headline),
                 figures=figures)


def load_study(path):
    """Read and check a study file and every case's scene; errors name the file and the key."""
    path = Path(path)
    try:
        with path.open("rb") as f:
            raw = tomllib.load(f)
    except OSError:
        raise InputError(f"{path}: no such study file") from None
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{path}: TOML syntax error: {err}") from None
    try:
        return _parse(raw, path)
    except InputError as err:
        raise InputError(f"{path}: {err}") from None


# ---------------------------------------------------------------- running the cases

def earlier_summary(case, folder):
    """The summary a run of exactly this case (its overrides, its resolved scene) left in
    its folder, or None. The recorded scene is the case's if it resolves to the same
    scene when read now: a key added to soilbin since the run takes its default, which
    keeps the behaviour the run had (a new key's default must)."""
    try:
        summary = json.loads((folder / "summary.json").read_text())
        resolved = (folder / "scene.toml").read_text()
    except (OSError, ValueError):
        return None
    wanted = case.scene.resolved()
    if summary.get("overrides") != list(case.overrides) or (
            resolved != wanted and _read_now(folder / "scene.toml") != wanted):
        return None
    return summary


def _read_now(path):
    """A run's recorded scene read by the present code (None if it no longer reads)."""
    from ..records.scene import load_scene
    try:
        return load_scene(path).resolved()
    except InputError:
        return None


def case_command(study, case, folder):
    """The command line that solves one case into its folder."""
    command = [sys.executable, "-m", "soilbin.app.cli", "run", str(study.scene_path),
               "--out", str(folder), "--json"]
    for override in case.overrides:
        command += ["--set", override]
    if study.run.mpi_ranks > 1:
        command = ["mpirun", "-n", str(study.run.mpi_ranks), *command]
    return command


def _launch(study, case, folder):
    """Start a case in its own process group; its output goes to run.log in its folder."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "summary.json").unlink(missing_ok=True)   # an interrupted rerun leaves none
    path = os.pathsep.join(p for p in (str(PACKAGE_ROOT), os.environ.get("PYTHONPATH")) if p)
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=path)
    with open(folder / "run.log", "w") as log:
        return subprocess.Popen(case_command(study, case, folder), stdout=log,
                                stderr=subprocess.STDOUT, env=env, start_new_session=True)


def _stop(processes):
    """SIGTERM each process group, then SIGKILL those that have not ended within STOP_S."""
    for process in processes:
        _signal_group(process, signal.SIGTERM)
    deadline = time.monotonic() + STOP_S
    for process in processes:
        try:
            process.wait(timeout=max(deadline - time.monotonic(), 0.0))
        except subprocess.TimeoutExpired:
            _signal_group(process, signal.SIGKILL)
            process.wait()


def _signal_group(process, signum):
    try:
        os.killpg(process.pid, signum)
    except ProcessLookupError:
        pass


def _interrupt(signum, frame):
    raise Interrupted(signum)


def _report(line):
    print(line, file=sys.stderr, flush=True)


def _earlier(case, folder, retry_failed):
    """The outcome of an earlier run that stands (complete, collapse; failed unless retried;
    never an interrupted one)."""
    summary = earlier_summary(case, folder)
    if (summary is None or summary["status"] == "interrupted"
            or (summary["status"] not in DONE and retry_failed)):
        return None
    return Outcome(case, summary["status"], summary, ran=False)


def run_study(study, out, retry_failed=False, report=_report):
    """Solve the cases not already in ``out``, ``study.run.jobs`` at a time; the outcomes
    in the study's order. SIGINT and SIGTERM stop the running cases and raise Interrupted."""
    n = len(study.cases)
    outcomes, queue = {}, []
    for i, case in enumerate(study.cases, 1):
        earlier = _earlier(case, out / case.name, retry_failed)
        if earlier is None:
            queue.append((i, case))
            continue
        outcomes[case.name] = earlier
        report(f"[{i}/{n}] {case.name}: {earlier.status} earlier"
               + ("" if earlier.status in DONE else " (--retry-failed runs it again)"))
    handlers = {s: signal.signal(s, _interrupt) for s in (signal.SIGINT, signal.SIGTERM)}
    running = {}   # name -> (i, case, process, start)
    try:
        while queue or running:
            while queue and len(running) < study.run.jobs:
                i, case = queue.pop(0)
                running[case.name] = (i, case, _launch(study, case, out / case.name),
                                      time.monotonic())
                report(f"[{i}/{n}] {case.name}: running")
            time.sleep(POLL_S)
            for name, (i, case, process, start) in list(running.items()):
                if process.poll() is None:
                    continue
                del running[name]
                outcomes[name] = _finished(case, out / name)
                report(f"[{i}/{n}] {name}: {outcomes[name].status} in "
                       f"{time.monotonic() - start:.1f} s"
                       + ("" if outcomes[name].summary else
                          f" (exit status {process.returncode}; see {out / name / 'run.log'})"))
    finally:
        _stop([process for _, _, process, _ in running.values()])
        for signum, handler in handlers.items():
            signal.signal(signum, handler)
    return [outcomes[case.name] for case in study.cases]


def collected(study, out):
    """Every case's outcome as its folder holds it now; "unfinished" where it has no summary
    of its own (not run, or stopped)."""
    outcomes = []
    for case in study.cases:
        summary = earlier_summary(case, out / case.name)
        if summary is None or summary["status"] == "interrupted":
            outcomes.append(Outcome(case, "unfinished", None, ran=False))
        else:
            outcomes.append(Outcome(case, summary["status"], summary, ran=False))
    return outcomes


def _finished(case, folder):
    summary = earlier_summary(case, folder)
    return Outcome(case, summary["status"] if summary else "error", summary, ran=True)


# ---------------------------------------------------------------- table and figures

def _cell(outcome, column):
    if column == "status":
        return outcome.status
    if column in outcome.case.values:
        return outcome.case.values[column]
    return (outcome.summary or {}).get(column)


def _markdown(value):
    if value is None:
        return ""
    return f"{value:.6g}" if isinstance(value, float) else label(value)


def write_table(study, outcomes, out):
    """table.csv (values as run) and table.md (6 significant digits) in the study folder; a
    first column "case" with the cases' labels if the study gives any."""
    out.mkdir(parents=True, exist_ok=True)
    header = [study.short.get(column, column) for column in study.columns]
    rows = [[_cell(outcome, column) for column in study.columns] for outcome in outcomes]
    if any(case.label for case in study.cases):
        header.insert(0, "case")
        for row, outcome in zip(rows, outcomes):
            row.insert(0, outcome.case.label)
    with open(out / "table.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows([["" if v is None else label(v) for v in row] for row in rows])
    done = sum(outcome.status in DONE for outcome in outcomes)
    lines = [f"# {study.title}", "",
             f"Scene `{study.scene_path}` ({study.units}); {done} of {len(outcomes)} cases "
             f"complete.", "",
             "| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
    lines += ["| " + " | ".join(_markdown(v) for v in row) + " |" for row in rows]
    (out / "table.md").write_text("\n".join(lines) + "\n")


def selected(figure, outcomes):
    return [o for o in outcomes if all(o.case.values.get(k) == v for k, v in figure.select)]


def draw_figures(study, outcomes, out):
    from .study_figures import curves_png, sweep_png
    draw = {FigureKind.CURVES: curves_png, FigureKind.SWEEP: sweep_png}
    for figure in study.figures:
        draw[figure.kind](figure, selected(figure, outcomes), study, out)


# ---------------------------------------------------------------- command line

STUDY_EPILOG = """\
study file (TOML; dotted keys are the keys of 'soilbin run --set'):
  title = "..."                  one line, heads table.md and the figures
  scene = "..."                  a scene file (relative to the study file) or a
                                 scene name in scenes/
  [set]                          overrides of every case
  [product]                      cases: every combination of these value lists
  [[case]]                       cases: one table of overrides each (with a
                                 [product]: each case with every combination)
    label = "..."                the case's name in the figures' legends and
                                 table.md (default: its values in words)
  materials.NAME = {{ from = "FILE.toml" }}
                                 in [set] or a [[case]]: the scene's material
                                 NAME replaced whole by the one material of
                                 FILE (soilbin calibrate's material.toml), or
                                 "FILE.toml:MATERIAL", one of several; FILE
                                 relative to the study file. Other keys of NAME
                                 then change the file's values; a [product] of
                                 materials.NAME.from = [...] sweeps files
  [run]
{run}
  [table]
{table}
  [[figures]]                    overlay figures, <name>.png in the study folder
{figures}

example:
  title = "Column settlement against E and the load"
  scene = "column-elastic"
  [set]
  mesh.nz = 2
  [product]
  materials.soil.E = [4500, 9000]
  loading.magnitude = [50, 100]
  [[figures]]
  name = "settlement"
  kind = "sweep"
  x = "materials.soil.E"
  y = "top_settlement"
  lines = "loading.magnitude"

Each case runs 'soilbin run SCENE --set ... --out DIR/CASE --json' in its own
process (its output in CASE/run.log); CASE is named after the values the case
sets, e.g. E=4500,magnitude=50. Every summary.json lists the case's
"overrides". DIR (default runs/<study file name>) collects table.csv,
table.md and the figures. Run it again to resume: a case whose folder holds
the summary of a run of the same overrides and the same resolved scene (read
by the present soilbin: a key added since takes its default) is not run again
(a failed one neither, unless --retry-failed); an interrupted one runs from
the start. SIGINT/SIGTERM stop the running cases and
write the table and figures of the finished ones.

exit status: 0 every case complete (or collapse), 1 some case failed or
ended in error, 2 bad input, 128 + signal number when interrupted.
"""


def _described(cls, skip=()):
    lines = [line for line in describe(cls) if line.split(" ")[0] not in skip]
    return "\n".join(textwrap.fill(line, 79, initial_indent="    ", subsequent_indent="      ")
                     for line in lines)


def add_parser(sub):
    """The 'study' subcommand of the soilbin command line."""
    import argparse
    study = sub.add_parser(
        "study", help="solve a scene for many cases (a sweep) and collect the results",
        description="Solve the cases of a study file (a base scene, overrides per case or a "
        "product of value lists), one process per case, each in its own folder; collect "
        "table.csv, table.md and overlay figures. Interrupted studies resume.",
        epilog=STUDY_EPILOG.format(run=_described(RunOptions), table=_described(Table),
                                   figures=_described(Figure)),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    study.add_argument("file", type=Path, metavar="FILE", help="the study file (TOML)")
    study.add_argument("--out", type=folder, help="study folder (default: runs/<study file name>)")
    study.add_argument("--jobs", type=int, help="cases at a time (default: run.jobs of the file)")
    study.add_argument("--retry-failed", action="store_true",
                       help="run again the cases whose earlier run failed")
    study.add_argument("--dry-run", action="store_true",
                       help="list the cases, their overrides and whether they would run")


def _dry_run(study, out, retry_failed):
    n = len(study.cases)
    for i, case in enumerate(study.cases, 1):
        earlier = _earlier(case, out / case.name, retry_failed)
        state = "to run" if earlier is None else f"{earlier.status} earlier"
        print(f"[{i}/{n}] {case.name}: {state}: "
              + " ".join(f"--set {override}" for override in case.overrides))
    return 0


def study_command(args):
    """soilbin study FILE: the exit status (0 all done, 1 some failed, 128 + signal)."""
    study = load_study(args.file)
    if args.jobs is not None:
        study = dataclasses.replace(study, run=dataclasses.replace(study.run, jobs=args.jobs))
    out = args.out or Path("runs") / study.name
    if args.dry_run:
        return _dry_run(study, out, args.retry_failed)
    writable(out)
    try:
        outcomes = run_study(study, out, args.retry_failed)
    except Interrupted as stop:
        outcomes = collected(study, out)
        write_table(study, outcomes, out)
        draw_figures(study, outcomes, out)
        _report(f"soilbin: study interrupted by {stop}; completed cases stay in {out} (table "
                f"and figures of those written), run it again to resume")
        return 128 + stop.signum
    write_table(study, outcomes, out)
    draw_figures(study, outcomes, out)
    done = sum(outcome.status in DONE for outcome in outcomes)
    _report(f"{done} of {len(outcomes)} cases complete; table in {out / 'table.md'}")
    return 0 if done == len(outcomes) else 1
