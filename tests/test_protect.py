"""The drive's answer to a lost lock and its overspeed stop
(csrc/control/fs_drive_protect.h): by default it re-acquires (a flying
restart at speed, the start sequence at low speed) or stops with the PWM
off, and says which; lock = "detect" still only flags."""
import math
from pathlib import Path

import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.cli import run_verdict
from fullspeed.design.rules import OVERSPEED_PER_TOP, design_overspeed
from fullspeed.design.scenario import load_scenario, scenario_from_dict
from fullspeed.model.schema import deep_merge
from fullspeed.model.units import rad_s_to_rpm, rpm_to_rad_s
from fullspeed.sim import build_config, simulate
from fullspeed.sim.metrics import summary_lines
from fullspeed.workflows import lock_campaign as lc

LOCK_LOSS = str(Path(__file__).resolve().parents[1] / "examples" / "lock-loss" / "lock-loss.toml")
T_IMPACT = 1.0


def impact(torque: float, hold: bool = False) -> dict:
    """lock-loss.toml's load: 7 N m, then `torque` from 1.0 s, for 50 ms or held."""
    prof = [[0.0, 0.0], [0.2, 0.0], [0.3, 7.0], [T_IMPACT, 7.0], [T_IMPACT + 0.002, torque]]
    if not hold:
        prof += [[T_IMPACT + 0.05, torque], [T_IMPACT + 0.052, 7.0]]
    return {"load": {"torque": prof}}


def test_the_default_acts_on_a_lost_lock_and_detect_stays_by_name():
    assert load_scenario(LOCK_LOSS).data["controller"]["lock"] == "recover"
    assert load_scenario("yang2022-smo-ramp").data["controller"]["lock"] == "recover"
    assert load_scenario("beyond-swvi-3ph").data["controller"]["lock"] == "stop"   # no restart sequence
    assert load_scenario(LOCK_LOSS, {"controller": {"lock": "detect"}}).data["controller"]["lock"] == "detect"
    cfg, keep = build_config(load_scenario(LOCK_LOSS))
    assert cfg.drive.lock_recover == 1 and cfg.lock_stop == 1


def test_a_lock_lost_at_speed_is_caught_on_the_fly_where_detect_drives_on():
    # a 50 ms impact of 2.5 T_max at 1000 rpm throws the rotor back to -640 rpm
    res = simulate(LOCK_LOSS)
    m = res.metrics
    assert res.stop_reason == "done" and m["recoveries"] == 1
    (ev,) = m["lock_events"]
    assert ev["action"] == "flying restart" and T_IMPACT < ev["t"] < ev["t_done"] < T_IMPACT + 0.15
    assert ev["t_done"] - ev["t"] == pytest.approx(res.scenario.data["controller"]["recover_time"], abs=2e-4)
    assert ev["rotor_rpm"] < -300.0                                      # caught spinning backwards
    assert ev["speed_rpm"] == pytest.approx(ev["rotor_rpm"], rel=0.1)   # on the rotor's speed
    t, err = res["t"], np.degrees(np.abs(res["theta_err"]))
    # on track from then on, through the band at 6,000 rpm/s (14.9 el.deg when the injection's estimate
    # coasted through its settling instead of following the converged SMO)
    assert np.max(err[(t > ev["t_done"] + 0.01)]) < 10.0
    assert abs(rad_s_to_rpm(res["w_m"][-1]) - 1000.0) < 20.0
    assert m["true_loss_unanswered_at"] is None and not m["silent_failure"] and run_verdict(res) == []
    assert any("by a flying restart" in line for line in summary_lines(m))
    # detection alone: the same loss flagged, the drive going on on the false estimate
    seen = simulate(LOCK_LOSS, overrides={"controller": {"lock": "detect"}})
    assert seen.metrics["recoveries"] == 0 and seen.metrics["lock_events"] == []
    assert seen.metrics["true_loss_at"] is not None and np.any(seen["lock_lost"] > 0)
    assert any("the drive went on" in line for line in run_verdict(seen))


