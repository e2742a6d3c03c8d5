"""TOML input: finding and reading scene files, and the values of ``--set key=value``.

Shared by the scene reader (:mod:`soilbin.records.scene`) and the material-point
driver (:mod:`soilbin.material_point.driver`); every error names the file or the key.
"""
import re
import tomllib
from pathlib import Path

from ..errors import InputError

#: A dotted key of --set.
KEY = re.compile(r"[A-Za-z0-9_-]+(\.[A-Za-z0-9_-]+)*")
#: The project's scene files.
SCENES_DIR = Path(__file__).resolve().parents[2] / "scenes"


def scene_path(arg):
    """A scene file path, or the name of a scene in the project's scenes/ folder."""
    path = Path(arg)
    if path.exists() or path.suffix == ".toml":
        return path
    return SCENES_DIR / f"{arg}.toml"


def read_toml(path, kind="scene"):
    """The tables of a TOML file (a ``kind`` file, for the messages); a missing file, bad
    UTF-8 or bad TOML is an InputError."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such {kind} file")
    try:
        return tomllib.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not UTF-8 text (byte {err.start}); save the {kind} as "
                         "UTF-8") from None
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{path}: TOML syntax error: {err}") from None


def read_scene_tables(path, _chain=()):
    """The tables of a scene file laid over those of its ``base`` scene, if it names one.

    ``base`` is the name of a scene in scenes/ or a path relative to the scene's folder; the
    base may have a base of its own. Tables merge key by key, any other value (arrays of
    tables included) is replaced whole, and so is a ``[mesh]`` that names another
    builder. A relative path of the base's ``[mesh]`` (a key ``file`` or ``*_file``) stays
    relative to the base's folder."""
    path = Path(path)
    raw = read_toml(path)
    base = raw.pop("base", None)
    if base is None:
        return raw
    if not isinstance(base, str) or not base:
        raise InputError(f"{path}: base = {base!r}: the name of a scene in scenes/ or a scene "
                         "file's path relative to this one's folder")
    near = path.parent / base
    base_path = near if near.exists() or base.endswith(".toml") else SCENES_DIR / f"{base}.toml"
    chain = _chain + (path.resolve(),)
    if base_path.resolve() in chain:
        raise InputError(f"{path}: base = {base!r}: the scenes name each other as base "
                         f"({' -> '.join(p.name for p in chain + (base_path.resolve(),))})")
    if not base_path.is_file():
        raise InputError(f"{path}: base = {base!r}: no such scene ({base_path})")
    tables = read_scene_tables(base_path, chain)
    mesh, top_mesh = tables.get("mesh"), raw.get("mesh")
    if isinstance(mesh, dict) and isinstance(top_mesh, dict) and \
            top_mesh.get("builder", mesh.get("builder")) != mesh.get("builder"):
        del tables["mesh"]
    elif isinstance(mesh, dict):
        for key, value in mesh.items():
            if (key == "file" or key.endswith("_file")) and isinstance(value, str):
                mesh[key] = str(base_path.parent / value)
    return _laid_over(tables, raw)


def _laid_over(base, top):
    """``top``'s tables merged into ``base``'s, key by key; other values replace base's."""
    merged = dict(base)
    for key, value in top.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = _laid_over(merged[key], value)
        else:
            merged[key] = value
    return merged


def parse_value(text):
    """A --set value: any TOML value, or a bare word taken as a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def assignment(item, expected="dotted.key=value"):
    """(key, value) of a ``--set key=value`` item."""
    key, sep, text = item.partition("=")
    key = key.strip()
    if not sep or not key:
        raise InputError(f"--set {item!r}: expected {expected}")
    if not KEY.fullmatch(key):
        raise InputError(f"--set {item!r}: a key is made of letters, digits, '_', '-' and dots")
    return key, parse_value(text.strip())
