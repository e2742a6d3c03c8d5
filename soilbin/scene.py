"""Scenes: TOML files describing one analysis, parsed into validated frozen records.

A scene names a mesh builder and its parameters, the material of each
region, supports, the loading (force or displacement control), analysis and
solver options, outputs and the headline results of its summary. Every
value is checked (type, accepted range, known name) before anything is
built; ``--set dotted.key=value`` overrides go through the same checks.
"""
import dataclasses
import enum
import tomllib
from pathlib import Path

import numpy as np

from .errors import InputError
from .forms.discretisation import Element
from .interface.mohr_coulomb import MohrCoulombInterface
from .meshes import BUILDERS
from .models import MODELS
from .params import Params, from_table, param
from . import toml_out


class Control(enum.Enum):
    FORCE = "force"
    DISPLACEMENT = "displacement"


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


class Field(enum.Enum):
    DISPLACEMENT = "displacement"
    STRESS = "stress"
    PLASTIC_STRAIN = "plastic_strain"
    GAP = "gap"   # opening between soil and tool (written only when there is an interface)


class Headline(enum.Enum):
    """How a headline result is read off the load–displacement curve.

    Displacement and force are measured along the loading direction, so
    settlement and compressive pressure are positive (geomechanics signs).
    """
    FINAL_DISPLACEMENT = "final_displacement"
    FINAL_PRESSURE = "final_pressure"
    PEAK_PRESSURE = "peak_pressure"
    FINAL_FORCE = "final_force"
    PEAK_FORCE = "peak_force"


@dataclasses.dataclass(frozen=True)
class HeadlineResult(Params):
    """A headline value: a quantity read off the curve, optionally divided by a
    scale (to make it dimensionless, e.g. an earth-pressure coefficient)."""
    of: Headline = param(doc="the quantity read off the curve")
    divide_by: float = param(1.0, lo=0.0, lo_open=True, doc="scale the value is divided by")


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
    magnitude: float = param(lo=0.0, doc="traction (force/area)")


@dataclasses.dataclass(frozen=True)
class Loading(Params):
    control: Control = param(doc="force: a traction on the boundary; displacement: a prescribed displacement")
    boundary: str = param(doc="facet group that is loaded or displaced")
    direction: Direction = param(doc="signed axis of the load, e.g. '-z'")
    magnitude: float = param(lo=0.0, lo_open=True,
                             doc="traction (force/area) or displacement (length) at load factor 1")
    steps: int = param(lo=1, doc="number of equal load steps to load factor 1")
    max_cuts: int = param(8, lo=0, hi=30, doc="times a failing step may be halved in a row")
    until_collapse: bool = param(False, doc="force control: a step that cannot be converged "
                                            "marks the collapse load and ends the run normally")


TOOL = "tool"   # the loading boundary name that means the rigid tool


@dataclasses.dataclass(frozen=True)
class Geostatic(Params):
    """Gravity and the K0 initial stress, in equilibrium before the first step:
    σ_v = γ (z − z_s), σ_h = K0 σ_v (tension positive: compressive below the surface)."""
    unit_weight: float = param(lo=0.0, doc="unit weight γ of the soil (force/volume)")
    K0: float = param(lo=0.0, hi=10.0, doc="coefficient of earth pressure at rest")
    surface: float = param(0.0, doc="z of the ground surface")

    def stress(self, x):
        """Initial stress (n, 6), Mandel, at the points x (n, 3)."""
        vertical = self.unit_weight * (x[:, 2] - self.surface)
        sigma = np.zeros((len(x), 6))
        sigma[:, 0] = sigma[:, 1] = self.K0 * vertical
        sigma[:, 2] = vertical
        return sigma


@dataclasses.dataclass(frozen=True)
class Tool(Params):
    """A rigid tool in a cavity of the soil mesh, displaced as a whole (loading.boundary = 'tool')."""
    faces: tuple[str, ...] = param(doc="soil boundaries against the tool (the cavity faces)")
    bonded: bool = param(False, doc="true: the faces move with the tool (no interface)")
    interface: MohrCoulombInterface = param(None, doc="Mohr-Coulomb interface law (unless bonded)")

    def __post_init__(self):
        super().__post_init__()
        if not self.faces:
            raise InputError("faces: name at least one boundary")
        if not self.bonded and self.interface is None:
            raise InputError("interface: a [tool.interface] table is required unless bonded = true")


