"""No success without the job done, and a summary whose lines agree: a run
that never left its start stage or whose speed ends far from its reference
is not `done` with exit 0; the sensorless error counts every stage the
loops make torque in; no steady window after a stop; no sensorless line for
an encoder run; a load's response only where the speed reference holds."""
from pathlib import Path

import numpy as np
import pytest

import fullspeed
from fullspeed.cli import run_verdict
from fullspeed.design.scenario import load_scenario, scenario_from_dict
from fullspeed.model.units import rad_s_to_rpm
from fullspeed.model.zoo import machine as zoo_machine
from fullspeed.sim import simulate
from fullspeed.sim.metrics import CONTROL_BAND, sensorless_error_max, stepping_channels, summary_lines


def test_a_start_that_never_hands_over_is_not_success():
    # the I/f start accelerates its frame towards the reference or the hand-over speed,
    # whichever is lower: a reference below the hand-over leaves the drive in its start stage
    ov = {"duration": 0.6, "metrics": {"steady": None}, "observer": {"start_handover_rpm": 400.0},
          "references": {"speed_rpm": [[0.0, 0.0], [0.1, 0.0], [0.1, 200.0]]}, "load": {"torque": 0.0}}
    res = simulate("bench-motulator-2kw", overrides=ov)
    assert res.stop_reason == "done"
    assert res.metrics["start_unfinished"]["stage"] == "start" and res.metrics["start_unfinished"]["never_left"]
    lines = run_verdict(res)
    assert any("ended in the start stage start" in line and "never closed its loops" in line for line in lines)


def test_a_speed_far_from_its_reference_at_the_end_is_not_success():
    # 6000 rpm asked of the yang2022 machine without flux weakening: its 24 V link stops it near 4600
    ov = {"duration": 1.2, "metrics": {"steady": None}, "references": {"speed_rpm": [[0.0, 0.0], [0.1, 6000.0]]}}
    res = simulate("yang2022-encoder-speedstep", overrides=ov)
    end = res.metrics["speed_end"]
    assert res.stop_reason == "done" and end["far"] and end["ref_rpm"] == pytest.approx(6000.0)
    assert abs(end["speed_rpm"] - 6000.0) > CONTROL_BAND * 6000.0
    assert any("the speed ends at" in line and "outside the +-600.0 rpm" in line for line in run_verdict(res))
    near = simulate("yang2022-encoder-speedstep")   # the same drive at 1000 rpm: within its band
    assert not near.metrics["speed_end"]["far"] and run_verdict(near) == []


def _loaded(T: float, duration: float):
    """The yang2022 drive at 1000 rpm (encoder, averaged inverter) with a
    load step to T at 0.5 s: its envelope there is about 2.9 N m."""
    return simulate("yang2022-encoder-speedstep", overrides={
        "duration": duration, "metrics": {"steady": None}, "converter": {"inverter": "averaged"},
        "load": {"torque": [[0.0, 0.0], [0.5, 0.0], [0.5, T]]}})


def test_a_steady_window_shorter_than_the_loops_time_constant_is_none():
    # the speed loop settles in 5 / bw_speed = 50 ms and its time constant is 10 ms: 6 ms left is no steady state
    short = _loaded(2.0, 0.556).metrics
    assert short["steady_window"] is None and "less than the loop's time constant 10 ms" in short["steady_basis"]
    assert "speed_error_pct" not in short
    assert _loaded(2.0, 0.57).metrics["steady_window"] == pytest.approx([0.55, 0.57])


def test_a_speed_that_recedes_or_settles_outside_its_band_is_not_success():
    """Inside CONTROL_BAND (10 %) but not held: a load beyond the envelope,
    the run ending before the loop could settle and the speed falling away;
    the same load after the settling time, the speed sagging 5 to 9 %
    (the new-user trial's Baldor at 30 N m and 3600 rpm ended -9.1 % and
    falling with exit 0). A load within the envelope, the run ending while
    the speed still recovers, is not judged on it."""
    away = _loaded(3.0, 0.54)
    end = away.metrics["speed_end"]
    assert not end["far"] and end["unheld"]["how"] == "moving away"
    assert abs(end["unheld"]["error_rpm"]) > abs(end["unheld"]["error_before_rpm"]) > 0.02 * 1000.0
    assert any("moving away" in line and "not holding the speed" in line for line in run_verdict(away))
    sag = _loaded(2.95, 0.6)
    end = sag.metrics["speed_end"]
    assert not end["far"] and end["unheld"]["how"] == "settled" and -0.1 * 1000 < end["unheld"]["error_rpm"] < -0.05 * 1000
    assert any("past the loop's settling in 50 ms" in line for line in run_verdict(sag))
    for T, t_end in ((2.8, 0.53), (2.0, 0.52)):   # still beyond 2 %: coming back; in the dip, before its peak
        res = _loaded(T, t_end)
        assert 0.02 * 1000.0 < 1000.0 - res.metrics["speed_end"]["speed_rpm"] < 0.1 * 1000.0
        assert res.metrics["speed_end"]["unheld"] is None and run_verdict(res) == []


