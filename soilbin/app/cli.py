"""The soilbin command line: run a scene, list the scenes, drive a material point."""
import os
os.environ.setdefault("OMP_NUM_THREADS", "1")  # before NumPy/PETSc load BLAS: threads fight MPI ranks
import argparse
import json
import logging
import resource
import sys
import tempfile
import time
import traceback
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from ..errors import InputError, SoilbinError
from ..launcher import launched_rank
from ..records.toml_in import SCENES_DIR, read_scene_tables, scene_path
from . import interrupt

EPILOG = """\
examples:
  soilbin list
  soilbin run scenes/strip-footing-von-mises.toml
  soilbin run column-elastic --set materials.soil.E=5000 --set loading.magnitude=20
  soilbin run block-drucker-prager --json --out /tmp/block
  soilbin run tine-2in-90deg --resume runs/tine-2in-90deg

exit status: 0 done (with loading.until_collapse = true a force-controlled run
that stops at the soil's limit counts as done: status "collapse", at the first
step whose displacement per unit load is 100 times the secant one at the first
nominal load step, or that cannot be converged), 1 the run could not reach the
full load (converged steps are on disk), 2 bad input (the message names the
file, the key and the accepted range), 3 internal error (one line; the
traceback is saved to a file it names), 130 / 143 interrupted by SIGINT /
SIGTERM (summary.json has status "interrupted"; converged steps are on disk).
"""


class _Parser(argparse.ArgumentParser):
    """argparse with its errors on one line (``--help`` shows the usage), printed by the
    first rank alone under mpirun."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n"
                  if launched_rank() == 0 else None)


def folder(text):
    """An --out or --resume folder: a non-empty name."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a folder, got an empty name")
    return Path(text)


def _parser(point_details=True):
    """The command line's parser; without ``point_details`` the ``point`` command's own
    help (its paths and their parameters) is left out, and NumPy is not loaded for it."""
    parser = _Parser(
        prog="soilbin", description="Geometric and material nonlinear finite element analysis "
        "of soil-structure interaction (DOLFINx).",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"soilbin {_version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = sub.add_parser("run", help="solve a scene", description=(
        "Solve a scene and write its run folder: scene.toml (resolved), curve.csv (one row per "
        "converged step), summary.json, fields.xdmf (ParaView) and checkpoint/ (the last "
        "converged step's state, for --resume)."),
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    run.add_argument("scene", help="scene file, or the name of a scene in scenes/ (see 'soilbin "
                     "list'); 'soilbin keys SCENE' lists every key it takes")
    run.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scene value, e.g. materials.soil.E=5000 (repeatable); "
                          "checked like the file")
    run.add_argument("--out", type=folder, help="run folder (default: runs/<scene name>, or "
                                                "FOLDER-resumed with --resume FOLDER)")
    run.add_argument("--json", action="store_true",
                     help="no progress lines; the last stdout line is the summary as one JSON object")
    run.add_argument("-v", "--verbose", action="store_true",
                     help="also a progress line per Newton iteration (its residual, the "
                          "target, the seconds since the last line and the peak resident "
                          "memory of all ranks): for long runs")
    run.add_argument("--resume", type=folder, metavar="FOLDER",
                     help="go on from the last converged step of the stopped run in FOLDER (its "
                          "checkpoint/; the same scene but for [solver], [output], [headline], "
                          "[soil_contact] and remesh.retries, any number of ranks); the new "
                          "--out starts with its steps")

    sub.add_parser("list", help="list the scenes in scenes/ with their titles",
                   description="List the scenes shipped in the project's scenes/ folder.")
    keys = sub.add_parser("keys", help="list every key of a scene with its value, range and "
                          "meaning", description="List every key a scene takes (the keys of "
                          "--set), with its value in the scene, its accepted range and its meaning.")
    keys.add_argument("scene", help="scene file, or the name of a scene in scenes/")
    keys.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                      help="override a scene value first (repeatable)")
    _point_parser(sub, point_details)
    from .study import add_parser as add_study_parser
    add_study_parser(sub)
    _calibrate_parser(sub)
    return parser


POINT_EPILOG = """\
paths (parameters: --set path.KEY=VALUE; compression positive):
{paths}
output (compression positive, the geomechanics convention): p = -tr(sigma)/3,
q = sqrt(3 J2) (negative when the axial stress is the smaller, as in triaxial
extension; unsigned in simple shear), eps_v = -tr(eps), eps_axial = -eps_zz,
sigma1 >= sigma2 >= sigma3; gamma = 2 eps_xz and tau = sigma_xz keep their sign.
z is the axial direction; simple shear is in the x-z plane.

examples:
  soilbin point drucker_prager triaxial-compression --set E=4000 --set nu=0.35 \\
      --set c=0 --set phi=33 --set matching=compression_cone --set path.confining=10
  soilbin point elastic oedometer --set E=1e4 --set nu=0.3 --set path.axial_strain=0.01
  soilbin point scenes/block-drucker-prager.toml:soil simple-shear \\
      --set path.confining=1000 --json

exit status: 0 done, 1 a step could not be converged (the converged steps are
written), 2 bad input.
"""


