"""The modified cap and DiMaggio–Sandler with the section VII.5 parameters as
printed (A = C: no strength at zero mean stress, the failure surface through
the origin) at points near the free surface, in the geostatic K0 state with
the cap through the initial stress (X0 = 0), under the stress paths a tool
imposes: compression and shear in front, extension and shear beside and
behind, lift (tension). Every return converges, lands on an admissible
stress, and the consistent tangent matches central differences in each
return mode reached (cap, cap/failure corner, failure surface, apex)."""
import dataclasses

import numpy as np
import pytest

from conftest import central_differences

from soilbin.models import DiMaggioSandler, ModifiedCap
from soilbin.models.cap import SECTION_VII5, CapHardening
from soilbin.tensors import IDENTITY, SQRT2, deviator, trace

S_ELASTIC, S_FAILURE, S_APEX, S_CAP, S_CAP_CORNER = 0.0, 1.0, 2.0, 4.0, 5.0
MODIFIED = ModifiedCap(**SECTION_VII5)
SANDLER = DiMaggioSandler(**{k: v for k, v in SECTION_VII5.items() if k != "B"})
GAMMA, K0 = 0.072, 0.455      # pci; 1 - sin 33 deg (the tine scene's geostatic state)


def geostatic(z):
    """K0 stress (tension positive) at the depths z (in)."""
    sv = -GAMMA * np.asarray(z, dtype=float)
    return np.stack([K0 * sv, K0 * sv, sv] + [0.0 * sv] * 3, axis=-1)


def unit(seed):
    n = deviator(np.random.default_rng(seed).standard_normal(6))
    return n / np.linalg.norm(n)


def tool_paths():
    """(depth, strain increment, expected yield_state): a shallow point (0.05 in,
    p = 0.0024 psi: the cap through it is 0.003 psi wide) and a point at the
    tool's mid depth (3 in)."""
    n, m = unit(7), unit(8)
    return [(0.05, -1e-4 * IDENTITY + 1e-5 * n, S_CAP),          # pushed ahead: compaction
            (0.05, 3e-4 * n, S_CAP),                             # sheared
            (0.05, 2e-6 * IDENTITY + 3e-4 * n, S_CAP_CORNER),    # sheared, dilating
            (0.05, 1e-4 * IDENTITY, S_APEX),                     # lifted: tension
            (0.05, 1e-5 * IDENTITY + 1e-6 * n, S_APEX),
            (3.0, 1e-5 * IDENTITY + 2e-3 * n, S_CAP_CORNER),
            (3.0, 2e-3 * n + 1e-5 * m, S_CAP),
            (3.0, 2e-5 * IDENTITY + 1e-5 * n, S_FAILURE),        # unloaded beside the tool
            (3.0, -1e-3 * IDENTITY + 1e-4 * n, S_CAP),
            (3.0, 1e-6 * IDENTITY, S_ELASTIC)]


def i1_j(sigma):
    s = deviator(sigma)
    return -trace(sigma), np.linalg.norm(s, axis=-1) / SQRT2


def assert_admissible(model, sigma, L):
    """Below the failure surface, on or above the apex, inside the cap."""
    I1, J = i1_j(sigma)
    tol = 1e-12 * (1.0 + np.abs(I1) + J)
    assert (J - model.failure(I1)[0] <= tol).all()
    assert (I1 >= 3.0 * model.lowest[0] - tol).all()
    cap_side = I1 > L
    assert (np.hypot((I1 - L) / model.R, J) - model.failure(L)[0] <= tol)[cap_side].all()


@pytest.mark.parametrize("model", [MODIFIED, SANDLER], ids=lambda m: type(m).__name__)
def test_tool_paths_converge_with_consistent_tangent(model):
    cases = tool_paths()
    deps = np.array([c[1] for c in cases])
    state = model.initial_state(len(cases), geostatic([c[0] for c in cases]))
    assert model.lowest[0] == 0.0 and state["cap_L"].min() > 0.0   # A = C: apex at the origin
    sigma, tangent, new = model.update(deps, state)
    np.testing.assert_array_equal(new["yield_state"], [c[2] for c in cases])
    assert_admissible(model, sigma, new["cap_L"])
    np.testing.assert_array_equal(sigma[new["yield_state"] == S_APEX], 0.0)
    fd = central_differences(model, deps, state, 1e-11)
    error = np.abs(fd - tangent).max(axis=(1, 2)) / np.abs(model.stiffness).max()
    assert error.max() < 1e-6, dict(enumerate(error))


