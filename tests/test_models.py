"""Constitutive models: consistent tangents by finite differences, closed-form
strengths, return to the yield surface, input checks."""
import math

import numpy as np
import pytest

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
ALL = [ELASTIC, VON_MISES, DP, DP_PLANE]


def cone_f(model, sigma):
    """(f, k): yield function of eqs. B.1/B.2 written out, f = alpha I1 + sqrt(J2) - k."""
    if isinstance(model, VonMises):
        alpha, k = 0.0, model.c
    else:
        alpha, k = model.matching.coefficients(model.c, model.phi)
    s = deviator(sigma)
    return alpha * trace(sigma) + np.sqrt(0.5 * np.sum(s * s, axis=-1)) - k, k


def mixed_points(model, rng):
    """(deps, stress_n, expected yield_state): elastic, cone and apex points."""
    dev = deviator(rng.standard_normal((3, 6)))
    dev /= np.linalg.norm(dev, axis=1)[:, None]
    p0 = -200.0 * IDENTITY
    # Elastic: small increment from a compressive state well inside.
    deps = [1e-4 * dev[0] - 1e-4 * IDENTITY]
    stress = [p0]
    expected = [0.0]
    # Cone: a large deviatoric trial at compressive pressure.
    deps.append(2e-2 * dev[1] - 1e-3 * IDENTITY)
    stress.append(p0)
    expected.append(1.0)
    if not isinstance(model, VonMises):
        # Apex: a large hydrostatic tension trial with a little shear.
        deps.append(5e-2 * IDENTITY + 1e-4 * dev[2])
        stress.append(np.zeros(6))
        expected.append(2.0)
    return np.array(deps), np.array(stress), np.array(expected)


def state_with(model, stress):
    state = model.initial_state(len(stress), stress)
    if "eps_p_eq" in state:
        state["eps_p_eq"][:] = 0.01
    return state


@pytest.mark.parametrize("model", ALL, ids=lambda m: type(m).__name__)
def test_tangent_matches_central_differences(model):
    rng = np.random.default_rng(1)
    deps, stress, expected = mixed_points(model, rng)
    state = state_with(model, stress)
    _, tangent, new = model.update(deps, state)
    if "yield_state" in new:
        np.testing.assert_array_equal(new["yield_state"], expected)
    h = 1e-9   # 1e-7 of the strain scale 1e-2
    fd = np.empty_like(tangent)
    for j in range(6):
        step = np.zeros(6)
        step[j] = h
        plus = model.update(deps + step, state)[0]
        minus = model.update(deps - step, state)[0]
        fd[:, :, j] = (plus - minus) / (2.0 * h)
    scale = np.abs(model.stiffness).max()
    assert np.abs(fd - tangent).max() / scale < 1e-6
    np.testing.assert_allclose(tangent, np.swapaxes(tangent, 1, 2), atol=1e-12 * scale)


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
    strength = 2 * C_MC * math.cos(math.radians(PHI)) / (1 - math.sin(math.radians(PHI)))
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
    strength = 2 * C_MC * math.cos(math.radians(PHI)) / (1 - math.sin(math.radians(PHI)))
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


@pytest.mark.parametrize("model", ALL, ids=lambda m: type(m).__name__)
def test_update_does_not_mutate_inputs(model):
    rng = np.random.default_rng(4)
    deps, stress, _ = mixed_points(model, rng)
    state = state_with(model, stress)
    before = {k: v.copy() for k, v in state.items()}
    deps_before = deps.copy()
    _, _, new = model.update(deps, state)
    np.testing.assert_array_equal(deps, deps_before)
    assert state.keys() == before.keys() == new.keys() == model.history.keys()
    for name, shape in model.history.items():
        np.testing.assert_array_equal(state[name], before[name])
        assert new[name].shape == (len(deps),) + shape
        assert not np.shares_memory(new[name], state[name])


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


@pytest.mark.parametrize("name, table, key", [
    ("elastic", {"E": 1e4, "nu": 0.5}, "nu"),
    ("elastic", {"E": -1.0, "nu": 0.3}, "E"),
    ("von_mises", {"E": 1e4, "nu": 0.3, "c": 0.0}, "c"),
    ("drucker_prager", {"E": 1e4, "nu": 0.3, "c": 10.0, "phi": 95.0,
                        "matching": "plane_strain"}, "phi"),
    ("drucker_prager", {"E": 1e4, "nu": 0.3, "c": -1.0, "phi": 30.0,
                        "matching": "plane_strain"}, "c"),
    ("drucker_prager", {"E": 1e4, "nu": 0.3, "c": 10.0, "phi": 30.0,
                        "matching": "tension_cone"}, "matching"),
])
def test_invalid_parameters_name_the_parameter(name, table, key):
    with pytest.raises(InputError, match=rf"materials\.soil\.{key}\b"):
        from_table(MODELS[name], table, "materials.soil")


def test_direct_construction_checks_ranges():
    with pytest.raises(InputError, match=r"nu = 0\.5 .*\(-1, 0\.5\)"):
        LinearElastic(E, 0.5)
    with pytest.raises(InputError, match=r"phi = 95"):
        DruckerPrager(E, NU, C_MC, 95.0, Matching.COMPRESSION_CONE)


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
