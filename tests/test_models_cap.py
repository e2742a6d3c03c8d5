"""DiMaggio–Sandler and modified cap models: returns onto the right surfaces,
the hardening law under hydrostatic loading, a cap that stays put on
unloading, triaxial strength, the initial cap and the registry (tangents,
inputs and parameter errors in every return mode: test_models_conformance.py)."""
import dataclasses
import math

import numpy as np
import pytest

from soilbin.models import MODELS, DiMaggioSandler, ModifiedCap
from soilbin.models.cap import SECTION_VII5, CapHardening, cap_return
from soilbin.models.invariant_return import local_settings, smooth_return, strain_row
from soilbin.models.yield_surfaces import CAP_C, CAP_R, G_, K_, cap_compaction, cap_failure
from soilbin.params import from_table
from soilbin.tensors import IDENTITY, SQRT2, deviator, trace

# yield_state codes.
S_ELASTIC, S_FAILURE, S_CORNER, S_CUTOFF, S_CAP, S_CAP_CORNER = 0.0, 1.0, 2.0, 3.0, 4.0, 5.0

VII5 = dict(SECTION_VII5)                                   # psi
DS = {k: v for k, v in VII5.items() if k != "B"}
MODIFIED = ModifiedCap(**VII5, X0=20.0)
SANDLER = DiMaggioSandler(**DS, X0=20.0)
# With cohesion (A > C: the apex in tension) and a tension cut-off below it.
MODIFIED_T = ModifiedCap(**{**VII5, "A": 8.0}, X0=20.0, tension_cutoff=0.5)
SANDLER_T = DiMaggioSandler(**{**DS, "A": 8.0}, X0=20.0, tension_cutoff=1.0)
ALL = [MODIFIED, SANDLER, MODIFIED_T, SANDLER_T]
# The cap that retreats with the dilation (hardening by the total plastic volume).
RETREATING = [dataclasses.replace(m, hardening=CapHardening.VOLUMETRIC) for m in ALL]
# Less dilatancy on the failure surface (non-associated flow), either hardening.
DILATING_LESS = [dataclasses.replace(m, dilatancy=eta) for m, eta in
                 ((MODIFIED, 0.5), (RETREATING[2], 0.5), (RETREATING[1], 0.5), (SANDLER_T, 0.5),
                  (RETREATING[0], 0.0), (SANDLER_T, 0.0))]


def model_id(model):
    name = type(model).__name__
    name += f"-T{model.tension_cutoff:g}" if math.isfinite(model.tension_cutoff) else ""
    name += f"-dilatancy{model.dilatancy:g}" if model.dilatancy < 1.0 else ""
    return name + ("-volumetric" if model.hardening is CapHardening.VOLUMETRIC else "")


def i1_j(sigma):
    """Compression-positive I1 and sqrt(J2)."""
    s = deviator(sigma)
    return -trace(sigma), np.sqrt(0.5 * np.sum(s * s, axis=-1))


def unit_deviator(seed):
    n = deviator(np.random.default_rng(seed).standard_normal(6))
    return n / np.linalg.norm(n)


