"""The rotating injection with the designed defaults through the rated
load's release at standstill (issue 34 item 6; bench/estimators.py case b,
"hfi designed": motulator's 2.2 kW IPMSM, 14 N m released at 3.5 s).

The load the drive does not know reaches the estimate only through the
motion observer: its error, from the error equation of fs_motion_obs.h, is
its designed response to the unknown step, whatever the speed loop does
(the loop's torque is the observer's feed-forward). What could be wrong: an
estimator whose loop gain is not the designed one, so that its poles are
not where the design put them. The negative carrier eq. (26) is divided by
was taken with the fundamental's leak in it (w_b_n / w_h of the rated
current, 1.9 times the designed carrier's 0.16 A): the error was scaled by
about 0.5 and the release lagged 8.85 el.deg, where the observer as
designed lags 4.9 (fs_hfi.c, the amplitude with cfg.leak). With the leak's image
taken out of the amplitude: 4.10 el.deg. One closed-loop run, 4 s
simulated, about 0.05 s.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.design.controller import controller_model, hfi_design, injection_inductances
from fullspeed.design.rules import control_period
from fullspeed.design.scenario import scenario_from_dict
from fullspeed.sim import simulate

from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
est = load_script(ROOT / "bench" / "estimators.py", "bench_estimators_release")

T_RELEASE = 3.5


def designed_step_response(Ts: float, J: float, p: int, w_o: float, w_lag: float, dT: float) -> float:
    """The largest angle error (el. rad) of the injection's motion observer
    (fs_motion_obs_init_lag, the filter twice: the leak removed) after an
    unknown torque step dT on the rotor alone, its error read through the
    SRFF's low-pass as fs_motion_obs.h gives it: the observer's own
    response, without the carrier."""
    obs = ffi.new("fs_motion_obs *")
    cfg = ffi.new("fs_motion_obs_config *", {"Ts": Ts, "J": J, "B": 0.0, "pole_pairs": p, "bandwidth": w_o})
    assert lib.fs_motion_obs_init_lag(obs, cfg, 2, w_lag) == lib.FS_OK
    lib.fs_motion_obs_reset(obs, 0.0, 0.0)
    a, acc = math.exp(-w_lag * Ts), p * dT / J
    b = 1.0 - a
    h = 1.0 - b / 2
    lp1 = lp2 = worst = 0.0
    for k in range(int(10.0 / (w_o * Ts))):
        x = 0.5 * acc * (k * Ts) ** 2 - obs.theta_hat   # the rotor less the angle the heterodyne takes
        eps = (b / 2) ** 2 * x + h * (1 + b / 2) * lp1 - h * lp2
        lp2 = a * lp2 + b * h * (x - lp1)
        lp1 = a * lp1 + b * x
        lib.fs_motion_obs_step(obs, eps, 0.0)
        worst = max(worst, abs(0.5 * acc * ((k + 1) * Ts) ** 2 - obs.theta_hat))
    return worst


def test_designed_injection_holds_the_rated_load_release_at_standstill():
    data = est.designed_data("bench-motulator-2kw-hfi", "hfi")
    sc = scenario_from_dict(data, "test")
    inj = sc.data["injection"]
    assert inj["tracking"] == "lag" and inj["leak"] == "remove"   # the designed estimator
    L_d, L_q = injection_inductances(controller_model(sc.data["controller"], sc.machine))
    Ts = control_period(sc.data)
    hd = hfi_design(inj, Ts, L_d, L_q)
    m = sc.machine
    dT = 14.0   # the scenario's load, released at 3.5 s
    designed = math.degrees(designed_step_response(Ts, m.J, m.pole_pairs, hd.cfg.obs.bandwidth, hd.cfg.w_b_n, dT))
    # the continuous design's figure, 1.965 p dT / (J w^2) at w_o = w_lag = w (5 poles at -w), as a check of the above
    w = hd.cfg.w_b_n
    assert hd.cfg.obs.bandwidth == w
    assert designed == pytest.approx(math.degrees(1.965 * m.pole_pairs * dT / (m.J * w * w)), rel=0.05)

    res = simulate(sc)
    assert res.stop_reason == "done"
    t, e = res["t"], np.degrees(est._wrap(res["theta_err"]))
    release = float(np.abs(e[(t >= T_RELEASE) & (t < T_RELEASE + 0.5)]).max())
    # the estimate lags the release as the observer is designed to, not more (8.85 with the loop gain halved)
    assert release <= 1.1 * designed, (release, designed)
    assert release <= 5.0, release   # issue 34 item 6
    # and the rated load itself held at standstill unbiased (issue 27's 1 el.deg)
    assert abs(e[(t >= 0.8) & (t < 1.0)].mean()) <= 1.0
