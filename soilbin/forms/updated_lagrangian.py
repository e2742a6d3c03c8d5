"""Updated Lagrangian virtual work (dissertation ch. II, eq. 2.47, 2.56-2.62).

Each load step is referred to the configuration Ω_n of the last converged
step: the unknown is the displacement increment Δu, gradients ∇ are taken on
Ω_n (the mesh is moved after every converged step) and F = I + ∇Δu.

Objective stress update (Hughes & Winget 1980, an incrementally objective
integration of the Jaumann rate of eq. 2.64-2.66): with the midpoint
velocity gradient L = ∇Δu (I + ∇Δu/2)⁻¹, the strain increment is
Δε = sym L and the incremental rotation R = (I − W/2)⁻¹ (I + W/2), W = skew L.
The model integrates in the frame of step n: σ̂ = model(σ_n, Δε̂) with the
midpoint strain rotated back by the half-step rotation,
Δε̂ = R½ᵀ Δε̄ R½, R½ = (I − W/4)⁻¹ (I + W/4), and σ_{n+1} = R σ̂ Rᵀ; for an
isotropic law this is σ_{n+1} = R σ_n Rᵀ + Q Δσ Qᵀ with Q = R R½ᵀ, which is the
half-step rotation to second order (both Cayley rotations are exponentials to
O(‖W‖³), so R½² = R + O(‖W‖³)): second-order accurate (rotating Δε by the whole R
instead makes it first order). For a rigid increment Δε = 0 and R is the
rotation itself, exactly.

Internal virtual work on Ω_{n+1}, pulled back to Ω_n::

    ∫ σ_{n+1} : ∇_{n+1} v dv = ∫ J σ_{n+1} : (∇v F⁻¹) dV,

with mean-dilatation elements as in ``virtual_work`` (σ → dev σ + p I, plus
the pressure and dilatation constraints, with Δε̄ = dev Δε + Δθ/3 I). The
Jacobian is the Gateaux derivative of this form, in which the stress is
σ̂_lin = σ̂ + C_tan : (Δε̂(Δu) − Δε̂_k), exact at the iterate k: it carries the
material stiffness, the initial-stress (geometric) stiffness of eq. 2.57 and
the linearised rotation, consistently.
"""
import ufl

from ..tensors import ufl_from_mandel, ufl_mandel


def _cayley(W):
    I = ufl.Identity(3)
    return ufl.inv(I - W / 2) * (I + W / 2)


def kinematics(disc, w):
    """(F, Δε, R, R½) of the increment in ``w`` on the current mesh Ω_n."""
    I = ufl.Identity(3)
    grad_du = disc.grad(disc.displacement(w))
    L = grad_du * ufl.inv(I + grad_du / 2)
    W = ufl.skew(L)
    return I + grad_du, ufl.sym(L), _cayley(W), _cayley(W / 2)


def model_strain(disc, w):
    """Δε̂ = R½ᵀ Δε̄ R½, the strain increment the constitutive model integrates."""
    _, deps, _, R_half = kinematics(disc, w)
    if disc.element.mixed:
        deps = ufl.dev(deps) + ufl.split(w)[1] / 3.0 * ufl.Identity(3)
    return R_half.T * deps * R_half


def rotation(disc, w):
    return kinematics(disc, w)[2]


def internal_force(disc, points, w, v):
    """∫ J σ_{n+1} : ∇v F⁻¹ dV (+ mean-dilatation terms) with σ̂ linearised about the iterate."""
    F, deps, R, _ = kinematics(disc, w)
    J = ufl.det(F)
    deps_hat = ufl_mandel(model_strain(disc, w))
    sigma_hat = points.stress + ufl.dot(points.tangent, deps_hat - points.strain)
    sigma = R * ufl_from_mandel(sigma_hat) * R.T
    dx = disc.measure()
    grad_v = disc.grad(disc.displacement(v)) * ufl.inv(F)
    if not disc.element.mixed:
        return J * ufl.inner(sigma, grad_v) * dx
    _, theta, p = ufl.split(w)
    _, psi, q = ufl.split(v)
    I = ufl.Identity(3)
    return J * (ufl.inner(ufl.dev(sigma) + p * I, grad_v)
                + (ufl.tr(sigma) / 3.0 - p) * psi
                + q * (ufl.tr(deps) - theta)) * dx


def surface_stretch(F, n):
    """da/dA of a facet with normal n on Ω_n: J ``|F⁻ᵀ n|`` (Nanson)."""
    return ufl.det(F) * ufl.sqrt(ufl.dot(ufl.inv(F).T * n, ufl.inv(F).T * n))
