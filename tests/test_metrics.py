"""Metrics that answer the usual questions: the steady window from the
profile, step responses, load dips, stages, and the DataFrame."""
import math

import numpy as np
import pytest

from fullspeed.sim.metrics import _changes, in_stages, stage_metrics, step_response, summary_lines, unwrap
from fullspeed.design.scenario import load_scenario
from fullspeed.sim import UNITS, simulate
from fullspeed.model.units import rpm_to_rad_s


def test_changes_merge_a_ramp_drawn_in_pieces_and_keep_steps_apart():
    prof = ([0.0, 0.1, 0.1, 0.2, 0.3, 0.5, 0.6], [0.0, 0.0, 5.0, 7.0, 9.0, 9.0, 2.0])
    # the jump and the rise after it go one way: one change, 0 -> 9 from 0.1 to 0.3 s
    assert _changes(prof) == [(0.1, 0.3, 0.0, 9.0), (0.5, 0.6, 9.0, 2.0)]
    assert _changes(([0.0], [3.0])) == []


def test_unwrap_gives_numpys_bits_on_jumps_exact_half_turns_and_nan():
    # the metrics' unwrap corrects only the steps of pi or more, where numpy's correction is not zeroed: the same
    # bits on wrapped ramps both ways, steps of exactly +-pi (numpy's boundary rule), a NaN and infinities
    rng = np.random.default_rng(7)
    ramps = [np.angle(np.exp(1j * np.cumsum(rng.normal(w, 0.3, 5000)))) for w in (0.9, -1.7, 0.0)]
    edges = np.array([0.0, np.pi, 0.0, -np.pi, 0.0, 3.0, -3.0 + 1e-16, np.nextafter(np.pi, 0), 0.0, 2 * np.pi])
    for p in (*ramps, edges, np.r_[ramps[0][:50], np.nan, ramps[0][50:100]], np.r_[0.0, np.inf, 1.0, -np.inf]):
        with np.errstate(invalid="ignore"):
            a, b = unwrap(p), np.unwrap(p)
        assert a.tobytes() == b.tobytes()
    assert unwrap(np.array([2.0])).tolist() == [2.0] and unwrap(np.array([])).size == 0


def test_in_stages_is_isin_on_every_code_and_set():
    s = np.r_[np.arange(-2, 12), np.random.default_rng(3).integers(0, 9, 1000)].astype(float)
    for stages in ((4, 5, 6, 7), (3, 4, 5, 6, 7), (2, 3), (8,), (2, 5), (7, 4, 6, 5)):
        assert np.array_equal(in_stages(s, stages), np.isin(s.astype(int), stages)), stages


def test_step_response_of_known_systems():
    t = np.linspace(0.0, 1.0, 200001)
    tau = 0.01   # first order: no overshoot, rise ln 9 tau, 2 % settling ln 50 tau
    r = step_response(t, 1.0 - np.exp(-t / tau), 0.0, 0.0, 1.0, 0.02)
    assert r["overshoot_pct"] == pytest.approx(0.0, abs=1e-9)
    assert r["rise_time"] == pytest.approx(math.log(9) * tau, rel=1e-3)
    assert r["settling_time"] == pytest.approx(math.log(50) * tau, rel=1e-3)
    z, wn = 0.3, 100.0   # second order, a downward step 4 -> 2: overshoot exp(-z pi / sqrt(1 - z^2))
    wd = wn * math.sqrt(1 - z * z)
    x = 1 - np.exp(-z * wn * t) * (np.cos(wd * t) + z / math.sqrt(1 - z * z) * np.sin(wd * t))
    r = step_response(t, 4.0 - 2.0 * x, 0.0, 4.0, 2.0, 0.04)
    assert r["overshoot_pct"] == pytest.approx(100 * math.exp(-z * math.pi / math.sqrt(1 - z * z)), rel=1e-3)
    r = step_response(t[:300], 1.0 - np.exp(-t[:300] / tau), 0.0, 0.0, 1.0, 0.02)   # cut before 90 %
    assert r["rise_time"] is None and r["settling_time"] is None and "did not reach 90 %" in r["note"]


