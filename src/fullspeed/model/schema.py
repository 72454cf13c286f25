"""A small declarative validator for the TOML inputs.

Each table is described by a dict of key -> Spec. Validation walks the data,
refuses unknown keys and bad values with a ConfigError naming the dotted
field, the value and what is allowed, and fills in defaults.
"""
from __future__ import annotations

import math
import re
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import ConfigError, MissingFields
from .files import read_text

MISSING = object()


@dataclass(frozen=True)
class Spec:
    kind: str                      # "float", "int", "bool", "str", "choice", "profile", "numbers", "notes", "table", "any"
    default: Any = MISSING         # MISSING: required
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False          # lo excluded
    hi_open: bool = False
    choices: tuple = ()
    table: dict | None = None      # for kind == "table"
    doc: str = ""

    def allowed(self) -> str:
        if self.kind == "choice":
            return "must be one of " + ", ".join(repr(c) for c in self.choices)
        if self.kind in ("float", "int"):
            word = "a number" if self.kind == "float" else "an integer"
            parts = []
            if self.lo is not None:
                parts.append(f"{'>' if self.lo_open else '>='} {self.lo:g}")
            if self.hi is not None:
                parts.append(f"{'<' if self.hi_open else '<='} {self.hi:g}")
            unit = f" ({self.doc})" if 0 < len(self.doc) <= 8 else ""   # a doc that is a unit
            return f"must be {word}" + (" " + " and ".join(parts) if parts else "") + unit
        if self.kind == "bool":
            return "must be true or false"
        if self.kind == "str":
            return "must be a string"
        if self.kind == "profile":
            bound = f" within +-{self.hi:g}" if self.hi is not None else ""
            return f"must be a number{bound} or a list of [time_s, value] pairs with non-decreasing times"
        if self.kind == "numbers":
            return "must be a list of finite numbers"
        if self.kind == "notes":
            return "must be a table of strings"
        if self.kind == "table":
            return "must be a table"
        return "invalid"


def F(default=MISSING, lo=None, hi=None, lo_open=False, hi_open=False, doc=""):
    return Spec("float", default, lo, hi, lo_open, hi_open, doc=doc)


def POS(default=MISSING, hi=None, doc=""):
    return Spec("float", default, 0.0, hi, True, False, doc=doc)


def NONNEG(default=MISSING, hi=None, doc=""):
    return Spec("float", default, 0.0, hi, False, False, doc=doc)


def I(default=MISSING, lo=None, hi=None, doc=""):
    return Spec("int", default, lo, hi, doc=doc)


def B(default=MISSING, doc=""):
    return Spec("bool", default, doc=doc)


def S(default=MISSING, doc=""):
    return Spec("str", default, doc=doc)


def C(*choices, default=MISSING, doc=""):
    return Spec("choice", default, choices=tuple(choices), doc=doc)


def P(default=MISSING, hi=None, doc=""):
    """A profile; hi bounds its values' magnitude."""
    return Spec("profile", default, hi=hi, doc=doc)


def N(default=MISSING, doc=""):
    """A list of finite numbers."""
    return Spec("numbers", default, doc=doc)


def NOTES(doc=""):
    """A table of free text (reasons, derivations): strings only."""
    return Spec("notes", {}, doc=doc)


def T(table: dict, default=MISSING, doc=""):
    return Spec("table", default, table=table, doc=doc)


ANY = Spec("any", None)


# units a field's doc may start or end with ("V; ...", "..., s")
UNITS = ("kg m^2", "N m s/rad", "N m", "rad/s", "el.deg", "ohm", "rpm", "Hz", "Wb", "V", "A", "s", "H", "F", "W", "J")


def unit_and_meaning(key: str, spec: Spec) -> tuple[str, str]:
    """The unit a doc starts or ends with (or a key's _rpm / _deg), and the rest."""
    doc = spec.doc.strip()
    for u in UNITS:
        if doc == u:
            return u, ""
        m = re.fullmatch(re.escape(u) + r"\s*[;,:]\s*(.*)", doc, re.S)
        if m:
            return u, m.group(1)
        m = re.fullmatch(r"(.*?),\s*" + re.escape(u), doc, re.S)
        if m:
            return u, m.group(1)
    if key.endswith("_rpm"):
        return "rpm", doc
    if key.endswith("_deg"):
        return "el.deg", doc
    return "", doc


def range_text(spec: Spec) -> str:
    """A field's range as the reference page gives it (">= 0 and <= 1000")."""
    if spec.kind == "choice":
        return ", ".join(f'"{c}"' if isinstance(c, str) else str(c) for c in spec.choices)
    parts = []
    if spec.lo is not None:
        parts.append(f"{'>' if spec.lo_open else '>='} {spec.lo:g}")
    if spec.hi is not None:
        parts.append(f"{'<' if spec.hi_open else '<='} {spec.hi:g}" if spec.kind != "profile" else f"within +-{spec.hi:g}")
    return " and ".join(parts)


