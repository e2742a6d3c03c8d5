"""Scenes: TOML files describing one analysis, parsed into validated frozen records.

A scene names a mesh builder and its parameters, the material of each
region, supports, the loading (force or displacement control), analysis and
solver options, outputs and the headline results of its summary. Every
value is checked (type, accepted range, known name) before anything is
built; ``--set dotted.key=value`` overrides go through the same checks.
"""
import copy
import dataclasses
import enum
from pathlib import Path

from ..elements import Element
from ..errors import InputError
from ..meshes import BUILDERS
from ..models import MODELS
from ..models.mohr_coulomb_interface import MohrCoulombInterface
from ..params import Params, from_table, magnitude_param, param
from . import toml_out
from .geostatic import Geostatic, read_geostatic
from .toml_in import assignment, read_scene_tables
from .units import read_units


class Control(enum.Enum):
    FORCE = "force"
    DISPLACEMENT = "displacement"
    INDIRECT = "indirect_displacement"   # a traction, its magnitude set by a mean displacement


class Direction(enum.Enum):
    """A signed coordinate axis."""
    PX, MX, PY, MY, PZ, MZ = "+x", "-x", "+y", "-y", "+z", "-z"

    @property
    def axis(self):
        return "xyz".index(self.value[1])

    @property
    def vector(self):
        v = [0.0, 0.0, 0.0]
        v[self.axis] = 1.0 if self.value[0] == "+" else -1.0
        return v


class LineSearch(enum.Enum):
    BASIC = "basic"   # full Newton steps: one constitutive update per iterate
    BACKTRACKING = "bt"
    CRITICAL_POINT = "cp"   # the energy's stationary point along the Newton direction


class LinearSolverKind(enum.Enum):
    AUTO = "auto"          # LDLT if the tangent is symmetric, else LU; BLR on large systems
    LU = "lu"              # MUMPS LU
    CHOLESKY = "cholesky"  # MUMPS LDLT of the condensed system
    AMG = "amg"            # CG or GMRES with GAMG on the condensed system
    BLR = "blr"            # MUMPS block low-rank LU of the condensed system


class Field(enum.Enum):
    DISPLACEMENT = "displacement"
    STRESS = "stress"
    PLASTIC_STRAIN = "plastic_strain"
    GAP = "gap"   # opening between soil and tool (written only when there is an interface)


class Headline(enum.Enum):
    """How a headline result is read off the load–displacement curve.

    Displacement and force are measured along the loading direction, so
    settlement and compressive pressure are positive (geomechanics signs).
    ``collapse_pressure`` is the pressure of the first step whose settlement
    increment per unit pressure increment is at least ``COLLAPSE_COMPLIANCE``
    times the secant one at the first nominal step (1/steps of the load; the
    elastic compliance), as a run to collapse stops: where the settlement per
    step blows up (or the first step at which the pressure falls). It does not depend on how far Newton gets past that point
    (in large deformation the geometry keeps the curve rising slowly and the
    last converged load does). Where no step gets there and the run ended at the
    soil's limit all the same (no larger load converged, status "collapse": with
    ``steps = 1`` the strip load's limit lies below the first nominal step), it is
    the last converged step's pressure; else none.
    The pressures are a loaded boundary's; ``final_lift`` is a tool's (the soil's
    upward force on it: a rough wall's friction). ``steady_force`` is the force averaged over
    the last sixth of the travel (the plateau of a tool pushed far: the steady draft over the
    last inch of six), ``steady_spread`` its range there over that mean, ``steady_slope``
    the slope of the straight line fitted to the force there (force per unit displacement:
    zero on a steady state).
    """
    FINAL_DISPLACEMENT = "final_displacement"
    FINAL_PRESSURE = "final_pressure"
    PEAK_PRESSURE = "peak_pressure"
    COLLAPSE_PRESSURE = "collapse_pressure"
    FINAL_FORCE = "final_force"
    PEAK_FORCE = "peak_force"
    FINAL_LIFT = "final_lift"
    STEADY_FORCE = "steady_force"
    STEADY_SPREAD = "steady_spread"
    STEADY_SLOPE = "steady_slope"


#: Headline results read off a loaded boundary's pressure, and off a tool's lift.
BOUNDARY_HEADLINES = (Headline.FINAL_PRESSURE, Headline.PEAK_PRESSURE, Headline.COLLAPSE_PRESSURE)
TOOL_HEADLINES = (Headline.FINAL_LIFT,)


