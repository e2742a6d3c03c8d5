"""The rigid tool: its motion, how it acts on the soil, and the force the soil exerts on it.

The tool sits in a cavity of the soil mesh and translates as a rigid body
along the loading direction. Under displacement control the load factor
prescribes its travel; under force control it prescribes the draft, and the
travel a is one more unknown of the Newton system with the equation
draft(u, a) = F (the tool is its :class:`~soilbin.solver.newton.NewtonSolver`
border). It acts on the cavity's faces either bonded (the faces move with
it: Dirichlet conditions; displacement control only) or through the
Mohr–Coulomb penalty interface (``interface.rigid_tool``: stick, slip,
separation).

:meth:`RigidTool.force` is the one measurement of the force between tool and
soil, read from the tool's own action on the soil: the sum of the interface
tractions over every contact point (a point whose soil dof a support also
holds included: the law acts on the tool there too), or for a bonded tool the
reaction of its faces, the soil's residual without the tool's terms
(internal force minus dead loads and gravity) read on the faces' dofs, one
probe per axis. The draft is its component along the travel; the lift its
vertical component.
"""
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc
from dolfinx import fem

from ..interface.rigid_tool import RigidToolContact
from ..scene import Control
from .loads import area_of, assemble_total, facets, probe


class RigidTool:
    def __init__(self, scene, tagged, disc, frame, kinematics, w, v, supports):
        tool, loading = scene.tool, scene.loading
        mesh = disc.mesh
        self.faces = tool.faces
        self.direction = frame.vector(loading.direction)
        self._magnitude = loading.magnitude
        self._incremental = kinematics.incremental
        self.force_controlled = loading.control is Control.FORCE
        self.travel = self._committed_travel = 0.0   # along the loading direction
        self._target = 0.0                            # the draft, under force control
        self.bcs, self._moving = [], []   # bonded faces: (Constant, component of the travel)
        self.interface = None
        if tool.bonded:
            V, tdim = disc.displacement_space, mesh.topology.dim
            for face in tool.faces:
                for i in range(3):
                    dofs = fem.locate_dofs_topological(V.sub(i), tdim - 1, facets(tagged, face))
                    value = fem.Constant(mesh, PETSc.ScalarType(0.0))
                    if self.direction[i] != 0.0:
                        self._moving.append((value, self.direction[i]))
                    self.bcs.append(fem.dirichletbc(value, dofs, V.sub(i)))
        else:
            geostatic = scene.geostatic
            self.interface = RigidToolContact(
                disc, w, tagged.facet_tags, [tagged.boundaries[f] for f in tool.faces],
                tool.interface, supports.bcs, incremental=kinematics.incremental,
                initial_stress=geostatic and geostatic.stress)
        self.nodal_terms = [self.interface] if self.interface is not None else []
        self._v = v
        self._probes = ([probe(disc, tagged, tool.faces, axis) for axis in np.eye(3)]
                        if tool.bonded else [])
        self._resultant = None
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=tagged.facet_tags)
        self._area = area_of(mesh, ds(tuple(tagged.boundaries[f] for f in tool.faces)))

    def measure_with(self, soil_residual):
        """A bonded tool reads its reaction from the soil's residual without its own terms."""
        self._resultant = [fem.form(ufl.replace(soil_residual, {self._v: p})) for p in self._probes]

    def set_factor(self, factor):
        """The travel (displacement control) or the draft (force control) at this factor."""
        if self.force_controlled:
            self._target = factor * self._magnitude
        else:
            self.set_value(factor * self._magnitude)

    def set_value(self, travel):
        """Place the tool at this travel."""
        self.travel = travel
        if self.interface is not None:
            self.interface.tool_displacement = travel * self.direction
        base = self._committed_travel if self._incremental else 0.0
        for value, component in self._moving:
            value.value = (travel - base) * component

    # -- the travel as a Newton unknown (force control) ---------------------------------
    @property
    def value(self):
        return self.travel

    def residual(self):
        """The draft's balance, draft − F (collective)."""
        return self.draft() - self._target

    def linearise(self, b, c):
        """∂(soil residual)/∂a into b, ∂(draft)/∂u into c; returns ∂(draft)/∂a."""
        return self.interface.travel_derivatives(self.direction, b, c)

    def update(self):
        """The interface law at the current iterate (nothing for a bonded tool)."""
        if self.interface is not None:
            self.interface.update()

    def commit(self):
        self._committed_travel = self.travel
        if self.interface is not None:
            self.interface.commit()

    def roll_back(self):
        self.set_value(self._committed_travel)

    @property
    def area(self):
        """Area of the tool's faces (current configuration); collective."""
        return assemble_total(self._area)

    def force(self):
        """Resultant force (3,) the tool exerts on the soil, world axes; collective."""
        if self.interface is not None:   # the soil's tractions on the tool, reversed
            return -self.interface.force()
        local = np.array([fem.assemble_scalar(form) for form in self._resultant])
        return self._resultant[0].mesh.comm.allreduce(local, op=MPI.SUM)

    def draft(self):
        """The force on the soil along the travel; collective."""
        return float(self.force() @ self.direction)

    def observe(self):
        """(travel, draft)."""
        return self.travel, self.draft()

    def gap(self):
        """(reference coordinates (n, 3), gap (n,)) at the interface's contact points."""
        return self.interface.reference_points, self.interface.gap()
