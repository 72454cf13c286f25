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
