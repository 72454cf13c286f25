"""Tests of bench/wall.py's logic: fullspeed against motulator and
motulator-export on motulator's example.

What could be wrong: a ratio taken the wrong way round or from the wrong
rounds, a goal judged met below its value, a trajectory check that lets a
peer or fullspeed run another job (or a NaN) through, a peer that cannot
run turning into a crash or a silent zero. No simulation runs and nothing is
timed here (the bench times): the engines are replaced by stubs that return
chosen figures.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]
wall = load_script(ROOT / "bench" / "wall.py", "bench_wall")

AT_TOP = {"0.4": 2547.0, "0.8": 3000.0, "1.2": 2999.7, "1.59": 3000.0}


def run(wall_s, speed=None, stop="done"):
    return {"wall_s": wall_s, "speed_rpm": dict(speed or AT_TOP), "stop": stop}


def test_the_peers_agree_everywhere_fullspeed_where_the_reference_is_held():
    slow_start = {**AT_TOP, "0.4": 1500.0}            # fullspeed's own acceleration: not checked
    chk = wall.trajectory_check({"motulator": AT_TOP, "motulator-export": AT_TOP, "fullspeed": slow_start})
    assert chk["ok"] and chk["reference"] == "motulator"
    assert {(r["engine"], r["t"]) for r in chk["rows"]} == \
        {("motulator-export", t) for t in wall.INSTANTS} | {("fullspeed", t) for t in wall.HELD}
    # the same slow start in motulator-export is another job: it fails
    chk = wall.trajectory_check({"motulator": AT_TOP, "motulator-export": slow_start})
    assert not chk["ok"]
    bad = [r for r in chk["rows"] if not r["ok"]]
    assert [(r["t"], r["diff_rpm"]) for r in bad] == [("0.4", pytest.approx(1047.0))]


def test_a_speed_off_by_more_than_the_tolerance_or_missing_fails():
    off = {**AT_TOP, "1.2": AT_TOP["1.2"] + wall.TOL_RPM + 0.5}
    assert not wall.trajectory_check({"motulator": AT_TOP, "fullspeed": off})["ok"]
    near = {**AT_TOP, "1.2": AT_TOP["1.2"] + wall.TOL_RPM - 0.5}
    assert wall.trajectory_check({"motulator": AT_TOP, "fullspeed": near})["ok"]
    nan = {**AT_TOP, "1.59": math.nan}
    assert not wall.trajectory_check({"motulator": AT_TOP, "fullspeed": nan})["ok"]
    missing = {k: v for k, v in AT_TOP.items() if k != "0.8"}
    assert not wall.trajectory_check({"motulator-export": AT_TOP, "fullspeed": missing})["ok"]


def test_ratios_are_peer_over_fullspeed_medians_and_paired_round_by_round():
    runs = {"motulator": [run(3.0), run(4.0), run(5.0)],
            "motulator-export": [run(0.20), run(0.10), run(0.15)],
            "fullspeed": [run(0.010), run(0.005), run(0.004)]}
    m = wall.pair_report(runs, "averaged")
    assert m["engines"]["fullspeed"]["median"] == pytest.approx(0.005)
    r = m["ratios"]["motulator-export"]
    assert r["ratio"] == pytest.approx(0.15 / 0.005)        # 30x: the goal, met
    assert r["goal"] == 30.0 and r["met"]
    assert [r["paired"][k] for k in ("min", "median", "max")] == \
        pytest.approx([20.0, 20.0, 37.5])                    # 0.2/0.01, 0.1/0.005, 0.15/0.004
    assert m["ratios"]["motulator"]["ratio"] == pytest.approx(800.0) and m["ratios"]["motulator"]["met"]
    runs["fullspeed"] = [run(0.0051)] * 3
    assert not wall.pair_report(runs, "averaged")["ratios"]["motulator-export"]["met"]   # 29.4x


def test_the_metrics_read_after_the_call_are_reported_beside_and_judged_on_the_call():
    runs = {"motulator-export": [run(0.20), run(0.10), run(0.15)],
            "fullspeed": [{**run(0.004), "metrics_s": 0.002}, {**run(0.005), "metrics_s": 0.001},
                          {**run(0.010), "metrics_s": 0.003}]}
    m = wall.pair_report(runs, "averaged")
    r = m["ratios"]["motulator-export"]
    assert r["ratio"] == pytest.approx(0.15 / 0.005) and r["met"]              # the goal: the call alone
    assert r["ratio_with_metrics"] == pytest.approx(0.15 / 0.006)              # medians of 6, 6 and 13 ms
    assert m["engines"]["fullspeed"]["metrics_s"]["median"] == pytest.approx(0.002)
    text = wall.format_report({"status": "ok", "repeat": 3, "peers": [], "engines": ["motulator-export", "fullspeed"],
                               "modes": {"averaged": m}, "load_average": {"before": None}})
    assert "25.0x with the metrics read" in text and "2.00 / 2.00 / 3.00 ms" not in text
    assert "1.00 / 2.00 / 3.00 ms" in text


def test_a_fullspeed_run_that_stopped_fails_the_check():
    runs = {"motulator": [run(3.0)], "fullspeed": [run(0.01, stop="loss_of_lock")]}
    assert not wall.pair_report(runs, "switching")["trajectory"]["ok"]


@pytest.fixture
def stubs(monkeypatch):
    """Engines that return chosen figures; calls recorded in order."""
    calls = []
    speeds = {"motulator": AT_TOP, "motulator-export": AT_TOP, "fullspeed": AT_TOP}
    walls = {"motulator": 4.0, "motulator-export": 0.2, "fullspeed": 0.005}

    def peer(py, engine, pwm):
        calls.append((engine, pwm))
        return run(walls[engine] * (1 + 2 * pwm), speeds[engine])

    def ours(inverter):
        calls.append(("fullspeed", inverter))
        return run(walls["fullspeed"], speeds["fullspeed"])

    monkeypatch.setattr(wall, "peer_python", lambda: "/peer/python")
    monkeypatch.setattr(wall, "run_peer", peer)
    monkeypatch.setattr(wall, "run_fullspeed", ours)
    return calls, speeds


def test_rounds_alternate_the_engines_and_the_report_gives_both_ratios(stubs):
    calls, _ = stubs
    rep = wall.wall_report(repeat=2)
    assert rep["status"] == "ok"
    timed = calls[2:]     # after fullspeed's and motulator-export's warm-ups
    assert timed[:6] == [("motulator", 0), ("motulator-export", 0), ("fullspeed", "averaged"),
                         ("motulator", 1), ("motulator-export", 1), ("fullspeed", "switching")]
    assert len(timed) == 12
    sw = rep["modes"]["switching"]["ratios"]
    assert sw["motulator-export"]["ratio"] == pytest.approx(0.6 / 0.005)
    assert sw["motulator"]["ratio"] == pytest.approx(12.0 / 0.005)
    text = wall.format_report(rep)
    assert "fullspeed vs motulator-export" in text and "120.0x" in text
    assert "FAIL" not in text


def test_disagreeing_speeds_fail_the_report(stubs):
    _, speeds = stubs
    speeds["motulator-export"] = {**AT_TOP, "0.8": 2500.0}
    rep = wall.wall_report(repeat=1)
    assert rep["status"] == "fail" and "trajectory" in rep["reason"]
    assert "FAIL" in wall.format_report(rep)
    assert wall.main(["--repeat", "1"]) == 1


def test_without_the_peers_fullspeed_still_runs_and_says_why(monkeypatch, stubs):
    def no_python():
        raise wall.Skip("no Python >= 3.12 found")
    monkeypatch.setattr(wall, "peer_python", no_python)
    rep = wall.wall_report(repeat=1)
    assert rep["peers_skipped"] == "no Python >= 3.12 found" and rep["engines"] == ["fullspeed"]
    assert rep["modes"]["averaged"]["ratios"] == {}
    only_peers = wall.wall_report(repeat=1, engines=("motulator-export",))
    assert only_peers == {"status": "skipped", "reason": "no Python >= 3.12 found"}
    assert "skipped: no Python" in wall.format_report(only_peers)


def test_bad_arguments_exit_2(capsys):
    assert wall.main(["--engines", "matlab"]) == 2
    assert "--engines = matlab" in capsys.readouterr().err
    assert wall.main(["--repeat", "0"]) == 2
