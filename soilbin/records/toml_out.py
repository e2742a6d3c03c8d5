"""A small TOML writer for resolved scenes (Python's tomllib only reads)."""
import enum
import json
import math


def _scalar(v):
    if isinstance(v, enum.Enum):
        v = v.value
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_scalar(x) for x in v) + "]"
    if isinstance(v, dict):   # an inline table
        return "{" + ", ".join(f"{k} = {_scalar(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"cannot write {v!r} as TOML")


def _is_table_array(v):
    return isinstance(v, (list, tuple)) and len(v) > 0 and all(isinstance(x, dict) for x in v)


def dumps(data, _prefix=""):
    """Serialise nested dicts (tables), lists of dicts (arrays of tables) and scalars."""
    lines, nested = [], []
    for key, value in data.items():
        if isinstance(value, dict) or _is_table_array(value):
            nested.append((key, value))
        else:
            lines.append(f"{key} = {_scalar(value)}")
    for key, value in nested:
        name = f"{_prefix}{key}"
        if isinstance(value, dict):
            lines += ["", f"[{name}]", dumps(value, name + ".")]
        else:
            for item in value:
                lines += ["", f"[[{name}]]", dumps(item, name + ".")]
    return "\n".join(line for line in lines if line is not None).strip("\n") + ("\n" if not _prefix else "")
