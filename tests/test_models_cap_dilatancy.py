"""The caps with less dilatancy on the failure surface (``dilatancy`` eta_d, the
flow potential sqrt(J2) - eta_d F(I1)): the plastic strain follows the
potential, the corners' regions are the cones spanned by the return
directions, the retreating cap retreats by the smaller dilation, and the
default is associated flow (tangents against central differences in every
return mode with eta_d = 0.5 and 0: test_models_conformance.py; admissible
returns, warm starts and large increments: test_models_cap.py)."""
import dataclasses

import numpy as np
import pytest

from soilbin.errors import InputError
from soilbin.models import MODELS, DiMaggioSandler, ModifiedCap
from soilbin.models.cap import SECTION_VII5, CapHardening
from soilbin.params import from_table
from soilbin.tensors import IDENTITY, SQRT2, deviator, trace

S_ELASTIC, S_FAILURE, S_APEX, S_CUTOFF, S_CAP, S_CAP_CORNER = 0.0, 1.0, 2.0, 3.0, 4.0, 5.0

VII5 = dict(SECTION_VII5)
DS = {k: v for k, v in VII5.items() if k != "B"}
MODIFIED = ModifiedCap(**VII5, X0=20.0)
SANDLER = DiMaggioSandler(**DS, X0=20.0)
MODIFIED_T = ModifiedCap(**{**VII5, "A": 8.0}, X0=20.0, tension_cutoff=0.5)
SANDLER_T = DiMaggioSandler(**{**DS, "A": 8.0}, X0=20.0, tension_cutoff=1.0)
PLAIN, CUT = [MODIFIED, SANDLER], [MODIFIED_T, SANDLER_T]


def with_(model, dilatancy, hardening=CapHardening.CAP_COMPACTION):
    return dataclasses.replace(model, dilatancy=dilatancy, hardening=hardening)


def model_id(model):
    return f"{type(model).__name__}-T{model.tension_cutoff:g}"


def unit_deviators(seed, n):
    d = deviator(np.random.default_rng(seed).standard_normal((n, 6)))
    return d / np.linalg.norm(d, axis=1)[:, None]


def invariants(sigma):
    """(compression-positive p, sqrt(J2))."""
    return -trace(sigma) / 3.0, np.linalg.norm(deviator(sigma), axis=-1) / SQRT2


def random_steps(model, seed, m=2000):
    """(deps, state, sigma, tangent, new) of random increments from -3 I (every mode)."""
    rng = np.random.default_rng(seed)
    deps = 1e-2 * rng.uniform(0, 1, (m, 1)) ** 2 * (rng.standard_normal((m, 6))
                                                      + rng.standard_normal((m, 1)) * IDENTITY)
    state = model.initial_state(m, np.tile(-3.0 * IDENTITY, (m, 1)))
    return (deps, state) + model.update(deps, state)


def test_dilatancy_defaults_to_associated_flow_and_is_checked():
    table = {**VII5, "X0": 20.0}
    model = from_table(MODELS["modified_cap"], table, "materials.soil")
    assert model.dilatancy == 1.0 and model == MODIFIED
    assert from_table(MODELS["modified_cap"], {**table, "dilatancy": 0}, "m").dilatancy == 0.0
    for bad in (-0.1, 1.1):
        with pytest.raises(InputError, match=r"materials\.soil\.dilatancy"):
            from_table(MODELS["modified_cap"], {**table, "dilatancy": bad}, "materials.soil")


@pytest.mark.parametrize("hardening", CapHardening, ids=lambda h: h.value)
@pytest.mark.parametrize("model", PLAIN + CUT, ids=model_id)
def test_the_associated_model_is_the_limit_of_less_dilatancy(model, hardening):
    """eta_d = 1 - 1e-9 (the non-associated return) gives the stress and tangent of
    the default, associated model to 1e-7 at every point away from a region's edge:
    no separate associated path. (The default against the code before dilatancy:
    every output byte equal at 280 000 points, every mode, cold and warm.)"""
    model = with_(model, 1.0, hardening)
    deps, state, sigma, tangent, new = random_steps(model, 11)
    near = with_(model, 1.0 - 1e-9, hardening)
    s_near, t_near, n_near = near.update(deps, state)
    same = n_near["yield_state"] == new["yield_state"]
    assert np.count_nonzero(~same) <= 2
    np.testing.assert_allclose(s_near[same], sigma[same], rtol=0.0,
                               atol=1e-7 * np.abs(sigma).max())
    np.testing.assert_allclose(t_near[same], tangent[same], rtol=0.0,
                               atol=1e-7 * np.abs(model.stiffness).max())


