"""Updated Lagrangian analysis: closed forms, objectivity, consistent linearisation."""
import csv
import math

import numpy as np
import pytest

from soilbin.app.collapse import collapse_limit, collapse_pressure, stepping
from soilbin.app.plateau import steady_force, steady_slope, steady_spread
from soilbin.records.scene import load_scene
from soilbin.solver.stepping import StepRecord, run_load_steps
from soilbin.tensors import from_mandel, rotation_matrix
from conftest import SCENES, jacobian_error, make_problem


def read_curve(out):
    with open(out / "curve.csv") as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


@pytest.mark.parametrize("E, nu", [(9000.0, 0.2), (500.0, 0.35)])
def test_column_follows_log_strain_to_30_percent(solve, E, nu):
    """VII.1, eq. 7.6: sigma = M ln(L / (L - w)) within 0.5% up to w/L = 0.3."""
    M, L = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)), 10.0
    p = 1.01 * M * math.log(1 / 0.7)
    summary, out = solve("column-elastic-large", f"materials.soil.E={E}", f"materials.soil.nu={nu}",
                         f"loading.magnitude={p}")
    rows = read_curve(out)
    assert rows[-1]["displacement"] / L >= 0.3
    for row in rows:
        assert row["pressure"] == pytest.approx(M * math.log(L / (L - row["displacement"])), rel=5e-3)
    assert summary["top_settlement"] == pytest.approx(rows[-1]["displacement"], rel=1e-9)
    # uniaxial strain keeps every angle of the mesh right: the scaled Jacobian stays 1
    assert all(row["mesh_quality"] == pytest.approx(1.0, abs=1e-12) for row in rows)


def test_small_deformation_column_stays_linear(solve):
    summary, out = solve("column-elastic", "loading.magnitude=3600")
    for row in read_curve(out):
        assert row["displacement"] == pytest.approx(row["pressure"] * 10 / 10000.0, rel=1e-8)


@pytest.mark.parametrize("element, c", [("hex8", 1e9), ("hex8", 500.0), ("hex8-bbar", 500.0),
                                        ("hex27-bbar", 500.0), ("tet10-bbar", 500.0)])
def test_updated_lagrangian_jacobian_is_consistent(element, c):
    """Material + geometric stiffness + linearised rotation = the derivative of the residual."""
    problem = make_problem("block-drucker-prager", "analysis.large_deformation=true", "mesh.nx=2",
                           "mesh.nz=2", "materials.soil.nu=0.3", f"materials.soil.c={c}",
                           f"analysis.element={element}")
    error, trial = jacobian_error(problem)
    assert error < 1e-6
    states = trial["soil"]["yield_state"]
    assert (states > 0).any() == (c < 1e6)   # the plastic cases are plastic


def test_newton_converges_quadratically_in_large_deformation():
    problem = make_problem("column-elastic-large")
    histories = []
    run_load_steps(problem, 12, 0, lambda r: histories.append(r.residuals))
    r = histories[-1]   # from the extrapolated first iterate: 4.6, 2.1e-3, 4.4e-10
    print("residual history of the last step:", " ".join(f"{x:.2e}" for x in r))
    assert r[0] < 0.1 * histories[0][0]   # the first step starts from w = 0: 1.5e2
    orders = [math.log(r[k + 1] / r[k]) / math.log(r[k] / r[k - 1]) for k in range(1, len(r) - 1)]
    assert orders and all(order > 1.8 for order in orders)


def test_a_mean_dilatation_step_starts_from_the_extrapolated_pressure_too():
    """quad4-bbar in large deformation, elastic steps of 20 psi: the second starts from the
    first's increment scaled to it, its total pressure extrapolated with it (leaving the
    pressure at the last step's doubled the first residual: 5.6 -> 11.2; measured 5.8e-3)."""
    problem = make_problem("strip-load-von-mises", "analysis.large_deformation=true",
                           "loading.until_collapse=false", "loading.magnitude=40",
                           "loading.steps=2")
    histories = []
    run_load_steps(problem, 2, 0, lambda r: histories.append(r.residuals))
    assert histories[1][0] < 1e-2 * histories[0][0]


def committed(problem, key):
    return problem.points.committed["soil"][key].copy()


