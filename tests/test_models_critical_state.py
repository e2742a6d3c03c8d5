"""Cam-Clay and modified Cam-Clay: returns with normal flow, triaxial paths
against the critical-state closed forms (Wood 1990, ch. 6-7), hardening,
initial state and input checks (tangents, inputs and range errors in every
return mode: test_models_conformance.py)."""
import math

import numpy as np
import pytest

from soilbin.errors import InputError, ReturnMapError
from soilbin.models import MODELS, CamClay, CriticalStateElasticity, ModifiedCamClay
from soilbin.models import invariant_return
from soilbin.params import from_table
from soilbin.tensors import IDENTITY, SQRT2, deviator, trace

LINEAR, PRESSURE = CriticalStateElasticity.LINEAR, CriticalStateElasticity.PRESSURE_DEPENDENT
# A lightly overconsolidated clay (stress units kPa): M = 1.2 for phi = 30 deg.
CLAY = dict(E=1.0e4, nu=0.3, phi=30.0, lam=0.2, kappa=0.04, e0=1.0, p_c0=1.0)
S_ELASTIC, S_DRY, S_ORIGIN, S_WET, S_TIP = 0.0, 1.0, 2.0, 4.0, 6.0


def model_id(model):
    return f"{type(model).__name__}-{model.elasticity.value}"


ALL = [cls(**CLAY, elasticity=e) for cls in (CamClay, ModifiedCamClay) for e in (LINEAR, PRESSURE)]


def p_q(sigma):
    """Compression-positive p and q = sqrt(3 J2)."""
    s = deviator(sigma)
    return -trace(sigma) / 3.0, np.sqrt(1.5 * np.sum(s * s, axis=-1))


def unit_deviator(seed):
    n = deviator(np.random.default_rng(seed).standard_normal(6))
    return n / np.linalg.norm(n)


def state_at(model, stress, p_c):
    state = model.initial_state(len(stress), stress)
    state["p_c"][:] = p_c
    return state


@pytest.mark.parametrize("model", ALL, ids=model_id)
def test_returned_stress_lies_on_the_yield_surface_with_normal_flow(model):
    rng = np.random.default_rng(2)
    m = 400
    deps = 2e-2 * rng.uniform(0, 1, (m, 1)) ** 2 * (rng.standard_normal((m, 6))
                                                      + rng.standard_normal((m, 1)) * IDENTITY)
    state = state_at(model, np.tile(-50.0 * IDENTITY, (m, 1)), 100.0)
    sigma, _, new = model.update(deps, state)
    p, q = p_q(sigma)
    p_c, M, ys = new["p_c"], model.M, new["yield_state"]
    on = (ys == S_WET) | (ys == S_DRY)
    assert on.sum() > 100 and (ys == S_ELASTIC).sum() > 20
    if isinstance(model, CamClay):
        f = q + M * p * np.log(p / p_c)
        grad_p, grad_q = M * (np.log(p / p_c) + 1.0), np.ones(m)
    else:
        f = (q**2 + M**2 * p * (p - p_c)) / p_c
        grad_p, grad_q = M**2 * (2.0 * p - p_c), 2.0 * q
    assert np.abs(f[on]).max() < 1e-9 * p_c[on].max()
    # Normality: plastic compaction / plastic shear = f_p / f_q, with the plastic
    # strains from the elastic law and the hardening law (ln p_c / p_c,n = theta eps_v^p).
    compaction = np.log(p_c / 100.0) / model.theta
    np.testing.assert_allclose(-new["eps_p_vol"], compaction, rtol=1e-9, atol=1e-15)
    s_tr = deviator(state["stress"]) + 2 * model.G * deviator(deps)
    q_tr = np.sqrt(1.5 * np.sum(s_tr * s_tr, axis=1))
    shear = (q_tr - q) / (3.0 * model.G)   # plastic shear strain conjugate to q
    lhs, rhs = compaction * grad_q, shear * grad_p
    tol = 1e-8 * (np.abs(compaction * grad_q) + np.abs(shear * grad_p)).max()
    assert np.abs(lhs - rhs)[on].max() < tol
    assert (shear[on] >= -1e-12).all()
    # Wet of critical compacts, dry dilates.
    assert (compaction[ys == S_WET] >= 0).all() and (compaction[ys == S_DRY] <= 0).all()


