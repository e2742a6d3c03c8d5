"""Kinematics of the soil: small strain, or updated Lagrangian (chapter II).

A kinematics object says what the unknown ``w`` holds (the total
displacement, or the increment since the last converged configuration),
which strain increment the models integrate, how the internal force and its
Jacobian are formed, how a traction acting per unit deformed area scales,
and what a converged step does (commit the history, move the mesh).
Small strain builds none of the updated Lagrangian machinery.
"""
import numpy as np
import ufl
from dolfinx import fem

from ..forms import updated_lagrangian, virtual_work
from ..layout import DOFS, NODES
from ..tensors import ufl_mandel


class _Extrapolated:
    """The first iterate of a step: the last converged step's change of w scaled to this
    step (linear extrapolation of the solution path)."""
    _last_increment = None

    def predict(self, ratio):
        """w = w_n + ratio Δw_n, with w_n the step's start and Δw_n the last step's change."""
        if self._last_increment is not None:
            self._w.x.array[:] = self._w_committed.x.array + ratio * self._last_increment

    def _remember_increment(self):
        """Δw_n of the step that converges (before w_n moves on)."""
        self._last_increment = self._w.x.array - self._w_committed.x.array

    def state(self):
        """What the last converged step leaves for the next: name -> (``layout`` kind, array)."""
        return ({} if self._last_increment is None else
                {"last_increment": (DOFS, self._last_increment)})

    def restore(self, state):
        """Back to a :meth:`state` (w itself is the problem's)."""
        self._last_increment = state.get("last_increment")


class SmallStrain(_Extrapolated):
    """w holds the total displacement; the models integrate ε̄(w) − ε̄(w_n)."""
    incremental = False
    moves_mesh = False
    keeps_strain = False   # the forms read σ and C_tan only

    def __init__(self, disc, w, w_committed):
        self._disc, self._w, self._w_committed = disc, w, w_committed
        self._p1 = None

    def strain_increment(self):
        """(ε̄(w), ε̄(w_n)), whose difference the models integrate (the second evaluated once
        a step: :class:`~soilbin.solver.quadrature.MaterialPoints`)."""
        return (ufl_mandel(virtual_work.enhanced_strain(self._disc, self._w)),
                ufl_mandel(virtual_work.enhanced_strain(self._disc, self._w_committed)))

    def internal_force(self, points, v):
        return virtual_work.internal_force(self._disc, points.stress, self._w, v)

    def jacobian(self, residual, points, dw, v):
        return virtual_work.material_stiffness(self._disc, points.tangent, dw, v)

    def area_stretch(self):
        """da/dA of a loaded facet: 1 in small strain."""
        return 1.0

    def commit(self, points):
        points.commit()
        self._remember_increment()
        self._w_committed.x.array[:] = self._w.x.array

    def total_displacement(self):
        """The displacement from the initial configuration (UFL)."""
        return self._disc.displacement(self._w)

    def iterate_displacement(self):
        """The displacement from the initial configuration at the current iterate (UFL)."""
        return self.total_displacement()

    def volume_change(self):
        """Volumetric strain since the initial configuration, ε_v = div u (UFL)."""
        return self._disc.div(self.total_displacement())

    def displacement_p1(self):
        """The total displacement as a P1 Function (for output): its values at the nodes."""
        if self._p1 is None:
            self._p1 = fem.Function(fem.VectorFunctionSpace(self._disc.mesh, ("Lagrange", 1)),
                                    name="displacement")
            self._vertex_dofs = self._disc.vertex_dofs(self._p1.function_space)
        nodal = self._w.x.array[self._vertex_dofs]
        self._p1.x.array[:] = self._disc.in_mesh_axes(nodal).ravel()
        return self._p1


