"""Heat: the two-node thermal model against its network's steady state, the
plant's R_s and magnet following the temperatures with the currents kept,
the online R_s / psi_f correction on the voltage equation, and the
configuration's refusals."""
import copy
import math

import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.model.errors import ConfigError
from fullspeed.design.scenario import scenario_from_dict
from fullspeed.sim import simulate

from conftest import MACHINE

THERMAL = {"T_ref": 20.0, "T_amb": 40.0, "R_wa": 0.8, "R_wm": 3.0, "R_ma": 4.0, "C_w": 900.0, "C_m": 700.0,
           "k_rotor": 0.1}
IRON = {"P_fe_ref": 20.0, "speed_fe_rpm": 2000.0, "k_hyst": 0.7, "source": "assumed: a test's"}


def thermal_model(**kw):
    cfg = ffi.new("fs_thermal_config *", {"enabled": 1, "T_amb": 40.0, "T_ref": 20.0, "T_w0": 40.0, "T_m0": 40.0,
                                          "R_wa": 0.8, "R_wm": 3.0, "R_ma": 4.0, "C_w": 900.0, "C_m": 700.0,
                                          "alpha_cu": 0.00393, "alpha_br": -0.0012,
                                          "iron": {"P_ref": 20.0, "w_ref": 1000.0, "psi_ref": 1.0, "k_hyst": 0.7,
                                                   "beta": 2.0, "w_band": 1.0},
                                          "k_rotor": 0.1, "time_scale": 1.0, **kw})
    th = ffi.new("fs_thermal *")
    return th, lib.fs_thermal_init(th, cfg)


def test_thermal_settles_at_the_networks_solution():
    """Constant losses: the temperatures settle where the heat flows of the
    two-node network balance, solved here by hand, and rise as the slower
    mode's time constant says."""
    th, st = thermal_model()
    assert st == lib.FS_OK
    P_cu, P_fe = 100.0, 10.0
    for _ in range(3000):   # backward Euler: steps of 100 s stay stable, and settle exactly
        lib.fs_thermal_step(th, P_cu, P_fe, 100.0)
    # (T_w - T_a)/R_wa + (T_w - T_m)/R_wm = P_cu + 0.9 P_fe;  (T_m - T_a)/R_ma - (T_w - T_m)/R_wm = 0.1 P_fe
    G = np.array([[1 / 0.8 + 1 / 3.0, -1 / 3.0], [-1 / 3.0, 1 / 4.0 + 1 / 3.0]])
    dT = np.linalg.solve(G, [P_cu + 0.9 * P_fe, 0.1 * P_fe])
    assert th.T_w == pytest.approx(40.0 + dT[0], rel=1e-9)
    assert th.T_m == pytest.approx(40.0 + dT[1], rel=1e-9)
    assert lib.fs_thermal_r_factor(th) == pytest.approx(1 + 0.00393 * (th.T_w - 20.0))
    assert lib.fs_thermal_magnet_factor(th) == pytest.approx(1 - 0.0012 * (th.T_m - 20.0))


def test_time_scale_speeds_the_heating_not_its_end():
    """The capacities divided by the scale: the same temperature after 1/scale
    of the time, and the same end."""
    slow, _ = thermal_model()
    fast, _ = thermal_model(time_scale=50.0)
    for _ in range(500):
        lib.fs_thermal_step(slow, 100.0, 0.0, 1.0)
        lib.fs_thermal_step(fast, 100.0, 0.0, 1.0 / 50.0)
    assert fast.T_w == pytest.approx(slow.T_w, rel=1e-12)
    assert slow.T_w > 60.0   # it did heat


def test_iron_loss_splits_hysteresis_and_eddy():
    th, _ = thermal_model()
    fe = ffi.addressof(th.cfg, "iron")
    assert lib.fs_iron_loss(fe, 1000.0, 1.0) == pytest.approx(20.0)
    assert lib.fs_iron_loss(fe, -500.0, 1.0) == pytest.approx(20.0 * (0.7 * 0.5 + 0.3 * 0.25))
    assert lib.fs_iron_loss(fe, 1000.0, 0.5) == pytest.approx(5.0)
    # a hysteresis exponent other than 2 acts on the hysteresis part alone
    fe.beta = 1.6
    assert lib.fs_iron_loss(fe, 500.0, 0.5) == pytest.approx(20.0 * (0.7 * 0.5 * 0.5 ** 1.6 + 0.3 * 0.25 * 0.25))