#: Settlement per unit pressure, relative to the elastic one, that marks the collapse.
COLLAPSE_COMPLIANCE = 100.0


@dataclasses.dataclass(frozen=True)
class HeadlineResult(Params):
    """A headline value: a quantity read off the curve, optionally divided by a
    scale (to make it dimensionless, e.g. an earth-pressure coefficient)."""
    of: Headline = param(doc="the quantity read off the curve")
    divide_by: float = magnitude_param(1.0, doc="scale the value is divided by")


AXES = ("x", "y", "z")


@dataclasses.dataclass(frozen=True)
class Support(Params):
    boundary: str = param(doc="facet group of the mesh")
    fix: tuple[str, ...] = param(doc="displacement components held at zero: any of x, y, z")

    def __post_init__(self):
        super().__post_init__()
        bad = [c for c in self.fix if c not in AXES]
        if bad or not self.fix:
            raise InputError(f"fix = {list(self.fix)!r}: expected a non-empty list of x, y, z")


@dataclasses.dataclass(frozen=True)
class Traction(Params):
    """A dead load (e.g. a surcharge) applied in full from the first step on."""
    boundary: str = param(doc="facet group of the mesh")
    direction: Direction = param(doc="signed axis of the traction, e.g. '-z'")
    magnitude: float = magnitude_param(zero=True, doc="traction (force/area)")


#: Most load steps a scene may ask for (each is a Newton solve).
MAX_STEPS = 10000


@dataclasses.dataclass(frozen=True)
class Loading(Params):
    control: Control = param(doc="force: a traction on the boundary; displacement: a prescribed "
                                 "displacement; indirect_displacement: a uniform traction whose "
                                 "magnitude is solved for so that the boundary's mean displacement "
                                 "is the load factor's (follows the load to its peak and past it)")
    boundary: str = param(doc="facet group that is loaded or displaced")
    direction: Direction = param(doc="signed axis of the load, e.g. '-z'")
    magnitude: float = magnitude_param(doc="traction (force/area) or displacement (length; the "
                                           "mean one under indirect_displacement) at load "
                                           "factor 1")
    steps: int = param(lo=1, hi=MAX_STEPS, doc="number of equal load steps to load factor 1")
    max_cuts: int = param(8, lo=0, hi=30, doc="times a failing step may be halved in a row")
    first_cuts: int = param(0, lo=0, hi=30, doc="times the first step is halved before it is "
                                               "tried (the next ones double back after easy "
                                               "steps); at most max_cuts")
    regrow_after_cut: int = param(0, lo=0, hi=100,
                                  doc="steps converged in few Newton iterations (those after "
                                      "which the increment doubles) at the size of a cut, the "
                                      "cut step's own included, before the increment doubles "
                                      "again; 0: at once")
    until_collapse: bool = param(False, doc="force control: the run ends normally at the soil's "
                                            "limit, the first step whose displacement per unit load "
                                            "is 100 times the secant one at the first nominal "
                                            "step (1/steps of the load), or a step that cannot "
                                            "be converged")

    def __post_init__(self):
        super().__post_init__()
        if self.first_cuts > self.max_cuts:
            raise InputError(f"first_cuts: {self.first_cuts} is more than max_cuts "
                             f"({self.max_cuts}), the smallest increment allowed")


TOOL = "tool"   # the loading boundary name that means the rigid tool


@dataclasses.dataclass(frozen=True)
class EstimateStrength(Params):
    """The soil's c, phi that the McKyes & Ali draft estimate of a tool uses (summary.json,
    curve.png) in place of its material's own, or its failure surface's at the wedge."""
    phi: float = param(lo=0.0, hi=90.0, hi_open=True, doc="the soil's friction angle in the "
                                                          "draft estimate [degrees]")
    c: float = magnitude_param(0.0, zero=True, doc="the soil's cohesion in the draft estimate "
                                                   "(force/area)")
    source: str = param("tool.estimate", doc="where phi and c come from, shown with the "
                                             "estimate, e.g. 'laboratory, section VII.5'")


