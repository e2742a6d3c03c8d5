"""The loads on the soil: supports, the driven boundary, dead tractions, gravity, in-situ stress.

A boundary driven by the load factor (``loading.boundary`` a facet group)
is a :class:`BoundaryLoad`: a traction under force control, a prescribed
displacement under displacement control. Its observables are the mean
displacement of the boundary and the force on it, both along the loading
direction: the force is the internal force of the soil on the boundary's
dofs (the reaction under displacement control, the applied load at
equilibrium under force control). A node that a support holds in a component
stays held in it where the driven boundary meets the support (e.g. the toe of
a wall pushed over soil held below it): only the boundary's other nodes move.
The force counts such a node's reaction in proportion to its tributary area on
the driven boundary over that on the boundary and the supports holding it (a
half at the toe of a wall on a uniform mesh): the reaction is the traction
integrated against the node's shape function over both, and this split of it
is exact where the traction is uniform about the node, O(h²) where smooth.
"""
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc
from dolfinx import fem, la
import dolfinx.fem.petsc  # noqa: F401

from ..errors import InputError
from ..layout import GLOBAL
from ..records.scene import TOOL, Control
from ..solver.resources import release
from ..solver.stepping import Observation
from ..tensors import ufl_from_mandel


def facets(tagged, name):
    return tagged.facet_tags.find(tagged.boundaries[name])


def probe(disc, tagged, boundaries, vector, supports, only=None):
    """A function of the unknown's space equal to ``vector`` (dof components: the scene's
    axes) on the displacement dofs of the named boundaries and zero elsewhere: the virtual
    displacement that reads a resultant. At a dof the ``supports`` hold it is scaled by the
    boundaries' share of the dof's tributary area (module doc). ``only``: the dofs (the
    unknown's numbering) it is limited to, if given; collective."""
    V, tdim = disc.displacement_space, disc.mesh.topology.dim
    comm = disc.mesh.comm
    field = fem.Function(disc.space)
    for i in np.flatnonzero(vector):
        component = disc.component(i)
        if component is None:   # y in plane strain: no dofs
            continue
        dofs = np.concatenate([fem.locate_dofs_topological(V.sub(component), tdim - 1,
                                                           facets(tagged, name))
                               for name in boundaries])
        if only is not None:
            dofs = np.intersect1d(dofs, only)
        held = np.isin(dofs, supports.held)
        share = 1.0
        if comm.allreduce(bool(held.any()), op=MPI.LOR):   # collective: every rank assembles
            own, support = tributary_areas(disc, tagged, (boundaries, supports.holding[i]),
                                           component)
            share = np.where(held, own[dofs] / (own[dofs] + support[dofs]), 1.0)
        field.x.array[dofs] = vector[i] * share
    field.x.scatter_forward()
    return field


def tributary_areas(disc, tagged, groups, component):
    """For each tuple of facet group names in ``groups``, ∫ N_j dA over those groups for
    every dof j of the displacement dof ``component``, in the unknown's numbering (zero at
    the other dofs)."""
    space, to_parent = disc.displacement_space.sub(component).collapse()
    dofs = disc.space.dofmap.index_map
    size = (dofs.size_local + dofs.num_ghosts) * disc.space.dofmap.index_map_bs
    measure = disc.facet_measure(tagged.facet_tags)
    areas = []
    for names in groups:
        area = fem.assemble_vector(fem.form(
            ufl.TestFunction(space) * measure(tuple(tagged.boundaries[n] for n in names))))
        area.scatter_reverse(la.ScatterMode.add)
        area.scatter_forward()
        out = np.zeros(size)
        out[np.asarray(to_parent)] = area.array
        areas.append(out)
    return areas


