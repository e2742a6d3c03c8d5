"""A run's constitutive kernels made ready ahead of their first call, in a thread.

numba compiles a kernel at its first call and keeps the machine code in its disk cache
(:mod:`soilbin.models.jit`). Where that cache is empty (a fresh checkout before ``make
setup``, a changed model) a run compiles its model's kernels at the first update: the
modified cap's take 6-9 s, mostly numba's type inference (Python), after the mesh and 4 s
of forms (FFCx's Python and gcc). :func:`compiled_ahead` compiles them in a thread from the
start of the run instead, and a problem builds its forms before it first updates its
models (:meth:`.quadrature.MaterialPoints.start`), so that the two overlap where one of them
is outside Python (gcc, gmsh, LLVM): both threads' Python shares one interpreter lock
(measured in docs/performance.md, *The first run and start-up*). Where the cache is warm
the thread only loads the kernels from it. Another process compiling into the cache instead
would not share the lock, but on a two-core machine the main thread and gcc already take
both cores: measured, the tine's first run on empty caches took as long or up to 3 s
longer that way.

The kernels are compiled by calling them as the run will: one update of one point of each
region's model from its initial state with its tangent's symmetry check and its plastic
work, one traction update of the tool's interface. numba's compiler lock makes a main
thread that calls a kernel meanwhile wait for it rather than compile it twice. The
assembler's loops (:mod:`.assembly`) are not among them: ``make setup`` compiles them
(:func:`~.assembly.compile_loops`), and where it has not, the first assembly does.
"""
import contextlib
import threading

import numpy as np

from ..models.base import exercise
from ..models.mohr_coulomb_interface import exercise_interface


def compile_model(model):
    """Compile ``model``'s kernels (or load them from the cache) on one point at its initial
    state (:func:`~soilbin.models.base.exercise`)."""
    exercise(model, np.zeros((1, 6)), model.initial_state(1), model.initial_state(1))


def compile_run_kernels(models, interface=None):
    """Compile the kernels that a run of ``models`` and ``interface`` (or None) calls."""
    for model in models:
        compile_model(model)
    if interface is not None:
        exercise_interface(interface)


@contextlib.contextmanager
def compiled_ahead(models, interface=None):
    """:func:`compile_run_kernels` in a thread while the block runs; the block's end waits
    for it (a process does not exit in numba's compiler). A compilation that fails in the
    thread is left to the run's own call to report."""
    def compile_all():
        try:
            compile_run_kernels(models, interface)
        except Exception:   # the run's first call compiles again and raises it there
            pass

    thread = threading.Thread(target=compile_all, name="soilbin-kernels", daemon=True)
    thread.start()
    try:
        yield thread
    finally:
        thread.join()
