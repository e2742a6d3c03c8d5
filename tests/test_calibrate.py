"""soilbin calibrate: parameters recovered from synthetic laboratory curves made by the
material-point driver itself (1% Gaussian noise of each column's range, fixed seed),
honest standard errors and unidentified parameters, and bad input refused before fitting."""
import json
import tomllib

import numpy as np
import pytest

from soilbin.app.cli import main
from soilbin.calibration.fit import FAILED_RESIDUAL, residuals
from soilbin.calibration.output import calibrate
from soilbin.calibration.problem import read_calibration
from soilbin.calibration.synthetic import laboratory_csv
from soilbin.errors import InputError
from soilbin.material_point.driver import build_model, build_path
from soilbin.models import MODELS
from soilbin.models.cap import SECTION_VII5
from soilbin.params import from_table

DP_TRUTH = {"c": 2.0, "phi": 30.0}
DP_FIXED = {"E": 4000.0, "nu": 0.35, "matching": "compression_cone"}
CONFINING = (5.0, 10.0, 20.0)
STEPS = 20
NOISE = 0.01


def synthetic_curve(model_name, table, path, settings, x, y, rng, leg):
    """The driver's rows of ``leg`` at the true parameters as a CSV text, with Gaussian
    noise of NOISE times each compared column's range."""
    return laboratory_csv(build_model(model_name, table), build_path(path, settings), path,
                          x, y, (leg,), rng, NOISE)


def toml_value(v):
    return json.dumps(v) if not isinstance(v, dict) else \
        "{ " + ", ".join(f"{k} = {toml_value(w)}" for k, w in v.items()) + " }"


def write_calibration(folder, model, fit, fixed, tests):
    """FILE.toml of the calibration; ``tests``: (data name, csv text, table) each."""
    lines = [f"model = {toml_value(model)}", "[fit]"]
    lines += [f"{k} = {toml_value(v)}" for k, v in fit.items()]
    lines += ["[fixed]"] + [f"{k} = {toml_value(v)}" for k, v in fixed.items()]
    for name, text, table in tests:
        (folder / name).write_text(text)
        lines += ["[[test]]"] + [f"{k} = {toml_value(v)}" for k, v in
                                 {**table, "data": name}.items()]
    path = folder / "fit.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def dp_tests(seed=1):
    rng = np.random.default_rng(seed)
    table = {**DP_TRUTH, **DP_FIXED}
    tests = []
    for confining in CONFINING:
        settings = {"confining": confining, "steps": STEPS}
        text = synthetic_curve("drucker_prager", table, "triaxial-compression", settings,
                               "eps_axial", ("q", "eps_v"), rng, "shear")
        tests.append((f"tx{confining:g}.csv", text, {"path": "triaxial-compression",
                                                     "set": settings, "x": "eps_axial",
                                                     "y": ["q", "eps_v"]}))
    return tests


def dp_file(folder, start=(1.0, 25.0)):
    fit = {"c": [0.1, start[0], 20.0], "phi": [5.0, start[1], 50.0]}
    return write_calibration(folder, "drucker_prager", fit, DP_FIXED, dp_tests())


def assert_recovered(summary, truth):
    assert summary["status"] == "converged"
    for name, value in truth.items():
        fitted, se = summary["parameters"][name], summary["standard_errors"][name]
        assert abs(fitted - value) <= 0.02 * value, (name, fitted, value)
        assert abs(fitted - value) <= 2.0 * se, (name, fitted, value, se)
    assert summary["unidentified"] == {}


def test_drucker_prager_c_and_phi_from_three_triaxial_tests(tmp_path):
    summary = calibrate(dp_file(tmp_path), tmp_path / "out")
    assert_recovered(summary, DP_TRUTH)
    out = tmp_path / "out"
    assert {p.name for p in out.iterdir()} == set(summary["files"])
    assert json.loads((out / "summary.json").read_text())["parameters"] == summary["parameters"]
    # fit.csv: measured against fitted at every point of every compared column
    fit_rows = (out / "fit.csv").read_text().splitlines()
    assert len(fit_rows) == 1 + len(CONFINING) * 2 * STEPS   # the shear leg's rows


def test_a_start_far_from_the_truth_still_finds_it(tmp_path):
    summary = calibrate(dp_file(tmp_path, start=(15.0, 8.0)), tmp_path / "out")
    assert_recovered(summary, DP_TRUTH)


