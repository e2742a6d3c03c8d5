"""soilbin study: parsing and checking study files, case folders, resuming, the collected table."""
import csv
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from soilbin.app.cli import main
from soilbin.closed_form.verification import column_settlement
from soilbin.app.study import SUMMARY_KEYS, _earlier, _short_names, folder_name, load_study
from conftest import ROOT

COLUMN = """\
title = "column: settlement against E"
scene = "column-elastic"
[set]
mesh.nz = 2
[product]
materials.soil.E = [4500, 9000]
"""
FIGURES = """\
[[figures]]
name = "settlement"
kind = "sweep"
x = "materials.soil.E"
y = "top_settlement"
[[figures]]
name = "curves"
"""


def settlement(E, nu=0.2, p=100.0, L=10.0):
    """w = pL/M of the constrained column (eq. 7.1) of the study's scene."""
    return column_settlement(p, L, E, nu)


def study_file(tmp_path, text, name="study.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize("text, expected", [
    ("jobz = 2\n" + COLUMN, "unknown key 'jobz'; top-level keys"),
    (COLUMN.replace('"column-elastic"', '""'), "scene: expected a non-empty string"),
    (COLUMN + "[run]\njobs = 0\n", "run.jobs = 0 is outside the accepted range"),
    (COLUMN.replace("[4500, 9000]", "4500"), "product.materials.soil.E: expected a non-empty list"),
    (COLUMN.replace("[4500, 9000]", "[4500, -9000]"),
     "case E=-9000: " + str(ROOT / "scenes" / "column-elastic.toml")
     + ": materials.soil.E = -9000.0 is outside"),
    (COLUMN + "[[case]]\nmaterials.soil.Young = 3\n", "unknown key 'Young'"),
    (COLUMN + "[[case]]\nmaterials.soil.E = 3\n",
     "case[0].materials.soil.E: the key is also swept in [product]"),
    (COLUMN.replace("[4500, 9000]", "[4500, 4500]"), "case E=4500: listed twice"),
    (COLUMN + FIGURES.replace('x = "materials.soil.E"', 'x = "mesh.nz"'),
     "figures[0].x = 'mesh.nz': expected one of materials.soil.E"),
    (COLUMN + FIGURES.replace('y = "top_settlement"', 'y = "draft"'), "figures[0].y = 'draft'"),
    (COLUMN + FIGURES + 'x = "time"\n', "figures[1].x = 'time': expected one of step,"),
    (COLUMN + FIGURES + "select = {mesh.nz = 2}\n", "figures[1].select.mesh.nz: no case sets"),
    (COLUMN + '[table]\ncolumns = ["E", "top_settlement"]\n', "table.columns[0] = 'E'"),
    (COLUMN + "[set\n", "TOML syntax error"),
    (COLUMN + "[[case]]\nlabel = 3\n", "case[0].label: expected a string, got 3"),
    (COLUMN + FIGURES.replace('name = "curves"', 'name = "../x/curves"'),
     "figures[1].name = '../x/curves': expected a file name in the study folder"),
    (COLUMN + FIGURES.replace('name = "curves"', 'name = ".."'), "figures[1].name = '..'"),
])
def test_bad_study_is_one_line_naming_file_and_key(capsys, tmp_path, text, expected):
    path = study_file(tmp_path, text)
    status = main(["study", str(path), "--dry-run"])
    err = capsys.readouterr().err
    assert status == 2
    assert f"{path}: " in err and expected in err
    assert "Traceback" not in err and len(err.strip().splitlines()) <= 2


@pytest.mark.parametrize("out, expected", [("/proc/foo", "cannot write there"),
                                           ("a-file", "a file, not a folder")])
def test_an_out_the_study_cannot_write_in_is_bad_input_before_any_case(capsys, tmp_path, out,
                                                                        expected):
    (tmp_path / "a-file").write_text("")
    out = out if out.startswith("/") else str(tmp_path / out)
    status = main(["study", str(study_file(tmp_path, COLUMN)), "--out", out])
    err = capsys.readouterr().err
    assert status == 2 and err.strip() == f"soilbin: error: --out {out}: {expected}" + (
        " (No such file or directory)" if out == "/proc/foo" else "")


