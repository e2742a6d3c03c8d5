"""The command line: bad input is a short message and exit status 2, never a traceback."""
import json
import resource

import meshio
import numpy as np
import pytest

from soilbin.app.cli import main
from conftest import SCENES, last_json, soilbin_cli

BLOCK = str(SCENES / "block-drucker-prager.toml")


def run_main(capsys, *args):
    status = main(list(args))
    out, err = capsys.readouterr()
    return status, out, err


@pytest.mark.parametrize("args, expected", [
    (["run", "no/such/scene.toml"], "no such scene file"),
    (["run", BLOCK, "--set", "materials.soil.nu=0.5"], "materials.soil.nu = 0.5 is outside the accepted range (-1, 0.5)"),
    (["run", BLOCK, "--set", "materials.soil.E=-5"], "materials.soil.E = -5.0 is outside"),
    (["run", BLOCK, "--set", "materials.soil.phi=95"], "materials.soil.phi = 95.0 is outside the accepted range [0, 90)"),
    (["run", BLOCK, "--set", "materials.soil.model=cam_clay_x"], "unknown material model"),
    (["run", BLOCK, "--set", "mesh.builder=sphere"], "unknown mesh builder"),
    (["run", BLOCK, "--set", "materials.soil.Young=5"], "unknown key 'Young'"),
    (["run", BLOCK, "--set", "nosuch.table.key=1"], "the scene has no table 'nosuch'"),
    (["run", BLOCK, "--set", "loading.steps=0"], "loading.steps = 0 is outside"),
    (["run", BLOCK, "--set", "loading.direction=up"], "loading.direction: 'up' is not one of"),
    (["run", BLOCK, "--set", "regions.soil=granite"], "no such material"),
])
def test_bad_input_is_one_clear_line(capsys, args, expected):
    status, out, err = run_main(capsys, *args)
    assert status == 2
    assert expected in err
    assert "Traceback" not in err and len(err.strip().splitlines()) <= 2
    if "scene.toml" not in args[1]:
        assert args[1] in err   # the message names the file


@pytest.mark.parametrize("args, expected", [
    (["run"], "soilbin run: error: the following arguments are required: scene"),
    (["study", "x.toml", "--jobs", "x"], "soilbin study: error: argument --jobs: invalid int"),
    (["run", "column-elastic", "--out", ""],
     "soilbin run: error: argument --out: expected a folder, got an empty name"),
    (["run", "column-elastic", "--resume", " "], "soilbin run: error: argument --resume: expected"),
    (["run", "column-elastic", "--bogus"], "soilbin: error: unrecognized arguments: --bogus"),
])
def test_command_line_errors_are_one_line(capsys, args, expected):
    with pytest.raises(SystemExit) as stop:
        main(args)
    err = capsys.readouterr().err
    assert stop.value.code == 2 and err.startswith(expected)
    assert len(err.strip().splitlines()) == 1 and "--help)" in err


POINT = ["point", "elastic", "oedometer", "--set", "E=1e4", "--set", "nu=0.3"]
CALIBRATE = ["calibrate", str(SCENES.parent / "examples" / "calibration-vii5" / "vii5.toml")]


@pytest.mark.parametrize("command", [POINT, CALIBRATE], ids=["point", "calibrate"])
@pytest.mark.parametrize("out, expected", [("/proc/foo", "cannot write there (No such file"),
                                           ("a-file", "a file, not a folder")])
def test_an_out_folder_that_cannot_be_written_is_one_clear_line(capsys, tmp_path, command,
                                                                 out, expected):
    (tmp_path / "a-file").write_text("")
    out = out if out.startswith("/") else str(tmp_path / out)
    status, _, err = run_main(capsys, *command, "--out", out)
    assert status == 2 and err.startswith(f"soilbin: error: --out {out}: {expected}")
    assert len(err.strip().splitlines()) == 1


def test_toml_syntax_and_unknown_key_name_file_and_line(capsys, tmp_path):
    broken = tmp_path / "broken.toml"
    broken.write_text((SCENES / "block-drucker-prager.toml").read_text() + "\n[loading\n")
    status, _, err = run_main(capsys, "run", str(broken))
    assert status == 2 and "TOML syntax error" in err and str(broken) in err and "line" in err

    unknown = tmp_path / "unknown.toml"
    unknown.write_text((SCENES / "block-drucker-prager.toml").read_text()
                       .replace("[loading]", "[loading]\nspeed = 3"))
    status, _, err = run_main(capsys, "run", str(unknown))
    assert status == 2 and "loading: unknown key 'speed'" in err


def test_list_shows_every_scene_with_its_title(capsys):
    status, out, _ = run_main(capsys, "list")
    assert status == 0
    names = [line.split()[0] for line in out.splitlines()]
    assert names == sorted(p.stem for p in SCENES.glob("*.toml"))
    assert all(len(line.split()) > 3 for line in out.splitlines())


