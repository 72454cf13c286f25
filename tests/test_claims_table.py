"""The claims registry matches CLAIMS.md, and the machine catalog is complete.

CLAIMS.md lives beside the clone (``../shared/CLAIMS.md`` from the repository
root); the tests that read it are skipped when it is absent.
"""

from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

import pytest

from fullspeed.reproduce.claims import CLAIMS, PAPERS, Claim, claims_for

REPO = Path(__file__).resolve().parents[1]
CLAIMS_MD = REPO.parent / "shared" / "CLAIMS.md"
MACHINES_DIR = REPO / "src" / "fullspeed" / "machines"
MACHINES = ("yang2022", "zou2021", "yu2022")

# [bench] keys whose value the paper states (its section cited in the comment);
# every other [bench] key is chosen or derived and needs a [bench.reasons] entry.
GIVEN_BY_PAPER = {
    "yang2022": {"f_pwm", "t_dead", "sampling", "encoder_bits"},
    "zou2021": {
        "f_pwm",
        "i_max",
        "i_lim",
        "bw_current",
        "u_grid_ll_rms",
        "f_grid",
        "l_filter",
        "r_filter",
        "c_filter",
    },
    "yu2022": {"f_pwm", "sampling", "adc_bits"},
}

SCHEMA = {
    None: {"name", "description", "source", "kind", "phases", "pole_pairs"},
    "electrical": {"R_s", "L_d", "L_q", "psi_f"},
    "mechanical": {"J", "B", "T_coulomb"},
    "rated": {"torque", "current", "speed_rpm", "voltage", "power"},
    "bench": {
        "u_dc",
        "f_pwm",
        "t_dead",
        "sampling",
        "i_max",
        "i_trip",
        "adc_bits",
        "adc_range",
        "encoder_bits",
        "bw_current",
        "bw_speed",
        "bw_pll",
    },
}

# Tables (and keys) each machine has beyond the common schema.
EXTRA = {
    "yang2022": {
        "injection": {"kind", "u_h"},   # f_h designed (design.design_carrier)
        "blending": {"lower_rpm", "upper_rpm"},
    },
    "zou2021": {
        "bench": {"i_lim", "u_dc_min"},
        "bench_experiment": {"u_grid_ll_rms", "f_grid", "u_dc", "i_max", "i_lim"},
    },
    "yu2022": {
        "injection": {"kind", "u_h", "f_h"},
        "third_harmonic": {"L_d3", "L_q3", "psi_f3"},
        "paper_gains": {"pll_kp", "pll_ki", "current_kp_d", "current_kp_q", "speed_kp"},
    },
}

ID_RE = re.compile(r"^[A-Z]-[A-Z0-9]+(?:-[A-Z0-9]+)*$")
KEBAB_RE = re.compile(r"^[a-z0-9]+(?:-[a-z0-9]+)*$")


# --------------------------------------------------------------------------
# CLAIMS.md
# --------------------------------------------------------------------------


def _markdown_rows() -> list[tuple[str, str, str, str]]:
    """(id, section, conditions, target) for every claim row of CLAIMS.md."""
    if not CLAIMS_MD.is_file():
        pytest.skip(f"{CLAIMS_MD} not present (shared/ is not beside the clone)")
    rows = []
    section = None
    for line in CLAIMS_MD.read_text(encoding="utf-8").splitlines():
        heading = re.match(r"^##\s+(\S+)", line)
        if heading:
            section = heading.group(1)
            continue
        if not line.startswith("|"):
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 3 or not ID_RE.match(cells[0]):
            continue  # header or separator row
        rows.append((cells[0], section, cells[1], cells[2]))
    assert rows, "no claim rows found in CLAIMS.md"
    return rows


def test_registry_ids_unique():
    ids = [c.id for c in CLAIMS]
    assert len(ids) == len(set(ids)), sorted(i for i in ids if ids.count(i) > 1)


def test_every_markdown_claim_once_with_its_section():
    rows = _markdown_rows()
    md_ids = [r[0] for r in rows]
    assert len(md_ids) == len(set(md_ids)), "duplicate ids in CLAIMS.md"
    by_id: dict[str, list[Claim]] = {}
    for c in CLAIMS:
        by_id.setdefault(c.id, []).append(c)
    for cid, section, _, _ in rows:
        assert section in PAPERS, f"{cid}: section {section!r} is not a paper"
        found = by_id.get(cid, [])
        assert len(found) == 1, f"{cid}: {len(found)} entries in CLAIMS"
        assert found[0].paper == section, f"{cid}: {found[0].paper} != {section}"
    extra = set(by_id) - set(md_ids)
    assert not extra, f"claims not in CLAIMS.md: {sorted(extra)}"


def test_registry_order_and_text_match_markdown():
    rows = _markdown_rows()
    assert [c.id for c in CLAIMS] == [r[0] for r in rows]
    for c, (cid, _, text, target) in zip(CLAIMS, rows):
        assert c.text == text, cid
        assert c.target == target, cid


