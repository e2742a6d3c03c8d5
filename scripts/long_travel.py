"""The 2-in tool's long travel against the mesh: studies/tine-long-travel.toml (the cap soil)
or, with --study tine-long-clay-paths, studies/tine-long-clay-paths.toml (the undrained clay
along three paths of remeshes on each of its meshes), with --study tine-long-cap-W,
studies/tine-long-cap-W.toml (the cap soil toward 12 in against its largest compaction W);
their tables in docs/chapter8.md.

Runs `soilbin study studies/STUDY.toml` (resumable), then reads each case's summary.json,
curve.csv and remeshes.csv and writes between the STUDY markers of docs/chapter8.md (--page)
two tables (where a mesh was run along several paths of remeshes, first the drafts over them,
mean and range, and the fit of the draft over the last half against the cells' size): per
element and mesh the draft at each inch of the scene's travel, the lift at the end, the draft
over the last sixth of the travel (mean, spread and slope) and over its last half (mean and
slope: the remeshes cut teeth into the curve); and what the travel cost (cells, remeshes and
how many of them were smoothed or meshed afresh around the poor cells alone, steps, Newton
iterations, wall time, a remesh against a Newton iteration, the plastic work's change by each
transfer, and the draft a fresh, a local and a smoothed mesh took off).
A case that failed (a remesh that could not be made) or was interrupted shows how far it went,
and each case how many of its remeshes failed (each tried again after the next step).
Copies the study's figures into docs/figures (--figures DIR). Loads in lb, travel in in.
"""
import shutil
from types import SimpleNamespace

import numpy as np

from soilbin.app.plateau import steady_force, steady_slope
from soilbin.app.study import Outcome, draw_figures, load_study
from soilbin.records.scene import load_scene
from soilbin.remesh.remesher import FRESH, LOCAL, MOVED
from doc_tables import ROOT, write_between_markers
from study_tables import arguments, at, finished, remeshes, run_study

STUDIES = ("tine-long-travel", "tine-long-clay-paths", "tine-long-cap-W")
SIZE = "mesh.element_size"
ELEMENT = "analysis.element"
#: The value that sets a case's path of remeshes and nothing else.
PATH = "remesh.min_quality"


def mesh_of(case, scene):
    """'element | element size' of a case, the scene's own marked, and what else the case
    sets (the threshold of a remesh, say)."""
    element = case.values.get(ELEMENT, scene.analysis.element.value)
    size = case.values.get(SIZE, scene.mesh.element_size)
    own = element == scene.analysis.element.value and size == scene.mesh.element_size
    others = [f"`{key} = {value:g}`" for key, value in case.values.items()
              if key not in (ELEMENT, SIZE)]
    return (f"`{element}` | {size:g}" + (" (the scene's)" if own else "")
            + "".join(f", {other}" for other in others))


def drafts(results, scene):
    travels = np.arange(1.0, scene.loading.magnitude + 1e-9)   # each inch
    lines = ["| element | element size [in] | travel [in] (status) | "
             + " | ".join(f"draft at {t:g} in [lb]" for t in travels)
             + " | lift at the end [lb] | draft over the last sixth of the travel [lb] | its spread "
             "| its slope [lb/in] | draft over the last half [lb] | its slope [lb/in] |",
             "| --- | --- | --- | " + "--- | " * (len(travels) + 6)]
    for case, summary, rows, _ in results:
        cells = [f"{d:.1f}" if (d := at(rows, "force", t)) is not None else "–" for t in travels]
        records = [SimpleNamespace(**row) for row in rows]
        lines.append(f"| {mesh_of(case, scene)} | {rows[-1]['displacement']:.2f} "
                     f"({_status(summary)}) | "
                     + " | ".join(cells) + f" | {rows[-1]['lift']:.1f} | "
                     f"{summary['steady_draft']:.1f} | {100 * summary['steady_spread']:.1f}% | "
                     f"{steady_slope(records):.0f} | {steady_force(records, 0.5):.1f} | "
                     f"{steady_slope(records, 0.5):.1f} |")
    return "\n".join(lines)


#: The travel over which :func:`with_heave` fits the slopes [in]: where every case has gone.
RISE = (4.0, 6.0)


def with_heave(results, scene):
    """Per case whose curve.csv has the heave: the heave at each second inch, and the slopes
    of the straight lines fitted to the draft and to the heave over :data:`RISE` (the curves
    between the steps taken as straight, sampled evenly); '' if none has it."""
    results = [r for r in results if "heave" in r[2][0]]
    if not results:
        return ""
    travels = np.arange(2.0, scene.loading.magnitude + 1e-9, 2.0)
    low, high = RISE
    lines = ["| element | element size [in] | "
             + " | ".join(f"heave at {t:g} in [in]" for t in travels)
             + f" | the draft's slope over {low:g}–{high:g} in [lb/in] | the heave's [in/in] |",
             "| --- | --- | " + "--- | " * (len(travels) + 2)]
    for case, _, rows, _ in results:
        heaves = [f"{h:.2f}" if (h := at(rows, "heave", t)) is not None else "–"
                  for t in travels]
        slopes = [_slope(rows, "force", low, high), _slope(rows, "heave", low, high)]
        slopes = [f"{v:.{digits}f}" if v is not None else "–"
                  for v, digits in zip(slopes, (0, 2))]
        lines.append(f"| {mesh_of(case, scene)} | " + " | ".join(heaves + slopes) + " |")
    return "\n".join(lines)


