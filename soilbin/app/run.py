"""Run a scene: mesh, problem, load stepping, outputs and the summary."""
import dataclasses
import gc
import shutil
import sys
import time
from pathlib import Path

from mpi4py import MPI

from ..closed_form import NoWedge
from ..errors import InputError, ReturnMapError
from ..layout import CellLayout
from ..meshes import scene_mesh
from ..problem import SoilProblem
from ..records.scene import Control, Headline, LineSearch
from ..remesh import RemeshError, Remeshing
from ..remesh.mesher import read_mesh
from ..solver.ahead import compiled_ahead
from ..solver.stepping import StepperResult, run_load_steps
from . import checkpoint, figures, figures_3d, interrupt, section_figures
from .collapse import collapse_pressure, stepping
from .estimates import blade_of, draft_estimates
from .insitu import check_initial_stress
from .outdir import prepare_on_rank0
from .output import RunFolder
from .plateau import steady_force, steady_slope, steady_spread



class _Current:
    """The load stepper's problem: the run's, which a remesh replaces."""

    def __init__(self, problem):
        self.problem = problem

    def __getattr__(self, name):
        return getattr(self.problem, name)


def resumed_mesh(comm, earlier, out_dir, dimension):
    """The remeshed mesh (of ``dimension``) a checkpoint was on, read from its run folder and
    copied into this run's (so that this run can be resumed in turn)."""
    source = Path(earlier.folder) / earlier.mesh["file"]
    if comm.rank == 0:
        target = Path(out_dir) / earlier.mesh["file"]
        target.parent.mkdir(exist_ok=True)
        shutil.copyfile(source, target)
    return read_mesh(comm, source, earlier.mesh["regions"], earlier.mesh["boundaries"],
                     dimension)


def folded_at_step(records):
    """The first step after which a cell of the moving mesh had folded over, or None."""
    return next((r.step for r in records if r.columns.get("mesh_quality", 1.0) <= 0.0), None)


def mesh_quality_results(records):
    """The least scaled Jacobian of the mesh over the steps (the mesh moves in large
    deformation, :mod:`soilbin.problem.mesh_quality`) and the step where a cell first
    folded over; nothing when the mesh does not move."""
    qualities = [r.columns["mesh_quality"] for r in records if "mesh_quality" in r.columns]
    if not qualities:
        return {}
    return {"mesh_quality": min(qualities), "folded_at_step": folded_at_step(records)}


def headline_results(scene, records, at_limit=False):
    """The scene's headline values, read off the converged steps (the pressure: the curve's,
    over the loaded boundary's current area); ``at_limit``: the run ended at the soil's limit
    (status "collapse")."""
    if not records:
        return {key: None for key in scene.headline}
    read = {
        Headline.FINAL_DISPLACEMENT: lambda: records[-1].displacement,
        Headline.FINAL_FORCE: lambda: records[-1].force,
        Headline.FINAL_PRESSURE: lambda: records[-1].columns["pressure"],
        Headline.PEAK_FORCE: lambda: max(r.force for r in records),
        Headline.PEAK_PRESSURE: lambda: max(r.columns["pressure"] for r in records),
        Headline.COLLAPSE_PRESSURE: lambda: collapse_pressure(records, 1.0 / scene.loading.steps,
                                                              at_limit),
        Headline.FINAL_LIFT: lambda: records[-1].columns["lift"],
        Headline.STEADY_FORCE: lambda: steady_force(records),
        Headline.STEADY_SPREAD: lambda: steady_spread(records),
        Headline.STEADY_SLOPE: lambda: steady_slope(records),
    }
    values = {key: read[result.of]() for key, result in scene.headline.items()}
    return {key: None if value is None else value / scene.headline[key].divide_by
            for key, value in values.items()}


def _checked_problem(scene, tagged, check):
    """The scene's problem on ``tagged``, and (``check``) its in-situ stress checked against
    the yield surfaces after the problem's forms are built (they compile while the kernels
    do, :mod:`soilbin.solver.ahead`); a first update that fails on an in-situ stress outside
    them is reported as that."""
    try:
        problem = SoilProblem(scene, tagged)
    except ReturnMapError:
        if check:
            check_initial_stress(scene, tagged)
        raise
    if check:
        check_initial_stress(scene, tagged)
    return problem