CALIBRATE_EPILOG = """\
the file (columns named as in path.csv of 'soilbin point', compression positive):
  model = "drucker_prager"         # any model of 'soilbin point'
  units = "lb, in"                 # optional, as a scene's: the figures' stress unit (psi)
  max_evaluations = 200            # optional: the fit stops there (not converged, exit 1)
  [fit]                            # parameter = [lower, start, upper]
  c   = [0.1, 1.0, 10.0]
  phi = [10.0, 25.0, 45.0]
  [fixed]                          # every other parameter the model needs
  E = 4000.0
  nu = 0.35
  matching = "compression_cone"
  [tied]                           # optional: parameter = "the one whose value it takes"
  psi = "phi"                      # (here: associated flow)
  [[test]]                         # one table per laboratory curve
  path = "triaxial-compression"    # a path of 'soilbin point'
  set = { confining = 5.0 }        # its path keys (path.KEY of 'soilbin point')
  data = "tx5.csv"                 # measured points, relative to this file
  x = "eps_axial"                  # the column the points are placed at (monotone;
                                   # along each leg with a 'leg' column, as in path.csv)
  y = ["q", "eps_v"]               # the columns compared
  weight = 1.0                     # optional
  strains_from = "shear"           # optional: strains count from this leg's start
                                   # (default: from the path's start, p_initial)

output (in --out): summary.json (status, parameters, standard_errors,
correlation, unidentified parameters, rms per test, evaluations, wall_s),
material.toml ([materials.NAME] to paste into a scene), fit.csv (measured
against fitted at every point), fit-TEST.png (one per test).

a study runs a scene in the fitted material with materials.NAME = { from =
"runs/calibrate-STEM/material.toml" } (relative to the study file).

example (the section VII.5 soil from its appendix C curves):
  soilbin calibrate examples/calibration-vii5/vii5.toml

exit status: 0 converged, 1 not converged (every output written), 2 bad input.
"""


