"""The discrete problem of a scene: the parts wired together, driven by the load stepper.

:class:`SoilProblem` implements :class:`~soilbin.solver.stepping.SteppedProblem`:
set a load factor, solve for equilibrium with Newton, commit or roll back,
observe the driven boundary or tool. Each physical thing is a part in its own
module: the frame (``frame``), the kinematics (``kinematics``: small strain
or updated Lagrangian), the material points (``solver.quadrature``), the
loads (``loads``: supports, the driven boundary, dead loads, gravity, the
in-situ state) and the tool (``tool``). Outputs read named fields
(:meth:`SoilProblem.output_fields`), not the parts.
"""
import dataclasses

import numpy as np
import ufl
from dolfinx import fem

from ..errors import ConvergenceError
from ..forms.discretisation import Discretisation
from ..layout import DOFS, GLOBAL, NODES, POINTS
from ..records.scene import TOOL
from ..solver.newton import NewtonSolver
from ..solver.quadrature import MaterialPoints
from . import fields
from .frame import Frame
from .kinematics import kinematics_of
from .loads import BoundaryLoad, Supports, dead_loads, start_mean_pressure, vector_norm
from .mesh_quality import MeshQuality
from .soil_contact import SoilContact
from .tool import RigidTool


class SoilProblem:
    def __init__(self, scene, tagged_mesh):
        self.scene, self.tagged = scene, tagged_mesh
        mesh = tagged_mesh.mesh
        self.comm = mesh.comm
        self.frame = frame = Frame(scene.analysis.frame_rotation)
        frame.turn_mesh(mesh)
        self.disc = disc = Discretisation.create(mesh, scene.analysis.element, frame.basis)
        self.w = fem.Function(disc.space, name="solution")
        self.w_committed = fem.Function(disc.space)
        self.kinematics = kinematics_of(scene.analysis, disc, self.w, self.w_committed)
        self.quality = MeshQuality(mesh) if self.kinematics.moves_mesh else None
        self.points = self._material_points()

        v = ufl.TestFunction(disc.space)
        self.supports = Supports(scene, tagged_mesh, disc)
        self.tool = (RigidTool(scene, tagged_mesh, disc, self.kinematics,
                               frame.vector(scene.loading.direction), self.w, self.supports)
                     if scene.tool is not None else None)
        self.drive = (self.tool if scene.loading.boundary == TOOL else
                      BoundaryLoad(scene, tagged_mesh, disc, frame, self.kinematics, self.supports,
                                   self.w, v))
        #: The Newton system's one extra unknown, if any: a force-controlled tool's travel, or
        #: the traction's magnitude under indirect displacement control.
        self.border = (self.tool if self.tool is not None and self.tool.force_controlled else
                       self.drive if self.drive is not self.tool and self.drive.indirect else None)
        self.bcs = self.supports.bcs
        self.soil_contact = (SoilContact(scene.soil_contact, tagged_mesh, disc, self.w, self.bcs)
                             if scene.soil_contact is not None else None)
        self.newton = self._newton(v)
        # the models' first call after the forms: they compile while its kernels do
        self.points.start()
        if scene.geostatic is not None and disc.element.mixed:
            start_mean_pressure(disc, self.points, self.w, self.w_committed)
        if self.border is not None and self.border is not self.tool:
            self.drive.calibrate(self.newton.tangent_solve)
        self._factor, self._factors, self._border_values = 0.0, (0.0, 0.0), (0.0, 0.0)

    def _material_points(self):
        scene, tagged = self.scene, self.tagged
        region_cells = {name: tagged.cell_tags.find(tagged.regions[name]) for name in scene.regions}
        models = {name: scene.materials[material] for name, material in scene.regions.items()}
        geostatic = scene.geostatic
        return MaterialPoints(self.disc, self.w, self.w_committed,
                              self.kinematics.strain_increment(), region_cells, models,
                              keep_strain=self.kinematics.keeps_strain,
                              initial_stress=geostatic and self.frame.stress_field(geostatic.stress),
                              tangent_floor=scene.solver.tangent_floor)

    def _newton(self, v):
        """Residual = internal − dead loads − the driven traction (+ the tool's nodal terms)."""
        internal = self.kinematics.internal_force(self.points, v)
        dead = dead_loads(self.scene, self.tagged, self.disc, self.frame, self.kinematics, v)
        residual = internal if dead is None else internal - dead
        if self.drive is not self.tool:
            if self.drive.external is not None:
                residual = residual - self.drive.external
            self.drive.measure_with(internal)
        if self.tool is not None:
            self.tool.measure_with(internal)
        jacobian = self.kinematics.jacobian(residual, self.points,
                                            ufl.TrialFunction(self.disc.space), v)
        tool = self.tool
        # symmetric Jacobian: small strain, and symmetric material and interface tangents
        # at the iterate (the border of a force-controlled tool is eliminated apart)
        def symmetric_tangent():
            return self.points.tangent_symmetric() and (
                tool is None or tool.interface.tangent_symmetric())
        newton = NewtonSolver(self.comm, residual, jacobian, self.w, self.bcs,
                              self.update_material_state, self.scene.solver, self.disc,
                              nodal_terms=tool.nodal_terms if tool else [],
                              coupled_terms=[self.soil_contact] if self.soil_contact else [],
                              border=self.border,
                              symmetric=not self.kinematics.incremental,
                              symmetric_tangent=symmetric_tangent)
        if dead is not None:   # loads present from the start set the force scale
            newton.include_force_scale(vector_norm(dead))
        return newton

    @property
    def n_dofs(self):
        imap = self.disc.space.dofmap.index_map
        return imap.size_global * self.disc.space.dofmap.index_map_bs

    @property
    def mesh(self):
        return self.disc.mesh

    @property
    def moves_mesh(self):
        return self.kinematics.moves_mesh

    @property
    def curve_columns(self):
        """Names of the values each observation carries beside displacement and force."""
        return (self.drive.columns + ("mesh_quality",) * (self.quality is not None)
                + ("soil_contact_force",) * (self.soil_contact is not None))

    def update_material_state(self):
        """The constitutive and interface updates of one Newton iterate."""
        self.points.update()
        if self.tool is not None:
            self.tool.update()
        if self.soil_contact is not None:
            self.soil_contact.update()

    # -- the load stepper's protocol -------------------------------------------------
    def set_load_factor(self, factor):
        """The load at ``factor`` and, after two converged states, the first iterate
        extrapolated linearly from them (the border's unknown too)."""
        self.drive.set_factor(factor)
        self._factor = factor
        last, before = self._factors
        if last > before:
            ratio = (factor - last) / (last - before)
            self.kinematics.predict(ratio)
            if self.border is not None:
                last, before = self._border_values
                self.border.set_value(last + ratio * (last - before))

    def solve(self):
        """Equilibrium at the current load factor, starting from the last committed state.
        A remeshing run (scene ``[remesh]``) refuses a solution that takes the mesh's quality
        below half ``remesh.min_quality`` (or folds a cell over), as a ConvergenceError: the
        stepper cuts the step, and the remesher never meets a folded or flattened cell."""
        result = self.newton.solve()
        remesh = self.scene.remesh
        if remesh.active:
            quality = self.quality.minimum(self.kinematics.node_increment())
            if quality <= remesh.min_quality / 2.0:
                raise ConvergenceError(f"the step takes the mesh's least scaled Jacobian to "
                                       f"{quality:.3g}, below half remesh.min_quality")
        return result

    def destroy(self):
        """Frees the solver's matrix, MUMPS's factors and vectors: a problem a remesh replaced
        (or made and gave up); not to be used after."""
        self.newton.destroy()

    def commit(self):
        self._factors = (self._factor, self._factors[0])
        if self.border is not None:
            self._border_values = (self.border.value, self._border_values[0])
        self.drive.commit()
        if self.tool is not None and self.tool is not self.drive:
            self.tool.commit()
        self.kinematics.commit(self.points)
        if self.soil_contact is not None:   # on the committed soil (the mesh moved)
            self.soil_contact.pair()

    def roll_back(self):
        self.w.x.array[:] = self.w_committed.x.array
        if self.tool is not None:
            self.tool.roll_back()
        if self.drive is not self.tool:
            self.drive.roll_back()

    def observe(self):
        """Displacement and force of the driven boundary or tool along the loading direction,
        and its further values (:attr:`curve_columns`): the mesh's least scaled Jacobian
        too when the mesh moves, and the soil contact's force; collective. The state observed
        is a converged one: Newton's residual floor keeps above the rounding of the force it
        carries (:meth:`~soilbin.solver.newton.NewtonSolver.carry`)."""
        observation = self.drive.observe()
        self.newton.carry(observation.force)
        columns = dict(observation.columns)
        if self.quality is not None:
            columns["mesh_quality"] = self.quality.minimum()
        if self.soil_contact is not None:
            columns["soil_contact_force"] = self.soil_contact.committed_force
        return dataclasses.replace(observation, columns=columns)

    # -- checkpoints ------------------------------------------------------------------
    def _stateful_parts(self):
        parts = {"kinematics": self.kinematics, "points": self.points}
        if self.tool is not None:
            parts["tool"] = self.tool
        if self.drive is not self.tool:
            parts["load"] = self.drive
        return parts

    def state(self):
        """Everything the last converged step leaves for the next: name -> (``layout``
        kind, this rank's array); with :meth:`restore`, a checkpoint (``app.checkpoint``)."""
        state = {"w": (DOFS, self.w_committed.x.array), "factors": (GLOBAL, self._factors),
                 "border_values": (GLOBAL, self._border_values),
                 "force_scale": (GLOBAL, self.newton.force_scale),
                 "carried_force": (GLOBAL, self.newton.carried)}
        for name, part in self._stateful_parts().items():
            state.update({f"{name}/{key}": value for key, value in part.state().items()})
        return state

    def entities(self):
        """This rank's entities of each ``layout`` kind, for :meth:`state`'s arrays: those of
        each local cell ((n_cells, k) indices, ghost cells included; the unknown's by block)
        and the contact points' keys (face tag and initial position, (n, 4)), or None."""
        mesh, dofmap = self.mesh, self.disc.space.dofmap
        cells = mesh.topology.index_map(mesh.topology.dim)
        n_cells = cells.size_local + cells.num_ghosts
        tables = {DOFS: dofmap.list.array.reshape(n_cells, -1),
                  POINTS: np.arange(n_cells * self.points.points_per_cell).reshape(n_cells, -1),
                  NODES: mesh.geometry.dofmap.array.reshape(n_cells, -1)}
        return tables, None if self.tool is None else self.tool.interface.contact_keys()

    def restore(self, state):
        """Back to a :meth:`state`, as if its step had just converged."""
        self.w.x.array[:] = state["w"].ravel()
        self.w_committed.x.array[:] = self.w.x.array
        self._factors = tuple(float(f) for f in state["factors"])
        self._factor = self._factors[0]
        self._border_values = tuple(float(v) for v in state["border_values"])
        self.newton.include_force_scale(float(state["force_scale"]))
        self.newton.carry(float(state.get("carried_force", 0.0)))   # absent from older checkpoints
        for name, part in self._stateful_parts().items():   # the mesh moves before the points
            part.restore({key.removeprefix(f"{name}/"): value for key, value in state.items()
                          if key.startswith(f"{name}/")})
        if self.soil_contact is not None:
            self.soil_contact.pair()

    # -- outputs ----------------------------------------------------------------------
    def displacement(self):
        """The total displacement as a P1 Function (nodal values)."""
        return self.kinematics.displacement_p1()

    def nodal_displacement(self):
        """(initial coordinates, total displacement), each (n, 3) in the scene's axes, at the
        owned mesh nodes."""
        u, dim = self.displacement(), self.disc.dimension
        owned = u.function_space.dofmap.index_map.size_local
        displacement = self.disc.to_world(u.x.array.reshape(-1, dim)[:owned])
        x = self.disc.to_world(u.function_space.tabulate_dof_coordinates()[:owned, :dim])
        return x - displacement * self.moves_mesh, displacement

    def output_fields(self, names):
        """Named output fields: name -> (Function, update)."""
        return fields.build(self, names)