def traction(disc, kinematics, magnitude, vector, measure, v):
    """External virtual work of a traction of fixed direction, per unit deformed area. In a
    rotated frame the direction is a Constant: as UFL literals with a zero component, FFCx
    0.5 fails to generate the large-deformation Jacobian (tests/test_frame.py)."""
    direction = (ufl.as_vector(vector) if disc.basis is None else
                 fem.Constant(disc.mesh, PETSc.ScalarType(np.asarray(vector))))
    return (magnitude * ufl.dot(direction, disc.displacement(v))
            * kinematics.area_stretch() * measure)


class Supports:
    """Dirichlet conditions: supports, plane strain, and under displacement control the driven
    boundary, whose prescribed values :meth:`move` sets. Components are the scene's own axes,
    which are those of the displacement dofs also in a rotated frame (``disc.basis``); a
    two-dimensional mesh has no y dofs (``disc.component``). Where the driven boundary meets
    a support, the dofs the support holds stay held: the driven boundary moves its other
    dofs."""

    def __init__(self, scene, tagged, disc):
        mesh, V = disc.mesh, disc.displacement_space
        tdim = mesh.topology.dim
        self._moving = []   # (Constant, coefficient of the prescribed displacement)
        self.bcs = []
        located = []        # (dofs, component, coefficient)
        constraints = self._constraints(scene)
        for boundary, axes in constraints.items():
            for axis, coefficient in axes.items():
                i = disc.component(axis)
                if i is None:
                    continue
                dofs = fem.locate_dofs_topological(V.sub(i), tdim - 1, facets(tagged, boundary))
                located.append((dofs, i, coefficient))
        #: The dofs held at zero (every component: a dof index is one component's).
        self.held = np.unique(np.concatenate(
            [np.empty(0, np.int32)] + [dofs for dofs, _, coefficient in located if coefficient == 0.0]))
        #: Per scene axis, the facet groups that hold it at zero.
        self.holding = tuple(tuple(b for b, axes in constraints.items() if axes.get(i) == 0.0)
                             for i in range(3))
        for dofs, i, coefficient in located:
            value = fem.Constant(mesh, PETSc.ScalarType(0.0))
            if coefficient != 0.0:
                self._moving.append((value, coefficient))
                dofs = np.setdiff1d(dofs, self.held).astype(np.int32)
            self.bcs.append(fem.dirichletbc(value, dofs, V.sub(i)))
        if scene.analysis.plane_strain and not disc.planar:   # the dofs of every cell
            cells = mesh.topology.index_map(tdim)
            all_cells = np.arange(cells.size_local + cells.num_ghosts, dtype=np.int32)
            dofs = fem.locate_dofs_topological(V.sub(1), tdim, all_cells)
            self.bcs.append(fem.dirichletbc(PETSc.ScalarType(0.0), dofs, V.sub(1)))

    @staticmethod
    def _constraints(scene):
        """Boundary -> {axis: coefficient of the prescribed displacement (0: a support)}."""
        constraints = {}
        for support in scene.supports:
            for axis in support.fix:
                constraints.setdefault(support.boundary, {})["xyz".index(axis)] = 0.0
        loading = scene.loading
        if loading.control is Control.DISPLACEMENT and loading.boundary != TOOL:
            axis = loading.direction.axis
            constraints.setdefault(loading.boundary, {})[axis] = loading.direction.vector[axis]
        return constraints

    def move(self, amount):
        """Prescribe ``amount`` of displacement along the loading direction on the driven boundary."""
        for value, coefficient in self._moving:
            value.value = amount * coefficient


def dead_loads(scene, tagged, disc, frame, kinematics, v):
    """External virtual work present from the first step: dead tractions and gravity
    (−γ e_z, e_z the scene's, per volume of the step's configuration), or None."""
    ds = disc.facet_measure(tagged.facet_tags)
    form = None
    for dead in scene.tractions:
        term = traction(disc, kinematics, dead.magnitude, frame.vector(dead.direction),
                        ds(tagged.boundaries[dead.boundary]), v)
        form = term if form is None else form + term
    if scene.geostatic is not None:
        up = ufl.as_vector(frame.vector([0.0, 0.0, 1.0]))
        gravity = -scene.geostatic.unit_weight * ufl.dot(up, disc.displacement(v)) * disc.measure()
        form = gravity if form is None else form + gravity
    return form