@pytest.mark.parametrize("model", ALL + RETREATING + DILATING_LESS, ids=model_id)
def test_returned_stresses_lie_on_the_right_surfaces(model):
    rng = np.random.default_rng(2)
    m = 3000
    deps = 1e-2 * rng.uniform(0, 1, (m, 1)) ** 2 * (rng.standard_normal((m, 6))
                                                      + rng.standard_normal((m, 1)) * IDENTITY)
    state = model.initial_state(m, np.tile(-3.0 * IDENTITY, (m, 1)))
    sigma, _, new = model.update(deps, state)
    ys = new["yield_state"]
    counts = {v: np.count_nonzero(ys == v) for v in np.unique(ys)}
    expected = {S_ELASTIC, S_FAILURE, S_CORNER, S_CAP}
    if model.dilatancy > 0.0:       # isochoric: only the vertical above the corner
        expected.add(S_CAP_CORNER)
    if math.isfinite(model.tension_cutoff):
        expected.add(S_CUTOFF)
    assert set(counts) == expected and min(counts.values()) > 10, counts
    I1, J = i1_j(sigma)
    F = model.failure(I1)[0]
    L, R = new["cap_L"], model.R
    F_L = model.failure(L)[0]
    p_lo, J_lo, _ = model.lowest
    tol = 1e-10 * 20.0
    # Admissible everywhere: below the failure surface, inside the cap, above the cut-off.
    assert (J - F).max() <= tol and (3 * p_lo - I1).max() <= tol
    cap_side = I1 > L
    assert (np.hypot((I1 - L) / R, J) - F_L)[cap_side].max() <= tol
    # On the surfaces the labels name.
    assert np.abs((J - F)[ys == S_FAILURE]).max() <= tol
    assert np.abs((np.hypot((I1 - L) / R, J) - F_L)[ys == S_CAP]).max() <= tol
    assert (I1[ys == S_CAP] >= L[ys == S_CAP]).all()
    on_corner = ys == S_CAP_CORNER
    np.testing.assert_allclose(I1[on_corner], L[on_corner], rtol=1e-13)
    np.testing.assert_allclose(J[on_corner], F_L[on_corner], rtol=1e-12)
    np.testing.assert_allclose(I1[ys == S_CORNER], 3 * p_lo, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(J[ys == S_CORNER], J_lo, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(I1[ys == S_CUTOFF], 3 * p_lo, rtol=1e-12)
    # Flow along the potential (the normal on the cap): on the failure surface
    # (I1 - I1_tr) / (9 K eta_d F') = (J_tr - J) / G >= 0, I1 = I1_tr if eta_d = 0;
    # on the cap (I1_tr - I1) / (9 K df/dI1) = (J_tr - J) / (G df/dJ).
    trial = model.trial(deps, state["stress"])
    I1_tr, J_tr = i1_j(trial)
    dF = model.failure(I1)[1]
    fail = ys == S_FAILURE
    b = (J_tr - J)[fail] / model.G
    if model.dilatancy > 0.0:
        a = (I1 - I1_tr)[fail] / (9 * model.K * model.dilatancy * dF[fail])
        np.testing.assert_allclose(a, b, rtol=1e-8)
    else:
        np.testing.assert_allclose(I1[fail], I1_tr[fail], rtol=0.0, atol=tol)
    assert (b > 0).all()
    cap = ys == S_CAP
    rho = np.hypot((I1 - L) / R, J)[cap]
    a = (I1_tr - I1)[cap] / (9 * model.K * ((I1 - L)[cap] / R**2 / rho))
    b = (J_tr - J)[cap] / (model.G * J[cap] / rho)
    np.testing.assert_allclose(a, b, rtol=1e-7)
    # The cap moves out only where the cap is active; it never moves back, or with the
    # volumetric hardening only where the soil dilates (failure surface, apex, cut-off,
    # corner), following its plastic volume (B.11) down to L_min: there the plastic
    # compaction is H(L) - H(L_n).
    L_n = state["cap_L"]
    assert ((new["cap_L"] > L_n) == cap).all()
    if model.hardening is CapHardening.CAP_COMPACTION:
        assert (new["cap_L"] >= L_n).all()
        return
    back = new["cap_L"] < L_n
    assert set(np.unique(ys[back])) <= {S_FAILURE, S_CORNER, S_CUTOFF, S_CAP_CORNER}
    assert back.sum() > 10 and new["cap_L"].min() >= model.L_min >= 0.0
    free = back & (new["cap_L"] > model.L_min)
    compaction = -(new["eps_p_vol"] - state["eps_p_vol"])
    np.testing.assert_allclose(model.compaction(new["cap_L"])[0][free],
                               model.compaction(L_n)[0][free] + compaction[free],
                               rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("model", ALL + RETREATING + DILATING_LESS, ids=model_id)
def test_large_increments_converge_in_one_vectorised_call(model):
    rng = np.random.default_rng(3)
    m = 2000
    deps = 0.1 * rng.uniform(0, 1, (m, 1)) ** 2 * (rng.standard_normal((m, 6))
                                                     + 0.7 * rng.standard_normal((m, 1)) * IDENTITY)
    sigma, tangent, new = model.update(deps, model.initial_state(m, np.tile(-3 * IDENTITY, (m, 1))))
    assert np.isfinite(sigma).all() and np.isfinite(tangent).all()
    I1, J = i1_j(sigma)
    assert (J - model.failure(I1)[0]).max() <= 1e-9 * np.abs(I1).max()
    assert (new["cap_L"] >= model.L_min).all()


def hydrostatic(model, state, d_eps_v):
    """Hydrostatic strain steps (compression positive d_eps_v); rows of (I1, state)."""
    rows = []
    for d in d_eps_v:
        sigma, _, state = model.update(np.atleast_2d(-d / 3.0 * IDENTITY), state)
        rows.append((i1_j(sigma)[0][0], i1_j(sigma)[1][0], state))
    return rows


@pytest.mark.parametrize("cls, params", [(ModifiedCap, VII5), (DiMaggioSandler, DS)])
@pytest.mark.parametrize("X0", [0.0, 20.0])
def test_hydrostatic_loading_follows_the_hardening_law(cls, params, X0):
    model = cls(**params, X0=X0)
    W, D, K = model.W, model.D, model.K
    state = model.initial_state(1)
    assert state["cap_X"][0] == pytest.approx(X0, abs=1e-12)
    rows = hydrostatic(model, state, np.full(40, 2.5e-3))
    I1 = np.array([r[0] for r in rows])
    X = np.array([r[2]["cap_X"][0] for r in rows])
    eps_p = -np.array([r[2]["eps_p_vol"][0] for r in rows])
    ys = np.array([r[2]["yield_state"][0] for r in rows])
    assert max(r[1] for r in rows) < 1e-12 * I1[-1]
    yielding = ys == S_CAP
    assert yielding.sum() > 30 and (ys[~yielding] == S_ELASTIC).all()
    # On the cap the hydrostatic stress is the cap position, and the plastic
    # compaction is W (1 - exp(-D X)) - W (1 - exp(-D X0)).
    np.testing.assert_allclose(X[yielding], I1[yielding], rtol=1e-12)
    np.testing.assert_allclose(eps_p, W * (np.exp(-D * X0) - np.exp(-D * X)), rtol=1e-11,
                               atol=1e-15)
    # Total strain = elastic I1 / 3K + plastic.
    np.testing.assert_allclose(np.cumsum(np.full(40, 2.5e-3)), I1 / (3 * K) + eps_p, rtol=1e-11)
    if X0 == 0.0:
        np.testing.assert_allclose(eps_p, W * (1 - np.exp(-D * I1)), rtol=1e-11)
    else:   # elastic up to I1 = X0
        assert (I1[~yielding] <= X0 * (1 + 1e-12)).all()


def test_cap_stays_put_on_unloading_and_reloading_picks_up_the_law():
    model = MODIFIED
    W, D, K = model.W, model.D, model.K
    rows = hydrostatic(model, model.initial_state(1), np.full(20, 4e-3))
    X_max, I1_max = rows[-1][2]["cap_X"][0], rows[-1][0]
    eps_p_max = -rows[-1][2]["eps_p_vol"][0]
    assert X_max == pytest.approx(I1_max, rel=1e-12) and X_max > 60.0
    # Unloading: elastic, the cap and the plastic strain stay.
    down = hydrostatic(model, rows[-1][2], np.full(10, -1e-3))
    for k, (I1, _, state) in enumerate(down, start=1):
        assert state["yield_state"][0] == S_ELASTIC
        assert state["cap_X"][0] == X_max and -state["eps_p_vol"][0] == eps_p_max
        assert I1 == pytest.approx(I1_max - 3 * K * 1e-3 * k, rel=1e-12)
    # Shear from the unloaded state inside the cap: still elastic, the cap does not move.
    sigma, _, state = model.update(np.atleast_2d(1e-4 * unit_deviator(4)), down[-1][2])
    assert state["yield_state"][0] == S_ELASTIC and state["cap_X"][0] == X_max
    # Reloading: elastic until the cap, then the same hardening law.
    up = hydrostatic(model, down[-1][2], np.full(20, 1e-3))
    I1 = np.array([r[0] for r in up])
    ys = np.array([r[2]["yield_state"][0] for r in up])
    X = np.array([r[2]["cap_X"][0] for r in up])
    eps_p = -np.array([r[2]["eps_p_vol"][0] for r in up])
    assert (ys[I1 <= X_max] == S_ELASTIC).all() and (ys[I1 > X_max * (1 + 1e-12)] == S_CAP).all()
    assert (ys == S_CAP).sum() > 5
    np.testing.assert_allclose(eps_p, W * (np.exp(-D * 20.0) - np.exp(-D * X)), rtol=1e-11)
    assert (np.diff(X) >= 0).all()


def test_dilatancy_on_the_failure_surface_softens_the_cap():
    # Shear at constant volume: the stress climbs the failure surface (dilating),
    # and the cap follows the plastic volume back (B.11) until it meets the stress
    # at the corner (L, F(L)), where the flow is deviatoric: the stress stays there
    # (labelled cap or corner: the same point to rounding).
    model = RETREATING[0]
    state = model.initial_state(1, -3.0 * IDENTITY)
    n = unit_deviator(5)
    codes, L = [], [state["cap_L"][0]]
    for _ in range(10):
        sigma, _, state = model.update(np.atleast_2d(2e-3 * n), state)
        codes.append(state["yield_state"][0])
        L.append(state["cap_L"][0])
    assert codes[:2] == [S_FAILURE, S_CAP_CORNER] and set(codes[2:]) <= {S_CAP, S_CAP_CORNER}
    assert L[0] > L[1] > L[2] > 0.0
    np.testing.assert_allclose(L[2:], L[2], rtol=1e-14)
    I1, J = i1_j(sigma)
    assert I1[0] == pytest.approx(L[-1], rel=1e-14)
    assert J[0] == pytest.approx(model.failure(np.array(L[-1]))[0], rel=1e-12)
    # The plastic volume is that of the cap (B.11), dilation tension positive.
    H = model.compaction(np.array(L))[0]
    assert state["eps_p_vol"][0] == pytest.approx(H[0] - H[-1], rel=1e-9)
    assert state["eps_p_vol"][0] > 1e-4


def test_dilatancy_does_not_soften_the_cap_with_cap_compaction_hardening():
    # The same shear with hardening = "cap_compaction" (the default): the stress climbs
    # the failure surface to the corner with the cap, which does not move (its normal
    # is deviatoric there): a perfectly plastic vertex.
    model = MODIFIED
    state = model.initial_state(1, -3.0 * IDENTITY)
    L0 = state["cap_L"][0]
    n = unit_deviator(5)
    codes = []
    for _ in range(10):
        _, tangent, state = model.update(np.atleast_2d(2e-3 * n), state)
        codes.append(state["yield_state"][0])
        assert state["cap_L"][0] == L0
    assert codes[0] == S_FAILURE and codes[-1] == S_CAP_CORNER
    assert state["eps_p_vol"][0] > 1e-4                 # dilation (tension positive)
    assert np.abs(tangent[0] @ IDENTITY).max() < 1e-12  # no volumetric stiffness


@pytest.mark.parametrize("model", [MODIFIED, SANDLER], ids=model_id)
def test_triaxial_compression_strength(model):
    # Conventional triaxial compression from p0 = 1 psi, inside the cap X0 = 20: the
    # stress path I1 = 3 p0 + q, sqrt(J2) = q / sqrt3 meets the failure surface,
    # q / sqrt3 = F(3 p0 + q), below the cap (I1 < L), and stays there.
    p0 = 1.0
    state = model.initial_state(1, -p0 * IDENTITY)
    lateral = np.full(2, 0.35 * 1e-4)
    for d in np.full(40, -1e-4):
        deps = np.zeros((1, 6))
        deps[0, 2] = d
        deps[0, :2] = lateral           # the last step's lateral strains
        for _ in range(30):
            sigma, tangent, new = model.update(deps, state)
            r = sigma[0, :2] + p0
            if np.abs(r).max() <= 1e-12 * p0:
                break
            deps[0, :2] -= np.linalg.solve(tangent[0][:2, :2], r)
        else:
            pytest.fail("lateral stress iteration did not converge")
        state, lateral = new, deps[0, :2]
    I1, J = i1_j(sigma)
    q = math.sqrt(3.0) * J[0]
    assert I1[0] == pytest.approx(3 * p0 + q, rel=1e-10)
    F = lambda q: model.failure(np.array(3 * p0 + q))[0] - q / math.sqrt(3.0)  # noqa: E731
    lo, hi = 0.0, 100.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if F(mid) > 0 else (lo, mid)
    assert q == pytest.approx(lo, rel=1e-10)
    assert state["yield_state"][0] == S_FAILURE and I1[0] < state["cap_L"][0]


def test_section_vii5_failure_surface():
    # The modified cap: through the origin (c = 0), initial slope B + C beta, and the
    # Drucker–Prager line sqrt(J2) = A + B I1 at high pressure.
    F, dF, _ = MODIFIED.failure(np.array([0.0, 1e3]))
    assert F[0] == 0.0 and dF[0] == pytest.approx(0.11 + 5.6 * 0.062, rel=1e-14)
    assert F[1] == pytest.approx(5.6 + 0.11 * 1e3, rel=1e-14) and dF[1] == pytest.approx(0.11)
    assert MODIFIED.apex == 0.0 and SANDLER.apex == 0.0
    assert SANDLER.failure(np.array(1e3))[0] == pytest.approx(5.6)   # the von Mises plateau
    # B = 0 is DiMaggio–Sandler.
    rng = np.random.default_rng(6)
    deps = 5e-3 * rng.standard_normal((50, 6))
    zero_b = ModifiedCap(**{**VII5, "B": 0.0}, X0=20.0)
    a = zero_b.update(deps, zero_b.initial_state(50, -3 * IDENTITY))
    b = SANDLER.update(deps, SANDLER.initial_state(50, -3 * IDENTITY))
    np.testing.assert_allclose(a[0], b[0], rtol=1e-12, atol=1e-12)


def test_initial_cap_passes_through_the_initial_stress():
    n = unit_deviator(7)
    stress = np.array([-3.0 * IDENTITY, -10.0 * IDENTITY, -10.0 * IDENTITY + SQRT2 * 2.0 * n,
                       np.zeros(6)])
    state = MODIFIED.initial_state(4, stress)
    I1, J = i1_j(stress)
    L, X = state["cap_L"], state["cap_X"]
    assert X[0] == pytest.approx(20.0) and X[3] == pytest.approx(20.0)
    assert X[1] == pytest.approx(30.0, rel=1e-12)
    F_L = MODIFIED.failure(L)[0]
    assert np.hypot((I1[2] - L[2]) / MODIFIED.R, J[2]) == pytest.approx(F_L[2], rel=1e-12)
    np.testing.assert_allclose(X, L + MODIFIED.R * F_L, rtol=1e-14)
    # The initial stress is then elastic.
    _, _, new = MODIFIED.update(np.zeros((4, 6)), state)
    np.testing.assert_array_equal(new["yield_state"], S_ELASTIC)


@pytest.mark.parametrize("name", ["modified_cap", "dimaggio_sandler"])
def test_conformance_samples_start_on_the_initial_cap(name):
    for sample in MODELS[name].conformance_samples():
        state = from_table(MODELS[name], sample.table, "m").initial_state(1, sample.stress)
        assert state["cap_X"][0] == pytest.approx(sample.table["X0"], rel=1e-14)


def test_registry_builds_the_caps():
    assert from_table(MODELS["modified_cap"], {**VII5, "X0": 20}, "m") == MODIFIED
    assert from_table(MODELS["dimaggio_sandler"], {**DS, "X0": 20.0}, "m") == SANDLER
    model = from_table(MODELS["modified_cap"], VII5, "m")
    assert model.X0 == 0.0 and model.tension_cutoff == math.inf
    assert dataclasses.replace(model, X0=20.0) == MODIFIED


@pytest.mark.parametrize("model", ALL + RETREATING + DILATING_LESS, ids=model_id)
def test_a_warm_start_from_any_guess_gives_the_cold_return(model):
    """The cap return may start from a guess state (the last Newton iterate's): from a
    nearby increment's, from a far one's and from one of another step, the stress and
    tangent (but at a point that crossed between vertices: next test) are those of the
    return from the trial state, to its tolerance (normally consolidated K0 states, as in
    the tool scenes)."""
    model = dataclasses.replace(model, X0=0.0)
    rng = np.random.default_rng(7)
    n = 400
    depth = rng.uniform(0.05, 12.0, n)
    stress = -0.072 * depth[:, None] * np.array([0.455, 0.455, 1.0, 0.0, 0.0, 0.0])
    state = model.initial_state(n, stress)
    deps = 3e-4 * rng.normal(size=(n, 6))
    sigma, tangent, new = model.update(deps, state)
    assert np.count_nonzero(new["yield_state"] == S_CAP) > n // 4
    for other in (deps * (1.0 + 1e-3 * rng.normal(size=deps.shape)), -deps,
                  30.0 * rng.normal(size=(n, 6)) * 3e-4):
        guess = model.update(other, state)[2]
        s_warm, t_warm, n_warm = model.update(deps, state, guess=guess)
        np.testing.assert_allclose(s_warm, sigma, rtol=0.0, atol=1e-10 * np.abs(sigma).max())
        np.testing.assert_array_equal(n_warm["yield_state"], new["yield_state"])
        # the tangent too, but where a point crossed between apex and cap corner
        codes = (guess["yield_state"], new["yield_state"])
        crossed = np.isin(codes, [(S_CORNER,), (S_CAP_CORNER,)]).all(axis=0) & (codes[0] != codes[1])
        np.testing.assert_allclose(t_warm[~crossed], tangent[~crossed], rtol=0.0,
                                   atol=1e-9 * np.abs(tangent).max())


@pytest.mark.parametrize("model", [ModifiedCap(**VII5), DiMaggioSandler(**DS),
                                   ModifiedCap(**VII5, dilatancy=0.5)], ids=model_id)
def test_a_point_that_crossed_between_the_vertices_gets_the_failure_surface_tangent(model):
    """Near the surface (small L, a short stretch of failure surface between apex and cap
    corner) the apex's own tangent has no bulk stiffness; a point that comes from the cap
    corner gets the failure surface's tangent there: the limit of the failure return's
    consistent tangent at the edge of the apex's normal cone."""
    stress = -0.072 * 0.2 * np.array([[0.455, 0.455, 1.0, 0.0, 0.0, 0.0]])
    state = model.initial_state(1, stress)
    n = np.array([1.0, -1.0, 0.0, 0.0, 0.0, 0.0]) / SQRT2
    code = lambda a: model.update((a * IDENTITY + 1e-6 * n)[None], state)[2]["yield_state"][0]
    lo, hi = 1e-6, 3e-6       # volumetric extension: failure surface at lo, apex at hi
    assert code(lo) == S_FAILURE and code(hi) == S_CORNER
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if code(mid) == S_FAILURE else (lo, mid)
    eps = 1e-9 * hi
    failure_side = model.update((lo * IDENTITY + 1e-6 * n)[None], state)[1][0]
    guess = {**state, "yield_state": np.array([S_CAP_CORNER])}
    apex = (hi + eps) * IDENTITY + 1e-6 * n
    crossed = model.update(apex[None], state, guess=guess)[1][0]
    own = model.update(apex[None], state)[1][0]
    assert IDENTITY @ own @ IDENTITY == pytest.approx(0.0, abs=1e-9 * np.abs(own).max())
    assert IDENTITY @ crossed @ IDENTITY > 0.01 * model.K
    np.testing.assert_allclose(crossed, failure_side, rtol=0.0, atol=1e-5 * np.abs(failure_side).max())


@pytest.mark.parametrize("model", ALL, ids=model_id)
def test_the_cap_return_in_two_unknowns_is_the_general_local_problems(model):
    """The return onto a free cap in (mu, kappa) (cap_return, 2 x 2) and the general local
    Newton in (p, J, dgamma, kappa) (smooth_return, 4 x 4), from the same trial states
    beyond the cap: the same p, J, kappa (to 1e-11) and sensitivities (p_e, p_J, J_e, J_J;
    to 1e-12 of K or 1)."""
    prm, rng, settings = model.prm, np.random.default_rng(11), local_settings()
    K, G, R = prm[K_], prm[G_], prm[CAP_R]
    s_n, n = np.zeros(6), unit_deviator(3)
    for _ in range(300):
        kappa_n = rng.uniform(model.L_min + 0.1, 80.0)
        F = cap_failure(prm, kappa_n)[0]
        I1_tr = kappa_n + R * F * rng.uniform(0.0, 3.0)
        J_tr = F * rng.uniform(0.0, 1.5)
        if math.hypot((I1_tr - kappa_n) / R, J_tr) <= 1.01 * F:
            continue
        p_n = kappa_n / 3.0 - rng.uniform(0.0, 1.0)
        p_tr = I1_tr / 3.0
        de_v = (p_tr - p_n) / K
        scale = 3.0 * abs(p_tr) + J_tr + abs(kappa_n + R * F) + prm[CAP_C]
        H_n, row = cap_compaction(prm, kappa_n)[0], strain_row(prm, p_tr, scale)
        p, J, kappa, sens, ok = cap_return(prm, p_tr, J_tr, H_n, 0.0, kappa_n, scale, row,
                                           settings)
        lp = (p_n, de_v, J_tr, kappa_n, scale, 0.0, H_n, row)
        cold = (p_tr, J_tr, 0.0, kappa_n)
        general = smooth_return(prm, lp, s_n, SQRT2 * J_tr * n, cold, cold, settings)
        assert ok and general[-1]
        np.testing.assert_allclose((p, J, kappa), (general[0], general[1], general[3]),
                                   rtol=1e-11, atol=1e-11 * scale)
        # p_e and J_e are moduli, p_J and J_J ratios
        assert (np.abs(np.subtract(sens, general[4])) <= 1e-12 * np.array((K, 1.0, K, 1.0))).all()
