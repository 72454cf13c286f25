"""The reference page is the schema; the machine template asks for exactly
what the schema requires, and a machine filled in from it is accepted."""
import os
import subprocess
import sys
import tomllib
from pathlib import Path

from fullspeed.design.machine import machine_from_dict

from fullspeed.model.machines import MACHINE
from fullspeed.model.reference import machine_template, reference_text, sections
from fullspeed.design.scenario import scenario_from_dict
from fullspeed.model.schema import MISSING

PAGE = Path(__file__).resolve().parents[1] / "docs" / "reference.md"

# a datasheet's worth of a 48 V IPMSM, by the template's dotted field
DATASHEET = {"kind": "ipmsm", "pole_pairs": 4, "electrical.R_s": 0.025, "electrical.L_d": 0.30e-3,
             "electrical.L_q": 0.55e-3, "electrical.psi_f": 0.0105, "mechanical.J": 5e-4,
             "rated.torque": 3.0, "rated.current": 28.0, "rated.speed_rpm": 3000.0,
             "bench.u_dc": 48.0, "bench.f_pwm": 20000.0}


def test_the_page_is_the_schema():
    """Regenerate with: python -c "from fullspeed.model.reference import reference_text;
    open('docs/reference.md', 'w').write(reference_text())" """
    assert PAGE.read_text(encoding="utf-8") == reference_text()


def test_every_field_says_what_it_is():
    for name, table, _ in sections():
        for key, spec in table.items():
            assert spec.doc or (spec.kind == "table" and spec.table), f"{name}.{key} has no doc"


def test_schema_command_prints_a_section_of_the_page():
    p = subprocess.run([sys.executable, "-m", "fullspeed", "schema", "injection"], capture_output=True, text=True,
                       timeout=60, env={**os.environ, "PYTHONWARNINGS": "ignore"})
    assert p.returncode == 0 and p.stdout.startswith("### `scenario.injection`")
    assert p.stdout in PAGE.read_text(encoding="utf-8")
    assert "| `u_h` | number | V | designed |" in p.stdout


def _filled(template: str) -> dict:
    d = tomllib.loads(template)
    for dotted, v in DATASHEET.items():
        *tables, key = dotted.split(".")
        t = d
        for k in tables:
            t = t[k]
        assert t[key] == "?", dotted
        t[key] = v
    return d


def test_the_template_asks_for_exactly_the_required_fields_and_is_enough():
    text = machine_template("my-48v")
    d = tomllib.loads(text)
    asked = {k for k, v in d.items() if v == "?"} | {f"{t}.{k}" for t, sub in d.items() if isinstance(sub, dict)
                                                     for k, v in sub.items() if v == "?"}
    required = {k for k, s in MACHINE.items() if s.default is MISSING and s.kind != "table" and k != "name"} | {
        f"{t}.{k}" for t, s in MACHINE.items() if s.kind == "table" and s.default is MISSING
        for k, ss in s.table.items() if ss.default is MISSING}
    assert asked == required == set(DATASHEET)
    m = machine_from_dict(_filled(text))
    assert m.name == "my-48v" and m.bench["i_max"] > m.i_rated            # designed from the datasheet
    sc = scenario_from_dict({"name": "first", "duration": 0.1, "machine": _filled(text),
                             "controller": {"mode": "speed", "angle": "blend"}})
    assert sc.data["injection"]["u_h"] > 0 and sc.data["blending"]["upper_rpm"] > sc.data["blending"]["lower_rpm"]


def test_the_claims_page_is_the_registry_and_reproduce_points_at_it():
    """Regenerate with: python -c "from fullspeed.reproduce.claims import claims_markdown;
    open('docs/CLAIMS.md', 'w').write(claims_markdown())" """
    from fullspeed.reproduce.claims import CLAIMS, claims_markdown
    page = (PAGE.parent / "CLAIMS.md").read_text(encoding="utf-8")
    assert page == claims_markdown()
    assert all(f"| {c.id} |" in page for c in CLAIMS)
    p = subprocess.run([sys.executable, "-m", "fullspeed", "reproduce", "--help"], capture_output=True, text=True, timeout=60)
    assert "docs/CLAIMS.md" in " ".join(p.stdout.split())
