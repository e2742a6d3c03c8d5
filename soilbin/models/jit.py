"""The compiler of the constitutive kernels: numba's nopython mode, cached on disk.

Every return map is written once, per point, in the subset of Python numba
compiles; the loop over a region's points runs inside the compiled code.
``error_model="numpy"`` keeps IEEE arithmetic (a division by zero gives inf
or nan, as the NumPy code it replaced, and :meth:`.base.Model.update`
reports a non-finite result); fastmath stays off so that the results do not
depend on the compiler's reordering. The compiled code is cached beside the
sources (``__pycache__``), so only the first run on a machine compiles.
Setting ``NUMBA_DISABLE_JIT=1`` runs the same source as plain Python (slow,
for a debugger).

The kernels run without numba's runtime (``_nrt=False``): they allocate nothing (a
caller passes scratch arrays), so a view of a caller's array, as ``deps[i]`` for a point,
is a plain pointer. With the runtime every such view took and released a reference by
atomic instructions: 46% of an elastic point's time in the cap's update (perf).
"""
import numba

kernel = numba.njit(cache=True, error_model="numpy", _nrt=False)