@dataclasses.dataclass(frozen=True)
class Tool(Params):
    """A rigid tool against faces of the soil mesh (a cavity's, or part of its outer boundary
    such as a wall's), displaced as a whole (loading.boundary = 'tool')."""
    faces: tuple[str, ...] = param(doc="soil boundaries against the tool (a cavity's faces, or "
                                       "a wall); default: the mesh builder's contact groups")
    bonded: bool = param(False, doc="true: the interface's springs never slip or open (no "
                                    "interface behaviour)")
    interface: MohrCoulombInterface = param(None, doc="Mohr-Coulomb interface law (its k_n, k_s "
                                                      "also tie a bonded tool)")
    estimate: EstimateStrength = param(None, doc="the c, phi of the McKyes & Ali draft estimate; "
                                                 "default: the soil material's own (a cap "
                                                 "model's failure surface linearised at the "
                                                 "wedge)")

    def __post_init__(self):
        super().__post_init__()
        if not self.faces:
            raise InputError("faces: name at least one boundary")
        if self.interface is None:
            raise InputError("interface: a [tool.interface] table is required (its penalty "
                             "stiffnesses k_n, k_s also tie a bonded tool)")

    @property
    def law(self):
        """The contact law: the interface, or its springs alone where the tool is bonded."""
        return self.interface.bonded() if self.bonded else self.interface


@dataclasses.dataclass(frozen=True)
class Analysis(Params):
    element: Element = param(Element.HEX8, doc="hex8, hex8-reduced (one point per cell), hex8-bbar, hex27, "
                                              "hex27-bbar (mean dilatation) on hexahedra, tet10 or "
                                              "tet10-bbar on tetrahedra; on a 2D mesh quad4, "
                                              "quad4-reduced, quad4-bbar, quad9, quad9-bbar, tri6 "
                                              "or tri6-bbar; the builders mesh with its cells")
    plane_strain: bool = param(False, doc="hold the y displacement at zero everywhere (x-z plane)")
    large_deformation: bool = param(False, doc="updated Lagrangian with an objective stress update "
                                               "(geometric stiffness, moving mesh)")
    frame_rotation: tuple[float, ...] = param(
        (0.0, 0.0, 0.0), doc="rotation vector [degrees, each in [-360, 360]] turning the whole "
                             "scene (mesh, supports, rollers, plane strain, loads, gravity): "
                             "results along the loading direction must not change")

    def __post_init__(self):
        super().__post_init__()
        if len(self.frame_rotation) != 3:
            raise InputError(f"frame_rotation = {list(self.frame_rotation)!r}: expected 3 numbers")
        if any(abs(angle) > 360.0 for angle in self.frame_rotation):
            raise InputError(f"frame_rotation = {list(self.frame_rotation)!r}: expected "
                             "components in [-360, 360] degrees")


#: The smallest residual tolerance: an assembled residual's rounding is about 1e-16 of its
#: largest terms times their number, so a Newton tolerance below this is never met and
#: every step would be cut.
RESIDUAL_FLOOR = 1e-14


@dataclasses.dataclass(frozen=True)
class Solver(Params):
    rtol: float = param(1e-9, lo=RESIDUAL_FLOOR, hi=1.0, hi_open=True,
                        doc="residual reduction that ends Newton in a step")
    atol: float = param(1e-10, lo=RESIDUAL_FLOOR, hi=1.0, hi_open=True,
                        doc="residual floor relative to the run's force scale")
    max_iterations: int = param(25, lo=1, hi=200, doc="Newton iterations before the step is cut")
    line_search: LineSearch = param(LineSearch.BACKTRACKING,
                                    doc="basic (full steps), bt (Armijo backtracking on the residual "
                                        "norm) or cp (the energy's stationary point along the step)")
    linear: LinearSolverKind = param(LinearSolverKind.AUTO,
                                     doc="linear solver: auto, lu, cholesky (LDLT), amg or blr "
                                         "(block low-rank LU)")
    tangent_floor: float = param(0.0, lo=0.0, hi=1.0,
                                 doc="fraction of the elastic stiffness added to every soil point's "
                                     "tangent in Newton's matrix (the residual, so the solution, "
                                     "unchanged): keeps the matrix regular where a point at a "
                                     "vertex of its yield surface (zero tangent) holds a node alone")