# --- Material-point paths ------------------------------------------------------------


def triaxial(model, state, d_axial, drained=True):
    """Triaxial compression at constant lateral stress (drained) or constant volume
    (undrained), the axial strain eps_33 driven in the increments ``d_axial``.
    Drained: Newton on the lateral strains with the model's tangent. Returns rows
    (eps, sigma, state)."""
    sigma_lateral = state["stress"][0, 0]
    eps = np.zeros(6)
    rows = []
    lateral = np.zeros(2)
    for d in d_axial:
        deps = np.zeros((1, 6))
        deps[0, 2] = d
        if drained:
            deps[0, :2] = lateral * d / d_axial[0]
            for _ in range(30):
                sigma, tangent, new = model.update(deps, state)
                r = sigma[0, :2] - sigma_lateral
                if np.abs(r).max() <= 1e-12 * abs(sigma_lateral):
                    break
                deps[0, :2] -= np.linalg.solve(tangent[0][:2, :2], r)
            else:
                pytest.fail("lateral stress iteration did not converge")
            lateral = deps[0, :2] * d_axial[0] / d
        else:
            deps[0, :2] = -0.5 * d
            sigma, _, new = model.update(deps, state)
        state = new
        eps = eps + deps[0]
        rows.append((eps, sigma[0], state))
    return rows


P0 = 100.0


def normally_consolidated(model):
    return model.initial_state(1, -P0 * IDENTITY)


@pytest.mark.parametrize("elasticity", [PRESSURE, LINEAR], ids=lambda e: e.value)
def test_modified_cam_clay_drained_triaxial_compression(elasticity):
    model = ModifiedCamClay(**CLAY, elasticity=elasticity)
    state = normally_consolidated(model)
    assert state["p_c"][0] == pytest.approx(P0)
    d_axial = -np.geomspace(1e-4, 5e-2, 120)
    rows = triaxial(model, state, d_axial)
    eps_v = np.array([-trace(e) for e, _, _ in rows])
    p, q = p_q(np.array([s for _, s, _ in rows]))
    M, e0 = model.M, model.e0
    # The stress path q = 3 (p - p0) and the yield surface through the current stress.
    np.testing.assert_allclose(q, 3.0 * (p - P0), rtol=1e-9)
    p_c = p + q**2 / (M**2 * p)
    np.testing.assert_allclose([s["p_c"][0] for _, _, s in rows], p_c, rtol=1e-9)
    # Volumetric strain from the e - ln p lines: kappa-line elastic part, and the
    # plastic part (lam - kappa) / (1 + e0) ln(p_c / p_c0).
    plastic = (model.lam - model.kappa) / (1 + e0) * np.log(p_c / P0)
    if elasticity is PRESSURE:
        elastic = model.kappa / (1 + e0) * np.log(p / P0)
    else:
        elastic = (p - P0) / model.K
    np.testing.assert_allclose(eps_v, elastic + plastic, rtol=1e-8)
    # Critical state: q = M p where q = 3 (p - p0) meets it, p_f = 3 p0 / (3 - M).
    assert q[-1] / p[-1] == pytest.approx(M, rel=1e-2)
    assert p[-1] == pytest.approx(3 * P0 / (3 - M), rel=1e-2)
    # Hardening all the way (wet side), the rate of compaction vanishing at the end.
    assert (np.diff(eps_v) > 0).all()
    rate = np.diff(eps_v) / -d_axial[1:]
    assert rate[-1] < 1e-2 * rate[0]
    assert rows[-1][2]["yield_state"][0] == S_WET


def test_modified_cam_clay_undrained_triaxial_compression():
    model = ModifiedCamClay(**CLAY, elasticity=PRESSURE)
    rows = triaxial(model, normally_consolidated(model), -np.geomspace(1e-5, 1e-2, 150),
                    drained=False)
    p, q = p_q(np.array([s for _, s, _ in rows]))
    eta, M = q / p, model.M
    Lambda = 1.0 - model.kappa / model.lam
    np.testing.assert_allclose(p / P0, (1 + eta**2 / M**2) ** -Lambda, rtol=1e-9)
    assert all(abs(trace(e)) < 1e-15 for e, _, _ in rows)
    # Approach to the critical state: eta -> M, p -> p0 2^-Lambda.
    assert eta[-1] == pytest.approx(M, rel=1e-2)
    assert p[-1] / P0 == pytest.approx(2.0**-Lambda, rel=1e-2)