def set_increment(problem, field):
    """Prescribe the displacement increment w(x) on the current mesh and commit it."""
    problem.w.interpolate(lambda x: field(x))
    problem.points.update()
    problem.commit()


@pytest.mark.parametrize("plastic", [False, True])
def test_rigid_rotation_rotates_stress_without_yielding(plastic):
    """90 degrees about an oblique axis in 9 steps: σ -> Q σ Qᵀ, invariants kept to 1e-8."""
    problem = make_problem("block-drucker-prager", "analysis.large_deformation=true", "mesh.nx=1",
                           "mesh.ny=1", "mesh.nz=1", "materials.soil.nu=0.25")
    strain = np.diag([0.004, -0.001, -0.006]) if plastic else np.diag([0.0004, -0.0001, -0.0006])
    strain[0, 2] = strain[2, 0] = 0.0005
    corners = problem.disc.mesh.geometry.x.copy()
    set_increment(problem, lambda x: strain @ x)
    sigma0, eps_p0 = committed(problem, "stress"), committed(problem, "eps_p_eq")
    assert (committed(problem, "yield_state") == 1.0).all() == plastic

    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    step = rotation_matrix(10.0 * axis)
    for _ in range(9):
        set_increment(problem, lambda x: (step - np.eye(3)) @ x)
    Q = rotation_matrix(90.0 * axis)
    expected = Q @ from_mandel(sigma0) @ Q.T
    scale = np.abs(sigma0).max()
    assert np.abs(from_mandel(committed(problem, "stress")) - expected).max() < 1e-8 * scale
    assert np.array_equal(committed(problem, "eps_p_eq"), eps_p0)   # no spurious yielding
    if plastic:   # and still on the yield surface
        model = problem.points.models["soil"]
        alpha, k = model.matching.coefficients(model.c, model.phi)
        sigma = committed(problem, "stress")
        I1 = sigma[:, :3].sum(axis=1)
        s = sigma.copy()
        s[:, :3] -= I1[:, None] / 3
        f = alpha * I1 + np.linalg.norm(s, axis=1) / math.sqrt(2) - k
        assert np.abs(f).max() < 1e-10 * k
    # the mesh went with it
    expected_x = corners @ (Q @ (np.eye(3) + strain)).T
    assert np.abs(problem.disc.mesh.geometry.x - expected_x).max() < 1e-12


SIMPLE_SHEAR = """
title = "one brick in simple shear: every node prescribed"
units = "any"
[mesh]
builder = "box"
nz = 1
[regions]
soil = "soil"
[materials.soil]
model = "elastic"
E = 1000.0
nu = 0.25
[[supports]]
boundary = "base"
fix = ["x", "y", "z"]
[[supports]]
boundary = "top"
fix = ["y", "z"]
[loading]
control = "displacement"
boundary = "top"
direction = "+x"
magnitude = 1.0   # gamma = 1
steps = 40
[analysis]
large_deformation = true
"""


def test_simple_shear_follows_the_jaumann_closed_form(tmp_path):
    """Hypoelastic simple shear to γ = 1 (Jaumann rate): σ_xz = G sin γ,
    σ_xx = -σ_zz = G (1 - cos γ), within 1% (the update is second order: 3e-5 in 40 steps)."""
    E, nu = 1000.0, 0.25
    G = E / (2 * (1 + nu))
    scene = tmp_path / "shear.toml"
    scene.write_text(SIMPLE_SHEAR)
    problem = make_problem(scene, f"materials.soil.E={E}", f"materials.soil.nu={nu}")
    rows = []
    run_load_steps(problem, 40, 0, rows.append)
    for row in rows[4::5]:
        gamma = row.load_factor   # top displacement / height 1
        assert row.force == pytest.approx(G * math.sin(gamma), rel=0.01)   # shear traction on the top
    sigma = from_mandel(committed(problem, "stress"))
    assert np.allclose(sigma, sigma[0], atol=1e-9 * G)   # homogeneous
    assert sigma[0, 0, 2] == pytest.approx(G * math.sin(1.0), rel=0.01)
    assert sigma[0, 0, 0] == pytest.approx(G * (1 - math.cos(1.0)), rel=0.01)
    assert sigma[0, 2, 2] == pytest.approx(-G * (1 - math.cos(1.0)), rel=0.01)
    # the sheared cells' corners: sin of the angle between the edges, 1 / sqrt(1 + γ²)
    assert problem.quality.minimum() == pytest.approx(1 / math.sqrt(2.0), rel=1e-9)
    assert [row.columns["mesh_quality"] for row in rows[9::10]] == pytest.approx(
        [1 / math.sqrt(1 + row.load_factor**2) for row in rows[9::10]], rel=1e-9)