@dataclasses.dataclass(frozen=True)
class Output(Params):
    fields: tuple[Field, ...] = param((Field.DISPLACEMENT, Field.STRESS, Field.PLASTIC_STRAIN),
                                      doc="XDMF fields: displacement, stress, plastic_strain, gap")
    every: int = param(1, lo=1, doc="write fields every this many converged steps (and the last)")
    at: tuple[float, ...] = param((), doc="loads (force or displacement, as loading.magnitude) where "
                                          "a step ends and fields and sections are written")

    def stops(self, loading):
        """The load factors of ``at``."""
        return tuple(sorted(value / loading.magnitude for value in self.at))


@dataclasses.dataclass(frozen=True)
class Remesh(Params):
    min_quality: float = param(0.0, lo=0.0, hi=1.0, hi_open=True,
                               doc="remesh after a converged step whose least scaled Jacobian "
                                   "(mesh_quality in curve.csv) is below this (0: never)")
    every: int = param(0, lo=0, doc="remesh after every this many converged steps as well "
                                    "(0: only by min_quality)")
    smooth_first: bool = param(True, doc="a three-dimensional soil below min_quality keeps "
                                         "its cells, their nodes moved, where that lifts its "
                                         "least scaled Jacobian to 1.15 min_quality (the "
                                         "transfer then loses far less force); else it is "
                                         "meshed afresh")
    local_first: bool = param(False, doc="a three-dimensional soil below min_quality that "
                                         "smoothing does not mend is meshed afresh only "
                                         "around its cells below 1.15 min_quality (up to "
                                         "three layers of neighbours), the rest kept, where "
                                         "that lifts it to 1.15 min_quality; else all of it. "
                                         "Off by default: gmsh fills a cavity with fewer "
                                         "nodes than it had, and a tool's draft climbs on "
                                         "the coarser cells (docs/theory.md, remeshing)")
    retries: int = param(3, lo=0, doc="after a remesh that fails (gmsh, the transfer or the "
                                      "re-equilibration), go on on the old mesh and try again "
                                      "after each of up to this many steps before the run "
                                      "stops (0: stop at once)")

    @property
    def active(self):
        return self.min_quality > 0.0 or self.every > 0


@dataclasses.dataclass(frozen=True)
class SoilContact(Params):
    """The soil against itself where its boundary folds over (problem.soil_contact)."""
    faces: tuple[str, ...] = param(doc="soil boundaries that may touch each other (any two of "
                                       "them, or one folding onto itself)")
    k_n: float = magnitude_param(doc="normal penalty stiffness (traction per length); each "
                                     "face's nodes press the other's triangles, so two faces "
                                     "in contact are held by 2 k_n")
    standoff: float = param(0.0, lo=0.0, hi=1.0e20, doc="gap (length) at which the contact "
                                                         "takes hold: the penalty's penetration "
                                                         "stays short of the other face")

    def __post_init__(self):
        super().__post_init__()
        if not self.faces:
            raise InputError("faces: name at least one boundary")


@dataclasses.dataclass(frozen=True)
class Scene:
    path: Path
    title: str
    units: str
    mesh_builder: str
    mesh: Params
    materials: dict          # material name -> model instance
    regions: dict            # cell group -> material name
    supports: tuple
    loading: Loading
    analysis: Analysis
    solver: Solver
    output: Output
    headline: dict           # result key -> HeadlineResult
    tool: Tool = None
    tractions: tuple = ()
    geostatic: Geostatic = None
    remesh: Remesh = Remesh()
    soil_contact: SoilContact = None

    @property
    def name(self):
        return self.path.stem

    @property
    def unit_system(self):
        """The force and length units of ``units`` (records.units: F and L if unnamed)."""
        return read_units(self.units)

    def resolved(self):
        """The scene with every default filled in, as TOML text (re-runnable)."""
        def table(record):
            return {f.name: getattr(record, f.name) for f in dataclasses.fields(record)}
        data = {"title": self.title, "units": self.units,
                "mesh": {"builder": self.mesh_builder, **table(self.mesh)},
                "regions": dict(self.regions),
                "materials": {n: {"model": _model_name(m), **table(m)} for n, m in self.materials.items()},
                "supports": [table(s) for s in self.supports],
                "tractions": [table(t) for t in self.tractions],
                "loading": table(self.loading), "analysis": table(self.analysis),
                "solver": table(self.solver), "output": table(self.output),
                "headline": {k: table(v) for k, v in self.headline.items()}}
        if self.geostatic is not None:
            data["geostatic"] = table(self.geostatic)
        if self.remesh.active:
            data["remesh"] = table(self.remesh)
        if self.soil_contact is not None:
            data["soil_contact"] = table(self.soil_contact)
        if self.tool is not None:
            data["tool"] = {"faces": self.tool.faces, "bonded": self.tool.bonded}
            if self.tool.interface is not None:
                data["tool"]["interface"] = table(self.tool.interface)
            if self.tool.estimate is not None:
                data["tool"]["estimate"] = table(self.tool.estimate)
        return toml_out.dumps(data)


