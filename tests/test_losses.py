"""Where the power goes: the device model (conduction and commutation), the
iron loss drawn from the shaft, and the energy balance of every converter:
the energy the converter takes from its source = the stored energy's change
+ every loss + the load's work, to the integrator's precision."""
import copy
import math

import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.design.scenario import load_scenario, scenario_from_dict
from fullspeed.model.errors import ConfigError
from fullspeed.model.machines import catalog_data
from fullspeed.model.units import rpm_to_rad_s
from fullspeed.sim import simulate
from fullspeed.sim.metrics import window_mask

from conftest import MACHINE

# A module for the test machine's 24 V link: thresholds and resistances unequal between
# transistor and diode, so that a wrong device choice shows.
CONV = {"module": "test module", "source": "a test's", "u_t": 0.8, "r_t": 0.004, "u_d": 0.9, "r_d": 0.003,
        "E_on": 1e-3, "E_off": 1.5e-3, "E_rr": 0.5e-3, "I_ref": 50.0, "V_ref": 24.0}
IRON = {"P_fe_ref": 20.0, "speed_fe_rpm": 2000.0, "k_hyst": 0.6, "beta": 1.8, "source": "assumed: a test's"}
METERS = ("E_in", "E_cu", "E_airgap", "W_mag", "E_grid", "E_rf", "W_filter",
          "E_dc", "E_cond", "E_rect", "E_sw", "E_fe", "E_mech", "E_shaft")


def device(**kw):
    d = {"enabled": 1, "kind": lib.FS_DEV_IGBT, "u_t": 0.8, "r_t": 0.004, "u_d": 0.9, "r_d": 0.003,
         "E_on": 1e-3, "E_off": 1.5e-3, "E_rr": 0.5e-3, "I_ref": 50.0, "V_ref": 24.0,
         "k_i_t": 1.0, "k_v_t": 1.35, "k_i_d": 0.6, "k_v_d": 0.6, **kw}
    return ffi.new("fs_device_config *", d)


def test_each_rail_conducts_through_the_device_its_current_picks():
    """A leg at duty 0.7 (no dead time) carrying +10 A: the upper IGBT for
    0.7 of the period, the lower diode for 0.3; at -10 A the upper diode and
    the lower IGBT. A MOSFET's channel both ways. The dc link passes s i."""
    inv = ffi.new("fs_inverter_config *", {"kind": lib.FS_INV_AVERAGED, "u_dc": 24.0, "T_pwm": 1e-4, "phases": 3,
                                           "dev": device()[0]})
    duty = ffi.new("double[3]", [0.7, 0.7, 0.7])
    s, drop = ffi.new("double[3]"), ffi.new("double[3]")
    i_ph = ffi.new("double[3]", [10.0, -10.0, 0.0])
    lib.fs_inverter_mean_legs(inv, duty, i_ph, s, drop)
    assert s[0] == pytest.approx(0.7) and s[1] == pytest.approx(0.7)
    assert drop[0] == pytest.approx(0.7 * (0.8 + 0.04) + 0.3 * (0.9 + 0.03))
    assert drop[1] == pytest.approx(-(0.7 * (0.9 + 0.03) + 0.3 * (0.8 + 0.04)))
    assert drop[2] == 0.0
    inv.dev.kind = lib.FS_DEV_MOSFET
    lib.fs_inverter_mean_legs(inv, duty, i_ph, s, drop)
    assert drop[0] == pytest.approx(0.8 + 0.04) and drop[1] == pytest.approx(-(0.8 + 0.04))
    # the switching model's dead time: the diode on the rail opposite to the current
    state = ffi.new("int[3]", [-1, -1, 1])
    lib.fs_inverter_legs(inv, state, i_ph, s, drop)
    assert (s[0], s[1]) == (0.0, 1.0)
    assert drop[0] == pytest.approx(0.9 + 0.03) and drop[1] == pytest.approx(-(0.9 + 0.03))