def test_help_answers():
    for args in (["--help"], ["run", "--help"], ["list", "--help"]):
        with pytest.raises(SystemExit) as exit_info:
            main(args)
        assert exit_info.value.code == 0


def test_installed_command_json_summary_and_run_folder(tmp_path):
    """The real entry point: --json makes the last stdout line the summary; files on disk."""
    done = soilbin_cli("run", "column-elastic", "--json", "--out", tmp_path / "col",
                       "--set", "materials.soil.E=4500")
    assert done.returncode == 0, done.stderr
    summary = last_json(done.stdout)
    for key in ("scene", "n_dofs", "n_steps", "newton_iterations", "wall_s", "converged",
                "top_settlement", "pressure"):
        assert key in summary
    assert summary["top_settlement"] == pytest.approx(100 * 10 / 5000.0, rel=1e-8)
    assert json.loads((tmp_path / "col" / "summary.json").read_text()) == summary
    resolved = (tmp_path / "col" / "scene.toml").read_text()
    assert "E = 4500.0" in resolved
    # the resolved scene runs again as it is
    again = soilbin_cli("run", tmp_path / "col" / "scene.toml", "--json", "--out", tmp_path / "again")
    assert last_json(again.stdout)["top_settlement"] == summary["top_settlement"]
    reader = meshio.xdmf.TimeSeriesReader(str(tmp_path / "col" / "fields.xdmf"))
    points, cells = reader.read_points_cells()
    assert reader.num_steps == 1 + summary["n_steps"] and cells[0].type == "hexahedron"
    t, point_data, cell_data = reader.read_data(reader.num_steps - 1)
    top = np.isclose(points[:, 2], points[:, 2].max())
    assert t == pytest.approx(1.0) and point_data["displacement"][top, 2] == pytest.approx(
        -summary["top_settlement"], rel=1e-8)
    assert cell_data["stress"][0][:, 8] == pytest.approx(-summary["pressure"], rel=1e-8)


def test_installed_command_bad_input_has_no_traceback():
    done = soilbin_cli("run", "block-drucker-prager", "--set", "materials.soil.phi=95")
    assert done.returncode == 2
    assert "Traceback" not in done.stderr and "phi" in done.stderr


