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
        super().__init__(one_line(text))

    def __reduce__(self):
        # rebuilt from its fields: an error raised in a worker process crosses back whole
        # (the default pickles the message alone, which __init__ cannot take)
        return self.__class__, (self.field, self.value, self.allowed, self.source)


class MissingFields(ConfigError):
    """Required fields not given, or left "?" as `fullspeed new-machine`'s
    template writes them: every one at once, in one line, grouped by the
    file they belong in ("my.toml: missing required fields: machine.rated.torque
    (N m; > 0 and <= 1e+06), ...; left \"?\": machine.kind (...)").

    `entries` are (source, field, hint, placeholder) tuples: hint the unit
    and range of the field, placeholder true where it was "?". `field` and
    `source` are the first entry's, as a one-field ConfigError has them."""

    def __init__(self, entries: list[tuple[str | None, str, str, bool]], note: str = ""):
        self.entries = list(entries)
        self.note = note
        source, field = self.entries[0][0], self.entries[0][1]
        groups: dict = {}
        for src, f, hint, placeholder in self.entries:
            groups.setdefault(src, ([], []))[placeholder].append(f"{_clip(f, 200)} ({hint})" if hint else _clip(f, 200))
        parts = []
        for src, (absent, left) in groups.items():
            said = ([f"missing required fields: {', '.join(absent)}"] if absent else []) \
                + ([f'required fields left "?": {", ".join(left)}'] if left else [])
            parts.append((f"{src}: " if src else "") + "; ".join(said))
        text = "; ".join(parts) + (f" ({note})" if note else "")
        self.field, self.value, self.source = field, "missing", source
        self.allowed = text[len(f"{source}: "):] if source and text.startswith(f"{source}: ") else text
        ValueError.__init__(self, one_line(text))

    def __reduce__(self):
        return MissingFields, (self.entries, self.note)

    def noted(self, note: str) -> "MissingFields":
        """The same fields, with where they were found appended."""
        return MissingFields(self.entries, note)


_BREAKS = {0x0A: "\\n", 0x0D: "\\r", 0x09: "\\t"}


def one_line(text: str) -> str:
    """text as one line of a terminal: the characters that end a line
    (\\n, \\r, form feed, \\u2028...) or drive the terminal (ESC, the other
    controls) written as escapes, whatever a path or a name from the input
    holds."""
    def esc(ch: str) -> str:
        o = ord(ch)
        if o < 0x20 or 0x7F <= o < 0xA0 or o in (0x2028, 0x2029):
            return _BREAKS.get(o) or (f"\\x{o:02x}" if o < 0x100 else f"\\u{o:04x}")
        return ch
    return "".join(esc(ch) for ch in text)


def _repr(value) -> str:
    """repr, bounded in depth and length: a 5,000-deep table or a 5,000-digit
    integer from the input must not raise while its error is being made."""
    if isinstance(value, float):
        # a long repr shortened to 12 digits where that is shorter: a value the design formed (1.2 x 4 A)
        # reads 4.8, not 4.800000000000001; a value as a user writes it reads as written (3.0, 1e-320)
        r = repr(value)
        return r if len(r) <= 12 else min(r, f"{value:.12g}", key=len)
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
