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
    """A scene's ``analysis.element``: displacement only, or with a mean-dilatation pair.

    ``hex8-reduced`` is the trilinear brick integrated at its centre only (uniform
    reduced integration): the model sees one strain per cell, so the volume change
    that associated flow ties to the shear (ε̇_v = sin ψ γ̇_max in plane strain) is met
    where the shear is measured. With 2 x 2 x 2 points, hex8 and hex8-bbar must
    meet it at every point of a cell whose shear varies (hex8-bbar with one
    dilatation for all of them): points with less shear than the cell's dilatation
    are driven to the cone's apex and the rest lock (README, VII.3). A brick with
    one point has hourglass modes (zero-energy nodal patterns); the supports must
    hold the mesh against them, as in the plane-strain slabs.
    """
    HEX8 = "hex8"
    HEX8_REDUCED = "hex8-reduced"
    HEX8_BBAR = "hex8-bbar"
    HEX27 = "hex27"
    HEX27_BBAR = "hex27-bbar"

    @property
    def degree(self):
        return 1 if self in (Element.HEX8, Element.HEX8_REDUCED, Element.HEX8_BBAR) else 2

    @property
    def mixed(self):
        return self in (Element.HEX8_BBAR, Element.HEX27_BBAR)

    @property
    def quadrature_degree(self):
        """Gauss rule: 2x2x2 points for trilinear, 3x3x3 for triquadratic, and the
        centre (degree 1, one point) for hex8-reduced."""
        return 1 if self is Element.HEX8_REDUCED else 2 * self.degree