@pytest.mark.parametrize("field,value", [("R_wa", 0.0), ("C_m", -1.0), ("time_scale", 0.5), ("k_rotor", 1.5),
                                         ("alpha_cu", 0.2), ("alpha_br", -0.01), ("T_w0", math.nan)])
def test_thermal_refuses_bad_fields(field, value):
    _, st = thermal_model(**{field: value})
    assert st == lib.FS_ERR_PARAM


def heated(model="linear", **thermal):
    m = copy.deepcopy(MACHINE)
    m["thermal"] = dict(THERMAL)
    m["losses"] = dict(IRON)
    if model == "algebraic":
        m["magnetic"] = {"model": "algebraic", "a_dd": 1.3e23, "S": 10.0, "a_dq": 9.6e14, "U": 2.0, "V": 1.0}
    return {"name": "heat", "duration": 0.3, "machine": m,
            "controller": {"mode": "current", "angle": "encoder"},
            "references": {"i_q": [[0.0, 0.0], [0.02, 50.0]], "i_d": -10.0},
            "load": {"kind": "speed", "speed_rpm": 300.0},
            "thermal": {"enabled": True, "time_scale": 2000.0, **thermal}}


@pytest.mark.parametrize("model", ["linear", "algebraic"])
def test_plant_parameters_follow_the_temperatures(model):
    """R_s and the magnet follow the traced temperatures; the winding is
    heated by the plant's own copper loss; the currents do not jump when the
    magnet's flux is moved (the states move with it)."""
    res = simulate(scenario_from_dict(heated(model, T_winding0=20.0, T_magnet0=20.0, T_amb=20.0)))
    assert res.stop_reason == "done"
    T_w, T_m = res["T_winding"], res["T_magnet"]
    assert T_w[-1] > T_w[0] + 30.0 and T_m[-1] > T_m[0] + 1.0
    assert np.allclose(res["R_s_true"], 0.036 * (1 + 0.00393 * (T_w - 20.0)), rtol=1e-9)
    k = 1 - 0.0012 * (T_m - 20.0)
    psi = res["psi_f_true"]
    if model == "linear":
        assert np.allclose(psi, 0.007 * k, rtol=2e-6)   # updated when the factor moves by 1e-6
    else:   # the magnet's equivalent current scales; where the iron saturates the flux falls less
        assert np.all(np.diff(psi) <= 1e-12) and 0.0 < 1 - psi[-1] / 0.007 <= 1 - k[-1] + 1e-6
    # the currents stay continuous while the flux states are moved
    t = res["t"]
    m = t > 0.1
    assert np.max(np.abs(np.diff(res["i_q"][m]))) < 1.0
    # the winding's first step: C_w/scale dT/dt = copper loss (+ iron) at the start of the heating
    P_cu = 1.5 * res["R_s_true"] * (res["i_d"] ** 2 + res["i_q"] ** 2)
    k0 = np.searchsorted(t, 0.1)
    dTdt = (T_w[k0 + 50] - T_w[k0 - 50]) / (t[k0 + 50] - t[k0 - 50])
    flow = (T_w[k0] - 20.0) / 0.8 + (T_w[k0] - T_m[k0]) / 3.0
    assert 900.0 / 2000.0 * dTdt == pytest.approx(P_cu[k0] - flow, rel=0.05, abs=2.0)


def test_thermal_off_leaves_the_parameters():
    d = heated()
    d["thermal"] = {"enabled": False}
    res = simulate(scenario_from_dict(d))
    assert np.all(res["R_s_true"] == 0.036) and np.all(res["psi_f_true"] == 0.007)
    assert np.all(res["T_winding"] == 0.0)


def test_thermal_config_errors():
    d = heated()
    del d["machine"]["thermal"]
    with pytest.raises(ConfigError, match="thermal.enabled"):
        scenario_from_dict(d)
    d = heated()
    d["machine"]["thermal"]["R_wa"] = 0.0
    with pytest.raises(ConfigError, match="R_wa"):
        scenario_from_dict(d)
    d = heated()
    d["thermal"]["time_scale"] = 0.5
    with pytest.raises(ConfigError, match="time_scale"):
        scenario_from_dict(d)
    d = heated()   # the iron loss is the machine's [losses], not the thermal model's
    d["machine"]["thermal"]["P_fe_ref"] = 20.0
    with pytest.raises(ConfigError, match="now called machine.losses.P_fe_ref"):
        scenario_from_dict(d)


def adapt(**kw):
    cfg = ffi.new("fs_param_adapt_config *", {"Ts": 1e-4, "R_s": 0.036, "L_d": 65e-6, "psi_f": 0.007,
                                              "i_max": 60.0, "w_e_max": 1500.0, "T_f": 2.0, **kw})
    a = ffi.new("fs_param_adapt *")
    assert lib.fs_param_adapt_init(a, cfg) == lib.FS_OK
    return a


