"""The plastic work each point accumulates (the remesh reports its change by the transfer):
per increment sigma : deps_p with deps_p = deps - deps_e, the elastic strain of the stress
change. Checked against each model's own plastic strain on its conformance samples, and
summed over a load path against the closed form of a block in uniaxial compression."""
import math

import numpy as np
import pytest

from conftest import make_problem

from soilbin.models import MODELS
from soilbin.models.base import ELASTIC, FAILURE
from soilbin.params import from_table
from soilbin.solver.quadrature import PLASTIC_WORK

#: The samples of the models whose history splits the plastic strain into its volume
#: (``eps_p_vol``) and its size (``eps_p_eq`` = sqrt(2/3) |deps_p|), and von Mises's on its
#: cylinder (isochoric flow: no volume; not on its tension cut-off).
SPLIT = [(name, sample) for name, cls in MODELS.items()
         for sample in cls.conformance_samples()
         if "eps_p_vol" in cls.history
         or (name == "von_mises" and sample.yield_state in (ELASTIC, FAILURE))]


@pytest.mark.parametrize("name, sample", SPLIT,
                         ids=[f"{name}-{i:02d}-{sample.mode.replace(' ', '_')}"
                              for i, (name, sample) in enumerate(SPLIT)])
def test_the_plastic_work_is_the_returns_own_plastic_strain_times_the_stress(name, sample):
    """An invariant model's plastic deviator is parallel to the returned stress's deviator
    s (the return keeps the trial's Lode direction), so sigma : deps_p = |s| |de_p| + p c
    with p the mean pressure and c the plastic compaction (both compression positive):
    from the model's own eps_p_vol and eps_p_eq, independently of the elastic strain (the
    kappa-line's included) from which the plastic work is computed."""
    model = from_table(MODELS[name], sample.table, "materials.soil")
    state = sample.state(model)
    sigma, _, new = model.update(sample.deps[None], state)
    compaction = -(new["eps_p_vol"] - state["eps_p_vol"])[0] if "eps_p_vol" in new else 0.0
    size = (new["eps_p_eq"] - state["eps_p_eq"])[0]   # sqrt(2/3) |deps_p|
    shear = math.sqrt(max(1.5 * size**2 - compaction**2 / 3.0, 0.0))   # |de_p|
    p = -sigma[0, :3].sum() / 3.0
    s = np.linalg.norm(sigma[0] + p * np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0]))
    expected = s * shear + p * compaction
    work = model.plastic_work(sample.deps[None], state["stress"], sigma)[0]
    scale = np.linalg.norm(sigma) * np.linalg.norm(sample.deps)
    assert abs(work - expected) <= 1e-8 * scale
    if sample.yield_state == ELASTIC:
        assert abs(work) <= 1e-12 * scale
    else:   # dissipates (nothing at Cam-Clay's origin, sigma = 0)
        assert work > 0.0 or not np.any(sigma)


def test_a_block_in_uniaxial_compression_does_the_plastic_work_of_its_collapse_stress():
    """The Drucker–Prager block of chapter VII (c 500 psf, phi 30, E 5e5 psf, nu 0) pressed
    by 0.01 ft in 20 steps: once it flows at sigma_c = 2 c cos(phi) / (1 - sin(phi)) every
    point has done sigma_c (eps - sigma_c / E) of plastic work per unit volume (the lateral
    stresses are zero), to the round-off: the elastic-plastic step included, whose plastic
    part is at sigma_c."""
    problem = make_problem("block-drucker-prager")
    for k in range(1, 21):
        problem.set_load_factor(k / 20)
        problem.solve()
        problem.commit()
    phi = math.radians(30.0)
    collapse = 2.0 * 500.0 * math.cos(phi) / (1.0 - math.sin(phi))
    work = problem.points.history(PLASTIC_WORK)
    assert np.allclose(work, collapse * (0.01 - collapse / 5.0e5), rtol=1e-9, atol=0.0)