def test_claim_fields():
    for c in CLAIMS:
        assert ID_RE.match(c.id), c.id
        assert c.paper in PAPERS, c.id
        assert c.text and c.target, c.id
        assert isinstance(c.unit, str), c.id
        assert KEBAB_RE.match(c.scenario), (c.id, c.scenario)
        assert c.scenario.startswith(c.paper + "-"), (c.id, c.scenario)


def test_claims_for():
    assert claims_for(None) == CLAIMS
    assert sum(len(claims_for(p)) for p in PAPERS) == len(CLAIMS)
    for p in PAPERS:
        sel = claims_for(p)
        assert sel and all(c.paper == p for c in sel)
    with pytest.raises(ValueError) as err:
        claims_for("x")
    assert str(err.value) == (
        "paper = 'x': must be one of yang2022, zou2021, yu2022, beyond"
    )


# --------------------------------------------------------------------------
# Machine catalog
# --------------------------------------------------------------------------


def _load(name: str) -> dict:
    with open(MACHINES_DIR / f"{name}.toml", "rb") as f:
        return tomllib.load(f)


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


@pytest.fixture(params=MACHINES)
def machine(request):
    return request.param, _load(request.param)


# machines that are not a paper's: the bench's peer scenario (bench/) and the catalog of
# published machines (issue 33), whose sources tests/test_catalog.py checks value by value
OTHER_MACHINES = ["motulator-2kw-ipmsm", "prius2004-mg2", "hefei-h27", "baldor-ecs101m0h7ef4", "syre-thor",
                  "anaheim-bly171d", "siemens-1ft6084", "grin-all-axle-5t", "odrive-d6374"]


def test_catalog_has_exactly_the_paper_machines_the_bench_peer_and_the_published_ones():
    assert sorted(p.stem for p in MACHINES_DIR.glob("*.toml")) == sorted([*MACHINES, *OTHER_MACHINES])


def test_schema_keys(machine):
    name, m = machine
    required = {k: set(v) for k, v in SCHEMA.items()}
    for table, keys in EXTRA[name].items():
        required.setdefault(table, set()).update(keys)
    for table, keys in required.items():
        t = m if table is None else m.get(table)
        assert isinstance(t, dict), f"{name}: missing table [{table}]"
        missing = keys - set(t)
        assert not missing, f"{name}: [{table or 'top'}] lacks {sorted(missing)}"
    assert m["name"] == name
    assert m["kind"] in ("ipmsm", "spmsm")
    assert m["phases"] in (3, 5)
    assert isinstance(m["pole_pairs"], int) and m["pole_pairs"] > 0


def test_numbers_are_numbers(machine):
    name, m = machine
    for table in ("electrical", "mechanical", "rated"):
        for k, v in m[table].items():
            assert _is_number(v), f"{name}: [{table}] {k} = {v!r}"
    for k, v in m["bench"].items():
        if k in ("sampling", "reasons"):
            continue
        assert _is_number(v), f"{name}: [bench] {k} = {v!r}"


def test_electrical_values(machine):
    name, m = machine
    e = m["electrical"]
    for k in ("R_s", "L_d", "L_q", "psi_f"):
        assert e[k] > 0, f"{name}: {k} must be positive"
    # SI: henry and weber, not mH
    assert e["L_d"] < 1.0 and e["L_q"] < 1.0, name
    if m["kind"] == "ipmsm":
        assert e["L_d"] <= e["L_q"], name
    else:
        assert e["L_d"] == e["L_q"], name


def test_mechanical_and_rated(machine):
    name, m = machine
    assert m["mechanical"]["J"] > 0
    assert m["mechanical"]["B"] >= 0
    assert m["mechanical"]["T_coulomb"] >= 0
    for k in ("torque", "current", "speed_rpm", "voltage", "power"):
        assert m["rated"][k] > 0, f"{name}: rated {k}"


def test_bench_values(machine):
    name, m = machine
    b = m["bench"]
    assert b["sampling"] in ("single", "double")
    assert b["u_dc"] > 0
    assert 1e3 <= b["f_pwm"] <= 1e5, "f_pwm in Hz"
    assert 0 < b["t_dead"] < 1e-5, "t_dead in s"
    assert 0 < b["i_max"] < b["i_trip"] < b["adc_range"], name
    assert isinstance(b["adc_bits"], int) and 8 <= b["adc_bits"] <= 24
    assert isinstance(b["encoder_bits"], int) and 8 <= b["encoder_bits"] <= 32
    assert b["bw_speed"] < b["bw_current"], name
    for k in ("bw_current", "bw_speed", "bw_pll"):
        assert b[k] > 0
    if "i_lim" in b:
        assert 0 < b["i_lim"] < b["i_max"]


