"""Every key a scene takes, with its value in that scene, its accepted range and its meaning
(``soilbin keys SCENE``), and with its default in every table a scene or a study file may
hold (the documentation's key reference: :func:`reference`, :func:`study_reference`); records
level: no FEniCSx."""
import dataclasses
import enum
import typing

from ..meshes import BUILDERS
from ..models import MODELS
from ..records.geostatic import Geostatic
from ..records.scene import (Analysis, HeadlineResult, Loading, Output, Remesh, SoilContact,
                             Solver, Support, Tool, Traction)
from .study import Figure, RunOptions, Table

#: What the key reference shows as the default of a key that must be given.
REQUIRED = "required"
BUILDER_DOC = "the mesh builder; changing it changes the mesh keys"
REGION_DOC = "material of the cell group"


def _shown(value):
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, tuple):
        return [_shown(v) for v in value]
    return value


def _accepted(field, kind):
    """A field's accepted range, or the choices of an enumeration ``kind``."""
    rng = field.metadata.get("range")
    if rng is not None:
        return str(rng)
    if isinstance(kind, type) and issubclass(kind, enum.Enum):
        return "one of " + ", ".join(m.value for m in kind)
    return ""


def record_keys(record, prefix):
    """(dotted key, value, range, doc) of every field of a parameter record, nested records
    included."""
    rows = []
    for f in dataclasses.fields(record):
        value = getattr(record, f.name)
        key = f"{prefix}.{f.name}"
        if dataclasses.is_dataclass(value):
            rows += record_keys(value, key)
            continue
        rows.append((key, _shown(value), _accepted(f, type(value)), f.metadata.get("doc", "")))
    return rows


def default_keys(cls, prefix):
    """(dotted key, default or REQUIRED, range, doc) of every field of a parameter record
    class, nested record classes included."""
    hints = typing.get_type_hints(cls)
    rows = []
    for f in dataclasses.fields(cls):
        kind, key = hints[f.name], f"{prefix}.{f.name}"
        if dataclasses.is_dataclass(kind):
            rows += default_keys(kind, key)
            continue
        default = REQUIRED if f.default is dataclasses.MISSING else _shown(f.default)
        rows.append((key, default, _accepted(f, kind), f.metadata.get("doc", "")))
    return rows


def _summary(cls):
    """The first paragraph of a class's docstring, on one line ('' for the signature that
    dataclasses write where a class has no docstring)."""
    doc = cls.__doc__ or ""
    return "" if doc.startswith(f"{cls.__name__}(") else " ".join(doc.split("\n\n")[0].split())


def _top_level():
    """The keys outside the records: title, units, the builder and the regions."""
    return [("title", REQUIRED, "", "one line describing the scene"),
            ("units", REQUIRED, "", "the units of every number in the scene, e.g. 'lb, in'"),
            ("mesh.builder", REQUIRED, "one of " + ", ".join(BUILDERS), BUILDER_DOC),
            ("regions.GROUP", REQUIRED, "a material name", REGION_DOC)]


def reference():
    """(table, kind, summary, rows) of every table a scene may hold, each key with its
    default: the top-level keys, the mesh of each builder and the material of each model
    (``kind``: the builder's or model's name), then the other tables (an array of tables as
    ``supports.N``, a headline result as ``headline.NAME``; ``kind`` empty)."""
    tables = [("top level", "", "", _top_level())]
    tables += [("mesh", name, builder.summary, default_keys(builder.params, "mesh"))
               for name, builder in BUILDERS.items()]
    tables += [("materials", name, _summary(cls), default_keys(cls, "materials.NAME"))
               for name, cls in MODELS.items()]
    for table, cls in (("loading", Loading), ("analysis", Analysis), ("solver", Solver),
                       ("output", Output), ("remesh", Remesh), ("tool", Tool),
                       ("soil_contact", SoilContact), ("geostatic", Geostatic),
                       ("supports", Support), ("tractions", Traction),
                       ("headline", HeadlineResult)):
        prefix = {"supports": "supports.N", "tractions": "tractions.N",
                  "headline": "headline.NAME"}.get(table, table)
        tables.append((table, "", _summary(cls), default_keys(cls, prefix)))
    return tables


def study_reference():
    """(table, kind, summary, rows) of the record tables of a study file, as reference()."""
    return [(table, "", _summary(cls), default_keys(cls, table))
            for table, cls in (("run", RunOptions), ("table", Table), ("figures", Figure))]


def scene_keys(scene):
    """The rows of every settable key of a loaded scene."""
    rows = [("mesh.builder", scene.mesh_builder, "one of " + ", ".join(BUILDERS), BUILDER_DOC)]
    rows += record_keys(scene.mesh, "mesh")
    for name, model in scene.materials.items():
        rows += record_keys(model, f"materials.{name}")
    rows += [(f"regions.{region}", material, "a material name", REGION_DOC)
             for region, material in scene.regions.items()]
    for table, records in (("supports", scene.supports), ("tractions", scene.tractions)):
        for i, record in enumerate(records):
            rows += record_keys(record, f"{table}.{i}")
    for name in ("loading", "analysis", "solver", "output", "remesh", "tool", "geostatic",
                 "soil_contact"):
        if getattr(scene, name) is not None:
            rows += record_keys(getattr(scene, name), name)
    for key, result in scene.headline.items():
        rows += record_keys(result, f"headline.{key}")
    return rows


def format_keys(scene):
    """Lines for the terminal: a header with the scene's units, then one key per line."""
    lines = [f"{scene.path}: every key takes --set KEY=VALUE; units: {scene.units}",
             f"{'key':42s} {'value':>16s}  accepted        meaning"]
    for key, value, accepted, doc in scene_keys(scene):
        lines.append(f"{key:42s} {str(value):>16s}  {accepted:15s} {doc}")
    return lines
