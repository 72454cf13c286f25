"""The scenario and machine reference, generated from the schema (the Spec
tables of model/scenario.py and model/machines.py): docs/reference.md, `fullspeed
schema [SECTION]`, and the machine template of `fullspeed new-machine`."""
from __future__ import annotations

from collections.abc import Iterator

from .machines import MACHINE
from .scenario import SCENARIO
from .schema import MISSING, Spec, range_text, toml_string, unit_and_meaning

KIND = {"float": "number", "int": "integer", "bool": "true/false", "str": "string", "choice": "choice",
        "profile": "number or [[t_s, value], ...]", "numbers": "list of numbers", "notes": "table of strings",
        "table": "table", "any": "see meaning"}
HEAD = "| field | type | unit | default | range | meaning |\n|---|---|---|---|---|---|\n"


def _roots() -> dict[str, dict]:
    return {"scenario": SCENARIO, "machine": MACHINE}


def _default(spec: Spec) -> str:
    if spec.default is MISSING:
        return "**required**"
    if spec.default is None:   # left out: derived from other fields (its doc says "default ..."), or unused
        return "designed" if "default" in spec.doc else "optional"
    if spec.kind == "table":
        return ""
    if isinstance(spec.default, bool):
        return "true" if spec.default else "false"
    if isinstance(spec.default, str):
        return f'"{spec.default}"'
    if isinstance(spec.default, (list, dict)) and not spec.default:
        return "empty"
    return f"{spec.default:g}" if isinstance(spec.default, float) else str(spec.default)


def sections() -> Iterator[tuple[str, dict[str, Spec], str]]:
    """(dotted section name, its Spec table, the table's own doc), depth first."""
    def walk(name, table, doc):
        yield name, table, doc
        for k, s in table.items():
            if s.kind == "table" and s.table:
                yield from walk(f"{name}.{k}", s.table, s.doc)
    for root, table in _roots().items():
        yield from walk(root, table, "")


def section_text(name: str, table: dict[str, Spec], doc: str) -> str:
    out = [f"### `{name}`\n"]
    if doc:
        out.append(doc + "\n")
    rows = []
    for k, s in table.items():
        if s.kind == "table" and s.table:
            rows.append(f"| `{k}` | table | | {'**required**' if s.default is MISSING else 'optional'} | | "
                        f"see `{name}.{k}` below |")
            continue
        unit, meaning = unit_and_meaning(k, s)
        rows.append(f"| `{k}` | {KIND[s.kind]} | {unit} | {_default(s)} | {range_text(s)} | {meaning.replace('|', '/')} |")
    return "\n".join(out) + "\n" + HEAD + "\n".join(rows) + "\n"


PREAMBLE = """# Scenario and machine reference

Generated from the schema (`fullspeed.model.reference`, from the Spec tables of
`src/fullspeed/model/scenario.py` and `src/fullspeed/model/machines.py`); a test keeps
this page equal to it, and `fullspeed schema [SECTION]` prints the same.

- *default*: **required** fields must be given; *designed* fields, left
  out, are derived from the others (the machine's bench, its datasheet
  values, the scenario's other fields: the meaning says from what), so a
  value given overrides a design; other defaults are used as shown.
- Units: SI inside; speeds in mechanical rpm and angles in electrical
  degrees in the files only (keys ending in `_rpm`, `_deg`). Currents and
  voltages are peak phase values (amplitude-invariant dq).
- Profiles are a number or `[[t_s, value], ...]` with non-decreasing times,
  linear between points and held after the last.
- A machine is a catalog name (`machine = "yang2022"`), a table
  (`[machine]` with the fields below), or a catalog machine with some
  fields overridden (`[machine] catalog = "yang2022"` and the fields to
  change); `fullspeed new-machine NAME` writes a template with the required
  fields.
"""


def reference_text(section: str | None = None) -> str:
    """The whole page, or the sections whose name starts with `section`
    ("machine.bench", "controller" for scenario.controller)."""
    parts = []
    for name, table, doc in sections():
        short = name.split(".", 1)[1] if name.startswith("scenario.") else name
        if section is None or name == section or short == section or name.startswith(section + ".") \
                or short.startswith(section + "."):
            parts.append(section_text(name, table, doc))
    if section is not None:
        return "\n".join(parts)
    return PREAMBLE + "\n## Scenario\n\n" + "\n".join(p for p in parts if p.startswith("### `scenario")) \
        + "\n## Machine\n\n" + "\n".join(p for p in parts if p.startswith("### `machine"))


def section_names() -> list[str]:
    return [name for name, _, _ in sections()]


# Comment lines the template puts under a field: the conversions datasheets need
TEMPLATE_NOTES = {
    "pole_pairs": ["# pole pairs = poles / 2: an 8-pole machine has 4"],
    "psi_f": ["# the magnet's peak phase flux linkage. From a datasheet's Ke (back-EMF constant in V per 1000 rpm,",
              "# line-to-line rms): psi_f = Ke * sqrt(2) / sqrt(3) / (pole_pairs * 2 * pi * 1000 / 60),",
              "# e.g. Ke = 50 V/krpm with 4 pole pairs: 50 * 1.4142 / 1.7321 / 418.88 = 0.0975 Wb",
              "# (forgetting the / sqrt(3) of line-to-line to phase makes it 1.73 x too large)"],
}


def machine_template(name: str) -> str:
    """A machine file with only the fields the schema requires, each with
    its unit, range and meaning in a comment; the value to fill in is "?"
    (refused until it is). Everything with a default or a design is left
    out: `fullspeed schema machine` lists it."""
    quoted = toml_string(name)   # escaped: a quote or a newline in the name cannot add keys
    lines = [f"# Machine {quoted}: fill in every \"?\" (the datasheet's values). Everything else has a",
             "# default or is designed from these; `fullspeed schema machine` lists all fields.",
             "# SI units; speeds in mechanical rpm; currents and voltages peak phase values."]

    def field_line(k, s):
        unit, meaning = unit_and_meaning(k, s)
        rng = range_text(s)
        note = "; ".join(x for x in (unit, rng, meaning) if x)
        value = quoted if k == "name" else '"?"'
        return "\n".join([f"{k} = {value}" + (f"    # {note}" if note else ""), *TEMPLATE_NOTES.get(k, [])])

    tables = []
    for k, s in MACHINE.items():
        if s.default is not MISSING:
            continue
        if s.kind == "table":
            req = [(kk, ss) for kk, ss in s.table.items() if ss.default is MISSING]
            tables.append((k, s, req))
        else:
            lines.append(field_line(k, s))
    for k, s, req in tables:
        lines += ["", f"[{k}]" + (f"    # {s.doc}" if s.doc else "")]
        lines += [field_line(kk, ss) for kk, ss in req]
    return "\n".join(lines) + "\n"
