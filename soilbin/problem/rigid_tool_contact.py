"""A rigid tool acting on the soil through an interface law, assembled at the nodes.

The soil mesh has a cavity where the tool is; its faces are the contact
surface. The tool moves rigidly by U (a translation), so the jump of a soil
node on a tool face is u − U and the face's normal is fixed. Each (node,
face) pair is a contact point with its tributary area A = ∫ φ_node ds over
the face and the face normal averaged at the node: the penalty terms are
integrated with the nodal (lumped) rule, so the law and its slip history
live exactly at the contact points and a node on an edge of the tool
touches both faces. On the six-node triangles of quadratic tetrahedra a
corner's φ integrates to zero over the triangle, which would leave the
corners free to pass into the tool: there the areas are the consistent
diagonal ∫ φ² ds scaled to the triangle's area (Hinton, Rock & Zienkiewicz
1976: a corner A/19, a mid-edge node 16 A/57). Residual += A t(u − U),
Jacobian += A dt/djump on the node's own 3x3 block (rows and columns of
Dirichlet dofs left alone). On a two-dimensional mesh the law still works in
the scene's three components (the jump's y component is zero, so is the
traction's); the node's dofs are its x and z ones, which take those
components of the traction and the 2x2 block of the tangent.

A support may hold a node of a face too. Along the face (the block on a
plate, held at its end, that the plate slides under) the law still acts:
the tool slides past the held node. But where a support holds the soil in a
component along both the travel and the face's normal (the toe of a wall
pushed over soil held below it), the tool would press the held node by its
whole travel: such a node is the support's, not a contact point, and its
held dofs there (``support_dofs``) are where the tool's force reads the
support's reaction instead (:class:`~soilbin.problem.tool.RigidTool`).
"""
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc
from dolfinx import fem
import dolfinx.fem.petsc  # noqa: F401

from ..layout import CONTACT
from ..solver.linear_solver import all_symmetric
from ..tensors import from_mandel


#: A six-node triangle's area over its consistent diagonal's sum, (3 x 6 + 3 x 32) / 180.
HRZ_SIX_NODE_TRIANGLE = 30.0 / 19.0


