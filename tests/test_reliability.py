"""Runs that never hang, never lose data, never print a traceback: signals, kills, bad
folders, errors under MPI, internal errors; first contact (keys, --version, quiet JIT)."""
import json
import os
import shutil
import signal
import subprocess
import sys

import meshio
import numpy as np
import pytest

from soilbin.app import cli
from soilbin.app.keys import scene_keys
from soilbin.records.scene import load_scene
from soilbin.records import toml_out
from conftest import ROOT, SCENES, SOILBIN, soilbin_cli

BLOCK = str(SCENES / "block-drucker-prager.toml")
COARSE_TINE = ["mesh.element_size=1.5", "mesh.growth=1.6", "mesh.ahead=10.0", "mesh.behind=10.0",
               "mesh.bin_width=10.0", "loading.steps=8"]


def run_main(capsys, *args):
    status = cli.main([str(a) for a in args])
    out, err = capsys.readouterr()
    return status, out, err


def read_series(path):
    """Every frame of an XDMF series through meshio: (points, cells, [(t, point, cell)])."""
    reader = meshio.xdmf.TimeSeriesReader(str(path))
    points, cells = reader.read_points_cells()
    return points, cells, [reader.read_data(k) for k in range(reader.num_steps)]


def tine_stopped_at_step_3(out, signum):
    """The coarse tine, stopped by ``signum`` once step 3 is reported; (status, stderr)."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    sets = [arg for key in COARSE_TINE for arg in ("--set", key)]
    proc = subprocess.Popen([str(SOILBIN), "run", "tine-2in-90deg", "--out", str(out), *sets],
                            stderr=subprocess.PIPE, text=True, env=env)
    lines = []
    for line in proc.stderr:
        lines.append(line)
        if line.startswith("step   3"):
            proc.send_signal(signum)
            break
    lines += proc.stderr.readlines()
    return proc.wait(timeout=120), "".join(lines)


def test_a_tine_killed_after_step_3_keeps_every_field_readable(tmp_path):
    """SIGKILL: nothing can be cleaned up, yet every frame on disk reads back."""
    out = tmp_path / "tine"
    code, err = tine_stopped_at_step_3(out, signal.SIGKILL)
    assert code == -signal.SIGKILL and "Traceback" not in err
    rows = (out / "curve.csv").read_text().strip().splitlines()[1:]
    points, cells, frames = read_series(out / "fields.xdmf")
    assert len(frames) == len(rows) + 1 >= 4   # the initial state, then every converged step
    assert [t for t, _, _ in frames] == [0.0] + [float(r.split(",")[1]) for r in rows]
    for t, point_data, cell_data in frames:
        assert point_data["displacement"].shape == (len(points), 3)
        assert cell_data["stress"][0].shape == (len(cells[0]), 9)
        assert np.isfinite(cell_data["plastic_strain"][0]).all()
    assert not frames[0][1]["displacement"].any()
    assert (frames[0][2]["stress"][0][:, 8] < 0).all()   # the in-situ stress, tension positive
    _, tool_cells, tool_frames = read_series(out / "tool.xdmf")
    assert tool_cells[0].type == "quad" and len(tool_frames) == len(frames)
    travel = float(rows[-1].split(",")[2])
    assert tool_frames[-1][1]["displacement"][:, 0] == pytest.approx(travel, rel=1e-12)
    assert not (out / "summary.json").exists()


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_ends_the_run_with_a_summary_and_128_plus_its_number(capsys, monkeypatch,
                                                                      tmp_path, signum):
    def progress(record):
        if record.step == 2:
            os.kill(os.getpid(), signum)
    monkeypatch.setattr(cli, "_progress", progress)
    status, _, err = run_main(capsys, "run", BLOCK, "--out", tmp_path / "b")
    assert status == 128 + signum and "Traceback" not in err and "KeyboardInterrupt" not in err
    name = signal.Signals(signum).name
    assert f"soilbin: interrupted by {name}; the converged steps are in {tmp_path / 'b'}" in err
    summary = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert (summary["status"], summary["signal"], summary["n_steps"], summary["converged"]) == (
        "interrupted", name, 2, False)
    assert len(read_series(tmp_path / "b" / "fields.xdmf")[2]) == 3


def test_ctrl_c_ends_a_run_with_a_summary_in_a_process_that_imports_gmsh_itself(tmp_path):
    """gmsh sets SIGINT's handler to the default when it is first imported (by the run's own
    imports, in a fresh process): SIGINT after the second step still ends the run as above."""
    run = subprocess.Popen([str(SOILBIN), "run", "strip-footing-von-mises", "--set",
                            "loading.steps=200", "--out", str(tmp_path / "f")],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           env=dict(os.environ, OMP_NUM_THREADS="1"))
    for line in run.stderr:
        if line.startswith("step   2 "):
            run.send_signal(signal.SIGINT)
            break
    _, err = run.communicate(timeout=300)
    assert run.returncode == 128 + signal.SIGINT and "interrupted by SIGINT" in err
    summary = json.loads((tmp_path / "f" / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["n_steps"] >= 2


def test_a_run_into_an_old_run_folder_leaves_none_of_its_files(capsys, tmp_path):
    out = tmp_path / "old"
    (out / "fields").mkdir(parents=True)
    for name in ("summary.json", "curve.png", "tool-section.png", "tool.xdmf", "fields.h5",
                 "sections-36.png", "fields/fields-000040.h5", "notes.txt"):
        (out / name).write_text("an older run")
    status, _, _ = run_main(capsys, "run", "column-elastic", "--json", "--out", out)
    assert status == 0
    assert json.loads((out / "summary.json").read_text())["scene"] == "column-elastic"
    assert not any((out / n).exists() for n in ("tool-section.png", "tool.xdmf", "fields.h5",
                                                "sections-36.png", "fields/fields-000040.h5"))
    assert (out / "notes.txt").read_text() == "an older run"   # not ours: kept
    assert len(read_series(out / "fields.xdmf")[2]) == 7


def test_an_unwritable_out_is_bad_input_before_meshing(capsys, monkeypatch):
    import gmsh
    monkeypatch.setattr(gmsh, "initialize", lambda *a, **k: pytest.fail("gmsh ran"))
    status, _, err = run_main(capsys, "run", BLOCK, "--out", "/proc/foo")
    assert status == 2 and err.strip() == ("soilbin: error: --out /proc/foo: cannot write there "
                                           "(No such file or directory)")


@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_an_error_on_rank_0_ends_both_ranks_with_one_message():
    done = soilbin_cli("run", "block-drucker-prager", "--out", "/proc/foo", "--json", mpi_ranks=2)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.count("soilbin: error: --out /proc/foo: cannot write there") == 1


def test_an_internal_error_is_one_line_exit_3_and_a_saved_traceback(capsys, monkeypatch, tmp_path):
    import soilbin.app.run

    def broken(scene, tagged):
        raise ZeroDivisionError("a bug")
    monkeypatch.setattr(soilbin.app.run, "check_initial_stress", broken)
    status, _, err = run_main(capsys, "run", BLOCK, "--out", tmp_path / "b")
    saved = tmp_path / "b" / "traceback.txt"
    assert status == cli.INTERNAL_ERROR == 3
    assert err.strip() == f"soilbin: internal error: ZeroDivisionError: a bug; traceback in {saved}"
    assert "Traceback" in saved.read_text() and "broken" in saved.read_text()


@pytest.mark.parametrize("scene, overrides, expected", [
    ("block-drucker-prager", ["supports=[]"],
     "supports: nothing holds the x, y displacement (no support, analysis.plane_strain or loading "
     "under displacement control), so the body can move as a rigid body"),
    ("column-elastic", ["supports.1.fix=['z']", "supports.2.fix=['z']"],
     "supports: nothing holds the x displacement"),
    ("tine-2in-90deg", ["tool.interface.c_a=inf"], "tool.interface.c_a = inf is outside"),
    ("block-drucker-prager", ['headline.x={of="final_force", divide_by=inf}'],
     "headline.x.divide_by = inf is outside the accepted range [1e-20, 1e+20]"),
])
def test_ill_posed_scenes_are_refused(capsys, scene, overrides, expected):
    status, _, err = run_main(capsys, "run", scene, *(f"--set={o}" for o in overrides))
    assert status == 2 and f"{scene}.toml: {expected}" in err


def test_an_in_situ_stress_outside_the_yield_surface_is_refused_before_the_steps(capsys, tmp_path):
    status, _, err = run_main(capsys, "run", "container-footing", "--out", tmp_path / "c",
                              "--set", "regions.soil=vm", "--set",
                              'materials.vm={model="von_mises", E=4000.0, nu=0.35, c=0.05}')
    assert status == 2 and len(err.strip().splitlines()) == 1
    assert ("geostatic: the in-situ stress (unit_weight 0.072, K0 0.455) at z = -12 in region "
            "'soil' lies outside the yield surface of materials.vm") in err
    assert not (tmp_path / "c" / "curve.csv").exists()


def test_a_first_update_failing_on_an_in_situ_stress_outside_the_yield_surface_says_so(
        capsys, tmp_path, monkeypatch):
    """The problem is built (its forms) before the in-situ stress is checked: a return that
    fails there is reported as the input's fault."""
    from soilbin.errors import ReturnMapError
    from soilbin.solver.quadrature import MaterialPoints

    def failing(points):
        raise ReturnMapError("local stress update failed (non-finite result)")
    monkeypatch.setattr(MaterialPoints, "start", failing)
    status, _, err = run_main(capsys, "run", "container-footing", "--out", tmp_path / "c",
                              "--set", "regions.soil=vm", "--set",
                              'materials.vm={model="von_mises", E=4000.0, nu=0.35, c=0.05}')
    assert status == 2 and "lies outside the yield surface of materials.vm" in err