def test_the_sensorless_error_counts_the_start_stage():
    # the new-user trial's PM-SyRM: 1.28 el.deg reported beside a start stage at 179.99
    t = np.arange(400) * 1e-3
    stage = np.where(t < 0.3, 3, 6).astype(float)   # the I/f start, then the back-EMF observer
    err = np.radians(np.where(t < 0.3, 179.99, 1.28))
    tr = {"t": t, "stage": stage, "theta_err": err, "w_m_ref": np.zeros_like(t), "T_L": np.zeros_like(t)}
    assert sensorless_error_max(tr) == pytest.approx(179.99)
    assert sensorless_error_max(tr, t_from=0.31) == pytest.approx(1.28)   # after the encoder handed over


def test_the_loops_own_current_references_forgive_no_error(tmp_path):
    """In speed mode i_d_ref and i_q_ref are the speed loop's and the start's
    outputs, not steps of the scenario: an I/f start whose rotor slipped
    (the catalog's hub motor with its inductances a thousand times too
    large, a new user's mH read as H) moved them at every sample, every
    sample was forgiven, and the summary said 0.00 el.deg beside 179.99 in
    the start stage."""
    t = np.arange(2000) * 1e-4
    tr = {"t": t, "stage": np.full(t.size, 3.0), "theta_err": np.radians(np.where(t > 0.0, 170.0, 0.0)),
          "w_m_ref": np.full(t.size, 10.0), "T_L": np.zeros_like(t), "i_d_ref": np.zeros_like(t),
          "i_q_ref": np.where(np.arange(t.size) % 2 == 0, 5.0, -5.0)}
    assert sensorless_error_max(tr) == 0.0      # every sample but the first forgiven: the 0.00 of the summary
    assert sensorless_error_max(tr, channels=("w_m_ref", "T_L")) == pytest.approx(170.0)
    assert stepping_channels(load_scenario("yang2022-encoder-speedstep")) == ("w_m_ref", "T_L")
    assert stepping_channels(load_scenario("yang2022-hfi-iqstep")) == ("i_q_ref", "i_d_ref")   # held at 100 rpm
    held = load_scenario("yang2022-smo-steady-400rpm")   # the shaft held by a speed load: its torque is the drive's
    assert held.data["load"]["kind"].startswith("speed") and "T_L" not in stepping_channels(held)

    text = (Path(fullspeed.__file__).parent / "machines" / "grin-all-axle-5t.toml").read_text()
    hub = tmp_path / "hub-mH.toml"
    hub.write_text(text.replace("L_d = 130e-6", "L_d = 0.13").replace("L_q = 130e-6", "L_q = 0.13"))
    res = simulate(scenario_from_dict({"name": "hub-mH", "duration": 1.0, "machine": str(hub),
                                       "controller": {"mode": "speed", "angle": "blend"},
                                       "references": {"speed_rpm": [[0.0, 0.0], [0.2, 0.0], [1.0, 330.0]]}}))
    start = res.metrics["stages"]["start"]
    assert res.stop_reason == "start_failed" and start["theta_err_max_deg"] > 90.0
    assert res.metrics["sensorless_err_deg_max"] == pytest.approx(start["theta_err_max_deg"])


def test_an_encoder_run_has_no_sensorless_error_even_in_flux_weakening():
    res = simulate("beyond-full-range", overrides={"controller": {"angle": "encoder"}, "duration": 3.4,
                                                  "metrics": {"steady": None}})
    assert "flux_weakening" in res.metrics["stages"]
    assert res.metrics["sensorless_err_deg_max"] is None
    assert not any("while sensorless" in line for line in summary_lines(res.metrics))