@pytest.mark.parametrize("hardening", CapHardening, ids=lambda h: h.value)
@pytest.mark.parametrize("model", [MODIFIED, SANDLER], ids=lambda m: type(m).__name__)
def test_surface_point_at_zero_stress(model, hardening):
    """At the free surface itself (zero stress, the cap at the apex, every surface
    through the origin): compression yields on the cap, lift leaves the point
    stress free at the apex, shear with dilation at the cap/failure corner, which
    is the origin too (the apex, where the cap retreats)."""
    model = dataclasses.replace(model, hardening=hardening)
    n = unit(9)
    deps = np.array([-1e-4 * IDENTITY + 2e-4 * n, -1e-5 * IDENTITY - 1e-3 * n,
                     1e-4 * IDENTITY + 1e-5 * n, 1e-4 * IDENTITY - 1e-3 * n])
    state = model.initial_state(4)
    assert (state["cap_L"] == 0.0).all()
    sigma, tangent, new = model.update(deps, state)
    corner = S_APEX if hardening is CapHardening.VOLUMETRIC else S_CAP_CORNER
    np.testing.assert_array_equal(new["yield_state"], [S_CAP, S_CAP, S_APEX, corner])
    np.testing.assert_array_equal(sigma[2:], 0.0)
    assert not tangent[2:].any()
    assert_admissible(model, sigma, new["cap_L"])
    fd = central_differences(model, deps, state, 1e-11)
    assert np.abs(fd - tangent).max() / np.abs(model.stiffness).max() < 1e-6


@pytest.mark.parametrize("hardening", CapHardening, ids=lambda h: h.value)
@pytest.mark.parametrize("model", [MODIFIED, SANDLER], ids=lambda m: type(m).__name__)
def test_shallow_point_along_a_tool_path(model, hardening):
    """A point 0.1 in deep pushed ahead of the tool (compression and shear, 30
    steps), passed by it (extension and reversed shear, 30 steps), then lifted
    (5 steps): every step converges through cap, failure surface, cap/failure
    corner and apex, and the stress stays admissible. The cap moves out ahead of
    the tool; behind it, it follows the dilation back to the apex (volumetric
    hardening) or never moves back (cap_compaction)."""
    model = dataclasses.replace(model, hardening=hardening)
    n = unit(10)
    state = model.initial_state(1, geostatic([0.1]))
    ahead = -2e-5 * IDENTITY + 5e-5 * n
    behind = 2e-5 * IDENTITY - 5e-5 * n
    lift = 1e-4 * IDENTITY
    seen, L = set(), [state["cap_L"][0]]
    for deps in [ahead] * 30 + [behind] * 30 + [lift] * 5:
        sigma, _, new = model.update(deps[None], state)
        assert_admissible(model, sigma, new["cap_L"])
        seen.add(float(new["yield_state"][0]))
        L.append(new["cap_L"][0])
        state = new
    assert seen == {S_CAP, S_FAILURE, S_CAP_CORNER, S_APEX}
    assert (np.diff(L[:31]) > 0.0).all()
    if hardening is CapHardening.VOLUMETRIC:
        assert (np.diff(L[31:]) <= 0.0).all() and L[-1] == 0.0
    else:
        assert (np.diff(L[31:]) == 0.0).all()


@pytest.mark.parametrize("shear", [0.0, 1e15])
def test_compression_beyond_the_soil_limit_locks_it_up(shear):
    """A step that compresses the soil far beyond its plastic compaction W (a volumetric
    strain of -1e6), with or without a huge shear: the cap takes all of W and the rest is
    elastic, p = K (1e6 - W), on the cap (hydrostatic) or at its corner with the failure
    surface, which the cap's centre has moved to (the shear): finite, not a NaN."""
    deps = np.array([-1e6 / 3.0 * IDENTITY + shear * unit(7)])
    sigma, tangent, state = SANDLER.update(deps, SANDLER.initial_state(1))
    assert state["yield_state"][0] == (S_CAP_CORNER if shear else S_CAP)
    # to the rounding of the strain of 1e6 it is split from (1e6 x 1e-16)
    assert state["eps_p_vol"][0] == pytest.approx(-SANDLER.W, abs=1e-9)
    # the trial's mean stress carries the rounding of the shear's 1e15 G (300 psi)
    assert -trace(sigma[0]) / 3.0 == pytest.approx(SANDLER.K * (1e6 - SANDLER.W),
                                                   rel=1e-7 if shear else 1e-12)
    assert np.isfinite(tangent).all()
