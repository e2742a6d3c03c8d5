"""Run time against error: the strip footing against (2 + pi) c, the tine's draft, a large tine.

Each case runs in its own process (``--case``), serially, and reports its CPU
time (``time.process_time``: set-up = mesh, spaces, form compilation; solve
= the load steps), its peak memory, load steps, Newton iterations of
converged steps and of attempts that were cut, the linear solver, and the
CPU time per Newton iteration of its parts. Errors are against closed forms
evaluated from the scene: the rigid footing's limit pressure and the strip
load's collapse pressure against (2 + pi) c, the block's collapse stress
against 2c cos(phi) / (1 - sin(phi)), the column's settlement against pL/M;
the tine reports its draft at the final travel (no closed form).

The results go to ``runs/benchmark/results.json`` and ``results.md``, and
between the benchmark markers of docs/performance.md (--page PATH; a run of
--quick or --only without --update writes no page unless --page names one;
--update keeps the page's rows of the cases it does not run).
"""
import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

from doc_tables import DOCS, ROOT, add_page_argument, write_between_markers
from soilbin.closed_form.verification import (column_settlement, prandtl_limit_pressure,
                                              unconfined_strength)

PAGE = DOCS / "performance.md"   # the page of a run of every case

FOOTING, COLUMN, TINE = "strip-footing-von-mises", "column-elastic", "tine-2in-90deg"
STRIP_LOAD, BLOCK, CAD_TINE = "strip-load-von-mises", "block-drucker-prager", "tine-2in-cad"
#: The tine's mesh levels of docs/chapter8.md, *The tine's draft against the mesh*: (element
#: size next to the blade [in], growth away from it); the scene's own mesh is "tine, refine=1".
TINE_LEVELS = ((1.0, 1.3), (0.75, 1.3), (0.5, 1.3), (0.35, 1.3))


#: The footing scene's problem on the one-hex slab of hex8-bbar: the same solution as on the
#: two-dimensional mesh, at three times the unknowns.
SLAB = ["mesh.dimension=3", "analysis.element=hex8-bbar"]
#: The strip load under indirect displacement control, to 0.1 in of mean settlement.
INDIRECT = ["loading.control=indirect_displacement", "loading.until_collapse=false",
            "loading.magnitude=0.1"]
#: The tine case's blade read from its STEP file (scenes/tine-2in-cad.toml) on tetrahedra of
#: tet10-bbar, with the tine case's side wall and loading: 0.1 in of travel in 8 steps.
CAD_AS_TINE = ["mesh.configuration=side_wall", "loading.control=displacement",
               "loading.magnitude=0.1", "loading.steps=8", "loading.first_cuts=0",
               "loading.until_collapse=false", "output.at=[]"]
#: A coarse mesh for quad9-bbar: edge cells of 0.02 in growing by 0.3 per in, up to 2 in.
COARSE = ["mesh.edge_size=0.02", "mesh.size_growth=0.3", "mesh.far_size=2"]


def cases(quick):
    """(name, scene, overrides)."""
    for r in (1, 2) if quick else (1, 2, 3, 4):
        yield f"footing, refine={r}", FOOTING, [f"mesh.refine={r}"]
    yield "footing, refine=2, LU", FOOTING, ["mesh.refine=2", "solver.linear=lu"]
    for r in (1,) if quick else (1, 2):
        yield f"footing slab, refine={r}", FOOTING, [f"mesh.refine={r}", *SLAB]
    yield "footing quad4, refine=1", FOOTING, ["mesh.refine=1", "analysis.element=quad4"]
    yield "footing quad9-bbar, coarse", FOOTING, ["analysis.element=quad9-bbar", *COARSE]
    for r in (1,) if quick else (1, 2):
        yield (f"footing quad9-bbar, refine={r}", FOOTING,
               [f"mesh.refine={r}", "analysis.element=quad9-bbar"])
    if not quick:   # the slab's quadratic element takes minutes
        yield ("footing slab hex27-bbar, refine=1", FOOTING,
               ["mesh.refine=1", "mesh.dimension=3", "analysis.element=hex27-bbar"])
    yield "column, nz=24", COLUMN, ["mesh.nz=24"]
    yield "tine, refine=1", TINE, []
    yield "tine from a STEP file, tet10-bbar, element_size=1", CAD_TINE, CAD_AS_TINE
    if quick:
        yield ("tine, refine=1, AMG, 2 steps to 0.025 in", TINE,
               ["solver.linear=amg", "loading.steps=2", "loading.magnitude=0.025"])
        return
    yield "tine, refine=1, AMG", TINE, ["solver.linear=amg"]
    for size, growth in TINE_LEVELS:
        yield (f"tine, element_size={size:g}, growth={growth:g}", TINE,
               [f"mesh.element_size={size:g}", f"mesh.growth={growth:g}"])
    for large in ("false", "true"):   # what the updated Lagrangian option costs
        kind = "large" if large == "true" else "small"
        yield f"block, {kind} deformation", BLOCK, [f"analysis.large_deformation={large}"]
        yield (f"strip load to collapse, {kind} deformation", STRIP_LOAD,
               [f"analysis.large_deformation={large}"])
    # the same collapse traced by the strip's mean settlement: no step is cut at the limit
    yield "strip load, indirect displacement control to 0.1 in", STRIP_LOAD, INDIRECT
    yield "tine, refine=2", TINE, ["mesh.refine=2"]
    yield "tine, refine=3, AMG", TINE, ["mesh.refine=3", "solver.linear=amg"]
    # the 10^6-unknown tine: scripts/large_tine.py (per Newton iteration; its step does not converge)


