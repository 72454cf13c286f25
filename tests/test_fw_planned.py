"""Flux weakening planned on the machine's map (controller.fw_method =
"planned", fs_fwmap.h), a machine given by L_d, L_q, psi_f included (the map
those make): the torque held with the encoder at speeds near the top of the
envelope (design.envelope) is the envelope's. These are the cases that were
not: the Grin hub motor (characteristic current 3.4 x i_max, top speed
1.6 x base) held 0.52 of its envelope at 1.43 x base once the table's rows
reached beyond its top speed, and braked at -23 N m at 1.29 x when its
trim had wound past it; the Anaheim BLY171D held 0.87 at 2 x base while the
trim could only deepen the weakening (the resistive drop planned as
R_s |i| left 1 % of the voltage unused)."""
import math
import tomllib
from importlib import resources

import pytest

from fullspeed.design.envelope import envelope, torque_at
from fullspeed.design.machine import load_machine
from fullspeed.design.scenario import scenario_from_dict
from fullspeed.model.errors import ConfigError
from fullspeed.reproduce.papers.real import held_scenario, held_torque


@pytest.mark.parametrize("name, x_base", [("grin-all-axle-5t", 1.43), ("anaheim-bly171d", 2.0)])
def test_the_planned_flux_weakening_holds_the_envelope_near_the_top_speed(name, x_base):
    m = load_machine(name)
    env = envelope(m, m.bench["u_dc"], m.bench["i_max"], w_end=4.0 * m.w_m_rated)
    w = x_base * env.w_base
    T_env = torque_at(env, w)
    r = held_torque({"machine": name, "rpm": w * 30.0 / math.pi, "angle": "encoder"})
    assert r["stop_reason"] == "done"
    assert abs(r["T"] / T_env - 1.0) < 0.02, (r["T"], T_env)


def _held(name: str, controller: dict) -> dict:
    d = held_scenario(name, 1000.0, "encoder")
    d["controller"].update(controller)
    return d


def test_the_method_is_refused_where_it_cannot_act():
    # zou2021's feedback on a flux-map machine: its flux weakening is planned on the map
    with pytest.raises(ConfigError, match=r"^controller\.fw_method = 'feedback': must be \"planned\" on a machine with a flux map"):
        scenario_from_dict(_held("prius2004-mg2", {"fw_method": "feedback"}))
    # the feedback's own settings with the planned method: no silent no-op
    for key, value in (("fw_gain", 2.0), ("fw_cutoff", 500.0), ("fw_top_speed_rpm", 3000.0)):
        with pytest.raises(ConfigError, match=rf"^controller\.{key} = .*: is fw_method = \"feedback\"'s"):
            scenario_from_dict(_held("anaheim-bly171d", {key: value}))
    with pytest.raises(ConfigError, match=r"^controller\.fw_excess = 'held': must be \"wound_back\" with fw_method = \"planned\""):
        scenario_from_dict(_held("anaheim-bly171d", {"fw_excess": "held"}))
    # both are accepted where they act
    scenario_from_dict(_held("anaheim-bly171d", {"fw_method": "feedback", "fw_gain": 2.0}))
    scenario_from_dict(_held("anaheim-bly171d", {}))


def test_the_default_method_follows_the_converter():
    """The plan's voltage limit is a three-phase inverter's: the matrix converter (zou2021) takes the
    feedback by default and refuses the plan by name; a three-phase inverter takes the plan."""
    d = tomllib.loads(resources.files("fullspeed").joinpath("scenarios/zou2021-region-b.toml").read_text())
    del d["controller"]["fw_method"]
    assert scenario_from_dict(d).data["controller"]["fw_method"] == "feedback"
    d["controller"]["fw_method"] = "planned"
    with pytest.raises(ConfigError, match=r"^.*controller\.fw_method = 'planned': must be \"feedback\" with five phases or the matrix converter"):
        scenario_from_dict(d)
    assert scenario_from_dict(_held("anaheim-bly171d", {})).data["controller"]["fw_method"] == "planned"


