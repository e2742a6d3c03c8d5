"""Elastic and cone models: Hooke's law, closed-form strengths, return to the
yield surface, tension cut-off, input checks (the checks every model passes
are in test_models_conformance.py)."""
import dataclasses
import math

import numpy as np
import pytest

from soilbin.closed_form.verification import unconfined_strength
from soilbin.errors import InputError, ReturnMapError
from soilbin.models import MODELS, DruckerPrager, LinearElastic, Matching, VonMises
from soilbin.params import from_table
from soilbin.tensors import IDENTITY, SQRT2, deviator, from_mandel, to_mandel, trace

E, NU = 1.0e5, 0.3
C_MC, PHI = 500.0, 30.0

ELASTIC = LinearElastic(E, NU)
VON_MISES = VonMises(E, NU, c=100.0)
DP = DruckerPrager(E, NU, C_MC, PHI, Matching.COMPRESSION_CONE)
DP_PLANE = DruckerPrager(E, NU, C_MC, PHI, Matching.PLANE_STRAIN)
# With a tension cut-off p <= T below the apex (k / eta = 866 for both cones).
DP_T = DruckerPrager(E, NU, C_MC, PHI, Matching.COMPRESSION_CONE, tension_cutoff=100.0)
DP_PLANE_T0 = DruckerPrager(E, NU, C_MC, PHI, Matching.PLANE_STRAIN, tension_cutoff=0.0)
VON_MISES_T = VonMises(E, NU, c=100.0, tension_cutoff=20.0)
CUTOFF = [DP_T, DP_PLANE_T0, VON_MISES_T]
# yield_state values.
S_ELASTIC, S_CONE, S_CORNER, S_CUTOFF = 0.0, 1.0, 2.0, 3.0


def model_id(model):
    name = type(model).__name__
    if math.isfinite(getattr(model, "tension_cutoff", math.inf)):
        name += f"-T{model.tension_cutoff:g}"
    return name


def cone_f(model, sigma):
    """(f, k): yield function of eqs. B.1/B.2 written out, f = alpha I1 + sqrt(J2) - k."""
    if isinstance(model, VonMises):
        alpha, k = 0.0, model.c
    else:
        alpha, k = model.matching.coefficients(model.c, model.phi)
    s = deviator(sigma)
    return alpha * trace(sigma) + np.sqrt(0.5 * np.sum(s * s, axis=-1)) - k, k


@pytest.mark.parametrize("name", ["von_mises", "drucker_prager"])
def test_associated_cone_tangent_is_symmetric(name):
    # In every return mode of the conformance samples with associated flow.
    for sample in MODELS[name].conformance_samples():
        model = from_table(MODELS[name], sample.table, "m")
        if model.flow_slope != model.cone[0]:
            continue
        _, tangent, _ = model.update(sample.deps[None], sample.state(model))
        np.testing.assert_allclose(tangent, np.swapaxes(tangent, 1, 2),
                                   atol=1e-12 * np.abs(model.stiffness).max())


def test_elastic_stress_is_hooke():
    rng = np.random.default_rng(2)
    eps = rng.standard_normal((5, 6)) * 1e-3
    sigma, _, _ = ELASTIC.update(eps, ELASTIC.initial_state(5))
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    mu = E / (2 * (1 + NU))
    eps_t = from_mandel(eps)
    hooke = lam * np.trace(eps_t, axis1=1, axis2=2)[:, None, None] * np.eye(3) + 2 * mu * eps_t
    np.testing.assert_allclose(sigma, to_mandel(hooke), rtol=1e-14, atol=1e-12)


def drive(model, eps_axial, axial, free, fixed=()):
    """Strain path in steps of the axial strain ``axial``, zero stress in the
    ``free`` components (Newton with the tangent), zero strain in ``fixed`` ones
    and in the shears. Returns the axial stress after each step and the state."""
    state = model.initial_state(1)
    free = list(free)
    history = []
    for target in eps_axial:
        deps = np.zeros((1, 6))
        deps[0, axial] = target - (history[-1][1] if history else 0.0)
        for _ in range(50):
            sigma, tangent, new = model.update(deps, state)
            r = sigma[0, free]
            if np.abs(r).max() < 1e-10 * C_MC:
                break
            deps[0, free] -= np.linalg.solve(tangent[0][np.ix_(free, free)], r)
        else:
            pytest.fail("lateral stress iteration did not converge")
        state = new
        history.append((sigma[0, axial], target))
    assert all(state["stress"][0, j] == 0.0 for j in range(3, 6))
    return np.array([s for s, _ in history]), state


