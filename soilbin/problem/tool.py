"""The rigid tool: its motion, how it acts on the soil, and the force the soil exerts on it.

The tool sits in a cavity of the soil mesh and translates as a rigid body
along the loading direction. Under displacement control the load factor
prescribes its travel; under force control it prescribes the draft, and the
travel a is one more unknown of the Newton system with the equation
draft(u, a) = F (the tool is its :class:`~soilbin.solver.newton.NewtonSolver`
border). It acts on the cavity's faces through penalty springs at the
contact points (``interface.rigid_tool``): the Mohr–Coulomb interface (stick,
slip, separation), or, bonded, the same springs that never slip or open.

:meth:`RigidTool.force` is the one measurement of the force between tool and
soil: the sum of the interface tractions over every contact point (a point
whose soil dof a support also holds along the face included: the law acts on
the tool there too), for the whole tool when the mesh holds part of it
(``share``: half across a symmetry plane). Where a support holds a face's
node against the travel (the toe of a wall over soil held below it: no
contact point, ``rigid_tool_contact``), the support's reaction along the
travel is counted instead, by the face's share of the node's tributary area
(as for a driven boundary, :func:`~soilbin.problem.loads.probe`); such a
tool is driven by displacement only. The draft is the force's component
along the travel, the lift the soil's upward force on the tool.
"""
import numpy as np
import ufl
from mpi4py import MPI
from dolfinx import fem

from ..errors import InputError
from ..layout import GLOBAL
from ..records.scene import Control
from ..solver.stepping import Observation
from .loads import assemble_total, probe
from .probes import CellValue, cell_ahead
from .rigid_tool_contact import RigidToolContact


