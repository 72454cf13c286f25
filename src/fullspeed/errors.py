"""The error every bad input becomes: one line naming where, the field, the
value and what is allowed."""
from __future__ import annotations

import reprlib


class ConfigError(ValueError):
    """Invalid scenario, machine or sweep input.

    str(err) is the one-line message shown to the user.
    """

    def __init__(self, field: str, value, allowed: str, source: str | None = None):
        self.field = field
        self.value = value
        self.allowed = allowed
        self.source = source
        where = f"{source}: " if source else ""
        shown = _clip(_repr(value), 60)
        # one line whatever the input holds (a quoted TOML key may contain a newline)
        text = f"{where}{_clip(str(field), 200)} = {shown}: {allowed}"
        super().__init__(text.replace("\r", "\\r").replace("\n", "\\n"))


def _repr(value) -> str:
    """repr, bounded in depth and length: a 5,000-deep table or a 5,000-digit
    integer from the input must not raise while its error is being made."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 256:
        return f"<an integer of {len(str(value)) if value.bit_length() < 14000 else 'over 4000'} digits>"
    r = reprlib.Repr()
    r.maxlevel, r.maxstring, r.maxother, r.maxlist, r.maxdict = 3, 80, 80, 8, 8
    try:
        return r.repr(value)
    except (RecursionError, ValueError):
        return f"<a {type(value).__name__}>"


def _clip(text: str, n: int) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."


class SimulationError(RuntimeError):
    """The C core refused a configuration (message from the core)."""


class EngineError(RuntimeError):
    """Tasks could not all be run for a reason outside the input: the Dask
    cluster was lost, or worker processes kept dying. What finished is in
    the journal; the same command resumes."""