def test_a_lock_lost_near_standstill_restarts_the_start_sequence():
    """Smaller impacts (37..44 N m for 50 ms) leave the rotor near
    standstill: every run gets back to its 1000 rpm with a clean verdict,
    at least half of them by the start sequence (the injection finds the
    rotor again), and only below 150 rpm. Not at every impact: the rotor,
    thrown from about 380 rpm through zero within the zero-current wait,
    is at the wait's end where neither the back-EMF observer nor the wait's
    EMF (a low-pass over a quarter of the lock time) has followed it (at 40
    N m the observer read -159 rpm at a -22 rpm rotor, at 41 N m +297 at
    -58), and the drive takes the flying restart, which catches the rotor.
    Four of the eight
    restart (37, 38, 39, 42 N m; 44 N m leaves the rotor at -160 rpm, a
    flying restart's); on 27134c9 five, the flying restarts near
    standstill at 41 and 43 N m (-62 and -127 rpm), and since the
    observer's schedule and its hand-over read the EMF over the active flux
    also at 40."""
    restarts = 0
    for torque in np.arange(37.0, 45.0):
        res = simulate(LOCK_LOSS, overrides=impact(float(torque)))
        ev = res.metrics["lock_events"][0]
        assert res.stop_reason == "done" and abs(rad_s_to_rpm(res["w_m"][-1]) - 1000.0) < 20.0, torque
        assert run_verdict(res) == [], torque
        if ev["action"] == "restart":
            assert ev["stage"] == "injection" and abs(ev["rotor_rpm"]) < 150.0, torque
            restarts += 1
        else:
            assert ev["action"] == "flying restart" and res.metrics["recoveries"] >= 1, torque
    assert restarts >= 4


def test_the_drive_stops_with_the_pwm_off_where_it_cannot_reacquire():
    # the load held at 1.5 T_max: the rotor runs backwards, the observer does not catch it in the wait
    res = simulate(LOCK_LOSS, overrides=impact(34.5, hold=True))
    assert res.stop_reason == "loss_of_lock" and res.halt["fault"] == "lock"
    (ev,) = res.metrics["lock_events"]
    assert ev["action"] == "stopped" and ev["halted"] and res.stop_time == pytest.approx(ev["t_done"], abs=2e-4)
    # what the zero-current wait measured: the back-EMF of a rotor spinning backwards, by its magnitude
    assert 0.5 * abs(ev["rotor_rpm"]) < res.halt["emf_rpm"] < 1.5 * abs(ev["rotor_rpm"])
    lines = run_verdict(res)
    assert "with the PWM off: loss of lock not re-acquired" in lines[0] and "blending.lower_rpm" in lines[0]


def test_an_observer_started_on_the_encoder_stops_where_nothing_finds_the_rotor():
    # SMO alone, the speed reference reversed far faster than the current allows: the
    # estimate is lost near zero speed, where neither the observer nor a start sequence finds it
    c = next(c for c in lc.cases() if c["base"] == "yang2022-smo" and c["kind"] == "reversal")
    ov = deep_merge(c["overrides"], {"controller": {"lock": "recover"}})
    del ov["controller"]["overspeed_rpm"]   # the campaign's "none": designed again
    res = simulate(load_scenario(c["scenario"], ov))
    assert res.stop_reason == "loss_of_lock" and res.metrics["lock_events"][-1]["halted"]
    assert "no start sequence" in run_verdict(res)[0]


def test_lock_retries_spent_halt_with_the_lock_fault():
    res = simulate(LOCK_LOSS, overrides={"controller": {"lock_retries": 0}})
    assert res.stop_reason == "loss_of_lock" and res.halt["fault"] == "lock" and res.metrics["lock_events"] == []
    assert "after 0 re-acquisitions (controller.lock_retries = 0)" in run_verdict(res)[0]


def test_a_machine_in_henry_stops_instead_of_running_away():
    # the new-user trial's first mistake: the Prius MG2's L_d, L_q in mH typed as H; the run
    # used to end at -120,510 rpm and print a speed error of -24001.96 %
    prius = {"name": "prius-h", "kind": "ipmsm", "pole_pairs": 4,
             "electrical": {"R_s": 0.077, "L_d": 2.26, "L_q": 6.15, "psi_f": 0.1607},
             "mechanical": {"J": 0.035}, "rated": {"torque": 400.0, "current": 250.0, "speed_rpm": 1200.0},
             "bench": {"u_dc": 500.0, "f_pwm": 10e3, "t_dead": 3e-6, "noise_i": 0.3}}
    d = {"name": "prius-h", "duration": 6.5, "machine": prius, "initial": {"theta_e_deg": 20.0},
         "controller": {"mode": "speed", "angle": "blend", "flux_weakening": True},
         "injection": {"u_h": 50.0}, "polarity": {"enabled": False},
         "references": {"speed_rpm": [[0.0, 0.0], [1.0, 0.0], [3.0, 5000.0], [4.5, 5000.0], [6.0, -500.0]]},
         "load": {"torque": [[0.0, 0.0], [0.1, 0.0], [0.6, 100.0], [2.0, 100.0], [2.5, 40.0], [5.0, 40.0], [5.5, 100.0]]}}
    res = simulate(scenario_from_dict(d))
    assert res.stop_reason in ("loss_of_lock", "overspeed") and res.stop_time < 0.5
    assert abs(rad_s_to_rpm(res["w_m"][-1])) < res.scenario.data["controller"]["overspeed_rpm"]
    assert res.metrics["steady_window"] is None and "speed_error_pct" not in res.metrics