class RigidTool:
    #: Per-step values beside travel and draft (see :meth:`observe`).
    columns = ("lift", "front_volumetric_strain", "heave")

    def __init__(self, scene, tagged, disc, kinematics, direction, w, supports):
        tool, loading = scene.tool, scene.loading
        mesh = disc.mesh
        self.faces = tool.faces
        self.direction = direction
        self.share = getattr(scene.mesh, "tool_share", 1.0)   # of the whole tool, in the mesh
        self.force_controlled = loading.control is Control.FORCE
        self._magnitude = loading.magnitude
        self.travel = self._committed_travel = 0.0   # along the loading direction
        self._target = 0.0                            # the draft, under force control
        geostatic = scene.geostatic
        self.interface = RigidToolContact(
            disc, w, tagged.facet_tags, [tagged.boundaries[f] for f in tool.faces], tool.law,
            supports.bcs, direction, incremental=kinematics.incremental,
            initial_stress=geostatic and geostatic.stress)
        self.nodal_terms = [self.interface]
        self._comm = mesh.comm
        self._reaction = None   # the supports' reaction along the travel (module doc)
        self._reaction_probe = None
        if self._comm.allreduce(len(self.interface.support_dofs), op=MPI.SUM):
            if self.force_controlled:
                raise InputError(
                    f"loading.control = 'force': a support holds soil of tool.faces "
                    f"{list(tool.faces)} against the tool's travel (as the support below a wall "
                    "holds its toe); its reaction is in the tool's force but not in the draft's "
                    "linearisation: use displacement control")
            self._reaction_probe = probe(disc, tagged, tool.faces, loading.direction.vector,
                                         supports, only=self.interface.support_dofs)
        # the contact points of each face: its nodes on the initial mesh (owned by this rank)
        ends = np.cumsum(self.interface.points_per_face)[:-1]
        self.face_points = dict(zip(tool.faces, np.split(self.interface.reference_points, ends)))
        self._front_strain = CellValue(mesh, kinematics.volume_change(),
                                       cell_ahead(mesh, self._front_centre(), direction))
        self._kinematics, self._disc = kinematics, disc

    def _front_centre(self):
        """Centre of the face that leads the travel (its nodes furthest along it)."""
        comm = self._comm
        lead = {face: comm.allreduce((x @ self.direction).max(initial=-np.inf), op=MPI.MAX)
                for face, x in self.face_points.items()}
        front = self.face_points[max(lead, key=lead.get)]
        total = comm.allreduce(np.append(front.sum(axis=0), len(front)), op=MPI.SUM)
        return total[:3] / total[3]

    def measure_with(self, internal):
        """Read the supports' reaction where they hold the soil against the travel as the
        internal force on those dofs."""
        if self._reaction_probe is not None:
            self._reaction = fem.form(ufl.replace(internal, {internal.arguments()[0]:
                                                             self._reaction_probe}))

    def set_factor(self, factor):
        """The travel (displacement control) or the draft (force control) at this factor."""
        if self.force_controlled:
            self._target = factor * self._magnitude
        else:
            self.set_value(factor * self._magnitude)

    def set_value(self, travel):
        """Place the tool at this travel."""
        self.travel = travel
        self.interface.tool_displacement = travel * self.direction

    # -- the travel as a Newton unknown (force control) ---------------------------------
    @property
    def value(self):
        return self.travel

    def residual(self):
        """The draft's balance, draft − F (collective)."""
        return self.draft() - self._target

    def linearise(self, b, c):
        """∂(soil residual)/∂a into b, ∂(draft)/∂u into c; returns ∂(draft)/∂a."""
        d = self.interface.travel_derivatives(self.direction, b, c)
        c.scale(1.0 / self.share)
        return d / self.share

    # -------------------------------------------------------------------------------------
    def update(self):
        """The interface law at the current iterate."""
        self.interface.update()

    def commit(self):
        self._committed_travel = self.travel
        self.interface.commit()

    def roll_back(self):
        self.set_value(self._committed_travel)

    def state(self):
        """The committed travel, the draft aimed at and the interface's state."""
        return {"travel": (GLOBAL, self._committed_travel), "target": (GLOBAL, self._target),
                **{f"interface/{key}": value for key, value in self.interface.state().items()}}

    def restore(self, state):
        self._target = float(state["target"])
        self.set_value(float(state["travel"]))
        self._committed_travel = self.travel
        self.interface.restore({key.removeprefix("interface/"): value
                                for key, value in state.items() if key.startswith("interface/")})

    def force(self):
        """Resultant force (3,) the whole tool exerts on the soil, world axes (across a symmetry
        plane the y component is twice the half's); collective."""
        force = -self.interface.force()
        if self._reaction is not None:
            force = force + assemble_total(self._reaction) * self.direction
        return force / self.share

    def draft(self):
        """The force on the soil along the travel; collective."""
        return float(self.force() @ self.direction)

    def observe(self):
        """Travel and draft, the lift (the soil's upward force on the tool), the volumetric
        strain of the soil element in front of the tool and the heave."""
        force = self.force()
        return Observation(self.travel, float(force @ self.direction),
                           {"lift": -force[2], "front_volumetric_strain": self._front_strain(),
                            "heave": self._heave()})

    def _heave(self):
        """How far the soil's highest point has risen above the soil's highest point at the
        start: the crest of the soil the tool pushes up (the nodes' starting heights are
        their heights less their total displacement, carried across remeshes); collective."""
        disc, total = self._disc, self._kinematics.displacement_p1()
        dim = disc.dimension
        rise = disc.to_world(total.x.array.reshape(-1, dim))[:, 2]
        height = disc.to_world(total.function_space.tabulate_dof_coordinates()[:, :dim])[:, 2]
        if not self._kinematics.moves_mesh:
            height = height + rise
        top, start = (self._comm.allreduce(float(z.max(initial=-np.inf)), op=MPI.MAX)
                      for z in (height, height - rise))
        return top - start

    def gap(self):
        """(reference coordinates (n, 3), gap (n,)) at the contact points."""
        return self.interface.reference_points, self.interface.gap()
