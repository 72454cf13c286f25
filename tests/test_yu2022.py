"""yu2022 in the closed loop: the filterless extraction's amplitude, the
optimized sequence's lead, the powder brake, the five-phase torque, the
square-wave scenario fields' errors, and the square wave on the three-phase
yang2022 machine (B-SWVI-3PH)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fullspeed.workflows.calibrate import xsat_table
from fullspeed.model.errors import ConfigError
from fullspeed.sim.metrics import window_mask
from fullspeed.design.scenario import load_scenario, scenario_from_dict
from fullspeed.model.scenario import xcomp_table
from fullspeed.sim import simulate
from fullspeed.model.units import rpm_to_rad_s

TS = 125e-6


def _held(rpm: float, sequence: str, **extra) -> dict:
    """Current control at i_q = 0, the estimator closing the loops, the speed
    ramped up by the load machine in 0.2 s and held (sec. 4.1's simulation:
    no dead time)."""
    return {"name": "t", "duration": 0.8, "machine": "yu2022",
            "converter": {"t_dead": 0.0},
            "controller": {"mode": "current", "angle": "swvi", "gains": "paper"},
            "injection": {"sequence": sequence},
            "load": {"kind": "speed", "speed_rpm": [[0.0, 0.0], [0.2, rpm]]}, **extra}


def test_filterless_extraction_returns_the_amplitude_of_eq5():
    res = simulate("yu2022-filterless-idstep")       # the encoder in the loop, estimator alongside
    m = machine = res.scenario.machine
    t = res["t"]
    fresh = window_mask(t, 0.1, 0.2) & (np.arange(t.size) % 2 == 0)
    amp = float(np.mean(res["i_hf_d"][fresh]))
    want = machine.extra["injection"]["u_h"] * TS / m.L_d     # eq. (5) at theta_err = 0, T_h = 4 Ts
    assert amp == pytest.approx(want, rel=0.02)
    assert abs(float(np.mean(res["i_hf_q"][fresh]))) < 0.02 * want


@pytest.mark.parametrize("rpm", [150.0, 300.0])
def test_optimized_sequence_leads_by_one_and_a_half_periods(rpm):
    res = simulate(scenario_from_dict(_held(rpm, "optimized")))
    w_e = res.scenario.machine.pole_pairs * rpm_to_rad_s(rpm)
    err = float(np.mean(res["est_err"][window_mask(res["t"], 0.5, 0.8)]))
    assert err == pytest.approx(-1.5 * w_e * TS, rel=0.3)     # eq. (18)


def test_conventional_sequence_lags_by_the_common_mode_leak():
    """(L_Sigma / (4 L_dif) - 1.25) w_e Ts (fs_swvi.h), in speed control at 300 rpm."""
    res = simulate(load_scenario("yu2022-seq-ss-300rpm", {"injection": {"sequence": "conventional"},
                                                          "converter": {"t_dead": 0.0}}))
    m = res.scenario.machine
    w_e = m.pole_pairs * rpm_to_rad_s(300.0)
    lag = ((m.L_d + m.L_q) / (4 * (m.L_q - m.L_d)) - 1.25) * w_e * TS
    assert float(np.mean(res["est_err"][window_mask(res["t"], 1.0, 1.6)])) == pytest.approx(lag, rel=0.3)


def test_five_phase_torque_is_five_halves_p_psi_iq():
    sc = scenario_from_dict({"name": "t", "duration": 0.3, "machine": "yu2022",
                             "controller": {"mode": "current", "angle": "encoder"},
                             "references": {"i_q": 4.0}, "load": {"kind": "speed", "speed_rpm": 100.0},
                             "initial": {"speed_rpm": 100.0}})
    res = simulate(sc)
    m = sc.machine
    T = float(np.mean(res["T_e"][window_mask(res["t"], 0.2, 0.3)]))
    assert T == pytest.approx(2.5 * m.pole_pairs * m.psi_f * 4.0, rel=0.02)


def test_powder_brake_stops_the_rotor_and_holds_it():
    """A 2 N m brake on a free-running rotor: the speed falls at (T_b + friction) / J
    until it sticks, then stays at zero."""
    sc = scenario_from_dict({"name": "t", "duration": 0.6, "machine": "yu2022",   # zero current: no torque
                             "controller": {"mode": "current", "angle": "encoder"},
                             "load": {"kind": "brake", "torque": 2.0}, "initial": {"speed_rpm": 100.0}})
    res = simulate(sc)
    m = sc.machine
    w0 = rpm_to_rad_s(100.0)
    t_stop = m.J * w0 / (2.0 + m.T_coulomb + m.B * w0 / 2)   # friction's viscous part at the mean speed
    t, w = res["t"], res["w_m"]
    stopped = t[np.argmax(w < 0.01)]
    assert stopped == pytest.approx(t_stop, rel=0.05)
    assert np.all(np.abs(w[t > stopped + 0.01]) < 0.011)
    assert np.all(res["T_L"][t < stopped - 0.01] == pytest.approx(2.0))


def test_square_wave_fields_are_checked():
    with pytest.raises(ConfigError, match=r"injection\.f_h.*1 / \(4 Ts\) = 2000 Hz"):
        load_scenario("yu2022-seq-dyn", {"injection": {"f_h": 1000.0}})
    with pytest.raises(ConfigError, match=r"controller\.mode"):
        load_scenario("yu2022-seq-dyn", {"controller": {"mode": "voltage"}})
    with pytest.raises(ConfigError, match=r"injection\.xcomp.*xcomp_paper"):
        scenario_from_dict({"name": "t", "duration": 1.0, "machine": "yang2022", "timing": {"sampling": "double"},
                                "controller": {"mode": "speed", "angle": "swvi"},
                            "injection": {"u_h": 2.0, "f_h": 5000.0, "bw_pll": 100.0, "xcomp": "paper"}})


def test_paper_gains_are_the_papers():
    sc = load_scenario("yu2022-seq-dyn")
    g, m = sc.data["controller"]["paper_gains"], sc.machine
    assert (g["k_p_d"], g["k_i_d"], g["k_p_q"], g["k_i_q"]) == (16.2, 77.0, 18.8, 66.0)
    assert g["k_p_w"] == pytest.approx(0.07 * 2.5 * m.pole_pairs * m.psi_f)
    assert math.isclose(sc.data["injection"]["bw_pll"] ** 2, 3306.0, rel_tol=1e-3)   # K_i = w_b^2


def test_square_wave_on_three_phases_sees_the_same_saliency_shift():
    """On the yang2022 machine the square wave's carrier has eq. (5)'s
    amplitude u_h Ts / L_d at no load, and the calibrated error turns with i_q
    as the rotating carrier's does (the machine's cross-saturation, not the
    estimator): within 0 +- 1 el.deg at no load and 10..30 at 25 A."""
    res = simulate("beyond-swvi-3ph-100rpm")
    m, inj = res.scenario.machine, res.scenario.data["injection"]
    Ts = 1.0 / res.scenario.data["converter"]["f_pwm"]
    no_load = window_mask(res["t"], 0.1, 0.2)
    assert float(np.mean(np.abs(res["i_hf_d"][no_load]))) == pytest.approx(inj["u_h"] * Ts / m.L_d, rel=0.05)
    fresh, _ = xsat_table("beyond-swvi-3ph-100rpm", i_q_max=60.0)
    shipped = xcomp_table("yang2022-swvi-xsat", None)
    assert np.max(np.abs(np.subtract(fresh["delta_deg"], shipped["delta_deg"]))) < 0.5
    d = dict(zip(fresh["i_q"], fresh["delta_deg"]))
    assert abs(d[0.0]) < 1.0 and 10.0 < d[22.5] < 30.0 and d[-22.5] == pytest.approx(-d[22.5], abs=2.0)


def test_square_wave_on_three_phases_carries_rated_load_from_standstill():
    """B-SWVI-3PH: the rotor 50 el.deg from the estimate, rated load taken on
    at standstill, 0 -> 200 -> 0 rpm under it; compensated, the error stays
    below 10 el.deg, without the table it does not."""
    comp = simulate("beyond-swvi-3ph")
    plain = simulate(load_scenario("beyond-swvi-3ph", {"injection": {"xcomp": False}}))
    t = comp["t"]
    assert comp.stop_reason == "done"
    assert np.max(np.abs(np.degrees(comp["est_err"][t >= 0.1]))) < 10.0
    top, end = window_mask(t, 1.6, 2.0), window_mask(t, 3.2, 3.5)
    assert float(np.mean(comp["w_m"][top])) == pytest.approx(rpm_to_rad_s(200.0), rel=0.02)
    assert abs(float(np.mean(comp["w_m"][end]))) < rpm_to_rad_s(5.0)   # held at standstill under the load
    assert np.max(np.abs(np.degrees(plain["est_err"][plain["t"] >= 0.1]))) > 15.0
