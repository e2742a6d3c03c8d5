"""Runs under `mpirun -n 2` give the same load-displacement curve as serial runs."""
import csv
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import last_json, soilbin_cli

pytestmark = pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")


def curve(path):
    with open(path) as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


@pytest.mark.parametrize("scene, overrides", [
    ("strip-footing-von-mises", ["--set", "loading.steps=5", "--set", "loading.magnitude=0.03"]),
    ("column-elastic", []),
    # the wall's contact points all on one rank: the other adds no interface entries
    ("retaining-wall-passive-rough", ["--set", "mesh.element_size=2", "--set", "output.fields=[]"]),
    # a tool from a STEP file on tetrahedra (tet10-bbar), its triangles split between ranks;
    # steps of 3-12 Newton iterations (on 0.01 in in two steps a step took 30, and the
    # rounding of two ranks cut it once where serial did not: another curve's points);
    # Newton to 1e-10 of the force scale, not the scene's 1e-6: at 1e-6 the first step's force
    # is good to 5e-7 of itself only, and two ranks once ended it 8e-6 away
    ("tine-2in-cad", [arg for key in ("mesh.element_size=1.5", "mesh.growth=1.8",
                                      "solver.atol=1e-10",
                                      "loading.control=displacement", "loading.magnitude=0.0025",
                                      "loading.steps=4", "loading.first_cuts=0",
                                      "loading.until_collapse=false", "output.at=[]",
                                      "output.fields=[]") for arg in ("--set", key)]),
    # remeshing: rank 0 meshes the outline and moves the state, the new mesh is partitioned
    ("strip-footing-penetration", [arg for key in ("mesh.edge_size=0.05", "loading.magnitude=0.1",
                                                   "loading.steps=10", "remesh.every=4")
                                   for arg in ("--set", key)]),
    # remeshing tetrahedra: rank 0 meshes the gathered boundary triangles
    ("block-drucker-prager", [arg for key in ("analysis.element=tet10-bbar",
                                              "analysis.large_deformation=true",
                                              "remesh.every=4", "loading.magnitude=0.1",
                                              "loading.steps=10") for arg in ("--set", key)]),
])
@pytest.mark.slow
def test_two_ranks_match_serial(tmp_path, scene, overrides):
    runs = {}
    for ranks in (1, 2):
        out = tmp_path / f"n{ranks}"
        done = soilbin_cli("run", scene, "--json", "--out", out, *overrides,
                           mpi_ranks=ranks if ranks > 1 else None)
        assert done.returncode == 0, done.stderr
        summary = last_json(done.stdout)
        assert summary["n_ranks"] == ranks
        runs[ranks] = (summary, curve(out / "curve.csv"))
    (s1, c1), (s2, c2) = runs[1], runs[2]
    assert s1["n_dofs"] == s2["n_dofs"] and len(c1) == len(c2)
    for r1, r2 in zip(c1, c2):
        assert r2["load_factor"] == pytest.approx(r1["load_factor"], rel=1e-12)
        assert r2["displacement"] == pytest.approx(r1["displacement"], rel=1e-6)
        assert r2["force"] == pytest.approx(r1["force"], rel=1e-6)


@pytest.mark.slow
def test_force_controlled_tine_with_progress_lines_matches_serial(tmp_path):
    """The tool's bordered Newton, the tool section and the sections of figures 8.10-8.12 under
    two ranks; without --json the progress lines are printed (rank 0 alone must not evaluate
    a collective for them)."""
    coarse = ["mesh.element_size=1.5", "mesh.growth=1.6", "mesh.ahead=10.0", "mesh.behind=10.0",
              "mesh.bin_width=10.0", "loading.control=force", "loading.magnitude=60",
              "loading.steps=3", "regions.soil=drucker_prager", "materials.drucker_prager.c=0.05",
              "output.at=[40.0]",
              # the same three steps in both runs: two-rank runs are not repeatable bit for bit,
              # and the first step, 8 iterations in serial, took 10 in 1 of 8 of them, which
              # halves the next step (stepping.HARD) and changes the plastic path
              "loading.max_cuts=0"]
    sets = [arg for key in coarse for arg in ("--set", key)]
    curves = {}
    for ranks in (1, 2):
        out = tmp_path / f"n{ranks}"
        done = soilbin_cli("run", "tine-2in-90deg", "--out", out, *sets,
                           mpi_ranks=ranks if ranks > 1 else None)
        assert done.returncode == 0, done.stderr
        assert "step   3" in done.stderr and (out / "tool-section.png").is_file()
        assert (out / "sections-40.png").is_file()
        curves[ranks] = curve(out / "curve.csv")
    assert len(curves[1]) == len(curves[2]) == 3
    for r1, r2 in zip(curves[1], curves[2]):
        assert r1["force"] == pytest.approx(60.0 * r1["load_factor"], rel=1e-6)
        assert r2["force"] == pytest.approx(r1["force"], rel=1e-6)
        assert r2["displacement"] == pytest.approx(r1["displacement"], rel=1e-6)