class UpdatedLagrangian(_Extrapolated):
    """w holds the increment from the last converged configuration Ω_n, which the mesh
    follows (``forms.updated_lagrangian``: Hughes–Winget objective update, eq. 2.64–2.66);
    a step starts from the last one's increment scaled to it (and, for mean-dilatation
    elements, its total pressure extrapolated)."""
    incremental = True
    moves_mesh = True
    keeps_strain = True    # the linearised stress needs the increment at the points

    def __init__(self, disc, w, w_committed):
        self._disc, self._w, self._w_committed = disc, w, w_committed
        self._motion = MeshMotion(disc, w)
        self._rotation = None

    def strain_increment(self):
        """(the increment of the models' strain since Ω_n, None): nothing to subtract."""
        return ufl_mandel(updated_lagrangian.model_strain(self._disc, self._w)), None

    def internal_force(self, points, v):
        return updated_lagrangian.internal_force(self._disc, points, self._w, v)

    def jacobian(self, residual, points, dw, v):
        """The Gateaux derivative of the residual: material, initial-stress and rotation terms."""
        return ufl.derivative(residual, self._w, dw)

    def area_stretch(self):
        """da/dA of a loaded facet (Nanson): tractions act per unit deformed area."""
        F = updated_lagrangian.kinematics(self._disc, self._w)[0]
        return updated_lagrangian.surface_stretch(F, self._disc.normal())

    def commit(self, points):
        """Rotate the history, move the mesh, start the next increment from zero."""
        if self._rotation is None:
            self._rotation = points.expression(updated_lagrangian.rotation(self._disc, self._w))
        points.commit(points.evaluate(self._rotation).reshape(-1, 3, 3))
        self._remember_increment()
        self._motion.advance()
        self._w_committed.x.array[:] = self._w.x.array
        points.update()   # the committed state: σ_{n+1} on the moved mesh

    def total_displacement(self):
        """The displacement from the initial configuration (UFL, three components)."""
        return self._disc.embed(self._motion.total)

    def iterate_displacement(self):
        """The displacement from the initial configuration at the current iterate: the
        converged total and the step's increment (UFL)."""
        return self.total_displacement() + self._disc.displacement(self._w)

    def volume_change(self):
        """dV/dV0 − 1 = 1/det(I − ∇u) − 1, with u the total displacement on the current mesh."""
        grad = self._disc.grad(self.total_displacement())
        return 1.0 / ufl.det(ufl.Identity(3) - grad) - 1.0

    def displacement_p1(self):
        return self._motion.total

    def node_increment(self):
        """The iterate's increment at the mesh's nodes, (n_nodes, dim): where it would move them."""
        return self._motion.node_increment()

    def state(self):
        """The extrapolation's increment and the mesh's position."""
        return {**super().state(), **self._motion.state()}

    def restore(self, state):
        super().restore(state)
        self._motion.restore(state)


def kinematics_of(analysis, disc, w, w_committed):
    """The kinematics a scene's analysis options ask for."""
    kind = UpdatedLagrangian if analysis.large_deformation else SmallStrain
    return kind(disc, w, w_committed)


class MeshMotion:
    """Moves the mesh by the converged increment and accumulates the total displacement.

    The increment is taken at the vertices onto the trilinear geometry (exact
    for hex8; at the vertices for hex27). The dilatation increment of
    mean-dilatation elements starts each step from zero; the pressure is
    total and carries over.
    """

    def __init__(self, disc, w):
        mesh = disc.mesh
        self._w, self._disc = w, disc
        V1 = fem.VectorFunctionSpace(mesh, ("Lagrange", 1))
        self.total = fem.Function(V1, name="displacement")
        cells = mesh.topology.index_map(mesh.topology.dim)
        n_cells = cells.size_local + cells.num_ghosts
        self._nodes = mesh.geometry.dofmap.array.reshape(n_cells, -1).ravel()
        self._dofs = V1.dofmap.list.array.reshape(n_cells, -1).ravel()
        self._x = mesh.geometry.x
        self._vertex_dofs = disc.vertex_dofs(V1)
        if disc.element.mixed:   # the displacement and dilatation dofs (the pressure carries over)
            self._reset = np.unique(np.concatenate(
                [disc.displacement_space.sub(i).dofmap.list.array for i in range(disc.dimension)]
                + [disc.space.sub(1).dofmap.list.array]))
        else:
            self._reset = slice(None)

    def _increment(self):
        return self._disc.in_mesh_axes(self._w.x.array[self._vertex_dofs])

    def node_increment(self):
        """(n_nodes, dim): the increment at each node of the mesh's geometry."""
        out = np.zeros((len(self._x), self._disc.dimension))
        out[self._nodes] = self._increment()[self._dofs]
        return out

    def advance(self):
        dim = self._disc.dimension
        du = self._increment()
        self._x[self._nodes, :dim] = self._x[self._nodes, :dim] + du[self._dofs]
        self.total.x.array[:] += du.ravel()
        self._w.x.array[self._reset] = 0.0

    def state(self):
        """The mesh's nodes and the total displacement at them."""
        total = np.zeros_like(self._x)
        dim = self._disc.dimension
        total[self._nodes, :dim] = self.total.x.array.reshape(-1, dim)[self._dofs]
        return {"mesh_x": (NODES, self._x), "total_displacement": (NODES, total)}

    def restore(self, state):
        self._x[:] = state["mesh_x"]
        dim = self._disc.dimension
        total = state["total_displacement"]
        self.total.x.array.reshape(-1, dim)[self._dofs] = total[self._nodes, :dim]
