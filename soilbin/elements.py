"""Finite elements by name, and the one cell type of every mesh (records level: no FEniCSx).

Every mesh is made of 8-node hexahedra: the gmsh builders check that
(:mod:`soilbin.meshes.tagged`), the spaces are built on them
(:mod:`soilbin.forms.discretisation`) and the Gauss rules are theirs
(:mod:`soilbin.solver.quadrature`); all three take the cell from :data:`CELL`.
"""
import enum

#: The cell of every mesh, by its DOLFINx / Basix / UFL name (gmsh: "Hexahedron", order 1).
CELL = "hexahedron"


class Element(enum.Enum):
    """A scene's ``analysis.element``: displacement only, or with a mean-dilatation pair."""
    HEX8 = "hex8"
    HEX8_BBAR = "hex8-bbar"
    HEX27 = "hex27"
    HEX27_BBAR = "hex27-bbar"

    @property
    def degree(self):
        return 1 if self in (Element.HEX8, Element.HEX8_BBAR) else 2

    @property
    def mixed(self):
        return self in (Element.HEX8_BBAR, Element.HEX27_BBAR)

    @property
    def quadrature_degree(self):
        """Gauss rule: 2x2x2 points for trilinear, 3x3x3 for triquadratic."""
        return 2 * self.degree