@pytest.mark.slow
def test_block_collapse_and_strip_load_collapse_in_large_deformation(solve):
    """VII.2 and VII.4 (flexible strip load): the strip's collapse pressure is where its
    settlement per step reaches 100 times the elastic one (+0.893% measured)."""
    block, _ = solve("block-drucker-prager", "analysis.large_deformation=true")
    assert block["collapse_stress"] == pytest.approx(1732.05, rel=0.01)
    strip, out = solve("strip-load-von-mises", "analysis.large_deformation=true", "output.fields=[]")
    assert strip["status"] == "collapse"
    assert strip["collapse_pressure"] == pytest.approx((2 + math.pi) * 17.5, rel=0.015)
    rows = read_curve(out)
    k = min(range(len(rows)), key=lambda i: abs(rows[i]["pressure"] - strip["collapse_pressure"]))
    elastic = rows[0]["displacement"] / rows[0]["pressure"]
    compliance = [(b["displacement"] - a["displacement"]) / (b["pressure"] - a["pressure"]) / elastic
                  for a, b in zip(rows, rows[1:])]
    assert compliance[k - 1] >= 100.0 > max(compliance[:k - 1])


def record(pressure, settlement):
    return StepRecord(0, 0.0, settlement, pressure, 1, 0, 0, 0.0, (), {"pressure": pressure})


def test_collapse_pressure_is_where_the_settlement_per_step_blows_up():
    """Settlement per unit pressure 1e-4 (elastic), then 5e-3 (50x), then 2e-2 (200x): the
    collapse is the third step, whatever comes after; none before it; a falling pressure too."""
    curve = [record(10.0, 1e-3), record(20.0, 0.051), record(20.5, 0.061)]
    assert collapse_pressure(curve) == 20.5
    assert collapse_pressure(curve + [record(20.6, 0.062)]) == 20.5
    assert collapse_pressure(curve[:2]) is None
    assert collapse_pressure(curve[:2] + [record(19.0, 0.052)]) == 19.0


def test_the_collapse_pressures_reference_is_the_first_nominal_step():
    """The secant at load factor 0.5 (the steps' nominal one; the first step was cut) is
    the reference, as for a run's own stop: against the first step's (elastic) 50x would
    read as collapse. A run that ended at the limit without such a step reads its last."""
    curve = [step(0.25, 10.0, 1e-3), step(0.5, 20.0, 0.051), step(0.75, 30.0, 0.2),
             step(1.0, 31.0, 0.7)]
    assert collapse_pressure(curve[:2]) is None
    assert collapse_pressure(curve, nominal=0.5) == 31.0
    assert collapse_pressure(curve[:3], nominal=0.5) is None
    assert collapse_pressure(curve[:3], nominal=0.5, at_limit=True) == 30.0
    assert collapse_pressure(curve[:1], nominal=0.5, at_limit=True) == 10.0


def step(factor, pressure, settlement):
    return StepRecord(0, factor, settlement, pressure, 1, 0, 0, 0.0, (), {"pressure": pressure})


def test_the_steady_force_is_the_mean_over_the_last_sixth_of_the_travel():
    """The plateau of a long travel: the force integrated over the last sixth of the final
    displacement (its start interpolated on the curve), over that length; the spread is its
    range there over the mean."""
    def travel(displacements, forces):
        return [StepRecord(0, 0.0, d, f, 1, 0, 0, 0.0, (), {}) for d, f in zip(displacements,
                                                                               forces)]
    flat = travel([1, 2, 3, 4, 5, 6], [5, 8, 9, 10, 10, 10])
    assert steady_force(flat) == 10.0 and steady_spread(flat) == 0.0
    uneven = travel([1, 2, 5.5, 6], [4, 8, 12, 6])
    at_5 = 8 + 4 * 3 / 3.5
    mean = 0.5 * (at_5 + 12) * 0.5 + 0.5 * (12 + 6) * 0.5
    assert steady_force(uneven) == pytest.approx(mean, rel=1e-14)
    assert steady_spread(uneven) == pytest.approx((12 - 6) / mean, rel=1e-14)



