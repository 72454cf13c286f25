"""The catalog of published machines (src/fullspeed/machines/, issue 33): each machine
loads quietly; every value says where it comes from, and every assumed value why; its
magnetics agree with its ratings (the MTPA torque at rated current against the published
rated torque, psi_f at zero current, the voltage at rated speed against its link); its
flux map is the one the generator writes; and a measured map narrower than the designed
current limit is used within its range."""
import math
import re
import tomllib
import warnings
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from fullspeed.cli import main
from fullspeed.design.machine import load_machine, machine_from_dict, mtpa_torque
from fullspeed.design.magnetics import mtpa_locus
from fullspeed.design.rules import u_linear
from fullspeed.model.errors import ConfigError
from fullspeed.model.fluxmap import FluxMapWarning, interp, zero_current_values
from fullspeed.model.machines import catalog_names
from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]
MACHINES = Path(str(resources.files("fullspeed") / "machines"))

# the papers' machines (reproduce/), calibrated to their papers rather than sourced value by value
PAPERS = {"yang2022", "yu2022", "zou2021", "motulator-2kw-ipmsm"}
CATALOG = ["prius2004-mg2", "hefei-h27", "baldor-ecs101m0h7ef4", "syre-thor",
           "anaheim-bly171d", "siemens-1ft6084", "grin-all-axle-5t", "odrive-d6374"]

# The MTPA torque at the rated current (the map's, or the linear model's) within 10 % of
# the rated torque: a datasheet's torque is rounded and measured warm.
TORQUE_TOL = 0.10
# Machines whose magnetics do not give the published torque, with the band of the
# mismatch their file explains ([derivations] "rated.torque"): the Prius map, built from
# two inductances per axis without cross-saturation, gives too much at its peak current;
# the H27 sheet's 4 N m maximum cannot be reached at its 6 A with its own psi_f and L_q.
TORQUE_EXPLAINED = {"prius2004-mg2": (0.15, 0.30), "hefei-h27": (-0.30, -0.15)}
PSI_F_TOL = 0.02          # [electrical] psi_f against the map at zero current
VOLTAGE_TOL = 0.05        # the rated point at most 5 % beyond the linear limit (base speed: at the limit)
# machines whose rated point lies in flux weakening on their link (the file says so)
FLUX_WEAKENING_AT_RATED = {"hefei-h27", "baldor-ecs101m0h7ef4"}
KINDS = ("published", "derived", "assumed")
DESCRIPTION_MAX = 130     # one line of `fullspeed list`


def text(name):
    return (MACHINES / f"{name}.toml").read_text()


def data(name):
    return tomllib.loads(text(name))


def loaded(name):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        m = load_machine(name)
    return m, [str(x.message) for x in w if issubclass(x.category, FluxMapWarning)]


def test_the_catalog_is_the_papers_machines_and_these():
    assert set(catalog_names()) == PAPERS | set(CATALOG)


# the tables whose every value needs its source beside it
SOURCED = {"", "electrical", "mechanical", "rated", "bench", "injection", "blending"}
SKIP = {("", "name"), ("", "description"), ("", "source"), ("", "kind")}
ASSIGN = re.compile(r'^\s*([A-Za-z_]\w*)\s*=\s*(.+?)\s*$')


def annotated_values(name):
    """(table, key, comment) for every value of the sourced tables, as written."""
    table, out = "", []
    for line in text(name).splitlines():
        head = re.match(r"^\s*\[([^\]]+)\]", line)
        if head:
            table = head.group(1).strip()
            continue
        m = ASSIGN.match(line)
        if not m or table not in SOURCED or (table, m.group(1)) in SKIP:
            continue
        value, _, comment = m.group(2).partition("#")
        if value.strip().startswith('"') and '"' in comment:   # a # inside a string
            continue
        out.append((table, m.group(1), comment.strip()))
    return out


