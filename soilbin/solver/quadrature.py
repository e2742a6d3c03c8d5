"""Material-point data on quadrature points: σ and C_tan for the forms, history per region.

Quadrature-space Functions hold the current stress (Mandel 6-vector) and
consistent tangent (6x6) that the virtual-work forms read. Each region (a
cell group) has its own model and committed history; one call to
:meth:`MaterialPoints.update` runs every model once, vectorised over the
region's points, and the trial history becomes committed only in
:meth:`commit`, after the load step converged.
"""
import basix
import basix.cell
import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from ..errors import ReturnMapError
from ..layout import POINTS
from ..tensors import from_mandel, to_mandel
from .linear_solver import all_symmetric

#: The history every point holds beside its model's: the plastic work per unit volume done
#: on it so far, sigma : deps_p summed over the converged steps
#: (:meth:`~soilbin.models.elastic.IsotropicElasticity.plastic_work`).
PLASTIC_WORK = "plastic_work"


def quadrature_space(mesh, degree, shape=None):
    """Quadrature space on the default Gauss rule of ``degree``: scalar, 6-vector or 6x6."""
    cell = mesh.ufl_cell()
    if shape is None:
        element = ufl.FiniteElement("Quadrature", cell, degree, quad_scheme="default")
    elif len(shape) == 1:
        element = ufl.VectorElement("Quadrature", cell, degree, dim=shape[0], quad_scheme="default")
    else:
        element = ufl.TensorElement("Quadrature", cell, degree, shape=shape, quad_scheme="default")
    return fem.FunctionSpace(mesh, element)


def _as_slice(index):
    """``index`` as the slice it equals if it is a contiguous ascending range, else itself."""
    if len(index) and np.array_equal(index, np.arange(index[0], index[0] + len(index))):
        return slice(int(index[0]), int(index[0]) + len(index))
    return index