@pytest.mark.parametrize("eta", [0.0, 0.3, 0.7, 1.0])
@pytest.mark.parametrize("model", PLAIN + CUT, ids=model_id)
def test_plastic_flow_follows_the_potential(model, eta):
    """On the failure surface the plastic strain is dgamma dg/dsigma: its dilation
    over sqrt2 |dev| is 3 eta_d F'(I1), and the stress is on J = F(I1); with
    eta_d = 0 the mean stress is the trial's."""
    model = with_(model, eta)
    n = 400
    p0 = np.linspace(0.5, 2.5, n)
    stress = -p0[:, None] * IDENTITY
    deps = 2.5e-3 * unit_deviators(5, n) + np.linspace(-2e-4, 2e-4, n)[:, None] * IDENTITY
    sigma, _, new = model.update(deps, model.initial_state(n, stress))
    fail = new["yield_state"] == S_FAILURE
    assert fail.sum() > n // 4
    deps_p = (deps - model.elastic_strain(stress, sigma))[fail]
    p, J = invariants(sigma[fail])
    F, dF, _ = model.failure(3.0 * p)
    np.testing.assert_allclose(J, F, rtol=1e-12)
    dilation = trace(deps_p)
    shear = SQRT2 * np.linalg.norm(deviator(deps_p), axis=1)
    np.testing.assert_allclose(dilation, 3.0 * eta * dF * shear, rtol=1e-9,
                               atol=1e-12 * shear.max())
    if eta == 0.0:
        p_tr = invariants(model.trial(deps, stress)[fail])[0]
        np.testing.assert_allclose(p, p_tr, rtol=0.0, atol=1e-14 * np.abs(p_tr).max())
        assert np.abs(new["eps_p_vol"][fail]).max() <= 1e-12 * shear.max()


@pytest.mark.parametrize("eta", [0.0, 0.5])
@pytest.mark.parametrize("model", PLAIN + CUT, ids=model_id)
def test_the_lowest_corner_takes_the_cone_of_the_return_directions(model, eta):
    """Trials of fixed shear J_tr and growing tension: the stress goes from the failure
    surface to the apex (or its corner with the cut-off, (p_lo, J_lo)) where the trial
    crosses the failure potential's return direction from the corner,
    p_lo - p_tr = 9 K eta_d F'(3 p_lo) (J_tr - J_lo) / (3 G), continuously; eta_d = 0:
    every trial beyond p_lo."""
    model = with_(model, eta)
    K, G = model.K, model.G
    p_lo, J_lo, dF_lo = model.lowest
    J_tr = J_lo + 0.3
    n = unit_deviators(3, 1)[0]
    edge = p_lo - 3.0 * K * eta * dF_lo * (J_tr - J_lo) / G      # p_tr at the edge
    p_n = 1.0

    def update(p_tr):
        deps = (p_n - p_tr) / (3.0 * K) * IDENTITY + J_tr / (SQRT2 * G) * n
        sigma, _, new = model.update(deps[None], model.initial_state(1, -p_n * IDENTITY))
        return sigma[0], new["yield_state"][0]

    step = 1e-9 * (1.0 + abs(edge))
    inside, beyond = update(edge + step), update(edge - step)
    assert inside[1] == S_FAILURE and beyond[1] == S_APEX
    np.testing.assert_allclose(invariants(beyond[0][None]), [[p_lo], [J_lo]], atol=1e-12)
    np.testing.assert_allclose(inside[0], beyond[0], atol=1e-7)
    # Associated flow returns the trial beyond the edge to the failure surface.
    if eta < 1.0:
        assert update(edge - 0.01)[1] == S_APEX
        assoc = dataclasses.replace(model, dilatancy=1.0)
        deps = (p_n - edge + 0.01) / (3.0 * K) * IDENTITY + J_tr / (SQRT2 * G) * n
        _, _, new = assoc.update(deps[None], assoc.initial_state(1, -p_n * IDENTITY))
        assert new["yield_state"][0] == S_FAILURE


@pytest.mark.parametrize("model", PLAIN + CUT, ids=model_id)
def test_the_cap_corner_takes_the_cone_of_the_return_directions(model):
    """Trials of fixed shear just below the cap's centre L: the stress goes from the
    failure surface to the fixed cap corner (L, F(L)) where the trial crosses the
    potential's return direction from it, L/3 - p_tr = 3 K eta_d F'(L) (J_tr - F(L)) / G
    (eta_d = 0.5: half the associated wedge), continuously."""
    model = with_(model, 0.5)
    K, G = model.K, model.G
    state = model.initial_state(1, -3.0 * IDENTITY)
    L = state["cap_L"][0]
    F_L, dF_L, _ = (float(v) for v in model.failure(np.array(L)))
    J_tr = F_L + 2.0
    n = unit_deviators(4, 1)[0]
    edge = L / 3.0 - 3.0 * K * 0.5 * dF_L * (J_tr - F_L) / G

    def update(p_tr):
        deps = (3.0 - p_tr) / (3.0 * K) * IDENTITY + J_tr / (SQRT2 * G) * n
        sigma, _, new = model.update(deps[None], state)
        return sigma[0], new["yield_state"][0]

    below, above = update(edge * (1.0 - 1e-9)), update(edge * (1.0 + 1e-9))
    assert below[1] == S_FAILURE and above[1] == S_CAP_CORNER
    np.testing.assert_allclose(invariants(above[0][None]), [[L / 3.0], [F_L]], rtol=1e-13)
    np.testing.assert_allclose(below[0], above[0], atol=1e-7)


