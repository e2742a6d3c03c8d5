"""Drucker–Prager with a dilation angle psi (non-associated flow): the plastic
strain follows the potential, the consistent tangent is unsymmetric on the
cone (it matches central differences in every return mode, with and without
cut-off: test_models_conformance.py), and psi = phi is the associated model
bit for bit."""
import math

import numpy as np
import pytest

from soilbin.errors import InputError
from soilbin.models import MODELS, DruckerPrager, Matching
from soilbin.params import from_table
from soilbin.tensors import IDENTITY, SQRT2, deviator, trace

E, NU = 4000.0, 0.35
C_MC, PHI = 0.5, 33.0
S_ELASTIC, S_CONE, S_APEX, S_CUTOFF = 0.0, 1.0, 2.0, 3.0


def dp(psi, matching=Matching.COMPRESSION_CONE, **kw):
    return DruckerPrager(E, NU, C_MC, PHI, matching, psi=psi, **kw)


def unit_deviators(seed, n):
    d = deviator(np.random.default_rng(seed).standard_normal((n, 6)))
    return d / np.linalg.norm(d, axis=1)[:, None]


def points(model):
    """(deps, stress_n, expected yield_state): elastic, cone (two), apex."""
    d = unit_deviators(3, 4)
    p0 = -2.0 * IDENTITY
    deps = np.array([1e-5 * d[0] - 1e-5 * IDENTITY,      # elastic
                     2e-3 * d[1] - 1e-4 * IDENTITY,      # cone, compressive
                     2e-3 * d[2] + 2e-4 * IDENTITY,      # cone, near the apex
                     2e-3 * IDENTITY + 1e-5 * d[3]])     # apex: hydrostatic tension
    stress = np.array([p0, p0, p0, np.zeros(6)])
    return deps, stress, np.array([S_ELASTIC, S_CONE, S_CONE, S_APEX])


def test_tangent_is_unsymmetric_on_the_cone_iff_non_associated():
    # On the conformance samples (tangents against central differences, in every
    # return mode: test_models_conformance.py).
    for sample in MODELS["drucker_prager"].conformance_samples():
        model = from_table(MODELS["drucker_prager"], sample.table, "m")
        _, tangent, _ = model.update(sample.deps[None], sample.state(model))
        asym = np.abs(tangent - np.swapaxes(tangent, 1, 2)).max() / np.abs(model.stiffness).max()
        if model.psi == model.phi:
            assert asym < 1e-12
        elif sample.yield_state == S_CONE:
            assert asym > 1e-3


def test_cutoff_and_corner_hold_the_mean_stress_at_the_cutoff():
    samples = [s for s in MODELS["drucker_prager"].conformance_samples()
               if s.table.get("psi", PHI) < PHI and "tension_cutoff" in s.table
               and s.yield_state in (S_CUTOFF, S_APEX)]
    assert len(samples) == 4
    for sample in samples:
        model = from_table(MODELS["drucker_prager"], sample.table, "m")
        sigma, _, _ = model.update(sample.deps[None], sample.state(model))
        assert trace(sigma)[0] / 3.0 == pytest.approx(model.tension_cutoff, rel=1e-13)


@pytest.mark.parametrize("psi", [0.0, 10.0, 25.0])
def test_plastic_flow_follows_the_potential(psi):
    """On the cone the plastic strain is dgamma dg/dsigma: its volumetric part over
    sqrt2 |dev| is eta_g = 3 alpha(psi) (dilation), and the stress is on f = 0."""
    model = dp(psi)
    deps = np.array([3e-3 * unit_deviators(5, 1)[0] - 2e-4 * IDENTITY])
    stress = np.array([-3.0 * IDENTITY])
    sigma, _, new = model.update(deps, model.initial_state(1, stress))
    assert new["yield_state"][0] == S_CONE
    deps_p = deps - model.elastic_strain(stress, sigma)
    eta, k = model.cone
    eta_g = 3.0 * Matching.COMPRESSION_CONE.coefficients(C_MC, psi)[0]
    assert trace(deps_p)[0] == pytest.approx(eta_g * SQRT2 * np.linalg.norm(deviator(deps_p)),
                                             rel=1e-10, abs=1e-15)
    s = deviator(sigma)
    f = np.linalg.norm(s) / SQRT2 + eta * trace(sigma)[0] / 3.0 - k
    assert abs(f) < 1e-12 * k
    if psi == 0.0:   # isochoric flow: the mean stress is the trial's
        assert trace(sigma)[0] == pytest.approx(trace(stress + deps @ model.stiffness)[0],
                                                rel=1e-13)


def test_isochoric_apex_takes_every_trial_beyond_it():
    """psi = 0: flow normal to g cannot change p, so any trial with p_tr beyond the
    apex k/eta returns to the apex (the cut-off at the apex takes the volume)."""
    model = dp(0.0)
    eta, k = model.cone
    d = unit_deviators(6, 1)[0]
    # p_tr just beyond the apex with a large shear: associated flow would reach the cone.
    deps = np.array([(k / eta + 0.01) / (3.0 * model.K) * IDENTITY + 5e-3 * d])
    sigma, tangent, new = model.update(deps, model.initial_state(1))
    assert new["yield_state"][0] == S_APEX
    np.testing.assert_allclose(sigma[0], k / eta * IDENTITY, rtol=1e-14)
    assert not tangent.any()
    _, _, assoc = dp(PHI).update(deps, dp(PHI).initial_state(1))
    assert assoc["yield_state"][0] == S_CONE


def test_psi_defaults_to_phi_and_is_checked():
    table = {"E": E, "nu": NU, "c": C_MC, "phi": PHI, "matching": "plane_strain"}
    model = from_table(MODELS["drucker_prager"], table, "materials.soil")
    assert model.psi == PHI and model.flow_slope == model.cone[0]
    explicit = from_table(MODELS["drucker_prager"], {**table, "psi": PHI}, "materials.soil")
    deps, stress, _ = points(model)
    for a, b in zip(model.update(deps, model.initial_state(4, stress))[:2],
                    explicit.update(deps, explicit.initial_state(4, stress))[:2]):
        np.testing.assert_array_equal(a, b)
    for bad in (-1.0, PHI + 1.0):
        with pytest.raises(InputError, match="psi"):
            from_table(MODELS["drucker_prager"], {**table, "psi": bad}, "materials.soil")
    assert math.isfinite(dp(0.0).flow_slope) and dp(0.0).flow_slope == 0.0
