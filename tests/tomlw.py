"""A small TOML writer for the tests that write scenario files (the
standard library reads TOML but does not write it). Tables become inline
tables, so any nesting round-trips; floats keep nan and inf."""
from __future__ import annotations

import json
import math


def value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)          # a JSON string is a TOML basic string
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def dumps(data: dict) -> str:
    """Top-level keys one per line; tables inline."""
    return "".join(f"{json.dumps(str(k))} = {value(v)}\n" for k, v in data.items())
