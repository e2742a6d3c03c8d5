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
import dolfinx.fem.petsc  # noqa: F401

from .forms import updated_lagrangian, virtual_work
from .forms.discretisation import Discretisation
from .interface.rigid_tool import RigidToolContact
from .scene import TOOL, Control
from .solver.newton import NewtonSolver
from .solver.quadrature import MaterialPoints
from .errors import InputError
from .tensors import rotation_matrix, ufl_from_mandel, ufl_mandel


class SoilProblem:
    def __init__(self, scene, tagged_mesh):
        self.scene, self.tagged = scene, tagged_mesh
        self._p1 = None
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
        frame = rotation_matrix(scene.analysis.frame_rotation)
        x = mesh.geometry.x   # the whole scene turned by the frame rotation
        x[:, :3] = x[:, :3] @ frame.T
        region_cells = {name: tagged_mesh.cell_tags.find(tagged_mesh.regions[name])
                        for name in scene.regions}
        models = {name: scene.materials[material] for name, material in scene.regions.items()}
        geostatic = scene.geostatic
        self.points = points = MaterialPoints(disc, w, self.w_committed, strain, region_cells,
                                              models, keep_strain=self.large,
                                              initial_stress=geostatic and geostatic.stress)
        if geostatic is not None and disc.element.mixed:
            self._initial_pressure()

        V = disc.displacement_space

        def facets(name):
            return tagged_mesh.facet_tags.find(tagged_mesh.boundaries[name])

        loading = scene.loading
        direction = frame @ loading.direction.vector
        self._prescribed = []   # (Constant, coefficient of the prescribed displacement)
        self.bcs = bcs = []
        for boundary, axes in self._constraints(scene).items():
            if len(axes) < 3 and not np.allclose(frame, np.eye(3)):
                raise InputError(f"analysis.frame_rotation: boundary {boundary!r} must be held in "
                                 f"all of x, y, z in a rotated frame (it holds {len(axes)})")
            local = np.array([axes.get(a, 0.0) for a in range(3)])
            components = (range(3) if len(axes) == 3 else axes)
            for i in components:
                coefficient = (frame @ local)[i] if len(axes) == 3 else local[i]
                dofs = fem.locate_dofs_topological(V.sub(i), tdim - 1, facets(boundary))
                value = fem.Constant(mesh, PETSc.ScalarType(0.0))
                if coefficient != 0.0:
                    self._prescribed.append((value, coefficient))
                bcs.append(fem.dirichletbc(value, dofs, V.sub(i)))
        if scene.analysis.plane_strain:   # the dofs of every cell
            cells = mesh.topology.index_map(tdim)
            all_cells = np.arange(cells.size_local + cells.num_ghosts, dtype=np.int32)
            dofs = fem.locate_dofs_topological(V.sub(1), tdim, all_cells)
            bcs.append(fem.dirichletbc(PETSc.ScalarType(0.0), dofs, V.sub(1)))

        tool = scene.tool
        self._drives_tool = loading.boundary == TOOL
        loaded = tool.faces if self._drives_tool else (loading.boundary,)
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=tagged_mesh.facet_tags)
        self._ds_load = ds(tuple(tagged_mesh.boundaries[name] for name in loaded))
        self._direction = direction
        self.contact = None
        if tool is not None and not tool.bonded:
            self.contact = RigidToolContact(disc, w, tagged_mesh.facet_tags,
                                            [tagged_mesh.boundaries[f] for f in tool.faces],
                                            tool.interface, bcs, incremental=self.large,
                                            initial_stress=geostatic and geostatic.stress)
        self._load = fem.Constant(mesh, PETSc.ScalarType(0.0))   # traction, force control
        self._magnitude = loading.magnitude
        # In large deformation w is the increment, so is a prescribed displacement.
        self._incremental = self.large and loading.control is Control.DISPLACEMENT
        self._factor = self._committed_factor = 0.0

        if self.large:
            internal = updated_lagrangian.internal_force(disc, points, w, v)
            F = updated_lagrangian.kinematics(disc, w)[0]   # traction per unit deformed area:
            da = updated_lagrangian.surface_stretch(F, ufl.FacetNormal(mesh))
        else:
            internal = virtual_work.internal_force(disc, points.stress, w, v)
            da = 1.0
        def traction(magnitude, axis_vector, measure):   # fixed direction, per deformed area
            t = ufl.as_vector(frame @ np.asarray(axis_vector))
            return magnitude * ufl.dot(t, disc.displacement(v)) * da * measure

        residual = internal
        if loading.control is Control.FORCE:
            residual -= traction(self._load, loading.direction.vector, self._ds_load)
        for dead in scene.tractions:
            residual -= traction(dead.magnitude, dead.direction.vector,
                                 ds(tagged_mesh.boundaries[dead.boundary]))
        if geostatic is not None:   # gravity, -γ e_z (per volume of the step's configuration)
            residual += geostatic.unit_weight * disc.displacement(v)[2] * disc.measure()
        if self.large:
            jacobian = ufl.derivative(residual, w, ufl.TrialFunction(disc.space))
            self._rotation = points.expression(updated_lagrangian.rotation(disc, w))
            self._motion = MeshMotion(disc, w)
        else:
            jacobian = virtual_work.material_stiffness(disc, points.tangent,
                                                       ufl.TrialFunction(disc.space), v)
        self.newton = NewtonSolver(self.comm, residual, jacobian, w, bcs, self._update, scene.solver,
                                   nodal_terms=[self.contact] if self.contact else [])
        if scene.tractions or geostatic is not None:   # loads present from the start set the scale
            dead_loads = fem.petsc.assemble_vector(fem.form(internal - residual))
            dead_loads.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            self.newton.include_force_scale(dead_loads.norm())
            dead_loads.destroy()

        # Observables on the loaded boundary. The force is the internal force on
        # the loaded dofs along the load direction: the reaction under
        # displacement control, the applied load (at equilibrium) under force control.
        probe = fem.Function(disc.space)
        for i in np.flatnonzero(direction):
            for name in loaded:
                probe.x.array[fem.locate_dofs_topological(V.sub(i), tdim - 1, facets(name))] \
                    = direction[i]
        probe.x.scatter_forward()
        self._force = fem.form(ufl.replace(internal, {v: probe}))
        one = fem.Constant(mesh, PETSc.ScalarType(1.0))
        self._area = fem.form(one * self._ds_load)
        self._displacement = fem.form(ufl.dot(ufl.as_vector(direction), self.total_displacement)
                                      * self._ds_load)

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

    @staticmethod
    def _constraints(scene):
        """Boundary -> {axis: coefficient of the prescribed displacement (0: a support)},
        axes in the scene's own frame. A bonded tool's faces move with it."""
        constraints = {}
        for support in scene.supports:
            for axis in support.fix:
                constraints.setdefault(support.boundary, {})["xyz".index(axis)] = 0.0
        loading = scene.loading
        if loading.control is Control.FORCE:
            return constraints
        if loading.boundary != TOOL:
            axis = loading.direction.axis
            constraints.setdefault(loading.boundary, {})[axis] = loading.direction.vector[axis]
        elif scene.tool.bonded:
            for face in scene.tool.faces:
                constraints[face] = dict(enumerate(loading.direction.vector))
        return constraints

    def _initial_pressure(self):
        """Start the mean-dilatation pressure at the projection of the initial mean stress,
        so that the initial state is in equilibrium."""
        P, to_parent = self.disc.space.sub(2).collapse()
        p, q = ufl.TrialFunction(P), ufl.TestFunction(P)
        mean_stress = ufl.tr(ufl_from_mandel(self.points.stress)) / 3.0
        dx = self.disc.measure()
        projection = fem.petsc.LinearProblem(p * q * dx, mean_stress * q * dx, petsc_options={
            "ksp_type": "preonly", "pc_type": "lu"}).solve()
        self.w.x.array[to_parent] = projection.x.array
        self.w_committed.x.array[:] = self.w.x.array

    def _update(self):
        """The constitutive and interface updates of one Newton iterate."""
        self.points.update()
        if self.contact is not None:
            self.contact.update()

    def displacement_p1(self):
        """The total displacement as a P1 Function (for output)."""
        if self.large:
            return self._motion.total
        if self._p1 is None:
            self._p1 = fem.Function(fem.VectorFunctionSpace(self.disc.mesh, ("Lagrange", 1)),
                                    name="displacement")
        self._p1.interpolate(self.w.sub(0).collapse() if self.disc.element.mixed else self.w)
        return self._p1

    def set_load_factor(self, factor):
        self._factor = factor
        self._load.value = factor * self._magnitude
        base = self._committed_factor if self._incremental else 0.0
        for value, coefficient in self._prescribed:
            value.value = (factor - base) * self._magnitude * coefficient
        if self.contact is not None and self._drives_tool:
            self.contact.tool_displacement = factor * self._magnitude * self._direction

    def solve(self):
        """Equilibrium at the current load factor, starting from the last committed state."""
        return self.newton.solve()

    def commit(self):
        self._committed_factor = self._factor
        if self.contact is not None:
            self.contact.commit()
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
        """(mean displacement, force) of the loaded boundary along the load direction; for a
        tool behind an interface, its displacement and the force that drives it."""
        if self.contact is not None and self._drives_tool:
            return (self._factor * self._magnitude,
                    -float(self.contact.force() @ self._direction))
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