def test_keys_lists_every_settable_key_and_each_one_sets(capsys):
    status, out, _ = run_main(capsys, "keys", "tine-2in-90deg")
    assert status == 0 and "units: lb, in" in out.splitlines()[0]
    scene = load_scene(SCENES / "tine-2in-90deg.toml")
    rows = scene_keys(scene)
    for key in ("mesh.rake_angle", "materials.drucker_prager.phi", "tool.interface.c_a",
                "geostatic.K0", "loading.steps", "supports.0.fix", "output.fields", "solver.rtol"):
        assert any(line.split()[0] == key for line in out.splitlines()[2:]), key
    assert len(out.splitlines()) == len(rows) + 2
    phi = next(line for line in out.splitlines() if line.startswith("materials.drucker_prager.phi "))
    assert "[0, 90)" in phi and str(scene.materials["drucker_prager"].phi) in phi
    for key, value, _, _ in rows:   # every key listed is one --set takes, with its own value
        text = toml_out.dumps({"v": value}).strip()[len("v = "):]
        assert load_scene(scene.path, [f"{key}={text}"]) == scene, key


def test_version(capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["--version"])
    assert exit_info.value.code == 0 and capsys.readouterr().out.startswith("soilbin 0.")


def test_the_point_driver_names_every_missing_parameter_at_once(capsys):
    status, _, err = run_main(capsys, "point", "modified_cam_clay", "triaxial-compression",
                              "--set", "path.steps=0")
    assert status == 2 and err.strip() == (
        "soilbin: error: modified_cam_clay: missing keys 'E', 'nu', 'phi', 'lam', 'kappa', "
        "'e0', 'p_c0'; path.steps = 0 is outside the accepted range [1, 100000]")