def test_no_steady_window_after_a_stop_before_it():
    # a linear zoo machine held to polarity pulses (no motion test allowed): refused at the start, long before
    # its steady window
    d = {"name": "z1", "duration": 1.0, "machine": {"zoo": 1}, "controller": {"mode": "speed", "angle": "blend"},
         "start": {"allow_motion": False},
         "references": {"speed_rpm": [[0.0, 0.0], [0.2, 0.0], [0.4, 0.3 * zoo_machine(1)["rated"]["speed_rpm"]]]}}
    res = simulate(scenario_from_dict(d))
    assert res.stop_reason == "polarity_undetermined" and res.stop_time < 0.4
    m = res.metrics
    assert m["steady_window"] is None and "the run stopped at" in m["steady_basis"]
    assert "speed_error_pct" not in m
    assert summary_lines(m)[0].startswith("steady window: none: the run stopped at")


def test_a_load_decrease_is_a_rise_and_a_load_change_on_a_ramp_is_not_measured():
    load = {"torque": [[0.0, 0.0], [0.3, 0.0], [0.31, 2.0], [0.8, 2.0], [0.81, 0.5], [1.3, 0.5], [1.5, 2.0]]}
    ref = {"speed_rpm": [[0.0, 0.0], [0.1, 1000.0], [1.2, 1000.0], [1.7, 1500.0]]}
    res = simulate("yang2022-encoder-speedstep", overrides={"duration": 2.0, "metrics": {"steady": None},
                                                             "load": load, "references": ref})
    up, down, ramp = [s for s in res.metrics["steps"] if s["kind"] == "load"]
    assert up["response"] == "dip" and up["dip_rpm"] > 5.0 and 0.3 <= up["t_dip"] < 0.31 + 0.3
    assert down["response"] == "rise" and "dip_rpm" not in down and down["rise_rpm"] > 5.0
    t, w, w_ref = res["t"], rad_s_to_rpm(res["w_m"]), rad_s_to_rpm(res["w_m_ref"])
    k = np.argmin(np.abs(t - down["t_rise"]))
    assert w[k] - w_ref[k] == pytest.approx(down["rise_rpm"])     # above the reference, not below
    assert ramp["dip_rpm"] is None and "speed reference changes" in ramp["note"]
    lines = summary_lines(res.metrics)
    assert any("speed rise" in line for line in lines)
    assert any(line.startswith("load step at 1.3 s") and "not measured" in line for line in lines)


def _overloaded_between(T: float, t_off: float, duration: float):
    """The yang2022 drive at 1000 rpm (its envelope there about 2.9 N m) with
    a load of T from 0.5 s to t_off, then none."""
    return simulate("yang2022-encoder-speedstep", overrides={
        "duration": duration, "metrics": {"steady": None}, "converter": {"inverter": "averaged"},
        "load": {"torque": [[0.0, 0.0], [0.5, 0.0], [0.5, T], [t_off, T], [t_off, 0.0]]}})


def test_a_load_the_speed_loop_did_not_answer_before_the_next_change_is_not_success():
    """The new-user trial's Baldor held 40 N m at 3000 rpm (its envelope 27.4) for
    0.5 s with the speed 1000 rpm down, recovered after the load went, and exited
    0. A load beyond the envelope held past the loop's settling (50 ms) and a
    time constant, then removed: the speed ends on its reference, the load's
    window says the drive did not hold it. The same load removed within the
    settling is not judged; one within the envelope recovers."""
    over = _overloaded_between(3.5, 0.65, 0.9)
    step = next(r for r in over.metrics["steps"] if r["kind"] == "load" and r["t"] == pytest.approx(0.5))
    assert step["recovery_time"] is None and step["unheld"]["until"] == pytest.approx(0.65)
    assert step["unheld"]["error_rpm"] < -0.02 * 1000.0
    assert not over.metrics["speed_end"]["far"] and over.metrics["speed_end"]["unheld"] is None   # back by the end
    assert any("the load's change at t = 0.5 s" in line and "did not hold the speed under that load" in line
               for line in run_verdict(over))
    short = _overloaded_between(3.5, 0.53, 0.9)   # removed 30 ms after: within the loop's 50 ms settling
    assert all(r.get("unheld") is None for r in short.metrics["steps"]) and run_verdict(short) == []
    within = _overloaded_between(2.0, 0.65, 0.9)
    assert all(r.get("unheld") is None for r in within.metrics["steps"]) and run_verdict(within) == []