#: Tables --set may create: all defaults, or (soil_contact) keys --set gives in turn.
OPTIONAL_TABLES = ("analysis", "solver", "output", "remesh", "soil_contact")
TOP_LEVEL = ("title", "units", "mesh", "regions", "materials", "supports", "loading",
             "analysis", "solver", "output", "headline", "tool", "tractions",
             "geostatic", "remesh", "soil_contact")


def _model_name(model):
    return next(name for name, cls in MODELS.items() if type(model) is cls)


def apply_overrides(raw, overrides):
    """Apply 'dotted.key=value' overrides to the raw TOML dict (returns a new dict)."""
    raw = copy.deepcopy(raw)
    for item in overrides:
        key, value = assignment(item)
        *parents, leaf = key.split(".")
        node = raw
        for depth, part in enumerate(parents):
            if node is raw and part in OPTIONAL_TABLES:
                node = raw.setdefault(part, {})
            elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
                node = node[int(part)]
            elif isinstance(node, dict) and part in node:
                if parents[:depth] == ["headline"] and isinstance(node[part], str):
                    node[part] = {"of": node[part]}   # a headline given by name: {of = name}
                node = node[part]
            else:
                raise InputError(f"--set {key}: the scene has no table {'.'.join(parents[:depth + 1])!r}")
        if not isinstance(node, dict):
            raise InputError(f"--set {key}: {'.'.join(parents)!r} is not a table")
        if parents == [] and leaf not in TOP_LEVEL:
            raise InputError(f"--set {key}: unknown key; top-level keys: {', '.join(TOP_LEVEL)}")
        node[leaf] = value
    return raw


def _require(raw, key, kind):
    if key not in raw:
        raise InputError(f"missing table [{key}]" if kind is dict else f"missing key {key!r}")
    return _optional(raw, key, kind)


def _optional(raw, key, kind):
    """raw[key] (empty if absent), which must be a table (dict) or an array of tables (list)."""
    value = raw.get(key, kind())
    if not isinstance(value, kind):
        raise InputError(f"{key}: expected {'a table' if kind is dict else 'an array of tables [[' + key + ']]'}, "
                         f"got {value!r}")
    return value


def _choice(value, where, choices, problem):
    """A name among ``choices``; a list, a table or an unknown name is an error naming the key."""
    if not isinstance(value, str) or value not in choices:
        raise InputError(f"{where} = {value!r}: {problem}: {', '.join(choices)}")
    return value


def _text(raw, key, hint):
    value = raw.get(key, "")
    if not isinstance(value, str) or not value:
        raise InputError(f"{key}: {hint}")
    return value