def test_the_steady_slope_is_the_rise_left_over_the_last_sixth_of_the_travel():
    """The straight line fitted to the force over the plateau: a force rising at 3 per unit
    displacement has slope 3 however its steps are cut; a steady force has none, a sawtooth
    about a steady force nearly none."""
    def travel(displacements, forces):
        return [StepRecord(0, 0.0, d, f, 1, 0, 0, 0.0, (), {}) for d, f in zip(displacements,
                                                                               forces)]
    uneven = [0.5, 1.0, 4.0, 5.2, 5.25, 5.9, 6.0]
    assert steady_slope(travel(uneven, [2 + 3 * d for d in uneven])) == pytest.approx(3.0,
                                                                                     rel=1e-12)
    assert steady_slope(travel([1, 2, 3, 4, 5, 6], [5, 8, 9, 10, 10, 10])) == pytest.approx(
        0.0, abs=1e-12)
    d = np.linspace(0.05, 6.0, 120)
    saw = 10 + ((d / 0.1) % 1.0 - 0.5)   # teeth 0.1 long about 10, each rising at 10
    assert abs(steady_slope(travel(d, saw))) < 0.01 * 10


def test_over_the_last_half_a_plateau_is_the_mean_and_slope_of_that_half():
    """``fraction``: the same measures over a longer window. A force rising at 3 to 4 then
    flat at 14: over the last half (4 to 8) its mean is 14 and its slope 0, over the last
    sixth too; over the last five eighths (3 to 8) the mean takes in the rise from 11 to 14."""
    records = [StepRecord(0, 0.0, d, f, 1, 0, 0, 0.0, (), {})
               for d, f in zip([1, 2, 3, 4, 6, 8], [5, 8, 11, 14, 14, 14])]
    assert steady_force(records, 0.5) == 14.0 and steady_slope(records, 0.5) == pytest.approx(
        0.0, abs=1e-12)
    assert steady_force(records) == pytest.approx(14.0, rel=1e-14)
    assert steady_force(records, 5 / 8) == pytest.approx((0.5 * (11 + 14) + 4 * 14) / 5,
                                                         rel=1e-14)
    assert steady_slope(records, 5 / 8) > 0.0


def test_force_control_until_collapse_ends_where_the_travel_runs_away():
    """The same criterion on the applied load ends a force-controlled run at its limit: the
    strip load (100 psi at load factor 1) stops at the 200x step, not at the 50x one."""
    scene = load_scene(SCENES / "strip-load-von-mises.toml")
    limit = collapse_limit(scene)
    curve = [StepRecord(k + 1, p / 100.0, w, p, 1, 0, 0, 0.0, (), {"pressure": p})
             for k, (p, w) in enumerate([(10.0, 1e-3), (20.0, 0.051), (20.5, 0.061)])]
    assert limit(curve[:1]) is None and limit(curve[:2]) is None
    assert "the soil's limit: at load 20.5" in limit(curve)
    # A first step cut to 1 psi and stiffer than what follows (a soil that is stiff only at
    # first) does not set the scale: the secant at the first nominal step (10 psi) does.
    soft = [StepRecord(k + 1, p / 100.0, w, p, 1, 0, 0, 0.0, (), {"pressure": p})
            for k, (p, w) in enumerate([(1.0, 1e-5), (10.0, 0.01), (20.0, 0.05), (21.0, 0.9)])]
    assert limit(soft[:3]) is None
    assert "the soil's limit: at load 21" in limit(soft)
    assert collapse_limit(load_scene(SCENES / "strip-load-von-mises.toml",
                                     ["loading.until_collapse=false"])) is None
    assert collapse_limit(load_scene(SCENES / "strip-footing-von-mises.toml")) is None


ROUGH_PLATENS = """
title = "block between rough platens, Drucker-Prager"
units = "lb, ft"
[mesh]
builder = "box"
nx = 2
ny = 2
nz = 2
[regions]
soil = "soil"
[materials.soil]
model = "drucker_prager"
E = 500000.0
nu = 0.3
c = 500.0
phi = 30.0
matching = "compression_cone"
[[supports]]
boundary = "base"
fix = ["x", "y", "z"]
[[supports]]
boundary = "top"
fix = ["x", "y"]
[loading]
control = "displacement"
boundary = "top"
direction = "-z"
magnitude = 0.05
steps = 10
[analysis]
large_deformation = true
"""