def _calibrate_parser(sub):
    calibrate = sub.add_parser(
        "calibrate", help="fit a model's parameters to laboratory curves",
        description="Fit a constitutive model's parameters to measured laboratory curves: each "
        "test's model curve is that of 'soilbin point' along its path, interpolated at the measured x; "
        "every compared column is scaled by its measured range; one least-squares fit "
        "(trust-region reflective, within the bounds) from the start values.",
        epilog=CALIBRATE_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    calibrate.add_argument("file", metavar="FILE.toml", type=Path, help="the calibration file")
    calibrate.add_argument("--out", type=folder, help="output folder (default: runs/calibrate-STEM)")
    calibrate.add_argument("--jobs", type=int, default=os.cpu_count() or 1, metavar="N",
                           help="processes for the fit's finite differences (default: the "
                                "machine's cores, %(default)s here; under mpirun the ranks)")
    calibrate.add_argument("--json", action="store_true",
                           help="the last stdout line is the summary as one JSON object")


def _print_calibration(summary, as_json):
    if as_json:
        print(json.dumps(summary))
        return
    errors = summary["standard_errors"]
    for name in summary["fitted"]:
        se = errors[name]
        print(f"{name} = {summary['parameters'][name]:.6g} "
              f"± {'unidentified' if se is None else f'{se:.3g}'}")
    for name, reason in summary["unidentified"].items():
        print(f"unidentified: {name}: {reason}")
    print(f"{summary['status']}: rms {summary['rms']['overall']:.3g} (scaled), "
          f"{summary['evaluations']} evaluations, {summary['wall_s']} s; results in "
          f"{summary['out']}", file=sys.stderr)


def _point_parser(sub, details=True):
    lines, paths = [], {}
    if details:
        import textwrap
        from ..material_point.paths import PATHS as paths
        from ..params import describe
        for name, cls in paths.items():
            lines += textwrap.wrap(f"{name}: {' '.join((cls.__doc__ or '').split())}", 79,
                                   initial_indent="  ", subsequent_indent="    ")
            for line in describe(cls):
                lines += textwrap.wrap(line, 79, initial_indent="    - ",
                                       subsequent_indent="      ")
    point = sub.add_parser(
        "point", help="drive one material point of a model along a loading path",
        description="Drive one material point of a constitutive model (the classes of the FE\n"
        "solve) along a strain-, stress- or mixed-controlled loading path and write the\n"
        "output folder: path.csv (one row per step), path.png (q-p stress path,\n"
        "stress-strain, volumetric strain) and summary.json.",
        epilog=POINT_EPILOG.format(paths="\n".join(lines)) if details else None,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    point.add_argument("model", metavar="MODEL",
                       help="a constitutive model (elastic, drucker_prager, ...: the keys of "
                            "soilbin.models.MODELS), or SCENE.toml:NAME for the model and "
                            "parameters of [materials.NAME] in a scene file (or scene name)")
    point.add_argument("path", metavar="PATH", help=f"loading path: {', '.join(paths)}")
    point.add_argument("--set", dest="overrides", action="append", default=[],
                       metavar="KEY=VALUE",
                       help="a model parameter (E=4000, matching=compression_cone; overrides "
                            "a scene material's) or a path parameter (path.confining=10); "
                            "repeatable, checked on input")
    point.add_argument("--out", type=folder, help="output folder (default: runs/point-MODEL-PATH)")
    point.add_argument("--json", action="store_true",
                       help="the last stdout line is the summary as one JSON object")


def _version():
    try:
        return version("soilbin")
    except PackageNotFoundError:
        return "(not installed)"


def _keys(args):
    from ..records.scene import load_scene
    from .keys import format_keys
    print("\n".join(format_keys(load_scene(scene_path(args.scene), args.overrides))))
    return 0


def _list_scenes(args):
    for path in sorted(SCENES_DIR.glob("*.toml"), key=lambda p: p.stem):
        title = read_scene_tables(path).get("title", "")
        print(f"{path.stem:32s} {title}")
    return 0


def _progress(record):
    columns = "".join(f"  {name} {value:11.5g}" for name, value in record.columns.items())
    print(f"step {record.step:3d}  load factor {record.load_factor:8.4f}  "
          f"displacement {record.displacement:11.5g}  force {record.force:11.5g}"
          f"{columns}  Newton {record.newton_iterations:2d}"
          + (f"  cuts {record.cuts}" if record.cuts else "")
          + f"  {record.wall_s:7.2f} s"
          + (f"  (last cut: {record.cut_reason})" if record.cuts else ""), file=sys.stderr, flush=True)


def _remesh_progress(report):
    how = "smoothed" if report.smoothed else "remeshed locally" if report.local else "remeshed"
    print(f"  {how} after step {report.step}: {report.cells_before} -> {report.cells_after} "
          f"cells, quality {report.quality_before:.3g} -> {report.quality_after:.3g}, force "
          f"{report.force_before:.5g} -> {report.force_after:.5g} ({report.newton_iterations} "
          f"Newton), {report.wall_s:.2f} s", file=sys.stderr, flush=True)


class _IterateProgress:
    """A line per Newton iterate on stderr (rank 0's): residual, target, seconds since the
    last line and the peak resident memory summed over the ranks. Called on every rank (the
    sum is a collective)."""

    def __init__(self, comm):
        self._comm = comm
        self._last = time.perf_counter()

    def __call__(self, iteration, residual, target):
        now = time.perf_counter()
        peak_kb = self._comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
        if self._comm.rank == 0:
            print(f"  Newton {iteration:3d}  residual {residual:10.4g}  target {target:9.3g}  "
                  f"{now - self._last:8.2f} s  peak {peak_kb / 2**20:6.2f} GB",
                  file=sys.stderr, flush=True)
        self._last = now


def _run(args):
    from mpi4py import MPI
    from ..records.scene import load_scene
    with interrupt.kept():   # gmsh's import (the remesher's) sets SIGINT's handler to the default
        from .run import run_scene

    scene = load_scene(scene_path(args.scene), args.overrides)
    out = args.out or (Path(f"{args.resume}-resumed") if args.resume
                       else Path("runs") / scene.name)
    comm = MPI.COMM_WORLD
    rank0 = comm.rank == 0
    try:
        quiet = args.json or not rank0
        summary = run_scene(scene, out, progress=None if quiet else _progress,
                            remesh_progress=None if quiet else _remesh_progress,
                            overrides=args.overrides, resume=args.resume,
                            iterate_progress=_IterateProgress(comm)
                            if args.verbose and not args.json else None)
    except (InputError, interrupt.Interrupted):
        raise   # every rank raises these alike
    except Exception as err:
        if comm.size == 1:
            raise
        # one rank failing alone would leave the others in a collective for ever
        print(f"soilbin: internal error on rank {comm.rank}: {_one_line(err)}; traceback in "
              f"{_save_traceback(out, comm.rank)}", file=sys.stderr, flush=True)
        comm.Abort(INTERNAL_ERROR)
    if rank0:
        if args.json:
            print(json.dumps(summary))
        else:
            resumed = (f" (resumed after step {summary['resumed_after_step']} of {args.resume})"
                       if args.resume else "")
            print(f"{summary['status']}: {summary['n_steps']} steps, "
                  f"{summary['newton_iterations']} Newton iterations, {summary['wall_s']} s; "
                  f"results in {out}{resumed}", file=sys.stderr)
            for key in scene.headline:
                print(f"{key} = {summary[key]}")
        if summary["message"]:
            print(f"soilbin: {summary['message']}", file=sys.stderr)
    if "exit_status" in summary:
        return summary["exit_status"]
    return 0 if summary["converged"] else 1


def _point(args):
    from ..errors import InputError
    from ..launcher import mpi_world
    from ..material_point.driver import material_table, run_point, split_overrides
    from .outdir import writable_on_rank0

    model_table, path_table = split_overrides(args.overrides)
    model, material, name = args.model, None, args.model
    if ":" in model:   # SCENE.toml:NAME
        material = model
        model, table = material_table(material)
        if model is None:
            raise InputError(f"{material}: the material has no 'model' key")
        model_table = {**table, **model_table}
        scene, _, material_name = material.rpartition(":")
        name = f"{Path(scene).stem}-{material_name}"
    out = args.out or Path("runs") / f"point-{name}-{args.path}"
    comm = mpi_world()   # under mpirun every rank drives the path, rank 0 writes and prints
    writable_on_rank0(comm, out, keep=False)   # made once the path is driven
    summary = run_point(model, model_table, args.path, path_table,
                        out if comm is None or comm.rank == 0 else None, material)
    if _rank0():
        _print_point(summary, out, args.json)
    return 0 if summary["converged"] else 1


def _print_point(summary, out, as_json):
    if as_json:
        print(json.dumps(summary))
    else:
        print(f"{summary['status']}: {summary['n_steps']} steps, {summary['newton_iterations']} "
              f"Newton iterations, {summary['cuts']} cuts; results in {out}", file=sys.stderr)
        final = summary["final"]
        print(f"q_peak = {summary['q_peak']:.6g} at p = {summary['p_at_q_peak']:.6g}; final "
              f"p = {final['p']:.6g}, q = {final['q']:.6g}, eps_v = {final['eps_v']:.6g}")
    if summary["message"]:
        print(f"soilbin: {summary['message']}", file=sys.stderr)


def _calibrate(args):
    from ..calibration.output import calibrate
    if args.jobs < 1:
        raise InputError(f"--jobs {args.jobs}: accepted: a positive number of processes")
    summary = calibrate(args.file, args.out, args.jobs)
    if _rank0():
        _print_calibration(summary, args.json)
    return 0 if summary["status"] == "converged" else 1


def _study(args):
    from .study import study_command
    return study_command(args)


#: Exit status of an error that is a bug, not bad input.
INTERNAL_ERROR = 3


def _quiet_logging():
    """Warnings and errors only, also while the JIT compiles (cffi sets the root logger's
    level to 0 for that; a handler's own level holds)."""
    logging.basicConfig(level=logging.WARNING)
    for handler in logging.getLogger().handlers:
        handler.setLevel(logging.WARNING)


def _one_line(err):
    return f"{type(err).__name__}: {' '.join(str(err).split())}"


def _save_traceback(out=None, rank=0):
    """Write the current exception's traceback to OUT/traceback.txt (else a temporary file)."""
    name = "traceback.txt" if rank == 0 else f"traceback-rank{rank}.txt"
    places = [Path(out) / name] if out else []
    places.append(Path(tempfile.gettempdir()) / f"soilbin-{os.getpid()}-{name}")
    for path in places:
        try:
            path.write_text(traceback.format_exc())
            return path
        except OSError:
            continue
    return "(not saved: no writable folder)"


def _rank0():
    mpi = sys.modules.get("mpi4py.MPI")
    return mpi is None or mpi.COMM_WORLD.rank == 0


def main(argv=None):
    _quiet_logging()
    argv = sys.argv[1:] if argv is None else list(argv)
    args = _parser(point_details="point" in argv).parse_args(argv)
    command = {"run": _run, "list": _list_scenes, "point": _point, "keys": _keys,
               "study": _study, "calibrate": _calibrate}[args.command]   # only run loads DOLFINx
    with interrupt.handlers():
        try:
            return command(args)
        except SoilbinError as err:
            if _rank0():
                print(f"soilbin: error: {err}", file=sys.stderr)
            return 2
        except interrupt.Interrupted as signal:
            if _rank0():
                print(f"soilbin: {signal}", file=sys.stderr)
            return signal.exit_status
        except BrokenPipeError:   # stdout closed early (soilbin keys SCENE | head)
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 0
        except Exception as err:
            print(f"soilbin: internal error: {_one_line(err)}; traceback in "
                  f"{_save_traceback(getattr(args, 'out', None))}", file=sys.stderr)
            return INTERNAL_ERROR


if __name__ == "__main__":
    sys.exit(main())