def test_a_commutation_is_a_turn_off_or_a_hard_turn_on_with_recovery():
    """Leaving the upper rail with the current out of the leg: its IGBT turns
    off (E_off); into the leg: the lower IGBT turns on against the upper
    diode (E_on + E_rr); scaled by the power laws from (I_ref, V_ref)."""
    d = device()
    assert lib.fs_device_commutation(d, 1, 50.0, 24.0) == pytest.approx(1.5e-3)
    assert lib.fs_device_commutation(d, 1, -50.0, 24.0) == pytest.approx(1.0e-3 + 0.5e-3)
    assert lib.fs_device_commutation(d, 0, -50.0, 24.0) == pytest.approx(1.5e-3)
    assert lib.fs_device_commutation(d, 0, 25.0, 48.0) == pytest.approx(
        1.0e-3 * 0.5 * 2.0 ** 1.35 + 0.5e-3 * 0.5 ** 0.6 * 2.0 ** 0.6)
    assert lib.fs_device_commutation(d, 0, 0.0, 48.0) == 0.0


def test_the_iron_drag_draws_the_iron_loss():
    """Above its band, T_fe w_m = P_fe at any flux, hysteresis exponent and sign of the speed."""
    fe = ffi.new("fs_iron_config *", {"P_ref": 500.0, "w_ref": 2000.0, "psi_ref": 0.16, "k_hyst": 0.4,
                                      "beta": 1.7, "w_band": 5.0})
    for w_m, psi in ((300.0, 0.16), (-150.0, 0.09), (600.0, 0.2)):
        P = lib.fs_iron_loss(fe, 4 * w_m, psi)
        assert lib.fs_iron_torque(fe, 4, w_m, psi) * w_m == pytest.approx(P, rel=1e-12)
    assert lib.fs_iron_loss(fe, 2000.0, 0.16) == pytest.approx(500.0)
    assert lib.fs_iron_torque(fe, 4, 0.0, 0.16) == 0.0


def run_test_machine(inverter, losses, **sections):
    m = copy.deepcopy(MACHINE)
    m.update(converter=CONV, losses=IRON, mechanical={"J": 1.87e-3, "B": 2e-4, "T_coulomb": 0.03})
    d = {"name": "losses", "duration": 0.15, "machine": m, "converter": {"inverter": inverter},
         "controller": {"mode": "speed"}, "losses": losses,
         "references": {"speed_rpm": [[0, 0], [0.01, 0], [0.05, 1500]]},
         "load": {"torque": [[0, 0], [0.08, 0], [0.1, 1.5]]}, **sections}
    return simulate(scenario_from_dict(d))


def balance(res, J):
    """The energy balance's residuals over the run (J) and the source's energy."""
    d = {k: res[k][-1] - res[k][0] for k in METERS}
    KE = 0.5 * J * (res["w_m"][-1] ** 2 - res["w_m"][0] ** 2)
    source = d["E_grid"] if res.scenario.data["converter"]["kind"] == "imc" else d["E_dc"]
    stored = d["W_mag"] + KE + d["W_filter"]
    losses = d["E_cu"] + d["E_fe"] + d["E_mech"] + d["E_cond"] + d["E_rect"] + d["E_sw"] + d["E_rf"]
    return {"total": source - (stored + losses + d["E_shaft"]),
            "converter": d["E_dc"] - (d["E_in"] + d["E_cond"] + d["E_rect"] + d["E_sw"]),
            "shaft": d["E_airgap"] - (d["E_fe"] + d["E_mech"] + d["E_shaft"] + KE)}, source, d