def field_hint(key: str, spec: Spec) -> str:
    """What a missing field takes, in a few words: its unit and range
    ("ohm; >= 0 and <= 1000"), its choices, or what its doc says first."""
    if spec.kind == "choice":
        return " or ".join(f'"{c}"' if isinstance(c, str) else str(c) for c in spec.choices)
    unit, meaning = unit_and_meaning(key, spec)
    if spec.kind in ("float", "int", "profile"):
        return "; ".join(x for x in (unit, range_text(spec) or ("an integer" if spec.kind == "int" else "")) if x)
    return re.split(r"[;:]", meaning, maxsplit=1)[0].strip() if meaning else {"bool": "true or false", "str": "text", "table": "a table"}.get(spec.kind, "")


def unfilled(spec: Spec, value) -> bool:
    """The template's placeholder "?" (`fullspeed new-machine`), in any
    field but free text, where "?" could be the text."""
    return value == "?" and spec.kind not in ("str", "notes")


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


FLOAT_MAX = sys.float_info.max
FLT32_MIN = 1.1754943508222875e-38   # the smallest normal float32: the controllers compute in float32
MAX_STR = 4096   # characters in a TOML string field: a name or a description, not a document


def finite_number(v) -> bool:
    """An int or float that is a finite double: a TOML integer has no size
    limit, and math.isfinite of a 401-digit one raises OverflowError."""
    if not _is_number(v):
        return False
    if isinstance(v, int):
        return -FLOAT_MAX <= v <= FLOAT_MAX   # int-float comparison is exact, never overflows
    return math.isfinite(v)


# units whose thousandth a datasheet gives (mH, mWb, mohm): a value above the field's range that fits it
# divided by 1000 gets that reading beside the refusal (the new-user trial's L_d = 26 for 26 mH)
MILLI_UNITS = ("H", "Wb", "ohm")


def check_value(spec: Spec, value, field: str, source: str | None):
    def fail():
        raise ConfigError(field, value, spec.allowed(), source)

    k = spec.kind
    if k == "any":
        return value
    if k == "float":
        if not finite_number(value):
            fail()
        v = float(value)
        if 0.0 < abs(v) < FLT32_MIN:   # 5e-324 would be 0 in the C core (a division by zero, a limit of 0)
            raise ConfigError(field, value, f"{spec.allowed()}, and 0 or at least {FLT32_MIN:.3g} in magnitude "
                              "(the controllers compute in float32)", source)
        if spec.lo is not None and (v < spec.lo or (spec.lo_open and v == spec.lo)):
            fail()
        if spec.hi is not None and (v > spec.hi or (spec.hi_open and v == spec.hi)):
            if spec.doc in MILLI_UNITS and v / 1000.0 <= spec.hi:   # the unit's thousandth written as the unit
                raise ConfigError(field, value, f"{spec.allowed()}; {v / 1000.0:g} {spec.doc} if the value is in "
                                  f"m{spec.doc}", source)
            fail()
        return v
    if k == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            fail()
        if spec.lo is not None and value < spec.lo:
            fail()
        if spec.hi is not None and value > spec.hi:
            fail()
        return value
    if k == "bool":
        if not isinstance(value, bool):
            fail()
        return value
    if k == "str":
        if not isinstance(value, str):
            fail()
        if len(value) > MAX_STR:
            raise ConfigError(field, value, f"must be a string of at most {MAX_STR} characters", source)
        return value
    if k == "choice":
        if value not in spec.choices:
            fail()
        return value
    if k == "profile":
        return check_profile(value, field, source, spec)
    if k == "numbers":
        if not isinstance(value, list) or not all(finite_number(x) for x in value):
            fail()
        return [float(x) for x in value]
    if k == "notes":
        if not isinstance(value, dict) or not all(isinstance(x, str) for x in value.values()):
            fail()
        return value
    if k == "table":
        if not isinstance(value, dict):
            fail()
        return validate(value, spec.table, field, source)
    raise AssertionError(k)