def test_the_trim_leaves_the_voltage_limit_fast_and_approaches_it_slowly():
    """fs_fwmap_trim: the voltage asked above the plan raises the trim at
    its whole rate, below the plan lowers it at FS_FWMAP_TRIM_APPROACH of
    it (beyond the limit the d current is lost, inside it some torque), and
    only where the current's flux is on the plan's flux limit."""
    import re
    from pathlib import Path
    from fullspeed._core import ffi, lib
    header = (Path(__file__).resolve().parents[1] / "csrc" / "control" / "fs_fwmap.h").read_text()
    approach = float(re.search(r"#define FS_FWMAP_TRIM_APPROACH ([0-9.]+)f", header).group(1))
    inside = float(re.search(r"#define FS_FWMAP_INSIDE ([0-9.]+)f", header).group(1))
    f = ffi.new("fs_fwmap *")
    f.k_trim = 0.01
    f.psi_mtpa = 1.0
    x = 2.0
    on_limit = f.psi_mtpa / x   # the current's flux on the plan's flux limit
    e = 0.2
    lib.fs_fwmap_reset(f)
    lib.fs_fwmap_trim(f, (1.0 + e) * 100.0, 100.0, on_limit, x)
    up = f.trim
    lib.fs_fwmap_reset(f)
    lib.fs_fwmap_trim(f, (1.0 - e) * 100.0, 100.0, on_limit, x)
    down = f.trim
    assert up == pytest.approx(0.01 * e, rel=1e-5)
    assert down == pytest.approx(-approach * 0.01 * e, rel=1e-5)
    assert 0.0 < approach < 1.0
    lib.fs_fwmap_reset(f)   # inside the flux limit (MTPA at a light load) the voltage below the plan lowers nothing
    lib.fs_fwmap_trim(f, (1.0 - e) * 100.0, 100.0, (1.0 - 2.0 * inside) * on_limit, x)
    assert f.trim == 0.0


@pytest.mark.parametrize("rpm", [2765.0, 3456.0])
def test_sensorless_deep_flux_weakening_holds_the_encoders_torque(rpm):
    """SyR-e's THOR held by a load machine at 2 and 2.5 x its base speed
    (B-REAL's fourth and fifth held speeds): with a trim as fast towards
    the voltage limit as away from it, the trim and the back-EMF observer's
    angle made a 15 Hz limit cycle that held 14 % less torque than the
    encoder drive at 2,765 rpm; at 3,456 rpm the carrier stayed on through
    the load machine's ramp (the blend's trust not yet whole) and its
    voltage, taken off the plan's, left no torque: overcurrent."""
    # The sensorless torque here moved with the speed by more than its mean error: at speeds 0.1 % apart
    # (k = -3..3) it spanned 29.38..30.26 N m at 3,456 rpm against the encoder's 30.28 before the trim's hold
    # inside the flux limit, 29.79..30.31 since, and with the start-up's settled read (fs_drive_reset) four
    # of the seven were 2 to 5.5 % short: the current loops' gains stepped with the map's incremental
    # inductance each time the q current crossed the grid's line at 11 A, the loops chattered at the voltage
    # limit and the trim wound up and down every 90 ms. On the slopes continuous across the lines
    # (fs_fluxmap_slopes) the seven lie within 0.29..0.30 % of the encoder's: three speeds 0.1 % apart, each
    # within 0.5 % (the limit cycle's loss was 14 %, B-REAL allows 5)
    for k in (-1, 0, 1):
        w = rpm * (1.0 + 1e-3 * k)
        enc = held_torque({"machine": "syre-thor", "rpm": w, "angle": "encoder"})
        sl = held_torque({"machine": "syre-thor", "rpm": w, "angle": "blend"})
        assert enc["stop_reason"] == sl["stop_reason"] == "done"
        assert abs(sl["T"] / enc["T"] - 1.0) < 0.005, (w, sl["T"], enc["T"])
