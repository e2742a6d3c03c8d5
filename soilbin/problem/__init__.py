"""The finite element problem of a scene and its parts (see ``core``)."""
from .core import SoilProblem

__all__ = ["SoilProblem"]
