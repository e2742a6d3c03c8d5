"""A stopped run goes on from its checkpoint (``soilbin run --resume``): the same steps, the
same Newton iterations and the same curve as the run that never stopped."""
import csv
import shutil
import signal

import numpy as np
import pytest

from conftest import SCENES
from soilbin.app import interrupt
from soilbin.app.run import run_scene
from soilbin.errors import InputError
from soilbin.records.scene import load_scene

TINE = ("mesh.element_size=1.5", "mesh.growth=1.6", "mesh.ahead=10.0", "mesh.behind=10.0",
        "mesh.bin_width=10.0", "loading.magnitude=0.04", "loading.steps=4",
        "output.fields=['displacement']")


def stop_after(step):
    """A progress callback that interrupts the run (as SIGTERM would) after ``step``."""
    def progress(record):
        if record.step == step:
            raise interrupt.Interrupted(signal.SIGTERM)
    return progress


def curve(folder):
    with open(folder / "curve.csv") as f:
        return [{key: float(value) for key, value in row.items() if key != "wall_s"}
                for row in csv.DictReader(f)]


def stop_and_resume(tmp_path, name, overrides, step, resume_overrides=()):
    """(the whole run's summary and curve, the resumed run's)."""
    scene = load_scene(SCENES / f"{name}.toml", overrides)
    whole = run_scene(scene, tmp_path / "whole")
    stopped = run_scene(scene, tmp_path / "stopped", progress=stop_after(step))
    assert stopped["status"] == "interrupted" and stopped["n_steps"] == step
    resumed = run_scene(load_scene(SCENES / f"{name}.toml", [*overrides, *resume_overrides]),
                        tmp_path / "resumed", resume=tmp_path / "stopped")
    return (whole, curve(tmp_path / "whole")), (resumed, curve(tmp_path / "resumed"))


@pytest.mark.parametrize("name, overrides, step", [
    # small strain, the tool's interface (slip, gap), displacement control
    ("tine-2in-90deg", TINE, 2),
    # updated Lagrangian (the mesh moved, the history rotated), force control
    ("column-elastic-large", (), 5),
    # updated Lagrangian mean-dilatation elements under indirect displacement control (the
    # traction's magnitude an unknown) in plane strain
    ("strip-load-von-mises", ("loading.control=indirect_displacement",
                              "loading.until_collapse=false", "analysis.large_deformation=true",
                              "loading.magnitude=0.03", "loading.steps=6"), 3),
])
def test_a_resumed_run_repeats_the_run_that_never_stopped(tmp_path, name, overrides, step):
    (whole, whole_curve), (resumed, resumed_curve) = stop_and_resume(tmp_path, name, overrides, step)
    assert resumed["status"] == whole["status"] == "complete"
    assert resumed["resumed_after_step"] == step < whole["n_steps"]
    assert resumed["newton_iterations"] == whole["newton_iterations"]
    assert len(resumed_curve) == len(whole_curve)
    for mine, theirs in zip(resumed_curve, whole_curve):
        assert mine == pytest.approx(theirs, rel=1e-12, abs=1e-14)


@pytest.mark.slow
def test_a_force_controlled_tool_resumes_at_its_travel(tmp_path):
    """The tool's travel is the border unknown under force control."""
    overrides = [o for o in TINE if not o.startswith("loading.magnitude")]
    (whole, whole_curve), (resumed, resumed_curve) = stop_and_resume(
        tmp_path, "tine-2in-90deg", [*overrides, "loading.control=force", "loading.magnitude=20"],
        2)
    assert resumed["newton_iterations"] == whole["newton_iterations"]
    for mine, theirs in zip(resumed_curve, whole_curve):
        assert mine == pytest.approx(theirs, rel=1e-12, abs=1e-14)


@pytest.mark.slow
def test_the_solver_may_change_on_resume(tmp_path):
    (whole, whole_curve), (resumed, resumed_curve) = stop_and_resume(
        tmp_path, "tine-2in-90deg", TINE, 2, resume_overrides=["solver.linear=lu"])
    assert resumed["linear_solver"] == "MUMPS LU" != whole["linear_solver"]
    assert resumed_curve[-1]["force"] == pytest.approx(whole_curve[-1]["force"], rel=1e-6)


@pytest.fixture(scope="module")
def stopped_column(tmp_path_factory):
    folder = tmp_path_factory.mktemp("stopped")
    scene = load_scene(SCENES / "column-elastic.toml", [])
    run_scene(scene, folder, progress=stop_after(2))
    return folder


def resume_column(stopped, out, *overrides):
    return run_scene(load_scene(SCENES / "column-elastic.toml", list(overrides)), out,
                     resume=stopped)


def test_resume_refuses_another_scene(stopped_column, tmp_path):
    with pytest.raises(InputError, match=r"differs from the checkpoint's in materials\.soil\.E "
                                         r"\(only title, solver, output, headline, remesh\.retries, "
                                         r"soil_contact may change\)"):
        resume_column(stopped_column, tmp_path, "materials.soil.E=5000")


def test_resume_takes_another_count_of_retries_of_a_failed_remesh(stopped_column, tmp_path):
    assert resume_column(stopped_column, tmp_path, "remesh.retries=7")["status"] == "complete"


def test_resume_refuses_a_folder_without_checkpoint_and_its_own_folder(stopped_column, tmp_path):
    with pytest.raises(InputError, match="no checkpoint there"):
        resume_column(tmp_path, tmp_path / "new")
    with pytest.raises(InputError, match="give the resumed run another --out"):
        resume_column(stopped_column, stopped_column)


def test_resume_refuses_a_checkpoint_of_another_mesh(stopped_column, tmp_path):
    """Another mesh of the scene (as another gmsh version might make): a cell moved."""
    copy = tmp_path / "copy"
    shutil.copytree(stopped_column, copy)
    with np.load(copy / "checkpoint" / "state.npz") as data:
        arrays = {key: data[key] for key in data.files}
    arrays["centres"][0] += 1e-6
    np.savez(copy / "checkpoint" / "state.npz", **arrays)
    with pytest.raises(InputError, match="the mesh differs from the checkpoint's"):
        resume_column(copy, tmp_path / "new")


def test_a_new_run_clears_the_checkpoint_of_the_last(stopped_column, tmp_path):
    """A folder's checkpoint is its own run's, not an older run's in the same folder."""
    folder = tmp_path / "again"
    shutil.copytree(stopped_column, folder)
    scene = load_scene(SCENES / "column-elastic.toml", ["loading.magnitude=5"])
    run_scene(scene, folder, progress=stop_after(1))
    with pytest.raises(InputError, match="loading.magnitude"):
        resume_column(folder, tmp_path / "new")
