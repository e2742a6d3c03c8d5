"""The discrete problem of a scene: spaces, material points, supports, loading, forms.

:class:`SoilProblem` is what the load stepper drives: set a load factor,
solve for equilibrium with Newton, commit or roll back, and observe the
loaded boundary (its mean displacement and the force it carries, both
along the loading direction).

Small deformation: the unknown w holds total displacement (and the
mean-dilatation fields); the models integrate ε̄(w) − ε̄(w_n). Large
deformation (updated Lagrangian, ``forms.updated_lagrangian``): w holds the
increment from the last converged configuration, which the mesh follows;
the total displacement is accumulated for output.
"""
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc
from dolfinx import fem

from .forms import updated_lagrangian, virtual_work
from .forms.discretisation import Discretisation
from .scene import Control
from .solver.newton import NewtonSolver
from .solver.quadrature import MaterialPoints
from .tensors import ufl_mandel


class SoilProblem:
    def __init__(self, scene, tagged_mesh):
        mesh = tagged_mesh.mesh
        self.comm = mesh.comm
        self.large = scene.analysis.large_deformation
        self.disc = disc = Discretisation.create(mesh, scene.analysis.element)
        self.w = fem.Function(disc.space, name="solution")
        self.w_committed = fem.Function(disc.space)
        w, v = self.w, ufl.TestFunction(disc.space)

        if self.large:
            strain = ufl_mandel(updated_lagrangian.model_strain(disc, w))
        else:
            strain = (ufl_mandel(virtual_work.enhanced_strain(disc, w))
                      - ufl_mandel(virtual_work.enhanced_strain(disc, self.w_committed)))
        tdim = mesh.topology.dim
        region_cells = {name: tagged_mesh.cell_tags.find(tagged_mesh.regions[name])
                        for name in scene.regions}
        models = {name: scene.materials[material] for name, material in scene.regions.items()}
        self.points = points = MaterialPoints(disc, w, self.w_committed, strain, region_cells,
                                              models, keep_strain=self.large)

        V = disc.displacement_space

        def facets(name):
            return tagged_mesh.facet_tags.find(tagged_mesh.boundaries[name])

        zero = PETSc.ScalarType(0.0)
        bcs = []
        for support in scene.supports:
            for axis in support.fix:
                i = "xyz".index(axis)
                dofs = fem.locate_dofs_topological(V.sub(i), tdim - 1, facets(support.boundary))
                bcs.append(fem.dirichletbc(zero, dofs, V.sub(i)))
        if scene.analysis.plane_strain:   # the dofs of every cell
            cells = mesh.topology.index_map(tdim)
            all_cells = np.arange(cells.size_local + cells.num_ghosts, dtype=np.int32)
            dofs = fem.locate_dofs_topological(V.sub(1), tdim, all_cells)
            bcs.append(fem.dirichletbc(zero, dofs, V.sub(1)))

        loading = scene.loading
        axis, sign = loading.direction.axis, loading.direction.vector[loading.direction.axis]
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=tagged_mesh.facet_tags)
        self._ds_load = ds(tagged_mesh.boundaries[loading.boundary])
        direction = ufl.as_vector(loading.direction.vector)
        loaded_dofs = fem.locate_dofs_topological(V.sub(axis), tdim - 1, facets(loading.boundary))
        self._load = fem.Constant(mesh, PETSc.ScalarType(0.0))   # traction or displacement
        # Load factor 1 is the traction magnitude along the direction, or the
        # displacement of the loaded component (signed by the direction).
        self._full_load = loading.magnitude
        # In large deformation w is the increment, so is a prescribed displacement.
        self._incremental_load = self.large and loading.control is Control.DISPLACEMENT
        self._factor = self._committed_factor = 0.0
        if loading.control is Control.DISPLACEMENT:
            self._full_load *= sign
            bcs.append(fem.dirichletbc(self._load, loaded_dofs, V.sub(axis)))
        self.bcs = bcs

        if self.large:
            internal = updated_lagrangian.internal_force(disc, points, w, v)
            F = updated_lagrangian.kinematics(disc, w)[0]   # traction per unit deformed area:
            da = updated_lagrangian.surface_stretch(F, ufl.FacetNormal(mesh))
        else:
            internal = virtual_work.internal_force(disc, points.stress, w, v)
            da = 1.0
        residual = internal
        if loading.control is Control.FORCE:   # a fixed direction
            residual = internal - self._load * ufl.dot(direction, disc.displacement(v)) * da * self._ds_load
        if self.large:
            jacobian = ufl.derivative(residual, w, ufl.TrialFunction(disc.space))
            self._rotation = points.expression(updated_lagrangian.rotation(disc, w))
            self._motion = MeshMotion(disc, w)
        else:
            jacobian = virtual_work.material_stiffness(disc, points.tangent,
                                                       ufl.TrialFunction(disc.space), v)
        self.newton = NewtonSolver(self.comm, residual, jacobian, w, bcs, points.update, scene.solver)

        # Observables on the loaded boundary. The force is the internal force on
        # the loaded dofs along the load direction: the reaction under
        # displacement control, the applied load (at equilibrium) under force control.
        probe = fem.Function(disc.space)
        probe.x.array[loaded_dofs] = sign
        probe.x.scatter_forward()
        self._force = fem.form(ufl.replace(internal, {v: probe}))
        one = fem.Constant(mesh, PETSc.ScalarType(1.0))
        self._area = fem.form(one * self._ds_load)
        self._displacement = fem.form(ufl.dot(direction, self.total_displacement) * self._ds_load)

    def _sum(self, form):
        return self.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)

    @property
    def n_dofs(self):
        imap = self.disc.space.dofmap.index_map
        return imap.size_global * self.disc.space.dofmap.index_map_bs

    @property
    def area(self):
        """Area of the loaded boundary (current configuration)."""
        return self._sum(self._area)

    @property
    def total_displacement(self):
        """The displacement from the initial configuration (UFL)."""
        return self._motion.total if self.large else self.disc.displacement(self.w)

    def set_load_factor(self, factor):
        self._factor = factor
        base = self._committed_factor if self._incremental_load else 0.0
        self._load.value = (factor - base) * self._full_load

    def solve(self):
        """Equilibrium at the current load factor, starting from the last committed state."""
        return self.newton.solve()

    def commit(self):
        self._committed_factor = self._factor
        if self.large:   # rotate the history, move the mesh, start the next increment
            self.points.commit(self.points.evaluate(self._rotation).reshape(-1, 3, 3))
            self._motion.advance()
            self.w_committed.x.array[:] = self.w.x.array
            self.points.update()   # the committed state: σ_{n+1} on the moved mesh
        else:
            self.points.commit()
            self.w_committed.x.array[:] = self.w.x.array

    def roll_back(self):
        self.w.x.array[:] = self.w_committed.x.array

    def observe(self):
        """(mean displacement, force) of the loaded boundary along the load direction."""
        return self._sum(self._displacement) / self.area, self._sum(self._force)


