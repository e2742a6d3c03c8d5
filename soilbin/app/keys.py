"""Every key a scene takes, with its value in that scene, its accepted range and its meaning
(``soilbin keys SCENE``; records level: no FEniCSx)."""
import dataclasses
import enum

from ..meshes import BUILDERS


def _shown(value):
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, tuple):
        return [_shown(v) for v in value]
    return value


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
        rng = f.metadata.get("range")
        choices = (type(value) if isinstance(value, enum.Enum) else None)
        accepted = (str(rng) if rng is not None else
                    "one of " + ", ".join(m.value for m in choices) if choices else "")
        rows.append((key, _shown(value), accepted, f.metadata.get("doc", "")))
    return rows


def scene_keys(scene):
    """The rows of every settable key of a loaded scene."""
    rows = [("mesh.builder", scene.mesh_builder, "one of " + ", ".join(BUILDERS),
             "the mesh builder; changing it changes the mesh keys")]
    rows += record_keys(scene.mesh, "mesh")
    for name, model in scene.materials.items():
        rows += record_keys(model, f"materials.{name}")
    rows += [(f"regions.{region}", material, "a material name", "material of the cell group")
             for region, material in scene.regions.items()]
    for table, records in (("supports", scene.supports), ("tractions", scene.tractions)):
        for i, record in enumerate(records):
            rows += record_keys(record, f"{table}.{i}")
    for name in ("loading", "analysis", "solver", "output", "tool", "geostatic"):
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
