"""Finite element spaces: displacement, optionally with a mean-dilatation pair.

Plane-strain plastic flow of von Mises soil is isochoric, which locks a plain
displacement element. The ``-bbar`` elements add a discontinuous dilatation
θ and pressure p (three-field Hu–Washizu, Simo, Taylor & Pister 1985): with
P0 fields on trilinear bricks this is exactly the B-bar / mean-dilatation
brick of Nagtegaal, Parks & Rice (1974); on triquadratic bricks the P1-disc
pair gives the LBB-stable Q2/P1 element. θ and p are cell-local, so they add
only cell-interior unknowns to the direct solve.

In a rotated frame (``problem.frame``) the displacement dofs are components
along the scene's own axes, the columns of ``basis`` in the world: the forms
see u = basis · u_dofs, and every support or roller holds a dof.

On a two-dimensional mesh (plane strain in the x-z plane, ``elements``) the
dofs are the x and z components. The forms see the three-dimensional
displacement u = (u_x, 0, u_z) and its 3 x 3 gradient, whose y row and column
are zero, so the models integrate the full stress state as in the slab.
"""
import dataclasses
from typing import Optional

import numpy as np

import ufl
from dolfinx import fem

from ..elements import PLANE_AXES, Element, embedding


@dataclasses.dataclass(frozen=True)
class Discretisation:
    element: Element
    space: fem.FunctionSpace          # the unknown's space (mixed or vector)
    displacement_space: fem.FunctionSpace  # view of the displacement block
    basis: Optional[tuple] = None     # the dofs' axes in the world (columns), None: the world's

    @classmethod
    def create(cls, mesh, element, basis=None):
        cell = mesh.ufl_cell()
        if cell.cellname() != element.cell:
            raise ValueError(f"{element.value} needs a mesh of {element.cell} cells, not "
                             f"{cell.cellname()}")
        if basis is not None and mesh.geometry.dim != 3:
            raise ValueError("a two-dimensional mesh cannot be turned out of its plane")
        ve = ufl.VectorElement("Lagrange", cell, element.degree)
        if not element.mixed:
            space = fem.FunctionSpace(mesh, ve)
            return cls(element, space, space, basis)
        # P0 with trilinear bricks and on simplices, P1-disc (family "DPC") with triquadratic
        # bricks
        pe = (ufl.FiniteElement("DG", cell, 0) if element.cell_dilatation
              else ufl.FiniteElement("DPC", cell, 1))
        space = fem.FunctionSpace(mesh, ufl.MixedElement([ve, pe, pe]))
        return cls(element, space, space.sub(0), basis)

    @property
    def mesh(self):
        return self.space.mesh

    @property
    def dimension(self):
        """The mesh's: 3, or 2 (plane strain in the x-z plane)."""
        return self.mesh.geometry.dim

    @property
    def planar(self):
        return self.dimension == 2

    def component(self, axis):
        """The displacement dof component along the scene's ``axis`` (0, 1, 2 for x, y, z);
        None for y on a two-dimensional mesh (plane strain holds it)."""
        if not self.planar:
            return axis
        return PLANE_AXES.index(axis) if axis in PLANE_AXES else None

    def embed(self, a):
        """A UFL vector along the mesh's axes in the scene's three components (0 along y in
        plane strain)."""
        return ufl.as_vector([a[0], 0, a[1]]) if self.planar else a

    def grad(self, a):
        """The 3 x 3 gradient of a UFL 3-vector field (its y column zero in plane strain)."""
        g = ufl.grad(a)
        if not self.planar:
            return g
        return ufl.as_matrix([[g[i, 0], 0, g[i, 1]] for i in range(3)])

    def div(self, a):
        return ufl.tr(self.grad(a)) if self.planar else ufl.div(a)

    def normal(self):
        """The outward unit normal of the facets, in the scene's three components."""
        return self.embed(ufl.FacetNormal(self.mesh))

    def coordinates(self):
        """The position, in the scene's three components (UFL)."""
        return self.embed(ufl.SpatialCoordinate(self.mesh))

    def measure(self, **kwargs):
        """The cell measure whose rule matches the quadrature spaces."""
        q = self.element.quadrature_degree
        return ufl.dx(domain=self.mesh, metadata={"quadrature_degree": q,
                                                   "quadrature_scheme": "default"}, **kwargs)

    def facet_measure(self, facet_tags):
        """The facet measure of the tagged facets, with the rule of the cell measure's degree
        (a traction per deformed area is not polynomial: FFCx would pick 22 x 22 points)."""
        return ufl.Measure("ds", domain=self.mesh, subdomain_data=facet_tags,
                           metadata={"quadrature_degree": self.element.quadrature_degree})

    def displacement(self, w):
        """Displacement part (world components, three) of a function, trial or test function
        of ``space``."""
        u = ufl.split(w)[0] if self.element.mixed else w
        if self.planar:
            return self.embed(u)
        return u if self.basis is None else ufl.dot(ufl.as_matrix(self.basis), u)

    def vertex_dofs(self, nodal_space):
        """The unknown's dof of each displacement component at each node of a P1 space
        (n_nodes, dimension; ghost nodes included): the displacement's vertex dofs, which
        come first in every Lagrange cell, matched cell by cell (no ``sub(0).collapse()``:
        its dof reordering takes minutes on 10⁶ unknowns)."""
        per_cell = nodal_space.dofmap.cell_dofs(0).size
        cells = nodal_space.dofmap.list.array.reshape(-1, per_cell)
        imap = nodal_space.dofmap.index_map
        dofs = np.empty((imap.size_local + imap.num_ghosts, self.dimension), dtype=np.int32)
        for i in range(self.dimension):
            component = self.displacement_space.sub(i).dofmap.list.array
            dofs[cells, i] = component.reshape(len(cells), -1)[:, :per_cell]
        return dofs

    def in_mesh_axes(self, values):
        """Nodal displacement dofs (n, dimension) along the mesh's axes (the world's in 3D)."""
        return values if self.basis is None else values @ np.array(self.basis).T

    def to_world(self, values):
        """Points or vectors along the mesh's axes (n, dimension) in the world's three."""
        return values @ embedding(2).T if self.planar else values

    def in_dof_axes(self, points):
        """Points of the mesh (n, 3; in 2D the third coordinate is 0) in the dofs' axes
        (n, dimension): rigid-body modes are built on these."""
        if self.planar:
            return points[:, :2]
        return points if self.basis is None else points @ np.array(self.basis)
