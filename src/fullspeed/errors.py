"""The error every bad input becomes: one line naming where, the field, the
value and what is allowed."""
from __future__ import annotations


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
        shown = _clip(repr(value), 60)
        # one line whatever the input holds (a quoted TOML key may contain a newline)
        text = f"{where}{_clip(str(field), 200)} = {shown}: {allowed}"
        super().__init__(text.replace("\r", "\\r").replace("\n", "\\n"))


def _clip(text: str, n: int) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."


class SimulationError(RuntimeError):
    """The C core refused a configuration (message from the core)."""