@pytest.mark.parametrize("large", [True, False])
def test_a_rotated_frame_gives_the_same_curve(solve, tmp_path, large):
    """Frame indifference of the whole code: the scene turned by an arbitrary rotation."""
    scene = tmp_path / "platens.toml"
    scene.write_text(ROUGH_PLATENS)
    from soilbin.app.run import run_scene
    from soilbin.records.scene import load_scene
    curves = []
    for rotation in ("[0.0, 0.0, 0.0]", "[31.0, -47.0, 76.0]"):
        out = tmp_path / rotation
        run_scene(load_scene(scene, [f"analysis.frame_rotation={rotation}",
                                     f"analysis.large_deformation={str(large).lower()}"]), out)
        curves.append(read_curve(out))
    assert len(curves[0]) == len(curves[1]) == 10
    for a, b in zip(*curves):
        assert b["displacement"] == pytest.approx(a["displacement"], rel=1e-6)
        assert b["force"] == pytest.approx(a["force"], rel=1e-6)
    assert curves[0][-1]["pressure"] > 1000.0   # well into the plastic range


def test_corner_squares_keep_their_size_whatever_the_refinement():
    """The 6 x 3 squares of side corner_size at the footing edge (x = 1, z = 0)."""
    from mpi4py import MPI
    from soilbin.meshes import BUILDERS, StripFootingParams
    for refine in (1, 2):
        tm = BUILDERS["strip_footing"].build(StripFootingParams(corner_size=0.05, refine=refine),
                                             MPI.COMM_WORLD)
        x = tm.mesh.geometry.x
        nodes = tm.mesh.geometry.dofmap.array.reshape(-1, 8)
        low, high = x[nodes].min(axis=1), x[nodes].max(axis=1)
        inside = (low[:, 0] > 0.85 - 1e-9) & (high[:, 0] < 1.15 + 1e-9) & (low[:, 2] > -0.15 - 1e-9)
        assert inside.sum() == 18
        assert np.allclose(high[inside][:, [0, 2]] - low[inside][:, [0, 2]], 0.05)


@pytest.mark.slow
def test_rigid_rough_footing_reaches_its_full_settlement(solve):
    """VII.4 footing in large deformation with squares of w/2 at its edge: to w = 0.1 in
    (10% of the half-width) without failing or folding (no drop in the pressure);
    +7.0% above (2 + π)c at the end (+3.0% in small deformation on this mesh)."""
    summary, out = solve("strip-footing-von-mises", "analysis.large_deformation=true",
                         "mesh.corner_size=0.05", "output.fields=[]")
    assert summary["status"] == "complete"
    rows = read_curve(out)
    assert rows[-1]["displacement"] == pytest.approx(0.1)
    limit = (2 + math.pi) * 17.5
    pressures = [row["pressure"] for row in rows]
    assert limit < pressures[-1] < 1.1 * limit
    peak = pressures.index(max(pressures))
    assert min(pressures[peak:]) > 0.98 * max(pressures)


def test_the_heave_is_the_rise_of_the_soils_highest_point_ahead_of_the_tool():
    """curve.csv's ``heave``: the soil's highest point above its highest at the start (the
    flat ground), as the mesh's own moved coordinates give it, at the crest of the soil the
    blade pushes up in front of it (the clay's blade, 0.3 in in large deformation)."""
    problem = make_problem("tine-2in-long-clay", "mesh.element_size=1.5",
                           "loading.magnitude=0.3", "loading.steps=3", "output.at=[]")
    ground = problem.mesh.geometry.x[:, 2].max()
    records = []
    assert run_load_steps(problem, on_step=records.append, **stepping(problem.scene)).complete
    heaves = [r.columns["heave"] for r in records]
    x = problem.mesh.geometry.x
    assert heaves[-1] == pytest.approx(x[:, 2].max() - ground, rel=1e-12)
    assert 0.0 < heaves[0] < heaves[1] < heaves[2]
    crest = x[np.argmax(x[:, 2])]
    front = max(x[:, 0].max(initial=-np.inf) for x in problem.tool.face_points.values())
    assert crest[0] > front + problem.tool.travel