def _parse(raw, path):
    unknown = sorted(set(raw) - set(TOP_LEVEL))
    if unknown:
        raise InputError(f"unknown key {unknown[0]!r}; top-level keys: {', '.join(TOP_LEVEL)}")
    title = _text(raw, "title", "a one-line description is required")
    units = _text(raw, "units", "state the units of the scene, e.g. 'lb, in'")
    mesh_table = dict(_require(raw, "mesh", dict))
    builder_name = _choice(mesh_table.pop("builder", None), "mesh.builder", BUILDERS,
                           "unknown mesh builder; known")
    builder = BUILDERS[builder_name]
    mesh = builder.locate(from_table(builder.params, mesh_table, "mesh"), path.parent)
    region_groups, boundary_groups, contact_groups = builder.groups(mesh)
    source = builder.label(mesh)

    materials = {}
    for name, table in _require(raw, "materials", dict).items():
        if not isinstance(table, dict) or "model" not in table:
            raise InputError(f"materials.{name}: missing key 'model'")
        table = dict(table)
        model_name = _choice(table.pop("model"), f"materials.{name}.model", MODELS,
                             "unknown material model; known")
        materials[name] = from_table(MODELS[model_name], table, f"materials.{name}")

    regions = _require(raw, "regions", dict)
    for region, material in regions.items():
        _choice(region, f"regions.{region}", region_groups,
                f"{source} has no such region; its regions")
        _choice(material, f"regions.{region}", materials, "no such material; defined in [materials]")
    missing = [r for r in region_groups if r not in regions]
    if missing:
        raise InputError(f"regions: no material for region {missing[0]!r}")

    supports = tuple(from_table(Support, s, f"supports[{i}]")
                     for i, s in enumerate(_optional(raw, "supports", list)))
    tractions = tuple(from_table(Traction, t, f"tractions[{i}]")
                      for i, t in enumerate(_optional(raw, "tractions", list)))
    loading = from_table(Loading, _require(raw, "loading", dict), "loading")
    tool = _tool(raw, source, boundary_groups, contact_groups) if "tool" in raw else None
    named = [(f"supports[{i}].boundary", s.boundary) for i, s in enumerate(supports)]
    named += [(f"tractions[{i}].boundary", t.boundary) for i, t in enumerate(tractions)]
    named += [(f"tool.faces[{i}]", face) for i, face in enumerate(tool.faces if tool else ())]
    soil_contact = (from_table(SoilContact, raw["soil_contact"], "soil_contact")
                    if "soil_contact" in raw else None)
    named += [(f"soil_contact.faces[{i}]", face)
              for i, face in enumerate(soil_contact.faces if soil_contact else ())]
    if loading.until_collapse and loading.control is not Control.FORCE:
        raise InputError(f"loading.until_collapse = true: only under force control (loading.control "
                         f"= {loading.control.value!r} follows the load past its limit without it)")
    if loading.boundary == TOOL:
        if tool is None:
            raise InputError("loading.boundary = 'tool' needs a [tool] table")
        if loading.control is Control.INDIRECT:
            raise InputError("loading.control = 'indirect_displacement' drives a traction on a "
                             "boundary, not the tool: use displacement or force")
    else:
        named.append(("loading.boundary", loading.boundary))
    for where, name in named:
        _choice(name, where, boundary_groups, f"{source} has no such boundary; its boundaries")

    analysis = from_table(Analysis, raw.get("analysis", {}), "analysis")
    _check_dimension(builder.dimension(mesh), analysis, supports, tractions, loading)
    builder.check_element(mesh, analysis.element)
    _check_held(supports, loading, analysis, tool)
    headline = {}
    unread, driven = ((BOUNDARY_HEADLINES, "a tool") if loading.boundary == TOOL
                      else (TOOL_HEADLINES, "a loaded boundary"))
    for key, value in _optional(raw, "headline", dict).items():
        spec = value if isinstance(value, dict) else {"of": value}
        headline[key] = from_table(HeadlineResult, spec, f"headline.{key}")
        if headline[key].of in unread:
            raise InputError(f"headline.{key}: {headline[key].of.value} is not read off {driven}")

    if tool is not None and any(analysis.frame_rotation):
        raise InputError("analysis.frame_rotation: a scene with a tool cannot be rotated (the "
                         "tool's interface works in world components)")
    if soil_contact is not None and (builder.dimension(mesh) != 3 or any(analysis.frame_rotation)):
        raise InputError("[soil_contact]: the soil's contact with itself is of three-dimensional "
                         "meshes, unturned (no analysis.frame_rotation)")
    geostatic = None
    if "geostatic" in raw:
        geostatic = read_geostatic(raw["geostatic"], {m: materials[m] for m in regions.values()})
    solver = from_table(Solver, raw.get("solver", {}), "solver")
    if loading.control is Control.INDIRECT and solver.line_search is LineSearch.CRITICAL_POINT:
        raise InputError("solver.line_search = 'cp' needs an energy that the Newton step lowers; "
                         "under loading.control = 'indirect_displacement' the traction's magnitude "
                         "is a multiplier of the displacement's equation (a saddle point, no such "
                         "energy): use 'bt' or 'basic'")
    output = from_table(Output, raw.get("output", {}), "output")
    remesh = from_table(Remesh, raw.get("remesh", {}), "remesh")
    if remesh.active:
        _check_remesh(builder.dimension(mesh), analysis, regions)
    for i, value in enumerate(output.at):
        if not 0.0 < value <= loading.magnitude:
            raise InputError(f"output.at[{i}] = {value!r} is outside (0, loading.magnitude = "
                             f"{loading.magnitude!r}]")
    return Scene(path=path, title=title, units=units, mesh_builder=builder_name, mesh=mesh,
                 materials=materials, regions=dict(regions), supports=supports, loading=loading,
                 analysis=analysis, solver=solver,
                 output=output,
                 headline=headline, tool=tool, tractions=tractions, geostatic=geostatic,
                 remesh=remesh, soil_contact=soil_contact)


