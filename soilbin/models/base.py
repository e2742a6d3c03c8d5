"""What every constitutive model offers the driver.

A model is a frozen, range-checked parameter record (:class:`Model`) that
updates the stress at many quadrature points at once. Its history at the
points is a :data:`State`: a mapping name -> array of shape (n_points, ...),
declared by the model's ``history`` and always holding ``"stress"`` (n, 6)
in the Mandel convention of :mod:`soilbin.tensors`.

Every model declares its :meth:`Model.conformance_samples`: one
:class:`Sample` per return mode, which tests/test_models_conformance.py runs
through the checks every model must pass (consistent tangent, inputs left
alone, history shapes, parameter errors).
"""
import abc
import dataclasses
from typing import ClassVar

import numpy as np

from ..errors import ReturnMapError
from ..params import Params
from .jit import kernel

State = dict[str, np.ndarray]

#: A unit deviatoric direction with every component non-zero, for the samples.
SHEAR = np.array([-0.09063425125224764, 0.19020462782182082, -0.09957037656957318,
                  -0.7688048616632173, 0.5341197324107143, 0.26334116331748947])

#: yield_state codes of every model (floats: the history arrays are float):
#: elastic; on the failure (shear) surface - the cone, or for Cam-Clay the
#: yield surface dry of critical (dilating); at the apex of the failure surface
#: or its corner with the tension cut-off (for Cam-Clay: at the origin, sigma = 0);
#: on the tension cut-off; on the cap, or for Cam-Clay on the yield surface wet
#: of critical (compacting); at the corner of cap and failure surface; at the
#: vertex of Cam-Clay on the mean-stress axis (p = p_c, q = 0).
ELASTIC, FAILURE, APEX, CUTOFF, CAP, CAP_CORNER, TIP = 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0


@kernel
def count_nonfinite(sigma, tangent):
    """The number of points whose stress (n, 6) or tangent (n, 36) has a non-finite entry."""
    failed = 0
    for i in range(sigma.shape[0]):
        total = 0.0    # inf or nan if any entry is
        for k in range(6):
            total += 0.0 * sigma[i, k]
        for k in range(36):
            total += 0.0 * tangent[i, k]
        failed += 0 if total == 0.0 else 1
    return failed


@kernel
def blocks_symmetric(blocks, rtol, atol):
    """Whether every (k, k) block of ``blocks`` (n, k, k) is symmetric to the test of
    ``np.allclose(B, B.T, rtol, atol * max|B|)``, stopping at the first that is not (a
    non-associated or slipping point's tangent is met early)."""
    scale = 0.0
    for b in range(blocks.shape[0]):
        for i in range(blocks.shape[1]):
            for j in range(blocks.shape[2]):
                scale = max(scale, abs(blocks[b, i, j]))
    atol = atol * scale
    for b in range(blocks.shape[0]):
        for i in range(blocks.shape[1]):
            for j in range(i + 1, blocks.shape[2]):
                upper, lower = blocks[b, i, j], blocks[b, j, i]
                if not abs(upper - lower) <= atol + rtol * min(abs(upper), abs(lower)):
                    return False
    return True


def exercise(model, deps, state, guess):
    """One update of ``model`` by ``deps`` (n, 6) from ``state`` with ``guess`` (as Newton's
    iterates call it), the linear solver's symmetry check of its tangent and its plastic
    work: every kernel of the model a run calls, compiled (or loaded from numba's cache)."""
    sigma, tangent, _ = model.update(deps, state, guess=guess)
    blocks_symmetric(tangent, 1e-9, 1e-12)
    model.plastic_work(deps, state["stress"], sigma)


@dataclasses.dataclass(frozen=True)
class Sample:
    """One point of a model's conformance suite: from the committed ``stress``
    (and ``history`` values besides :meth:`Model.initial_state`'s), the strain
    increment ``deps`` lands in the return mode ``mode``, recorded as ``yield_state``."""

    mode: str
    table: dict            # the parameters, as a scene's TOML table
    stress: np.ndarray     # (6,)
    deps: np.ndarray       # (6,)
    yield_state: float
    history: dict = dataclasses.field(default_factory=dict)
    fd_step: float = 1e-8  # central-difference step of the tangent check

    def state(self, model):
        """The committed history at one point for ``model`` (built from ``table``)."""
        state = model.initial_state(1, self.stress)
        for name, value in self.history.items():
            state[name][:] = value
        return state


@dataclasses.dataclass(frozen=True)
class Model(Params, abc.ABC):
    """Base of the constitutive models: history allocation, checked update."""

    #: History variable name -> per-point shape.
    history: ClassVar[dict[str, tuple]] = {"stress": (6,)}
    #: True when the tangent never changes (the driver then assembles it once).
    linear: ClassVar[bool] = False

    def initial_state(self, n, stress0=None) -> State:
        """History at ``n`` points: zeros, and ``stress0`` ((6,) or (n, 6)) as stress."""
        state = {name: np.zeros((n,) + shape) for name, shape in self.history.items()}
        if stress0 is not None:
            state["stress"][:] = stress0
        return state

    def consistent_history(self, state) -> State:
        """``state`` with the history variables that the model ties to one another made
        consistent again, after a transfer that moved each by itself (remeshing); here
        none are tied."""
        return state

    def update(self, deps, state, guess=None, tangent=None):
        """(sigma, C_tan, new_state) for the strain increment ``deps`` (n, 6) from
        the committed ``state``; neither input is modified. ``guess``, if given, is
        the new state of a nearby increment from the same ``state`` (the last Newton
        iterate's): an iterative return may start from it, and a tangent where the
        return mode changed may differ (the caps' vertices); the stress and history
        do not depend on it beyond the return's tolerance. ``tangent``, if given, is the
        C-contiguous (n, 6, 6) array C_tan is written into (the quadrature Function's
        values: no array of 36 numbers a point allocated and copied each iterate).

        Raises ReturnMapError when the result is not finite at some point.
        """
        if tangent is None:
            tangent = np.empty((len(deps), 6, 6))
        with np.errstate(all="ignore"):   # a non-finite result is reported below
            sigma, new_state = self.integrate(np.asarray(deps, dtype=float), state, guess, tangent)
        failed = count_nonfinite(sigma, tangent.reshape(len(tangent), 36))
        if failed:
            raise ReturnMapError(f"{type(self).__name__}: local stress update failed "
                                 f"(non-finite result) at {failed} of {len(sigma)} points")
        return sigma, tangent, new_state

    @classmethod
    def conformance_samples(cls) -> list[Sample]:
        """At least one :class:`Sample` per return mode of the model."""
        raise NotImplementedError(f"{cls.__name__} declares no conformance samples")

    @abc.abstractmethod
    def integrate(self, deps, state, guess, tangent):
        """The model's own update, as :meth:`update` but unchecked, C_tan written into
        ``tangent`` (n, 6, 6): returns (sigma, new_state)."""
