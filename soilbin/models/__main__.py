"""``python -m soilbin.models``: compile every model's kernels into numba's disk cache (each
conformance sample's update, its tangent's symmetry check and plastic work:
:func:`.base.exercise`; a traction update of each tool-soil interface law), so that the first
run of a scene does not wait for the compiler. ``make setup`` runs it after the sources
change."""
import time

from ..params import from_table
from . import MODELS
from .base import exercise
from .mohr_coulomb_interface import MohrCoulombInterface, exercise_interface


def compile_kernels():
    """Exercise each registered model on its conformance samples once; returns the seconds
    taken."""
    start = time.perf_counter()
    for name, cls in MODELS.items():
        for sample in cls.conformance_samples():
            model = from_table(cls, sample.table, name)
            exercise(model, sample.deps[None], sample.state(model), sample.state(model))
    law = MohrCoulombInterface(k_n=1.0, k_s=1.0, delta=30.0)
    for interface in (law, law.bonded()):
        exercise_interface(interface)
    return time.perf_counter() - start


if __name__ == "__main__":
    print(f"constitutive kernels compiled and cached in {compile_kernels():.1f} s")