def test_modified_cam_clay_undrained_with_linear_elasticity():
    # Constant volume: (p - p0)/K + (lam - kappa)/(1 + e0) ln(p (1 + eta^2/M^2) / p0) = 0.
    model = ModifiedCamClay(**CLAY, elasticity=LINEAR)
    rows = triaxial(model, normally_consolidated(model), -np.geomspace(1e-5, 1e-2, 100),
                    drained=False)
    p, q = p_q(np.array([s for _, s, _ in rows]))
    eta, M = q / p, model.M
    residual = (p - P0) / model.K + np.log(p * (1 + eta**2 / M**2) / P0) / model.theta
    assert np.abs(residual).max() < 1e-12
    assert p[-1] < 0.9 * P0 and eta[-1] == pytest.approx(M, rel=2e-2)


def test_cam_clay_undrained_follows_exponential_stress_path():
    # Cam-Clay: ln(p_c / p) = eta / M on the yield surface, so p / p0 = exp(-Lambda eta / M).
    model = CamClay(**CLAY, elasticity=PRESSURE)
    rows = triaxial(model, normally_consolidated(model), -np.geomspace(1e-5, 1e-2, 100),
                    drained=False)
    p, q = p_q(np.array([s for _, s, _ in rows]))
    Lambda = 1.0 - model.kappa / model.lam
    np.testing.assert_allclose(p / P0, np.exp(-Lambda * q / (p * model.M)), rtol=1e-9)
    assert q[-1] / p[-1] == pytest.approx(model.M, rel=2e-2)


@pytest.mark.parametrize("cls", [CamClay, ModifiedCamClay])
def test_isotropic_compression_follows_the_normal_compression_line(cls):
    # From the tip, isotropic compression stays on the p axis (Cam-Clay: at its
    # vertex), eps_v = lam / (1 + e0) ln(p / p0); unloading follows kappa.
    model = cls(**CLAY, elasticity=PRESSURE)
    state = normally_consolidated(model)
    eps_v, p = 0.0, []
    for _ in range(20):
        sigma, _, state = model.update(np.tile(-2e-3 / 3 * IDENTITY, (1, 1)), state)
        eps_v += 2e-3
        p.append(p_q(sigma)[0][0])
        assert p_q(sigma)[1][0] < 1e-9 * p[-1]
        assert state["yield_state"][0] == (S_TIP if cls is CamClay else S_WET)
        assert eps_v == pytest.approx(model.lam / (1 + model.e0) * math.log(p[-1] / P0), rel=1e-10)
    p_max, eps_max = p[-1], eps_v
    sigma, _, state = model.update(np.tile(1e-2 / 3 * IDENTITY, (1, 1)), state)
    assert state["yield_state"][0] == S_ELASTIC
    assert p_q(sigma)[0][0] == pytest.approx(
        p_max * math.exp(-(1 + model.e0) * 1e-2 / model.kappa), rel=1e-12)
    assert state["p_c"][0] == pytest.approx(p_max, rel=1e-12)
    assert eps_max > 0


# --- Robustness, errors, state ---------------------------------------------------------


@pytest.mark.parametrize("model", ALL, ids=model_id)
def test_large_increments_converge_in_one_vectorised_call(model):
    rng = np.random.default_rng(4)
    m = 2000
    deps = 0.1 * rng.uniform(0, 1, (m, 1)) ** 2 * (rng.standard_normal((m, 6))
                                                     + 0.7 * rng.standard_normal((m, 1)) * IDENTITY)
    sigma, tangent, new = model.update(deps, state_at(model, np.tile(-P0 * IDENTITY, (m, 1)), P0))
    assert np.isfinite(sigma).all() and np.isfinite(tangent).all()
    p, _ = p_q(sigma)
    assert (p >= 0.0).all() and (p <= new["p_c"] * (1 + 1e-12)).all()