def _check_remesh(dimension, analysis, regions):
    """Remeshing meshes the deformed soil afresh: the soil moves with the mesh (large
    deformation), and the remesher takes one soil region of a two-dimensional mesh or of a
    tetrahedral one, unturned."""
    if not analysis.large_deformation:
        raise InputError("[remesh] needs analysis.large_deformation = true (in small strain the "
                         "mesh does not move)")
    if dimension == 3 and not analysis.element.simplex:
        raise InputError(f"[remesh]: remeshing takes two-dimensional (plane-strain) meshes or "
                         f"tetrahedra (analysis.element = tet10 or tet10-bbar); this scene's "
                         f"mesh is of {analysis.element.value}")
    if len(regions) != 1 or any(analysis.frame_rotation):
        raise InputError("[remesh]: remeshing takes one soil region and no "
                         "analysis.frame_rotation")


def _check_dimension(dimension, analysis, supports, tractions, loading):
    """The element fits the mesh's cells; a two-dimensional mesh is a plane-strain x-z plane:
    nothing acts along y, and it cannot be turned out of its plane."""
    element = analysis.element
    if element.dimension != dimension:
        mesh = "a 3D mesh" if dimension == 3 else "a 2D mesh (mesh.dimension = 2)"
        raise InputError(f"analysis.element = {element.value!r} is not an element of {mesh}: "
                         f"use {element.on(dimension).value!r}")
    if dimension == 3:
        return
    where = "mesh.dimension = 2 (plane strain in the x-z plane)"
    if not analysis.plane_strain:
        raise InputError(f"analysis.plane_strain: {where} needs it true")
    for i, support in enumerate(supports):
        if "y" in support.fix:
            raise InputError(f"supports[{i}].fix: y is not a displacement of {where}; "
                             "plane strain holds it")
    along_y = [(f"tractions[{i}].direction", t.direction) for i, t in enumerate(tractions)]
    for key, direction in along_y + [("loading.direction", loading.direction)]:
        if direction.axis == 1:
            raise InputError(f"{key} = {direction.value!r}: {where} has no y direction")
    if any(analysis.frame_rotation):
        raise InputError(f"analysis.frame_rotation: {where} cannot be turned out of its plane")


def _check_held(supports, loading, analysis, tool):
    """Every displacement component held somewhere (a support, plane strain, a prescribed
    displacement, or the tool against the soil); else the body moves as a rigid body, the
    stiffness matrix is singular and the solver would return noise as a result."""
    if tool is not None:
        return
    held = {axis for s in supports for axis in s.fix}
    if analysis.plane_strain:
        held.add("y")
    if loading.control is Control.DISPLACEMENT:
        held.add(AXES[loading.direction.axis])
    free = [axis for axis in AXES if axis not in held]
    if free:
        raise InputError(f"supports: nothing holds the {', '.join(free)} displacement (no "
                         "support, analysis.plane_strain or loading under displacement control), "
                         "so the body can move as a rigid body (the stiffness matrix is singular); "
                         f"add a [[supports]] table with fix = {free!r} on some boundary")


def _tool(raw, source, boundaries, contact):
    """The [tool] record; its faces default to the mesh builder's contact groups."""
    table = _optional(raw, "tool", dict)
    if "faces" not in table:
        if not contact:
            raise InputError(f"tool.faces: required: {source} declares no "
                             f"contact groups; its boundaries: {', '.join(boundaries)}")
        table = {**table, "faces": list(contact)}
    return from_table(Tool, table, "tool")


def load_scene(path, overrides=()):
    """Read, override and validate a scene; every error names the file and the key."""
    return scene_from_table(read_scene_tables(path), path, overrides)


def scene_from_table(raw, path, overrides=()):
    """The scene of the tables ``raw`` of the file ``path`` (as read by tomllib)."""
    path = Path(path)
    try:
        return _parse(apply_overrides(raw, overrides), path)
    except InputError as err:
        raise InputError(f"{path}: {err}") from None
