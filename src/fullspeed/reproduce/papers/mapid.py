"""B-MAPID's second half: the identified map in the controller against the
true map's, on B-REAL's full-range scenario.

For each zoo machine identified at standstill (workflows.identify's
zoo_campaign writes its machine.toml and fluxmap.csv), B-REAL's scenario
(reproduce.papers.real.real_scenario: standstill start under half the rated
torque, acceleration into flux weakening, a load step to 0.8 of the
envelope at 1.5 x base speed, reversal under load) runs sensorless twice
on the same plant, the true machine: once with the drive designed from the
true machine (its map), once with the drive designed from the identified
machine file (plant_machine the true one). The same scenario data both
times (built from the true machine), the sensorless angle the design
accepts for the true machine on both.
"""
from __future__ import annotations

import copy
from pathlib import Path

from ...design.scenario import scenario_from_dict
from ...model.errors import ConfigError
from ...model.zoo import machine as zoo_machine
from ...sim.runner import simulate
from ...workflows.journal import run_tasks
from .common import sweep_dir
from .real import real_scenario, sensorless_angle

ANGLE_TOL = 1.0   # el.deg: the identified map's largest sensorless error within this of the true map's


def mapid_run(task: dict) -> dict:
    """journal.run_tasks' worker: zoo machine k on B-REAL's scenario, the
    drive designed from the true machine (which = "true") or from its
    identified machine file (which = "identified", the plant the true one)."""
    k, which = task["k"], task["which"]
    table = zoo_machine(k, task["seed"]) if task["seed"] is not None else zoo_machine(k)
    angle, refused = sensorless_angle(table)
    row = {"k": k, "which": which, "angle": angle}
    if angle is None:
        return {**row, "refused": refused}
    data, _ = real_scenario(table, angle)
    if which == "identified":
        data = {**data, "machine": task["machine_file"], "plant_machine": copy.deepcopy(table)}
    try:
        sc = scenario_from_dict(data, f"B-MAPID zoo {k} ({which})")
    except ConfigError as exc:
        return {**row, "refused": str(exc)}
    res = simulate(sc)
    mt = res.metrics
    return {**row, "refused": None, "stop_reason": res.stop_reason, "lock_lost_at": mt.get("lock_lost_at"),
            "err_max": mt.get("sensorless_err_deg_max"), "steady_mean": (mt.get("theta_err_deg") or {}).get("mean")}


mapid_run.journal_name = "fullspeed.reproduce.mapid"


def _outcome(run: dict) -> str:
    """Why a run is not a completed one, in a few words."""
    if run.get("refused"):
        return f"was refused ({run['refused']})"
    if run.get("stop_reason") != "done":
        return f"stopped: {run.get('stop_reason')}"
    return f"lost lock at {run['lock_lost_at']:.3f} s"


def verdict(t: dict, i: dict) -> dict:
    """One machine's true-map run t against its identified-map run i: not
    comparable where t did not complete without a loss of lock, outside
    where i did not (or its largest error exceeds t's by more than
    ANGLE_TOL), else within."""
    keys = ("stop_reason", "lock_lost_at", "err_max", "refused")
    row = {"true": {k: t.get(k) for k in keys}, "identified": {k: i.get(k) for k in keys}}
    done_t, done_i = (x.get("stop_reason") == "done" and x.get("lock_lost_at") is None for x in (t, i))
    if not done_t:
        return {**row, "verdict": f"not comparable: the true map's run {_outcome(t)}"}
    if not done_i:
        return {**row, "verdict": f"outside: the identified map's run {_outcome(i)}"}
    d = i["err_max"] - t["err_max"]
    return {**row, "diff_deg": d, "verdict": "within" if d <= ANGLE_TOL else "outside"}


def identified_against_true(rows: list[dict], out: Path, seed: int | None = None) -> dict:
    """The rows' machines with a machine file, each run on the true and the
    identified map (mapid_run), and the comparison: per machine both
    largest errors and whether the identified one is within ANGLE_TOL of the
    true one's; a machine whose true-map run does not complete is not
    comparable (B-REAL's own finding), one whose identified run does not
    complete where the true one does is outside."""
    files = [r for r in rows if r.get("machine_file")]
    tasks = [{"k": r["k"], "which": w, "seed": seed, "machine_file": r["machine_file"]}
             for r in files for w in ("true", "identified")]
    runs = run_tasks(mapid_run, tasks, sweep_dir(out, "B-MAPID-sensorless"), fresh=True)
    per = []
    for r in files:
        t, i = (next(x for x in runs if x and x.get("k") == r["k"] and x.get("which") == w) for w in ("true", "identified"))
        per.append({"k": r["k"], "angle": t.get("angle"), **verdict(t, i)})
    comparable = [p for p in per if not p["verdict"].startswith("not comparable")]
    return {"machines": len(per), "comparable": len(comparable),
            "within": sum(p["verdict"] == "within" for p in comparable), "rows": per}