def _slope(rows, column, low, high):
    """The slope of the straight line fitted to a column over the travel from low to high,
    or None if the curve stops short of high."""
    if at(rows, column, high) is None:
        return None
    d = np.array([r["displacement"] for r in rows])
    x = np.linspace(low, high, 201)
    return float(np.polyfit(x, np.interp(x, d, [r[column] for r in rows]), 1)[0])


def costs(results, scene):
    lines = ["| element | element size [in] | cells at the start → the end | unknowns at the end | "
             "remeshes (smoothed, local) | steps (cuts) | Newton (failed) | wall time [min] | "
             "wall time per Newton iteration [s] | a remesh and its transfer [s] | "
             "its re-equilibration [s] | the plastic work's change by a transfer | "
             "draft lost at a fresh mesh / a local one / a smoothed one |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for case, summary, _, remeshed in results:
        iterations = summary["newton_iterations"] + summary["failed_newton_iterations"]
        per_iteration = summary["wall_s"] / iterations
        first = int(remeshed[0]["cells_before"]) if remeshed else summary["n_cells"]
        if remeshed:
            moved = [r["mesh_s"] + r["transfer_s"] for r in remeshed]
            settled = [r["equilibrium_s"] for r in remeshed]
            iterations_worth = sum(moved) / len(moved) / per_iteration
            remesh = f"{min(moved):.1f}–{max(moved):.1f} ({iterations_worth:.1f} iterations)"
            equilibrium = f"{min(settled):.0f}–{max(settled):.0f}"
            work = [100 * r["plastic_work_change"] for r in remeshed]
            work = f"{min(work):+.1f}% to {max(work):+.1f}%"
            lost = " / ".join(_lost([r for r in remeshed if _kept(r) == kept])
                              for kept in (FRESH, LOCAL, MOVED))
        else:
            remesh = equilibrium = work = lost = "–"
        smoothed, local = (sum(_kept(r) == kept for r in remeshed) for kept in (MOVED, LOCAL))
        lines.append(f"| {mesh_of(case, scene)} | {first} → {summary['n_cells']} | "
                     f"{summary['n_dofs']} | {len(remeshed)} ({smoothed}, {local}) | "
                     f"{summary['n_steps']} "
                     f"({summary['cuts']}) | {summary['newton_iterations']} "
                     f"({summary['failed_newton_iterations']}) | {summary['wall_s'] / 60:.0f} | "
                     f"{per_iteration:.2f} | {remesh} | {equilibrium} | {work} | {lost} |")
    return "\n".join(lines)


def over_paths(results, scene):
    """Per mesh run along several paths of remeshes (cases that differ in :data:`PATH` alone):
    the draft at 2 and 4 in and over the last half and the last sixth of the travel, each as
    the mean over the paths that got there and their range; '' where no mesh has two paths."""
    groups = {}
    for case, summary, rows, _ in results:
        mesh = (case.values.get(ELEMENT, scene.analysis.element.value),
                case.values.get(SIZE, scene.mesh.element_size),
                tuple(sorted((key, value) for key, value in case.values.items()
                             if key not in (ELEMENT, SIZE, PATH))))
        groups.setdefault(mesh, []).append((summary, rows))
    if all(len(paths) < 2 for paths in groups.values()):
        return ""
    travel = scene.loading.magnitude
    lines = ["| element | element size [in] | paths (to the end) | draft at 2 in [lb] | "
             "draft at 4 in [lb] | draft over the last half [lb] | "
             "draft over the last sixth [lb] |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for (element, size, _), paths in groups.items():
        ended = [(summary, rows) for summary, rows in paths if _ended(rows, travel)]
        halves = [_last_half(rows) for _, rows in ended]
        sixths = [summary["steady_draft"] for summary, _ in ended]
        cells = [_mean_range([at(rows, "force", t) for _, rows in paths]) for t in (2.0, 4.0)]
        lines.append(f"| `{element}` | {size:g} | {len(paths)} ({len(ended)}) | "
                     + " | ".join(cells + [_mean_range(halves), _mean_range(sixths)]) + " |")
    return "\n".join(lines)


#: The orders of D = D_inf + C h^p fitted besides p = 1, with their names (:func:`mesh_limit`).
OTHER_ORDERS = {0.5: "√h", 2.0: "h²"}


def mesh_limit(results, scene):
    """The steady draft (over the last half) of every path that reached the end against its
    cells' size h at the blade, fitted by least squares with D = D_inf + C h^p: p = 1 with
    the standard error of D_inf (the paths of one mesh are its samples, their spread the
    scatter the error carries), and D_inf with p = 0.5 and 2, to show how far the limit hangs
    on an order that the paths' scatter does not fix. '' with fewer than two meshes or than
    four paths."""
    travel = scene.loading.magnitude
    levels = [(case.values.get(SIZE, scene.mesh.element_size), _last_half(rows))
              for case, _, rows, _ in results if _ended(rows, travel)]
    h, draft = np.array(levels).T if levels else (np.empty(0), np.empty(0))
    if len(np.unique(h)) < 2 or len(h) < 4:
        return ""
    limit, slope, scatter, error = _power_fit(h, draft, 1.0)
    others = [_power_fit(h, draft, p) for p in OTHER_ORDERS]
    return (f"D = D∞ + C h through the draft over the last half of the {len(h)} paths that "
            f"reached {travel:g} in on {len(np.unique(h))} meshes (h = "
            f"{', '.join(f'{size:g}' for size in sorted(set(h), reverse=True))} in), by least "
            f"squares: D∞ = {limit:.1f} ± {error:.1f} lb (one standard error), C = {slope:.1f} "
            f"lb/in, the paths about the line ±{scatter:.1f} lb (rms). With "
            + " or ".join(OTHER_ORDERS.values()) + " instead of h: D∞ = "
            + " or ".join(f"{fit[0]:.1f} lb (±{fit[2]:.1f} lb rms)" for fit in others) + ".")


def _power_fit(h, draft, order):
    """D_inf, C, the rms of the residuals and the standard error of D_inf of the least-squares
    fit D = D_inf + C h^order."""
    design = np.column_stack([np.ones_like(h), h**order])
    (limit, slope), residual, _, _ = np.linalg.lstsq(design, draft, rcond=None)
    variance = residual[0] / (len(h) - 2) * np.linalg.inv(design.T @ design)
    return limit, slope, np.sqrt(residual[0] / len(h)), np.sqrt(variance[0, 0])


def _ended(rows, travel):
    """Whether a curve reached the scene's whole travel."""
    return rows[-1]["displacement"] >= travel * (1.0 - 1e-9)


def _last_half(rows):
    """The draft over the last half of a curve's travel."""
    return steady_force([SimpleNamespace(**row) for row in rows], 0.5)


def _mean_range(values):
    """'mean (low–high, ±half the range in % of the mean)' of the values that are not None."""
    values = [v for v in values if v is not None]
    if not values:
        return "–"
    mean = float(np.mean(values))
    if len(values) == 1:
        return f"{mean:.1f}"
    low, high = min(values), max(values)
    return f"{mean:.1f} ({low:.1f}–{high:.1f}, ±{50 * (high - low) / mean:.1f}%)"


def _status(summary):
    """A run's status and how many of its remeshes failed (each tried again after the next
    step), where any did."""
    failed = summary.get("remeshes_failed", 0)
    return summary["status"] + (f"; {failed} remesh{'es' * (failed > 1)} failed" if failed else "")


def _kept(remesh):
    """How much of the old mesh a remesh (a row of remeshes.csv) kept."""
    return MOVED if remesh["smoothed"] else LOCAL if remesh["local"] else FRESH


def _lost(remeshed):
    """The range of the draft a remesh took off, in percent of the draft before it (one
    number where all round alike)."""
    if not remeshed:
        return "–"
    lost = [100 * (1 - r["force_after"] / r["force_before"]) for r in remeshed]
    low, high = f"{min(lost):.1f}", f"{max(lost):.1f}"
    return f"{low}%" if low == high else f"{low}–{high}%"


def main():
    args = arguments(__doc__, STUDIES[0], "chapter8.md", STUDIES)
    path = ROOT / "studies" / f"{args.study}.toml"
    run_study(path, args)
    study = load_study(path)
    results = [(case, summary, rows, remeshes(args.out / case.name))
               for case, summary, rows in finished(study, args.out, interrupted=True) if rows]
    if not results:
        raise SystemExit(f"{args.out}: no finished case")
    scene = load_scene(study.scene_path)
    results.sort(key=lambda r: (r[0].values.get(ELEMENT, ""), -r[0].values.get(SIZE, 0.0)))
    summary = over_paths(results, scene)
    limit = mesh_limit(results, scene) if summary else ""
    text = ("\n\n".join(filter(None, [summary, limit, drafts(results, scene),
                                        with_heave(results, scene), costs(results, scene)]))
            + "\n")
    print(text)
    draw_figures(study, [Outcome(case, summary["status"], summary, ran=False)
                         for case, summary, _, _ in results], args.out)
    for figure in study.figures:
        shutil.copy(args.out / f"{figure.name}.png", args.figures / f"{figure.name}.png")
    write_between_markers(args.page, args.study, text)


if __name__ == "__main__":
    main()
