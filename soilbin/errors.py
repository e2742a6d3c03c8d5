"""Typed errors. The command line turns each into a one- or two-line message."""


class SoilbinError(Exception):
    """Base of every error soilbin reports to the user without a traceback."""


class InputError(SoilbinError):
    """Bad input: a scene file, a key, a value out of range, a --set override."""


class ReturnMapError(SoilbinError):
    """A constitutive update failed at some quadrature points (the step is cut)."""


class ConvergenceError(SoilbinError):
    """A load step could not be converged even after cutting it."""
