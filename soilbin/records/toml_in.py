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


def read_toml(path):
    """The tables of a TOML file; a missing file, bad UTF-8 or bad TOML is an InputError."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such scene file")
    try:
        return tomllib.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not UTF-8 text (byte {err.start}); save the scene as UTF-8") from None
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{path}: TOML syntax error: {err}") from None


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