def test_material_toml_read_back_by_the_scene_reader(tmp_path):
    summary = calibrate(dp_file(tmp_path), tmp_path / "out")
    tables = tomllib.loads((tmp_path / "out" / "material.toml").read_text())["materials"]
    table = dict(tables[summary["material"]])
    model = from_table(MODELS[table.pop("model")], table, "materials.fit")
    assert model.c == summary["parameters"]["c"] and model.phi == summary["parameters"]["phi"]
    assert model.E == DP_FIXED["E"]


def test_a_tied_parameter_takes_the_value_of_its_partner(tmp_path):
    """psi tied to the fitted phi: associated flow at every trial, in material.toml too."""
    path = dp_file(tmp_path)
    path.write_text(path.read_text() + '[tied]\npsi = "phi"\n')
    calibration = read_calibration(path)
    assert calibration.model(np.array([2.0, 27.5])).psi == 27.5
    summary = calibrate(path, tmp_path / "out")
    assert_recovered(summary, DP_TRUTH)
    assert summary["parameters"]["psi"] == summary["parameters"]["phi"]
    assert summary["tied"] == {"psi": "phi"}


@pytest.mark.parametrize("tied, words", [('psi = "chi"', ["tied.psi = 'chi'", "accepted", "phi"]),
                                         ('nu = "phi"', ["'nu'", "[tied]", "[fixed]"])],
                         ids=["unknown partner", "tied and fixed"])
