"""Run a scene: mesh, problem, load stepping, outputs and the summary."""
import time

from mpi4py import MPI

from pathlib import Path

from . import figures
from .meshes import BUILDERS
from .output import RunFolder
from .problem import SoilProblem
from .scene import Headline
from .solver.stepping import run_load_steps


def headline_results(scene, records, area):
    """The scene's headline values, read off the converged steps."""
    if not records:
        return {key: None for key in scene.headline}
    read = {
        Headline.FINAL_DISPLACEMENT: lambda: records[-1].displacement,
        Headline.FINAL_FORCE: lambda: records[-1].force,
        Headline.FINAL_PRESSURE: lambda: records[-1].force / area,
        Headline.PEAK_FORCE: lambda: max(r.force for r in records),
        Headline.PEAK_PRESSURE: lambda: max(r.force for r in records) / area,
    }
    return {key: read[result.of]() / result.divide_by for key, result in scene.headline.items()}


def run_scene(scene, out_dir, comm=MPI.COMM_WORLD, progress=None, overrides=()):
    """Solve ``scene``, writing into ``out_dir``; returns the summary dict (``overrides``:
    the --set items the scene was loaded with, echoed in it)."""
    start = time.perf_counter()
    out_dir = Path(out_dir)
    tagged = BUILDERS[scene.mesh_builder].build(scene.mesh, comm)
    problem = SoilProblem(scene, tagged)
    folder = RunFolder(out_dir, problem, scene)
    setup_s = time.perf_counter() - start

    area = problem.area   # collective: every rank, before the steps

    def on_step(record):
        folder.add_step(record)
        if progress is not None:
            progress(record, area)

    loading = scene.loading
    result = run_load_steps(problem, loading.steps, loading.max_cuts, on_step)
    if result.complete:
        status = "complete"
    elif loading.until_collapse and result.steps:
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
        "converged": status != "failed",
        "message": result.message,
        "n_cells": tagged.mesh.topology.index_map(3).size_global,
        "n_dofs": problem.n_dofs,
        "n_ranks": comm.size,
        "n_steps": len(records),
        "load_factor": records[-1].load_factor if records else 0.0,
        "newton_iterations": sum(r.newton_iterations for r in records),
        "cuts": sum(r.cuts for r in records),
        "setup_s": round(setup_s, 3),
        "wall_s": round(time.perf_counter() - start, 3),
        **headline_results(scene, records, problem.area),
    }
    folder.finish(summary)
    if records and comm.rank == 0:
        figures.curve_png(records, scene, out_dir / "curve.png")
    if records and problem.tool is not None and problem.tool.interface is not None:
        figures.tool_section_png(problem, out_dir / "tool-section.png")
    return summary