@pytest.mark.parametrize("name", CATALOG)
def test_every_value_has_its_source_and_every_assumption_its_reason(name):
    d = data(name)
    assert d["source"].strip() and d["description"].strip()
    notes = {**d.get("derivations", {}), **{f"bench.{k}": v for k, v in d.get("bench", {}).get("reasons", {}).items()}}
    values = annotated_values(name)
    assert len(values) >= 12      # electrical, mechanical, rated and bench at least
    for table, key, comment in values:
        where = f"{name}: {table + '.' if table else ''}{key}"
        kind = comment.split(":")[0].split(" ")[0]
        assert kind in KINDS, f"{where}: its comment must start with one of {KINDS} (got {comment!r})"
        assert len(comment.split()) >= 2, f"{where}: '{comment}' names no source"
        if kind == "assumed":
            reason = notes.get(f"{table}.{key}", "")
            assert len(reason.split()) >= 10, f"{where} is assumed: [derivations] or [bench.reasons] must give the reason"
    # every given value is annotated: the parsed tables hold no value the text scan missed
    seen = {(t, k) for t, k, _ in values}
    for table in SOURCED - {""}:
        for key, v in d.get(table, {}).items():
            if not isinstance(v, dict):
                assert (table, key) in seen, f"{name}: {table}.{key} has no comment"
    if "magnetic" in d:
        assert len(d["magnetic"]["source"].split()) >= 10 and len(d["magnetic"]["reason"].split()) >= 10


@pytest.mark.parametrize("name", CATALOG)
def test_each_loads_without_a_warning_and_fullspeed_list_shows_it(name, capsys):
    m, lines = loaded(name)
    assert not lines, lines          # the loader's consistency warnings: quiet
    assert m.name == name
    main(["list"])
    shown = [ln for ln in capsys.readouterr().out.splitlines() if ln.split()[:1] == [name]]
    assert len(shown) == 1 and data(name)["description"] in shown[0]
    assert len(data(name)["description"]) <= DESCRIPTION_MAX and "\n" not in data(name)["description"]


MAPPED = [n for n in CATALOG if "magnetic" in data(n)]


@pytest.mark.parametrize("name", MAPPED)
def test_the_map_is_in_the_pmsm_convention_and_its_zero_current_values_are_electrical(name):
    """Magnet on +d: psi_d(0, 0) = psi_f > 0, psi_q(i_d, 0) = 0, the larger inductance on q;
    [electrical] psi_f is the map's at zero current."""
    m, _ = loaded(name)
    mag = m.magnetic
    z = zero_current_values(mag)
    assert z["psi_f"] > 0 and abs(z["psi_f"] - m.psi_f) <= PSI_F_TOL * m.psi_f
    row = interp(mag, "psi_q", np.array(mag["i_d"]), 0.0)
    assert np.max(np.abs(row)) < 1e-3 * z["psi_f"]
    assert z["L_d"] < z["L_q"]


def rated_point(m):
    """Torque, currents and flux linkages on MTPA at the rated current."""
    if m.magnetic["model"] == "fluxmap":
        T, d, q = mtpa_locus(m.magnetic, m.i_rated, m.phases, m.pole_pairs)
        i_d, i_q = float(d[-1]), float(q[-1])
        return float(T[-1]), i_d, i_q, float(interp(m.magnetic, "psi_d", i_d, i_q)), float(interp(m.magnetic, "psi_q", i_d, i_q))
    T = mtpa_torque(m, m.i_rated)
    assert m.L_d == m.L_q       # the linear catalog machines are surface-magnet ones: MTPA is i_d = 0
    return T, 0.0, m.i_rated, m.psi_f, m.L_q * m.i_rated


@pytest.mark.parametrize("name", CATALOG)
def test_the_mtpa_torque_at_rated_current_is_the_published_torque(name):
    m, _ = loaded(name)
    T = rated_point(m)[0]
    off = T / m.T_rated - 1.0
    if name in TORQUE_EXPLAINED:
        lo, hi = TORQUE_EXPLAINED[name]
        assert lo <= off <= hi, f"{name}: {off:+.1%} is no longer the mismatch its file explains ({lo:+.0%}..{hi:+.0%})"
        assert len(data(name)["derivations"]["rated.torque"].split()) >= 20
    else:
        assert abs(off) <= TORQUE_TOL, f"{name}: {T:.4g} N m on MTPA at {m.i_rated:g} A against the rated {m.T_rated:g} ({off:+.1%})"