def test_cam_clay_tension_returns_to_the_origin():
    model = CamClay(**CLAY)   # linear elasticity: tensile trial states exist
    deps = np.outer([1e-2, 1e-1], IDENTITY)
    sigma, tangent, new = model.update(deps, state_at(model, np.tile(-10.0 * IDENTITY, (2, 1)),
                                                      P0))
    np.testing.assert_array_equal(new["yield_state"], S_ORIGIN)
    assert np.abs(sigma).max() == 0.0 and np.abs(tangent).max() == 0.0
    # The dilation softens p_c: ln(p_c / p_c,n) = -theta dilation, where the dilation is
    # the expansion tr deps less the elastic 10 / K of unloading p = 10 to 0.
    dilation = 3 * np.array([1e-2, 1e-1]) - 10.0 / model.K
    np.testing.assert_allclose(new["p_c"], P0 * np.exp(-model.theta * dilation), rtol=1e-12)
    np.testing.assert_allclose(new["eps_p_vol"], dilation, rtol=1e-12)


def test_failed_local_solve_raises_return_map_error(monkeypatch):
    monkeypatch.setattr(invariant_return, "MAX_ITERATIONS", 1)
    monkeypatch.setattr(invariant_return, "CONTINUATION_PARTS", ())
    model = ModifiedCamClay(**CLAY)
    deps = np.outer([1e-5, -5e-2, -1e-1], IDENTITY) + np.outer([0, 1e-2, 3e-2], unit_deviator(3))
    with pytest.raises(ReturnMapError,
                       match=r"ModifiedCamClay: .*did not converge at 2 of 3 points"):
        model.update(deps, state_at(model, np.tile(-P0 * IDENTITY, (3, 1)), P0))


def test_initial_preconsolidation_pressure():
    stress = np.array([-P0 * IDENTITY, -0.5 * IDENTITY, np.zeros(6),
                       -P0 * IDENTITY + 40.0 * SQRT2 * unit_deviator(5)])
    q = 40.0 * math.sqrt(3.0)
    mcc = ModifiedCamClay(**{**CLAY, "p_c0": 5.0}, ocr=2.0)
    np.testing.assert_allclose(mcc.initial_state(4, stress)["p_c"],
                               [2 * P0, 5.0, 5.0, 2 * (P0 + q**2 / (mcc.M**2 * P0))], rtol=1e-14)
    cc = CamClay(**{**CLAY, "p_c0": 5.0})
    np.testing.assert_allclose(cc.initial_state(4, stress)["p_c"],
                               [P0, 5.0, 5.0, P0 * math.exp(q / (cc.M * P0))], rtol=1e-14)
    state = cc.initial_state(3)
    assert set(state) == set(cc.history) == {"stress", "p_c", "eps_p_vol", "eps_p_eq",
                                              "yield_state"}
    np.testing.assert_array_equal(state["p_c"], 5.0)
    with pytest.raises(InputError, match=r"p_min.*compressive initial stress.*1 of 2 points"):
        ModifiedCamClay(**CLAY, elasticity=PRESSURE).initial_state(2, np.array([-IDENTITY,
                                                                                 np.zeros(6)]))
    ModifiedCamClay(**CLAY, elasticity=PRESSURE, p_min=1.0).initial_state(2)


def test_registry_and_parameters():
    table = {**CLAY, "p_c0": 20, "elasticity": "pressure_dependent"}
    model = from_table(MODELS["modified_cam_clay"], table, "m")
    assert model == ModifiedCamClay(**{**CLAY, "p_c0": 20.0}, elasticity=PRESSURE)
    assert from_table(MODELS["cam_clay"], CLAY, "m") == CamClay(**CLAY)
    assert CamClay(**CLAY).elasticity is LINEAR and CamClay(**CLAY).ocr == 1.0
    s = math.sin(math.radians(30.0))
    assert CamClay(**CLAY).M == pytest.approx(6 * s / (3 - s), rel=1e-15)
    assert ModifiedCamClay(**CLAY, elasticity="pressure_dependent").elasticity is PRESSURE


@pytest.mark.parametrize("name, value", [("cam_clay", 0.04), ("modified_cam_clay", 0.01)])
def test_lam_must_exceed_kappa(name, value):
    with pytest.raises(InputError, match=r"materials\.soil\.lam = .* larger than kappa"):
        from_table(MODELS[name], {**CLAY, "lam": value}, "materials.soil")