def peak_pressure(records):
    return max(r.columns["pressure"] for r in records)


def result_value(scene, records):
    """(error in %, or the draft) of a case from its converged steps (a pressure is the curve's,
    over the loaded boundary's current area, as in the run's summary)."""
    if scene.name.startswith(("strip-footing", "strip-load")):
        c = scene.materials[scene.regions["soil"]].c
        return "error %", 100 * (peak_pressure(records) / prandtl_limit_pressure(c) - 1)
    if scene.name.startswith("block"):
        soil = scene.materials[scene.regions["soil"]]
        return "error %", 100 * (peak_pressure(records) / unconfined_strength(soil.c, soil.phi) - 1)
    if scene.name.startswith("column"):
        soil = scene.materials[scene.regions["soil"]]
        exact = column_settlement(scene.loading.magnitude, scene.mesh.lz, soil.E, soil.nu)
        return "error %", 100 * (records[-1].displacement / exact - 1)
    return "draft lb", records[-1].force


def run_case(scene_name, overrides):
    """Solve one case in this process; returns its measurements."""
    start = time.process_time()
    from mpi4py import MPI
    from soilbin.app.collapse import stepping
    from soilbin.meshes import scene_mesh
    from soilbin.problem import SoilProblem
    from soilbin.records.scene import load_scene
    from soilbin.solver.stepping import run_load_steps

    scene = load_scene(ROOT / "scenes" / f"{scene_name}.toml", overrides)
    problem = SoilProblem(scene, scene_mesh(scene, MPI.COMM_WORLD))
    setup = time.process_time() - start
    result = run_load_steps(problem, on_step=lambda r: None, **stepping(scene))
    solve = time.process_time() - start - setup
    newton, linear = problem.newton.stats, problem.newton.linear.stats
    kind, value = result_value(scene, result.steps) if result.steps else ("", None)
    return dict(element=scene.analysis.element.value, solver=problem.newton.linear.description,
                dofs=problem.n_dofs, complete=result.complete, steps=len(result.steps),
                until_collapse=scene.loading.until_collapse,
                iterations=newton["iterations"], failed=newton["failed_iterations"],
                residuals=newton["residual_evaluations"], setup_s=setup, solve_s=solve,
                memory_MB=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                kind=kind, value=value, krylov=linear["krylov_iterations"],
                factorisations=linear["factorisations"],
                factorisation_s=linear["factorisation_s"], linear_solve_s=linear["solve_s"],
                assembly_s=newton["assembly_s"], constitutive_s=newton["constitutive_s"])


def measure(name, scene, overrides):
    cmd = [sys.executable, __file__, "--case", scene, *overrides]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True,
                          env={**os.environ, "OMP_NUM_THREADS": "1"})
    if proc.returncode != 0:
        sys.exit(f"{name} failed:\n{proc.stderr[-3000:]}")
    return {"case": name, "overrides": overrides, **json.loads(proc.stdout.strip().splitlines()[-1])}


def row(cells):
    return "| " + " | ".join(map(str, cells)) + " |"


HEAD = ["case", "element", "linear solver", "dofs", "load steps", "Newton (failed)",
        "CPU solve (s)", "CPU total (s)", "memory (MB)", "error (%) or draft (lb)"]
COST = ["case", "dofs", "factorisation / set-up", "assembly", "constitutive update", "solves",
        "Krylov its / solve"]
COST_TITLE = "CPU milliseconds per Newton iteration (converged and failed):"


def table_rows(r):
    """A case's (row of the first table, row of the per-iteration table)."""
    value = "failed" if r["value"] is None else (
        f"{r['value']:+.3g}" if r["kind"] == "error %" else f"{r['value']:.1f} lb")
    if not r["complete"]:
        value += " (collapse)" if r["until_collapse"] else " (incomplete)"
    n = max(r["iterations"] + r["failed"], 1)
    per = [f"{1000 * r[k] / n:.1f}" for k in ("factorisation_s", "assembly_s", "constitutive_s",
                                               "linear_solve_s")]
    krylov = f"{r['krylov'] / n:.0f}" if r["krylov"] else "-"
    return (row([r["case"], r["element"], r["solver"], r["dofs"], r["steps"],
                 f"{r['iterations']} ({r['failed']})", f"{r['solve_s']:.2f}",
                 f"{r['setup_s'] + r['solve_s']:.2f}", f"{r['memory_MB']:.0f}", value]),
            row([r["case"], r["dofs"], *per, krylov]))


