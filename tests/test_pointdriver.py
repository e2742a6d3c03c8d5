"""The material-point driver (soilbin point) against closed forms.

Output is compression positive: p = -tr(sigma)/3, q = sqrt(3 J2) (negative in
extension), eps_v = -tr(eps), eps_axial = -eps_zz.
"""
import csv
import json
import math

import numpy as np
import pytest

from soilbin.app.cli import main
from soilbin.material_point.driver import run_point
from conftest import SCENES, last_json

C, PHI = 500.0, 30.0
S, CO = math.sin(math.radians(PHI)), math.cos(math.radians(PHI))
DP = {"E": 1.0e5, "nu": 0.0, "c": C, "phi": PHI, "matching": "compression_cone"}
ELASTIC = {"E": 1.0e4, "nu": 0.3}
K = ELASTIC["E"] / (3 * (1 - 2 * ELASTIC["nu"]))
G = ELASTIC["E"] / (2 * (1 + ELASTIC["nu"]))


def sets(table):
    return [arg for key, value in table.items()
            for arg in ("--set", f"{key}={value}" if not isinstance(value, bool)
                        else f"{key}={str(value).lower()}")]


def point(capsys, tmp_path, model, path, params, path_params=()):
    """Run `soilbin point ... --json` in this process: (status, summary, rows, stderr)."""
    out = tmp_path / "out"
    args = ["point", model, path, "--out", str(out), "--json", *sets(params),
            *sets({f"path.{k}": v for k, v in dict(path_params).items()})]
    status = main(args)
    stdout, stderr = capsys.readouterr()
    rows = []
    if (out / "path.csv").exists():
        with open(out / "path.csv", newline="") as f:
            rows = [{k: (v if k == "leg" else float(v)) for k, v in row.items()}
                    for row in csv.DictReader(f)]
    return status, last_json(stdout) if stdout.strip() else None, rows, stderr


def mc_compression_strength(sigma3):
    """Mohr–Coulomb sigma1 - sigma3 in triaxial compression at lateral stress sigma3."""
    return 2 * C * CO / (1 - S) + 2 * S / (1 - S) * sigma3


def dp_extension_strength(sigma_r):
    """sigma_r - sigma_axial at failure in drained triaxial extension on the compression
    cone sqrt(J2) + eta p - k = 0 (tension positive p; eta = 6 sin/(sqrt3 (3 - sin)),
    k = 6 c cos/(sqrt3 (3 - sin))): with sqrt(J2) = q/sqrt3 and p = -(sigma_r - q/3),
    q (1/sqrt3 + eta/3) = k + eta sigma_r, i.e. q = 6 (c cos + sigma_r sin) / (3 + sin)."""
    return 6 * (C * CO + sigma_r * S) / (3 + S)


def test_unconfined_compression_peak_is_2c_cos_over_1_minus_sin(capsys, tmp_path):
    status, summary, rows, _ = point(capsys, tmp_path, "drucker_prager",
                                     "triaxial-compression", DP, {"steps": 40})
    assert status == 0 and summary["converged"]
    assert 2 * C * CO / (1 - S) == pytest.approx(1732.0508075688772)
    assert abs(summary["q_peak"] - 2 * C * CO / (1 - S)) < 1e-6
    last = rows[-1]
    assert abs(last["q"] - 2 * C * CO / (1 - S)) < 1e-6   # perfectly plastic: stays there
    assert abs(last["sigma_lateral"]) < 1e-6               # the lateral stress is held at 0
    assert last["yield_state"] == 1.0 and last["eps_p_eq"] > 0.0
    assert last["eps_v"] < rows[20]["eps_v"]               # associated flow dilates


@pytest.mark.parametrize("p0", [100.0, 1000.0, 5000.0])
def test_confined_compression_peak_is_mohr_coulomb(p0):
    summary = run_point("drucker_prager", DP, "triaxial-compression",
                        {"confining": p0, "axial_strain": 0.2, "steps": 40})
    assert summary["converged"]
    assert abs(summary["q_peak"] - mc_compression_strength(p0)) < 1e-6 * max(1.0, p0 / 1000)
    final = summary["final"]
    assert final["sigma1"] - final["sigma3"] == pytest.approx(mc_compression_strength(p0), abs=1e-6)
    assert final["sigma3"] == pytest.approx(p0, abs=1e-8)