def test_uniaxial_compression_compression_cone_collapses_at_unconfined_strength():
    strength = unconfined_strength(C_MC, PHI)
    assert strength == pytest.approx(1732.0508, abs=1e-4)
    eps = -np.linspace(0.1, 3.0, 30) * strength / E
    sigma, state = drive(DP, eps, axial=2, free=(0, 1))
    elastic = eps > -strength / E
    np.testing.assert_allclose(sigma[elastic], E * eps[elastic], rtol=1e-10)
    np.testing.assert_allclose(sigma[~elastic], -strength, rtol=1e-10)
    assert state["yield_state"][0] == 1.0 and state["eps_p_eq"][0] > 0.0


def test_plane_strain_matching_gives_mohr_coulomb_collapse_in_plane_strain():
    # Unconfined plane-strain compression: sigma_11 = 0, eps_33 = 0. Once the
    # stress stops changing the plastic flow is plane, and the plane-strain
    # cone reproduces the Mohr–Coulomb strength 2c cos(phi) / (1 - sin(phi)).
    strength = unconfined_strength(C_MC, PHI)
    eps = -np.geomspace(0.1, 30.0, 30) * strength / E
    sigma, _ = drive(DP_PLANE, eps, axial=1, free=(0,))
    assert sigma[-1] == pytest.approx(-strength, rel=1e-10)


def test_von_mises_pure_shear_yields_at_c():
    c, G = VON_MISES.c, VON_MISES.G
    gamma = np.linspace(0.2, 3.0, 15) * c / G   # engineering shear strain
    tau = []
    state = VON_MISES.initial_state(1)
    previous = 0.0
    for g in gamma:
        deps = np.zeros((1, 6))
        deps[0, 5] = SQRT2 * (g - previous) / 2   # Mandel: sqrt2 * eps_12
        sigma, _, state = VON_MISES.update(deps, state)
        tau.append(sigma[0, 5] / SQRT2)
        previous = g
    tau = np.array(tau)
    elastic = gamma < c / G
    np.testing.assert_allclose(tau[elastic], G * gamma[elastic], rtol=1e-12)
    np.testing.assert_allclose(tau[~elastic], c, rtol=1e-12)


@pytest.mark.parametrize("model", [VON_MISES, DP, DP_PLANE], ids=lambda m: type(m).__name__)
def test_returned_stress_lies_on_yield_surface(model):
    rng = np.random.default_rng(3)
    scale = 2e-2 * rng.uniform(0.0, 1.0, (200, 1)) ** 3
    deps = scale * (rng.standard_normal((200, 6)) + rng.standard_normal((200, 1)) * IDENTITY)
    sigma, _, state = model.update(deps, model.initial_state(200))
    f, k = cone_f(model, sigma)
    on_cone = state["yield_state"] == 1.0
    assert on_cone.sum() > 20
    assert np.abs(f[on_cone]).max() < 1e-10 * k
    elastic = state["yield_state"] == 0.0
    assert elastic.sum() > 20 and (f[elastic] <= 0.0).all()
    apex = state["yield_state"] == 2.0
    if isinstance(model, DruckerPrager):
        assert apex.sum() > 10
        alpha, k = model.matching.coefficients(model.c, model.phi)
        np.testing.assert_allclose(sigma[apex], np.outer(np.full(apex.sum(), k / (3 * alpha)),
                                                         IDENTITY), rtol=1e-13, atol=1e-10)
    # Plastic points accumulate equivalent plastic strain, elastic ones do not.
    assert (state["eps_p_eq"][on_cone | apex] > 0).all()
    assert np.abs(state["eps_p_eq"][elastic]).max() < 1e-15


def test_initial_state():
    state = DP.initial_state(4, stress0=-10.0 * IDENTITY)
    assert set(state) == {"stress", "eps_p_eq", "yield_state"}
    np.testing.assert_array_equal(state["stress"], np.tile(-10.0 * IDENTITY, (4, 1)))
    assert state["eps_p_eq"].shape == state["yield_state"].shape == (4,)
    assert ELASTIC.linear and not DP.linear and not VON_MISES.linear


def test_non_finite_update_raises_return_map_error():
    deps = np.zeros((3, 6))
    deps[1, 0] = np.nan
    with pytest.raises(ReturnMapError, match=r"DruckerPrager.* 1 of 3 points"):
        DP.update(deps, DP.initial_state(3))


