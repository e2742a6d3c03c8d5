"""The tine on a large mesh: time, Krylov iterations and memory of every Newton iteration.

    OMP_NUM_THREADS=1 python scripts/large_tine.py --set mesh.refine=4 [--set ...]
    OMP_NUM_THREADS=1 mpirun -n 2 python scripts/large_tine.py --set mesh.refine=4

One load step of the tine scene tine-2in-90deg (by default 1/8 of its travel,
``loading.magnitude = 0.0125``: the step out of the K0 state, the hardest of
the run) with GMRES + GAMG (``solver.linear = "amg"``) unless overridden
(``--set solver.linear=blr``: MUMPS's block low-rank LU). On the fine meshes
that step does not converge; a smaller one does (refine 2:
``--set loading.magnitude=0.003125``, 1/32 of the travel; refine 4, with BLR:
``0.00078125``, 1/128, in 32 iterations at 17.1 GB; docs/performance.md,
*The large tine*). Prints a line per Newton iteration (CPU seconds of the iteration on
rank 0, its Krylov iterations, the peak resident memory summed over the ranks,
the line search's trial step lengths along the previous correction, the
points whose return mode changed since the previous iteration and the points
in each mode, summed over the ranks), every residual norm (a failed local
return too, with its message), and writes them with the set-up's to ``--out``
(JSON), for the large tine's table of docs/performance.md.
"""
import argparse
import json
import resource
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from soilbin.errors import ConvergenceError, ReturnMapError  # noqa: E402
from soilbin.meshes import BUILDERS  # noqa: E402
from soilbin.models.cap import ModifiedCap  # noqa: E402
from soilbin.models.base import ELASTIC, FAILURE, APEX, CUTOFF, CAP, CAP_CORNER  # noqa: E402
from soilbin.problem import SoilProblem  # noqa: E402
from soilbin.records.scene import load_scene  # noqa: E402
from soilbin.solver.newton import NewtonSolver  # noqa: E402

DEFAULTS = ["solver.linear=amg", "loading.steps=1", "loading.magnitude=0.0125"]
MODES = dict(elastic=ELASTIC, failure=FAILURE, apex=APEX, cutoff=CUTOFF, cap=CAP,
             cap_corner=CAP_CORNER)


def memory_mb(comm):
    """Peak resident set of all ranks together [MB]."""
    return comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)


def modes(problem):
    """The return mode (``yield_state``) of every local point at the last update."""
    points = problem.points
    out = np.full(sum(len(idx) for idx in points.index.values()), -1.0)
    for name, idx in points.index.items():
        if "yield_state" in points.trial[name]:
            out[idx] = points.trial[name]["yield_state"]
    return out


def stiffen_apex(alpha):
    """Add ``alpha`` times the elastic stiffness to the modified cap's tangent at the points
    at the apex, the stress untouched (the converged state is the same, the Newton matrix
    differs). With A = C the apex is zero stress and its tangent is zero, so a cell whose
    points are all there has no stiffness, and a cluster of them near the free surface makes
    the Newton matrix singular (docs/performance.md, *The large tine*)."""
    integrate = ModifiedCap.integrate

    def stiffened(self, deps, state, guess, tangent):
        sigma, new_state = integrate(self, deps, state, guess, tangent)
        tangent[new_state["yield_state"] == APEX] += alpha * self.stiffness
        return sigma, new_state

    ModifiedCap.integrate = stiffened


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "large-tine" / "result.json")
    parser.add_argument("--apex-stiffness", type=float, default=0.0, metavar="ALPHA",
                        help="an experiment: add ALPHA times the elastic stiffness to the tangent "
                             "at the modified cap's points at the apex (their own is zero)")
    args = parser.parse_args()
    if args.apex_stiffness:
        stiffen_apex(args.apex_stiffness)
    comm = MPI.COMM_WORLD
    say = print if comm.rank == 0 else (lambda *a, **k: None)

    start = time.process_time()
    scene = load_scene(ROOT / "scenes" / "tine-2in-90deg.toml", DEFAULTS + args.set)
    problem = SoilProblem(scene, BUILDERS[scene.mesh_builder].build(scene.mesh, comm))
    setup = dict(setup_s=time.process_time() - start, memory_MB=memory_mb(comm),
                 dofs=problem.n_dofs, cells=problem.disc.mesh.topology.index_map(3).size_global,
                 ranks=comm.size, solver=problem.newton.linear.description, overrides=args.set)
    say(json.dumps(setup), flush=True)

    newton, iterations = problem.newton, []
    stats = newton.linear.stats
    step, residual = NewtonSolver._newton_step, NewtonSolver.residual
    set_iterate = NewtonSolver._set_iterate
    clock = {"t": time.process_time(), "krylov": 0, "modes": modes(problem), "steps": []}

    def logged_step(self):
        """The Newton correction; logs the iteration that ends with it: its CPU time,
        Krylov iterations, memory, the line search's trial steps along the last
        correction, the points whose return mode changed since the last correction
        (summed over the ranks) and how many points are in each mode."""
        da = step(self)
        now, now_modes = time.process_time(), modes(problem)
        row = dict(cpu_s=now - clock["t"], krylov=stats["krylov_iterations"] - clock["krylov"],
                   memory_MB=memory_mb(comm), line_search=clock["steps"],
                   mode_changes=comm.allreduce(int(np.sum(now_modes != clock["modes"]))),
                   modes={name: comm.allreduce(int(np.sum(now_modes == code)))
                          for name, code in MODES.items()})
        clock.update(t=now, krylov=stats["krylov_iterations"], modes=now_modes, steps=[])
        iterations.append(row)
        say(f"Newton {len(iterations):3d}  {row['cpu_s']:8.1f} CPU s  Krylov {row['krylov']:4d}  "
            f"memory {row['memory_MB']:8.0f} MB  steps {' '.join(f'{s:.3g}' for s in row['line_search'])}"
            f"  changed {row['mode_changes']}  {row['modes']}", flush=True)
        return da

    def logged_set_iterate(self, x, a, dx, da, length):
        clock["steps"].append(length)
        set_iterate(self, x, a, dx, da, length)

    def logged_residual(self, b):
        try:
            norm = residual(self, b)
        except ReturnMapError as err:   # the line search takes it as an infinite residual
            say(f"    |R| = inf ({err})", flush=True)
            raise
        say(f"    |R| = {norm:.4e}", flush=True)
        return norm

    NewtonSolver._newton_step, NewtonSolver.residual = logged_step, logged_residual
    NewtonSolver._set_iterate = logged_set_iterate
    problem.set_load_factor(1.0)
    try:
        result = problem.solve()
        outcome = dict(converged=True, newton=result.iterations)
    except ConvergenceError as err:   # report what was measured before the failure
        outcome = dict(converged=False, message=str(err))
    summary = dict(**setup, **outcome, iterations=iterations,
                   draft=problem.observe().force if outcome["converged"] else None,
                   newton_stats=dict(newton.stats), linear_stats=dict(stats))
    if comm.rank == 0:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(summary, indent=1))
    say(json.dumps({k: v for k, v in summary.items() if k != "iterations"}))


if __name__ == "__main__":
    main()