def test_case_folders_are_named_after_their_own_values():
    short = _short_names(("materials.soil.E", "materials.clay.E", "mesh.nz"))
    assert short == {"materials.soil.E": "soil.E", "materials.clay.E": "clay.E", "mesh.nz": "nz"}
    assert folder_name({"mesh.nz": 2, "materials.soil.E": 4500.0}, short) == "soil.E=4500.0,nz=2"
    assert folder_name({}, short) == "base"
    odd = folder_name({"materials.soil.E": "a/b c"}, short)   # not filesystem-safe: a hash
    assert odd.startswith("soil.E=a_b_c-") and len(odd) == len("soil.E=a_b_c-") + 8
    long = folder_name({"materials.soil.E": "x" * 100}, short)
    assert len(long) == 64 and long != folder_name({"materials.soil.E": "x" * 101}, short)


def test_cases_are_every_listed_case_with_every_combination(tmp_path):
    study = load_study(study_file(tmp_path, COLUMN.replace("[4500, 9000]", "[4500, 9000, 18000]")
                                  + "[[case]]\nloading.magnitude = 50\n"
                                  + "[[case]]\nloading.magnitude = 100\nloading.steps = 2\n"))
    assert [case.name for case in study.cases] == [
        f"magnitude=50,E={E}" for E in (4500, 9000, 18000)] + [
        f"magnitude=100,E={E},steps=2" for E in (4500, 9000, 18000)]
    last = study.cases[-1]
    assert last.overrides == ("mesh.nz=2", "loading.magnitude=100", "loading.steps=2",
                              "materials.soil.E=18000")
    assert last.scene.loading.steps == 2 and last.scene.materials["soil"].E == 18000.0
    assert study.columns == ("loading.magnitude", "materials.soil.E", "loading.steps", "status",
                             "top_settlement", "pressure", "n_dofs", "newton_iterations", "wall_s")


TINE = f"""\
title = "2-in tine, bonded or not, two widths"
scene = "{ROOT / 'scenes' / 'tine-2in-90deg.toml'}"
[product]
mesh.tool_width = [1, 2]
[[case]]
label = "bonded"
tool.bonded = true
[[case]]
tool.bonded = false
[[figures]]
name = "curves"
[[figures]]
name = "sweep"
kind = "sweep"
x = "mesh.tool_width"
y = "draft_force_at"
lines = "tool.bonded"
"""


def _tine_outcomes(tmp_path):
    """The TINE study with made-up curves and summaries in its case folders."""
    from soilbin.app.study import Outcome
    study = load_study(study_file(tmp_path, TINE))
    outcomes = []
    for i, case in enumerate(study.cases):
        (tmp_path / case.name).mkdir()
        (tmp_path / case.name / "curve.csv").write_text(
            f"step,displacement,force\n1,0.05,{10 + i}\n2,0.1,{20 + i}\n")
        outcomes.append(Outcome(case, "complete", {"draft_force_at": 20.0 + i}, ran=False))
    return study, outcomes


def test_study_figures_read_as_quantities_and_cases_in_words(tmp_path):
    """Axes with units; a labelled case's legend is its label and the values it does not name
    (its [product] values), an unlabelled one's its values in words."""
    from soilbin.app.study_figures import curves_figure, sweep_figure
    study, outcomes = _tine_outcomes(tmp_path)
    assert [case.label for case in study.cases] == ["bonded", "bonded", "", ""]
    curves, sweep = study.figures
    ax = curves_figure(curves, outcomes, study, tmp_path).axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("tool travel [in]", "draft [lb]")
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "bonded, tool width 1 in", "bonded, tool width 2 in",
        "bonded = false, tool width 1 in", "bonded = false, tool width 2 in"]
    assert ax.get_lines()[0].get_xydata().tolist() == [[0, 0], [0.05, 10], [0.1, 20]]
    ax = sweep_figure(sweep, outcomes, study).axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("tool width [in]", "draft [lb]")
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["bonded = true",
                                                                   "bonded = false"]


def test_past_ten_curves_a_study_figure_dashes_the_default_colours(tmp_path):
    """The eleventh curve has the first one's colour, dashed (the clay's paths study draws
    twelve)."""
    from soilbin.app.study_figures import curves_figure
    study, outcomes = _tine_outcomes(tmp_path)
    lines = curves_figure(study.figures[0], outcomes * 3, study, tmp_path).axes[0].get_lines()
    assert len(lines) == 12
    assert [line.get_linestyle() for line in (lines[0], lines[9], lines[10])] == ["-", "-", "--"]
    assert lines[10].get_color() == lines[0].get_color() != lines[1].get_color()