def five_phase_scenario():
    m = copy.deepcopy(catalog_data("yu2022"))
    m["converter"] = {**CONV, "V_ref": 60.0, "I_ref": 10.0}
    m["losses"] = {**IRON, "P_fe_ref": 60.0, "speed_fe_rpm": 300.0}
    return {"name": "losses-5ph", "duration": 0.3, "machine": m, "converter": {"inverter": "switching"},
            "controller": {"mode": "speed", "angle": "encoder"}, "losses": {"devices": True, "iron": True},
            "references": {"speed_rpm": [[0, 0], [0.02, 0], [0.1, 300]]},
            "load": {"torque": [[0, 0], [0.15, 0], [0.2, 5.0]]}}


@pytest.mark.parametrize("case", ["switching", "averaged", "speed-held", "five-phase", "imc"])
def test_source_energy_is_stored_energy_plus_every_loss(case):
    """Through an acceleration and a load step, with the module's devices and
    the iron loss on: the converter's source gives what is stored (magnetic,
    kinetic, the filter's) plus every loss (copper, iron, friction,
    conduction, rectifier, commutation, damping) plus the load's work, to the
    integrator's precision; the converter passes E_in plus its own losses
    (an identity of the held coefficients, to rounding); the shaft side
    closes on the kinetic energy (an ideal speed load takes what the shaft
    gives beyond the speed's own change)."""
    if case in ("switching", "averaged"):
        res, J = run_test_machine(case, {"devices": True, "iron": True}), 1.87e-3
    elif case == "speed-held":
        res, J = run_test_machine("switching", {"devices": True, "iron": True}, controller={"mode": "current"},
                                  references={"i_q": 20.0},
                                  load={"kind": "speed", "speed_rpm": [[0, 0], [0.1, 1200.0]]}), 1.87e-3
    elif case == "five-phase":
        sc = scenario_from_dict(five_phase_scenario())
        res, J = simulate(sc), sc.machine.J
    else:
        sc = load_scenario("zou2021-region-c", {"losses": {"devices": True}, "converter": {"t_dead": 2e-6}})
        res, J = simulate(sc), sc.machine.J
    assert res.stop_reason == "done"
    r, source, d = balance(res, J)
    assert source > 10.0
    for key in ("E_cond", "E_sw", "E_cu", "E_mech", "E_shaft"):
        assert abs(d[key]) > 1e-3 * source, key   # each meter has something to say (a speed load may push)
    if case != "imc":
        assert d["E_fe"] > 1e-3 * source
    else:
        assert d["E_rect"] > 1e-3 * source and d["E_rf"] > 0.0
    assert abs(r["total"]) < 1e-6 * source, r
    assert abs(r["converter"]) < 1e-10 * source, r
    # an ideal speed load resets the speed to its profile each period, with the profile's slope held over it:
    # at the ramp's corner that is the run's approximation, not the integrator's
    assert abs(r["shaft"]) < (1e-6 if case == "speed-held" else 1e-8) * source, r


def held_point(inverter, conv, rpm=1200.0, i_q=30.0):
    """The test machine at a held speed in current mode: a steady sinusoidal current of amplitude ~i_q."""
    m = copy.deepcopy(MACHINE)
    m["converter"] = {**CONV, **conv}
    d = {"name": "held", "duration": 0.1, "machine": m,
         "converter": {"inverter": inverter, "t_dead": 0.0}, "sensors": {"adc_bits": 0, "encoder_bits": 0, "noise_i": 0.0},
         "controller": {"mode": "current", "angle": "true", "dead_time_comp": False},
         "references": {"i_q": i_q}, "load": {"kind": "speed", "speed_rpm": rpm}, "losses": {"devices": True}}
    res = simulate(scenario_from_dict(d))
    m = window_mask(res["t"], 0.05, 0.1)
    T = res["t"][m][-1] - res["t"][m][0]
    I = float(np.mean(np.hypot(res["i_d"][m], res["i_q"][m])))
    rate = {k: (res[k][m][-1] - res[k][m][0]) / T for k in ("E_cond", "E_sw", "E_dc", "E_in")}
    rate["i_ph"] = np.stack([res[ch][m] for ch in ("i_a", "i_b", "i_c")])
    return I, rate


