"""Finite elements by name, their cells, and where a two-dimensional mesh lies (records
level: no FEniCSx).

A mesh is made of 8-node hexahedra or 4-node tetrahedra, or, for plane strain, of
4-node quadrilaterals or 3-node triangles in the scene's x-z plane: the mesh's axes 0 and
1 are the scene's x and z (:data:`PLANE_AXES`), y is the direction held by plane strain.
The element names the cell: the gmsh builders mesh with it and check the cells
(:mod:`soilbin.meshes.tagged`), the spaces are built on them
(:mod:`soilbin.forms.discretisation`) and the Gauss rules are theirs
(:mod:`soilbin.solver.quadrature`). A quadratic element keeps the cells' straight-sided
geometry (its mid-side nodes are the edges' midpoints).
"""
import enum

import numpy as np

#: The cell of each element family, by its DOLFINx / Basix / UFL name.
CELLS = {"hex": "hexahedron", "quad": "quadrilateral", "tet": "tetrahedron", "tri": "triangle"}
#: The scene's axes along which a two-dimensional mesh's axes 0 and 1 lie.
PLANE_AXES = (0, 2)


def embedding(dimension):
    """The (3, dimension) matrix whose columns are the mesh's axes in the scene's: a point or
    vector with ``dimension`` components x is E x in the scene's three."""
    return np.eye(3) if dimension == 3 else np.eye(3)[:, PLANE_AXES]


class Element(enum.Enum):
    """A scene's ``analysis.element``: displacement only, or with a mean-dilatation pair.

    ``hex8-reduced`` is the trilinear brick integrated at its centre only (uniform
    reduced integration): the model sees one strain per cell, so the volume change
    that associated flow ties to the shear (ε̇_v = sin ψ γ̇_max in plane strain) is met
    where the shear is measured. With 2 x 2 x 2 points, hex8 and hex8-bbar must
    meet it at every point of a cell whose shear varies (hex8-bbar with one
    dilatation for all of them): points with less shear than the cell's dilatation
    are driven to the cone's apex and the rest lock (docs/verification.md, VII.3). A brick with
    one point has hourglass modes (zero-energy nodal patterns); the supports must
    hold the mesh against them, as in the plane-strain slabs.

    The ``quad`` elements are the same on quadrilaterals of a plane-strain mesh:
    on a slab of one hex layer whose nodes move alike in y, hex8-bbar and
    quad4-bbar give one discrete solution.

    ``tet10`` is the quadratic tetrahedron (10 nodes, the 4-point rule of degree 2, exact
    for its linear strains' stiffness), for meshes of any shape; ``tet10-bbar`` adds one
    dilatation and pressure per cell (P2/P0, the tetrahedral mean-dilatation element: a
    mesh of N vertices has about 6N cells and 8N nodes, 24N displacements against 6N
    volume constraints, so isochoric flow does not lock). ``tri6`` and ``tri6-bbar`` are
    the same on triangles of a plane-strain mesh.
    """
    HEX8 = "hex8"
    HEX8_REDUCED = "hex8-reduced"
    HEX8_BBAR = "hex8-bbar"
    HEX27 = "hex27"
    HEX27_BBAR = "hex27-bbar"
    QUAD4 = "quad4"
    QUAD4_REDUCED = "quad4-reduced"
    QUAD4_BBAR = "quad4-bbar"
    QUAD9 = "quad9"
    QUAD9_BBAR = "quad9-bbar"
    TET10 = "tet10"
    TET10_BBAR = "tet10-bbar"
    TRI6 = "tri6"
    TRI6_BBAR = "tri6-bbar"

    @property
    def family(self):
        """hex, quad, tet or tri."""
        return self.value[:3] if self.value[:3] in ("hex", "tet", "tri") else "quad"

    @property
    def dimension(self):
        return 2 if self.family in ("quad", "tri") else 3

    @property
    def cell(self):
        return CELLS[self.family]

    @property
    def simplex(self):
        return self.family in ("tet", "tri")

    @property
    def degree(self):
        return 2 if self.value.split("-")[0] in ("hex27", "quad9", "tet10", "tri6") else 1

    @property
    def mixed(self):
        return self.value.endswith("-bbar")

    @property
    def reduced(self):
        return self.value.endswith("-reduced")

    @property
    def cell_dilatation(self):
        """Whether the mean-dilatation pair is one value per cell (P0): the hex8, quad4 and
        simplex ``-bbar`` elements, whose pair static condensation removes."""
        return self.mixed and (self.degree == 1 or self.simplex)

    @property
    def quadrature_degree(self):
        """Gauss rule: 2 points per direction for (tri)linear, 3 for (tri)quadratic, the
        centre (degree 1, one point) for the reduced elements, and degree 2 on simplices
        (4 points in a tetrahedron, 3 in a triangle)."""
        if self.simplex:
            return 2
        return 1 if self.reduced else 2 * self.degree

    def on(self, dimension):
        """The element of the same kind on cells of ``dimension`` (hex8-bbar <-> quad4-bbar,
        tet10-bbar <-> tri6-bbar)."""
        kinds = {e.dimension: e for e in Element if (e.degree, e.mixed, e.reduced, e.simplex)
                 == (self.degree, self.mixed, self.reduced, self.simplex)}
        return kinds[dimension]