def test_direct_construction_checks_ranges():
    with pytest.raises(InputError, match=r"nu = 0\.5 .*\(-1, 0\.5\)"):
        LinearElastic(E, 0.5)
    with pytest.raises(InputError, match=r"phi = 95"):
        DruckerPrager(E, NU, C_MC, 95.0, Matching.COMPRESSION_CONE)
    with pytest.raises(InputError, match=r"tension_cutoff = -1\.0 .*\[0, inf\]"):
        DruckerPrager(E, NU, C_MC, PHI, Matching.COMPRESSION_CONE, tension_cutoff=-1.0)


def test_registry_builds_models_from_tables():
    dp = from_table(MODELS["drucker_prager"], {"E": E, "nu": NU, "c": C_MC, "phi": PHI,
                                               "matching": "compression_cone"}, "m")
    assert dp == DP
    alpha, k = dp.matching.coefficients(C_MC, PHI)
    s = math.sin(math.radians(PHI))
    assert alpha == pytest.approx(2 * s / (math.sqrt(3) * (3 - s)), rel=1e-15)
    t = math.tan(math.radians(PHI))
    alpha, k = Matching.PLANE_STRAIN.coefficients(C_MC, PHI)
    d = math.sqrt(9 + 12 * t * t)
    assert (alpha, k) == pytest.approx((t / d, 3 * C_MC / d), rel=1e-15)


# --- Tension cut-off p <= T ------------------------------------------------------


def cone_params(model):
    """(eta, k, T) of f_cone = sqrt(J2) + eta p - k and f_t = p - T, written out."""
    if isinstance(model, VonMises):
        eta, k = 0.0, model.c
    else:
        alpha, k = model.matching.coefficients(model.c, model.phi)
        eta = 3.0 * alpha
    return eta, k, model.tension_cutoff


def p_and_j(sigma):
    s = deviator(sigma)
    return trace(sigma) / 3.0, np.sqrt(0.5 * np.sum(s * s, axis=-1))


def trial_stress(p, J, n):
    """Stresses with mean stress p, sqrt(J2) = J and deviatoric direction n (|n| = 1)."""
    return np.outer(p, IDENTITY) + SQRT2 * np.outer(J, n)


def unit_deviator(rng):
    n = deviator(rng.standard_normal(6))
    return n / np.linalg.norm(n)


def stress_update(model, sigma_tr):
    """Return map of the trial stresses themselves (zero strain increment)."""
    sigma_tr = np.atleast_2d(sigma_tr)
    return model.update(np.zeros_like(sigma_tr), model.initial_state(len(sigma_tr), sigma_tr))


@pytest.mark.parametrize("model", CUTOFF, ids=model_id)
def test_cutoff_returns_onto_both_surfaces_by_normality(model):
    eta, k, T = cone_params(model)
    G, K = model.G, model.K
    rng = np.random.default_rng(5)
    n = 4000
    scale = 2e-2 * rng.uniform(0.0, 1.0, (n, 1)) ** 3
    deps = scale * (rng.standard_normal((n, 6)) + rng.standard_normal((n, 1)) * IDENTITY)
    sigma, _, state = model.update(deps, model.initial_state(n))
    sigma_tr = model.trial(deps, np.zeros((n, 6)))
    ys = state["yield_state"]
    counts = {v: np.count_nonzero(ys == v) for v in (S_ELASTIC, S_CONE, S_CORNER, S_CUTOFF)}
    assert set(np.unique(ys)) <= set(counts) and min(counts.values()) > 50, counts
    p, J = p_and_j(sigma)
    f_cone, f_t = J + eta * p - k, p - T
    tol = 1e-10 * k
    # Admissible everywhere, and on the surface(s) the label names.
    assert f_cone.max() <= tol and f_t.max() <= tol
    assert np.abs(f_cone[(ys == S_CONE) | (ys == S_CORNER)]).max() <= tol
    assert np.abs(f_t[(ys == S_CUTOFF) | (ys == S_CORNER)]).max() <= tol
    np.testing.assert_array_equal(sigma[ys == S_ELASTIC], sigma_tr[ys == S_ELASTIC])
    # Normality: sigma_tr - sigma = C_e : (dgamma df_cone/dsigma + dlambda df_t/dsigma)
    # = dgamma (sqrt2 G n + eta K I) + dlambda K I, with n = s / |s| and the
    # multiplier of each surface >= 0 (> 0 only where the point is on it). This
    # is the closest-point projection, so it also checks the region boundaries.
    plastic = ys != S_ELASTIC
    d_sigma = (sigma_tr - sigma)[plastic]
    s = deviator(sigma[plastic])
    s_norm = np.linalg.norm(s, axis=1)
    nvec = s / np.where(s_norm > 0, s_norm, 1.0)[:, None]
    d_s = deviator(d_sigma)
    g_dgamma = np.sum(d_s * nvec, axis=1) / SQRT2          # G dgamma
    assert np.abs(d_s - SQRT2 * g_dgamma[:, None] * nvec).max() <= tol
    k_dlambda = trace(d_sigma) / 3.0 - eta * K / G * g_dgamma  # K dlambda
    on = ys[plastic]
    assert g_dgamma.min() >= -tol and k_dlambda.min() >= -tol
    assert np.abs(g_dgamma[on == S_CUTOFF]).max() <= tol
    assert np.abs(k_dlambda[on == S_CONE]).max() <= tol
    assert (g_dgamma[on == S_CONE] > 0).all() and (k_dlambda[on == S_CUTOFF] > 0).all()
    # Plastic points accumulate equivalent plastic strain, elastic ones do not.
    assert (state["eps_p_eq"][plastic] > 0).all()
    assert np.abs(state["eps_p_eq"][~plastic]).max() < 1e-15