@dataclasses.dataclass(frozen=True)
class Analysis(Params):
    element: Element = param(Element.HEX8, doc="hex8, hex8-bbar, hex27 or hex27-bbar (mean dilatation)")
    plane_strain: bool = param(False, doc="hold the y displacement at zero everywhere (x-z plane)")
    large_deformation: bool = param(False, doc="updated Lagrangian with an objective stress update "
                                               "(geometric stiffness, moving mesh)")
    frame_rotation: tuple[float, ...] = param(
        (0.0, 0.0, 0.0), doc="rotation vector [degrees] turning the whole scene (mesh, supports, "
                             "loads): results along the loading direction must not change")

    def __post_init__(self):
        super().__post_init__()
        if len(self.frame_rotation) != 3:
            raise InputError(f"frame_rotation = {list(self.frame_rotation)!r}: expected 3 numbers")
        if any(self.frame_rotation) and self.plane_strain:
            raise InputError("frame_rotation: a rotated frame cannot be plane strain in y")


@dataclasses.dataclass(frozen=True)
class Solver(Params):
    rtol: float = param(1e-9, lo=0.0, hi=1.0, lo_open=True, hi_open=True,
                        doc="residual reduction that ends Newton in a step")
    atol: float = param(1e-10, lo=0.0, hi=1.0, lo_open=True, hi_open=True,
                        doc="residual floor relative to the run's force scale")
    max_iterations: int = param(25, lo=1, hi=200, doc="Newton iterations before the step is cut")
    line_search: LineSearch = param(LineSearch.BASIC, doc="basic (full steps) or bt (backtracking)")


@dataclasses.dataclass(frozen=True)
class Output(Params):
    fields: tuple[Field, ...] = param((Field.DISPLACEMENT, Field.STRESS, Field.PLASTIC_STRAIN),
                                      doc="XDMF fields: displacement, stress, plastic_strain, gap")
    every: int = param(1, lo=1, doc="write fields every this many converged steps (and the last)")


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

    @property
    def name(self):
        return self.path.stem

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
        if self.tool is not None:
            data["tool"] = {"faces": self.tool.faces, "bonded": self.tool.bonded}
            if self.tool.interface is not None:
                data["tool"]["interface"] = table(self.tool.interface)
        return toml_out.dumps(data)


OPTIONAL_TABLES = ("analysis", "solver", "output")   # all defaults: --set may create them
TOP_LEVEL = ("title", "units", "mesh", "regions", "materials", "supports", "loading",
             "analysis", "solver", "output", "headline", "tool", "tractions",
             "geostatic")


def _model_name(model):
    return next(name for name, cls in MODELS.items() if type(model) is cls)


def read_toml(path):
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such scene file")
    try:
        with path.open("rb") as f:
            return tomllib.load(f)
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{path}: TOML syntax error: {err}") from None


