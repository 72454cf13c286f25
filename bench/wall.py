"""Wall time of fullspeed against both of its peers on motulator's own example.

The example is motulator's examples/drive/flux_vector/plot_2kw_ipmsm_fvc.py
(2.2 kW IPMSM, 540 V, 125 us sampling, sensorless speed control, 0 -> 2 p.u.
at 0.2 s, 0.7 x 14 N m at 0.8 s, 1.6 s). Three engines run it, each once
with the averaged converter and once with the switching one:

  motulator         motulator 0.18's own Simulation (Python), pwm=False/True
  motulator-export  motulator-export 0.11's native.Simulation: the same
                    motulator system, the same RK45 steps, simulated in C
  fullspeed         catalog scenario bench-motulator-2kw (the same machine,
                    profile and sampling; its SMO with an I/f start and flux
                    weakening), inverter = averaged / switching

Runs alternate, round by round (motulator, motulator-export, fullspeed, ...),
so that a slow moment of the machine hits every engine; each engine's figure
is the min / median / max over the rounds, each ratio (peer / fullspeed) the
ratio of the medians, with the round-by-round (paired) ratios' spread beside.

Trajectory check: the speed at a few instants must agree. motulator-export
simulates motulator's own system, so it must agree with motulator at every
instant; fullspeed runs its own controller, so it must agree where the
reference is held (0.8, 1.2, 1.59 s: at 3000 rpm, before and after the load
step), within TOL_RPM. At 0.4 s the drives are still accelerating, each at
its own controller's pace: shown, not checked. A disagreement fails the
report (status "fail"): a fast wrong answer is not a result.

Timed on every side: the simulation call alone (motulator's and
motulator-export's sim.simulate, which fill motulator's time series;
fullspeed's simulate, which also collects every trace channel at every
sample), after one untimed warm-up of each engine, not interpreter start-up
or imports. fullspeed's metrics are formed at their first read
(Result.metrics), which the bench times apart after the call: the report
gives them and the ratios the call and that read together would have.

The peers need Python >= 3.12: the bench finds one (PATH, then pyenv), makes
a virtual environment for it under bench/.venv-motulator and installs both
peers there, or skips saying why.

Usage: python bench/wall.py [--repeat N] [--engines motulator,motulator-export,fullspeed]
       python bench/wall.py --fullspeed-only averaged|switching [--runs N]
(the second form runs fullspeed's side alone and prints one JSON line a run,
for a whole-process timer; the peers' side alone is bench/motulator_peer.py.)
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
PEER = HERE / "motulator_peer.py"
VENV = HERE / ".venv-motulator"
PEERS = ("motulator==0.18.0", "motulator-export==0.11.0")
SCENARIO = "bench-motulator-2kw"
ENGINES = ("motulator", "motulator-export", "fullspeed")
PEER_ENGINE = {"motulator": "python", "motulator-export": "native"}   # motulator_peer.py --engine
MODES = (("averaged", 0), ("switching", 1))   # fullspeed inverter, motulator pwm
GOALS = {("motulator", "averaged"): 500.0, ("motulator", "switching"): 300.0,
         ("motulator-export", "averaged"): 30.0, ("motulator-export", "switching"): 30.0}
INSTANTS = ("0.4", "0.8", "1.2", "1.59")     # s, as motulator_peer.py formats them
HELD = ("0.8", "1.2", "1.59")                # the reference is held at 3000 rpm here
TOL_RPM = 30.0                               # 1 % of the 3000 rpm the reference holds


class Skip(Exception):
    """The peer cannot run here; the message says why."""


def _python_ok(exe: str) -> bool:
    try:
        out = subprocess.run([exe, "-c", "import sys; print(sys.version_info >= (3, 12))"],
                             capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return out.stdout.strip() == "True"


def find_python312() -> str:
    """A Python >= 3.12: on PATH, else among pyenv's versions."""
    candidates = [shutil.which(n) for n in ("python3.13", "python3.12")]
    roots = [os.environ.get("PYENV_ROOT", ""), str(Path.home() / ".pyenv")]
    for root in roots:
        if root:
            candidates += sorted(glob.glob(f"{root}/versions/3.1[2-9]*/bin/python"), reverse=True)
    for exe in candidates:
        if exe and _python_ok(exe):
            return exe
    raise Skip("no Python >= 3.12 found (PATH or pyenv), which motulator 0.18 and motulator-export 0.11 need")


