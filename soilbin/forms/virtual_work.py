"""Virtual work of the soil in small strain, reading σ and C_tan at quadrature points.

This module knows nothing of return mapping: stress and tangent arrive as
quadrature-space functions (Mandel vectors / matrices, see ``tensors``).

Plain displacement elements::

    R = ∫ σ : ε(v)                       J = ∫ ε(v) : C : ε(du)

Mean-dilatation elements (w = (u, θ, p), test (v, ψ, q)), with the enhanced
strain ε̄(u, θ) = dev ε(u) + θ/3 I::

    R = ∫ σ : ε̄(v, ψ) + ∫ p (div v − ψ) + ∫ q (div u − θ)
    J = ∫ ε̄(v, ψ) : C : ε̄(du, dθ) + ∫ dp (div v − ψ) + ∫ q (div du − dθ)

Both are symmetric when C is.
"""
import ufl

from ..tensors import ufl_mandel


def enhanced_strain(disc, w):
    """ε̄ of a (mixed) function: the strain the constitutive law sees."""
    eps = ufl.sym(disc.grad(disc.displacement(w)))
    if not disc.element.mixed:
        return eps
    return ufl.dev(eps) + ufl.split(w)[1] / 3.0 * ufl.Identity(3)


def _constraint(disc, w, w_hat):
    """∫ p̂ (div v − ψ) + ∫ q (div u − θ) with (v, ψ, q) from w_hat."""
    _, theta, p = ufl.split(w)
    _, psi, q = ufl.split(w_hat)
    u, v = disc.displacement(w), disc.displacement(w_hat)
    return (p * (disc.div(v) - psi) + q * (disc.div(u) - theta)) * disc.measure()


def internal_force(disc, sigma_q, w, v):
    """R_int(w; v) = ∫ σ : ε̄(v) (+ mean-dilatation constraint terms)."""
    form = ufl.inner(sigma_q, ufl_mandel(enhanced_strain(disc, v))) * disc.measure()
    if disc.element.mixed:
        form += _constraint(disc, w, v)
    return form


def material_stiffness(disc, tangent_q, dw, v):
    """Linearisation of internal_force with dσ = C_tan : dε̄."""
    eps_v = ufl_mandel(enhanced_strain(disc, v))
    eps_dw = ufl_mandel(enhanced_strain(disc, dw))
    form = ufl.inner(ufl.dot(tangent_q, eps_dw), eps_v) * disc.measure()
    if disc.element.mixed:
        form += _constraint(disc, dw, v)
    return form