def overhauled(overspeed_rpm=None):
    """The encoder drive at 1000 rpm, then an active load of -1.5 T_max (pulling forwards) from 0.3 s."""
    sc = load_scenario("yang2022-encoder-speedstep", {"metrics": {"steady": None}})
    T = -1.5 * sc.data["controller"]["T_max"]
    ov = {"duration": 2.0, "metrics": {"steady": None}, "load": {"torque": [[0.0, 0.0], [0.3, 0.0], [0.301, T]]},
          "controller": {"overspeed_rpm": overspeed_rpm} if overspeed_rpm is not None else {}}
    return simulate(load_scenario("yang2022-encoder-speedstep", ov))


def test_an_overhauled_drive_stops_at_its_designed_overspeed():
    res = overhauled()
    ctl = res.scenario.data["controller"]
    limit = ctl["overspeed_rpm"]
    assert limit == pytest.approx(OVERSPEED_PER_TOP * res.scenario.data["observer"]["top_speed_rpm"])
    assert res.stop_reason == "overspeed" and res.halt["fault"] == "overspeed"
    w = rad_s_to_rpm(res["w_m_hat"])
    assert w[-1] > limit and np.all(w[:-1] <= limit)        # the step that passed it halted
    assert "overspeed" in run_verdict(res)[0] and "controller.overspeed_rpm" in run_verdict(res)[0]
    free = overhauled(overspeed_rpm=0.0)                      # 0: none, the rotor runs away (until a trip)
    assert free.stop_reason != "overspeed" and rad_s_to_rpm(np.max(free["w_m"])) > 1.1 * limit


def test_the_overspeed_limit_is_the_fastest_asked_or_designed_with_margin():
    v = design_overspeed({"observer.top_speed_rpm": 3000.0, "references.speed_rpm": 4400.0, "initial.speed_rpm": -100.0})
    assert v.value == pytest.approx(1.2 * 4400.0) and "references.speed_rpm" in v.reason and not v.given
    sc = load_scenario("beyond-full-range")   # top speed 5000 rpm, the reference 4400
    assert sc.data["controller"]["overspeed_rpm"] == pytest.approx(6000.0)
    assert sc.design["controller.overspeed_rpm"].value == pytest.approx(6000.0)
    cfg, keep = build_config(sc)
    assert cfg.drive.w_over == pytest.approx(sc.machine.pole_pairs * rpm_to_rad_s(6000.0), rel=1e-6)


def drive_at(w_over: float):
    cfg, keep = build_config(load_scenario("yang2022-encoder-speedstep"))
    cfg.drive.w_over = w_over
    drv = ffi.new("fs_drive *")
    return drv, lib.fs_drive_init(drv, ffi.addressof(cfg, "drive")), keep


def test_the_drive_halts_at_its_overspeed_and_refuses_a_bad_limit():
    drv, st, keep = drive_at(100.0)   # el. rad/s
    assert st == lib.FS_OK
    inp, out = ffi.new("fs_drive_in *"), ffi.new("fs_drive_out *")
    inp.u_dc, inp.w_m_ref = 24.0, 0.0
    k, dth = 0, 0.002
    while k < 5000:   # the encoder turning ever faster: the PLL's speed passes 100 el. rad/s
        inp.theta_m_enc = 0.5 * dth * k * k * 1e-3
        lib.fs_drive_step(drv, inp, out)
        if out.fault:
            break
        k += 1
    assert out.fault == lib.FS_FAULT_OVERSPEED and out.phase == lib.FS_PHASE_HALT
    assert abs(out.w_e) > 100.0 and list(out.duty)[:3] == [0.5, 0.5, 0.5]
    lib.fs_drive_step(drv, inp, out)   # held
    assert out.fault == lib.FS_FAULT_OVERSPEED and out.stage == lib.FS_STAGE_OPEN
    for bad in (-1.0, math.nan, math.inf):
        drv, st, keep = drive_at(bad)
        assert st == lib.FS_ERR_LIMIT and ffi.string(drv.fail) == b"w_over"