def _setup(cmds: list[list[str]]) -> None:
    for cmd in cmds:
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            last = (r.stderr.strip().splitlines() or ["(no output)"])[-1]
            raise Skip(f"could not set up the peers ({' '.join(cmd[-2:])}): {last}")


def peer_python() -> str:
    """The peers' interpreter, creating their virtual environment (or adding
    the missing peer to it) if needed."""
    py = VENV / "bin" / "python"
    probe = "import motulator, motulator_export.native"
    if py.exists() and subprocess.run([str(py), "-c", probe], capture_output=True).returncode == 0:
        return str(py)
    install = [str(py), "-m", "pip", "install", "-q", *PEERS]
    if py.exists() and subprocess.run([str(py), "-c", "import sys"], capture_output=True).returncode == 0:
        _setup([install])
    else:
        _setup([[find_python312(), "-m", "venv", "--clear", str(VENV)], install])
    return str(py)


def run_peer(py: str, engine: str, pwm: int) -> dict:
    """One timed run of a peer (its own process: warm-up, then the run)."""
    env = dict(os.environ, TQDM_DISABLE="1")
    cmd = [py, str(PEER), "--engine", PEER_ENGINE[engine], "--pwm", str(pwm)]
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise RuntimeError(f"{engine} run failed: {(r.stderr.strip().splitlines() or ['?'])[-1]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def run_fullspeed(inverter: str) -> dict:
    import numpy as np
    import fullspeed.sim as fs
    from fullspeed.design.scenario import load_scenario
    sc = load_scenario(SCENARIO, {"converter": {"inverter": inverter}})
    t0 = time.perf_counter()
    res = fs.simulate(sc)
    wall = time.perf_counter() - t0
    speed = {x: float(np.interp(float(x), res["t"], res["w_m"]) * 60 / (2 * np.pi)) for x in INSTANTS}
    t1 = time.perf_counter()
    res.metrics                              # formed at the first read: timed apart, reported beside
    metrics = time.perf_counter() - t1
    return {"wall_s": wall, "metrics_s": metrics, "samples": len(res["t"]), "speed_rpm": speed, "stop": res.stop_reason}


def spread(xs: list[float]) -> dict:
    """min / median / max of a list of figures."""
    return {"min": min(xs), "median": statistics.median(xs), "max": max(xs), "n": len(xs)}


def trajectory_check(speeds: dict[str, dict[str, float]], tol: float = TOL_RPM) -> dict:
    """Each engine's speed (rpm at INSTANTS) against motulator's (or, without
    it, motulator-export's): the peers at every instant, fullspeed where the
    reference is held. ok is False on a difference above tol or a missing
    figure (a NaN compares as a disagreement)."""
    ref_engine = next((e for e in ("motulator", "motulator-export") if e in speeds), None)
    rows, ok = [], True
    for engine, sp in speeds.items():
        if engine == ref_engine or ref_engine is None:
            continue
        for x in (HELD if engine == "fullspeed" else INSTANTS):
            a, b = speeds[ref_engine].get(x, float("nan")), sp.get(x, float("nan"))
            diff = abs(b - a)
            good = diff <= tol      # False for NaN
            ok = ok and good
            rows.append({"engine": engine, "against": ref_engine, "t": x, "rpm": b, "ref_rpm": a,
                         "diff_rpm": diff, "ok": good})
    return {"ok": ok, "tol_rpm": tol, "rows": rows, "reference": ref_engine}


def pair_report(runs: dict[str, list[dict]], mode: str) -> dict:
    """One mode's figures from its rounds: each engine's spread, each peer's
    ratio to fullspeed (medians, and the paired ratios' spread), the goals
    and the trajectory check on the last round."""
    out = {"engines": {}, "ratios": {}}
    for engine, rs in runs.items():
        out["engines"][engine] = {"wall_s": [r["wall_s"] for r in rs], **spread([r["wall_s"] for r in rs]),
                                  "speed_rpm": rs[-1]["speed_rpm"], "stop": rs[-1].get("stop", "done")}
    if "fullspeed" in runs:
        ours = out["engines"]["fullspeed"]
        with_metrics = None      # the call and the metrics' first read, each round's sum
        if all("metrics_s" in r for r in runs["fullspeed"]):
            ours["metrics_s"] = spread([r["metrics_s"] for r in runs["fullspeed"]])
            with_metrics = spread([r["wall_s"] + r["metrics_s"] for r in runs["fullspeed"]])
        for engine in runs:
            if engine == "fullspeed":
                continue
            paired = [p["wall_s"] / f["wall_s"] for p, f in zip(runs[engine], runs["fullspeed"])]
            ratio = out["engines"][engine]["median"] / ours["median"]
            goal = GOALS[(engine, mode)]
            out["ratios"][engine] = {"ratio": ratio, "paired": spread(paired), "goal": goal, "met": ratio >= goal}
            if with_metrics is not None:
                out["ratios"][engine]["ratio_with_metrics"] = out["engines"][engine]["median"] / with_metrics["median"]
    out["trajectory"] = trajectory_check({e: r["speed_rpm"] for e, r in out["engines"].items()})
    if "fullspeed" in runs and out["engines"]["fullspeed"]["stop"] != "done":
        out["trajectory"]["ok"] = False
    return out


def load_average() -> list[float] | None:
    try:
        return list(os.getloadavg())
    except OSError:
        return None


def wall_report(repeat: int = 3, engines: tuple[str, ...] = ENGINES) -> dict:
    peers = [e for e in engines if e != "fullspeed"]
    py = None
    if peers:
        try:
            py = peer_python()
        except Skip as exc:
            if "fullspeed" not in engines:
                return {"status": "skipped", "reason": str(exc)}
            skipped, peers = str(exc), []
    load0 = load_average()
    if "fullspeed" in engines:
        run_fullspeed("averaged")            # build caches, first-call costs
    if "motulator-export" in peers:
        run_peer(py, "motulator-export", 0)  # it compiles its library once, into its own cache
    modes = {}
    runs = {mode: {e: [] for e in (*peers, *(["fullspeed"] if "fullspeed" in engines else []))} for mode, _ in MODES}
    for _ in range(repeat):
        for inverter, pwm in MODES:
            for engine in peers:
                runs[inverter][engine].append(run_peer(py, engine, pwm))
            if "fullspeed" in engines:
                runs[inverter]["fullspeed"].append(run_fullspeed(inverter))
    for inverter, _ in MODES:
        modes[inverter] = pair_report(runs[inverter], inverter)
    ok = all(m["trajectory"]["ok"] for m in modes.values())
    rep = {"status": "ok" if ok else "fail", "repeat": repeat, "peers": list(PEERS), "python": py,
           "engines": [e for e in ENGINES if e in runs["averaged"]], "modes": modes,
           "load_average": {"before": load0, "after": load_average()}}
    if not ok:
        rep["reason"] = "the engines' speeds disagree (trajectory check): the timings do not compare the same job"
    if peers != [e for e in engines if e != "fullspeed"]:
        rep["peers_skipped"] = skipped
    return rep


def format_report(rep: dict) -> str:
    if rep["status"] == "skipped":
        return f"wall time vs motulator and motulator-export: skipped: {rep['reason']}"
    engines = rep["engines"]
    load = rep["load_average"]["before"]
    lines = [f"wall time on motulator's 2.2 kW IPMSM example (1.6 s simulated, 125 us sampling), "
             f"{rep['repeat']} alternating rounds; {' '.join(rep['peers'])}"
             + (f"; load average {load[0]:.2f} before" if load else "")]
    if rep.get("peers_skipped"):
        lines.append(f"  peers skipped: {rep['peers_skipped']}")
    lines.append(f"  {'mode':<11}" + "".join(f"{e + ' s (min/med/max)':>34}" for e in engines))
    for mode, m in rep["modes"].items():
        cells = "".join(f"{'%.4f / %.4f / %.4f' % (m['engines'][e]['min'], m['engines'][e]['median'], m['engines'][e]['max']):>34}"
                        for e in engines)
        lines.append(f"  {mode:<11}{cells}")
    for mode, m in rep["modes"].items():
        for peer, r in m["ratios"].items():
            p = r["paired"]
            lines.append(f"  {mode:<11}fullspeed vs {peer:<17}{r['ratio']:>7.1f}x  (paired {p['min']:.1f}..{p['max']:.1f}x)"
                         f"   goal >= {r['goal']:.0f}x: {'met' if r['met'] else 'NOT met'}"
                         + (f"; {r['ratio_with_metrics']:.1f}x with the metrics read" if "ratio_with_metrics" in r else ""))
    for mode, m in rep["modes"].items():
        ms = m["engines"].get("fullspeed", {}).get("metrics_s")
        if ms:
            lines.append(f"  {mode:<11}fullspeed's metrics at their first read, after the call (not in its time): "
                         f"{1e3 * ms['min']:.2f} / {1e3 * ms['median']:.2f} / {1e3 * ms['max']:.2f} ms")
    for mode, m in rep["modes"].items():
        tr = m["trajectory"]
        row = "; ".join(f"{e} " + "/".join(f"{m['engines'][e]['speed_rpm'].get(x, float('nan')):.0f}" for x in INSTANTS)
                        for e in engines)
        lines.append(f"  speed rpm at {'/'.join(INSTANTS)} s ({mode}): {row}; "
                     f"check (fullspeed at {'/'.join(HELD)} s, where the reference is held; within {tr['tol_rpm']:.0f} rpm "
                     f"of {tr['reference']}): {'ok' if tr['ok'] else 'FAILED'}")
    if rep["status"] == "fail":
        lines.append(f"  FAIL: {rep['reason']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="rounds (default 3)")
    ap.add_argument("--engines", default=",".join(ENGINES), help="comma-separated, among " + ", ".join(ENGINES))
    ap.add_argument("--fullspeed-only", choices=[m for m, _ in MODES],
                    help="run fullspeed's side alone in this mode, one JSON line a run")
    ap.add_argument("--runs", type=int, default=1, help="with --fullspeed-only: timed runs (default 1)")
    a = ap.parse_args(argv)
    engines = tuple(e.strip() for e in a.engines.split(",") if e.strip())
    bad = [e for e in engines if e not in ENGINES]
    if a.repeat < 1 or a.runs < 1 or bad or not engines:
        what = (f"--engines = {a.engines}: must be among {', '.join(ENGINES)}" if bad or not engines
                else f"--repeat = {a.repeat}, --runs = {a.runs}: must be >= 1")
        print(what, file=sys.stderr)
        return 2
    if a.fullspeed_only:
        run_fullspeed(a.fullspeed_only)      # the same warm-up as the peers'
        for _ in range(a.runs):
            print(json.dumps({"engine": "fullspeed", **run_fullspeed(a.fullspeed_only)}), flush=True)
        return 0
    rep = wall_report(a.repeat, engines)
    print(format_report(rep))
    return 1 if rep["status"] == "fail" else 0


if __name__ == "__main__":
    sys.exit(main())
