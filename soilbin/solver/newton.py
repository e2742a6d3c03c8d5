"""Newton's method for one load step, with one factorisation (or AMG set-up) per iterate.

The residual evaluation runs the constitutive update once per iterate; the
Jacobian, assembled at the same iterate, reuses its tangent. Convergence is
tested on the residual norm, relative to the step's initial residual (its norm
over the equilibrium rows: at a displacement step's first iterate the prescribed
rows hold the mismatch g - x, a length, which would make the tolerance depend on
the units; the mean-dilatation elements' cell rows, a stress times a volume and
a volume, still count: below 1e-5 of the norm in the footing's psi and inches,
they would swamp forces a billion times smaller) or, as
a floor, to the run's force scale (the largest initial residual seen so
far), so that a step that starts near equilibrium does not chase round-off;
and never below the rounding of the forces the soil carries (``ROUNDING``
times the largest force on the driven boundary so far, :meth:`carry`): a first
step cut to 2^-30 of the load sets a force scale that the rounding of later,
larger loads passes, and every step after it would stagnate.
A diverged or failed solve raises :class:`NewtonFailure`, which the load
stepper turns into a step cut.

A *border* adds one global scalar unknown a and its equation g(w, a) = 0
to the system (the travel of a force-controlled tool and its force
balance). The bordered Newton system [K b; cᵀ d] [Δw; Δa] = −[R; g] is
solved by block elimination with the one factorisation of K:
K x = −R, K z = b, Δa = (−g − c·x) / (d − c·z), Δw = x − z Δa.

A step that is not going to converge is cut early: as soon as the residual
exceeds ``DIVERGENCE`` times the step's first, has grown in two successive
iterations, or has not reached a new minimum for ``STAGNATION`` iterations
(on the footing, every step that later diverged had grown twice in a row
first, and no converged step had; under the critical-point line search only
the first of these). ``stats`` accumulates the CPU time of
each part of an iterate (constitutive update, assembly, factorisation,
solves) and the iterations of converged and failed solves.
"""
import dataclasses
import math
import time

import numpy as np
from petsc4py import PETSc
from dolfinx import fem
import dolfinx.fem.petsc  # noqa: F401  (registers fem.petsc)

from ..errors import ConvergenceError, ReturnMapError
from ..records.scene import LineSearch
from .assembly import ElementAssembler
from .linear_solver import LinearSolver, LinearSolveError
from .resources import release


class NewtonFailure(ConvergenceError):
    """A Newton solve that did not converge (the reason is in the message) after
    ``iterations`` Newton corrections."""

    def __init__(self, message, iterations=0):
        super().__init__(message)
        self.iterations = iterations


@dataclasses.dataclass(frozen=True)
class NewtonResult:
    iterations: int
    residuals: tuple  # residual norm at each iterate, the initial one first


#: Shortenings of the step a backtracking line search tries before taking the shortest.
MAX_BACKTRACKS = 10
#: Fraction of the Newton decrease of ‖R‖²/2 a backtracking step must achieve.
ARMIJO = 1e-4
#: Trial steps of the critical-point line search, and its tolerance on ``|g(λ)|/|g(0)|``:
#: 6 and 0.2 take the tine's first step out of K0 in 26 Newton iterations, where 4 trials
#: and 0.5 take 33 and Crisfield's 0.8 takes 46 (each trial costs one residual).
CP_TRIALS, CP_TOLERANCE = 6, 0.2
#: A residual this many times the step's first ends the step (it is cut).
DIVERGENCE = 10.0
#: Iterations without a new smallest residual that end the step.
STAGNATION = 5
#: The rounding of an assembled residual relative to the force it balances (about 1e-16
#: times the element terms summed into a dof, with a margin): no floor goes below it.
#: The elastic column's first step cut to 2^-30 of the load stagnated at 1e-15 of its
#: force by the 16th step.
ROUNDING = 1e-13


class _Clock:
    """Adds the CPU time of a ``with`` block to ``stats[key]``."""

    def __init__(self, stats):
        self._stats = stats

    def __call__(self, key):
        self._key = key
        return self

    def __enter__(self):
        self._start = time.process_time()

    def __exit__(self, *exc):
        self._stats[self._key] += time.process_time() - self._start


