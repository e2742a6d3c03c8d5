"""Run a scene: mesh, problem, load stepping, outputs and the summary."""
import dataclasses
import sys
import time

from mpi4py import MPI

from ..closed_form import MODEL, NoWedge, narrow_tine_draft, passive_wedge_strength
from ..meshes import BUILDERS
from ..problem import SoilProblem
from ..records.scene import COLLAPSE_COMPLIANCE, Control, Headline
from ..solver.stepping import StepperResult, run_load_steps
from . import figures, figures_3d, interrupt, section_figures
from .insitu import check_initial_stress
from .outdir import prepare_on_rank0
from .output import RunFolder


def collapse_step(loads, displacements, reference=1):
    """Index of the first step (of curves starting at zero, not included) whose displacement
    increment per unit load increment is at least COLLAPSE_COMPLIANCE times the secant
    compliance displacements[reference] / loads[reference] (by default the first step's),
    or None."""
    compliance = displacements[reference] / loads[reference]
    for k in range(1, len(loads)):
        dp, dw = loads[k] - loads[k - 1], displacements[k] - displacements[k - 1]
        if dw >= COLLAPSE_COMPLIANCE * compliance * dp:
            return k
    return None


def collapse_pressure(records):
    """The pressure of the first step whose settlement increment per unit pressure increment
    is at least COLLAPSE_COMPLIANCE times the first step's, or None."""
    pressures = [0.0] + [r.columns["pressure"] for r in records]
    k = collapse_step(pressures, [0.0] + [r.displacement for r in records])
    return None if k is None else pressures[k]


def collapse_limit(scene):
    """Under force control with ``until_collapse``: the stepper's ``limit`` that ends the run
    at the first step whose travel per unit of applied load is COLLAPSE_COMPLIANCE times the
    secant compliance at the first nominal load step, 1/steps of the load (the soil's limit:
    the travel runs away), else None. Not the first step's own compliance: where that step
    was cut to a small fraction of the nominal one in a soil that is stiff only at first (a
    normally consolidated cap soil leaves its elastic range at about 1/1000 of the tine's
    draft), the compaction that follows would read as a runaway."""
    loading = scene.loading
    if loading.control is not Control.FORCE or not loading.until_collapse:
        return None
    nominal = loading.magnitude / loading.steps

    def limit(records):
        loads = [0.0] + [r.load_factor * loading.magnitude for r in records]
        reference = next((k for k, load in enumerate(loads) if load >= nominal * (1 - 1e-9)), None)
        displacements = [0.0] + [r.displacement for r in records]
        if reference is None or collapse_step(loads, displacements, reference) is None:
            return None
        last = records[-1]
        return (f"the soil's limit: at load {loads[-1]:.6g} the displacement per unit load of "
                f"step {last.step} is at least {COLLAPSE_COMPLIANCE:g} times the secant one at "
                f"load {loads[reference]:.6g} (displacement {last.displacement:.6g})")
    return limit


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


def run_scene(scene, out_dir, comm=MPI.COMM_WORLD, progress=None, overrides=()):
    """Solve ``scene``, writing into ``out_dir`` (checked writable and cleared of an older
    run before the mesh is built); returns the summary dict (``overrides``: the --set items
    the scene was loaded with, echoed in it). SIGINT or SIGTERM during the steps ends the
    run with status "interrupted" (summary written, no collective call after it)."""
    start, start_cpu = time.perf_counter(), time.process_time()
    out_dir = prepare_on_rank0(comm, out_dir)
    with interrupt.kept():
        tagged = BUILDERS[scene.mesh_builder].build(scene.mesh, comm)
    check_initial_stress(scene, tagged)
    problem = SoilProblem(scene, tagged)
    folder = RunFolder(out_dir, problem, scene)
    setup_s = time.perf_counter() - start

    stops = scene.output.stops(scene.loading)
    sections = problem.tool is not None and not problem.disc.planar   # cuts through the soil

    def on_step(record):
        folder.add_step(record)
        if sections and any(abs(record.load_factor - s) < 1e-9 for s in stops):
            load = record.load_factor * scene.loading.magnitude
            section_figures.sections_png(problem, scene, load, out_dir / f"sections-{load:g}.png")
        if progress is not None:
            progress(record)

    loading = scene.loading
    interrupted = None
    try:
        result = run_load_steps(problem, loading.steps, loading.max_cuts, on_step, stops=stops,
                                limit=collapse_limit(scene), first_cuts=loading.first_cuts)
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