def feed(a, R, psi, points, seconds, learn=True, L_d=65e-6):
    """Steady operating points (i_d, i_q, w_e), each held in turn for 0.5 s."""
    n = int(0.5 / 1e-4)
    for _ in range(int(seconds / 0.5 / len(points))):
        for i_d, i_q, w in points:
            u = {"d": R * i_d - w * 90e-6 * i_q, "q": R * i_q + w * (L_d * i_d + psi)}
            for _ in range(n):
                lib.fs_param_adapt_step(a, u, {"d": i_d, "q": i_q}, w, learn)


def test_adapt_finds_R_and_psi_over_two_operating_points():
    """Hot machine (R +50 %, psi_f -8 %) at 100 and 600 rpm under load: both
    found; at one operating point (one equation, two unknowns) the nominal
    values are held; not learning, nothing moves."""
    hot = (0.054, 0.00644)
    a = adapt()
    feed(a, *hot, [(-2.0, 40.0, 52.0), (-5.0, 40.0, 314.0)], 8.0)
    assert a.R_s == pytest.approx(hot[0], rel=2e-3) and a.psi_f == pytest.approx(hot[1], rel=2e-3)
    one = adapt()
    feed(one, *hot, [(-2.0, 40.0, 314.0)], 4.0)
    assert (one.R_s, one.psi_f) == (pytest.approx(0.036), pytest.approx(0.007)) and one.sep < 0.05
    early = adapt()   # the window (T_f = 2 s) not yet filled: the start alone does not decide
    feed(early, *hot, [(-2.0, 40.0, 52.0), (-5.0, 40.0, 314.0)], 1.0)
    assert (early.R_s, early.psi_f) == (pytest.approx(0.036), pytest.approx(0.007))
    idle = adapt()
    feed(idle, *hot, [(-2.0, 40.0, 52.0), (-5.0, 40.0, 314.0)], 4.0, learn=False)
    assert (idle.R_s, idle.psi_f) == (pytest.approx(0.036), pytest.approx(0.007))


def test_adapt_refuses_bad_config():
    a = ffi.new("fs_param_adapt *")
    base = {"Ts": 1e-4, "R_s": 0.036, "L_d": 65e-6, "psi_f": 0.007, "i_max": 60.0, "w_e_max": 1500.0, "T_f": 2.0}
    for field, value, st in (("T_f", 0.0, lib.FS_ERR_PARAM), ("T_f", 0.01, lib.FS_ERR_PARAM),
                             ("psi_f", 0.0, lib.FS_ERR_PSI_F), ("i_max", 0.0, lib.FS_ERR_LIMIT),
                             ("min_sep", 1.0, lib.FS_ERR_PARAM), ("Ts", 0.0, lib.FS_ERR_TS)):
        cfg = ffi.new("fs_param_adapt_config *", {**base, field: value})
        assert lib.fs_param_adapt_init(a, cfg) == st, field
    assert lib.fs_param_adapt_init(ffi.NULL, ffi.new("fs_param_adapt_config *", base)) == lib.FS_ERR_NULL


def test_hfi_takes_a_new_resistance_as_if_designed_with_it():
    """fs_hfi_set_resistance gives the carrier phase and amplitude init gives
    for that resistance, and a hotter winding turns the reference."""
    base = {"Ts": 1e-4, "delay": 1.0, "u_h": 5.0, "w_h": 2 * math.pi * 1000, "R_s": 0.036, "L_d": 65e-6, "L_q": 90e-6,
            "obs": {"J": 1.87e-3, "pole_pairs": 5}}
    cold, hot = ffi.new("fs_hfi *"), ffi.new("fs_hfi *")
    assert lib.fs_hfi_init(cold, ffi.new("fs_hfi_config *", base)) == lib.FS_OK
    assert lib.fs_hfi_init(hot, ffi.new("fs_hfi_config *", {**base, "R_s": 0.054})) == lib.FS_OK
    assert abs(hot.phi_ref - cold.phi_ref) > 0.02
    lib.fs_hfi_set_resistance(cold, 0.054)
    assert (cold.phi_ref, cold.i_n_design, cold.cfg.R_s) == (hot.phi_ref, hot.i_n_design, pytest.approx(0.054))
    lib.fs_hfi_set_resistance(cold, -1.0)   # ignored
    assert cold.phi_ref == hot.phi_ref
