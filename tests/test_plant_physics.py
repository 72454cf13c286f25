"""The plant against physics: phasor steady state, power balance, the
designed current-loop bandwidth, averaged vs switching inverter."""
import math

import numpy as np
import pytest

from fullspeed.design.scenario import scenario_from_dict
from fullspeed.sim import simulate
from fullspeed.model.units import rpm_to_rad_s

from conftest import MACHINE


def run(d):
    return simulate(scenario_from_dict(d))


def window(res, t0, t1, name):
    t = res["t"]
    m = (t >= t0) & (t <= t1)
    return res[name][m]


def ideal_converter(inverter):
    return {"inverter": inverter, "t_dead": 0.0, "u_on": 0.0}


@pytest.mark.parametrize("inverter,r_on", [("averaged", 0.0), ("switching", 0.0), ("averaged", 0.02),
                                           ("switching", 0.02)])
def test_steady_state_equals_phasor_solution(make_scenario, inverter, r_on):
    """Open-loop dq voltage at a held speed: the mean currents equal the
    solution of u_d = R i_d - w L_q i_q, u_q = R i_q + w (L_d i_d + psi_f);
    the devices' on-state resistance r_on (their drop r_on i in every phase)
    adds to R."""
    n = 600.0
    u_d, u_q = -1.2, 3.0
    d = make_scenario(
        duration=0.3, converter={**ideal_converter(inverter), "r_on": r_on},
        sensors={"adc_bits": 0, "encoder_bits": 0},
        controller={"mode": "voltage", "dead_time_comp": False},
        references={"u_d": u_d, "u_q": u_q, "frame_rpm": n},
        load={"kind": "speed", "speed_rpm": n},
    )
    res = run(d)
    e = MACHINE["electrical"]
    w = MACHINE["pole_pairs"] * rpm_to_rad_s(n)
    R = e["R_s"] + r_on
    A = np.array([[R, -w * e["L_q"]], [w * e["L_d"], R]])
    i_d, i_q = np.linalg.solve(A, [u_d, u_q - w * e["psi_f"]])
    # the open-loop frame and the rotor both start at 0 and turn at w
    m_d = window(res, 0.2, 0.3, "i_d").mean()
    m_q = window(res, 0.2, 0.3, "i_q").mean()
    mag = math.hypot(i_d, i_q)
    assert mag > 5.0  # a meaningful operating point
    assert abs(m_d - i_d) < 0.005 * mag, (m_d, i_d)
    assert abs(m_q - i_q) < 0.005 * mag, (m_q, i_q)


@pytest.mark.parametrize("model", ["linear", "algebraic"])
def test_power_balance(make_scenario, model):
    """Terminal energy = copper loss + air-gap work + change of magnetic
    energy, and air-gap work = kinetic energy on a free, frictionless shaft,
    through a switching-inverter acceleration."""
    mag = {"model": model}
    if model == "algebraic":  # strong self- and cross-saturation
        mag.update(a_dd=2e8, S=4.0, a_qq=5e8, T=4.0, a_dq=1e9, U=1.0, V=1.0)
    d = make_scenario(duration=0.15, controller={"mode": "speed"},
                      references={"speed_rpm": [[0, 0], [0.01, 0], [0.01, 800]]})
    d["machine"]["magnetic"] = mag
    res = run(d)
    E_in = res["E_in"][-1] - res["E_in"][0]
    E_cu = res["E_cu"][-1] - res["E_cu"][0]
    E_ag = res["E_airgap"][-1] - res["E_airgap"][0]
    dW = res["W_mag"][-1] - res["W_mag"][0]
    assert E_in > 1.0
    assert abs(E_in - (E_cu + E_ag + dW)) < 0.01 * E_in
    J = MACHINE["mechanical"]["J"]
    KE = 0.5 * J * (res["w_m"][-1] ** 2 - res["w_m"][0] ** 2)
    assert abs(E_ag - KE) < 0.01 * E_ag


def fit_bandwidth(t, y, delay):
    """Least-squares bandwidth of y = 1 - exp(-a (t - delay)), t > delay."""
    grid = np.linspace(100.0, 20000.0, 19901)
    tt = np.clip(t - delay, 0.0, None)
    err = [np.sum((y - (1 - np.exp(-a * tt))) ** 2) for a in grid]
    return grid[int(np.argmin(err))]


