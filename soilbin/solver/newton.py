"""Newton's method for one load step: PETSc SNES (newtonls) with a MUMPS LU solve.

The residual callback runs the constitutive update once per iterate; the
Jacobian callback, called by SNES at the same iterate, reuses its tangent.
Convergence is tested on the residual norm, relative to the step's initial
residual or, as a floor, to the run's force scale (the largest initial
residual seen so far), so that a step that starts near equilibrium does not
chase round-off. A diverged or failed solve raises :class:`NewtonFailure`,
which the load stepper turns into a step cut.
"""
import dataclasses

import numpy as np
from petsc4py import PETSc
from dolfinx import fem
import dolfinx.fem.petsc  # noqa: F401  (registers fem.petsc)

from ..errors import ConvergenceError, ReturnMapError


class NewtonFailure(ConvergenceError):
    """A Newton solve that did not converge (the reason is in the message)."""


@dataclasses.dataclass(frozen=True)
class NewtonResult:
    iterations: int
    residuals: tuple  # residual norm at each iterate, the initial one first


_REASONS = {-3: "linear solve failed", -4: "residual is not a number",
            -5: "iteration limit reached", -6: "line search failed"}


class NewtonSolver:
    def __init__(self, comm, residual, jacobian, w, bcs, before_residual, options, prefix="soil_",
                 nodal_terms=()):
        """``before_residual()`` runs after ``w`` is set to an iterate, before assembly;
        ``nodal_terms`` add their own entries (``add_residual(b)``, ``add_jacobian(A)``)."""
        self._L, self._a = fem.form(residual), fem.form(jacobian)
        self._w, self._bcs, self._before = w, bcs, before_residual
        self._nodal_terms = tuple(nodal_terms)
        self._opts = options
        self._b = fem.petsc.create_vector(self._L)
        self._A = fem.petsc.create_matrix(self._a)
        self._x = w.vector.duplicate()
        self._gap = w.vector.duplicate()
        self._force_scale = 0.0
        self._error = None
        self._residuals = []

        snes = PETSc.SNES().create(comm)
        snes.setOptionsPrefix(prefix)
        petsc = PETSc.Options(prefix)
        for key, value in {"snes_type": "newtonls", "snes_linesearch_type": options.line_search.value,
                           "snes_max_it": options.max_iterations,
                           "ksp_type": "preonly", "pc_type": "lu",
                           "pc_factor_mat_solver_type": "mumps",
                           # null pivots (e.g. soil yielded at the apex, zero tangent) are
                           # detected and their solution components set to zero, not an abort
                           "mat_mumps_icntl_24": 1}.items():
            petsc[key] = value
        snes.setFromOptions()
        snes.setFunction(self._F, self._b)
        snes.setJacobian(self._J, self._A)
        snes.setConvergenceTest(self._converged)
        self._snes = snes

    def include_force_scale(self, norm):
        """Make the residual floor relative to at least this force norm (e.g. of dead loads)."""
        self._force_scale = max(self._force_scale, norm)

    def _F(self, snes, x, b):
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        x.copy(self._w.vector)
        self._w.x.scatter_forward()
        with b.localForm() as b_local:
            b_local.set(0.0)
        try:
            self._before()
        except ReturnMapError as err:   # PETSc cannot carry it: stop SNES with a NaN
            self._error = err
            b.set(np.nan)
            return
        fem.petsc.assemble_vector(b, self._L)
        if self._bc_mismatch(x):   # first iterate of a displacement step: lift g - x
            fem.petsc.apply_lifting(b, [self._a], bcs=[self._bcs], x0=[x], scale=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        for term in self._nodal_terms:
            term.add_residual(b)
        fem.petsc.set_bc(b, self._bcs, x, -1.0)

    def _bc_mismatch(self, x):
        """Whether x misses a prescribed value (else the lifting term is zero)."""
        with self._gap.localForm() as gap:
            gap.set(0.0)
        fem.petsc.set_bc(self._gap, self._bcs, x, 1.0)
        return self._gap.norm(PETSc.NormType.NORM_INFINITY) > 0.0

    def _J(self, snes, x, A, P):
        A.zeroEntries()
        fem.petsc.assemble_matrix(A, self._a, bcs=self._bcs)
        if self._nodal_terms:   # the BC diagonal was inserted: flush before adding
            A.assemble(PETSc.Mat.AssemblyType.FLUSH)
        for term in self._nodal_terms:
            term.add_jacobian(A)
        A.assemble()

    def _converged(self, snes, it, norms):
        fnorm = norms[2]
        self._residuals.append(fnorm)
        if not np.isfinite(fnorm):
            return PETSc.SNES.ConvergedReason.DIVERGED_FNORM_NAN
        if it == 0:
            self._force_scale = max(self._force_scale, fnorm)
        target = max(self._opts.rtol * self._residuals[0], self._opts.atol * self._force_scale)
        if fnorm <= target:
            return PETSc.SNES.ConvergedReason.CONVERGED_FNORM_ABS if it else \
                PETSc.SNES.ConvergedReason.CONVERGED_ITS
        if it >= self._opts.max_iterations:
            return PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT
        return PETSc.SNES.ConvergedReason.ITERATING

    def solve(self):
        """Newton from the current ``w``; on success ``w`` holds the solution."""
        self._residuals, self._error = [], None
        self._w.vector.copy(self._x)
        try:
            self._snes.solve(None, self._x)
        except PETSc.Error as err:   # e.g. MUMPS failing on a singular tangent
            raise NewtonFailure(f"the linear solve failed (PETSc error {err.ierr})") from None
        reason = self._snes.getConvergedReason()
        if self._error is not None:
            raise NewtonFailure(str(self._error))
        if reason <= 0:
            raise NewtonFailure(f"Newton did not converge ({_REASONS.get(reason, reason)}) "
                                f"after {self._snes.getIterationNumber()} iterations")
        self._x.copy(self._w.vector)
        self._w.x.scatter_forward()
        return NewtonResult(self._snes.getIterationNumber(), tuple(self._residuals))