def test_bad_ties_are_refused(tmp_path, capsys, tied, words):
    path = dp_file(tmp_path)
    path.write_text(path.read_text() + f"[tied]\n{tied}\n")
    assert main(["calibrate", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    for word in words:
        assert word in err, (word, err)


@pytest.mark.parametrize("units, stress", [(None, "psi"), ('"kN, m"', "kPa"),
                                           ('"any consistent units"', "F/L²")])
def test_the_figures_stress_unit_is_read_as_a_scene_reads_its_units(tmp_path, units, stress):
    path = dp_file(tmp_path)
    if units is not None:
        path.write_text(f"units = {units}\n" + path.read_text())
    assert read_calibration(path).stress_unit == stress


MCC_TRUTH = {"lam": 0.2, "kappa": 0.04, "phi": 30.0}
MCC_FIXED = {"E": 1.0e4, "nu": 0.3, "e0": 1.0, "p_c0": 100.0, "elasticity": "pressure_dependent"}
MCC_TESTS = (   # data, path, its keys, x, y, the leg measured
    ("drained.csv", "triaxial-compression", {"axial_strain": 0.1}, "eps_axial", ("q", "eps_v"),
     "shear"),
    ("undrained.csv", "undrained-triaxial", {}, "eps_axial", ("q", "p"), "shear"),
    ("isotropic.csv", "hydrostatic", {"pressure": 400.0, "unload": False}, "p", ("eps_v",),
     "load"))


@pytest.mark.slow
def test_modified_cam_clay_lambda_kappa_m_from_drained_undrained_and_isotropic(tmp_path):
    """M through the critical-state friction angle phi (M = 6 sin phi / (3 - sin phi));
    every test from p = 100 on the normal compression line."""
    rng = np.random.default_rng(3)
    tests = []
    for data, path, keys, x, y, leg in MCC_TESTS:
        settings = {"p_initial": 100.0, "steps": STEPS, **keys}
        text = synthetic_curve("modified_cam_clay", {**MCC_TRUTH, **MCC_FIXED}, path, settings,
                               x, y, rng, leg)
        tests.append((data, text, {"path": path, "set": settings, "x": x, "y": list(y)}))
    fit = {"lam": [0.05, 0.1, 0.5], "kappa": [0.005, 0.02, 0.09], "phi": [15.0, 25.0, 45.0]}
    summary = calibrate(write_calibration(tmp_path, "modified_cam_clay", fit, MCC_FIXED, tests),
                        tmp_path / "out")
    assert_recovered(summary, MCC_TRUTH)


def test_e_and_nu_from_one_hydrostatic_test_names_nu_unidentified(tmp_path, capsys):
    rng = np.random.default_rng(2)
    settings = {"pressure": 50.0, "unload": False, "steps": STEPS}
    text = synthetic_curve("elastic", {"E": 4000.0, "nu": 0.3}, "hydrostatic", settings,
                           "p", ("eps_v",), rng, "load")
    path = write_calibration(tmp_path, "elastic", {"E": [500.0, 2000.0, 20000.0],
                                                   "nu": [0.0, 0.2, 0.45]}, {},
                             [("iso.csv", text, {"path": "hydrostatic", "set": settings,
                                                 "x": "p", "y": "eps_v"})])
    status = main(["calibrate", str(path), "--out", str(tmp_path / "out"), "--json"])
    summary = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert status in (0, 1) and status == (summary["status"] != "converged")
    assert "nu" in summary["unidentified"]
    assert "triaxial" in summary["unidentified"]["nu"]


def bad_input_cases():
    """(id, edit of the valid DP files, words the message must hold)."""
    return [
        ("missing column", ("tx5.csv", "eps_axial,q,eps_v", "eps_axial,qq,eps_v"), ["tx5.csv", "'q'"]),
        ("non-numeric column", ("tx5.csv", "\n0", "\nabc"), ["tx5.csv", "row 2", "'eps_axial'"]),
        ("row not a number", ("tx10.csv", "\n0", "\nnan"), ["tx10.csv", "row 2"]),
        ("x not monotone", ("tx20.csv", "eps_axial,q,eps_v\n", "eps_axial,q,eps_v\n1,1,1\n"),
         ["tx20.csv", "'eps_axial'", "monotone"]),
        ("fixed and fitted", ("fit.toml", "nu = 0.35", "nu = 0.35\nc = 1.0"), ["'c'", "[fixed]"]),
        ("missing from both", ("fit.toml", "nu = 0.35\n", ""), ["'nu'", "missing"]),
        ("y not a column list", ("fit.toml", "y = [\"q\", \"eps_v\"]", "y = []"), ["test 1", "y = []"]),
        ("bounds cross", ("fit.toml", "[0.1, 1.0, 20.0]", "[30.0, 1.0, 20.0]"), ["fit.c", "upper"]),
        ("start outside", ("fit.toml", "[0.1, 1.0, 20.0]", "[0.1, 25.0, 20.0]"), ["fit.c", "start"]),
        ("unknown model", ("fit.toml", '"drucker_prager"', '"drucker"'), ["'drucker'", "known"]),
        ("unknown path key", ("fit.toml", "confining = 5.0", "confinement = 5.0"),
         ["test 1", "'confinement'", "accepted keys"]),
        ("model's own check", ("fit.toml", "nu = 0.35", "nu = 0.7"), ["nu", "accepted range"]),
    ]


def test_a_missing_calibration_file_is_named_as_one(capsys, tmp_path):
    status = main(["calibrate", str(tmp_path / "no.toml")])
    assert status == 2
    assert capsys.readouterr().err.strip() == f"soilbin: error: {tmp_path / 'no.toml'}: no such calibration file"


@pytest.mark.parametrize("name, edit, words", bad_input_cases(), ids=[c[0] for c in bad_input_cases()])
def test_bad_input_is_refused_before_fitting(tmp_path, capsys, name, edit, words):
    path = dp_file(tmp_path)
    file, old, new = edit
    text = (tmp_path / file).read_text()
    assert old in text
    (tmp_path / file).write_text(text.replace(old, new, 1))
    status = main(["calibrate", str(path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert status == 2
    assert len(err.strip().splitlines()) == 1
    for word in words:
        assert word in err, (word, err)
    assert not (tmp_path / "out").exists()


def test_fewer_points_than_parameters_is_refused(tmp_path, capsys):
    text = "eps_axial,q\n0.01,5\n0.02,6\n"
    path = write_calibration(tmp_path, "drucker_prager",
                             {"E": [500.0, 2000.0, 2e4], "c": [0.1, 1.0, 20.0],
                              "phi": [5.0, 25.0, 50.0]}, {"nu": 0.35, "matching": "compression_cone"},
                             [("short.csv", text, {"path": "triaxial-compression",
                                                   "set": {"confining": 5.0}, "x": "eps_axial",
                                                   "y": ["q"]})])
    assert main(["calibrate", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "2 measured values for 3 fitted parameters" in err and str(path) in err


def test_parameters_the_model_refuses_give_a_large_residual(tmp_path):
    """psi = 25 fixed: a trial phi below it is refused by the model, not by the fit."""
    calibration = read_calibration(write_calibration(
        tmp_path, "drucker_prager", {"c": [0.1, 1.0, 20.0], "phi": [5.0, 30.0, 50.0]},
        {**DP_FIXED, "psi": 25.0}, dp_tests()))
    assert np.all(residuals(np.array([2.0, 30.0]), calibration) < 10.0)
    assert np.all(residuals(np.array([2.0, 20.0]), calibration) == FAILED_RESIDUAL)


CAP_TRUTH = {k: v for k, v in SECTION_VII5.items() if k not in ("nu", "B")}
CAP_FIXED = {"nu": SECTION_VII5["nu"], "B": SECTION_VII5["B"]}
SEATING = 1.0   # psi: every cap test starts from it (a seating pressure, as in the laboratory)


def hydrostatic_with_unloading(table, rng, pressure=100.0):
    """(settings, csv text with a leg column) of a hydrostatic test loaded to ``pressure``
    and unloaded to the seating pressure: p is not monotone, each leg is."""
    settings = {"p_initial": SEATING, "pressure": pressure, "steps": 10}
    return settings, laboratory_csv(build_model("modified_cap", table),
                                    build_path("hydrostatic", settings), "hydrostatic", "p",
                                    ("eps_v",), ("load", "unload"), rng, NOISE, leg_column=True)


@pytest.mark.slow
def test_a_leg_column_places_the_unloading_points_on_the_unloading_leg(tmp_path):
    """E from the unloading leg's slope (nu fixed), W and D from the loading leg's
    compaction: one hydrostatic test with unloading fixes the three."""
    settings, text = hydrostatic_with_unloading({**CAP_TRUTH, **CAP_FIXED},
                                                np.random.default_rng(4))
    fixed = {**CAP_FIXED, **{k: CAP_TRUTH[k] for k in ("A", "C", "beta", "R")}}
    path = write_calibration(tmp_path, "modified_cap",
                             {"E": [500.0, 2000.0, 20000.0], "W": [0.05, 0.1, 0.5],
                              "D": [0.005, 0.03, 0.5]}, fixed,
                             [("hydro.csv", text, {"path": "hydrostatic", "set": settings,
                                                   "x": "p", "y": "eps_v"})])
    summary = calibrate(path, tmp_path / "out")
    assert_recovered(summary, {k: CAP_TRUTH[k] for k in ("E", "W", "D")})
    legs = {row.split(",")[1] for row in (tmp_path / "out" / "fit.csv").read_text().splitlines()[1:]}
    assert legs == {"load", "unload"}


@pytest.mark.slow
def test_modified_cap_from_three_triaxial_tests_and_a_hydrostatic_test(tmp_path):
    """E, A, C, beta, R, W, D of the section VII.5 soil (nu, B fixed) from triaxial
    compression at 2, 6 and 20 psi and a hydrostatic test to 100 psi with unloading."""
    rng = np.random.default_rng(5)
    table = {**CAP_TRUTH, **CAP_FIXED}
    tests = []
    for confining in (2.0, 6.0, 20.0):
        settings = {"p_initial": SEATING, "confining": confining, "confining_steps": 5,
                    "axial_strain": 0.1, "steps": 10}
        text = synthetic_curve("modified_cap", table, "triaxial-compression", settings,
                               "eps_axial", ("q", "eps_v"), rng, "shear")
        tests.append((f"tx{confining:g}.csv", text, {"path": "triaxial-compression",
                                                     "set": settings, "x": "eps_axial",
                                                     "y": ["q", "eps_v"]}))
    settings, text = hydrostatic_with_unloading(table, rng)
    tests.append(("hydro.csv", text, {"path": "hydrostatic", "set": settings, "x": "p",
                                      "y": "eps_v"}))
    fit = {"E": [500.0, 2000.0, 20000.0], "A": [1.0, 4.0, 20.0], "C": [0.5, 4.0, 20.0],
           "beta": [0.005, 0.05, 0.5], "R": [0.5, 1.5, 5.0], "W": [0.05, 0.1, 0.5],
           "D": [0.005, 0.03, 0.5]}
    summary = calibrate(write_calibration(tmp_path, "modified_cap", fit, CAP_FIXED, tests),
                        tmp_path / "out")
    assert_recovered(summary, CAP_TRUTH)


def test_a_fit_stopped_before_converging_keeps_its_best_point(tmp_path, capsys):
    path = dp_file(tmp_path)
    path.write_text("max_evaluations = 2\n" + path.read_text())
    status = main(["calibrate", str(path), "--out", str(tmp_path / "out"), "--json"])
    summary = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert status == 1 and summary["status"] == "not converged"
    assert summary["nfev"] == 2 and summary["evaluations"] > summary["nfev"]
    assert {p.name for p in (tmp_path / "out").iterdir()} == set(summary["files"])
    start_cost = float(np.sum(residuals(np.array([1.0, 25.0]), read_calibration(path)) ** 2))
    best = np.array([summary["parameters"][k] for k in ("c", "phi")])
    assert np.sum(residuals(best, read_calibration(path)) ** 2) < start_cost


def test_a_model_curve_that_cannot_meet_its_data_is_refused_before_fitting(tmp_path, capsys):
    """Loading points of a hydrostatic test with unloading, no leg column: p of the model
    curve turns back along the path, so the points have no place on it."""
    settings, text = hydrostatic_with_unloading({**CAP_TRUTH, **CAP_FIXED},
                                                np.random.default_rng(4))
    text = "p,eps_v\n" + "".join(line.split(",", 1)[1] + "\n"
                                 for line in text.splitlines() if line.startswith("load,"))
    path = write_calibration(tmp_path, "modified_cap", {"W": [0.05, 0.1, 0.5]},
                             {**CAP_FIXED, **{k: v for k, v in CAP_TRUTH.items() if k != "W"}},
                             [("hydro.csv", text, {"path": "hydrostatic", "set": settings,
                                                   "x": "p", "y": "eps_v"})])
    assert main(["calibrate", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "'hydro'" in err and "not monotone along the path" in err and "'leg'" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("edit, words", [
    (("load,", "loading,"), ["row 2", "'loading'", "accepted: load, unload"]),
    (("unload,", "load,"), ["'p' (x)", "along leg 'load'", "row 12"])],
    ids=["unknown leg", "x not monotone along a leg"])
def test_bad_leg_columns_are_refused(tmp_path, capsys, edit, words):
    settings, text = hydrostatic_with_unloading({**CAP_TRUTH, **CAP_FIXED},
                                                np.random.default_rng(4))
    path = write_calibration(tmp_path, "modified_cap", {"W": [0.05, 0.1, 0.5]},
                             {**CAP_FIXED, **{k: v for k, v in CAP_TRUTH.items() if k != "W"}},
                             [("hydro.csv", text.replace(*edit, 1), {
                                 "path": "hydrostatic", "set": settings, "x": "p", "y": "eps_v"})])
    assert main(["calibrate", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    for word in words:
        assert word in err, (word, err)


def test_strains_counted_from_the_start_of_shearing(tmp_path):
    """Laboratory triaxial strains start at zero when shearing starts: strains_from =
    "shear" shifts the model's strain columns alike, and c, phi come back as before."""
    rng = np.random.default_rng(1)
    model = build_model("drucker_prager", {**DP_TRUTH, **DP_FIXED})
    tests = []
    for confining in CONFINING:
        settings = {"confining": confining, "steps": STEPS}
        text = laboratory_csv(model, build_path("triaxial-compression", settings),
                              "triaxial-compression", "eps_axial", ("q", "eps_v"), ("shear",),
                              rng, NOISE, strains_from="shear")
        tests.append((f"tx{confining:g}.csv", text, {
            "path": "triaxial-compression", "set": settings, "x": "eps_axial",
            "y": ["q", "eps_v"], "strains_from": "shear"}))
    assert tests[0][1].splitlines()[1].startswith("0.0025,")   # the first step's strain
    path = write_calibration(tmp_path, "drucker_prager", {"c": [0.1, 1.0, 20.0],
                                                          "phi": [5.0, 25.0, 50.0]},
                             DP_FIXED, tests)
    assert_recovered(calibrate(path, tmp_path / "out"), DP_TRUTH)
    text = path.read_text().replace('strains_from = "shear"', 'strains_from = "shearing"', 1)
    path.write_text(text)
    with pytest.raises(InputError, match="strains_from = 'shearing'; accepted: a leg of the path: confine, shear"):
        read_calibration(path)