class MaterialPoints:
    """Stress, tangent and history at every quadrature point of the local (owned + ghost) cells."""

    def __init__(self, disc, w, w_committed, strain_increment, region_cells, models, keep_strain=False,
                 initial_stress=None, tangent_floor=0.0):
        """``strain_increment``: (ε, ε_n), UFL Mandel vectors whose difference is the strain
        increment the models integrate; ε_n, a strain of the committed state (None: ε is the
        increment itself), is evaluated again only where ``w_committed`` changed (one strain
        at every iterate instead of two, and the same numbers to the bit: FFCx evaluates a
        difference as ε + (−1) ε_n); ``region_cells``: region name ->
        local cell indices; ``models``: region name -> model; ``keep_strain``: also hold that
        increment at the points in the Function ``strain`` (the updated Lagrangian forms need
        it); ``initial_stress(x)``: the stress (n, 6) at the points x (n, 3); ``tangent_floor``:
        the fraction of each nonlinear model's elastic stiffness added to its tangent."""
        mesh = disc.mesh
        degree = disc.element.quadrature_degree
        points, _ = basix.make_quadrature(basix.cell.string_to_type(disc.element.cell), degree)
        self.points_per_cell = len(points)
        imap = mesh.topology.index_map(mesh.topology.dim)
        self._cells = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
        n_points = len(self._cells) * self.points_per_cell

        self.stress = fem.Function(quadrature_space(mesh, degree, (6,)), name="stress_q")
        self.tangent = fem.Function(quadrature_space(mesh, degree, (6, 6)), name="tangent_q")
        # Position of each evaluated point (cell-major, as Expression.eval) in the Functions.
        self._slot = self.stress.function_space.dofmap.list.array
        self.strain = (fem.Function(self.stress.function_space, name="strain_q")
                       if keep_strain else None)
        self._w, self._w_committed = w, w_committed
        self._comm = mesh.comm
        strain, strain_n = strain_increment
        self._strain = fem.Expression(strain, points)
        self._strain_n = None if strain_n is None else fem.Expression(strain_n, points)
        self._strain_n_values = self._strain_n_of = None   # ε_n at the points, and its w_n
        self._points = points

        covered = np.concatenate([np.asarray(c) for c in region_cells.values()])
        if len(np.unique(covered)) != len(self._cells):
            raise ValueError("every cell must belong to exactly one material region")
        self.models = dict(models)
        self.index = {name: (np.asarray(cells, dtype=np.int64)[:, None] * self.points_per_cell
                             + np.arange(self.points_per_cell)).ravel()
                      for name, cells in region_cells.items()}
        # the update's view of each region: a slice where its points are a contiguous range
        # (one region: all of them), so that deps[part] and the writes copy no index
        self._parts = {name: _as_slice(idx) for name, idx in self.index.items()}
        stress0 = None
        if initial_stress is not None:
            x = self.evaluate(self.expression(disc.coordinates()))
            stress0 = initial_stress(x)
        self.committed = {name: {**self.models[name].initial_state(
                                     len(idx), None if stress0 is None else stress0[idx]),
                                 PLASTIC_WORK: np.zeros(len(idx))}
                          for name, idx in self.index.items()}
        self.trial = dict(self.committed)
        self._increment = None   # the strain increment of the trial states
        # Stress and tangent in evaluation order: views of the Functions' values where their
        # dof order is the evaluation order (no copy to write), else arrays copied over.
        self._in_order = np.array_equal(self._slot, np.arange(n_points))
        self._stress = self._values(self.stress, (6,))
        self._tangent = self._values(self.tangent, (6, 6))
        self._tangent_frozen = False
        self._converged_tangent = None
        self.tangent_floor = 0.0
        self.floor_tangent(tangent_floor)

    def start(self):
        """The first update, at zero increment: the initial stress and the elastic tangent,
        the last converged one of the first step. Apart from the constructor, so that a
        problem can build (compile) its forms before the models' kernels are first called
        (:mod:`soilbin.solver.ahead`)."""
        self.update()
        self._converged_tangent = self._tangent.copy()

    def floor_tangent(self, eps):
        """C_tan + eps C_el at every point of a nonlinear model, from the next update on and
        in the last converged tangent (a step's first iterate): the residual reads the stress
        only, so the floor moves Newton's matrix and not its solution."""
        change, self.tangent_floor = eps - self.tangent_floor, eps
        self._floor = {name: eps * model.stiffness for name, model in self.models.items()
                       if eps > 0.0 and not model.linear}
        if self._converged_tangent is not None:
            for name, idx in self.index.items():
                if not self.models[name].linear:
                    self._converged_tangent[idx] += change * self.models[name].stiffness

    def _values(self, function, shape):
        """The per-point values (n_points, *shape) of a quadrature Function in evaluation
        order: a view of its array if that is its order, else a zero array of that shape."""
        n_points = len(self._slot)
        if self._in_order:
            function.x.array[:] = 0.0
            return function.x.array.reshape((n_points,) + shape)
        return np.zeros((n_points,) + shape)

    def write(self, values, function):
        """Copy per-point values (n_points, ...), in evaluation order, into a quadrature Function
        (nothing to do for the views of :meth:`_values`)."""
        if np.may_share_memory(values, function.x.array):
            return
        block = values.reshape(len(values), -1)
        function.x.array.reshape(len(values), -1)[self._slot] = block

    def strain_increment(self):
        """The strain increment at every local point, (n_points, 6), for the current iterate."""
        strain = self.evaluate(self._strain)
        if self._strain_n is None:
            return strain
        committed = self._w_committed.x.array
        if self._strain_n_of is None or not np.array_equal(self._strain_n_of, committed):
            self._strain_n_values = self.evaluate(self._strain_n)
            self._strain_n_of = committed.copy()
        strain -= self._strain_n_values
        return strain

    def update(self):
        """One constitutive update at the current iterate: σ, C_tan and trial history;
        ReturnMapError on every rank if a local return failed on any.

        At the committed state itself (the first iterate of a load step) the
        stress is the committed one and the tangent the last converged one, so
        Newton's first correction is elasto-plastic rather than elastic. Elsewhere
        the returns may start from the last iterate's states (``guess``).
        """
        if self._at_committed_state():
            self.trial = dict(self.committed)
            self._increment = None
            for name, idx in self.index.items():
                self._stress[idx] = self.committed[name]["stress"]
            if not self._tangent_frozen:
                self._tangent[:] = self._converged_tangent
            if self.strain is not None:
                self.strain.x.array[:] = 0.0
        else:
            deps = self._increment = self.strain_increment()
            if self.strain is not None:
                self.write(deps, self.strain)
            failure = ""
            try:
                for name, part in self._parts.items():
                    # a region's points in one range: its tangent written in place
                    into = (self._tangent[part]
                            if isinstance(part, slice) and not self._tangent_frozen else None)
                    sigma, tangent, state = self.models[name].update(
                        deps[part], self.committed[name], guess=self.trial[name], tangent=into)
                    self._stress[part] = sigma
                    if not self._tangent_frozen:
                        if into is None:
                            self._tangent[part] = tangent
                        if name in self._floor:
                            self._tangent[part] += self._floor[name]
                    self.trial[name] = state
            except ReturnMapError as err:
                failure = str(err)
            # every rank stops together (a rank alone would leave the others in assembly)
            failures = [f for f in self._comm.allgather(failure) if f]
            if failures:
                raise ReturnMapError(failures[0])
        self.write(self._stress, self.stress)
        if not self._tangent_frozen:
            self.write(self._tangent, self.tangent)
            # Linear models have a constant tangent: write it once.
            self._tangent_frozen = all(m.linear for m in self.models.values())

    def tangent_symmetric(self):
        """Whether the tangent at every point of every rank is symmetric (to round-off)."""
        return all_symmetric(self._tangent, self._comm)

    def _at_committed_state(self):
        """Whether the iterate is the committed state on every rank (collective: the ranks
        take the same branch of :meth:`update`, whose other gathers failures; a rank whose
        soil has not moved, e.g. a block not yet pressed, is not at it alone)."""
        return self._comm.allreduce(
            self._converged_tangent is not None
            and bool(np.array_equal(self._w.x.array, self._w_committed.x.array)), op=MPI.LAND)

    def expression(self, ufl_expression):
        """Compile a UFL expression at the quadrature points (for :meth:`evaluate`)."""
        return fem.Expression(ufl_expression, self._points)

    def evaluate(self, expression):
        """A compiled expression at every local point, (n_points, value size)."""
        return expression.eval(self._cells).reshape(len(self._cells) * self.points_per_cell, -1)

    def commit(self, rotation=None):
        """The trial history of the converged iterate becomes the committed history.

        ``rotation`` (n_points, 3, 3), if given, turns every symmetric-tensor
        history (shape (6,), stress included) with it: h -> R h Rᵀ. The plastic work of
        each point (:data:`PLASTIC_WORK`) grows by its increment's.
        """
        for name, part in self._parts.items():
            if PLASTIC_WORK not in self.trial[name]:   # returned from the committed state
                committed, trial = self.committed[name], self.trial[name]
                work = self.models[name].plastic_work(self._increment[part], committed["stress"],
                                                      trial["stress"])
                self.trial[name] = {**trial, PLASTIC_WORK: committed[PLASTIC_WORK] + work}
        self.committed = dict(self.trial)
        if rotation is not None:
            for name, state in self.committed.items():
                idx = self.index[name]
                self.committed[name] = {
                    key: (to_mandel(rotation[idx] @ from_mandel(value) @ rotation[idx].transpose(0, 2, 1))
                          if value.shape[1:] == (6,) else value)
                    for key, value in state.items()}
        if not self._tangent_frozen:
            self._converged_tangent = self._tangent.copy()

    def state(self):
        """The committed history of every region and the last converged tangent, over all
        local points: name -> (``layout`` kind, array), for :meth:`restore`."""
        state = {}
        for name, history in self.committed.items():
            for key, value in history.items():
                full = np.zeros((len(self._cells) * self.points_per_cell,) + value.shape[1:],
                                dtype=value.dtype)
                full[self.index[name]] = value
                state[f"{name}/{key}"] = (POINTS, full)
        return {**state, "converged_tangent": (POINTS, self._converged_tangent)}

    def restore(self, state):
        """Back to a :meth:`state`, the unknowns already at that state: its stress and
        tangent are written for the forms."""
        self.committed = {name: {key: state[f"{name}/{key}"][self.index[name]] for key in history}
                          for name, history in self.committed.items()}
        self._converged_tangent = state["converged_tangent"]
        self.update()

    def settle_history(self):
        """Each region's committed history made consistent by its model
        (:meth:`~soilbin.models.base.Model.consistent_history`), after a transfer."""
        self.committed = {name: self.models[name].consistent_history(state)
                          for name, state in self.committed.items()}
        self.trial = dict(self.committed)

    def history(self, key):
        """A committed history variable over all local points (n_points, ...), zero where absent."""
        states = [(self.index[name], s[key]) for name, s in self.committed.items() if key in s]
        shape = states[0][1].shape[1:] if states else ()
        out = np.zeros((len(self._cells) * self.points_per_cell,) + shape)
        for idx, values in states:
            out[idx] = values
        return out