@pytest.mark.parametrize("alpha", [1000.0, 3000.0])
def test_current_step_matches_designed_bandwidth(make_scenario, alpha):
    """An i_q step: first-order response with the designed bandwidth, after
    the one period of computation delay (switching inverter, dead time and
    its compensation on, as on the bench)."""
    Ts, step, t_step = 1e-4, 10.0, 0.02
    d = make_scenario(
        duration=0.03, converter={"inverter": "switching"},
        sensors={"adc_bits": 0, "encoder_bits": 0},
        controller={"mode": "current", "angle": "true", "bw_current": alpha},
        references={"i_d": -5.0, "i_q": [[0, 0], [t_step, 0], [t_step, step]]},
        load={"kind": "speed", "speed_rpm": 0.0},
    )
    res = run(d)
    t = res["t"] - t_step
    m = t >= 0
    y = res["i_q"][m] / step
    a_fit = fit_bandwidth(t[m], y, Ts)
    assert abs(a_fit - alpha) < 0.1 * alpha, a_fit
    assert abs(y[t[m] > 0.008].mean() - 1.0) < 0.01


def test_averaged_and_switching_give_same_mean_currents(make_scenario):
    """With dead time: open-loop voltage at a held speed, both inverter
    models give the same mean currents within 2 %."""
    n = 800.0
    out = {}
    for inv in ("averaged", "switching"):
        d = make_scenario(
            duration=0.25, converter={"inverter": inv, "t_dead": 1e-6},
            controller={"mode": "voltage", "dead_time_comp": False},
            references={"u_d": -1.0, "u_q": 3.5, "frame_rpm": n},
            load={"kind": "speed", "speed_rpm": n},
        )
        res = run(d)
        out[inv] = np.array([window(res, 0.15, 0.25, k).mean() for k in ("i_d", "i_q")])
    mag = np.hypot(*out["switching"])
    assert mag > 5.0
    assert np.all(np.abs(out["averaged"] - out["switching"]) < 0.02 * mag), out


def test_double_sampling_halves_the_delay(make_scenario):
    """DSDU: sampling and update at peak and valley; the step response starts
    one half carrier period after the reference step, with the same bandwidth."""
    alpha, step, t_step = 3000.0, 10.0, 0.02
    d = make_scenario(
        duration=0.03, timing={"sampling": "double"}, converter={"inverter": "switching"},
        sensors={"adc_bits": 0, "encoder_bits": 0},
        controller={"mode": "current", "angle": "true", "bw_current": alpha},
        references={"i_q": [[0, 0], [t_step, 0], [t_step, step]]},
        load={"kind": "speed", "speed_rpm": 0.0},
    )
    res = run(d)
    t = res["t"] - t_step
    assert np.allclose(np.diff(res["t"]), 0.5e-4)  # samples every half period
    m = t >= 0
    y = res["i_q"][m] / step
    assert y[1] == pytest.approx(0.0, abs=0.01)  # one control period of delay
    assert y[2] > 0.05
    assert abs(fit_bandwidth(t[m], y, 0.5e-4) - alpha) < 0.1 * alpha


def test_overcurrent_stops_with_reason_and_time_and_keeps_traces(make_scenario):
    d = make_scenario(duration=0.2, controller={"mode": "voltage"},
                      references={"u_q": [[0, 0], [0.05, 0], [0.05, 6.0]], "frame_rpm": 0.0},
                      load={"kind": "speed", "speed_rpm": 0.0})
    res = run(d)
    assert res.stop_reason == "overcurrent"
    assert 0.05 < res.stop_time < 0.2
    assert res["t"][-1] <= res.stop_time
    assert res["t"].size > 400  # what was computed before the stop is kept
    assert np.max(np.abs(res["i_a"])) < 90.0 * 1.5  # tripped near the 90 A level