def check_profile(value, field, source, spec=None):
    """A number, or [[t, y], ...] with non-decreasing t. Returns (t, y) lists."""
    spec = spec or P()
    allowed = spec.allowed()
    hi = spec.hi if spec.hi is not None else math.inf
    if finite_number(value):
        if abs(value) > hi:
            raise ConfigError(field, value, allowed, source)
        return ([0.0], [float(value)])
    if not isinstance(value, list) or not value:
        raise ConfigError(field, value, allowed, source)
    ts, ys = [], []
    for n, pair in enumerate(value):
        if (not isinstance(pair, list) or len(pair) != 2
                or not all(finite_number(x) for x in pair)):
            raise ConfigError(f"{field}[{n}]", pair, "must be a pair [time_s, value] of finite numbers", source)
        if ts and pair[0] < ts[-1]:
            raise ConfigError(f"{field}[{n}]", pair, f"time must not be before the previous one ({ts[-1]:g} s)", source)
        if pair[0] < 0:
            raise ConfigError(f"{field}[{n}]", pair, "time must be >= 0", source)
        if abs(pair[1]) > hi:
            raise ConfigError(f"{field}[{n}]", pair, f"the value must be within +-{hi:g}", source)
        ts.append(float(pair[0]))
        ys.append(float(pair[1]))
    return (ts, ys)


def validate(data: dict, table: dict[str, Spec], prefix: str, source: str | None, missing: list | None = None) -> dict:
    """Validate one table: unknown keys and bad values refused (the first,
    with its own message), defaults filled in. Required fields not given or
    left "?" are gathered into `missing` (MissingFields entries), through
    the nested tables; without that list, all of them are refused at once
    here, as one MissingFields. A gathered field is absent from the result."""
    top = missing is None
    missing = [] if top else missing
    out = {}
    for key, value in data.items():
        field = f"{prefix}.{key}" if prefix else key
        if key not in table:
            allowed = ", ".join(sorted(table)) or "none"
            raise ConfigError(field, value, f"unknown key; allowed here: {allowed}", source)
        spec = table[key]
        if unfilled(spec, value):
            missing.append((source, field, field_hint(key, spec), True))
        elif spec.kind == "table" and isinstance(value, dict):
            out[key] = validate(value, spec.table, field, source, missing)
        else:
            out[key] = check_value(spec, value, field, source)
    for key, spec in table.items():
        if key in data:
            continue
        field = f"{prefix}.{key}" if prefix else key
        if spec.default is MISSING and spec.kind == "table":   # a required table: the fields it requires
            out[key] = validate({}, spec.table, field, source, missing)
        elif spec.default is MISSING:
            missing.append((source, field, field_hint(key, spec), False))
        elif spec.kind == "table" and isinstance(spec.default, dict):
            out[key] = validate(spec.default, spec.table, field, source, missing)
        elif spec.kind == "profile":
            out[key] = None if spec.default is None else check_profile(spec.default, field, source, spec)
        else:
            out[key] = spec.default
    if top and missing:
        raise MissingFields(missing)
    return out


def deep_merge(base: dict, override: dict) -> dict:
    """Override's keys replace base's; tables merge recursively."""
    out = dict(base)
    for k, v in override.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = deep_merge(out[k], v)
        else:
            out[k] = v
    return out


def even_grid(xs: list) -> bool:
    """Numbers rising in equal steps (a table's axis the C core indexes)."""
    steps = [b - a for a, b in zip(xs, xs[1:])]
    return bool(steps) and steps[0] > 0 and all(math.isclose(x, steps[0], rel_tol=1e-6, abs_tol=1e-9) for x in steps)


def toml_string(s: str) -> str:
    """s as a TOML basic string that tomllib reads back as s: quotes,
    backslashes and the control characters (DEL too) escaped, every other
    character written as it is (JSON's surrogate pairs for characters
    beyond the BMP are not TOML); a lone surrogate, which UTF-8 cannot
    hold, becomes U+FFFD."""
    def one(ch: str) -> str:
        o = ord(ch)
        if ch in '"\\':
            return "\\" + ch
        if o < 0x20 or o == 0x7F:
            return f"\\u{o:04X}"
        return "\ufffd" if 0xD800 <= o <= 0xDFFF else ch
    return '"' + "".join(one(ch) for ch in s) + '"'


def parse_toml(text: str, field: str, source: str | None) -> dict:
    """TOML text as a table; a syntax error becomes a ConfigError."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(field, "unparsable", f"not valid TOML: {exc}", source) from None
    except RecursionError:
        raise ConfigError(field, "nested too deeply", "not valid input: arrays or tables nested beyond the parser's depth", source) from None
    except ValueError as exc:   # an integer beyond Python's digit limit for conversion (4300)
        raise ConfigError(field, "unparsable", f"not valid input: {' '.join(str(exc).split())[:120]}", source) from None


def read_toml(path: str | Path, field: str, source: str | None = None) -> dict:
    """A TOML file as a table; a file that is missing, not a regular file,
    over files.MAX_TOML_BYTES, not UTF-8 or not TOML becomes a ConfigError
    naming the file."""
    p = Path(path)
    return parse_toml(read_text(p, field, source), "toml", str(p))
