"""The linear solve of each Newton iterate: MUMPS LU, MUMPS LDLᵀ, or preconditioned Krylov.

``solver.linear`` picks one (``auto``: LDLᵀ when the Jacobian can be
symmetric, LU otherwise, block low-rank LU above ``BLR_DOFS`` unknowns):

* ``lu``: MUMPS LU.
* ``cholesky``: MUMPS LDLᵀ (symmetric indefinite: the mean-dilatation
  systems are saddle points). It needs a symmetric Jacobian: small strain
  and symmetric material and interface tangents (no point slipping on a
  Mohr–Coulomb interface; a bonded tool is fine), which is checked at every
  iterate; an iterate that fails the check, and every iterate of a scene that
  cannot be symmetric, is solved by LU instead (``stats["unsymmetric_solves"]``
  counts them).
* ``amg``: GMRES preconditioned by PETSc's smoothed aggregation (GAMG) with
  the rigid-body modes as near-nullspace. ``hex8-bbar`` systems are
  condensed first (``condensation.CellCondensation``: the cell dilatation
  and pressure eliminated exactly), since AMG needs a displacement system.
* ``blr``: MUMPS's block low-rank LU of the same (condensed) system, the
  off-diagonal blocks of the fronts compressed to ``BLR_TOLERANCE`` (MUMPS
  ICNTL(35), CNTL(7); Amestoy et al. 2015, SIAM J. Sci. Comput.
  37(3):A1451), used as the solver: each Newton correction is inexact by
  about that tolerance, which Newton absorbs. A factorisation per iterate.
  GMRES around it (the factor as preconditioner) stalls where the Newton
  matrix is singular (a cluster of points at a vertex with a zero tangent:
  more than 170 GMRES iterations on the tine's refine 4); the factor alone,
  like LU, sets the components of its null pivots to zero. On refine 4
  (10⁶ unknowns) it peaks at 16.6 GB; MUMPS estimates the full-rank LU's
  factorisation alone at 24.6 GB.

Both factorisations use the PORD ordering above ``PORD_DOFS`` unknowns
(faster than MUMPS's automatic choice on the footing and the tine, by 0-45%
for LDLᵀ); PORD aborts the process on some tiny graphs (a
one-element column: "no valid number of stages in multisector").
"""
import time

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ..errors import ConvergenceError, InputError
from ..models.base import blocks_symmetric
from ..records.scene import LinearSolverKind
from .condensation import CellCondensation, Uncondensed
from .resources import release

#: Above this many unknowns ``auto`` takes the block low-rank LU: with it the tine in cap
#: soil converges its whole travel on 134 045 unknowns and its steps on 1 036 591, where
#: GMRES + GAMG breaks down or Newton stalls along its corrections (docs/performance.md,
#: *The large tine*).
BLR_DOFS = 300_000
#: From this many unknowns on, MUMPS orders with PORD (below: its automatic choice).
PORD_DOFS = 5000
#: Krylov tolerance relative to the right-hand side (Newton's rtol is 1e-9).
KRYLOV_RTOL = 1e-10
#: Added to every diagonal entry SOR divides by on the multigrid levels (a stiffness
#: diagonal is 1e2-1e6 in the scenes' units; the zero rows' right-hand sides are zero).
SOR_SHIFT = 1e-10
#: BLR compression tolerance, relative (MUMPS CNTL(7)), about the inexactness of a correction.
BLR_TOLERANCE = 1e-4


def all_symmetric(blocks, comm):
    """Whether every (n, k, k) block on every rank is symmetric to round-off (the same
    answer on all ranks: each takes the same factorisation)."""
    local = blocks_symmetric(np.ascontiguousarray(blocks), 1e-9, 1e-12)
    return comm.allreduce(bool(local), op=MPI.LAND)


class LinearSolveError(ConvergenceError):
    """The linear solve failed (singular factor, Krylov divergence); the step is cut."""


def _mumps(ksp, prefix, factor, n_dofs, **more):
    ksp.setOptionsPrefix(prefix)
    options = PETSc.Options(prefix)
    for key, value in {"ksp_type": "preonly", "pc_type": factor,
                       "pc_factor_mat_solver_type": "mumps",
                       "mat_mumps_icntl_7": 4 if n_dofs >= PORD_DOFS else 7,
                       # null pivots (soil yielded at the apex, zero tangent) are detected and
                       # their solution components set to zero, not an abort
                       "mat_mumps_icntl_24": 1, **more}.items():
        options.setValue(key, value)
    ksp.setFromOptions()


