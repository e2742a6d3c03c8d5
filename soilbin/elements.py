"""Finite elements by name, their cells, and where a two-dimensional mesh lies (records
level: no FEniCSx).

Every mesh is made of 8-node hexahedra, or, for plane strain, of 4-node
quadrilaterals in the scene's x-z plane: the mesh's axes 0 and 1 are the
scene's x and z (:data:`PLANE_AXES`), y is the direction held by plane strain.
The gmsh builders check the cells (:mod:`soilbin.meshes.tagged`), the spaces
are built on them (:mod:`soilbin.forms.discretisation`) and the Gauss rules
are theirs (:mod:`soilbin.solver.quadrature`); each element names its cell.
"""
import enum

import numpy as np

#: The cell of a mesh of each dimension, by its DOLFINx / Basix / UFL name.
CELLS = {3: "hexahedron", 2: "quadrilateral"}
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

    @property
    def dimension(self):
        return 2 if self.value.startswith("quad") else 3

    @property
    def cell(self):
        return CELLS[self.dimension]

    @property
    def degree(self):
        return 2 if self.value.split("-")[0] in ("hex27", "quad9") else 1

    @property
    def mixed(self):
        return self.value.endswith("-bbar")

    @property
    def reduced(self):
        return self.value.endswith("-reduced")

    @property
    def quadrature_degree(self):
        """Gauss rule: 2 points per direction for (tri)linear, 3 for (tri)quadratic, and the
        centre (degree 1, one point) for the reduced elements."""
        return 1 if self.reduced else 2 * self.degree

    def on(self, dimension):
        """The element of the same kind on cells of ``dimension`` (hex8-bbar <-> quad4-bbar)."""
        kinds = {e.dimension: e for e in Element if (e.degree, e.mixed, e.reduced)
                 == (self.degree, self.mixed, self.reduced)}
        return kinds[dimension]