@pytest.mark.parametrize("model", ["linear", "algebraic"])
def test_power_balance_with_spatial_harmonics(make_scenario, model):
    """The flux depends on the rotor angle (back-EMF harmonics 5..13,
    saliency harmonics, cogging): the torque from the co-energy with its
    angle derivative keeps terminal energy = copper loss + air-gap work +
    change of stored energy at every sample of an acceleration, while the
    angle-dependent energy exchanged is far larger than the tolerance."""
    d = make_scenario(duration=0.15, controller={"mode": "speed"},
                      references={"speed_rpm": [[0, 0], [0.01, 0], [0.01, 800]]},
                      harmonics={"enabled": True})
    d["machine"]["harmonics"] = {"emf5": 0.1, "emf7": -0.05, "emf11": 0.03, "emf13": 0.02,
                                 "sal6_dd": 0.1, "sal6_qq": -0.08, "sal6_dq": 0.05, "sal12_dd": 0.03,
                                 "cogging_Nm": 0.1, "cogging_order": 12}
    if model == "algebraic":
        d["machine"]["magnetic"] = {"model": "algebraic", "a_dd": 2e8, "S": 4.0, "a_qq": 5e8, "T": 4.0,
                                    "a_dq": 1e9, "U": 1.0, "V": 1.0}
    res = run(d)
    assert res.stop_reason == "done"
    E_in = res["E_in"] - res["E_in"][0]
    E_bal = (res["E_cu"] - res["E_cu"][0]) + (res["E_airgap"] - res["E_airgap"][0]) + (res["W_mag"] - res["W_mag"][0])
    assert E_in[-1] > 1.0
    assert np.max(np.abs(E_in - E_bal)) < 1e-3 * E_in[-1]
    # the angle's share is not negligible: the torque ripples at the harmonics' orders
    t = res["t"]
    m = t > 0.1
    assert np.ptp(res["T_e"][m]) > 0.2
    # and the stored energy swings with the angle by far more than the tolerance
    assert np.ptp(np.diff(res["W_mag"][m])) > 10 * 1e-3 * E_in[-1] / m.sum()


def test_harmonic_back_emf_matches_the_table():
    """At zero current phase a's flux linkage has the table's harmonics:
    E_n / E_1 = n psi_n / psi_1 at orders 5, 7, 11, 13 (signed, in phase at
    theta = 0), through the plant's own flux at rest."""
    from fullspeed._core import ffi, lib

    table = {5: 0.04, 7: -0.02, 11: 0.01, 13: 0.008}
    psi_f, p = 0.007, 5
    cfg = ffi.new("fs_pmsm_config *", {"pole_pairs": p, "R_s": 0.036, "J": 1e-3, "phases": 3,
                                       "mag": {"kind": lib.FS_MAG_LINEAR, "L_d": 65e-6, "L_q": 90e-6, "psi_f": psi_f},
                                       "psi_h": [table[n] * psi_f / n for n in (5, 7, 11, 13)],
                                       "sal6": [0.1, -0.05, 0.02]})   # saliency harmonics act with current only
    m = ffi.new("fs_pmsm *")
    assert lib.fs_pmsm_init(m, cfg) == lib.FS_OK and m.harm
    x = ffi.new("double[]", lib.FS_X_N)
    th = np.linspace(0.0, 2 * np.pi, 720, endpoint=False)
    psi_a = []
    for t in th:
        x[lib.FS_X_THETA_M] = t / p
        lib.fs_pmsm_rest_flux(m, x)
        i_d, i_q = ffi.new("double *"), ffi.new("double *")
        lib.fs_pmsm_current_dq(m, x, np.cos(t), np.sin(t), i_d, i_q)
        assert abs(i_d[0]) < 1e-9 and abs(i_q[0]) < 1e-9
        psi_a.append(x[lib.FS_X_PSI_D] * np.cos(t) - x[lib.FS_X_PSI_Q] * np.sin(t))
    psi_a = np.array(psi_a)
    c1 = 2 * np.mean(psi_a * np.cos(th))
    assert c1 == pytest.approx(psi_f, rel=1e-9)
    for n, ratio in table.items():
        assert n * 2 * np.mean(psi_a * np.cos(n * th)) / c1 == pytest.approx(ratio, rel=1e-9), n
        assert abs(np.mean(psi_a * np.sin(n * th))) < 1e-12