class LinearSolver:
    """Factorise (or set up) once per Newton iterate, then solve any number of right-hand sides.

    ``stats`` accumulates the CPU seconds of factorisation / set-up and solves
    and counts solves and Krylov iterations."""

    def __init__(self, comm, kind, disc, n_dofs, symmetric, prefix):
        if kind is LinearSolverKind.AUTO:
            kind = (LinearSolverKind.BLR if n_dofs > BLR_DOFS else
                    LinearSolverKind.CHOLESKY if symmetric else LinearSolverKind.LU)
        self.kind = kind
        self.stats = dict(factorisation_s=0.0, solve_s=0.0, solves=0, krylov_iterations=0,
                          factorisations=0, unsymmetric_solves=0)
        self._lu = PETSc.KSP().create(comm)
        _mumps(self._lu, prefix + "lu_", "lu", n_dofs)
        self._condensed = None
        self._symmetric = symmetric
        self._ksp = PETSc.KSP().create(comm)
        if kind is LinearSolverKind.LU:
            return
        if kind is LinearSolverKind.CHOLESKY:
            _mumps(self._ksp, prefix + "ldlt_", "cholesky", n_dofs)
            return
        bbar = disc.element.cell_dilatation
        if kind is LinearSolverKind.BLR:   # any system factorises; B-bar's condensed is smaller
            self._condensed = CellCondensation(disc) if bbar else None
            # the UCFS variant (ICNTL(36) = 1: compress before the update) and compressed
            # contribution blocks (ICNTL(37) = 1): on the tine's refine 4 (serial) a peak of
            # 16.6 GB instead of 18.4 and Newton iterations of 95-146 s instead of 118-172;
            # refine 2: 9% less CPU, 4.5% less memory (docs/performance.md, *Block low-rank
            # settings*)
            _mumps(self._ksp, prefix + "blr_", "lu", n_dofs,
                   mat_mumps_icntl_35=1, mat_mumps_cntl_7=BLR_TOLERANCE,
                   mat_mumps_icntl_36=1, mat_mumps_icntl_37=1)
            return
        if disc.element.mixed and not bbar:
            raise InputError(f"solver.linear = amg: not for {disc.element.value} (its cell "
                             f"fields are not condensed); use lu or cholesky")
        self._condensed = CellCondensation(disc) if bbar else Uncondensed(disc)
        ksp = self._ksp
        ksp.setOptionsPrefix(prefix + "amg_")
        options = PETSc.Options(prefix + "amg_")
        # GMRES even when symmetric: CG meets indefinite GAMG preconditioners on the footing.
        # Smoother: Chebyshev on SOR (tine-2in-90deg with AMG: 35 GMRES iterations per
        # solve against 81 on Jacobi, the same Newton iterations). GAMG leaves a few
        # singleton aggregates, whose rotations are zero columns of the prolongator and so
        # zero rows of the coarse operator; the diagonal shift lets SOR pass them. Classical
        # Gram-Schmidt with a second pass where it loses orthogonality: without it GMRES
        # breaks down (KSP reason -5) in the second Newton iteration of the tine on refine 4
        # after 400 iterations; with it, it converges in 158.
        for key, value in {"ksp_type": "gmres", "ksp_rtol": KRYLOV_RTOL,
                           "ksp_max_it": 1000, "ksp_gmres_restart": 200,
                           "ksp_gmres_cgs_refinement_type": "refine_ifneeded", "pc_type": "gamg",
                           "pc_gamg_type": "agg", "pc_gamg_agg_nsmooths": 1,
                           "pc_gamg_threshold": 0.01, "mg_levels_ksp_type": "chebyshev",
                           "mg_levels_pc_type": "sor",
                           "mg_levels_pc_sor_diagonal_shift": SOR_SHIFT}.items():
            options.setValue(key, value)
        ksp.setFromOptions()

    @property
    def description(self):
        if self.kind is LinearSolverKind.LU:
            return "MUMPS LU"
        if self.kind is LinearSolverKind.CHOLESKY:
            lu, every = self.stats["unsymmetric_solves"], self.stats["factorisations"]
            if not self._symmetric or (lu and lu == every):
                return "MUMPS LU (the Jacobian is unsymmetric)"
            return "MUMPS LDLT" + (f", LU for {lu} of {every} iterates (unsymmetric)" if lu else "")
        if self.kind is LinearSolverKind.BLR:
            return "MUMPS BLR LU" + (f" ({self._condensed.description})"
                                     if self._condensed is not None else "")
        return f"GMRES + GAMG ({self._condensed.description})"

    def destroy(self):
        """Frees the KSPs (MUMPS's factors with them) and the condensation's objects."""
        release(self._lu, self._ksp)
        if self._condensed is not None:
            self._condensed.destroy()

    def set_operator(self, A, symmetric_tangent):
        """Factorise (or set up the preconditioner for) this iterate's matrix;
        ``symmetric_tangent()`` says whether it is symmetric (asked only if it matters)."""
        use_lu = self.kind is LinearSolverKind.LU or (
            self.kind is LinearSolverKind.CHOLESKY and not (self._symmetric and symmetric_tangent()))
        start = time.process_time()
        if use_lu and self.kind is LinearSolverKind.CHOLESKY:
            self.stats["unsymmetric_solves"] += 1
        self.stats["factorisations"] += 1
        self._active = self._lu if use_lu else self._ksp
        self._active.setOperators(A if self._condensed is None else self._condensed.condense(A))
        self._setup(self._active)
        self.stats["factorisation_s"] += time.process_time() - start

    @staticmethod
    def _setup(ksp):
        try:
            ksp.setUp()
        except PETSc.Error as err:   # e.g. MUMPS failing on a singular tangent
            raise LinearSolveError(f"the factorisation failed (PETSc error {err.ierr})") from None

    def solve(self, rhs, x):
        """x = A⁻¹ rhs with the last operator."""
        start = time.process_time()
        ksp = self._active
        try:
            if self._condensed is None:
                ksp.solve(rhs, x)
            else:
                self._condensed.solve(ksp, rhs, x)
        except PETSc.Error as err:
            raise LinearSolveError(f"the linear solve failed (PETSc error {err.ierr})") from None
        reason = ksp.getConvergedReason()
        self.stats["solves"] += 1
        if self.kind is LinearSolverKind.AMG:
            self.stats["krylov_iterations"] += ksp.getIterationNumber()
        self.stats["solve_s"] += time.process_time() - start
        if reason < 0:
            raise LinearSolveError(f"the linear solve failed (KSP reason {reason})")