def test_a_long_legend_goes_beside_the_axes_not_over_the_curves(tmp_path):
    """Four cases: the legend inside the axes; twelve: to their right, the figure wider."""
    from soilbin.app.study_figures import curves_figure
    study, outcomes = _tine_outcomes(tmp_path)
    for copies, outside in ((1, False), (3, True)):
        fig = curves_figure(study.figures[0], outcomes * copies, study, tmp_path)
        fig.canvas.draw()
        ax = fig.axes[0]
        legend_box = ax.get_legend().get_window_extent()
        assert bool(legend_box.x0 > ax.get_window_extent().x1) == outside
        assert fig.get_size_inches()[0] == (9.5 if outside else 6.5)


def test_the_table_names_labelled_cases(tmp_path):
    from soilbin.app.study import write_table
    study, outcomes = _tine_outcomes(tmp_path)
    write_table(study, outcomes, tmp_path)
    lines = (tmp_path / "table.md").read_text().splitlines()
    assert lines[4].startswith("| case | bonded | tool_width | status |")
    assert [line.split(" | ")[:3] for line in lines[6:]] == [
        ["| bonded", "true", "1"], ["| bonded", "true", "2"], ["| ", "false", "1"],
        ["| ", "false", "2"]]
    assert (tmp_path / "table.csv").read_text().startswith("case,bonded,tool_width,status")


def test_the_chapter_viii_cases_are_labelled():
    study = load_study(ROOT / "studies" / "chapter8.toml")
    assert all(case.label for case in study.cases)
    figure_83 = [case.label for case in study.cases if case.values["mesh.configuration"]
                 == "embedded" and case.values["mesh.tool_width"] == 2
                 and case.values["mesh.rake_angle"] == 90]
    assert figure_83 == ["bonded, small deformation", "interface, small deformation",
                         "interface, large deformation"]


@pytest.mark.parametrize("path", sorted((ROOT / "studies").glob("*.toml")), ids=lambda p: p.stem)
def test_every_shipped_study_loads_with_distinct_cases(path):
    """Each study's scene and every case's overrides pass the scene reader (what
    `soilbin study --dry-run` checks), and no two cases share a folder."""
    study = load_study(path)
    names = [case.name for case in study.cases]
    assert names and len(set(names)) == len(names)


def test_the_chapter_viii_cases_are_titled_by_their_tool():
    """The sections and curve of a case name its own tool, not the default scene's."""
    study = load_study(ROOT / "studies" / "chapter8.toml")
    for case in study.cases:
        values, title = case.values, case.scene.title
        where = "against the side wall" if values["mesh.configuration"] == "side_wall" else "embedded"
        assert where in title and f"{values['mesh.tool_width']}-in" in title
        assert ("bonded" if values["tool.bonded"] else "interface") in title


def test_an_earlier_run_stands_only_for_the_same_overrides_and_scene(tmp_path):
    case = load_study(study_file(tmp_path, COLUMN)).cases[0]
    folder = tmp_path / case.name
    folder.mkdir()
    assert _earlier(case, folder, retry_failed=False) is None   # never ran

    def earlier(status, overrides=case.overrides, resolved=case.scene.resolved(), retry=False):
        (folder / "summary.json").write_text(json.dumps({"status": status,
                                                         "overrides": list(overrides)}))
        (folder / "scene.toml").write_text(resolved)
        found = _earlier(case, folder, retry_failed=retry)
        return found and found.status
    assert earlier("complete") == "complete" and earlier("collapse") == "collapse"
    assert earlier("failed") == "failed"                    # reported, not rerun
    assert earlier("failed", retry=True) is None            # --retry-failed
    assert earlier("complete", retry=True) == "complete"
    assert earlier("complete", overrides=case.overrides[:-1]) is None        # another case's
    edited = case.scene.resolved().replace("E = 4500.0", "E = 4501.0")   # the base scene changed
    assert earlier("complete", resolved=edited) is None
    # a run recorded before a key was added (here the line search, at its default) is
    # still this case's; the same key at another value is not
    before = case.scene.resolved().replace('line_search = "bt"\n', "")
    assert before != case.scene.resolved()
    assert earlier("complete", resolved=before) == "complete"
    other = case.scene.resolved().replace('line_search = "bt"', 'line_search = "cp"')
    assert earlier("complete", resolved=other) is None
    assert earlier("complete", resolved="title = ") is None                 # no longer reads
    (folder / "summary.json").write_text('{"status": ')     # cut short
    assert _earlier(case, folder, retry_failed=False) is None


