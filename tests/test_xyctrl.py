"""x-y current control of the five-phase machine (fs_xyctrl.h): the duty
pattern it adds lies in the x-y plane alone, and closed loop it holds the
third-harmonic current near zero where the open-loop modulator leaves the
magnet's third harmonic and the dead time to drive it."""
import copy

import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.model.machines import catalog_data
from fullspeed.design.scenario import scenario_from_dict
from fullspeed.model.errors import ConfigError
from fullspeed.sim import simulate


def test_duty_pattern_is_pure_x_y():
    duty = ffi.new("float[5]", [0.5, 0.4, 0.6, 0.55, 0.45])
    before = [duty[k] for k in range(5)]
    lib.fs_xyctrl_duties({"alpha": 3.0, "beta": -2.0}, 100.0, duty)
    dv = ffi.new("double[5]", [100.0 * (duty[k] - before[k]) for k in range(5)])
    a, b, x, y = (ffi.new("double *") for _ in range(4))
    lib.fs_inverter_vsd5(dv, a, b, x, y)
    assert (a[0], b[0]) == (pytest.approx(0.0, abs=1e-5), pytest.approx(0.0, abs=1e-5))
    assert (x[0], y[0]) == (pytest.approx(3.0, abs=1e-5), pytest.approx(-2.0, abs=1e-5))
    assert sum(dv[k] for k in range(5)) == pytest.approx(0.0, abs=1e-5)


def run(xy: bool):
    m = copy.deepcopy(catalog_data("yu2022"))
    m["third_harmonic"]["psi_f3"] = 0.01        # 10 % of psi_f: a clear third-harmonic current
    d = {"name": "xy", "duration": 0.4, "machine": m,
         "controller": {"mode": "current", "angle": "encoder", "xy_control": xy},
         "references": {"i_q": 4.0}, "load": {"kind": "speed", "speed_rpm": 300.0}}
    res = simulate(scenario_from_dict(d))
    assert res.stop_reason == "done"
    w = res["t"] > 0.25
    return (float(np.sqrt(np.mean(res["i_d3"][w] ** 2 + res["i_q3"][w] ** 2))),
            float(np.sqrt(np.mean(res["i_d"][w] ** 2 + res["i_q"][w] ** 2))))


def test_closed_loop_holds_the_x_y_current():
    i3_open, i1_open = run(False)
    i3_ctl, i1_ctl = run(True)
    assert i3_open > 0.1 * i1_open              # open loop: a third-harmonic current of >10 % of the fundamental
    assert i3_ctl < 0.2 * i3_open               # held down by the PI pair
    assert i1_ctl == pytest.approx(i1_open, rel=0.05)   # the fundamental untouched


def test_x_y_control_needs_five_phases():
    from conftest import scenario
    d = scenario(controller={"mode": "current", "xy_control": True})
    with pytest.raises(ConfigError, match="xy_control"):
        scenario_from_dict(d)