def test_a_motion_test_that_failed_on_an_implausible_inertia_names_it():
    """The new-user trial's J 100 x too small was warned at load, then the start
    failed naming the estimate's spread alone. The doublet is sized on J: the
    verdict now names it where J's time to rated speed is implausible, and
    not on the catalog's own J."""
    import copy
    from fullspeed.model.machines import catalog_data

    def start(J_factor):
        d = copy.deepcopy(catalog_data("syre-thor"))
        d["mechanical"]["J"] *= J_factor
        sc = scenario_from_dict({"name": "j", "duration": 0.8, "machine": d, "controller": {"mode": "speed", "angle": "blend"},
                                 "references": {"speed_rpm": [[0, 0], [0.6, 0], [0.8, 300]]}}, "j", warn=False)
        return simulate(sc)
    # J x 0.01 (0.59 ms to rated speed) refused on main only because the injection's estimate, read while its
    # filters were a third of the carrier behind, asked the doublet for a 66 el.deg threshold; read once they have
    # settled (fs_drive_reset) it asks 4, the doublet turns that rotor 11.7 el.deg and it starts and runs within
    # 0.9 el.deg: that rotor is light, not unstartable. At x 0.001 (59 us) the rotor turns on its own and the
    # motion test refuses: the implausible J the verdict must name
    light = start(0.001)
    lines = run_verdict(light)
    assert light.stop_reason == "polarity_undetermined" and len(lines) == 1
    assert "polarity undetermined by the motion test" in lines[0] and "check J's unit" in lines[0]
    assert not any("J's unit" in line for line in run_verdict(start(1.0)))


SERVO = {"name": "servo400", "kind": "ipmsm", "pole_pairs": 4,
         "electrical": {"R_s": 0.3, "L_d": 0.6e-3, "L_q": 0.7e-3, "psi_f": 0.011}, "mechanical": {"J": 5e-5},
         "rated": {"torque": 1.27, "current": 8.0, "speed_rpm": 3000.0}, "bench": {"u_dc": 48.0, "f_pwm": 16000.0}}


def _servo(L_unit: float):
    m = {**SERVO, "electrical": {**SERVO["electrical"], "L_d": 0.6 * L_unit, "L_q": 0.7 * L_unit}}
    return simulate(scenario_from_dict({"name": "servo", "duration": 1.0, "machine": m,
                                        "controller": {"mode": "speed", "angle": "encoder"},
                                        "references": {"speed_rpm": [[0.0, 0.0], [0.5, 1000.0]]}}, "servo", warn=False))


def test_a_speed_that_passes_its_reference_as_the_run_ends_is_no_hold():
    """A new user's servo with its inductances in mH typed as H: the modulator
    saturated from the start, the speed climbs through its reference as the
    run ends (within 2 % there: the end check alone passed it, exit 0) while
    its mean over the steady window is 5.5 % short. With L in H it holds."""
    bad = _servo(1.0)
    m = bad.metrics
    assert bad.stop_reason == "done" and not m["speed_end"]["far"] and m["speed_end"]["unheld"] is None
    st = m["speed_steady"]
    assert st["window"] == pytest.approx(m["steady_window"]) and st["ref_rpm"] == pytest.approx(1000.0)
    assert -0.1 * 1000.0 < st["speed_rpm"] - 1000.0 < -st["band_rpm"]
    assert any("mean over the steady window" in line and "did not hold the speed" in line for line in run_verdict(bad))
    good = _servo(1e-3)
    assert good.metrics["speed_steady"] is None and run_verdict(good) == []


def test_a_window_given_over_a_ramp_is_not_judged_as_a_hold():
    """yang2022-smo-ramp's [metrics] steady lies on its speed ramp: the loop's
    lag behind a ramp is no failure to hold a speed."""
    res = simulate("yang2022-smo-ramp")
    assert np.ptp(res["w_m_ref"][(res["t"] >= 1.8) & (res["t"] <= 2.5)]) > 0
    assert res.metrics["speed_steady"] is None and run_verdict(res) == []
