"""Run a scene: mesh, problem, load stepping, outputs and the summary."""
import dataclasses
import sys
import time
from pathlib import Path

from mpi4py import MPI

from ..closed_form import MODEL, NoWedge, narrow_tine_draft, passive_wedge_strength
from ..errors import InputError
from ..meshes import BUILDERS
from ..problem import SoilProblem
from ..records.scene import Headline
from ..solver.stepping import StepperResult, run_load_steps
from . import checkpoint, figures, figures_3d, interrupt, section_figures
from .collapse import collapse_limit, collapse_pressure
from .insitu import check_initial_stress
from .outdir import prepare_on_rank0
from .output import RunFolder


def headline_results(scene, records):
    """The scene's headline values, read off the converged steps (the pressure: the curve's,
    over the loaded boundary's current area)."""
    if not records:
        return {key: None for key in scene.headline}
    read = {
        Headline.FINAL_DISPLACEMENT: lambda: records[-1].displacement,
        Headline.FINAL_FORCE: lambda: records[-1].force,
        Headline.FINAL_PRESSURE: lambda: records[-1].columns["pressure"],
        Headline.PEAK_FORCE: lambda: max(r.force for r in records),
        Headline.PEAK_PRESSURE: lambda: max(r.columns["pressure"] for r in records),
        Headline.COLLAPSE_PRESSURE: lambda: collapse_pressure(records),
        Headline.FINAL_LIFT: lambda: records[-1].columns["lift"],
    }
    values = {key: read[result.of]() for key, result in scene.headline.items()}
    return {key: None if value is None else value / scene.headline[key].divide_by
            for key, value in values.items()}


def draft_estimate(scene):
    """McKyes & Ali draft of the whole tool (a soil_bin scene with gravity), or None: one
    side crescent against the bin's glass wall, two when embedded. The soil's c, phi are
    its own or, for a cap model, its failure surface's at the passive wedge's stress level
    (closed_form.equivalent_strength). A bonded tool is fully rough: delta = phi, c_a = c."""
    if scene.mesh_builder != "soil_bin" or scene.tool is None or scene.geostatic is None:
        return None
    soil, mesh = scene.materials[scene.regions["soil"]], scene.mesh
    gamma = scene.geostatic.unit_weight
    if hasattr(soil, "failure"):
        strength = passive_wedge_strength(soil.failure, gamma, mesh.tool_depth)
        phi, c, source = strength.phi, strength.c, f"failure surface at I1 = {strength.I1:.3g}"
    elif hasattr(soil, "phi") and hasattr(soil, "c"):
        phi, c, source = soil.phi, soil.c, "material"
    else:
        return None
    interface = scene.tool.interface
    delta, c_a = (phi, c) if scene.tool.bonded else (interface.delta, interface.c_a)
    try:
        return narrow_tine_draft(width=mesh.tool_width, depth=mesh.tool_depth, rake=mesh.rake_angle,
                                 phi=phi, delta=delta, gamma=gamma, c=c, c_a=c_a,
                                 crescents=2 if mesh.tool_share < 1.0 else 1, strength=source)
    except NoWedge as err:
        raise NoWedge(f"no {MODEL} estimate: {err} (phi = {phi:.3g} from the {source}, "
                      f"delta = {delta:.3g})") from None


def run_scene(scene, out_dir, comm=MPI.COMM_WORLD, progress=None, overrides=(), resume=None,
              iterate_progress=None):
    """Solve ``scene``, writing into ``out_dir`` (checked writable and cleared of an older
    run before the mesh is built); returns the summary dict (``overrides``: the --set items
    the scene was loaded with, echoed in it). ``progress(record)`` is called after each
    converged step, ``iterate_progress(iteration, residual, target)`` at each Newton
    iterate. ``resume``: a stopped run's folder to go on from (its checkpoint,
    ``app.checkpoint``). SIGINT or SIGTERM during the steps ends the run with status
    "interrupted" (summary written, no collective call after it)."""
    start, start_cpu = time.perf_counter(), time.process_time()
    if resume is not None and Path(resume).resolve() == Path(out_dir).resolve():
        raise InputError(f"--resume {resume}: give the resumed run another --out (this "
                         "folder keeps the steps before the resume)")
    earlier = checkpoint.read(resume, scene) if resume is not None else None
    out_dir = prepare_on_rank0(comm, out_dir)
    with interrupt.kept():
        tagged = BUILDERS[scene.mesh_builder].build(scene.mesh, comm)
    check_initial_stress(scene, tagged)
    problem = SoilProblem(scene, tagged)
    problem.newton.on_iterate = iterate_progress
    folder = RunFolder(out_dir, problem, scene)
    checkpoints = checkpoint.Checkpoints(out_dir, problem, scene)
    if earlier is not None:
        earlier.restore(problem)
        folder.add_earlier(earlier.records)
    setup_s = time.perf_counter() - start

    stops = scene.output.stops(scene.loading)
    sections = problem.tool is not None and not problem.disc.planar   # cuts through the soil

    def on_step(record):
        folder.add_step(record)
        checkpoints.write(folder.records)
        if sections and any(abs(record.load_factor - s) < 1e-9 for s in stops):
            load = record.load_factor * scene.loading.magnitude
            section_figures.sections_png(problem, scene, load, out_dir / f"sections-{load:g}.png")
        if progress is not None:
            progress(record)

    loading = scene.loading
    interrupted = None
    try:
        result = run_load_steps(problem, loading.steps, loading.max_cuts, on_step, stops=stops,
                                limit=collapse_limit(scene), first_cuts=loading.first_cuts,
                                resume=folder.records)
    except interrupt.Interrupted as signal:
        interrupted = signal
        result = StepperResult(tuple(folder.records), False,
                               f"{signal}; the converged steps are in {out_dir}")
    if interrupted is not None:
        status = "interrupted"
    elif result.complete:
        status = "complete"
    elif result.limit_reached or (loading.until_collapse and result.steps):
        status = "collapse"
    else:
        status = "failed"
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
        "message": result.message,
        "n_cells": tagged.mesh.topology.index_map(tagged.mesh.topology.dim).size_global,
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
        **headline_results(scene, records),
    }
    try:
        estimate = draft_estimate(scene)
    except NoWedge as err:
        estimate = None
        if comm.rank == 0:
            print(f"soilbin: note: {err}", file=sys.stderr)
    if estimate is not None:
        summary["draft_estimate"] = dataclasses.asdict(estimate)
    if interrupted is not None:
        summary["signal"] = interrupted.name
        summary["exit_status"] = interrupted.exit_status
    folder.finish(summary, interrupted=interrupted is not None)
    if records and comm.rank == 0:
        figures.curve_png(records, scene, out_dir / "curve.png", estimate)
    if interrupted is None and records and sections:
        figures.tool_section_png(problem, out_dir / "tool-section.png")
    picture = folder.fields.picture() if folder.fields is not None and comm.rank == 0 else None
    if interrupted is None and records and picture is not None:
        failure = figures_3d.draw_in_subprocess(*picture, scene.units, out_dir / "soil-3d.png")
        if failure:
            print(f"soilbin: warning: soil-3d.png not drawn: {failure}", file=sys.stderr)
    return summary
