"""zou2021 in closed loop: the matrix converter's energy balance, the
transfer ratio of each modulation region, flux weakening that leaves by
itself, PART_2's polarity gate, and the fields the model refuses."""
import math

import numpy as np
import pytest

import fullspeed.sim as fs
from fullspeed.model.errors import ConfigError
from fullspeed.sim.metrics import window_mask
from fullspeed.reproduce.papers.zou2021 import eq12, thd
from fullspeed.design.scenario import load_scenario
from fullspeed.model.units import rad_s_to_rpm


@pytest.fixture(scope="module")
def region_b():
    return fs.simulate("zou2021-region-b")


def _at(res, t):
    return int(np.searchsorted(res["t"], t))


def test_grid_energy_is_the_machines_input_plus_the_filters_and_the_devices_losses(region_b):
    """Over ten whole grid cycles in steady state: energy from the grid =
    damping loss + change of the filter's stored energy + the energy the
    converter takes, which is what the inverter stage delivers to the
    machine plus its devices' losses (the scenario's module)."""
    r = region_b
    k0, k1 = _at(r, 0.38), _at(r, 0.58)
    d = {ch: r[ch][k1] - r[ch][k0] for ch in ("E_grid", "E_rf", "W_filter", "E_in", "E_dc", "E_cond", "E_rect", "E_sw")}
    assert d["E_in"] > 0.2 * 0.2 * 10.0 * 150.0, "the machine takes power (10 N m at 1500 rpm for 0.2 s)"
    assert d["E_grid"] - d["E_rf"] - d["W_filter"] == pytest.approx(d["E_dc"], rel=1e-6)
    assert d["E_dc"] == pytest.approx(d["E_in"] + d["E_cond"] + d["E_rect"] + d["E_sw"], rel=1e-9)
    assert d["E_rf"] > 0.0 and min(d["E_cond"], d["E_rect"], d["E_sw"]) > 1e-3 * d["E_in"]


def test_region_b_weakens_the_flux_in_over_modulation_with_the_rectifier_in_case_1(region_b):
    r = region_b
    m = window_mask(r["t"], 0.4, 0.6)
    assert abs(np.mean(rad_s_to_rpm(r["w_m"][m])) - 1500.0) < 5.0
    assert np.mean(r["i_d"][m]) < -2.0, "flux weakening"
    assert np.mean(r["overmod"][m]) > 0.9, "the inverter stage over-modulates"
    assert np.max(r["alpha"][m]) == 0.0, "PART_2 off: I_ref below I_lim, alpha = 0 (OM-I)"


def test_grid_current_thd_is_computed_over_whole_cycles(region_b):
    """A pure 50 Hz current has no distortion; one fifth harmonic of 10 % gives 10 %."""
    r = region_b
    t = r["t"]
    pure = {"t": t, "i_grid_a": np.cos(2 * np.pi * 50 * t)}
    fifth = {"t": t, "i_grid_a": np.cos(2 * np.pi * 50 * t) + 0.1 * np.cos(2 * np.pi * 250 * t + 1.0)}
    assert thd(pure, 0.4, 0.6) < 1e-6
    assert thd(fifth, 0.4, 0.6) == pytest.approx(10.0, rel=1e-6)


@pytest.mark.parametrize("modulation, q_max", [("linear", math.sqrt(3) / 2),
                                               ("om1", 3 * math.log(3) / math.pi * eq12(0.0) / math.sqrt(3)),
                                               ("om2", 3 * math.log(3) / math.pi * eq12(math.pi / 6) / math.sqrt(3))])
def test_each_region_saturates_at_its_transfer_ratio(modulation, q_max):
    """Output demanded at twice the input: the fundamental of the output line
    voltage stops at eq. (20)'s ratio of the region (within 0.01)."""
    r = fs.simulate("zou2021-modulator-vtr", overrides={"converter": {"modulation": modulation}})
    t = r["t"]
    m = window_mask(t, 0.1, 0.3)
    x = r["u_ab"][m]
    k = int(round(40.0 * x.size * (t[1] - t[0])))
    v_om = 2.0 * abs(np.fft.rfft(x)[k]) / x.size / math.sqrt(3)
    assert v_om / (380.0 * math.sqrt(2 / 3)) == pytest.approx(q_max, abs=0.01)


def test_flux_weakening_and_rectifier_over_modulation_end_when_the_speed_falls_back():
    """The low-pass of eq. (30) in place of the integrator: back at 1000 rpm
    the d-current returns to 0 and alpha to 0 by themselves. I_lim at 10.5 A
    (12 in Region C) so that PART_2 holds a deep alpha at 1750 rpm first."""
    r = fs.simulate("zou2021-region-c", overrides={
        "duration": 1.0, "controller": {"i_lim": 10.5}, "references": {"speed_rpm": [[0.0, 1500.0], [0.2, 1500.0], [0.2, 1750.0],
                                                      [0.5, 1750.0], [0.5, 1000.0], [1.0, 1000.0]]},
        "load": {"torque": [[0.0, 0.0], [0.1, 0.0], [0.1, 10.0], [1.0, 10.0]]}})
    t = r["t"]
    deep = window_mask(t, 0.4, 0.5)
    after = window_mask(t, 0.8, 1.0)
    assert np.mean(r["i_d_fw"][deep]) < -5.0 and np.mean(r["alpha"][deep]) > 0.1
    assert np.max(np.abs(r["i_d_fw"][after])) < 0.05
    assert np.max(r["alpha"][after]) == 0.0
    assert abs(np.mean(rad_s_to_rpm(r["w_m"][after])) - 1000.0) < 5.0


def test_part2_stays_off_at_low_speed_and_heavy_load():
    """Sec. 4.4's gate (segment HI of Fig. 6): the current above I_lim at low
    speed does not start rectifier over-modulation."""
    r = fs.simulate("zou2021-region-a", overrides={
        "controller": {"i_lim": 2.0},
        "load": {"torque": [[0.0, 0.0], [0.2, 0.0], [0.2, 15.0], [0.4, 15.0]]}})
    m = window_mask(r["t"], 0.2, 0.4)   # loaded at 1200 rpm, after the speed step's transient
    assert np.mean(np.hypot(r["i_d_ref"][m], r["i_q_ref"][m])) > 4.0, "I_ref above I_lim"
    assert np.max(r["alpha"][m]) == 0.0


@pytest.mark.parametrize("field, value", [("inverter", "switching"), ("u_on", 1.0), ("r_on", 0.05)])
def test_what_the_averaged_model_lacks_is_a_field_error(field, value):
    with pytest.raises(ConfigError, match=f"converter.{field}"):
        load_scenario("zou2021-region-a", {"converter": {field: value}})


def test_a_five_phase_machine_on_the_matrix_converter_is_a_field_error():
    with pytest.raises(ConfigError, match="converter.kind"):
        load_scenario("yu2022-seq-dyn", {"converter": {"kind": "imc"}})
