"""What every registered constitutive model must do, checked on the samples it
declares (``conformance_samples``: at least one per return mode): the
yield_state of each sample, the consistent tangent against central
differences, an update that leaves its inputs alone and returns the declared
history, and parameter tables that name the offending key. A new model gets
these checks by registering in MODELS and declaring its samples."""
import dataclasses
import enum
import math
import typing

import numpy as np
import pytest

from conftest import central_differences

from soilbin.errors import InputError, ReturnMapError
from soilbin.models import MODELS
from soilbin.params import from_table

SAMPLES = [(name, sample) for name, cls in MODELS.items()
           for sample in cls.conformance_samples()]
IDS = [f"{name}-{i:02d}-{sample.mode.replace(' ', '_')}"
       for i, (name, sample) in enumerate(SAMPLES)]


@pytest.fixture(params=SAMPLES, ids=IDS)
def sample(request):
    """(model, deps (1, 6), committed state, the declared Sample)."""
    name, declared = request.param
    model = from_table(MODELS[name], declared.table, "materials.soil")
    return model, declared.deps[None], declared.state(model), declared


def test_yield_state_and_consistent_tangent(sample):
    model, deps, state, declared = sample
    _, tangent, new = model.update(deps, state)
    if "yield_state" in model.history:
        assert new["yield_state"][0] == declared.yield_state
    fd = central_differences(model, deps, state, declared.fd_step)
    scale = max(np.abs(model.stiffness).max(), np.abs(fd).max())
    assert np.abs(fd - tangent).max() / scale < 1e-6


def test_update_leaves_its_inputs_alone_and_returns_the_history(sample):
    model, deps, state, _ = sample
    before = {k: v.copy() for k, v in state.items()}
    deps_before = deps.copy()
    sigma, tangent, new = model.update(deps, state)
    np.testing.assert_array_equal(deps, deps_before)
    assert state.keys() == before.keys() == new.keys() == model.history.keys()
    for name, shape in model.history.items():
        np.testing.assert_array_equal(state[name], before[name])
        assert new[name].shape == (1,) + shape
        assert not np.shares_memory(new[name], state[name])
    assert sigma.shape == (1, 6) and tangent.shape == (1, 6, 6)
    np.testing.assert_array_equal(new["stress"], sigma)


def test_every_model_declares_samples():
    assert {name for name, _ in SAMPLES} == set(MODELS)


def bad_values(cls):
    """(key, value) pairs a parameter table must refuse, from the declared fields:
    the bounds of each range (just outside a closed one), NaN and, for an open
    infinite bound, inf; a word that is not one of an enumeration's."""
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        rng = f.metadata.get("range")
        if rng is not None:
            yield f.name, math.nan
            for bound, is_open, outward in ((rng.lo, rng.lo_open, -1.0),
                                            (rng.hi, rng.hi_open, 1.0)):
                if math.isfinite(bound):
                    # a step outside a closed bound that survives rounding (1e20 + 1 == 1e20)
                    yield f.name, bound if is_open else bound + outward * max(1.0, 1e-9 * abs(bound))
                elif is_open:
                    yield f.name, bound
        elif isinstance(hints[f.name], type) and issubclass(hints[f.name], enum.Enum):
            yield f.name, "not_a_choice"


BAD = [(name, key, value) for name, cls in MODELS.items() for key, value in bad_values(cls)]


@pytest.mark.parametrize("name, key, value", BAD,
                         ids=[f"{n}-{k}={v}" for n, k, v in BAD])
def test_invalid_parameters_name_the_key(name, key, value):
    table = MODELS[name].conformance_samples()[0].table
    with pytest.raises(InputError, match=rf"materials\.soil\.{key}\b"):
        from_table(MODELS[name], {**table, key: value}, "materials.soil")


def test_a_non_finite_result_names_the_points():
    model = from_table(MODELS["elastic"], {"E": 1.0e5, "nu": 0.3}, "materials.soil")
    deps = np.zeros((3, 6))
    deps[1, 2] = math.inf
    with pytest.raises(ReturnMapError, match=r"LinearElastic: local stress update failed "
                                             r"\(non-finite result\) at 1 of 3 points"):
        model.update(deps, model.initial_state(3))