def test_every_chosen_bench_key_has_a_reason(machine):
    name, m = machine
    bench = {k for k in m["bench"] if k != "reasons"}
    reasons = m["bench"].get("reasons", {})
    assert not set(GIVEN_BY_PAPER[name]) - bench, "GIVEN_BY_PAPER names unknown keys"
    for k in sorted(bench - GIVEN_BY_PAPER[name]):
        r = reasons.get(k)
        assert isinstance(r, str) and len(r.split()) >= 4, f"{name}: no reason for {k}"
    stray = set(reasons) - bench
    assert not stray, f"{name}: reasons for unknown keys {sorted(stray)}"


def test_derivations_point_at_existing_keys(machine):
    name, m = machine
    for path, text in m.get("derivations", {}).items():
        node = m
        for part in path.split("."):
            assert isinstance(node, dict) and part in node, f"{name}: {path}"
            node = node[part]
        assert isinstance(text, str) and text.strip(), f"{name}: {path}"


NUMERIC_LINE = re.compile(r"^\s*[A-Za-z_][A-Za-z0-9_]*\s*=\s*[-+]?[0-9.]")


@pytest.mark.parametrize("name", MACHINES)
def test_every_numeric_value_cites_its_source(name):
    lines = (MACHINES_DIR / f"{name}.toml").read_text(encoding="utf-8").splitlines()
    for n, line in enumerate(lines, 1):
        if NUMERIC_LINE.match(line):
            _, _, comment = line.partition("#")
            assert comment.strip(), f"{name}.toml:{n}: numeric value without source"


def test_injection_and_machine_specifics():
    yang, zou, yu = (_load(n) for n in MACHINES)
    assert yang["injection"]["kind"] == "rotating"
    assert 0 < yang["injection"]["u_h"] < yang["bench"]["u_dc"] / math.sqrt(3)
    # the carrier, designed (the machine leaves it out: design.design_carrier), well below Nyquist:
    # at least 5 samples per period
    from fullspeed.design.scenario import load_scenario
    assert "f_h" not in yang["injection"]
    assert yang["bench"]["f_pwm"] / load_scenario("yang2022-hfi-ramp").data["injection"]["f_h"] >= 5
    assert yang["blending"]["lower_rpm"] < yang["blending"]["upper_rpm"]

    inj = yu["injection"]
    assert (inj["kind"], inj["u_h"], inj["f_h"]) == ("square", 60.0, 2000.0)
    # the paper's PLL gains are fs_pll's design k_p = 2 w_b, k_i = w_b^2
    assert math.isclose(2 * inj["bw_pll"], yu["paper_gains"]["pll_kp"], rel_tol=1e-3)
    assert math.isclose(inj["bw_pll"] ** 2, yu["paper_gains"]["pll_ki"], rel_tol=1e-3)
    assert inj["xcomp_paper"] == [0.018, -0.025, 0.0, -0.0015]   # eq. (22)
    assert yu["bench"]["sampling"] == "double"
    assert yu["paper_gains"]["pll_kp"] == 115.0
    assert yu["paper_gains"]["pll_ki"] == 3306.0
    th = yu["third_harmonic"]
    assert 0 < th["L_d3"] < yu["electrical"]["L_d"]
    assert 0 < th["L_q3"] < yu["electrical"]["L_q"]
    assert 0 < th["psi_f3"] < 0.1 * yu["electrical"]["psi_f"]

    b, x = zou["bench"], zou["bench_experiment"]
    assert b["i_max"] == 15.0 and b["i_lim"] == 12.0
    assert x["i_max"] == 8.8 and x["i_lim"] == 6.0
    # mean virtual dc link of the linear rectifier modulation, eq. (9)
    for t in (b, x):
        vim = t["u_grid_ll_rms"] * math.sqrt(2.0 / 3.0)
        assert t["u_dc"] == pytest.approx(9 * math.log(3) / (2 * math.pi) * vim, abs=0.1)
        assert t["u_dc_min"] == pytest.approx(1.5 * vim, abs=0.1)


def test_yang_dc_link_reaches_rated_point():
    """Rated current at rated speed (id = 0) fits in the linear SVPWM range."""
    m = _load("yang2022")
    e, r = m["electrical"], m["rated"]
    we = r["speed_rpm"] * 2 * math.pi / 60 * m["pole_pairs"]
    iq = r["current"]
    u = math.hypot(e["R_s"] * iq + we * e["psi_f"], we * e["L_q"] * iq)
    assert u < 0.9 * m["bench"]["u_dc"] / math.sqrt(3)


def test_yu_flux_gives_rated_torque():
    m = _load("yu2022")
    torque = 2.5 * m["pole_pairs"] * m["electrical"]["psi_f"] * m["rated"]["current"]
    assert torque == pytest.approx(m["rated"]["torque"], rel=0.02)
