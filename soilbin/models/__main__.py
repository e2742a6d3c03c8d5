"""``python -m soilbin.models``: compile every model's kernels into numba's disk cache (one
update of each conformance sample, and the symmetry check of its tangent), so that the
first run of a scene does not wait for the compiler. ``make setup`` runs it after the
sources change."""
import time

from ..params import from_table
from . import MODELS
from .base import blocks_symmetric


def compile_kernels():
    """Run each registered model's conformance samples once (its update and its plastic
    work); returns the seconds taken."""
    start = time.perf_counter()
    for name, cls in MODELS.items():
        for sample in cls.conformance_samples():
            model = from_table(cls, sample.table, name)
            state = sample.state(model)
            sigma, tangent, _ = model.update(sample.deps[None], state,
                                             guess=sample.state(model))
            blocks_symmetric(tangent, 1e-9, 0.0)   # the linear solver's check
            model.plastic_work(sample.deps[None], state["stress"], sigma)
    return time.perf_counter() - start


if __name__ == "__main__":
    print(f"constitutive kernels compiled and cached in {compile_kernels():.1f} s")