@pytest.mark.parametrize("model", CUTOFF, ids=model_id)
def test_hydrostatic_tension_returns_to_cutoff_exactly(model):
    T = model.tension_cutoff
    # A hydrostatic trial stress beyond T: exactly T I.
    p_tr = T + np.array([1e-6, 1.0, 1e3, 1e6])
    sigma, tangent, state = stress_update(model, np.outer(p_tr, IDENTITY))
    np.testing.assert_array_equal(sigma, np.tile(T * IDENTITY, (4, 1)))
    np.testing.assert_array_equal(state["yield_state"], S_CUTOFF)
    np.testing.assert_allclose(tangent, np.tile(2 * model.G * (np.eye(6) - np.outer(
        IDENTITY, IDENTITY) / 3), (4, 1, 1)), rtol=1e-15, atol=1e-10)
    # Strain-driven from zero stress: p = T and s = 0 up to rounding.
    deps = np.outer([1e-3, 1e-2, 1.0], IDENTITY)
    sigma, _, state = model.update(deps, model.initial_state(3))
    p, J = p_and_j(sigma)
    np.testing.assert_allclose(p, T, rtol=0, atol=1e-13 * (T + model.K))
    assert np.abs(deviator(sigma)).max() <= 1e-15 * model.K
    np.testing.assert_array_equal(state["yield_state"], S_CUTOFF)


def test_uniaxial_tension_is_cut_off_at_three_t():
    # The compression cone's uniaxial tensile strength k / (1/sqrt3 + eta/3) is
    # 742.3; with T = 100 the cut-off governs and sigma = 3T (p = sigma/3 = T).
    eta, k, T = cone_params(DP_T)
    strength = k / (1 / math.sqrt(3) + eta / 3)
    assert strength == pytest.approx(742.3075, abs=1e-4) and 3 * T < strength
    eps = np.linspace(0.1, 3.0, 30) * 3 * T / E
    sigma, state = drive(DP_T, eps, axial=2, free=(0, 1))
    elastic = eps <= 3 * T / E
    np.testing.assert_allclose(sigma[elastic], E * eps[elastic], rtol=1e-10)
    np.testing.assert_allclose(sigma[~elastic], 3 * T, rtol=1e-10)
    assert state["yield_state"][0] == S_CUTOFF and state["eps_p_eq"][0] > 0.0
    # With 3T above the tensile strength (T = 400, still below the apex 866) the
    # cone governs, at the same strength as without cut-off.
    dp_400 = dataclasses.replace(DP_T, tension_cutoff=400.0)
    eps = np.linspace(0.1, 3.0, 30) * strength / E
    sigma, state = drive(dp_400, eps, axial=2, free=(0, 1))
    np.testing.assert_allclose(sigma[eps > strength / E], strength, rtol=1e-10)
    assert state["yield_state"][0] == S_CONE
    np.testing.assert_allclose(sigma, drive(DP, eps, axial=2, free=(0, 1))[0], rtol=1e-12)