@pytest.mark.parametrize("p0", [0.0, 1000.0])
def test_extension_peak_of_the_compression_cone(capsys, tmp_path, p0):
    status, summary, rows, _ = point(capsys, tmp_path, "drucker_prager", "triaxial-extension",
                                     DP, {"confining": p0, "steps": 40})
    assert status == 0
    assert summary["q_peak"] < 0.0   # the axial stress is the smaller
    assert abs(-summary["q_peak"] - dp_extension_strength(p0)) < 1e-6
    # total strain from the unstressed state: confinement (nu = 0: p0 / E), then -0.05
    assert rows[-1]["eps_axial"] == pytest.approx(p0 / DP["E"] - 0.05)
    assert rows[-1]["sigma_lateral"] == pytest.approx(p0, abs=1e-8)
    # The compression cone circumscribes Mohr–Coulomb: stronger than MC in extension,
    # whose strength is 2 (c cos + sigma_r sin) / (1 + sin).
    assert -summary["q_peak"] > 2 * (C * CO + p0 * S) / (1 + S)


def test_elastic_oedometer_is_constrained_modulus(capsys, tmp_path):
    status, summary, rows, _ = point(capsys, tmp_path, "elastic", "oedometer", ELASTIC,
                                     {"axial_strain": 0.01, "steps": 10})
    assert status == 0
    assert len(rows) == 1 + 10 + 10   # initial, loading, unloading
    M = K + 4 * G / 3
    nu = ELASTIC["nu"]
    for row in rows:
        assert row["sigma_axial"] == pytest.approx(M * row["eps_axial"], rel=1e-10, abs=1e-9)
        assert row["sigma_lateral"] == pytest.approx(nu / (1 - nu) * row["sigma_axial"], abs=1e-9)
        assert row["eps_v"] == pytest.approx(row["eps_axial"], abs=1e-15)
    assert rows[10]["sigma_axial"] == pytest.approx(M * 0.01)
    assert rows[-1]["eps_axial"] == pytest.approx(0.0, abs=1e-14)   # elastic: back to zero


def test_elastic_hydrostatic_is_bulk_modulus(capsys, tmp_path):
    status, summary, rows, _ = point(capsys, tmp_path, "elastic", "hydrostatic", ELASTIC,
                                     {"pressure": 100.0, "steps": 5})
    assert status == 0 and len(rows) == 11
    for row in rows:
        assert row["p"] == pytest.approx(K * row["eps_v"], rel=1e-10, abs=1e-9)
        assert abs(row["q"]) < 1e-9
    assert rows[5]["p"] == pytest.approx(100.0) and rows[-1]["p"] == pytest.approx(0.0, abs=1e-9)
    # By volumetric strain, the same line.
    summary = run_point("elastic", ELASTIC, "hydrostatic",
                        {"control": "strain", "volumetric_strain": 0.003, "unload": False})
    assert summary["final"]["p"] == pytest.approx(K * 0.003)


def test_elastic_mixed_control_closed_forms():
    """Drained triaxial: dq = E de_a at constant lateral stress; undrained: p constant,
    q = 3G e_a; simple shear: tau = G gamma at constant normal stress."""
    drained = run_point("elastic", ELASTIC, "triaxial-compression",
                        {"confining": 50.0, "axial_strain": 0.01, "steps": 4})["final"]
    assert drained["q"] == pytest.approx(ELASTIC["E"] * 0.01)
    assert drained["sigma_lateral"] == pytest.approx(50.0)
    assert drained["eps_axial"] == pytest.approx(0.01 + 50.0 / (3 * K))

    undrained = run_point("elastic", ELASTIC, "undrained-triaxial",
                          {"confining": 50.0, "axial_strain": 0.01, "steps": 4})["final"]
    assert undrained["p"] == pytest.approx(50.0)
    assert undrained["q"] == pytest.approx(3 * G * 0.01)

    shear = run_point("elastic", ELASTIC, "simple-shear",
                      {"confining": 50.0, "shear_strain": 0.02, "steps": 4})["final"]
    assert shear["tau"] == pytest.approx(G * 0.02)
    assert shear["gamma"] == pytest.approx(0.02)
    assert shear["sigma_axial"] == pytest.approx(50.0)