FAIL_ON_RANK_0 = """
import sys
sys.path.insert(0, {tests!r})
from mpi4py import MPI
from conftest import make_problem
from soilbin.errors import ReturnMapError
from soilbin.solver.newton import NewtonFailure

problem = make_problem("strip-footing-von-mises", "mesh.edge_size=0.08", "loading.steps=4",
                       "solver.line_search=bt")
name, model = next(iter(problem.points.models.items()))
update = model.update

def failing(deps, state, guess=None, tangent=None):
    if MPI.COMM_WORLD.rank == 0:
        raise ReturnMapError("forced on rank 0")
    return update(deps, state, guess=guess, tangent=tangent)

object.__setattr__(model, "update", failing)
problem.set_load_factor(0.25)
try:
    problem.solve()
except NewtonFailure as err:
    print(f"rank {{MPI.COMM_WORLD.rank}}: {{err}}", flush=True)
"""


@pytest.mark.slow
def test_a_local_return_failing_on_one_rank_fails_the_iterate_on_every_rank(tmp_path):
    """A ReturnMapError on rank 0 alone reaches rank 1 too (both cut the step, neither is
    left waiting in an assembly: the run would hang)."""
    script = tmp_path / "fail.py"
    script.write_text(FAIL_ON_RANK_0.format(tests=str(Path(__file__).parent)))
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    done = subprocess.run(["mpirun", "-n", "2", sys.executable, str(script)], capture_output=True,
                          text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    for rank in (0, 1):
        assert f"rank {rank}: forced on rank 0" in done.stdout


STOP_AFTER_STEP_2 = """
import sys
sys.path.insert(0, {tests!r})
from test_checkpoint import TINE, stop_after
from conftest import SCENES
from soilbin.app.run import run_scene
from soilbin.records.scene import load_scene

summary = run_scene(load_scene(SCENES / "tine-2in-90deg.toml", TINE), {out!r},
                    progress=stop_after(2))   # on every rank: all stop after the same step
assert summary["status"] == "interrupted", summary
"""


@pytest.mark.slow
def test_two_ranks_resume_from_their_checkpoint(tmp_path):
    """Two ranks stopped after step 2 and resumed by `soilbin run --resume`, on two ranks (the
    mesh partitioned anew) and on one, end where two ranks that never stopped do."""
    from test_checkpoint import TINE
    sets = [arg for key in TINE for arg in ("--set", key)]
    whole = soilbin_cli("run", "tine-2in-90deg", "--json", "--out", tmp_path / "whole", *sets,
                        mpi_ranks=2)
    assert whole.returncode == 0, whole.stderr
    script = tmp_path / "stop.py"
    script.write_text(STOP_AFTER_STEP_2.format(tests=str(Path(__file__).parent),
                                               out=str(tmp_path / "stopped")))
    env = dict(os.environ, OMP_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    stopped = subprocess.run(["mpirun", "-n", "2", sys.executable, str(script)],
                             capture_output=True, text=True, env=env, timeout=300)
    assert stopped.returncode == 0, stopped.stderr
    theirs = last_json(whole.stdout)
    for ranks in (2, 1):
        resumed = soilbin_cli("run", "tine-2in-90deg", "--json", "--out", tmp_path / f"n{ranks}",
                              "--resume", tmp_path / "stopped", *sets,
                              mpi_ranks=ranks if ranks > 1 else None)
        assert resumed.returncode == 0, resumed.stderr
        mine = last_json(resumed.stdout)
        assert mine["resumed_after_step"] == 2 and mine["n_ranks"] == ranks
        assert mine["load_factor"] == theirs["load_factor"] == 1.0
        assert mine["draft_force_at"] == pytest.approx(theirs["draft_force_at"], rel=1e-6)


@pytest.mark.slow
def test_calibrate_shares_its_jacobian_over_two_ranks(tmp_path):
    """Each rank evaluates its share of the finite-difference trials and all gather them:
    the same fit as one process, to the last digit; rank 0 alone writes and prints."""
    from test_calibrate import dp_file
    path = dp_file(tmp_path)
    summaries = {}
    for ranks in (1, 2):
        done = soilbin_cli("calibrate", path, "--out", tmp_path / f"n{ranks}", "--jobs", "1",
                           "--json", mpi_ranks=ranks if ranks > 1 else None)
        assert done.returncode == 0, done.stderr
        assert len(done.stdout.strip().splitlines()) == 1
        summaries[ranks] = last_json(done.stdout)
    assert summaries[2]["jobs"] == 2 and summaries[1]["jobs"] == 1
    for key in ("parameters", "standard_errors", "evaluations"):
        assert summaries[2][key] == summaries[1][key]


def test_point_under_two_ranks_writes_and_prints_once(tmp_path):
    done = soilbin_cli("point", "elastic", "hydrostatic", "--set", "E=1e4", "--set", "nu=0.3",
                       "--set", "path.pressure=10", "--out", tmp_path / "out", "--json",
                       mpi_ranks=2)
    assert done.returncode == 0, done.stderr
    assert len(done.stdout.strip().splitlines()) == 1
    assert last_json(done.stdout)["final"]["p"] == pytest.approx(0.0, abs=1e-9)
    assert {p.name for p in (tmp_path / "out").iterdir()} == {"path.csv", "path.png", "summary.json"}
