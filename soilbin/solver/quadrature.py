"""Material-point data on quadrature points: σ and C_tan for the forms, history per region.

Quadrature-space Functions hold the current stress (Mandel 6-vector) and
consistent tangent (6x6) that the virtual-work forms read. Each region (a
cell group) has its own model and committed history; one call to
:meth:`MaterialPoints.update` runs every model once, vectorised over the
region's points, and the trial history becomes committed only in
:meth:`commit`, after the load step converged.
"""
import basix
import numpy as np
import ufl
from dolfinx import fem

from ..tensors import ufl_mandel
from ..forms.virtual_work import enhanced_strain


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


class MaterialPoints:
    """Stress, tangent and history at every quadrature point of the local (owned + ghost) cells."""

    def __init__(self, disc, w, w_committed, region_cells, models):
        """``region_cells``: region name -> local cell indices; ``models``: region name -> model."""
        mesh = disc.mesh
        degree = disc.element.quadrature_degree
        points, _ = basix.make_quadrature(basix.CellType.hexahedron, degree)
        self.points_per_cell = len(points)
        imap = mesh.topology.index_map(mesh.topology.dim)
        self._cells = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
        n_points = len(self._cells) * self.points_per_cell

        self.stress = fem.Function(quadrature_space(mesh, degree, (6,)), name="stress_q")
        self.tangent = fem.Function(quadrature_space(mesh, degree, (6, 6)), name="tangent_q")
        # Position of each evaluated point (cell-major, as Expression.eval) in the Functions.
        self._slot = self.stress.function_space.dofmap.list.array
        # Strain increment from the last committed state, Δε̄ = ε̄(w) - ε̄(w_n).
        self._w, self._w_committed = w, w_committed
        self._deps = fem.Expression(
            ufl_mandel(enhanced_strain(disc, w)) - ufl_mandel(enhanced_strain(disc, w_committed)),
            points)

        covered = np.concatenate([np.asarray(c) for c in region_cells.values()])
        if len(np.unique(covered)) != len(self._cells):
            raise ValueError("every cell must belong to exactly one material region")
        self.models = dict(models)
        self.index = {name: (np.asarray(cells, dtype=np.int64)[:, None] * self.points_per_cell
                             + np.arange(self.points_per_cell)).ravel()
                      for name, cells in region_cells.items()}
        self.committed = {name: self.models[name].initial_state(len(idx))
                          for name, idx in self.index.items()}
        self.trial = dict(self.committed)
        self._stress = np.zeros((n_points, 6))
        self._tangent = np.zeros((n_points, 6, 6))
        self._tangent_frozen = False
        self._converged_tangent = None
        self.update()   # zero increment: the initial stress and the elastic tangent
        self._converged_tangent = self._tangent.copy()

    def write(self, values, function):
        """Copy per-point values (n_points, ...), in evaluation order, into a quadrature Function."""
        block = values.reshape(len(values), -1)
        function.x.array.reshape(len(values), -1)[self._slot] = block

    def strain_increment(self):
        """Δε̄ at every local point, (n_points, 6), for the current iterate."""
        return self._deps.eval(self._cells).reshape(-1, 6)

    def update(self):
        """One constitutive update at the current iterate: σ, C_tan and trial history.

        At the committed state itself (the first iterate of a load step) the
        stress is the committed one and the tangent the last converged one, so
        Newton's first correction is elasto-plastic rather than elastic.
        """
        if self._at_committed_state():
            self.trial = dict(self.committed)
            for name, idx in self.index.items():
                self._stress[idx] = self.committed[name]["stress"]
            if not self._tangent_frozen:
                self._tangent[:] = self._converged_tangent
        else:
            deps = self.strain_increment()
            for name, idx in self.index.items():
                sigma, tangent, state = self.models[name].update(deps[idx], self.committed[name])
                self._stress[idx] = sigma
                if not self._tangent_frozen:
                    self._tangent[idx] = tangent
                self.trial[name] = state
        self.write(self._stress, self.stress)
        if not self._tangent_frozen:
            self.write(self._tangent, self.tangent)
            # Linear models have a constant tangent: write it once.
            self._tangent_frozen = all(m.linear for m in self.models.values())

    def _at_committed_state(self):
        return (self._converged_tangent is not None
                and np.array_equal(self._w.x.array, self._w_committed.x.array))

    def commit(self):
        """The trial history of the converged iterate becomes the committed history."""
        self.committed = dict(self.trial)
        if not self._tangent_frozen:
            self._converged_tangent = self._tangent.copy()

    def history(self, key):
        """A committed history variable over all local points (n_points, ...), zero where absent."""
        states = [(self.index[name], s[key]) for name, s in self.committed.items() if key in s]
        shape = states[0][1].shape[1:] if states else ()
        out = np.zeros((len(self._cells) * self.points_per_cell,) + shape)
        for idx, values in states:
            out[idx] = values
        return out