class BoundaryLoad:
    """A facet group driven by the load factor: a traction (force control), a displacement
    (displacement control, through the supports' prescribed values), or a traction whose
    magnitude p is one more unknown of the Newton system, with the equation that the
    boundary's mean displacement along the loading direction is the load factor's
    (indirect displacement control, de Borst 1987: the load follows the soil to its peak
    and past it, with no step cut at the limit). Under the last it is the
    :class:`~soilbin.solver.newton.NewtonSolver`'s border: its equation is written in force
    units, g = k (ū − ū*), k = ‖f‖ / (∂ū/∂p) with f the nodal load of p = 1 and ∂ū/∂p the
    mean displacement per unit p of the first tangent (:meth:`calibrate`), so that the
    Newton residual's norm weighs it as the load that would close it. In large deformation
    ū is the mean over the boundary as it was at the step's start (the curve's, over the
    moved boundary, differs by about the strain times the step's settlement)."""
    #: Per-step values beside displacement and force (see :meth:`observe`).
    columns = ("pressure",)

    def __init__(self, scene, tagged, disc, frame, kinematics, supports, w, v):
        loading = scene.loading
        mesh = disc.mesh
        self._control, self._magnitude = loading.control, loading.magnitude
        self._boundary = loading.boundary
        self._supports, self._kinematics = supports, kinematics
        self.indirect = loading.control is Control.INDIRECT
        self.direction = frame.vector(loading.direction)
        self._ds = disc.facet_measure(tagged.facet_tags)(tagged.boundaries[loading.boundary])
        self._load = fem.Constant(mesh, PETSc.ScalarType(0.0))
        self.external = (traction(disc, kinematics, self._load, self.direction, self._ds, v)
                         if loading.control is not Control.DISPLACEMENT else None)
        self._probe = probe(disc, tagged, (loading.boundary,), loading.direction.vector, supports)
        self._v, self._force = v, None
        self._area = area_of(mesh, self._ds)
        along = ufl.as_vector(self.direction)
        self._displacement = fem.form(ufl.dot(along, kinematics.total_displacement()) * self._ds)
        self._factor = self._committed_factor = 0.0
        if self.indirect:
            moved = ufl.dot(along, kinematics.iterate_displacement()) * self._ds
            self._moved = fem.form(moved)
            self._moved_derivative = fem.form(ufl.derivative(moved, w, v))
            unit = fem.Constant(mesh, PETSc.ScalarType(1.0))
            self._unit_load = fem.form(traction(disc, kinematics, unit, self.direction, self._ds, v))
            self._stiffness = 1.0   # k, until calibrated
            self._committed_load = 0.0

    def measure_with(self, internal):
        """Read the force on the boundary as the internal force on its dofs."""
        self._force = fem.form(ufl.replace(internal, {self._v: self._probe}))

    def set_factor(self, factor):
        self._factor = factor
        if self._control is Control.FORCE:
            self._load.value = factor * self._magnitude
        elif self._control is Control.DISPLACEMENT:   # the unknown may hold the increment
            base = self._committed_factor if self._kinematics.incremental else 0.0
            self._supports.move((factor - base) * self._magnitude)

    def commit(self):
        self._committed_factor = self._factor
        if self.indirect:
            self._committed_load = self.value

    def roll_back(self):
        if self.indirect:
            self.set_value(self._committed_load)

    def state(self):
        """The committed load factor and the traction's magnitude."""
        return {"factor": (GLOBAL, self._committed_factor), "load": (GLOBAL, self.value)}

    def restore(self, state):
        self._factor = self._committed_factor = float(state["factor"])
        self.set_value(float(state["load"]))
        if self.indirect:
            self._committed_load = self.value

    # -- the traction's magnitude as a Newton unknown (indirect displacement control) -------
    @property
    def value(self):
        return float(self._load.value)

    def set_value(self, load):
        self._load.value = load

    def residual(self):
        """The mean displacement's equation, k (ū − ū*) (collective)."""
        return self._stiffness * (assemble_total(self._moved) / self.area
                                  - self._factor * self._magnitude)

    def linearise(self, b, c):
        """∂(soil residual)/∂p = −f into b, ∂g/∂u into c (zero on held dofs); returns ∂g/∂p = 0."""
        bcs = self._supports.bcs
        for vector, form, scale in ((b, self._unit_load, -1.0),
                                    (c, self._moved_derivative, self._stiffness / self.area)):
            with vector.localForm() as local:
                local.set(0.0)
            fem.petsc.assemble_vector(vector, form)
            vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            vector.scale(scale)
            fem.petsc.set_bc(vector, bcs, scale=0.0)
        return 0.0

    def calibrate(self, tangent_solve):
        """k = ‖f‖ / (∂ū/∂p) of the tangent that ``tangent_solve(rhs, out)`` inverts."""
        b = fem.petsc.create_vector(self._unit_load)
        c, z = b.duplicate(), b.duplicate()
        self._stiffness = 1.0
        self.linearise(b, c)
        tangent_solve(b, z)
        compliance, norm = abs(c.dot(z)), b.norm()
        for vector in (b, c, z):
            vector.destroy()
        if not compliance > 0.0:
            raise InputError(f"loading.control = 'indirect_displacement': a traction on "
                             f"{self._boundary!r} does not move it along loading.direction (the "
                             "supports hold it there), so its mean displacement cannot set it")
        self._stiffness = norm / compliance

    # -------------------------------------------------------------------------------------
    @property
    def area(self):
        """Area of the loaded boundary (current configuration); collective."""
        return assemble_total(self._area)

    def observe(self):
        """Mean displacement and force along the loading direction, and the pressure: the
        force over the boundary's current area (its initial area in small deformation);
        collective."""
        force, area = assemble_total(self._force), self.area
        return Observation(assemble_total(self._displacement) / area, force,
                           {"pressure": force / area})