@pytest.mark.parametrize("name", CATALOG)
def test_the_voltage_at_rated_speed_fits_the_link(name):
    """The back-EMF at rated speed within the modulator's linear limit, and the rated
    point (rated current on MTPA at rated speed) at most VOLTAGE_TOL beyond it; or the
    file says the rated point is in flux weakening."""
    m, _ = loaded(name)
    T, i_d, i_q, psi_d, psi_q = rated_point(m)
    w_e = m.pole_pairs * m.w_m_rated
    u = math.hypot(m.R_s * i_d - w_e * psi_q, m.R_s * i_q + w_e * psi_d)
    u_lin = u_linear(m.bench["u_dc"], m.phases)
    if name in FLUX_WEAKENING_AT_RATED:
        assert u > (1 + VOLTAGE_TOL) * u_lin, f"{name}: the rated point fits the link now ({u:.1f} of {u_lin:.1f} V)"
        assert "flux weakening" in text(name)
    else:
        assert w_e * m.psi_f < u_lin and u <= (1 + VOLTAGE_TOL) * u_lin, f"{name}: {u:.1f} V at the rated point, {u_lin:.1f} V linear"


def make_maps():
    return load_script(ROOT / "tools" / "catalog" / "make_maps.py", "make_maps")


@pytest.mark.parametrize("build", ["prius", "h27", "baldor"])
def test_the_maps_are_the_generators_output(build, tmp_path):
    """The catalog's maps are written by tools/catalog/make_maps.py from their sources,
    not by hand (the THOR map needs the motulator sdist: tools/catalog/make_maps.py says how)."""
    path = getattr(make_maps(), build)(tmp_path)
    assert path.read_bytes() == (MACHINES / path.name).read_bytes()


@pytest.mark.parametrize("name", MAPPED)
def test_a_map_names_its_licence_and_the_licence_is_beside_it(name):
    head = [ln for ln in (MACHINES / data(name)["magnetic"]["file"]).read_text().splitlines() if ln.startswith("#")]
    assert any("source" in ln for ln in head) and any("tools/catalog/make_maps.py" in ln for ln in head)
    for lic in re.findall(r"LICENSE-[\w.-]+\.txt", "\n".join(head)):
        assert (MACHINES / lic).is_file(), f"{name}: its map names {lic}, which is not beside it"


def baldor(**changed):
    """The catalog's Baldor machine, its map by absolute path and fields changed
    ("rated__current": rated.current), loaded and designed as a machine table."""
    d = data("baldor-ecs101m0h7ef4")
    d["magnetic"]["file"] = str(MACHINES / d["magnetic"]["file"])
    for key, v in changed.items():
        table, field = key.split("__")
        d[table][field] = v
    return machine_from_dict(d, "baldor.toml")


def test_a_measured_map_narrower_than_the_designed_limit_holds_the_limit_with_one_warning():
    """The Baldor map reaches i_d = -20 A; a rated current of 16.6 A would design 24.9 A."""
    m = baldor()          # 12.45 A rated: 18.7 A designed, inside the map
    assert m.bench["i_max"] == pytest.approx(1.5 * 12.45)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        m = baldor(rated__current=16.6)
    lines = [str(x.message) for x in w if issubclass(x.category, FluxMapWarning)]
    assert len(lines) == 1 and "\n" not in lines[0]
    assert "i_d -20..20 A, i_q -26..26 A" in lines[0] and "held to 20 A" in lines[0] and "24.9 A" in lines[0]
    assert m.bench["i_max"] == 20.0
    assert m.bench["i_trip"] == pytest.approx(1.25 * 20.0)         # what depends on the limit follows it
    assert "flux map covers" in m.design["i_max"].reason and not m.design["i_max"].given


def test_a_given_limit_beyond_a_measured_map_is_refused_naming_the_maps_range():
    with pytest.raises(ConfigError, match=r"machine.magnetic.i_d = '-20..20 A': must cover -i_max..i_max/2 = -24.9..12.45 A"):
        baldor(bench__i_max=24.9)
