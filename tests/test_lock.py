"""Loss of lock: the monitor (fs_lock.h), its residuals in the drive, and the
runner's stop reason."""
import math

import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.errors import ConfigError
from fullspeed.scenario import load_scenario
from fullspeed.sim import build_config, simulate

SS = "yang2022-smo-steady-400rpm"      # current mode on the SMO, speed held by the load machine
HANDOVER = 0.2


def monitor(Ts=1e-3, t_lost=0.01):
    lk = ffi.new("fs_lock *")
    assert lib.fs_lock_init(lk, ffi.new("fs_lock_config *", {"Ts": Ts, "t_lost": t_lost})) == lib.FS_OK
    return lk


def test_monitor_latches_after_the_net_time_off_track_and_resets():
    lk = monitor()
    # 9 ms above, 5 ms below, 5 ms above: the net time is 9 - 5 + 5 = 9 ms < 10 ms
    seq = [2.0] * 9 + [0.5] * 5 + [2.0] * 5
    assert not any(lib.fs_lock_step(lk, r) for r in seq)
    assert lib.fs_lock_step(lk, 2.0)                # the 10th net millisecond
    assert lib.fs_lock_step(lk, 0.0)                # latched
    lib.fs_lock_reset(lk)
    assert not lib.fs_lock_step(lk, 0.0)


def test_monitor_counts_nan_as_off_track_and_refuses_bad_configs():
    lk = monitor(t_lost=0.003)
    assert [lib.fs_lock_step(lk, math.nan) for _ in range(3)] == [False, False, True]
    bad = ffi.new("fs_lock *")
    assert lib.fs_lock_init(bad, ffi.new("fs_lock_config *", {"Ts": 1e-3, "t_lost": 1e-4})) == lib.FS_ERR_LIMIT
    assert lib.fs_lock_init(bad, ffi.new("fs_lock_config *", {"Ts": 0.0, "t_lost": 1.0})) == lib.FS_ERR_TS


def smo_run(top_rpm: float, lock: str):
    return simulate(SS, overrides={"observer": {"top_speed_rpm": top_rpm}, "load": {"speed_rpm": 2000.0},
                                   "controller": {"lock": lock}})


def test_an_observer_that_cannot_slide_is_stopped_as_lost_with_its_time():
    # the switching gain designed for 500 rpm cannot hold the EMF at 2000 rpm
    r = smo_run(500.0, "stop")
    assert r.stop_reason == "loss_of_lock"
    assert HANDOVER < r.stop_time < HANDOVER + 0.05          # lock_time (20 ms) after the loops take it
    t, err = r["t"], np.degrees(np.abs(r["est_err"]))
    assert np.max(err[t > HANDOVER]) > 45.0                   # it had truly lost the rotor
    assert r["lock_lost"][-1] == 1.0


def test_detect_only_traces_the_loss_and_runs_on():
    r = smo_run(500.0, "detect")
    assert r.stop_reason == "done"
    t_lost = r["t"][np.flatnonzero(r["lock_lost"])[0]]
    assert HANDOVER < t_lost < HANDOVER + 0.05


def test_the_same_observer_designed_for_its_speed_keeps_lock():
    r = smo_run(3000.0, "stop")
    assert r.stop_reason == "done" and not r["lock_lost"].any()
    assert np.max(np.degrees(np.abs(r["est_err"][r["t"] > HANDOVER]))) < 5.0


@pytest.mark.parametrize("name, overrides", [
    ("yang2022-blend-accdec", {}),                        # SMO, injection and the blend between them
    ("yang2022-hfi-iqstep", {}),                          # injection, a 5 -> 20 A step
    ("beyond-xcomp-3ph", {}),                             # injection at 25 A, the noisiest residual
    (SS, {"controller": {"psi_f_scale": 0.5}}),           # a wrong magnet flux the observer tolerates
    ("beyond-swvi-3ph", {}),                              # square wave: 50 el.deg off at the start, rated load
    ("yu2022-xcouple", {"injection": {"xcomp": "yu2022-xsat"}}),   # a rated brake step swings it 30 el.deg
])
def test_no_false_alarm_where_the_estimators_track(name, overrides):
    r = simulate(name, overrides={**overrides, "controller": {**overrides.get("controller", {}), "lock": "stop"}})
    assert r.stop_reason == "done"
    assert np.max(r["lock_resid"]) < 1.0


def swvi_impact(lock: str, torque: float = 6.0):
    """beyond-swvi-3ph on its ramp to 200 rpm, a load of `torque` N m from
    1.01 s: three times rated, beyond what i_max can hold."""
    load = [[0.0, 0.0], [0.1, 0.0], [0.3, 2.0], [1.0, 2.0], [1.01, torque]]
    return simulate("beyond-swvi-3ph", overrides={"load": {"torque": load}, "controller": {"lock": lock}})


def test_a_square_wave_estimate_thrown_off_by_a_load_impact_is_stopped_as_lost():
    r = swvi_impact("stop")
    assert r.stop_reason == "loss_of_lock" and 1.01 < r.stop_time < 1.06
    seen = swvi_impact("detect")          # runs on: the estimate truly left the rotor
    t, err = seen["t"], np.degrees(np.abs(seen["est_err"]))
    assert np.max(err[(t > r.stop_time) & (t < r.stop_time + 0.1)]) > 45.0
    assert np.max(err[(t > 0.1) & (t < 1.01)]) < 10.0   # and before the impact it tracked


def test_square_wave_cannot_recover_and_says_so():
    with pytest.raises(ConfigError, match=r"controller\.lock.*restart sequence"):
        load_scenario("beyond-swvi-3ph", {"controller": {"lock": "recover"}})
    cfg, keep = build_config(load_scenario("beyond-swvi-3ph", {"controller": {"lock": "stop"}}))
    cfg.drive.lock_recover, cfg.drive.t_recover = 1, 0.1
    drv = ffi.new("fs_drive *")
    assert lib.fs_drive_init(drv, ffi.addressof(cfg, "drive")) == lib.FS_ERR_MODE
    assert ffi.string(drv.fail) == b"lock_recover"
