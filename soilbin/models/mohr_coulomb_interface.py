"""Mohr–Coulomb interface law: penalty stick, slip and separation (dissertation ch. V, eq. B.13).

The law has the bulk law's shape, ``traction_update(jump, normal, state)
-> (t, dt_djump, new_state)``, vectorised over contact points. ``jump`` is
the displacement of the soil relative to the tool and ``normal`` the unit
normal pointing from the soil into the tool, so g = jump·n > 0 is
penetration. ``t`` is the traction the soil exerts on the tool::

    g < 0 (separation): t = 0, and the slip follows the jump (no memory);
    g >= 0 (contact; closed at zero gap, so a body resting on the tool is
    supported from the first iterate): t_n = k_n g, trial shear t_tr = k_s (P_t jump - slip);
           stick when |t_tr| <= τ_max = c_a + t_n tan δ, else slip:
           t = t_n n + τ_max m, m = t_tr / |t_tr|, slip = P_t jump - τ_max m / k_s.

The history is the tangential slip (n, 3). The tangent is consistent (and
not symmetric in slip): dt/djump = k_n n⊗n + k_n tan δ m⊗n
+ (τ_max k_s / ``|t_tr|``)(P_t - m⊗m).
"""
import dataclasses
import math

import numpy as np

from ..params import Params, magnitude_param, param


@dataclasses.dataclass(frozen=True)
class MohrCoulombInterface(Params):
    k_n: float = magnitude_param(doc="normal penalty stiffness (traction per length)")
    k_s: float = magnitude_param(doc="shear penalty stiffness (traction per length)")
    c_a: float = magnitude_param(0.0, zero=True, doc="adhesion of soil to the tool (stress)")
    delta: float = param(0.0, lo=0.0, hi=90.0, hi_open=True,
                         doc="soil-tool friction angle [degrees]")

    history = {"slip": (3,)}

    def initial_state(self, n):
        return {"slip": np.zeros((n, 3))}

    def bonded(self):
        """The same penalty springs, never slipping or opening: a tool without interface."""
        return BondedInterface(k_n=self.k_n, k_s=self.k_s)

    def traction_update(self, jump, normal, state):
        g = np.einsum("ij,ij->i", jump, normal)
        nn = normal[:, :, None] * normal[:, None, :]
        P_t = np.eye(3) - nn
        jump_t = jump - g[:, None] * normal
        contact = g >= 0.0

        t_n = np.where(contact, self.k_n * g, 0.0)
        t_trial = self.k_s * (jump_t - state["slip"])
        t_trial_norm = np.linalg.norm(t_trial, axis=1)
        tau_max = self.c_a + t_n * math.tan(math.radians(self.delta))
        slipping = contact & (t_trial_norm > tau_max)
        ratio = np.divide(tau_max, t_trial_norm, out=np.ones_like(tau_max), where=slipping)
        t_shear = np.where(slipping, ratio, 1.0)[:, None] * t_trial

        traction = np.where(contact[:, None], t_n[:, None] * normal + t_shear, 0.0)
        slip = np.where(slipping[:, None], jump_t - t_shear / self.k_s,
                        np.where(contact[:, None], state["slip"], jump_t))

        m = np.divide(t_trial, t_trial_norm[:, None], out=np.zeros_like(t_trial),
                      where=slipping[:, None])
        tangent = self.k_n * nn + self.k_s * P_t
        tangent[~contact] = 0.0
        if slipping.any():
            mm = m[:, :, None] * m[:, None, :]
            mn = m[:, :, None] * normal[:, None, :]
            slip_tangent = (self.k_n * nn + self.k_n * math.tan(math.radians(self.delta)) * mn
                            + (self.k_s * ratio)[:, None, None] * (P_t - mm))
            tangent[slipping] = slip_tangent[slipping]
        return traction, tangent, {"slip": slip}


@dataclasses.dataclass(frozen=True)
class BondedInterface(Params):
    """Soil glued to the tool by the penalty springs alone: t = k_n g n + k_s P_t jump,
    in tension as in compression, with no slip (the dissertation's analyses "without
    interface elements"). Linear; its history is an unused slip kept for a uniform state."""
    k_n: float = magnitude_param(doc="normal penalty stiffness (traction per length)")
    k_s: float = magnitude_param(doc="shear penalty stiffness (traction per length)")

    history = MohrCoulombInterface.history
    initial_state = MohrCoulombInterface.initial_state

    def traction_update(self, jump, normal, state):
        nn = normal[:, :, None] * normal[:, None, :]
        tangent = self.k_n * nn + self.k_s * (np.eye(3) - nn)
        return np.einsum("pij,pj->pi", tangent, jump), tangent, state