class NewtonSolver:
    def __init__(self, comm, residual, jacobian, w, bcs, before_residual, options, disc,
                 prefix="soil_", nodal_terms=(), coupled_terms=(), border=None,
                 symmetric=False, symmetric_tangent=lambda: True):
        """``before_residual()`` runs after ``w`` is set to an iterate, before assembly;
        ``nodal_terms`` add their own entries (``add_residual(b)``, ``add_jacobian(A)``);
        ``coupled_terms`` add to the residual too and couple dofs of no common element: the
        matrix is made anew whenever their ``version`` changes, with the entries
        ``coupling_entries()`` (global rows and columns), and their ``coupling_values()``
        are added at every assembly;
        ``border``, if given, carries the extra scalar unknown (see the module docstring):
        ``residual()`` → g, ``linearise(b, c)`` fills b, c and returns d,
        ``value``/``set_value(a)``, and, for the ``cp`` line search, ``share`` (g times it
        is the energy's derivative in a); ``symmetric``: whether the Jacobian can be symmetric
        (then ``symmetric_tangent()`` says whether it is at the current iterate)."""
        self._L, self._a = fem.form(residual), fem.form(jacobian)
        self._w, self._bcs, self._before = w, bcs, before_residual
        self._nodal_terms = tuple(nodal_terms)
        self._coupled_terms = tuple(coupled_terms)
        self._coupling_version = (None,) * len(self._coupled_terms)   # the first assembly couples
        self._held, self._held_fraction = None, 0.0   # hold_out_of_balance
        self._border = border
        self._opts = options
        self._b = fem.petsc.create_vector(self._L)
        self.matrix = fem.petsc.create_matrix(self._a)
        self._assembler = ElementAssembler(self._a, w.function_space, bcs, self.matrix,
                                           coupled=bool(coupled_terms))
        self._dx = w.vector.duplicate()
        self._gap = w.vector.duplicate()
        # 1 on the rows of the equilibrium equations, 0 on the prescribed ones: those hold the
        # mismatch x - g of a displacement step's first iterate, a length, which the step's
        # first norm leaves out (the tolerance it sets is a force, in any units)
        self._equations = w.vector.duplicate()
        self._equations.set(1.0)
        fem.petsc.set_bc(self._equations, bcs, scale=0.0)
        self._on_equations = w.vector.duplicate()
        self._force_scale = 0.0
        self._carried = 0.0   # the largest force carried so far (:meth:`carry`)
        self._symmetric_tangent = symmetric_tangent
        #: Called at every iterate with (iteration, residual norm, target), e.g. for progress.
        self.on_iterate = None
        n_dofs = w.vector.getSize()
        self.linear = LinearSolver(comm, options.linear, disc, n_dofs,
                                   symmetric, prefix)
        self.stats = dict(constitutive_s=0.0, assembly_s=0.0, iterations=0, failed_iterations=0,
                          residual_evaluations=0)
        self._clock = _Clock(self.stats)
        if border is not None:
            self._border_b, self._border_c = w.vector.duplicate(), w.vector.duplicate()
            self._border_z = w.vector.duplicate()
            self._border_g = 0.0   # the border's equation at the last residual

    def destroy(self):
        """Frees its PETSc objects (module :mod:`.resources`); not to be used after."""
        border = (() if self._border is None else
                  (self._border_b, self._border_c, self._border_z))
        release(self._b, self.matrix, self._dx, self._gap, self._equations, self._on_equations,
                self._held, *border)
        self.linear.destroy()

    def include_force_scale(self, norm):
        """Make the residual floor relative to at least this force norm (e.g. of dead loads)."""
        self._force_scale = max(self._force_scale, norm)

    def carry(self, force):
        """The soil carries ``force`` (a converged step's force on the driven boundary): the
        residual floor is at least ROUNDING times the largest such force."""
        self._carried = max(self._carried, abs(force))

    @property
    def carried(self):
        """The largest force :meth:`carry` was told of."""
        return self._carried

    @property
    def force_scale(self):
        """The force norm the residual floor is relative to: the largest first residual of a
        step so far, or of the loads present from the start."""
        return self._force_scale

    def residual(self, b):
        """Assemble the residual at the current ``w`` into ``b``; returns its norm (with the
        border's equation). Raises ReturnMapError from the constitutive update."""
        x = self._w.vector
        with b.localForm() as b_local:
            b_local.set(0.0)
        self.stats["residual_evaluations"] += 1
        with self._clock("constitutive_s"):
            self._before()
        with self._clock("assembly_s"):
            fem.petsc.assemble_vector(b, self._L)
        if self._bc_mismatch(x):   # first iterate of a displacement step: lift g - x
            fem.petsc.apply_lifting(b, [self._a], bcs=[self._bcs], x0=[x], scale=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        for term in self._nodal_terms + self._coupled_terms:
            term.add_residual(b)
        if self._held is not None:
            b.axpy(-self._held_fraction, self._held)
        fem.petsc.set_bc(b, self._bcs, x, -1.0)
        norm = b.norm()
        if self._border is not None:
            self._border_g = self._border.residual()
            norm = math.hypot(norm, self._border_g)
        return norm

    def _equilibrium_norm(self):
        """The norm of the last residual (in ``self._b``) over the equilibrium rows, with the
        border's equation."""
        self._on_equations.pointwiseMult(self._b, self._equations)
        norm = self._on_equations.norm()
        return norm if self._border is None else math.hypot(norm, self._border_g)

    def hold_out_of_balance(self, fraction):
        """From now on solve R(w) = ``fraction`` R(w_0), R(w_0) the residual at the current
        ``w`` when first called (its norm is returned): a state out of equilibrium (a
        remeshed soil's) brought to it in stages of ``fraction``; 0 ends the holding."""
        if fraction == 0.0:
            if self._held is not None:
                self._held.destroy()
            self._held = None
            return 0.0
        if self._held is None:
            held = self._b.duplicate()
            self._held_norm = self.residual(held)
            self._held = held
        self._held_fraction = fraction
        return self._held_norm

    def _bc_mismatch(self, x):
        """Whether x misses a prescribed value (else the lifting term is zero)."""
        with self._gap.localForm() as gap:
            gap.set(0.0)
        fem.petsc.set_bc(self._gap, self._bcs, x, 1.0)
        return self._gap.norm(PETSc.NormType.NORM_INFINITY) > 0.0

    def jacobian(self):
        """Assemble the Jacobian at the current iterate (after :meth:`residual`) into
        :attr:`matrix`."""
        self._recouple()
        A = self.matrix
        coupling = (np.concatenate([term.coupling_values() for term in self._coupled_terms])
                    if self._coupled_terms else None)
        self._assembler.assemble(A, coupling)
        for term in self._nodal_terms:
            term.add_jacobian(A)
        A.assemble()

    def _recouple(self):
        """A fresh matrix with the coupled terms' entries when they have changed
        (collective: the terms' versions agree on every rank)."""
        version = tuple(term.version for term in self._coupled_terms)
        if version == self._coupling_version:
            return
        rows, columns = (np.concatenate(parts) for parts in
                         zip(*(term.coupling_entries() for term in self._coupled_terms)))
        matrix = fem.petsc.create_matrix(self._a)
        self._assembler.couple(matrix, rows, columns)
        self.matrix.destroy()
        self.matrix, self._coupling_version = matrix, version

    def tangent_solve(self, rhs, out):
        """out = K⁻¹ rhs with the Jacobian at the current ``w`` (its constitutive update run
        first), e.g. for a compliance."""
        self.residual(self._b)
        self._factorise()
        self.linear.solve(rhs, out)

    def _factorise(self):
        """Assemble the Jacobian at the current iterate (after :meth:`residual`) and factorise
        it (or set up the preconditioner)."""
        with self._clock("assembly_s"):
            self.jacobian()
        self.linear.set_operator(self.matrix, self._symmetric_tangent)

    def _converged(self, residuals, first):
        """Whether the last residual is within the step's tolerance: rtol of ``first``, the
        first residual's norm over the equilibrium rows, atol of the force scale (which
        ``first`` joins), ROUNDING of the force carried."""
        if first > 0.0 and len(residuals) == 1:
            self._force_scale = max(self._force_scale, first)
        target, _ = self._target(first)
        if self.on_iterate is not None:
            self.on_iterate(len(residuals) - 1, residuals[-1], target)
        if not math.isfinite(residuals[-1]):
            raise NewtonFailure(f"the residual is {residuals[-1]} (a load or stiffness too large "
                                "for double precision)")
        return residuals[-1] <= target

    def _newton_step(self):
        """Solve for the Newton correction into ``self._dx`` (and the border's Δa)."""
        self._factorise()
        self._b.scale(-1.0)
        self.linear.solve(self._b, self._dx)
        if self._border is None:
            return 0.0
        b, c, z = self._border_b, self._border_c, self._border_z
        d = self._border.linearise(b, c)
        self.linear.solve(b, z)
        da = (-self._border_g - c.dot(self._dx)) / (d - c.dot(z))
        self._dx.axpy(-da, z)
        return da

    def _set_iterate(self, x, a, dx, da, step):
        """w = x + step dx (and a + step da)."""
        self._w.vector.waxpy(step, dx, x)
        self._w.x.scatter_forward()
        if self._border is not None:
            self._border.set_value(a + step * da)

    def solve(self):
        """Newton from the current ``w``; on success ``w`` holds the solution."""
        residuals, corrections = [], 0
        x = self._w.vector.duplicate()
        try:
            residuals.append(self.residual(self._b))
            # the tolerance's force: the first residual's equilibrium rows (the whole first
            # residual where those are zero: every row prescribed, as in the simple shear)
            first = self._equilibrium_norm() or residuals[0]
            while True:
                if self._converged(residuals, first):
                    self.stats["iterations"] += len(residuals) - 1
                    return NewtonResult(len(residuals) - 1, tuple(residuals))
                self._check_progress(residuals, first)
                corrections += 1
                da = self._newton_step()
                self._w.vector.copy(x)
                a = self._border.value if self._border is not None else 0.0
                residuals.append(self._line_search(x, a, da, residuals[-1]))
        except (ReturnMapError, LinearSolveError, NewtonFailure) as err:
            self.stats["failed_iterations"] += corrections
            raise NewtonFailure(str(err), corrections) from None
        finally:
            x.destroy()

    def _check_progress(self, residuals, first):
        """Raise NewtonFailure if the step is not going to converge: the residual not a
        number or DIVERGENCE times the first, grown in two successive iterations or
        without a new minimum for STAGNATION iterations, or the iteration limit. Under
        ``cp`` the residual's trend is not looked at: the norm may rise along steps that
        lower the energy, and a step that never raises the energy can only stall (on the
        tine in DiMaggio–Sandler soil those two tests cut the first step three times,
        where it converges in 41 iterations without them)."""
        n = len(residuals) - 1
        if not np.isfinite(residuals[-1]):
            raise NewtonFailure(f"Newton did not converge (residual is not a number) "
                                f"after {n} iterations")
        if residuals[-1] > DIVERGENCE * residuals[0]:
            raise NewtonFailure(f"Newton diverged (residual {residuals[-1]:.3g}, "
                                f"{DIVERGENCE:g} times the first) after {n} iterations")
        if self._opts.line_search is not LineSearch.CRITICAL_POINT:
            if n >= 2 and residuals[-1] > residuals[-2] > residuals[-3]:
                raise NewtonFailure(f"Newton diverged (the residual grew in two successive "
                                    f"iterations) after {n} iterations")
            if n > STAGNATION and min(residuals[-STAGNATION:]) >= min(residuals[:-STAGNATION]):
                raise NewtonFailure(f"Newton stagnated ({STAGNATION} iterations without a "
                                    f"smaller residual) after {n} iterations; "
                                    + self._shortfall(residuals, first))
        if n >= self._opts.max_iterations:
            raise NewtonFailure(f"Newton did not converge (iteration limit reached) "
                                f"after {n} iterations; " + self._shortfall(residuals, first))

    def _target(self, first):
        """(the step's residual target, which term sets it): the largest of 0 rtol times
        ``first``, 1 atol times the force scale, 2 ROUNDING times the force carried."""
        terms = (self._opts.rtol * first, self._opts.atol * self._force_scale,
                 ROUNDING * self._carried)
        which = max(range(3), key=terms.__getitem__)
        return terms[which], which

    def _shortfall(self, residuals, first):
        """The least residual of a step that failed against its target, and the term that
        sets the target (:meth:`_target`), for the failure's message."""
        target, which = self._target(first)
        opts = self._opts
        term = (f"solver.rtol {opts.rtol:.3g} x the step's first residual {first:.3g}",
                f"solver.atol {opts.atol:.3g} x the force scale {self._force_scale:.3g}",
                f"{ROUNDING:g} x the force carried {self._carried:.3g}")[which]
        return (f"the residual {min(residuals):.3g} at least against the target {target:.3g}, "
                + term)

    def _line_search(self, x, a, da, norm0):
        """The full step, or a shorter one along it (``bt``, ``cp``); returns the new norm."""
        if self._opts.line_search is LineSearch.CRITICAL_POINT:
            return self._critical_point(x, a, da)
        step = 1.0
        self._set_iterate(x, a, self._dx, da, step)
        norm = self.residual(self._b)
        if self._opts.line_search is LineSearch.BASIC:
            return norm
        # bt: a step is taken once it lowers φ(λ) = ‖R(x + λ dx)‖²/2 by the Armijo fraction
        # of the Newton decrease, φ(λ) ≤ (1 − 2 ARMIJO λ) φ(0), else shortened to the minimum
        # of the quadratic through φ(0), φ'(0) = −‖R_0‖² and φ(λ), kept within [0.1, 0.5] λ
        # (Dennis & Schnabel 1996, alg. A6.3.1), at most MAX_BACKTRACKS times.
        for _ in range(MAX_BACKTRACKS):
            if np.isfinite(norm) and norm**2 <= (1.0 - 2.0 * ARMIJO * step) * norm0**2:
                break
            if np.isfinite(norm):
                quadratic = step**2 * norm0**2 / (norm**2 - norm0**2 + 2.0 * step * norm0**2)
                step = min(max(quadratic, 0.1 * step), 0.5 * step)
            else:
                step *= 0.1
            self._set_iterate(x, a, self._dx, da, step)
            norm = self.residual(self._b)
        return norm

    def _slope(self, da, sign=1.0):
        """g = R·dx + share g_border da, the derivative of the energy along the Newton step
        (the border's equation times ``border.share`` is the energy's derivative in its
        unknown), for ``sign`` R in ``self._b``."""
        slope = sign * self._b.dot(self._dx)
        if self._border is not None:
            slope += self._border.share * self._border_g * da
        return slope

    def _critical_point(self, x, a, da):
        """The step λ where the energy is stationary along dx, g(λ) = R(x + λ dx)·dx = 0,
        to ``|g(λ)| ≤ CP_TOLERANCE |g(0)|`` (Crisfield 1991, vol. 1, sec. 9.3.2: a slack line
        search): the full step if the energy still falls there, else regula falsi on the
        bracket [0, 1], a trial step where the local return fails bisected toward the
        bracket's lower end; the full step too where g(0) ≥ 0 (dx is not a descent
        direction: an unsymmetric or indefinite tangent). It does not need ‖R‖ to fall:
        where points change mode (elastic, cap, corner) the residual norm rises along
        steps that lower the energy."""
        g0 = self._slope(da, sign=-1.0)   # self._b holds −R(x), the Newton right-hand side
        lo, g_lo, hi, g_hi, step = 0.0, g0, None, None, 1.0
        for _ in range(CP_TRIALS):
            self._set_iterate(x, a, self._dx, da, step)
            try:
                norm = self.residual(self._b)
            except ReturnMapError:
                norm = math.inf
            if not np.isfinite(norm):
                hi, g_hi, step = step, None, 0.5 * (lo + step)
                continue
            g = self._slope(da)
            if g0 >= 0.0 or abs(g) <= CP_TOLERANCE * abs(g0) or (g < 0.0 and hi is None):
                return norm
            if g < 0.0:
                lo, g_lo = step, g
            else:
                hi, g_hi = step, g
            step = lo + (hi - lo) * g_lo / (g_lo - g_hi) if g_hi is not None else 0.5 * (lo + hi)
            step = min(max(step, lo + 0.1 * (hi - lo)), hi - 0.1 * (hi - lo))
        if not np.isfinite(norm):
            raise NewtonFailure("the local return failed along the whole Newton step")
        return norm
