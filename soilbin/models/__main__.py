"""``python -m soilbin.models``: compile every model's kernels into numba's disk cache (each
conformance sample's update, its tangent's symmetry check and plastic work:
:func:`.base.exercise`), so that the first run of a scene does not wait for the compiler.
``make setup`` runs it after the sources change."""
import time

from ..params import from_table
from . import MODELS
from .base import exercise


def compile_kernels():
    """Exercise each registered model on its conformance samples once; returns the seconds
    taken."""
    start = time.perf_counter()
    for name, cls in MODELS.items():
        for sample in cls.conformance_samples():
            model = from_table(cls, sample.table, name)
            exercise(model, sample.deps[None], sample.state(model), sample.state(model))
    return time.perf_counter() - start


if __name__ == "__main__":
    print(f"constitutive kernels compiled and cached in {compile_kernels():.1f} s")
