"""`fullspeed reproduce` stopped before its end (issue 40, C9 of
../shared/reports/reliability-probe-2026-11-28.md: an interrupted
reproduction kept a claims.json of the claims measured so far with nothing
saying it was partial), and its claims measured concurrently (issue 38:
the claims that share runs in one process, the rows in CLAIMS order).

The measurements here are stand-ins at module level, so that the claim
processes (which import this module by name) run them as well as this one.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from fullspeed.reproduce import report as rp
from fullspeed.reproduce.claims import CLAIMS, claims_for
from fullspeed.reproduce.registry import SHARES, Measurement

STOP_AT = "U-THIRD"   # a claim of the default cost: measured late, after the long ones


def measured(out):
    return Measurement({"pid": os.getpid(), "nice": os.nice(0)}, True, "stand-in")


def interrupted(out):
    raise KeyboardInterrupt   # what Ctrl-C raises inside a measurement run here


def fakes(stop: str | None = STOP_AT) -> dict:
    return {c.id: interrupted if c.id == stop else measured for c in CLAIMS}


@pytest.mark.parametrize("lanes", [1, 2])
def test_c9_an_interrupted_reproduction_says_it_is_partial_and_what_did_not_run(tmp_path, monkeypatch, lanes):
    monkeypatch.setattr(rp, "MEASURES", fakes())
    (tmp_path / "claims.json").write_text(json.dumps({"complete": True, "claims": [], "not_run": []}))   # an older run's
    with pytest.raises(KeyboardInterrupt):
        rp.reproduce(None, tmp_path, progress=False, lanes=lanes)
    f = json.loads((tmp_path / "claims.json").read_text())
    ids = [c.id for c in CLAIMS]
    got = [r["id"] for r in f["claims"]]
    assert f["complete"] is False and STOP_AT in f["not_run"] and STOP_AT not in got
    assert sorted(got + f["not_run"], key=ids.index) == ids          # every claim: measured or named as not run
    assert got == sorted(got, key=ids.index) and f["not_run"] == sorted(f["not_run"], key=ids.index)
    if lanes == 1:   # one after the other, the longest first: those before the stop were measured
        assert "B-LOCK" in got and all(r["value"] is not None for r in f["claims"])
    report = (tmp_path / "report.md").read_text()
    assert "**Incomplete**" in report and STOP_AT in report.split("**Incomplete**")[1].splitlines()[0]


def test_a_whole_reproduction_says_it_is_complete_each_claim_with_its_wall_time(tmp_path, monkeypatch):
    """In two lanes: every claim in CLAIMS order, measured in a claim
    process (not this one), the claims that share runs in one process."""
    monkeypatch.setattr(rp, "MEASURES", fakes(stop=None))
    rows = rp.reproduce(None, tmp_path, progress=False, lanes=2)
    f = json.loads((tmp_path / "claims.json").read_text())
    assert f["complete"] is True and f["not_run"] == [] and f["claims"] == rows and f["lanes"] == 2
    assert [r["id"] for r in rows] == [c.id for c in CLAIMS]
    pid = {r["id"]: r["value"]["pid"] for r in rows}
    assert os.getpid() not in pid.values()
    for name in set(SHARES.values()):
        assert len({pid[c] for c, s in SHARES.items() if s == name}) == 1, name
    assert all(r["wall_s"] >= 0.0 for r in rows)
    assert "**Incomplete**" not in (tmp_path / "report.md").read_text()


def test_the_longest_unit_runs_in_the_foreground_lane_the_others_below_it(tmp_path, monkeypatch):
    """Lane 0 is the process that ran the first unit (the longest), at the
    command's priority; a claim in another lane ran BACKGROUND_NICE below
    it. Each row says its lane and start; the report sums them per lane."""
    monkeypatch.setattr(rp, "MEASURES", fakes(stop=None))
    rows = {r["id"]: r for r in rp.reproduce(None, tmp_path, progress=False, lanes=2)}
    first = rp.units(CLAIMS)[0]
    assert {rows[c.id]["lane"] for c in first} == {0}
    here = os.nice(0)
    for r in rows.values():
        assert r["lane"] in (0, 1) and 0.0 <= r["start_s"] <= json.loads((tmp_path / "claims.json").read_text())["wall_s"] + 0.1
        assert r["value"]["nice"] == (here if r["lane"] == 0 else min(19, here + rp.BACKGROUND_NICE)), r["id"]
    assert len({r["value"]["pid"] for r in rows.values() if r["lane"] == 0}) == 1
    report = (tmp_path / "report.md").read_text()
    assert "Lane 0 (foreground): " in report and "By CPU time: " in report


def test_the_lanes_summary_counts_each_lanes_claims_and_its_end():
    rows = [{"id": "A", "cpu_s": 30.0, "wall_s": 20.0, "lane": 0, "start_s": 0.0},
            {"id": "B", "cpu_s": 5.0, "wall_s": 4.0, "lane": 1, "start_s": 0.5},
            {"id": "C", "cpu_s": 2.0, "wall_s": 3.0, "lane": 1, "start_s": 30.0},
            {"id": "D", "cpu_s": 1.0, "wall_s": 1.0, "lane": 0, "start_s": 20.0},
            {"id": "E", "cpu_s": 0.5, "wall_s": 9.0, "lane": 2, "start_s": 1.0}]
    lines = rp.lanes_summary(rows)
    assert lines[0] == "By CPU time: A 30.0 s, B 5.0 s, C 2.0 s, D 1.0 s, E 0.5 s."
    assert lines[1] == "Lane 0 (foreground): 2 claims, 31 s of CPU, its last ended at 21 s."
    assert lines[2] == "Lane 1: 2 claims, 7 s of CPU, its last ended at 33 s."
    assert lines[3] == "Lane 2: 1 claim, 0 s of CPU, its last ended at 10 s."


def test_a_shared_group_runs_in_claims_order_and_the_longest_first():
    us = rp.units(CLAIMS)
    order = [c.id for c in CLAIMS]
    assert sorted(c.id for u in us for c in u) == sorted(order)
    for u in us:
        assert [c.id for c in u] == sorted((c.id for c in u), key=order.index)
        assert len({SHARES.get(c.id, c.id) for c in u}) == 1
    cost = [sum(rp.COST.get(c.id, rp.COST_DEFAULT) for c in u) for u in us]
    assert cost == sorted(cost, reverse=True)


def test_ctrl_c_stops_the_claim_processes_exit_130_and_the_file_says_partial(tmp_path):
    """The command under Ctrl-C (SIGINT to its process group, as a terminal
    sends it): exit 130, claims.json partial, no process of it left."""
    out = tmp_path / "r"
    # Ctrl-C's default action in the child, as under a terminal: a suite run as a background job of a
    # non-interactive shell inherits SIGINT ignored, and Python leaves an ignored SIGINT ignored
    p = subprocess.Popen([sys.executable, "-m", "fullspeed", "reproduce", "--paper", "yu2022", "--out", str(out),
                          "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        t0 = time.monotonic()
        while not (out / "claims.json").exists() and p.poll() is None and time.monotonic() - t0 < 120:
            time.sleep(0.1)
        time.sleep(1.0)   # the lanes started
        os.killpg(p.pid, signal.SIGINT)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
    assert p.returncode == 130, err
    f = json.loads((out / "claims.json").read_text())
    ids = [c.id for c in claims_for("yu2022")]
    assert f["complete"] is False and f["not_run"] and sorted([r["id"] for r in f["claims"]] + f["not_run"]) == sorted(ids)
    t0 = time.monotonic()
    while time.monotonic() - t0 < 30:   # the lanes, their pools and forkservers end after the command
        try:
            os.killpg(p.pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.2)
    else:
        pytest.fail("processes of the interrupted reproduction are still running")


def test_the_runs_b_ident_and_b_mapid_take_from_b_zoo_and_b_ident_are_the_ones_they_would_make():
    """B-IDENT's sensorless runs on the true parameters are B-ZOO's sweep
    points (zoo.RUNS), B-MAPID's identifications B-IDENT's (IDENTIFIED): the
    same scenarios, so the same runs."""
    from fullspeed.design.scenario import load_scenario, scenario_from_dict
    from fullspeed.reproduce.papers.beyond import IDENT_SAMPLE, MAPID_SAMPLE
    from fullspeed.workflows.sweep import load_sweep_file

    tasks = load_sweep_file("beyond-zoo").tasks()
    for k in (0, 2, 38, 98):
        swept = scenario_from_dict(tasks[k]["scenario"], tasks[k]["source"]).data
        assert swept == load_scenario("beyond-zoo", {"machine": {"zoo": k}, "controller": {}}).data   # identify._sensorless_task's
    assert set(range(0, 2 * MAPID_SAMPLE, 2)) <= set(range(IDENT_SAMPLE))
    assert SHARES["B-ZOO"] == SHARES["B-IDENT"] == SHARES["B-MAPID"]


def _burn(task: dict) -> dict:
    """A campaign task that spends task["s"] seconds of CPU."""
    t0, n = time.process_time(), 0
    while time.process_time() - t0 < task["s"]:
        n += 1
    return {"n": n}


def campaign(out):
    from fullspeed.workflows.journal import run_tasks
    rows = run_tasks(_burn, [{"s": 0.2, "k": k} for k in range(4)], out / "burn", workers=2, fresh=True)
    return Measurement({"tasks": len(rows)}, True, "stand-in")


def test_a_claims_cpu_time_counts_its_campaigns_workers(tmp_path):
    """cpu_s is what the claim cost: the 0.8 s its pool's workers spent,
    though the measuring process itself only waited for them (its own CPU
    time alone would say a fraction of that)."""
    t0 = time.process_time()
    row = rp.measure(CLAIMS[0], tmp_path, campaign)
    own = time.process_time() - t0
    assert row["value"] == {"tasks": 4}
    assert row["cpu_s"] >= 0.8 and row["cpu_s"] >= own + 0.75
