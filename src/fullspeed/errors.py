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
        shown = repr(value)
        if len(shown) > 60:
            shown = shown[:57] + "..."
        super().__init__(f"{where}{field} = {shown}: {allowed}")


class SimulationError(RuntimeError):
    """The C core refused a configuration (message from the core)."""