class RigidToolContact:
    def __init__(self, disc, w, facet_tags, face_tags, law, bcs, travel, incremental,
                 initial_stress=None):
        """``face_tags``: facet tags of the tool faces; ``w``: the unknown, which
        holds the total displacement or, if ``incremental`` (updated Lagrangian),
        the increment since the last commit; ``travel``: the unit vector the tool
        moves along; ``initial_stress(x)`` (n, 6): the soil's in-situ stress, which
        the tool carries from the start."""
        mesh = disc.mesh
        V = disc.displacement_space
        scalar_space = fem.FunctionSpace(mesh, V.ufl_element().sub_elements()[0])
        nodes_map = scalar_space.dofmap.index_map
        owned = nodes_map.size_local
        #: The scene's axes of the dof components (x, y, z; x and z on a 2D mesh).
        self.axes = [axis for axis in range(3) if disc.component(axis) is not None]
        # the unknown's dof of each component at each node, matched cell by cell (no
        # V.sub(i).collapse(), which builds and reorders a dof map per component)
        nodal_dofs = np.empty((owned + nodes_map.num_ghosts, len(self.axes)), dtype=np.int32)
        nodal_dofs[scalar_space.dofmap.list.array] = np.stack(
            [V.sub(i).dofmap.list.array for i in range(len(self.axes))], axis=1)
        self.scalar_space = scalar_space
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)
        phi = ufl.TestFunction(scalar_space)
        normal = disc.normal()
        fixed = np.zeros(len(w.x.array), dtype=bool)
        for bc in bcs:
            fixed[bc.dof_indices()[0]] = True

        # Two compiled forms for all faces and directions (a form per face and component
        # would each be compiled on a fresh machine): the face and the direction are constants.
        face = fem.Constant(mesh, np.zeros(len(face_tags)))
        direction = fem.Constant(mesh, np.zeros(3))
        weight = phi        # a linear form: ∫ φ ds; a bilinear one: its diagonal (module doc)
        if (mesh.topology.dim == 3 and disc.element.simplex
                and scalar_space.ufl_element().degree() == 2):
            weight = HRZ_SIX_NODE_TRIANGLE * ufl.TrialFunction(scalar_space) * phi
        area_form, normal_form = (
            fem.form(sum(face[k] * integrand * ds(tag) for k, tag in enumerate(face_tags)))
            for integrand in (weight, ufl.dot(normal, direction) * weight))

        def component(i):
            direction.value[:] = np.eye(3)[i]
            return self._nodal(normal_form)

        nodes, areas, normals, pressed_dofs = [], [], [], []
        for k in range(len(face_tags)):
            face.value[:] = np.eye(len(face_tags))[k]
            area = self._nodal(area_form)
            on_face = np.flatnonzero(area[:owned] > 0.0)
            n = np.stack([component(i) for i in range(3)], axis=1)[on_face]
            n /= np.linalg.norm(n, axis=1)[:, None]
            # held components along the travel and the normal (beyond round-off): the support's
            pressed = fixed[nodal_dofs[on_face]] & (np.abs(n * travel)[:, self.axes] > 1e-9)
            pressed_dofs.append(nodal_dofs[on_face][pressed])
            contact = ~pressed.any(axis=1)
            nodes.append(on_face[contact])
            areas.append(area[on_face][contact])
            normals.append(n[contact])
        #: Held dofs of the nodes that are the supports', not contact points (module doc).
        self.support_dofs = np.unique(np.concatenate(pressed_dofs))
        self.points_per_face = [len(n) for n in nodes]
        self._face_tags = list(face_tags)
        self.nodes = np.concatenate(nodes)               # local node index per contact point
        self.areas = np.concatenate(areas)
        self.normals = np.concatenate(normals)
        self.dofs = nodal_dofs[self.nodes].astype(PETSc.IntType)
        self._free = ~fixed[self.dofs]                    # (n_points, dof components)
        self.law = law
        self._dimension, self._to_world = disc.dimension, disc.to_world
        self.reference_points = self.positions()          # on the initial mesh
        # The jump is u_n + u − U: the soil's committed displacement at the point, with the
        # offset of a tool wished in place, which carries the in-situ traction t0 = -σ0 n:
        # t0_n n / k_n + t0_t / k_s, so that the law returns t0 at zero displacement.
        self._committed_offset = np.zeros((len(self.nodes), 3))
        if initial_stress is not None:
            t0 = -np.einsum("pij,pj->pi", from_mandel(initial_stress(self.reference_points)),
                            self.normals)
            t0_n = np.einsum("pi,pi->p", t0, self.normals)[:, None] * self.normals
            self._committed_offset = t0_n / law.k_n + (t0 - t0_n) / law.k_s
        self.committed = law.initial_state(len(self.nodes))
        self.trial = self.committed
        self._w, self._incremental = w, incremental
        self.tool_displacement = np.zeros(3)
        self._traction = np.zeros((len(self.nodes), 3))
        self._tangent = np.zeros((len(self.nodes), 3, 3))
        self.comm = mesh.comm

    def _nodal(self, form):
        """A linear form over the scalar space, assembled and summed over ranks, or a bilinear
        one's diagonal; per local node."""
        if form.rank == 2:
            A = fem.petsc.assemble_matrix(form)
            A.assemble()
            diagonal = fem.Function(self.scalar_space)
            A.getDiagonal(diagonal.vector)
            A.destroy()
            diagonal.x.scatter_forward()
            return diagonal.x.array.copy()
        b = fem.petsc.assemble_vector(form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        b.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        with b.localForm() as local:
            values = local.array.copy()
        b.destroy()
        return values

    def _soil_offset(self):
        """u_n + u: the committed offset (the in-situ offset and the soil's committed
        displacement) and the unknown's displacement at the contact points."""
        u = np.zeros((len(self.dofs), 3))
        u[:, self.axes] = self._w.x.array[self.dofs]
        return self._committed_offset + u

    def jump(self):
        return self._soil_offset() - self.tool_displacement

    def update(self):
        """The interface law at the current iterate (call once per iterate)."""
        self._traction, self._tangent, self.trial = self.law.traction_update(
            self.jump(), self.normals, self.committed)

    def tangent_symmetric(self):
        """Whether the law's tangent at every contact point of every rank is symmetric (a
        slipping Mohr–Coulomb point's is not)."""
        return all_symmetric(self._tangent, self.comm)

    def add_residual(self, b):
        """Residual (internal − external) += A t at the owned, free dofs."""
        forces = self.areas[:, None] * self._traction[:, self.axes] * self._free
        with b.localForm() as local:
            np.add.at(local.array, self.dofs.ravel(), forces.ravel())

    def add_jacobian(self, A):
        if not len(self.dofs):   # no contact point on this rank (PETSc divides by the count)
            return
        free = self._free[:, :, None] & self._free[:, None, :]
        blocks = self.areas[:, None, None] * self._tangent[:, self.axes][:, :, self.axes] * free
        A.setValuesLocalRCV(self.dofs, self.dofs, blocks, addv=PETSc.InsertMode.ADD)

    def travel_derivatives(self, direction, b, c):
        """For a tool translating by a·direction, with the draft −Σ A t·direction:
        ∂(residual)/∂a into b and ∂(draft)/∂u into c (free dofs of the contact points);
        returns ∂(draft)/∂a, summed over ranks."""
        t_d = self._tangent @ direction                                # T d
        tt_d = np.einsum("pji,j->pi", self._tangent, direction)        # Tᵀ d
        for vector, values in ((b, -self.areas[:, None] * t_d), (c, -self.areas[:, None] * tt_d)):
            with vector.localForm() as local:
                local.set(0.0)
                np.add.at(local.array, self.dofs.ravel(),
                          (values[:, self.axes] * self._free).ravel())
        return self.comm.allreduce(float(self.areas @ (t_d @ direction)), op=MPI.SUM)

    def commit(self):
        self.committed = self.trial
        if self._incremental:   # the unknown restarts from zero after the commit
            self._committed_offset = self._soil_offset()

    def contact_keys(self):
        """What tells the contact points apart on any partition: the tag of the face and
        the initial position, (n, 4)."""
        faces = np.repeat(self._face_tags, self.points_per_face)
        return np.column_stack([faces, self.reference_points])

    def positions(self):
        """Where the contact points are now, (n, 3) world axes (the mesh moves in large
        deformation)."""
        x = self.scalar_space.tabulate_dof_coordinates()[self.nodes, :self._dimension]
        return self._to_world(x)

    def state(self):
        """The committed law state and offset (the soil's displacement and the in-situ
        offset) at the contact points, and the tool's normal there (a remeshed soil's face
        against the tool is not quite flat: the law keeps the tool's)."""
        return {"committed_offset": (CONTACT, self._committed_offset),
                "normals": (CONTACT, self.normals),
                **{f"law/{key}": (CONTACT, value) for key, value in self.committed.items()}}

    def restore(self, state):
        self._committed_offset = state["committed_offset"]
        self.normals = state["normals"]
        self.committed = self.trial = {key: state[f"law/{key}"] for key in self.committed}

    def force(self):
        """Resultant force of the soil on the tool (3,), summed over ranks."""
        return self.comm.allreduce((self.areas[:, None] * self._traction).sum(axis=0), op=MPI.SUM)

    def gap(self):
        """Opening between soil and tool at each contact point (>= 0)."""
        return np.maximum(-np.einsum("ij,ij->i", self.jump(), self.normals), 0.0)
