"""Figures a reader understands: units read off a scene's ``units``, axes as quantities with
their units, the closed-form estimate inside the axes or, far off, in the legend."""
from pathlib import Path
from types import SimpleNamespace

import pytest

from soilbin.records.units import FORCES, LENGTHS, read_units

ROOT = Path(__file__).resolve().parent.parent
SCENES = sorted((ROOT / "scenes").glob("*.toml"))


@pytest.mark.parametrize("text, force, length, stress, curve_force", [
    ("lb, in (stresses in psi, unit weight in pci)", "lb", "in", "psi", "lb"),
    ("lb, ft (stresses in psf)", "lb", "ft", "psf", "lb"),
    ("lb, in (stresses in psi; forces per inch of strip)", "lb", "in", "psi", "lb/in"),
    ("kN, m", "kN", "m", "kPa", "kN"),
    ("N,mm", "N", "mm", "MPa", "N"),
    ("kip, yd", "kip", "yd", "kip/yd²", "kip"),
    ("any consistent units (length L, force F): E and p in F/L^2", "F", "L", "F/L²", "F"),
    ("furlongs, fortnights", "F", "L", "F/L²", "F"),
    ("SI", "F", "L", "F/L²", "F"),
])
def test_units_are_read_off_the_leading_force_and_length(text, force, length, stress, curve_force):
    units = read_units(text)
    assert (units.force, units.length, units.stress, units.curve_force) == (
        force, length, stress, curve_force)


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_every_shipped_scene_names_its_force_and_length(path):
    """A named pair, or the symbols F and L of a scene in any consistent units."""
    from soilbin.records.scene import load_scene
    scene = load_scene(path)
    units = scene.unit_system
    if scene.units.startswith("any consistent units"):
        assert (units.force, units.length) == ("F", "L")
    else:
        assert units.force in FORCES and units.length in LENGTHS


def _steps(travel, draft, **columns):
    return [SimpleNamespace(displacement=x, force=f, columns={k: v[i] for k, v in columns.items()})
            for i, (x, f) in enumerate(zip(travel, draft))]


def _legend(ax):
    return [text.get_text() for text in ax.get_legend().get_texts()]


def _horizontal_lines(ax):
    return [line.get_ydata()[0] for line in ax.get_lines() if len(set(line.get_ydata())) == 1
            and len(line.get_ydata()) == 2]


@pytest.fixture
def tine():
    from soilbin.records.scene import load_scene
    return load_scene(ROOT / "scenes" / "tine-2in-90deg.toml", ["mesh.configuration=embedded"])


def test_the_draft_curve_draws_the_estimate_within_its_range(tine):
    """Embedded tool to 108 lb: the laboratory estimate (129 lb, within 1.3 x 108) a dashed
    line; the cap surface's (1540 lb) a number in the legend, the y axis not stretched."""
    from soilbin.app.figures import curve_figure
    from soilbin.app.estimates import draft_estimates
    lab, cap = draft_estimates(tine)
    fig = curve_figure(_steps([0.1, 0.5, 0.94], [36.0, 72.0, 108.0]), tine, [lab, cap])
    ax = fig.axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("tool travel [in]", "draft [lb]")
    assert _horizontal_lines(ax) == [pytest.approx(lab.draft)]
    assert lab.draft < ax.get_ylim()[1] < 1.3 * 108.0 * 1.1
    assert _legend(ax) == [
        "finite elements",
        "McKyes & Ali (1977) narrow blade: 129 lb\nlaboratory, section VII.5: φ = 33°, c = 0 psi",
        "McKyes & Ali (1977) narrow blade: 1537 lb (off scale)\nfailure surface linearised at "
        "I1 = 2.86 psi: φ = 50.6°, c = 0.079 psi"]
    assert tine.title.startswith(ax.get_title().split("\n")[0])


def test_an_estimate_far_above_the_curve_stays_off_the_axes(tine):
    from soilbin.app.figures import curve_figure
    from soilbin.app.estimates import draft_estimate
    lab = draft_estimate(tine)
    ax = curve_figure(_steps([0.05, 0.1], [15.0, 21.7]), tine, [lab]).axes[0]
    assert _horizontal_lines(ax) == [] and ax.get_ylim()[1] < 30.0
    assert _legend(ax)[1].startswith("McKyes & Ali (1977) narrow blade: 129 lb (off scale)\n")


def test_a_loaded_boundary_draws_its_pressure_against_its_settlement():
    from soilbin.app.figures import curve_figure
    from soilbin.records.scene import load_scene
    scene = load_scene(ROOT / "scenes" / "strip-footing-von-mises.toml")
    ax = curve_figure(_steps([0.01, 0.02], [40.0, 80.0], pressure=[20.0, 40.0]), scene).axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("settlement [in]", "pressure [psi]")
    assert ax.get_lines()[0].get_ydata().tolist() == [0.0, 20.0, 40.0]
    assert ax.get_legend() is None


def test_axes_words_of_curve_columns_summary_keys_and_swept_keys():
    from soilbin.app.figure_labels import column_label, key_label, key_value, summary_label
    from soilbin.records.scene import load_scene
    tine = load_scene(ROOT / "scenes" / "tine-2in-90deg.toml")
    assert [column_label(c, tine) for c in ("lift", "wall_s", "newton_iterations")] == [
        "lift [lb]", "wall time [s]", "Newton iterations"]
    assert summary_label("draft_force_at", tine) == "draft [lb]"
    assert summary_label("n_dofs", tine) == "degrees of freedom"
    assert key_label("mesh.rake_angle", tine) == "rake angle [°]"
    assert key_label("loading.magnitude", tine) == "tool travel [in]"
    assert key_value("mesh.tool_width", 2, tine) == "tool width 2 in"
    assert key_value("tool.bonded", True, tine) == "bonded = true"
    wall = load_scene(ROOT / "scenes" / "retaining-wall-passive.toml")
    assert column_label("force", wall) == "force on the wall [lb/in]"   # per inch of wall
    assert summary_label("passive_coefficient", wall) == "passive coefficient"
    load = load_scene(ROOT / "scenes" / "strip-load-von-mises.toml")
    assert summary_label("collapse_pressure", load) == "collapse pressure [psi]"
    assert key_label("loading.magnitude", load) == "pressure [psi]"


def test_a_tool_section_that_meets_no_tool_face_says_so_and_draws_nothing(tmp_path):
    """A tool given by a horizontal face of the bin (its base): the section at half its depth
    holds no tool point; the figure is not drawn, and the run is told why (it crashed)."""
    from conftest import make_problem
    from test_soil_bin import COARSE
    from soilbin.app.figures import tool_section_png
    problem = make_problem("tine-2in-90deg", *COARSE, 'tool.faces=["base"]')
    why = tool_section_png(problem, tmp_path / "tool-section.png")
    assert why.startswith("no face of the tool crosses the section at z = -6 in")
    assert not (tmp_path / "tool-section.png").exists()
    drawn = make_problem("tine-2in-90deg", *COARSE)
    assert tool_section_png(drawn, tmp_path / "tool-section.png") is None
    assert (tmp_path / "tool-section.png").exists()
