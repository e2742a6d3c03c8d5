"""The declaration of a mesh builder (records level: no gmsh, no DOLFINx).

A builder declares, in one place, its parameter record, the cell groups
(regions) and facet groups (boundaries) of every mesh it makes, which of the
boundaries are the contact surface of a rigid tool, and the module whose
``geometry(params, simplices)`` builds the gmsh model (of hexahedra, or of
tetrahedra where ``simplices``, as the scene's element needs). That module is imported only
when a mesh is built, so a scene can be read without gmsh; building checks
that the geometry made exactly the declared groups, none of them empty but those it
declares ``may_be_empty`` (a CAD tool's faces by the way they face: a flat blade has no
top). A
plane-strain builder may also make a two-dimensional mesh in the x-z plane
(its parameter ``dimension``): then the faces of the slab in y
(``slab_faces``) are not among its boundaries.
"""
import importlib
from dataclasses import dataclass

from ..errors import InputError
from ..params import param

#: Most cells a mesh may have: more would not fit the machine (about 3e6 unknowns
#: of hex8 cells for a direct solve); refuse before gmsh runs.
MAX_CELLS = 1_000_000
#: Most times a builder's ``refine`` may split its elements (per direction).
MAX_REFINE = 32


@dataclass(frozen=True)
class Builder:
    name: str
    params: type                 # a Params record: the builder's parameters
    summary: str
    regions: tuple[str, ...]     # cell groups of every mesh it builds
    boundaries: tuple[str, ...]  # facet groups of every mesh it builds
    contact: tuple[str, ...]     # the boundaries a rigid tool acts on (the default tool.faces)
    geometry: str                # module (in soilbin.meshes) with geometry(params, simplices)
                                 # -> (regions, boundaries)
    slab_faces: tuple[str, ...] = ()  # boundaries only a three-dimensional mesh has
    may_be_empty: tuple[str, ...] = ()  # boundaries a mesh may leave without facets

    def __post_init__(self):
        stray = set(self.contact) - set(self.boundaries)
        if stray:
            raise ValueError(f"builder {self.name!r}: contact groups {sorted(stray)} are not boundaries")

    def locate(self, params, folder):
        """``params`` with any file they name found relative to ``folder`` (the scene's)."""
        return params

    @staticmethod
    def dimension(params):
        """The dimension of the meshes built with ``params``: 3, or 2 (x-z plane)."""
        return getattr(params, "dimension", 3)

    def groups(self, params):
        """(regions, boundaries, contact) of the meshes built with ``params``."""
        boundaries = self.boundaries
        if self.dimension(params) == 2:
            boundaries = tuple(b for b in boundaries if b not in self.slab_faces)
        return self.regions, boundaries, self.contact

    def check_element(self, params, element):
        """Raise an InputError if the builder cannot mesh the cells of ``element`` (an
        elements.Element) with ``params``; every builder meshes hexahedra and tetrahedra."""

    def label(self, params):
        """What the scene's messages call the source of the groups."""
        return f"mesh builder {self.name!r}"

    def build(self, params, comm, simplices=False):
        """Mesh with gmsh on rank 0 and distribute over ``comm``: a TaggedMesh of hexahedra
        (quadrilaterals), or of tetrahedra (triangles) where ``simplices``."""
        from .tagged import build_tagged_mesh
        geometry = importlib.import_module(f"{__package__}.{self.geometry}").geometry
        regions, boundaries, _ = self.groups(params)
        return build_tagged_mesh(comm, self.name, lambda: geometry(params, simplices),
                                 regions=regions, boundaries=boundaries,
                                 dimension=self.dimension(params), simplices=simplices,
                                 may_be_empty=self.may_be_empty)


def check_cell_count(cells, keys):
    """Refuse a mesh of more than MAX_CELLS cells; ``keys`` names the parameters that set it."""
    if cells > MAX_CELLS:
        raise InputError(f"{keys} give about {cells:.3g} cells; accepted: at most {MAX_CELLS:g}")


def check_proportions(lengths):
    """Refuse a length of the mesh (``lengths``: key -> value, its extents, the parts of its
    geometry and its element sizes) below MIN_PROPORTION times the largest. A graded mesh
    checks it before its cells are counted: a size of 1e-300 would count 1e900 of them."""
    extent = max(lengths.values())
    floor = MIN_PROPORTION * extent
    for key, value in lengths.items():
        if value < floor:
            raise InputError(f"{key} = {value:g}: gmsh cannot mesh a length below "
                             f"{MIN_PROPORTION:g} of the mesh's largest extent {extent:g}; "
                             f"accepted: at least {floor:g}")


#: Longest extent a mesh parameter may have, in the scene's length unit.
MAX_LENGTH = 1.0e6
#: Shortest length of a mesh (a part of its geometry or an element size) relative to its
#: largest extent. gmsh's mesher fails near its geometric tolerance (Geometry.Tolerance,
#: 1e-8): in the 12 in soil of scenes/container-footing.toml an edge_size of 1e-8 leaves
#: triangles and 1e-9 aborts gmsh, and 8e-9 of the extent leaves triangles in a soil scaled
#: to 12e-6 in. And the builders find their faces within 1e-6 of the extent
#: (:func:`.blocks.entities_within`): at that length two faces are one (a 1e6 x 1 x 1 block
#: lost its loaded face). 1e-5 keeps a decade from there (a mesh graded over more has no use).
MIN_PROPORTION = 1.0e-5


def length_param(default, doc):
    """A positive, finite length of the geometry."""
    return param(default, lo=0.0, hi=MAX_LENGTH, lo_open=True, doc=doc)


def dimension_param():
    return param(3, lo=2, hi=3, doc="3: a slab of one hex layer in y; 2: quadrilaterals in the x-z "
                                    "plane (plane strain solved in 2D, a third of the unknowns)")


def refine_param(doc):
    return param(1, lo=1, hi=MAX_REFINE, doc=doc)
