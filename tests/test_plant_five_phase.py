"""The five-phase plant through the runner (the drive's five-phase modulation
is not needed: with the drive off every leg sits at duty 0.5, so the machine
is short-circuited in both VSD planes), the [third_harmonic] machine table,
and the runner's phase-count checks."""
import copy
import math

import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.model.errors import ConfigError
from fullspeed.design.machine import load_machine, machine_from_dict
from fullspeed.model.machines import catalog_data
from fullspeed.design.scenario import scenario_from_dict
from fullspeed.sim import build_config, simulate
from fullspeed.model.units import rpm_to_rad_s


def yu_machine(**third):
    """yu2022 inline, with a stronger third-harmonic magnet flux (a clear
    current) and a trip level above the short-circuit transient."""
    m = copy.deepcopy(catalog_data("yu2022"))
    m["third_harmonic"].update({"psi_f3": 0.02, **third})
    m["bench"].update({"i_max": 30.0, "i_trip": 40.0, "adc_range": 50.0})
    return m


def off_scenario(machine, inverter, rpm=300.0, duration=0.4):
    return {
        "name": "five-phase-off", "duration": duration, "machine": machine,
        "converter": {"inverter": inverter, "t_dead": 0.0, "u_on": 0.0},
        "sensors": {"adc_bits": 0, "encoder_bits": 0},
        "controller": {"mode": "off", "dead_time_comp": False},
        "load": {"kind": "speed", "speed_rpm": rpm},
    }


@pytest.mark.parametrize("inverter", ["averaged", "switching"])
def test_short_circuit_steady_state_both_planes(inverter):
    """Zero voltage in both planes at a held speed: the steady currents solve
    the fundamental dq equations and eq. (1) of yu2022 (d3-q3) with p = 0; the
    phase currents are the inverse VSD of the two planes; the power balance
    holds with the stored energy 5/2 (W + W3)."""
    md = yu_machine()
    rpm = 300.0
    res = simulate(scenario_from_dict(off_scenario(md, inverter, rpm)))
    assert res.stop_reason == "done"
    e, th = md["electrical"], md["third_harmonic"]
    R, w = e["R_s"], md["pole_pairs"] * rpm_to_rad_s(rpm)
    t = res["t"]
    last = t >= 0.3

    # fundamental: 0 = R i_d - w L_q i_q, 0 = R i_q + w (L_d i_d + psi_f)
    i_d, i_q = np.linalg.solve([[R, -w * e["L_q"]], [w * e["L_d"], R]], [0.0, -w * e["psi_f"]])
    # third harmonic, eq. (1): 0 = R i_d3 - 3w L_q3 i_q3, 0 = R i_q3 + 3w (L_d3 i_d3 + psi_f3)
    i_d3, i_q3 = np.linalg.solve([[R, -3 * w * th["L_q3"]], [3 * w * th["L_d3"], R]], [0.0, -3 * w * th["psi_f3"]])
    mag1, mag3 = math.hypot(i_d, i_q), math.hypot(i_d3, i_q3)
    assert mag3 > 0.5
    for name, want, mag in (("i_d", i_d, mag1), ("i_q", i_q, mag1), ("i_d3", i_d3, mag3), ("i_q3", i_q3, mag3)):
        got = res[name][last].mean()
        assert abs(got - want) < 0.01 * mag, (name, got, want)

    # the first three phase currents from both planes (phase k at k 2 pi/5)
    g = 2 * math.pi / 5
    th_e = res["theta_e"]
    i_al = np.cos(th_e) * res["i_d"] - np.sin(th_e) * res["i_q"]
    i_be = np.sin(th_e) * res["i_d"] + np.cos(th_e) * res["i_q"]
    i_x = np.cos(3 * th_e) * res["i_d3"] - np.sin(3 * th_e) * res["i_q3"]
    i_y = np.sin(3 * th_e) * res["i_d3"] + np.cos(3 * th_e) * res["i_q3"]
    for k, name in enumerate(("i_a", "i_b", "i_c")):
        want = i_al * math.cos(k * g) + i_be * math.sin(k * g) + i_x * math.cos(3 * k * g) + i_y * math.sin(3 * k * g)
        np.testing.assert_allclose(res[name], want, atol=1e-9 * (mag1 + mag3))
    assert np.ptp(res["i_a"][last]) > 2 * mag1 * 0.9   # the phase current swings through both signs

    # power balance through the transient
    E_in, E_cu, E_ag = (res[k][-1] - res[k][0] for k in ("E_in", "E_cu", "E_airgap"))
    dW = res["W_mag"][-1] - res["W_mag"][0]
    assert E_cu > 1.0
    assert abs(E_in - E_cu - E_ag - dW) < 1e-4 * E_cu