@pytest.mark.parametrize("normal", ["stress", "strain"])
def test_von_mises_simple_shear_strength_is_c(normal):
    summary = run_point("von_mises", {"E": 1.0e4, "nu": 0.3, "c": 20.0}, "simple-shear",
                        {"confining": 100.0, "shear_strain": 0.02, "steps": 10, "normal": normal})
    assert summary["final"]["tau"] == pytest.approx(20.0, rel=1e-12)   # sqrt(J2) = tau = c
    assert summary["final"]["p"] == pytest.approx(100.0)


def test_output_folder(capsys, tmp_path):
    status, summary, rows, _ = point(
        capsys, tmp_path, "drucker_prager", "triaxial-compression", DP,
        {"confining": 200.0, "confining_steps": 5, "steps": 20, "unload": True})
    out = tmp_path / "out"
    assert status == 0
    assert (out / "path.png").stat().st_size > 10000
    assert json.loads((out / "summary.json").read_text()) == summary
    assert len(rows) == 1 + 5 + 20 + 20 == summary["n_steps"] + 1
    assert [r["step"] for r in rows] == list(range(len(rows)))
    assert {r["leg"] for r in rows} == {"initial", "confine", "shear", "unload"}
    assert {"step", "eps_axial", "eps_v", "p", "q", "sigma1", "sigma2", "sigma3",
            "eps_p_eq", "yield_state"} <= set(rows[0])
    assert rows[-1]["q"] == pytest.approx(0.0, abs=1e-8)   # unloaded to the confining pressure
    assert summary["path_parameters"]["confining"] == 200.0


def test_scene_material(capsys, tmp_path):
    out = tmp_path / "scene"
    status = main(["point", f"{SCENES / 'block-drucker-prager.toml'}:soil", "triaxial-compression",
                   "--set", "path.steps=10", "--out", str(out), "--json"])
    summary = last_json(capsys.readouterr().out)
    assert status == 0 and summary["parameters"]["c"] == 500.0
    assert abs(summary["q_peak"] - 2 * C * CO / (1 - S)) < 1e-6


def test_failure_keeps_the_converged_steps(capsys, tmp_path):
    """Isotropic tension beyond the cone's apex cannot be reached: exit 1, rows kept."""
    status, summary, rows, stderr = point(capsys, tmp_path, "drucker_prager", "hydrostatic",
                                          DP, {"pressure": -2000.0, "steps": 4})
    apex = C / math.tan(math.radians(PHI))   # 866: the apex of the compression cone
    assert status == 1 and summary["status"] == "failed"
    assert "Newton iteration failed" in summary["message"] and "soilbin:" in stderr
    assert len(rows) == 2 and -rows[-1]["p"] < apex   # step 1 (p = -500) only


@pytest.mark.parametrize("args, expected", [
    (["cam_clayx", "hydrostatic"], "unknown model 'cam_clayx'; known: elastic, "),
    (["drucker_prager", "hydrostatic", "--set", "nu=0.5"],
     "drucker_prager.nu = 0.5 is outside the accepted range (-1, 0.5)"),
    (["drucker_prager", "hydrostatic", "--set", "Young=3"], "unknown key 'Young'"),
    (["drucker_prager", "triaxial", "--set", "nu=0.2"], "unknown path 'triaxial'; known: hydrostatic"),
    (["drucker_prager", "triaxial-compression", "--set", "path.steps=0"],
     "path.steps = 0 is outside the accepted range [1, 100000]"),
    (["drucker_prager", "triaxial-compression", "--set", "path.confinement=1"],
     "path: unknown key 'confinement'"),
    (["drucker_prager", "hydrostatic"], "path.pressure = nan: required with control = 'stress'"),
    (["drucker_prager", "oedometer", "--set", "path.control=force"],
     "path.control: 'force' is not one of stress, strain"),
    (["nosuch.toml:soil", "hydrostatic"], "no such scene file"),
    (["drucker_prager", "undrained-triaxial", "--set", "path.axial_strain=1e300"],
     "path.axial_strain = 1e+300 is outside the accepted range [-1, 1]"),
    (["drucker_prager", "simple-shear", "--set", "path.shear_strain=-2"],
     "path.shear_strain = -2.0 is outside the accepted range [-1, 1]"),
    (["drucker_prager", "hydrostatic", "--set", "path.control=strain",
      "--set", "path.volumetric_strain=1e300"],
     "path.volumetric_strain = 1e+300 is outside the accepted range [-1, 1]"),
])
def test_bad_input_is_one_line_and_exit_2(capsys, tmp_path, args, expected):
    model_sets = sets(DP) if args[0] == "drucker_prager" else []   # later --set wins
    full = ["point", *args[:2], *model_sets, *args[2:], "--out", str(tmp_path / "bad")]
    status = main(full)
    out, err = capsys.readouterr()
    assert status == 2
    assert expected in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "bad").exists()


