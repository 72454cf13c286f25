"""The 2004 Prius MG2 held at 294 rpm by a load machine, its torque asked
from about 40 to the envelope's 486 N m (B-REAL's held torque at a quarter
of base speed, scenario reproduce.papers.real.held_scenario).

What could be wrong: the back-EMF observer's hold (fs_smo_hold, the
injection's carrier fading out just above 290 rpm) running the tracker on
its model alone through the torque's step: on the 0.035 kg m^2 rotor the
model took the 446 N m the load machine held for the rotor's, ran the
estimate to 660 rpm and 100 el.deg off in 6 ms, and the drive lost the
torque the encoder's drive holds.
"""
from pathlib import Path

import numpy as np
import pytest

from fullspeed.design.scenario import scenario_from_dict
from fullspeed.reproduce.papers.real import held_scenario
from fullspeed.sim import simulate
from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]


def _claims_speed() -> float:
    """B-REAL's held speed at a quarter of base speed, rpm, as the claim forms it."""
    from fullspeed.design.envelope import envelope
    from fullspeed.design.machine import load_machine
    from fullspeed.model.units import rad_s_to_rpm
    from fullspeed.reproduce.papers.real import held_speeds

    m = load_machine("prius2004-mg2")
    return rad_s_to_rpm(held_speeds(envelope(m, m.bench["u_dc"], m.bench["i_max"], w_end=4.0 * m.w_m_rated))[0])


def test_the_prius_holds_the_envelopes_torque_through_the_hand_over():
    """At the claim's own speed, and at most of the six 0.1 % beside it:
    the outcome after this step is chaotic (docs/held-runs.md), so one run
    at one speed (293.7 rpm, this test's until 2026-11-30) is a sample,
    not a margin. With the tracker on its model alone through the step
    none of the seven held; 4 of 7 on 1ff566d, 6 of 7 since the slew's
    anchor (fs_drive.c) stopped following the plan's cuts, 16 of 25 at
    --k 12 (bench/held_margin.py). All since the back-EMF tracker takes the
    speed of the EMF's magnitude where the map hides the angle's error
    (fs_smo_speed) and its hold bounds the speed it takes on as well as the
    angle (fs_smo_hold): 25 of 25 at --k 12. Since the start reads the
    injection's error once its filters have settled (fs_drive_reset) 23 of
    25 (k = -6 and +3 stop on overspeed after the step); with the start
    angle nudged instead at k = -6, 0, +3 the build before held 22 of 24 and
    the settled start 20. 7 of 7 was a draw on both, and the settled start
    loses margin here (a regression kept, docs/held-runs.md): the claim's
    run, and at least 6 of the 7."""
    rpm0 = _claims_speed()
    held = []
    for k in range(-3, 4):
        d = held_scenario("prius2004-mg2", rpm0 * (1.0 + 1e-3 * k), "blend")
        res = simulate(scenario_from_dict(d, "prius-held", warn=False))
        t = np.asarray(res["t"])
        e = np.degrees(np.abs(np.asarray(res["theta_err"])))
        steady = t >= d["metrics"]["steady"][0]
        ok = (res.stop_reason == "done" and res.metrics.get("lock_lost_at") is None
              and np.mean(np.asarray(res["T_e"])[steady]) > 0.99 * 486.5)   # the map's envelope at 294 rpm
        held.append(ok)
        if k == 0:   # the claim's run: held, the step's transient bounded, steady within 2 el.deg
            assert ok, res.stop_reason
            assert e[(t > 0.5) & (t < 0.51)].max() < 45.0
            assert e[steady].max() < 2.0
    assert sum(held) >= 6, held


