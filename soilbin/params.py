"""Typed, range-checked parameter records built from TOML tables.

A parameter record is a frozen dataclass whose fields are declared with
:func:`param`; ranges are checked on construction, so a record that exists
is valid. :func:`from_table` builds a record from a TOML table and names the
offending key (with its dotted path in the scene) when a key is unknown,
missing, of the wrong type or out of range.

Numbers are finite: NaN is refused everywhere (except where NaN is the
field's default, the mark of a value not given), and so is ±inf unless the
field's range names it as a closed bound (``param(hi=math.inf)``: inf
accepted; a bound left out is open). Stresses, moduli, loads and material constants are
bounded by :data:`MAGNITUDE` (:func:`magnitude_param`).
"""
import dataclasses
import enum
import math
import typing

from .errors import InputError


@dataclasses.dataclass(frozen=True)
class Range:
    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False

    def contains(self, x):
        if math.isnan(x):
            return False
        above = x > self.lo if self.lo_open else x >= self.lo
        below = x < self.hi if self.hi_open else x <= self.hi
        return above and below

    def __str__(self):
        lo = "(" if self.lo_open else "["
        hi = ")" if self.hi_open else "]"
        return f"{lo}{self.lo:g}, {self.hi:g}{hi}"


def param(default=dataclasses.MISSING, *, lo=None, hi=None,
          lo_open=False, hi_open=False, doc=""):
    """A dataclass field with an accepted range (numbers only) and a doc line.

    A bound left out is open at infinity; ``hi=math.inf`` (closed) accepts inf."""
    meta = {"doc": doc}
    if lo is not None or hi is not None:
        meta["range"] = Range(-math.inf if lo is None else lo, math.inf if hi is None else hi,
                              lo_open or lo is None, hi_open or hi is None)
    if isinstance(default, (list, dict)):
        raise TypeError("use a tuple for a sequence default")
    return dataclasses.field(default=default, metadata=meta)


#: Accepted range of a stress, a modulus, a stiffness, a load or a material constant, in the
#: scene's units. No physical problem leaves it in any unit system: the stiffest solid
#: (diamond, E = 1.2e12 Pa = 1.2e13 dyn/cm^2) is seven decades below its top, the smallest
#: constants a scene takes (a cap's compaction constant D of 7e-6 /Pa) fourteen above its
#: bottom. Within it the products a run forms stay inside double precision (1.8e308 to
#: 2.2e-308): squared stresses in the return map, stress x strain x volume in the assembly,
#: the residual norm (PETSc sums unscaled squares: an entry above 1e154 makes it inf) and a
#: load over a modulus (a strain of at most 1e40). At a load of 1e300 the norm is inf and
#: Newton can only fail the step.
MAGNITUDE = Range(1e-20, 1e20)


def magnitude_param(default=dataclasses.MISSING, *, doc, zero=False):
    """A positive number within :data:`MAGNITUDE`; ``zero``: 0 also accepted ([0, 1e20])."""
    return param(default, lo=0.0 if zero else MAGNITUDE.lo, hi=MAGNITUDE.hi, doc=doc)


class Params:
    """Mixin: range checks on construction. Subclasses are frozen dataclasses."""

    def __post_init__(self):
        for f in dataclasses.fields(self):
            rng = f.metadata.get("range")
            value = getattr(self, f.name)
            if rng is not None and not rng.contains(value):
                raise InputError(f"{f.name} = {value!r} is outside the accepted range {rng}")
            if rng is None and not _finite(value, f.default):
                raise InputError(f"{f.name} = {value!r}: expected finite numbers")


def _finite(value, default):
    """No inf or NaN in a number or a sequence of numbers (NaN where it is the default)."""
    if isinstance(value, (tuple, list)):
        return all(_finite(v, None) for v in value)
    if not isinstance(value, float) or math.isfinite(value):
        return True
    return math.isnan(value) and isinstance(default, float) and math.isnan(default)


def _coerce(value, tp, where):
    """Convert a TOML value to the field type ``tp`` or raise InputError."""
    origin = typing.get_origin(tp)
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(f"{where}: expected a number, got {value!r}")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"{where}: expected an integer, got {value!r}")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise InputError(f"{where}: expected true or false, got {value!r}")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise InputError(f"{where}: expected a string, got {value!r}")
        return value
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        choices = [m.value for m in tp]
        if value not in choices:
            raise InputError(f"{where}: {value!r} is not one of {', '.join(map(str, choices))}")
        return tp(value)
    if origin is tuple:
        (item,) = set(typing.get_args(tp)) - {Ellipsis}
        if not isinstance(value, (list, tuple)):
            raise InputError(f"{where}: expected a list, got {value!r}")
        return tuple(_coerce(v, item, f"{where}[{i}]") for i, v in enumerate(value))
    if dataclasses.is_dataclass(tp):
        return from_table(tp, value, where)
    raise TypeError(f"unsupported parameter type {tp!r} at {where}")


def from_table(cls, table, where):
    """Build the record ``cls`` from a TOML table; ``where`` is its dotted path."""
    if not isinstance(table, dict):
        raise InputError(f"{where}: expected a table, got {table!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(table) - set(fields))
    if unknown:
        raise InputError(f"{where}: unknown key {unknown[0]!r}; accepted keys: {', '.join(fields)}")
    missing = [name for name, f in fields.items() if name not in table
               and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
    if missing:
        raise InputError(f"{where}: missing key{'s' if len(missing) > 1 else ''} "
                         f"{', '.join(map(repr, missing))}")
    kwargs = {name: _coerce(table[name], hints[name], f"{where}.{name}")
              for name in fields if name in table}
    try:
        return cls(**kwargs)
    except InputError as err:
        raise InputError(f"{where}.{err}") from None


def describe(cls):
    """Lines 'name (type, in RANGE, default VALUE): doc' of a parameter record, for --help."""
    hints = typing.get_type_hints(cls)
    lines = []
    for f in dataclasses.fields(cls):
        tp = hints[f.name]
        name = tp.__name__ if isinstance(tp, type) else str(tp)
        parts = [f"{f.name} ({name}"]
        if "range" in f.metadata:
            parts.append(f", in {f.metadata['range']}")
        if f.default is not dataclasses.MISSING:
            default = f.default.value if isinstance(f.default, enum.Enum) else f.default
            parts.append(f", default {default!r}")
        parts.append(")")
        doc = f.metadata.get("doc", "")
        lines.append("".join(parts) + (f": {doc}" if doc else ""))
    return lines