def test_a_run_that_cannot_finish_keeps_its_steps(tmp_path):
    """Force control past collapse without until_collapse: exit 1, converged steps on disk."""
    done = soilbin_cli("run", "strip-load-von-mises", "--json", "--out", tmp_path / "fail",
                       "--set", "loading.until_collapse=false", "--set", "loading.max_cuts=2")
    assert done.returncode == 1
    summary = last_json(done.stdout)
    assert summary["status"] == "failed" and not summary["converged"]
    assert "smallest increment" in done.stderr
    rows = (tmp_path / "fail" / "curve.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + summary["n_steps"] and summary["n_steps"] >= 8


@pytest.mark.parametrize("override, expected", [
    ("regions.soil=[1]", "regions.soil = [1]: no such material; defined in [materials]: soil"),
    ("materials.soil.model={a = 1}", "materials.soil.model = {'a': 1}: unknown material model; known: elastic"),
    ('mesh.builder=["box"]', "mesh.builder = ['box']: unknown mesh builder; known: box"),
    ("headline=5", "headline: expected a table, got 5"),
    ("supports=5", "supports: expected an array of tables [[supports]], got 5"),
    ("mesh.lx=inf", "mesh.lx = inf is outside the accepted range (0, 1e+06]"),
    ("mesh.lx=1e300", "mesh.lx = 1e+300 is outside the accepted range (0, 1e+06]"),
    ("mesh.lx=nan", "mesh.lx = nan is outside the accepted range (0, 1e+06]"),
    ("loading.magnitude=inf", "loading.magnitude = inf is outside the accepted range [1e-20, 1e+20]"),
    ("loading.steps=1000000", "loading.steps = 1000000 is outside the accepted range [1, 10000]"),
    ("mesh.nz=1000000000", "mesh.nx, ny, nz give about 4e+09 cells; accepted: at most 1e+06"),
    ("mesh.nz=1e9", "mesh.nz: expected an integer, got 1000000000.0"),
    ("materials.soil.E=inf", "materials.soil.E = inf is outside the accepted range [1e-20, 1e+20]"),
    ("analysis.frame_rotation=[0, nan, 0]", "analysis.frame_rotation = (0.0, nan, 0.0): expected finite numbers"),
    ("analysis.frame_rotation=[1e308, 0, 0]",
     "analysis.frame_rotation = [1e+308, 0.0, 0.0]: expected components in [-360, 360] degrees"),
])
def test_names_tables_and_numbers_out_of_bounds_are_one_clear_line(capsys, override, expected):
    status, _, err = run_main(capsys, "run", BLOCK, "--set", override)
    assert status == 2 and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert f"{BLOCK}: {expected}" in err


@pytest.mark.parametrize("scene, overrides, expected", [
    ("tine-2in-90deg", ["geostatic.surface=nan"], "geostatic.surface = nan is outside the accepted range [-1e+06, 1e+06]"),
    ("tine-2in-90deg", ["geostatic.unit_weight=inf"],
     "geostatic.unit_weight = inf is outside the accepted range [0, 1e+20]"),
    ("tine-2in-90deg", ["mesh.refine=1000000"], "mesh.refine = 1000000 is outside the accepted range [1, 32]"),
    ("tine-2in-90deg", ["mesh.refine=32"],
     "mesh.element_size, growth, refine and the extents give about 1.03e+08 cells; accepted: at most 1e+06"),
    ("tine-2in-90deg", ["mesh.element_size=1e-3"],
     "mesh.element_size, growth, refine and the extents give about 6.49e+08 cells"),
    ("strip-footing-von-mises", ["mesh.size_growth=1e-9"],
     "mesh.size_growth = 1e-09 is outside the accepted range [0.01, 2]"),
    ("strip-footing-von-mises", ["mesh.size_growth=0.01", "mesh.refine=7"],
     "mesh.edge_size, far_size, size_growth, refine give about 2.91e+06 cells; accepted: at most 1e+06"),
    ("retaining-wall-passive", ["mesh.element_size=1e-2", "mesh.growth=1.0"],
     "mesh.element_size, growth, refine give about 4.5e+06 cells; accepted: at most 1e+06"),
])
def test_absurd_meshes_are_refused_before_gmsh_runs(capsys, monkeypatch, scene, overrides, expected):
    import gmsh
    monkeypatch.setattr(gmsh, "initialize", lambda *a, **k: pytest.fail("gmsh ran"))
    status, _, err = run_main(capsys, "run", scene, *(f"--set={o}" for o in overrides))
    assert status == 2 and len(err.strip().splitlines()) == 1
    assert f"{scene}.toml: {expected}" in err


def test_a_scene_that_is_not_utf8_is_a_clear_error(capsys, tmp_path):
    latin1 = tmp_path / "latin1.toml"
    latin1.write_bytes((SCENES / "block-drucker-prager.toml").read_bytes().replace(b"Drucker", b"Dr\xfccker"))
    status, _, err = run_main(capsys, "run", str(latin1))
    assert status == 2 and "Traceback" not in err
    assert f"{latin1}: not UTF-8 text (byte " in err


def test_resume_without_a_checkpoint_is_one_clear_line(capsys, tmp_path):
    status, out, err = run_main(capsys, "run", BLOCK, "--resume", "no/such/run", "--out", str(tmp_path))
    assert status == 2 and len(err.strip().splitlines()) == 1
    assert "--resume no/such/run: no checkpoint there" in err


def test_a_resumed_run_goes_next_to_the_one_it_resumes(capsys, tmp_path):
    assert run_main(capsys, "run", "column-elastic", "--out", str(tmp_path / "a"))[0] == 0
    status, _, err = run_main(capsys, "run", "column-elastic", "--resume", str(tmp_path / "a"))
    assert status == 0 and f"results in {tmp_path / 'a-resumed'} (resumed after step" in err
    assert json.loads((tmp_path / "a-resumed" / "summary.json").read_text())["resumed_from"]


def test_verbose_prints_every_newton_iterate(capsys, tmp_path):
    """-v: a line per iterate, the first (iteration 0) before any correction, then each step's
    line; the last iterate of a step is below its target."""
    status, out, err = run_main(capsys, "run", "column-elastic-large", "-v", "--out", str(tmp_path))
    summary = json.loads((tmp_path / "summary.json").read_text())
    lines = [line.split() for line in err.splitlines() if line.startswith("  Newton")]
    assert status == 0
    assert len(lines) == summary["newton_iterations"] + summary["n_steps"]
    assert sum(line[1] == "0" for line in lines) == summary["n_steps"]
    last = [lines[i] for i in range(len(lines)) if i + 1 == len(lines) or lines[i + 1][1] == "0"]
    assert all(float(line[3]) <= float(line[5]) for line in last)
    # the peak resident memory (one rank here: this process's), never falling
    peaks = [float(line[9]) for line in lines]
    assert all(line[8] == "peak" and line[10] == "GB" for line in lines)
    assert peaks == sorted(peaks)
    # printed to 0.01 GB: rounding is monotone, so the printed peak is at most ru_maxrss rounded alike
    assert 0.0 < peaks[-1] <= round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20, 2)
