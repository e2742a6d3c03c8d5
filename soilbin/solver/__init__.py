"""The nonlinear solver: material points, Newton, load stepping, linear solves.

Importing it routes DOLFINx's JIT through :mod:`soilbin.solver.jit` (every form,
expression and element that soilbin compiles is built there)."""
from .jit import install

install()