def test_three_phase_third_harmonic_channels_are_zero(make_scenario):
    res = simulate(scenario_from_dict(make_scenario(duration=0.02, references={"i_q": 10.0})))
    assert np.all(res["i_d3"] == 0.0) and np.all(res["i_q3"] == 0.0)
    assert np.any(res["i_q"] != 0.0)


def test_machine_third_harmonic_table():
    m = load_machine("yu2022")
    assert m.phases == 5
    th = catalog_data("yu2022")["third_harmonic"]
    assert (m.L_d3, m.L_q3, m.psi_f3) == (th["L_d3"], th["L_q3"], th["psi_f3"])
    assert m.L_d3 > 0 and m.L_q3 > 0 and m.psi_f3 >= 0


@pytest.mark.parametrize("change, field", [
    ({"L_d3": 0.0}, "machine.third_harmonic.L_d3"),
    ({"L_q3": -1e-3}, "machine.third_harmonic.L_q3"),
    ({"psi_f3": -0.001}, "machine.third_harmonic.psi_f3"),
    ({"psi_f3": "x"}, "machine.third_harmonic.psi_f3"),
    ({"L_e3": 1e-3}, "machine.third_harmonic.L_e3"),
])
def test_third_harmonic_table_errors(change, field):
    md = yu_machine(**change)
    with pytest.raises(ConfigError) as exc:
        machine_from_dict(md)
    assert exc.value.field == field


def test_five_phase_machine_needs_the_table():
    md = yu_machine()
    del md["third_harmonic"]
    with pytest.raises(ConfigError) as exc:
        machine_from_dict(md)
    assert exc.value.field == "machine.third_harmonic"
    md = yu_machine()
    del md["third_harmonic"]["L_q3"]
    with pytest.raises(ConfigError) as exc:
        machine_from_dict(md)
    assert exc.value.field == "machine.third_harmonic.L_q3"


def _create_error(cfg) -> str | None:
    err = ffi.new("char[]", 512)
    ptr = lib.fs_sim_create(cfg, err, 512)
    if ptr != ffi.NULL:
        lib.fs_sim_destroy(ptr)
        return None
    return ffi.string(err).decode()


def test_runner_checks_the_phase_counts():
    sc = scenario_from_dict(off_scenario(yu_machine(), "averaged"))
    cfg, keep = build_config(sc)
    assert (cfg.plant.phases, cfg.inverter.phases, cfg.drive.phases) == (5, 5, 5)
    assert cfg.plant.psi_f3 == 0.02
    assert _create_error(cfg) is None
    cfg.inverter.phases = 3
    assert "inverter.phases" in _create_error(cfg)
    cfg.inverter.phases = 5
    cfg.drive.phases = 3
    assert "controller.phases" in _create_error(cfg)
    cfg.drive.phases = 5
    cfg.plant.phases = 4
    assert "plant.phases" in _create_error(cfg)
    cfg.plant.phases = 5
    cfg.plant.L_d3 = 0.0
    assert "plant.L_d3" in _create_error(cfg)
    cfg.plant.L_d3 = 1e-3
    cfg.plant.psi_f3 = -1.0
    assert "plant.psi_f3" in _create_error(cfg)
