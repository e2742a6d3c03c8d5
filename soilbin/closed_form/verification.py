"""Closed forms of the chapter VII verification problems, shared by the tests and the benchmark.

Compression positive here (geomechanics convention): pressures, strengths, settlements.
"""
import math


def prandtl_limit_pressure(c):
    """(2 + pi) c: the collapse pressure of a strip on a Tresca (von Mises in plane strain)
    half-space, smooth or rough, without weight (Prandtl 1920; section VII.4)."""
    return (2.0 + math.pi) * c


def unconfined_strength(c, phi):
    """2 c cos(phi) / (1 - sin(phi)): the Mohr–Coulomb uniaxial compressive strength (the
    block of section VII.2), phi in degrees."""
    phi = math.radians(phi)
    return 2.0 * c * math.cos(phi) / (1.0 - math.sin(phi))


def constrained_modulus(E, nu):
    """M = E (1 - nu) / ((1 + nu)(1 - 2 nu)): stress over strain in one-dimensional
    (oedometric) compression of an isotropic elastic body."""
    return E * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu))


def column_settlement(pressure, height, E, nu):
    """p L / M: the top settlement of a laterally confined elastic column (section VII.1)."""
    return pressure * height / constrained_modulus(E, nu)