@pytest.mark.parametrize("model", CUTOFF, ids=model_id)
def test_cutoff_return_is_continuous_across_region_boundaries(model):
    eta, k, T = cone_params(model)
    K, G = model.K, model.G
    J_c = k - eta * T   # sqrt(J2) at the corner
    n = unit_deviator(np.random.default_rng(6))
    delta = 1e-7 * k
    # (p, sqrt(J2)) on a boundary, crossing direction, yield_state below / above.
    boundaries = {
        "elastic|cone": ((T - k / 2, k - eta * (T - k / 2)), (0.0, 1.0), (S_ELASTIC, S_CONE)),
        "elastic|cut-off": ((T, J_c / 2), (1.0, 0.0), (S_ELASTIC, S_CUTOFF)),
        "cut-off|corner": ((T + k, J_c), (0.0, 1.0), (S_CUTOFF, S_CORNER)),
        "cone|corner": ((T + eta * K / G * k / 2, J_c + k / 2), (1.0, 0.0), (S_CONE, S_CORNER)),
    }
    for name, ((p, J), (dp, dJ), expected) in boundaries.items():
        p_tr = p + np.array([-1.0, 1.0]) * delta * dp
        J_tr = J + np.array([-1.0, 1.0]) * delta * dJ
        sigma, _, state = stress_update(model, trial_stress(p_tr, J_tr, n))
        np.testing.assert_array_equal(state["yield_state"], expected, err_msg=name)
        jump = np.abs(sigma[1] - sigma[0]).max()
        assert jump <= 10 * delta, (name, jump / delta)


def test_cutoff_corner_replaces_apex():
    eta, k, T = cone_params(DP_T)
    # Pure hydrostatic trial far beyond the apex: cut-off, not apex.
    sigma, _, state = stress_update(DP_T, 5 * k / eta * IDENTITY)
    np.testing.assert_array_equal(sigma[0], T * IDENTITY)
    assert state["yield_state"][0] == S_CUTOFF
    # A trial in the corner region: p = T and sqrt(J2) = k - eta T, s radial.
    n = unit_deviator(np.random.default_rng(7))
    sigma, tangent, state = stress_update(DP_T, trial_stress([5 * k / eta], [2 * k], n))
    p, J = p_and_j(sigma)
    assert state["yield_state"][0] == S_CORNER
    assert p[0] == pytest.approx(T, rel=1e-14) and J[0] == pytest.approx(k - eta * T, rel=1e-14)
    np.testing.assert_allclose(deviator(sigma)[0], SQRT2 * J[0] * n, rtol=0, atol=1e-12 * k)
    # von Mises: corner at p = T, sqrt(J2) = c.
    sigma, _, state = stress_update(VON_MISES_T, trial_stress([1e3], [1e3], n))
    p, J = p_and_j(sigma)
    assert state["yield_state"][0] == S_CORNER
    assert (p[0], J[0]) == pytest.approx((VON_MISES_T.tension_cutoff, VON_MISES_T.c), rel=1e-14)


@pytest.mark.parametrize("model, inactive", [
    (DP, DP.matching.coefficients(C_MC, PHI)[1] / (3 * DP.matching.coefficients(C_MC, PHI)[0])),
    (DP, 1e4), (DP_PLANE, 1e9), (VON_MISES, math.inf),
], ids=["DP-apex", "DP-above-apex", "DP_PLANE", "VonMises-inf"])
def test_cutoff_at_or_above_apex_changes_nothing(model, inactive):
    assert model.tension_cutoff == math.inf   # the default
    rng = np.random.default_rng(8)
    deps = 3e-2 * rng.uniform(0, 1, (500, 1)) ** 3 * (
        rng.standard_normal((500, 6)) + 2 * rng.standard_normal((500, 1)) * IDENTITY)
    with_t = dataclasses.replace(model, tension_cutoff=inactive)
    a = model.update(deps, model.initial_state(500))
    b = with_t.update(deps, with_t.initial_state(500))
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    for name in a[2]:
        np.testing.assert_array_equal(a[2][name], b[2][name])
    assert set(np.unique(a[2]["yield_state"])) <= {S_ELASTIC, S_CONE, S_CORNER}


def test_tension_cutoff_from_table():
    table = {"E": E, "nu": NU, "c": C_MC, "phi": PHI, "matching": "compression_cone"}
    assert from_table(MODELS["drucker_prager"], table, "m").tension_cutoff == math.inf
    dp = from_table(MODELS["drucker_prager"], {**table, "tension_cutoff": 100}, "m")
    assert dp == DP_T and isinstance(dp.tension_cutoff, float)
    assert from_table(MODELS["drucker_prager"], {**table, "tension_cutoff": math.inf},
                      "m") == DP
    vm = from_table(MODELS["von_mises"], {"E": E, "nu": NU, "c": 100.0,
                                          "tension_cutoff": 20.0}, "m")
    assert vm == VON_MISES_T
