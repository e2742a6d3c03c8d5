import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "scenes"
SOILBIN = Path(sys.executable).parent / "soilbin"


@pytest.fixture
def solve(tmp_path):
    """solve(scene_name, *overrides) -> (summary, run folder), in this process."""
    from soilbin.app.run import run_scene
    from soilbin.records.scene import load_scene

    def _solve(name, *overrides):
        scene = load_scene(SCENES / f"{name}.toml", overrides)
        out = tmp_path / name
        return run_scene(scene, out), out
    return _solve


def soilbin_cli(*args, mpi_ranks=None, cwd=None):
    """Run the installed command line; returns the CompletedProcess."""
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    cmd = [str(SOILBIN), *map(str, args)]
    if mpi_ranks:
        cmd = ["mpirun", "-n", str(mpi_ranks), sys.executable, "-m", "soilbin.app.cli", *map(str, args)]
    return subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=cwd, timeout=600)


def last_json(stdout):
    return json.loads(stdout.strip().splitlines()[-1])


def make_problem(scene, *overrides):
    """A SoilProblem for a scene (name in scenes/ or a path) with --set style overrides."""
    from mpi4py import MPI
    from soilbin.meshes import scene_mesh
    from soilbin.problem import SoilProblem
    from soilbin.records.scene import load_scene

    path = Path(scene) if str(scene).endswith(".toml") else SCENES / f"{scene}.toml"
    loaded = load_scene(path, overrides)
    return SoilProblem(loaded, scene_mesh(loaded, MPI.COMM_WORLD))


def jacobian_error(problem, seed=0, amplitude=0.01):
    """Relative error of J dx against central differences of the residual, at a
    random increment of this amplitude (BC rows excluded), the difference step 1e-5 of it
    (a point within it of a kink between return modes would spoil the difference); and the
    points' trial states."""
    newton, w = problem.newton, problem.w
    rng = np.random.default_rng(seed)
    fixed = np.concatenate([bc.dof_indices()[0] for bc in problem.bcs])
    w.x.array[:] = amplitude * rng.standard_normal(len(w.x.array))
    w.x.array[fixed] = 0.0

    def residual(x):
        x.copy(w.vector)
        w.x.scatter_forward()
        b = x.duplicate()
        newton.residual(b)
        return b.array.copy()

    x0 = w.vector.copy()
    residual(x0)
    newton.jacobian()
    dx = x0.duplicate()
    dx.array[:] = rng.standard_normal(len(dx.array))
    dx.array[fixed] = 0.0
    Jdx = newton.matrix.createVecLeft()
    newton.matrix.mult(dx, Jdx)
    h = 1e-5 * amplitude
    fd = (residual(x0 + h * dx) - residual(x0 - h * dx)) / (2 * h)
    exact = Jdx.array.copy()
    fd[fixed] = exact[fixed] = 0.0
    return np.linalg.norm(fd - exact) / np.linalg.norm(exact), problem.points.trial


@pytest.fixture
def solve_file():
    """solve_file(path, *overrides) -> (summary, curve rows, problem), serial, in this process."""
    from soilbin.solver.stepping import run_load_steps

    def _solve(path, *overrides):
        problem = make_problem(path, *overrides)
        steps = problem.scene.loading
        result = run_load_steps(problem, steps.steps, steps.max_cuts, lambda r: None,
                                first_cuts=steps.first_cuts)
        rows = [{"force": r.force, "displacement": r.displacement, "load_factor": r.load_factor}
                for r in result.steps]
        return result, rows, problem
    return _solve


def central_differences(model, deps, state, h):
    """dσ/dΔε (n, 6, 6) of a model by central differences of its update, column by column."""
    fd = np.empty((len(deps), 6, 6))
    for j in range(6):
        step = np.zeros(6)
        step[j] = h
        fd[:, :, j] = (model.update(deps + step, state)[0]
                       - model.update(deps - step, state)[0]) / (2.0 * h)
    return fd


#: A unit cube's six tetrahedra around its diagonal from corner 0 to corner 7 (corner k at
#: the bits of k: x, y, z).
KUHN = [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]]


def kuhn_cube(n=2):
    """The unit cube cut into n x n x n cubes of six tetrahedra each: (nodes ((n + 1)^3, 3),
    cells (6 n^3, 4), boundary triangles (12 n^2, 3) turned outward, their tags: 1 + the
    cube's face, xmin .. zmax)."""
    unit = np.array([[k & 1, (k >> 1) & 1, (k >> 2) & 1] for k in range(8)], dtype=float)
    corners = np.concatenate([(unit[KUHN] + [i, j, k]) / n
                              for i in range(n) for j in range(n) for k in range(n)])
    points, index = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
    cells = index.reshape(-1, 4)
    faces = np.sort(cells[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]].reshape(-1, 3), axis=1)
    unique, count = np.unique(faces, axis=0, return_counts=True)
    triangles = unique[count == 1]
    centre = points[triangles].mean(axis=1)
    axis = np.argmin(np.minimum(centre, 1.0 - centre), axis=1)
    high = centre[np.arange(len(centre)), axis] > 0.5
    a, b, c = (points[triangles[:, k]] for k in range(3))
    outward = np.cross(b - a, c - a)[np.arange(len(centre)), axis] * np.where(high, 1, -1) > 0
    triangles[~outward] = triangles[~outward][:, [0, 2, 1]]
    return points, cells, triangles, 1 + 2 * axis + high


def volume(points, cells):
    """The volume of the tetrahedra ``cells`` (m, 4) on the ``points`` (n, 3)."""
    a, b, c, d = (points[cells[:, k]] for k in range(4))
    return np.abs(np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)).sum() / 6.0