class MeshMotion:
    """Moves the mesh by the converged increment and accumulates the total displacement.

    The increment is interpolated onto the trilinear geometry (exact for
    hex8; at the vertices for hex27). The dilatation increment of
    mean-dilatation elements starts each step from zero; the pressure is
    total and carries over.
    """

    def __init__(self, disc, w):
        mesh = disc.mesh
        self._w, self._disc = w, disc
        V1 = fem.VectorFunctionSpace(mesh, ("Lagrange", 1))
        self.total = fem.Function(V1, name="displacement")
        self._increment = fem.Function(V1)
        cells = mesh.topology.index_map(3)
        n_cells = cells.size_local + cells.num_ghosts
        self._nodes = mesh.geometry.dofmap.array.reshape(n_cells, -1).ravel()
        self._dofs = V1.dofmap.list.array.reshape(n_cells, -1).ravel()
        self._x = mesh.geometry.x
        if disc.element.mixed:
            _, self._reset = disc.space.sub(0).collapse()
            _, dilatation = disc.space.sub(1).collapse()
            self._reset = np.concatenate([self._reset, dilatation])
        else:
            self._reset = slice(None)

    def advance(self):
        source = self._w.sub(0).collapse() if self._disc.element.mixed else self._w
        self._increment.interpolate(source)
        du = self._increment.x.array.reshape(-1, 3)
        self._x[self._nodes, :3] = self._x[self._nodes, :3] + du[self._dofs]
        self.total.x.array[:] += self._increment.x.array
        self._w.x.array[self._reset] = 0.0