@pytest.mark.parametrize("model", PLAIN + CUT, ids=model_id)
def test_isochoric_flow_sends_every_trial_beyond_the_lowest_point_there(model):
    """eta_d = 0: a trial with p_tr < p_lo returns to the apex (or the cut-off and its
    corner), any other beyond the failure surface below L to it at p = p_tr; the cap
    corner is reached from no trial below L."""
    model = with_(model, 0.0)
    deps, state, sigma, _, new = random_steps(model, 12)
    p_tr = invariants(model.trial(deps, state["stress"]))[0]
    ys = new["yield_state"]
    beyond = p_tr < model.lowest[0]
    assert beyond.sum() > 100
    np.testing.assert_array_equal(np.isin(ys, [S_APEX, S_CUTOFF]), beyond)
    assert not (ys == S_CAP_CORNER).any()


def shear_path(model, steps=10):
    """Constant-volume shear steps from -3 I: (yield states, cap centres, states, tangent)."""
    state = model.initial_state(1, -3.0 * IDENTITY)
    n = unit_deviators(5, 1)[0]
    codes, L = [], [state["cap_L"][0]]
    for _ in range(steps):
        _, tangent, state = model.update((2e-3 * n)[None], state)
        codes.append(state["yield_state"][0])
        L.append(state["cap_L"][0])
    return codes, np.array(L), state, tangent[0]


@pytest.mark.parametrize("model", PLAIN, ids=model_id)
def test_less_dilatancy_retreats_the_cap_less(model):
    """Volumetric hardening: the cap follows the failure surface's dilation back
    (B.11), so after the same shear step on the failure surface it has retreated the
    less the smaller eta_d, and not at all with eta_d = 0 (the plastic volume is then
    zero). (Where the cap meets the stress, at its corner, the volume balance alone
    sets L, whatever eta_d.)"""
    retreat = []
    for eta in (1.0, 0.5, 0.25, 0.0):
        codes, L, state, _ = shear_path(with_(model, eta, CapHardening.VOLUMETRIC), steps=1)
        assert codes[0] == S_FAILURE
        retreat.append(L[0] - L[-1])
        H = model.compaction(L)[0]
        assert -state["eps_p_vol"][0] == pytest.approx(H[-1] - H[0], rel=1e-9, abs=1e-15)
    assert retreat[0] > retreat[1] > retreat[2] > 0.0
    assert retreat[3] == pytest.approx(0.0, abs=1e-12 * L[0])   # round-off of L's inverse


@pytest.mark.parametrize("model", PLAIN, ids=model_id)
def test_isochoric_shear_stays_on_the_failure_surface_with_bulk_stiffness(model):
    """cap_compaction: associated shear at constant volume climbs the failure surface
    into the fixed cap corner, a vertex without bulk stiffness
    (test_models_cap.py); isochoric, the mean stress stays, the point stays on the
    failure surface, and its tangent keeps the bulk modulus: I:C:I = 9 K."""
    codes, L, state, tangent = shear_path(with_(model, 0.0))
    assert set(codes) == {S_FAILURE} and (L == L[0]).all()
    p, J = invariants(state["stress"])
    assert p[0] == pytest.approx(3.0, rel=1e-13) and state["eps_p_vol"][0] == 0.0
    assert J[0] == pytest.approx(float(model.failure(np.array(9.0))[0]), rel=1e-13)
    assert IDENTITY @ tangent @ IDENTITY == pytest.approx(9.0 * model.K, rel=1e-12)


@pytest.mark.parametrize("name", ["modified_cap", "dimaggio_sandler"])
def test_failure_tangent_is_unsymmetric_iff_non_associated(name):
    """On the conformance samples on the failure surface (central differences:
    test_models_conformance.py)."""
    samples = [s for s in MODELS[name].conformance_samples() if s.yield_state == S_FAILURE]
    assert {s.table.get("dilatancy", 1.0) for s in samples} == {1.0, 0.5, 0.0}
    for sample in samples:
        model = from_table(MODELS[name], sample.table, "m")
        _, tangent, _ = model.update(sample.deps[None], sample.state(model))
        asym = np.abs(tangent - np.swapaxes(tangent, 1, 2)).max() / np.abs(model.stiffness).max()
        if model.dilatancy == 1.0:
            assert asym < 1e-12
        else:
            assert asym > 1e-3


@pytest.mark.parametrize("name", ["modified_cap", "dimaggio_sandler"])
def test_samples_beyond_the_failure_potential_are_failure_returns_when_associated(name):
    samples = [s for s in MODELS[name].conformance_samples()
               if "beyond the failure potential" in s.mode]
    assert len(samples) == 8
    for sample in samples:
        table = {k: v for k, v in sample.table.items() if k != "dilatancy"}
        model = from_table(MODELS[name], table, "m")
        _, _, new = model.update(sample.deps[None], sample.state(model))
        assert new["yield_state"][0] == S_FAILURE