def run_scene(scene, out_dir, comm=MPI.COMM_WORLD, progress=None, overrides=(), resume=None,
              iterate_progress=None, remesh_progress=None):
    """Solve ``scene``, writing into ``out_dir`` (checked writable and cleared of an older
    run before the mesh is built); returns the summary dict (``overrides``: the --set items
    the scene was loaded with, echoed in it). ``progress(record)`` is called after each
    converged step, ``iterate_progress(iteration, residual, target)`` at each Newton
    iterate, ``remesh_progress(report)`` after a step's remesh. ``resume``: a stopped run's
    folder to go on from (its checkpoint, ``app.checkpoint``). SIGINT or SIGTERM during the
    steps ends the run with status "interrupted" (summary written, no collective call after
    it). The models' kernels compile (or load from numba's cache) in a thread meanwhile
    (:mod:`soilbin.solver.ahead`)."""
    models = [scene.materials[material] for material in dict.fromkeys(scene.regions.values())]
    with compiled_ahead(models, scene.tool and scene.tool.law):
        return _run(scene, out_dir, comm, progress, overrides, resume, iterate_progress,
                    remesh_progress)


def _run(scene, out_dir, comm, progress, overrides, resume, iterate_progress, remesh_progress):
    """:func:`run_scene`'s run."""
    start, start_cpu = time.perf_counter(), time.process_time()
    if resume is not None and Path(resume).resolve() == Path(out_dir).resolve():
        raise InputError(f"--resume {resume}: give the resumed run another --out (this "
                         "folder keeps the steps before the resume)")
    earlier = checkpoint.read(resume, scene) if resume is not None else None
    out_dir = prepare_on_rank0(comm, out_dir)
    remeshing = Remeshing(scene, out_dir) if scene.remesh.active else None
    remeshed = earlier is not None and earlier.mesh is not None
    with interrupt.kept():
        tagged = (scene_mesh(scene, comm) if not remeshed else
                  resumed_mesh(comm, earlier, out_dir, scene.analysis.element.dimension))
    # a remeshed soil has risen above its ground level: its state is stored, not checked
    problem = _checked_problem(scene, tagged, check=not remeshed)
    problem.newton.on_iterate = iterate_progress
    if remeshed:   # the remeshed mesh as made, then moved by the steps after the remesh
        remeshing.restore(earlier.remeshing_state(), earlier.mesh["file"], CellLayout(problem))
        earlier.restore(problem, remeshing.layout)
    folder = RunFolder(out_dir, problem, scene, initial_frame=not remeshed)
    checkpoints = checkpoint.Checkpoints(out_dir, problem, scene, remeshing)
    if remeshed:
        checkpoints.remeshed(problem)
    elif earlier is not None:
        earlier.restore(problem)
        if remeshing is not None:
            remeshing.restore(earlier.remeshing_state(), None, None)
    if earlier is not None:
        folder.add_earlier(earlier.records)
    setup_s = time.perf_counter() - start
    stepped = _Current(problem)

    stops = scene.output.stops(scene.loading)
    sections = problem.tool is not None and not problem.disc.planar   # cuts through the soil

    def on_step(record):
        folder.add_step(record)
        remeshed = None
        if remeshing is not None:
            remeshing.check_folding(stepped.problem, record)
        if remeshing is not None and remeshing.due(record):   # the step ends on the new mesh
            old = stepped.problem
            try:
                stepped.problem = remeshing.remesh(old, record)
            except RemeshError as err:
                if not remeshing.goes_on():
                    raise
                if comm.rank == 0:
                    print(f"soilbin: warning: {err}; the run goes on on the old mesh and tries "
                          f"again after the next step ({remeshing.failures} failed so far)",
                          file=sys.stderr)
            else:
                old.destroy()
                remeshed = remeshing.reports[-1]
                folder.remeshed(stepped.problem, remeshed)
                checkpoints.remeshed(stepped.problem)
            finally:
                # the rest of the problem a remesh replaced (or made and gave up), held in
                # reference cycles that Python's full collection reaches seldom: without
                # this and the destroy, the clay's 0.5-in mesh held 11.6 GB after 64 remeshes
                gc.collect()
        checkpoints.write(folder.records)
        if comm.rank == 0 and record.step == folded_at_step(folder.records):
            print(f"soilbin: warning: step {record.step}: a cell of the mesh has folded over "
                  f"(least scaled Jacobian {record.columns['mesh_quality']:.3g}); the results "
                  f"from here on are not to be trusted: refine the mesh where it distorts",
                  file=sys.stderr)
        if sections and any(abs(record.load_factor - s) < 1e-9 for s in stops):
            load = record.load_factor * scene.loading.magnitude
            section_figures.sections_png(stepped.problem, scene, load,
                                         out_dir / f"sections-{load:g}.png")
        if progress is not None:
            progress(record)
        if remeshed is not None and remesh_progress is not None:
            remesh_progress(remeshed)

    loading = scene.loading
    interrupted = None
    try:
        result = run_load_steps(stepped, on_step=on_step, stops=stops, resume=folder.records,
                                **stepping(scene))
    except interrupt.Interrupted as signal:
        interrupted = signal
        result = StepperResult(tuple(folder.records), False,
                               f"{signal}; the converged steps are in {out_dir}")
    except RemeshError as err:
        result = StepperResult(tuple(folder.records), False,
                               f"{err}; the converged steps and the last good mesh are in "
                               f"{out_dir}")
    problem = stepped.problem
    if interrupted is not None:
        status = "interrupted"
    elif result.complete:
        status = "complete"
    elif result.limit_reached or (loading.until_collapse and result.steps):
        status = "collapse"
    else:
        status = "failed"
    message = result.message + (line_search_hint(scene) if status == "failed" and result.stalled
                                 else "")
    records = result.steps
    summary = {
        "scene": scene.name,
        "title": scene.title,
        "units": scene.units,
        "overrides": list(overrides),
        **({"resumed_from": str(resume), "resumed_after_step": len(earlier.records)}
           if earlier is not None else {}),
        "status": status,
        "converged": status in ("complete", "collapse"),
        "message": message,
        "n_cells": problem.mesh.topology.index_map(problem.mesh.topology.dim).size_global,
        "n_dofs": problem.n_dofs,
        "n_ranks": comm.size,
        "n_steps": len(records),
        "load_factor": records[-1].load_factor if records else 0.0,
        "newton_iterations": sum(r.newton_iterations for r in records),
        "failed_newton_iterations": sum(r.failed_iterations for r in records),
        "cuts": sum(r.cuts for r in records),
        "linear_solver": problem.newton.linear.description,
        "setup_s": round(setup_s, 3),
        "wall_s": round(time.perf_counter() - start, 3),
        "cpu_s": round(time.process_time() - start_cpu, 3),
        **headline_results(scene, records, at_limit=status == "collapse"),
        **mesh_quality_results(records),
        **({} if remeshing is None else {"remeshes": remeshing.count,
                                          "remeshes_failed": remeshing.failures}),
    }
    try:
        estimates = draft_estimates(scene, blade_of(scene, problem))
    except NoWedge as err:
        estimates = []
        if comm.rank == 0:
            print(f"soilbin: note: {err}", file=sys.stderr)
    for key, estimate in zip(("draft_estimate", "draft_estimate_material"), estimates):
        summary[key] = dataclasses.asdict(estimate)
    if interrupted is not None:
        summary["signal"] = interrupted.name
        summary["exit_status"] = interrupted.exit_status
    folder.finish(summary, interrupted=interrupted is not None)
    if records and comm.rank == 0:
        figures.curve_png(records, scene, out_dir / "curve.png", estimates)
    if interrupted is None and records and sections:
        failure = figures.tool_section_png(problem, out_dir / "tool-section.png")
        if failure:
            print(f"soilbin: warning: tool-section.png not drawn: {failure}", file=sys.stderr)
    picture = folder.fields.picture() if folder.fields is not None and comm.rank == 0 else None
    if interrupted is None and records and picture is not None:
        failure = figures_3d.draw_in_subprocess(*picture, scene.unit_system.length,
                                                out_dir / "soil-3d.png",
                                                to_scale=problem.moves_mesh)
        if failure:
            print(f"soilbin: warning: soil-3d.png not drawn: {failure}", file=sys.stderr)
    return summary


def line_search_hint(scene):
    """What a run that failed with the smallest increment under the backtracking line search
    may try (docs/theory.md, *Line searches*); '' where that does not apply."""
    if (scene.solver.line_search is not LineSearch.BACKTRACKING
            or scene.loading.control is Control.INDIRECT):
        return ""
    return ("; --set solver.line_search=cp may get past it (the line search to the energy's "
            "stationary point along the Newton step goes on where the residual norm rises "
            "along steps that lower the energy, as on a nearly incompressible soil)")
