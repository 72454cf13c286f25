"""Tests of bench/estimators.py, the estimators' comparison with motulator.

What could be wrong: window statistics that take the wrong samples or the
wrong units (rad for deg, rad/s for rpm), a goal check that passes a value
above its limit, and a peer that cannot run turning into a crash or into
zeros instead of a missing column that says why. The simulations themselves
are not run here (the bench runs them); everything is synthetic and fast.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
est = load_script(ROOT / "bench" / "estimators.py", "bench_estimators")


def test_window_stats_takes_the_window_and_converts_units():
    t = np.arange(0.0, 1.0, 1e-3)
    err = np.where(t < 0.5, np.radians(1.0), np.radians(-3.0))   # 1 el.deg, then -3
    w = np.full_like(t, 100.0)
    w_ref = w + np.where((t >= 0.6) & (t < 0.61), 10.0, 0.0)     # a 10 rad/s dip inside the second window
    w_hat = w + np.where(t < 0.5, 1.0, 0.0)
    s = est.window_stats(t, err, w, w_hat, w_ref, (("first", 0.0, 0.5), ("second", 0.5, 1.0), ("empty", 2.0, 3.0)))
    assert s["first"]["max"] == pytest.approx(1.0) and s["first"]["mean"] == pytest.approx(1.0)
    assert s["second"]["max"] == pytest.approx(3.0) and s["second"]["mean"] == pytest.approx(-3.0)
    assert s["second"]["rms"] == pytest.approx(3.0)
    assert s["first"]["dw_max"] == pytest.approx(0.0)
    assert s["second"]["dw_max"] == pytest.approx(10.0 * 30.0 / math.pi)   # rpm
    assert s["first"]["dw_hat_max"] == pytest.approx(30.0 / math.pi) and s["second"]["dw_hat_max"] == 0.0
    assert s["empty"] is None


def test_goals_compare_magnitudes_with_limits():
    case = {"goals": {"x": (("w", "max", 2.0), ("w", "mean", 0.2))}}
    runs = {"x": {"windows": {"w": {"max": 2.5, "mean": -0.1}}}}
    rows = est.goals_met(case, runs)
    assert [r["met"] for r in rows] == [False, True]
    assert rows[1]["value"] == pytest.approx(0.1)
    assert est.goals_met(case, {})[0]["met"] is False      # a run that is missing meets nothing


def test_a_peer_that_cannot_run_is_missing_with_its_reason(monkeypatch):
    def no_python():
        raise est.wall.Skip("no Python >= 3.12 found")
    monkeypatch.setattr(est.wall, "peer_python", no_python)
    rep, traces = est.run_peer("a", est.CASES["a"]["windows"])
    assert traces is None and rep == {"status": "missing", "reason": "no Python >= 3.12 found"}
    row = {"windows": {w[0]: {"max": 1.0, "rms": 0.5, "mean": 0.1, "dw_max": 2.0, "dw_hat_max": 3.0}
                       for w in est.CASES["a"]["windows"]},
           "t_err_over_90deg_s": 0.0, "stop": "done", "wall_s": 0.01}
    text = est.format_report({"cases": {"a": {"title": "t", "peer_label": "motulator FVC", "peer": rep,
                                              "fullspeed": {"SMO": row}, "goals": [], "figure": None}}})
    assert "motulator FVC: missing: no Python >= 3.12 found" in text
    assert "fullspeed SMO" in text


def test_a_goal_relative_to_another_run_compares_the_difference():
    """Issue 34's blend goal: at most 1 el.deg worse than the back-EMF
    observer alone on the same window; better meets it, a missing run meets
    nothing."""
    case = {"goals": {"blend": (("step", "max", 1.0, "smo"),)}}
    worse = {"blend": {"windows": {"step": {"max": 2.6}}}, "smo": {"windows": {"step": {"max": 1.5}}}}
    (row,) = est.goals_met(case, worse)
    assert row["met"] is False and row["value"] == pytest.approx(1.1)
    assert row["run_value"] == pytest.approx(2.6) and row["ref_value"] == pytest.approx(1.5)
    better = {"blend": {"windows": {"step": {"max": 0.4}}}, "smo": {"windows": {"step": {"max": 1.5}}}}
    assert est.goals_met(case, better)[0]["met"] is True
    assert est.goals_met(case, {"blend": worse["blend"]})[0]["met"] is False   # no reference run
    text = est.format_report({"cases": {"a": {"title": "t", "peer_label": "p", "peer": {"status": "missing", "reason": "r"},
                                              "fullspeed": {"smo": {"windows": {"step": {"max": 1.5, "rms": 0, "mean": 0, "dw_max": 0, "dw_hat_max": 0}},
                                                                    "t_err_over_90deg_s": 0.0, "stop": "done", "wall_s": 0.1}},
                                              "goals": est.goals_met(case, worse), "figure": None}}})
    assert "goal blend [step] max <= smo's + 1: 1.10 more (2.60 / 1.50) NOT met" in text


@pytest.mark.parametrize("run", [r for c in est.CASES.values() for r in c["runs"].values() if isinstance(r, est.Designed)])
def test_designed_runs_take_nothing_of_the_estimators_from_the_scenario(run):
    """The designed runs' catalog scenarios set the carrier, the band and
    bandwidths by hand: a designed run that kept any of them would measure
    the hand-set drive under the designed drive's name."""
    from fullspeed.design.scenario import scenario_from_dict
    from fullspeed.model.scenario import scenario_data
    base, _ = scenario_data(run.base)
    data = est.designed_data(run.base, run.angle)
    assert data["controller"]["angle"] == run.angle and data["references"] == base["references"]
    assert not {"injection", "blending"} & set(data)
    assert set(data.get("observer", {})) <= {"start"}
    assert not [k for k in data["controller"] if k.startswith("bw_")]
    sc = scenario_from_dict(data, "test")
    given = {k: v["reason"] for k, v in est.designed_settings(sc).items() if v["given"] and "machine file" not in v["reason"]}
    assert given == {}
    if run.angle != "smo":   # the carrier the design gives, not the scenario's 1.6 kHz
        assert sc.design["injection.f_h"].given is False and sc.data["injection"]["f_h"] != 1600.0
