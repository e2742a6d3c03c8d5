"""The discrete problem of a scene: spaces, material points, supports, loading, forms.

:class:`SoilProblem` is what the load stepper drives: set a load factor,
solve for equilibrium with Newton, commit or roll back, and observe the
loaded boundary (its mean displacement and the force it carries, both
along the loading direction).
"""
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc
from dolfinx import fem

from .forms.discretisation import Discretisation
from .forms.virtual_work import internal_force, material_stiffness
from .scene import Control
from .solver.newton import NewtonSolver
from .solver.quadrature import MaterialPoints


class SoilProblem:
    def __init__(self, scene, tagged_mesh):
        mesh = tagged_mesh.mesh
        self.comm = mesh.comm
        self.disc = disc = Discretisation.create(mesh, scene.analysis.element)
        self.w = fem.Function(disc.space, name="solution")
        self.w_committed = fem.Function(disc.space)

        tdim = mesh.topology.dim
        region_cells = {name: tagged_mesh.cell_tags.find(tagged_mesh.regions[name])
                        for name in scene.regions}
        models = {name: scene.materials[material] for name, material in scene.regions.items()}
        self.points = MaterialPoints(disc, self.w, self.w_committed, region_cells, models)

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
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=tagged_mesh.facet_tags)
        ds_load = ds(tagged_mesh.boundaries[loading.boundary])
        direction = ufl.as_vector(loading.direction.vector)
        v = ufl.TestFunction(disc.space)
        residual = internal_force(disc, self.points.stress, self.w, v)
        self._load = fem.Constant(mesh, PETSc.ScalarType(0.0))   # traction or displacement
        loaded_dofs = fem.locate_dofs_topological(V.sub(loading.direction.axis), tdim - 1,
                                                  facets(loading.boundary))
        # Load factor 1 is the traction magnitude along the direction, or the
        # displacement of the loaded component (signed by the direction).
        self._full_load = loading.magnitude
        if loading.control is Control.DISPLACEMENT:
            self._full_load *= loading.direction.vector[loading.direction.axis]
            bcs.append(fem.dirichletbc(self._load, loaded_dofs, V.sub(loading.direction.axis)))
        else:
            residual -= self._load * ufl.dot(direction, disc.displacement(v)) * ds_load
        self.bcs = bcs

        jacobian = material_stiffness(disc, self.points.tangent, ufl.TrialFunction(disc.space), v)
        self.newton = NewtonSolver(self.comm, residual, jacobian, self.w, bcs,
                                   self.points.update, scene.solver)

        # Observables on the loaded boundary. The force is the internal force on
        # the loaded dofs along the load direction: the reaction under
        # displacement control, the applied load (at equilibrium) under force control.
        self._probe = fem.Function(disc.space)
        self._probe.x.array[loaded_dofs] = loading.direction.vector[loading.direction.axis]
        self._probe.x.scatter_forward()
        self._force = fem.form(internal_force(disc, self.points.stress, self.w, self._probe))
        self.area = self._sum(fem.form(fem.Constant(mesh, PETSc.ScalarType(1.0)) * ds_load))
        self._displacement = fem.form(ufl.dot(direction, disc.displacement(self.w)) * ds_load)

    def _sum(self, form):
        return self.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)

    @property
    def n_dofs(self):
        imap = self.disc.space.dofmap.index_map
        return imap.size_global * self.disc.space.dofmap.index_map_bs

    def set_load_factor(self, factor):
        self._load.value = factor * self._full_load

    def solve(self):
        """Equilibrium at the current load factor, starting from the last committed state."""
        return self.newton.solve()

    def commit(self):
        self.points.commit()
        self.w_committed.x.array[:] = self.w.x.array

    def roll_back(self):
        self.w.x.array[:] = self.w_committed.x.array

    def observe(self):
        """(mean displacement, force) of the loaded boundary along the load direction."""
        return self._sum(self._displacement) / self.area, self._sum(self._force)