def _parse_value(text):
    """A --set value: any TOML value, or a bare word taken as a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def apply_overrides(raw, overrides):
    """Apply 'dotted.key=value' overrides to the raw TOML dict (returns a new dict)."""
    import copy
    raw = copy.deepcopy(raw)
    for item in overrides:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise InputError(f"--set {item!r}: expected dotted.key=value")
        *parents, leaf = key.split(".")
        node = raw
        for depth, part in enumerate(parents):
            if node is raw and part in OPTIONAL_TABLES:
                node = raw.setdefault(part, {})
            elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
                node = node[int(part)]
            elif isinstance(node, dict) and part in node:
                node = node[part]
            else:
                raise InputError(f"--set {key}: the scene has no table {'.'.join(parents[:depth + 1])!r}")
        if not isinstance(node, dict):
            raise InputError(f"--set {key}: {'.'.join(parents)!r} is not a table")
        if parents == [] and leaf not in TOP_LEVEL:
            raise InputError(f"--set {key}: unknown key; top-level keys: {', '.join(TOP_LEVEL)}")
        node[leaf] = _parse_value(text)
    return raw


def _require(raw, key, kind):
    if key not in raw:
        raise InputError(f"missing table [{key}]" if kind is dict else f"missing key {key!r}")
    if not isinstance(raw[key], kind):
        raise InputError(f"{key}: expected a {'table' if kind is dict else kind.__name__}")
    return raw[key]


def _parse(raw, path):
    unknown = sorted(set(raw) - set(TOP_LEVEL))
    if unknown:
        raise InputError(f"unknown key {unknown[0]!r}; top-level keys: {', '.join(TOP_LEVEL)}")
    mesh_table = dict(_require(raw, "mesh", dict))
    builder_name = mesh_table.pop("builder", None)
    if builder_name not in BUILDERS:
        raise InputError(f"mesh.builder = {builder_name!r}: unknown mesh builder; "
                         f"known: {', '.join(BUILDERS)}")
    builder = BUILDERS[builder_name]
    mesh = from_table(builder.params, mesh_table, "mesh")

    materials = {}
    for name, table in _require(raw, "materials", dict).items():
        table = dict(table) if isinstance(table, dict) else table
        if not isinstance(table, dict) or "model" not in table:
            raise InputError(f"materials.{name}: missing key 'model'")
        model_name = table.pop("model")
        if model_name not in MODELS:
            raise InputError(f"materials.{name}.model = {model_name!r}: unknown material model; "
                             f"known: {', '.join(MODELS)}")
        materials[name] = from_table(MODELS[model_name], table, f"materials.{name}")

    regions = _require(raw, "regions", dict)
    for region, material in regions.items():
        if region not in builder.regions:
            raise InputError(f"regions.{region}: mesh builder {builder_name!r} has no region "
                             f"{region!r}; its regions: {', '.join(builder.regions)}")
        if material not in materials:
            raise InputError(f"regions.{region} = {material!r}: no such material; "
                             f"defined: {', '.join(materials)}")
    missing = [r for r in builder.regions if r not in regions]
    if missing:
        raise InputError(f"regions: no material for region {missing[0]!r}")

    supports = raw.get("supports", [])
    if not isinstance(supports, list):
        raise InputError("supports: expected an array of tables [[supports]]")
    supports = tuple(from_table(Support, s, f"supports[{i}]") for i, s in enumerate(supports))
    tractions = raw.get("tractions", [])
    if not isinstance(tractions, list):
        raise InputError("tractions: expected an array of tables [[tractions]]")
    tractions = tuple(from_table(Traction, t, f"tractions[{i}]") for i, t in enumerate(tractions))
    loading = from_table(Loading, _require(raw, "loading", dict), "loading")
    tool = from_table(Tool, raw["tool"], "tool") if "tool" in raw else None
    named = [(f"supports[{i}].boundary", s.boundary) for i, s in enumerate(supports)]
    named += [(f"tractions[{i}].boundary", t.boundary) for i, t in enumerate(tractions)]
    named += [(f"tool.faces[{i}]", face) for i, face in enumerate(tool.faces if tool else ())]
    if loading.boundary == TOOL:
        if tool is None:
            raise InputError("loading.boundary = 'tool' needs a [tool] table")
        if loading.control is not Control.DISPLACEMENT:
            raise InputError("loading.control: the rigid tool is driven by displacement control")
    else:
        named.append(("loading.boundary", loading.boundary))
    for where, name in named:
        if name not in builder.boundaries:
            raise InputError(f"{where} = {name!r}: mesh builder {builder_name!r} has no such "
                             f"boundary; its boundaries: {', '.join(builder.boundaries)}")

    headline = {}
    for key, value in raw.get("headline", {}).items():
        spec = value if isinstance(value, dict) else {"of": value}
        headline[key] = from_table(HeadlineResult, spec, f"headline.{key}")

    title = raw.get("title", "")
    if not isinstance(title, str) or not title:
        raise InputError("title: a one-line description is required")
    if "geostatic" in raw and any(from_table(Analysis, raw.get("analysis", {}), "analysis")
                                  .frame_rotation):
        raise InputError("geostatic: gravity acts along -z; it cannot be combined with "
                         "analysis.frame_rotation")
    output = from_table(Output, raw.get("output", {}), "output")
    units = raw.get("units", "")
    if not isinstance(units, str) or not units:
        raise InputError("units: state the units of the scene, e.g. 'lb, in'")
    return Scene(path=path, title=title, units=units, mesh_builder=builder_name, mesh=mesh,
                 materials=materials, regions=dict(regions), supports=supports, loading=loading,
                 analysis=from_table(Analysis, raw.get("analysis", {}), "analysis"),
                 solver=from_table(Solver, raw.get("solver", {}), "solver"),
                 output=output,
                 headline=headline, tool=tool, tractions=tractions,
                 geostatic=(from_table(Geostatic, raw["geostatic"], "geostatic")
                            if "geostatic" in raw else None))


def load_scene(path, overrides=()):
    """Read, override and validate a scene; every error names the file and the key."""
    path = Path(path)
    raw = read_toml(path)
    try:
        return _parse(apply_overrides(raw, overrides), path)
    except InputError as err:
        raise InputError(f"{path}: {err}") from None