def test_stages_by_name_with_time_entries_and_largest_error():
    t = np.arange(10) * 0.01
    stage = np.array([2, 2, 4, 4, 4, 5, 4, 4, 6, 6], float)
    err = np.radians([1, -3, 0, 9, 2, -12, -4, 1, 0.5, 0.2])
    st = stage_metrics({"t": t, "stage": stage, "theta_err": err})
    assert list(st) == ["polarity", "injection", "blend", "backemf"]
    assert st["injection"]["time"] == pytest.approx(0.05) and st["injection"]["entries"] == 2
    assert st["injection"]["theta_err_max_deg"] == pytest.approx(9.0)
    assert st["blend"]["theta_err_max_deg"] == pytest.approx(12.0)


def test_steady_window_from_the_profile_and_the_steps_of_a_speed_step():
    """yang2022-encoder-speedstep without its [metrics] steady: the last flat
    stretch starts at the load step (0.6 s), plus 5 / bw_speed; the speed step
    and the load step are measured."""
    res = simulate(load_scenario("yang2022-encoder-speedstep", {"metrics": {"steady": None}}))
    m, ctl = res.metrics, res.scenario.data["controller"]
    assert m["steady_window"] == pytest.approx([0.6 + 5.0 / ctl["bw_speed"], 1.2])
    assert abs(m["speed_error_pct"]) < 0.5
    ref, load = m["steps"]
    assert (ref["kind"], ref["from"], ref["to"]) == ("reference", 0.0, 1000.0)
    assert ref["rise_time"] > 0 and ref["settling_time"] > ref["rise_time"] and ref["overshoot_pct"] < 5.0
    assert (load["kind"], load["t"], load["to"]) == ("load", 0.6, 2.0)
    t, w, w_ref = res["t"], res["w_m"], res["w_m_ref"]
    k = np.argmin(np.abs(t - load["t_dip"]))
    assert load["dip_rpm"] > 5.0
    assert (w_ref[k] - w[k]) == pytest.approx(rpm_to_rad_s(load["dip_rpm"]))   # below the reference, not above
    after = t >= load["t"] + load["recovery_time"]
    assert np.all(np.abs(w[after] - w_ref[after]) <= 0.02 * rpm_to_rad_s(1000.0) + 1e-9)
    assert not np.all(np.abs(w[t >= load["t"]] - w_ref[t >= load["t"]]) <= 0.02 * rpm_to_rad_s(1000.0))
    assert any(line.startswith("load step at 0.6 s") for line in summary_lines(m))


def test_no_steady_window_on_a_run_that_ends_on_a_ramp():
    res = simulate(load_scenario("yang2022-encoder-speedstep", {
        "duration": 0.3, "metrics": {"steady": None}, "references": {"speed_rpm": [[0.0, 0.0], [0.3, 500.0]]}}))
    assert res.metrics["steady_window"] is None and "speed_error_pct" not in res.metrics
    assert "set [metrics] steady" in res.metrics["steady_basis"]
    assert res.metrics["steps"] == []   # the ramp is no step, and the load step at 0.6 s is after the end


def test_metrics_are_formed_at_their_first_read_and_kept(monkeypatch):
    """simulate() leaves the metrics to the first read of Result.metrics
    (a caller of the traces alone does not pay for them): then they are
    compute_metrics of the run, once."""
    import json

    from fullspeed.model.files import json_safe
    from fullspeed.sim import runner
    from fullspeed.sim.metrics import compute_metrics

    calls = []
    monkeypatch.setattr(runner, "compute_metrics", lambda r: calls.append(r) or compute_metrics(r))
    res = simulate(load_scenario("yang2022-encoder-speedstep", {"duration": 0.05, "metrics": {"steady": None}}))
    assert calls == []
    m = res.metrics
    assert calls == [res] and res.metrics is m and len(calls) == 1
    assert json.dumps(json_safe(m), sort_keys=True) == json.dumps(json_safe(compute_metrics(res)), sort_keys=True)
    res.metrics = {"given": 1.0}   # a caller's own, as before
    assert res.metrics == {"given": 1.0} and len(calls) == 1


def test_dataframe_has_units_time_index_and_stage_names():
    res = simulate(load_scenario("yang2022-encoder-speedstep", {"duration": 0.05, "metrics": {"steady": None}}))
    df = res.to_dataframe()
    assert df.index.name == "t" and df.index[1] - df.index[0] > 0
    assert df.attrs["units"]["w_m"] == "rad/s" and df.attrs["units"]["i_q"] == "A" and df.attrs["units"]["T_e"] == "N m"
    assert set(df.attrs["units"]) == set(UNITS) and "t" not in df.columns
    assert set(df["stage"].unique()) == {"sensor"}
    assert np.array_equal(df["i_q"].to_numpy(), res["i_q"])