AGAIN = "; rows measured again by "
MACHINE, COMMAND = "Machine: ", "; command: "


def this_machine():
    """'nproc N, CPU model' of the machine this runs on."""
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo")
                if line.startswith("model name")), "unknown CPU")
    return f"nproc {len(os.sched_getaffinity(0))}, {cpu}"


def page_rows(page, names):
    """The rows of the cases ``names`` in ``page``'s benchmark block, in its order: case ->
    (row of the first table, row of the per-iteration table), as the page holds them; the
    commands that measured rows again, as its last line names them (None if none); and the
    machine it names."""
    block = page.read_text().split("<!-- benchmark:start -->")[1].split("<!-- benchmark:end -->")[0]
    first, cost = ({line.split(" | ")[0][2:]: line for line in part.splitlines()
                    if line.startswith("| ")} for part in block.split(COST_TITLE))
    last = block.strip().splitlines()[-1]
    again = last.partition(AGAIN)[2] or None
    machine = last.partition(MACHINE)[2].partition(COMMAND)[0]
    return {name: (line, cost[name]) for name, line in first.items()
            if name in names and name in cost}, again, machine


def markdown(rows, command, again=None, machine=None):
    """The block: ``rows`` a list of :func:`table_rows`; ``again`` the commands (in
    backquotes) that measured some of them again; ``machine`` what they were measured on
    (default: :func:`this_machine`)."""
    lines = [row(HEAD), row(["---"] * len(HEAD)), *(first for first, _ in rows),
             "", COST_TITLE, "", row(COST), row(["---"] * len(COST)), *(cost for _, cost in rows)]
    lines += ["", "Newton (failed): iterations of converged steps (of attempts that were cut). "
              "CPU = `time.process_time` of the case's own process (total = set-up incl. mesh and "
              "form compilation + solve); memory = peak resident set. Serial runs on a machine "
              "shared with other jobs (CPU time, not wall time, is comparable).",
              f"{MACHINE}{machine or this_machine()}{COMMAND}`{command}`"
              + (AGAIN + again if again else "")]
    return "\n".join(lines) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_page_argument(parser, "performance.md", default=False)
    parser.add_argument("--quick", action="store_true", help="the small cases only (< 3 min)")
    parser.add_argument("--only", nargs="+", metavar="TEXT",
                        help="only the cases whose name contains one of these")
    parser.add_argument("--update", action="store_true",
                        help="keep the page's rows of the other cases (those still among the "
                             "cases), replace these")
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "benchmark")
    parser.add_argument("--case", nargs="+", metavar=("SCENE", "OVERRIDE"),
                        help="run one case in this process and print its JSON")
    args = parser.parse_args()
    every_case = args.update or not (args.quick or args.only)
    page = args.page or (PAGE if every_case else None)
    if args.case:
        print(json.dumps(run_case(args.case[0], args.case[1:])))
        return
    results = []
    for name, scene, overrides in cases(args.quick):
        if args.only and not any(text in name for text in args.only):
            continue
        results.append(measure(name, scene, overrides))
        r = results[-1]
        print(f"{name}: {r['dofs']} dofs, {r['iterations']} ({r['failed']}) Newton, "
              f"{r['solve_s']:.2f} s solve, {r['value']}", file=sys.stderr, flush=True)
    command = " ".join(["OMP_NUM_THREADS=1 python", *sys.argv])
    if args.update:   # the page's rows of the other cases that are still cases, as they stand
        known = {name for quick in (False, True) for name, _, _ in cases(quick)}
        fresh = {r["case"]: table_rows(r) for r in results}
        kept, again, machine = page_rows(page, known)
        rows = [fresh.pop(name, None) or old for name, old in kept.items()] + list(fresh.values())
        # a whole run's table with some of its rows measured again, perhaps on another machine
        here = this_machine()
        if machine and here not in machine:
            machine = f"{machine}, then {here}"
        text = markdown(rows, "OMP_NUM_THREADS=1 python scripts/benchmark.py",
                        again=(again + ", then " if again else "") + f"`{command}`",
                        machine=machine)
    else:
        text = markdown([table_rows(r) for r in results], command)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps(results, indent=1))
    (args.out / "results.md").write_text(text)
    print(text)
    if page:
        write_between_markers(page, "benchmark", text)


if __name__ == "__main__":
    main()