# The same step with the injection stopped before it (its stop at 270 rpm, the blend's top at 240: 294 rpm is
# above both and above the resume at 243), so that the back-EMF observer's tracker alone carries the angle
# through it. The tracker feeds the torque forward on the rotor's J (0.035 kg m^2) while the load machine holds
# the shaft: the 450 N m step is an acceleration of p dT / J = 51,000 el.rad/s^2 that is not there, whose
# error peaks at 0.27 p dT / (J w_o^2) (fs_motion_obs.h; 13 el.deg at the tracker's 246 rad/s there, more as
# the swing drags its speed-scheduled bandwidth). Measured (issue 33): the tracker's speed ran from 297 to
# 543 rpm in 5 ms, 41 el.deg off at 11 ms, and the drive lost the rotor; none of the 7 speeds 0.1 % apart
# (293.1..294.9 rpm) holds the torque. With the feed-forward on half the torque (an experiment, k = 0.5 in
# every observer) or none, all 7 hold 486.4 N m; but the default hand-over (the step while injecting, the
# test above) then holds none of its 7, with none SyR-e's THOR above the band trips (3,456 and 4,147 rpm), and
# with half B-ZOO and B-ROBUST lose runs on free shafts: no fixed gain is the remedy. The remedy is the speed:
# on the saturated map the EMF's angle shows only g ~ 0.3..0.4 of the tracker's error at this current, so it
# corrects at that fraction of its bandwidth, while the EMF's magnitude over the active flux gives the speed
# whatever the angle. With that speed as a second innovation weighted 1 - g until the tracker has converged
# (fs_smo_speed) all 25 speeds 0.1 % apart (290.5..297.5 rpm) hold, the error's peak in the step's first 50 ms
# 23..28 el.deg.
def test_the_back_emf_tracker_alone_holds_the_prius_through_the_step():
    d = held_scenario("prius2004-mg2", 294.0, "blend")
    d["blending"] = {**d.get("blending", {}), "upper_rpm": 240.0}
    d["injection"] = {**d.get("injection", {}), "stop_rpm": 270.0}
    res = simulate(scenario_from_dict(d, "prius-held-smo", warn=False))
    t = np.asarray(res["t"])
    e = np.degrees(np.abs(np.asarray(res["theta_err"])))
    steady = t >= d["metrics"]["steady"][0]
    inj = np.asarray(res["inject"])
    assert not inj[(t > 0.49) & (t < 0.5)].any()   # the injection is off before the step: the tracker alone
    assert res.stop_reason == "done" and res.metrics.get("lock_lost_at") is None
    assert np.mean(np.asarray(res["T_e"])[steady]) > 0.99 * 486.5
    assert e[(t > 0.5) & (t < 0.55)].max() < 45.0
    assert e[steady].max() < 2.0


# While injecting, the back-EMF observer takes the injection filters' fundamental current i_f (fs_hfi_filter:
# two SRFFs, linear). What it estimates is what its model leaves of the voltage it is given: that voltage must be
# the one i_f belongs to, the fundamental's through the same filters (fs_hfi_filter_u: their step response, a
# decaying tone near the carrier of about w_b / w_h of a step, is then in both), less the map's transient
# (L_inc - L_d) di/dt on that same current (fs_smo.h). The torque's step here (38 -> 486 N m, i_q up by some
# 200 A in a millisecond, L_qq 6.15 mH at no load against the observer's L_d 2.26 mH) is a current step while
# injecting, on a shaft that does not move: the EMF's speed must stay the shaft's. Measured: with the unfiltered
# voltage and no transient while injecting (main at 5375a99) it read 1,344 rpm 1 ms into the step; with the
# voltage unfiltered but the transient taken, 366; with both, 169..310 rpm. Both together (branch h-smoinj-exp)
# pass this, and B-ROBUST's worst error falls 14.5 -> 7.0 el.deg, but the held run above is then lost at all
# 7 speeds (4 of 7 hold on main): with its EMF right, the tracker still runs from 294 to 426 rpm in 3 ms on the
# torque it feeds forward on the rotor's J (the test above's mechanism), and the spike that happened to knock it
# out of `converged` and off its hold no longer does. Strict: the day the pair is mended, the mark goes.
@pytest.mark.xfail(strict=True, reason="while injecting the back-EMF observer takes the filters' fundamental current "
                                       "with the unfiltered voltage and without the map's transient (issue 33)")
def test_a_current_step_while_injecting_leaves_the_back_emf_speed_the_shafts():
    ht = load_script(ROOT / "bench" / "held_trace.py", "bench_held_trace_emf")
    rows = ht.trace("prius2004-mg2", 293.706, before=1e-3, after=3e-3, every=1e-4)
    t_s = ht.step_time(held_scenario("prius2004-mg2", 293.706, "blend"))
    pre = [r for r in rows if r["t"] < t_s]
    post = [r for r in rows if r["t"] >= t_s]
    assert pre and post and all(r["injecting"] for r in pre + post[:5])   # the step comes while injecting
    assert max(r["T_ff"] for r in pre) < 50.0 and max(r["T_ff"] for r in post) > 400.0   # ... and is a step
    ratio = [r["smo"]["w_emf_rpm"] / r["w_m_rpm"] for r in post]
    assert 0.5 < min(ratio) and max(ratio) < 1.5, (min(ratio), max(ratio))
