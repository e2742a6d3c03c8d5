"""What every constitutive model offers the driver.

A model is a frozen, range-checked parameter record (:class:`Model`) that
updates the stress at many quadrature points at once. Its history at the
points is a :data:`State`: a mapping name -> array of shape (n_points, ...),
declared by the model's ``history`` and always holding ``"stress"`` (n, 6)
in the Mandel convention of :mod:`soilbin.tensors`.
"""
import abc
import dataclasses
from typing import ClassVar

import numpy as np

from ..errors import ReturnMapError
from ..params import Params

State = dict[str, np.ndarray]


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

    def update(self, deps, state):
        """(sigma, C_tan, new_state) for the strain increment ``deps`` (n, 6) from
        the committed ``state``; neither input is modified.

        Raises ReturnMapError when the result is not finite at some point.
        """
        with np.errstate(all="ignore"):   # a non-finite result is reported below
            sigma, tangent, new_state = self.integrate(np.asarray(deps, dtype=float), state)
        ok = np.isfinite(sigma).all(axis=-1) & np.isfinite(tangent).all(axis=(-2, -1))
        failed = np.count_nonzero(~ok)
        if failed:
            raise ReturnMapError(f"{type(self).__name__}: local stress update failed "
                                 f"(non-finite result) at {failed} of {len(ok)} points")
        return sigma, tangent, new_state

    @abc.abstractmethod
    def integrate(self, deps, state):
        """The model's own update, as :meth:`update` but unchecked."""