def assemble_total(form):
    """A scalar form assembled and summed over the ranks; collective."""
    comm = form.mesh.comm
    return comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)


def area_of(mesh, measure):
    """The (collective) area integral of a facet measure, as a compiled form."""
    return fem.form(fem.Constant(mesh, PETSc.ScalarType(1.0)) * measure)


def vector_norm(linear_form):
    """Euclidean norm of an assembled linear form (e.g. of the dead loads: a force scale)."""
    b = fem.petsc.assemble_vector(fem.form(linear_form))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    norm = b.norm()
    b.destroy()
    return norm


def start_mean_pressure(disc, points, w, w_committed):
    """Mean-dilatation elements: start the pressure field at the projection of the initial
    mean stress, so that the in-situ state is in equilibrium."""
    P, to_parent = disc.space.sub(2).collapse()
    p, q = ufl.TrialFunction(P), ufl.TestFunction(P)
    mean_stress = ufl.tr(ufl_from_mandel(points.stress)) / 3.0
    dx = disc.measure()
    options = {"ksp_type": "preonly", "pc_type": "lu"}
    problem = fem.petsc.LinearProblem(p * q * dx, mean_stress * q * dx, petsc_options=options)
    w.x.array[to_parent] = problem.solve().x.array
    w_committed.x.array[:] = w.x.array
    # DOLFINx leaves its options in PETSc's database under a prefix of its own, which holds
    # 512 at most: a run that remeshed some 250 times stopped on a full database
    prefix = problem.solver.getOptionsPrefix()
    database = PETSc.Options()
    for key in options:
        database.delValue(prefix + key)
    release(problem.solver, problem.A, problem.b)
