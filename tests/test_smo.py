"""The extended-EMF sliding-mode observer (yang2022 sec. 2) in closed loop."""
import math

import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.model.errors import ConfigError
from fullspeed.sim.metrics import window_mask
from fullspeed.design.scenario import load_scenario
from fullspeed.sim import simulate


def smo_config(**kw):
    c = dict(Ts=1e-4, R_s=0.036, L_d=0.065e-3, L_q=0.09e-3, psi_f=0.007, w_e_max=1570.0, i_max=60.0,
             k=0.0, margin=1.5, delta=0.0, w_c_min=10.0, bw_pll=250.0, w_valid=50.0, lag=lib.FS_SMO_LAG_EXACT)
    c.update(kw)
    return ffi.new("fs_smo_config *", c)


def test_gain_bound_of_eq18():
    smo = ffi.new("fs_smo *")
    assert lib.fs_smo_init(smo, smo_config()) == lib.FS_OK
    # eq. (18) for the top speed and current: k > max|e| / 2
    bound = 0.5 * 1570.0 * (0.007 + 0.025e-3 * 60.0)
    assert smo.k_bound == pytest.approx(bound, rel=1e-5)
    assert smo.k == pytest.approx(1.5 * bound, rel=1e-5)
    # the boundary layer keeps the discrete correction at most deadbeat
    assert smo.delta >= smo.k * 1e-4 / 0.065e-3 * (1 - 1e-6)
    assert lib.fs_smo_init(smo, smo_config(k=0.9 * bound)) == lib.FS_ERR_SMO_GAIN
    assert lib.fs_smo_init(smo, smo_config(k=1.1 * bound)) == lib.FS_OK


def test_gain_below_bound_is_a_field_error():
    with pytest.raises(ConfigError) as e:
        simulate(load_scenario("yang2022-smo-steady-400rpm", {"observer": {"k": 1.0}}))
    assert "observer.k" in str(e.value) and "eq. (18)" in str(e.value)


def test_converges_from_90_degrees_within_pll_time():
    """Encoder-driven current control at 400 rpm; the observer starts 90 el.deg
    and 400 rpm off (angle 0, speed 0). A critically damped PLL with both
    poles at w_b settles a step within about 6.6 / w_b (1 %); allowing for the
    speed it must also acquire and the filter's start-up, 10 / w_b."""
    sc = load_scenario("yang2022-smo-steady-400rpm", {
        "duration": 0.3, "observer": {"handover": 0.3}, "initial": {"theta_e_deg": 90.0, "speed_rpm": 400.0},
        "load": {"kind": "speed"}, "metrics": {"steady": [0.2, 0.3]}})
    res = simulate(sc)
    w_b = sc.data["observer"]["bw_pll"]
    err = np.degrees(res["est_err"])
    assert abs(err[0]) > 80.0  # it did start 90 el.deg off
    t_conv = 10.0 / w_b
    after = window_mask(res["t"], t_conv, 0.3)
    assert np.max(np.abs(err[after])) < 5.0
    # and not much earlier: the bound is the PLL's, not slack
    early = window_mask(res["t"], 0.0, 2.0 / w_b)
    assert np.max(np.abs(err[early])) > 20.0


@pytest.mark.parametrize("lag, expect_small", [("exact", True), ("paper", False)])
def test_lag_compensation(lag, expect_small):
    """With e_hat fed back as in eq. (4), compensating pi/4 leaves a bias of
    pi/4 - atan(1/2) = 18.4 el.deg; compensating the structure's lag does not."""
    res = simulate(load_scenario("yang2022-smo-steady-400rpm", {"observer": {"lag": lag}, "duration": 0.8, "metrics": {"steady": [0.5, 0.8]}}))
    m = window_mask(res["t"], 0.5, 0.8)
    mean = float(np.degrees(np.mean(res["est_err"][m])))
    if expect_small:
        assert abs(mean) < 3.0
    else:
        assert mean == pytest.approx(-math.degrees(math.pi / 4 - math.atan(0.5)), abs=3.0)


def test_sensorless_speed_control_holds_800rpm_with_rated_torque():
    sc = load_scenario("yang2022-smo-ramp", {
        "duration": 1.6, "observer": {"handover": 0.4},
        "references": {"speed_rpm": [[0.0, 0.0], [0.3, 800.0]]},
        "load": {"torque": [[0.0, 0.1], [0.8, 0.1], [0.8, 2.0]]},
        "metrics": {"steady": [1.2, 1.6]}})
    res = simulate(sc)
    assert res.stop_reason == "done"
    assert abs(res.metrics["speed_error_pct"]) < 0.5
    assert res.metrics["T_e_mean"] > 2.0
    m = window_mask(res["t"], 0.4, 1.6)
    assert np.max(np.abs(np.degrees(res["est_err"][m]))) < 10.0
    assert np.all(res["est_valid"][m] == 1.0)
