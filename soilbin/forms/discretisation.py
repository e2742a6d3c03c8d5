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
"""
import dataclasses
from typing import Optional

import numpy as np

import ufl
from dolfinx import fem

from ..elements import CELL, Element


@dataclasses.dataclass(frozen=True)
class Discretisation:
    element: Element
    space: fem.FunctionSpace          # the unknown's space (mixed or vector)
    displacement_space: fem.FunctionSpace  # view of the displacement block
    basis: Optional[tuple] = None     # the dofs' axes in the world (columns), None: the world's

    @classmethod
    def create(cls, mesh, element, basis=None):
        cell = mesh.ufl_cell()
        if cell.cellname() != CELL:
            raise ValueError(f"{element.value} needs a mesh of {CELL} cells, not {cell.cellname()}")
        ve = ufl.VectorElement("Lagrange", cell, element.degree)
        if not element.mixed:
            space = fem.FunctionSpace(mesh, ve)
            return cls(element, space, space, basis)
        # P0 with trilinear, P1-disc (family "DPC") with triquadratic bricks
        pe = (ufl.FiniteElement("DG", cell, 0) if element.degree == 1
              else ufl.FiniteElement("DPC", cell, 1))
        space = fem.FunctionSpace(mesh, ufl.MixedElement([ve, pe, pe]))
        return cls(element, space, space.sub(0), basis)

    @property
    def mesh(self):
        return self.space.mesh

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
        """Displacement part (world components) of a function, trial or test function of
        ``space``."""
        u = ufl.split(w)[0] if self.element.mixed else w
        return u if self.basis is None else ufl.dot(ufl.as_matrix(self.basis), u)

    def to_world(self, values):
        """Nodal displacement dofs (n, 3) as world components."""
        return values if self.basis is None else values @ np.array(self.basis).T

    def in_dof_axes(self, points):
        """World points (n, 3) in the dofs' axes (rigid-body modes are built on these)."""
        return points if self.basis is None else points @ np.array(self.basis)
