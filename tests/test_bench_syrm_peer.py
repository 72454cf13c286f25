"""Tests of bench/syrm_peer.py, fullspeed's blended drive against motulator
on two saturated PM-SyRMs.

What could be wrong: stretches that leave a gap or overlap, a start-up
that does not end where the ramp reaches its share of the top speed, two
sides given different references or loads (rpm against rad/s), a load
beyond what the envelope holds at the top speed, an acceleration time or
current share read from the wrong samples, a comparison that takes the
worse peer or judges the start-up's parts, and a peer that cannot run
turning into a crash. The simulations themselves are not run here.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
import syrm_peer as sp  # noqa: E402


def _job(**kw) -> "sp.Job":
    t0, t1, t_step = 0.5, 1.5, 1.8
    base = dict(machine="syre-thor", n_p=2, R_s=0.2, J=0.01, u_dc=310.0, i_max=44.0, w_rated=266.0, w_top=532.0,
                T_rated=19.0, T_env_top=20.0, T_load=18.0, t_acc_min=0.1, t_least=(0.08, 0.095),
                t0=t0, t1=t1, t_step=t_step, t_end=t_step + sp.LOAD_WINDOW + sp.STEADY,
                windows=sp.stretches(t0, t1, t_step))
    base.update(kw)
    return sp.Job(**base)


def test_stretches_tile_the_job_and_the_start_up_ends_at_its_share_of_the_top_speed():
    job = _job()
    main = job.windows[:len(sp.STRETCHES)]
    assert tuple(w[0] for w in main) == sp.STRETCHES
    assert main[0][1] == 0.0 and main[-1][2] == pytest.approx(job.t_end)
    for (_, _, b), (_, a, _) in zip(main, main[1:]):
        assert a == b                                   # no gap, no overlap
    t_su = main[0][2]
    pts = sp.speed_points(job, step=False)
    w_ref = np.interp(t_su, [p[0] for p in pts], [p[1] for p in pts])
    assert w_ref == pytest.approx(sp.START_SHARE * job.w_top)
    assert main[2][1] == job.t_step                      # the load step's stretch starts at the step
    parts = {w[0]: (w[1], w[2]) for w in job.windows[len(sp.STRETCHES):]}
    assert parts == {sp.PARTS[0]: (0.0, job.t0), sp.PARTS[1]: (job.t0, t_su)}


def test_both_sides_get_the_same_reference_and_load():
    job = _job()
    for variant in sp.VARIANTS:
        fs_data = sp.fullspeed_data(job, "blend", variant)
        peer = sp.peer_job(job, "thor-cvc", sensorless=True)
        ref = fs_data["references"]["speed_rpm"]
        assert [t for t, _ in ref] == [t for t, _ in peer["speed"]]
        assert [w / sp.RPM for _, w in ref] == pytest.approx([w for _, w in peer["speed"]])   # rpm there, rad/s here
        assert fs_data["load"]["torque"] == peer["load"]
        assert fs_data["duration"] == pytest.approx(peer["t_stop"])
        assert peer["i_s_max"] == job.i_max and peer["J"] == job.J and peer["R_s"] == job.R_s
    assert sp.fullspeed_data(job, "blend", "known start")["polarity"] == {"enabled": False}
    assert sp.fullspeed_data(job, "blend", "ideal ADC")["sensors"] == {"adc_bits": 0}
    assert "polarity" not in sp.fullspeed_data(job, "blend") and "sensors" not in sp.fullspeed_data(job, "blend")
    # the load steps from nothing to T_load at t_step; the encoder's and the sensored peer's runs take the step, no load
    assert sp.load_points(job, False)[-2:] == [[job.t_step, 0.0], [job.t_step, job.T_load]]
    enc, peer_enc = sp.fullspeed_data(job, "encoder"), sp.peer_job(job, "thor-cvc", sensorless=False)
    assert enc["references"]["speed_rpm"][2] == [job.t0, pytest.approx(job.w_top * sp.RPM)]
    assert peer_enc["speed"][2] == [job.t0, job.w_top] and peer_enc["load"] == [[0.0, 0.0]]


def test_the_baldor_load_is_held_within_its_envelope_at_the_top_speed():
    """The Baldor's rated 29.7 N m is beyond its envelope at 2 x 1800 rpm
    (at the designed 18.7 A): the job's load is the envelope's share there,
    and its ramp at least ACC_MARGIN x the least time."""
    job = sp.syrm_job("baldor-ecs101m0h7ef4")
    assert job.w_top == pytest.approx(sp.TOP * 1800.0 / sp.RPM)
    assert job.T_env_top < job.T_rated
    assert job.T_load == pytest.approx(sp.LOAD_SHARE * job.T_env_top)
    assert job.t1 - job.t0 >= sp.ACC_MARGIN * job.t_acc_min - 0.005
    assert job.t_least[0] < job.t_least[1] < job.t_acc_min


def test_least_time_at_constant_torque_is_J_w_over_T():
    w = np.linspace(0.0, 300.0, 11)
    assert sp.least_time(0.02, w, np.full_like(w, 12.0)) == pytest.approx(0.02 * 300.0 / 12.0)
    assert sp.least_time(0.02, w, np.full_like(w, 12.0), T_load=4.0) == pytest.approx(0.02 * 300.0 / 8.0)


def test_acceleration_reads_the_times_and_the_current_from_the_step_on():
    t = np.arange(0.0, 2.0, 1e-4)
    t0, w_top, i_max = 0.5, 100.0, 10.0
    w = np.clip((t - t0) / 1.0, 0.0, 1.0) * w_top                       # reaches the top 1 s after the step
    i_abs = np.where((t >= t0) & (t < t0 + 0.45), i_max, 0.5 * i_max)     # at the limit for half of the time to 90 %
    i_abs[(t >= 0.1) & (t < 0.2)] = 3 * i_max                            # before the step: not counted
    a = sp.acceleration(t, w, i_abs, t0, w_top, i_max)
    assert a["t_90"] == pytest.approx(0.9, abs=2e-4) and a["t_98"] == pytest.approx(0.98, abs=2e-4)
    assert a["at_limit_share"] == pytest.approx(0.5, abs=1e-3)
    assert a["i_mean_share"] == pytest.approx(0.75, abs=1e-3)
    assert a["i_peak"] == pytest.approx(i_max)
    never = sp.acceleration(t, 0.5 * w, i_abs, t0, w_top, i_max)
    assert never["t_90"] is None and never["t_98"] is None


def test_the_comparison_takes_the_best_peer_per_stretch_and_judges_the_stretches_only():
    job = _job()
    names = [w[0] for w in job.windows]
    stats = lambda mx: {"max": mx, "rms": mx / 2}   # noqa: E731
    peers = {"a": {"status": "ok", "windows": {n: stats(2.0) for n in names}},
             "b": {"status": "ok", "windows": {n: stats(1.0 if n == "steady" else 5.0) for n in names}},
             "c": {"status": "missing", "reason": "no Python"}}
    run = {"windows": {n: stats(4.5 if n in ("steady", sp.PARTS[0]) else 4.9) for n in names}}
    rows = {r["stretch"]: r for r in sp.against_best_peer(job.windows, run, peers)}
    assert rows["steady"]["peer_max"] == 1.0 and rows["steady"]["peer_max_by"] == "b"
    assert rows["steady"]["d_max"] == pytest.approx(3.5) and rows["steady"]["within"] is False
    assert rows["start-up"]["peer_max_by"] == "a" and rows["start-up"]["d_max"] == pytest.approx(2.9)
    assert rows["start-up"]["within"] is True
    assert rows[sp.PARTS[0]]["within"] is None                    # a part is reported, not judged
    assert sp.within_everywhere(list(rows.values())) is False
    none = sp.against_best_peer(job.windows, run, {"c": peers["c"]})
    assert all(r["within"] is None for r in none) and sp.within_everywhere(none) is None


def test_a_peer_that_cannot_run_is_missing_with_its_reason(monkeypatch):
    def no_python():
        raise sp.estimators.wall.Skip("no Python >= 3.12 found")
    monkeypatch.setattr(sp.estimators.wall, "peer_python", no_python)
    rep, traces = sp.run_peer(_job(), "thor-cvc", sensorless=True)
    assert traces is None and rep == {"status": "missing", "reason": "no Python >= 3.12 found"}