def test_help_lists_every_path(capsys):
    from soilbin.material_point.paths import PATHS
    with pytest.raises(SystemExit):
        main(["point", "--help"])
    text = capsys.readouterr().out
    for name in PATHS:
        assert f"  {name}:" in text


def test_path_targets_are_linear_in_the_leg():
    from soilbin.material_point.paths import PATHS, targets
    legs = PATHS["triaxial-compression"](confining=10.0, axial_strain=0.02).legs()
    assert [leg.name for leg in legs] == ["confine", "shear"]
    shear = legs[1]
    eps0, sigma0 = np.array([1, 1, 1, 0, 0, 0]) * -1e-3, -10.0 * np.array([1, 1, 1, 0, 0, 0])
    target = targets(shear.stress_controlled, np.array(shear.end), eps0, sigma0, 0.5)
    assert list(shear.stress_controlled) == [True, True, False, False, False, False]
    assert target[:2] == pytest.approx([-10.0, -10.0])      # lateral stress held
    assert target[2] == pytest.approx(-1e-3 - 0.01)         # half the axial strain


@pytest.mark.parametrize("path, settings", [
    ("hydrostatic", ["path.pressure=30", "path.unload=true"]),
    ("triaxial-compression", ["path.confining=10"]),
    ("simple-shear", ["path.confining=10"])])
def test_appendix_c_paths_of_the_modified_cap_run(tmp_path, path, settings):
    """Appendix C (cubical device): the modified cap with the VII.5 parameters on each path.
    (Extension runs too, in scripts/appendix_c.py, but takes a minute: the driver's
    mixed-control Newton keeps cutting at the cap/failure corner.)"""
    from soilbin.app.cli import main
    args = ["point", "modified_cap", path, "--out", str(tmp_path), "--json"]
    for s in ["E=4000", "nu=0.35", "A=5.65", "B=0.11", "C=5.6", "beta=0.062", "R=2", "W=0.18",
              "D=0.05", *settings]:
        args += ["--set", s]
    assert main(args) == 0
    assert (tmp_path / "path.png").exists()


@pytest.mark.slow
def test_paths_driven_together_give_each_path_alone():
    """drive_all steps the points of several paths in one vectorised update; each point
    keeps its own Newton iteration and step cuts, so each path's rows are those of its
    own run (to rounding), whatever the others do."""
    from soilbin.material_point.driver import build_model, build_path, drive, drive_all
    from soilbin.models.cap import SECTION_VII5
    model = build_model("modified_cap", dict(SECTION_VII5))
    paths = [(build_path(name, table), name) for name, table in [
        ("hydrostatic", {"pressure": 30.0, "steps": 10}),
        ("triaxial-compression", {"confining": 10.0, "steps": 10}),
        ("simple-shear", {"confining": 10.0, "steps": 15}),
        ("undrained-triaxial", {"confining": 5.0, "steps": 5}),
        ("triaxial-extension", {"confining": 10.0, "steps": 2, "axial_strain": 0.01})]]
    together = drive_all(model, paths)
    for (params, name), result in zip(paths, together):
        alone = drive(model, params, name)
        assert result.converged and len(result.rows) == len(alone.rows)
        assert [r["leg"] for r in result.rows] == [r["leg"] for r in alone.rows]
        for a, b in zip(result.rows, alone.rows):
            for key, value in b.items():
                if key != "leg":
                    assert a[key] == pytest.approx(value, rel=1e-12, abs=1e-12), (name, key)
        assert (result.newton_iterations, result.cuts) == (alone.newton_iterations, alone.cuts)
    assert together[-1].cuts > 0   # the extension's steps are cut at the cap's corner