def test_conduction_loss_of_equal_devices_is_the_sinusoids():
    """Transistor and diode alike: whichever conducts, each leg dissipates
    u |i| + r i^2 whatever the duties: the meter against the traced phase
    currents (the averaged inverter's are smooth), and against a sinusoid of
    their amplitude, 3 (2 u I / pi + r I^2 / 2) (the threshold's square-wave
    voltage bends the current by a few per mille)."""
    u, r = 0.85, 0.0035
    I, rate = held_point("averaged", {"u_t": u, "u_d": u, "r_t": r, "r_d": r})
    assert I > 25.0
    i = rate["i_ph"]
    assert rate["E_cond"] == pytest.approx(np.mean(np.sum(u * np.abs(i) + r * i * i, axis=0)), rel=2e-3)
    assert rate["E_cond"] == pytest.approx(3 * (2 * u * I / math.pi + r * I * I / 2), rel=0.02)


def test_motoring_loads_the_transistors_more_than_the_diodes():
    """Motoring (power factor near 1) the transistors carry most of the
    current: the loss with unequal devices lies between the two equal-device
    ones, nearer the transistor's."""
    I, both = held_point("averaged", {})
    _, all_t = held_point("averaged", {"u_d": CONV["u_t"], "r_d": CONV["r_t"]})
    _, all_d = held_point("averaged", {"u_t": CONV["u_d"], "r_t": CONV["r_d"]})
    lo, hi = sorted((all_t["E_cond"], all_d["E_cond"]))
    assert lo < both["E_cond"] < hi
    assert abs(both["E_cond"] - all_t["E_cond"]) < abs(both["E_cond"] - all_d["E_cond"])


@pytest.mark.parametrize("inverter", ["averaged", "switching"])
def test_commutation_power_is_the_edges_at_the_sinusoids_mean_current(inverter):
    """Every leg switches on and off once a period (linear modulation): with
    energies linear in the current, 3 f (E_on + E_off + E_rr) (2 I / pi) / I_ref
    at the link's voltage over V_ref to its exponents."""
    conv = {"k_i_t": 1.0, "k_i_d": 1.0, "V_ref": 20.0}
    I, rate = held_point(inverter, conv)
    E = (CONV["E_on"] + CONV["E_off"]) * (24.0 / 20.0) ** 1.35 + CONV["E_rr"] * (24.0 / 20.0) ** 0.6
    assert rate["E_sw"] == pytest.approx(3 * 1e4 * E * 2 * I / math.pi / CONV["I_ref"], rel=0.02)


def test_the_meters_do_not_touch_the_plant():
    """Ideal switches and no iron loss: metering (losses.trace) leaves every
    other channel as it was, to the bit."""
    a = run_test_machine("switching", {})
    b = run_test_machine("switching", {"trace": True})
    for ch in a.traces:
        if ch not in METERS[7:]:
            assert np.array_equal(a[ch], b[ch]), ch
    assert b["E_dc"][-1] > 0.0 and np.all(a["E_dc"] == 0.0)


def test_losses_need_the_machines_tables():
    d = {"name": "x", "duration": 0.1, "machine": copy.deepcopy(MACHINE), "controller": {"mode": "speed"}}
    with pytest.raises(ConfigError, match="losses.devices"):
        scenario_from_dict({**d, "losses": {"devices": True}})
    with pytest.raises(ConfigError, match="losses.iron"):
        scenario_from_dict({**d, "losses": {"iron": True}})
    d["machine"]["converter"] = CONV
    with pytest.raises(ConfigError, match="converter.u_on"):
        scenario_from_dict({**d, "losses": {"devices": True}, "converter": {"u_on": 0.5}})
    with pytest.raises(ConfigError, match="machine.converter.I_ref"):
        scenario_from_dict({**d, "machine": {**d["machine"], "converter": {**CONV, "I_ref": 0.0}}})