def test_tool_geometry_study_parses_and_dry_runs(capsys, tmp_path):
    path = ROOT / "studies" / "tool-geometry.toml"
    study = load_study(path)
    assert len(study.cases) == 16 and len({case.name for case in study.cases}) == 16
    assert study.cases[9].name == "rake_angle=45,tool_width=2"
    mesh = study.cases[9].scene.mesh
    assert (mesh.rake_angle, mesh.tool_width) == (45.0, 2.0)
    assert all(case.scene.loading.magnitude == 0.05 for case in study.cases)
    assert [(f.kind.value, f.x, f.lines) for f in study.figures[:2]] == [
        ("sweep", "mesh.rake_angle", "mesh.tool_width"), ("sweep", "mesh.tool_width",
                                                           "mesh.rake_angle")]
    assert main(["study", str(path), "--dry-run", "--out", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 16 and all(": to run: --set loading.magnitude=0.05" in x for x in lines)


def _study_command(path, out):
    env = dict(os.environ, OMP_NUM_THREADS="1",
               PYTHONPATH=os.pathsep.join(filter(None, (str(ROOT), os.environ.get("PYTHONPATH")))))
    return [sys.executable, "-m", "soilbin.app.cli", "study", str(path), "--out", str(out)], env


def _processes_writing(folder):
    """Processes whose command line names the folder (a case still running)."""
    found = []
    for proc in Path("/proc").iterdir():
        try:
            if proc.name.isdigit() and str(folder) in (proc / "cmdline").read_text():
                found.append(proc.name)
        except OSError:
            pass
    return found


@pytest.mark.slow
def test_study_runs_resumes_after_a_kill_and_writes_its_table(tmp_path):
    path = study_file(tmp_path, COLUMN + FIGURES)
    out = tmp_path / "out"
    first, second = out / "E=4500", out / "E=9000"
    command, env = _study_command(path, out)

    # stopped by SIGTERM while the second case runs
    study = subprocess.Popen(command, env=env, stderr=subprocess.PIPE, text=True)
    for line in study.stderr:
        if line.startswith("[2/2] E=9000: running"):
            break
    study.send_signal(signal.SIGTERM)
    _, err = study.communicate(timeout=30)
    assert study.returncode == 128 + signal.SIGTERM, err
    assert "interrupted by SIGTERM" in err
    assert (first / "summary.json").exists() and not (second / "summary.json").exists()
    assert _processes_writing(second) == []    # the running case was stopped with the study
    table = (out / "table.md").read_text()   # what is done so far, the rest unfinished
    assert "1 of 2 cases complete" in table and "| 9000 | unfinished |" in table
    assert (out / "curves.png").exists()
    done_at = (first / "summary.json").stat().st_mtime_ns

    # run again: the first case stands, the second runs
    again = subprocess.run(command, env=env, capture_output=True, text=True, timeout=120)
    assert again.returncode == 0, again.stderr
    assert "[1/2] E=4500: complete earlier" in again.stderr
    assert "[2/2] E=9000: complete in" in again.stderr
    assert (first / "summary.json").stat().st_mtime_ns == done_at

    summaries = [json.loads((folder / "summary.json").read_text()) for folder in (first, second)]
    assert [s["overrides"] for s in summaries] == [["mesh.nz=2", "materials.soil.E=4500"],
                                                   ["mesh.nz=2", "materials.soil.E=9000"]]
    assert set(SUMMARY_KEYS) <= set(summaries[0])
    with open(out / "table.csv") as f:
        rows = list(csv.DictReader(f))
    assert [row["E"] for row in rows] == ["4500", "9000"]
    for row, summary, E in zip(rows, summaries, (4500, 9000)):
        assert row["status"] == "complete"
        assert float(row["top_settlement"]) == summary["top_settlement"]
        assert float(row["top_settlement"]) == pytest.approx(settlement(E), rel=1e-8)
        assert int(row["n_dofs"]) == summary["n_dofs"] == 36
    table = (out / "table.md").read_text()
    assert "2 of 2 cases complete" in table
    assert "| 4500 | complete | 0.2 | 100 | 36 |" in table
    assert "| 9000 | complete | 0.1 | 100 | 36 |" in table
    assert all((out / f"{name}.png").stat().st_size > 10000 for name in ("settlement", "curves"))
