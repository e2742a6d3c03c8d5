"""Mohr–Coulomb interface law: penalty stick, slip and separation (dissertation ch. V, eq. B.13).

The law has the bulk law's shape, ``traction_update(jump, normal, state)
-> (t, dt_djump, new_state)``, over contact points: compiled per point
(:mod:`soilbin.models.jit`, :func:`traction_point`), one loop over the points per call. ``jump`` is
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
+ (τ_max k_s / ``|t_tr|``)(P_t - m⊗m); in stick m = 0 and τ_max / ``|t_tr|`` = 1:
the penalty springs k_n n⊗n + k_s P_t.
"""
import dataclasses
import math

import numpy as np

from ..params import Params, magnitude_param, param
from .jit import kernel

ZERO3 = (0.0, 0.0, 0.0)

# Per point on 3-tuples (values, not array views: no reference counting in the compiled
# loop). A point's tangent travels as its form (k, slope, shear) and the slip direction m:
# D = k n⊗n + slope m⊗n + shear (P_t - m⊗m) (:func:`interface_tangent`).


@kernel
def row(a, p):
    """Row p of an (n, 3) array as a 3-tuple."""
    return a[p, 0], a[p, 1], a[p, 2]


@kernel
def interface_tangent(form, normal, m, i, j):
    """D_ij of D = k n⊗n + slope m⊗n + shear (P_t - m⊗m), P_t = I - n⊗n, form = (k, slope,
    shear): in slip (k_n, k_n tan δ, k_s τ_max / ``|t_tr|``); in stick and bonded
    (k_n, 0, k_s) with m = 0, the penalty springs k_n n⊗n + k_s P_t; in separation 0."""
    k, slope, shear = form
    nn = normal[i] * normal[j]
    P_t = (1.0 if i == j else 0.0) - nn
    return k * nn + slope * (m[i] * normal[j]) + shear * (P_t - m[i] * m[j])


@kernel
def traction_point(k_n, k_s, c_a, tan_delta, jump, normal, slip_n):
    """The law of the module doc at one point: (t, slip, the tangent's form, m)."""
    g = jump[0] * normal[0] + jump[1] * normal[1] + jump[2] * normal[2]
    jump_t = (jump[0] - g * normal[0], jump[1] - g * normal[1], jump[2] - g * normal[2])
    if not g >= 0.0:   # separation (g < 0, or NaN): no traction, the slip follows the jump
        return ZERO3, jump_t, ZERO3, ZERO3
    t_n = k_n * g
    t_tr = (k_s * (jump_t[0] - slip_n[0]), k_s * (jump_t[1] - slip_n[1]),
            k_s * (jump_t[2] - slip_n[2]))
    t_tr_norm = math.sqrt(t_tr[0] * t_tr[0] + t_tr[1] * t_tr[1] + t_tr[2] * t_tr[2])
    tau_max = c_a + t_n * tan_delta
    if t_tr_norm > tau_max:   # slip: t = t_n n + τ_max m, slip = P_t jump - τ_max m / k_s
        ratio = tau_max / t_tr_norm
        m = (t_tr[0] / t_tr_norm, t_tr[1] / t_tr_norm, t_tr[2] / t_tr_norm)
        t_s = (ratio * t_tr[0], ratio * t_tr[1], ratio * t_tr[2])
        slip = (jump_t[0] - t_s[0] / k_s, jump_t[1] - t_s[1] / k_s, jump_t[2] - t_s[2] / k_s)
        form = (k_n, k_n * tan_delta, k_s * ratio)
    else:   # stick
        m, t_s, slip, form = ZERO3, t_tr, slip_n, (k_n, 0.0, k_s)
    t = (t_n * normal[0] + t_s[0], t_n * normal[1] + t_s[1], t_n * normal[2] + t_s[2])
    return t, slip, form, m


@kernel
def mohr_coulomb_update(k_n, k_s, c_a, tan_delta, jump, normal, slip_n, t, D, slip):
    """:func:`traction_point` at every point: writes the traction t, its tangent D and the
    slip."""
    for p in range(jump.shape[0]):
        n = row(normal, p)
        t_p, slip_p, form, m = traction_point(k_n, k_s, c_a, tan_delta, row(jump, p), n,
                                              row(slip_n, p))
        for i in range(3):
            t[p, i], slip[p, i] = t_p[i], slip_p[i]
            for j in range(3):
                D[p, i, j] = interface_tangent(form, n, m, i, j)


@kernel
def bonded_update(k_n, k_s, jump, normal, t, D):
    """t = D jump with the penalty springs D = k_n n⊗n + k_s P_t at every point."""
    for p in range(jump.shape[0]):
        n = row(normal, p)
        for i in range(3):
            for j in range(3):
                D[p, i, j] = interface_tangent((k_n, 0.0, k_s), n, ZERO3, i, j)
        for i in range(3):
            t[p, i] = D[p, i, 0] * jump[p, 0] + D[p, i, 1] * jump[p, 1] + D[p, i, 2] * jump[p, 2]


def contiguous(*arrays):
    """The arrays as C-contiguous float arrays (no copy where they are), as the compiled
    loops take them."""
    return tuple(np.ascontiguousarray(a, dtype=float) for a in arrays)


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
        jump, normal, slip_n = contiguous(jump, normal, state["slip"])
        m = len(jump)
        traction, tangent, slip = np.empty((m, 3)), np.empty((m, 3, 3)), np.empty((m, 3))
        mohr_coulomb_update(float(self.k_n), float(self.k_s), float(self.c_a),
                            math.tan(math.radians(self.delta)), jump, normal, slip_n, traction,
                            tangent, slip)
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
        jump, normal = contiguous(jump, normal)
        traction, tangent = np.empty((len(jump), 3)), np.empty((len(jump), 3, 3))
        bonded_update(float(self.k_n), float(self.k_s), jump, normal, traction, tangent)
        return traction, tangent, state


def exercise_interface(law):
    """One traction update of ``law`` at one closed point: its kernels compiled (or loaded
    from numba's cache)."""
    law.traction_update(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), law.initial_state(1))
