"""The caps' hardening after Sandler & Rubin (1979), "An algorithm and a modular
subroutine for the cap model", Int. J. Numer. Anal. Methods Geomech. 3, 173-186:
the cap follows the plastic volumetric strain of every surface (it retreats
when the soil dilates) and its centre stays on the compression side,
L = max(kappa, 0). Their uniaxial strain test of McCormick Ranch sand (issue
12: at 0.5 % axial strain the published lateral stress is +0.003 ksi, and the
cap that never retreats, from L = -0.133 ksi, gives -0.016 ksi and an axial
stress 21 % higher), and the bulk stiffness where the cap retreats, in each
return mode it adds (the tangents: test_models_conformance.py)."""
import dataclasses

import numpy as np
import pytest

from soilbin.models import DiMaggioSandler
from soilbin.models.cap import MCCORMICK_RANCH, CapHardening
from soilbin.params import from_table
from soilbin.tensors import IDENTITY, deviator

S_FAILURE, S_CAP, S_CAP_CORNER = 1.0, 4.0, 5.0

#: McCormick Ranch sand (ksi, 1/ksi; Sandler & Rubin 1979): K = 66.67, G = 40
#: (E = 100, nu = 0.25), W = 0.066, D = 0.67, R = 2.5, A = 0.25, C = 0.18,
#: beta = 0.67, X0 = 0 (kappa0 = -0.133: the cap centre L = 0, the cap's end X = 0).
SAND = DiMaggioSandler(**MCCORMICK_RANCH, hardening=CapHardening.VOLUMETRIC)
NEVER_RETREATS = dataclasses.replace(SAND, hardening=CapHardening.CAP_COMPACTION)


def uniaxial_strain(model, steps, d_eps):
    """Axial (z) strain steps from the stress-free state; (axial, lateral) stresses
    (compression positive) and the state after each step."""
    state = model.initial_state(1)
    rows = []
    for _ in range(steps):
        deps = np.zeros((1, 6))
        deps[0, 2] = -d_eps
        sigma, _, state = model.update(deps, state)
        rows.append((-sigma[0, 2], -sigma[0, 0], state))
    return rows


def test_uniaxial_strain_of_mccormick_ranch_sand():
    rows = uniaxial_strain(SAND, 50, 1e-4)                 # to 0.5 % axial strain
    axial, lateral, state = rows[-1]
    assert lateral == pytest.approx(0.003, abs=3e-4)       # Sandler & Rubin: +0.003 ksi
    # The centre stays at L = 0 while the cap's end grows from X = 0 (kappa < 0), and
    # the cap through the stress (I1 = 0.068, sqrt(J2) = 0.034) ends at X = 0.109.
    assert all(r[2]["cap_L"][0] == 0.0 for r in rows)
    assert state["cap_X"][0] == pytest.approx(0.1093, abs=1e-4)
    assert all(r[2]["yield_state"][0] == S_CAP for r in rows)
    # The cap that never retreats starts from the apex side (L = -0.133 ksi): tensile
    # lateral stress and 21 % more axial stress.
    old_axial, old_lateral, old = uniaxial_strain(NEVER_RETREATS, 50, 1e-4)[-1]
    assert NEVER_RETREATS.initial_state(1)["cap_L"][0] == pytest.approx(-0.133, abs=1e-3)
    assert old_lateral == pytest.approx(-0.016, abs=1e-3)
    assert old_axial / axial == pytest.approx(1.21, abs=0.01)
    # Unloading from the cap is elastic: the cap stays.
    deps = np.zeros((1, 6))
    deps[0, 2] = 1e-5
    _, _, after = SAND.update(deps, state)
    assert after["yield_state"][0] == 0.0 and after["cap_X"][0] == state["cap_X"][0]


def unit(seed):
    n = deviator(np.random.default_rng(seed).standard_normal(6))
    return n / np.linalg.norm(n)


def test_cap_retreats_to_the_compression_side_and_below():
    """Dilation on the failure surface pulls the cap back (B.11) to its corner and
    on to L = 0; further dilation moves only its end X (kappa < 0), down to the
    point cap X = L = 0."""
    model = dataclasses.replace(SAND, X0=1.0)
    state = model.initial_state(1, -0.1 * IDENTITY)
    n = unit(3)
    L, X, codes = [state["cap_L"][0]], [state["cap_X"][0]], []
    for deps in [2e-4 * IDENTITY + 2e-3 * n] * 30 + [1e-3 * IDENTITY + 5e-3 * n] * 4:
        _, _, state = model.update(deps[None], state)
        L.append(state["cap_L"][0])
        X.append(state["cap_X"][0])
        codes.append(state["yield_state"][0])
    assert (np.diff(X) < 0.0).all() and (np.diff(L) <= 0.0).all()
    assert L[-1] == 0.0 and X[-1] < model.X(np.array(0.0))   # kappa < 0
    assert S_FAILURE in codes and S_CAP_CORNER in codes
    H = model.compaction(model.kappa(np.array(X)))[0]
    assert -state["eps_p_vol"][0] == pytest.approx(H[-1] - H[0], rel=1e-9)
    for deps in [1e-3 * IDENTITY + 5e-3 * n] * 2:
        _, _, state = model.update(deps[None], state)
    assert state["cap_L"][0] == 0.0 and state["cap_X"][0] == pytest.approx(0.0, abs=1e-12)


#: The retreating cap's conformance samples (tangents against central differences:
#: test_models_conformance.py) and whether dp/de_v > 0 there.
STIFF = {"failure, the cap retreating": True, "moving cap corner": True,
         "cap corner held at L = 0": False, "shrunken cap, kappa < 0": True,
         "apex, lifted": False}


def test_bulk_stiffness_where_the_cap_retreats():
    # The moving corner and the cap keep a bulk stiffness (the fixed corner had none).
    samples = [s for s in DiMaggioSandler.conformance_samples() if s.mode in STIFF]
    assert {s.mode for s in samples} == set(STIFF)
    for sample in samples:
        model = from_table(DiMaggioSandler, sample.table, "m")
        _, tangent, _ = model.update(sample.deps[None], sample.state(model))
        assert (IDENTITY @ tangent[0] @ IDENTITY > 1e-9 * model.K) == STIFF[sample.mode]