def test_the_jit_compiler_logs_nothing_below_warnings():
    """cffi sets the root logger's level to 0 while it compiles; the command line's handler
    keeps its own level, so a first run on an empty form cache prints no INFO lines."""
    code = ("from soilbin.app.cli import _quiet_logging\n_quiet_logging()\nimport ffcx, logging\n"
            "from setuptools._distutils import log\nlog.set_threshold(0)\n"
            "logging.info('x86_64-linux-gnu-gcc -pthread ...')\nlogging.warning('kept')\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert done.stderr.strip() == "WARNING:root:kept"


def test_the_3d_picture_draws_a_large_deformation_to_scale():
    """Small strain: the largest displacement drawn as 3% of the mesh's extent; large
    deformation: as it is (the heave and the furrow of a long travel are the soil's shape)."""
    from soilbin.app.figures_3d import drawn_scale
    points = np.array([[0.0, 0.0, 0.0], [20.0, 10.0, 5.0]])
    u = np.array([[0.0, 0.0, 0.0], [6.0, 0.0, 1.0]])
    assert drawn_scale(points, u, to_scale=False) == pytest.approx(0.03 * 20.0 / 6.0)
    assert drawn_scale(points, u, to_scale=True) == 1.0
    assert drawn_scale(points, 0.0 * u, to_scale=False) == 1.0


@pytest.mark.parametrize("cells, faces", [
    (np.array([[0, 1, 3, 2, 4, 5, 7, 6]]), np.array([[0, 1, 2, 3]])),          # a brick
    (np.array([[0, 1, 3, 7], [0, 3, 2, 7]]), np.array([[0, 1, 2], [0, 2, 3]])),  # tetrahedra
])
def test_the_3d_picture_is_drawn_off_screen(tmp_path, cells, faces):
    """pyvista in its own process (VTK and DOLFINx clash in one): a PNG of the set size."""
    from matplotlib.image import imread
    from soilbin.app.figures_3d import draw_in_subprocess
    corners = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
    soil = (corners, cells, {"displacement": 0.01 * corners},
            {"plastic_strain": np.full(len(cells), 0.02)})
    tool = (corners[[0, 1, 3, 2]] + [0, 0, 1.2], faces, np.array([0.01, 0, 0]))
    assert draw_in_subprocess(soil, tool, "lb, in", tmp_path / "soil-3d.png") == ""
    assert imread(tmp_path / "soil-3d.png").shape[:2] == (650, 1000)
    assert not (tmp_path / "soil-3d.npz").exists()
