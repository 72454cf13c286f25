"""Wall time of fullspeed against motulator on motulator's own example.

The peer scenario is motulator's examples/drive/flux_vector/plot_2kw_ipmsm_fvc.py
(2.2 kW IPMSM, 540 V, 125 us sampling, sensorless speed control, 0 -> 2 p.u.
at 0.2 s, 0.7 x 14 N m at 0.8 s, 1.6 s). fullspeed runs the same machine,
profile and sampling (catalog scenario bench-motulator-2kw: its SMO with an
I/f start and flux weakening) once with the averaged and once with the
switching inverter; motulator runs with pwm=False and pwm=True. Runs
alternate (motulator, fullspeed, motulator, ...) so that a slow moment of the
machine hits both sides, and each pair's ratio is the ratio of the medians.

motulator 0.18 needs Python >= 3.12: the bench finds one (PATH, then pyenv),
makes a virtual environment for it under bench/.venv-motulator and installs
motulator there, or skips saying why. Timed on both sides: the simulation
call alone (motulator's sim.simulate; fullspeed's simulate, which also
collects every trace channel at every sample and computes the metrics),
not interpreter start-up or imports.

Usage: python bench/wall.py [--repeat N]
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
MOTULATOR = "motulator==0.18.0"
SCENARIO = "bench-motulator-2kw"
PAIRS = (("averaged", 0), ("switching", 1))   # fullspeed inverter, motulator pwm
GOALS = {"averaged": 500.0, "switching": 300.0}


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
    raise Skip("no Python >= 3.12 found (PATH or pyenv), which motulator 0.18 needs")


def peer_python() -> str:
    """motulator's interpreter, creating its virtual environment if needed."""
    py = VENV / "bin" / "python"
    ok = py.exists() and subprocess.run([str(py), "-c", "import motulator"], capture_output=True).returncode == 0
    if ok:
        return str(py)
    base = find_python312()
    steps = ([base, "-m", "venv", "--clear", str(VENV)],
             [str(py), "-m", "pip", "install", "-q", MOTULATOR])
    for cmd in steps:
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            last = (r.stderr.strip().splitlines() or ["(no output)"])[-1]
            raise Skip(f"could not set up motulator ({' '.join(cmd[-2:])}): {last}")
    return str(py)


def run_peer(py: str, pwm: int) -> dict:
    env = dict(os.environ, TQDM_DISABLE="1")
    r = subprocess.run([py, str(PEER), "--pwm", str(pwm)], capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise RuntimeError(f"motulator run failed: {(r.stderr.strip().splitlines() or ['?'])[-1]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def run_fullspeed(inverter: str) -> dict:
    import numpy as np
    import fullspeed.sim as fs
    from fullspeed.design.scenario import load_scenario
    sc = load_scenario(SCENARIO, {"converter": {"inverter": inverter}})
    t0 = time.perf_counter()
    res = fs.simulate(sc)
    wall = time.perf_counter() - t0
    speed = {f"{x:g}": float(np.interp(x, res["t"], res["w_m"]) * 60 / (2 * np.pi)) for x in (0.4, 0.8, 1.2, 1.59)}
    return {"wall_s": wall, "speed_rpm": speed, "stop": res.stop_reason}


def wall_report(repeat: int = 3) -> dict:
    try:
        py = peer_python()
    except Skip as exc:
        return {"status": "skipped", "reason": str(exc)}
    run_fullspeed("averaged")            # build caches, first-call costs
    pairs = {}
    for inverter, pwm in PAIRS:
        peer, ours = [], []
        for _ in range(repeat):
            peer.append(run_peer(py, pwm))
            ours.append(run_fullspeed(inverter))
        m_peer = statistics.median(r["wall_s"] for r in peer)
        m_ours = statistics.median(r["wall_s"] for r in ours)
        ratio = m_peer / m_ours
        pairs[inverter] = {
            "motulator": {"pwm": bool(pwm), "wall_s": [r["wall_s"] for r in peer], "median_s": m_peer,
                          "speed_rpm": peer[-1].get("speed_rpm")},
            "fullspeed": {"inverter": inverter, "wall_s": [r["wall_s"] for r in ours], "median_s": m_ours,
                          "speed_rpm": ours[-1]["speed_rpm"], "stop": ours[-1]["stop"]},
            "ratio": ratio, "goal": GOALS[inverter], "met": ratio >= GOALS[inverter],
            "sim_s_per_wall_s": {"motulator": 1.6 / m_peer, "fullspeed": 1.6 / m_ours},
        }
    # every fullspeed model against every motulator model (the pairs above are the diagonal)
    peer_s = {p["motulator"]["pwm"]: p["motulator"]["median_s"] for p in pairs.values()}
    cross = {f"{inv} vs pwm={pwm}": peer_s[pwm] / pairs[inv]["fullspeed"]["median_s"]
             for inv in pairs for pwm in (False, True)}
    return {"status": "ok", "repeat": repeat, "peer": MOTULATOR, "python": py, "pairs": pairs, "ratios": cross}


def format_report(rep: dict) -> str:
    if rep["status"] != "ok":
        return f"wall time vs motulator: skipped: {rep['reason']}"
    lines = [f"wall time vs {rep['peer']} on its 2.2 kW IPMSM example (1.6 s simulated), median of {rep['repeat']} alternating runs"]
    lines.append(f"  {'pair':<28}{'motulator':>11}{'fullspeed':>11}{'ratio':>9}   goal")
    for inv, p in rep["pairs"].items():
        label = f"{inv} / pwm={p['motulator']['pwm']}"
        lines.append(f"  {label:<28}{p['motulator']['median_s']:>10.3f}s{p['fullspeed']['median_s']:>10.4f}s"
                     f"{p['ratio']:>8.0f}x   >= {p['goal']:.0f}x: {'met' if p['met'] else 'NOT met'}")
    lines.append("  all four ratios (motulator median / fullspeed median): "
                 + ", ".join(f"{k} {v:.0f}x" for k, v in rep["ratios"].items()))
    for inv, p in rep["pairs"].items():
        ms, fs_ = p["motulator"]["speed_rpm"] or {}, p["fullspeed"]["speed_rpm"]
        row = "  ".join(f"{t} s: {ms.get(t, float('nan')):.0f}/{fs_[t]:.0f}" for t in fs_)
        lines.append(f"  speed rpm motulator/fullspeed ({inv}): {row}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs per side and pair (default 3)")
    a = ap.parse_args(argv)
    if a.repeat < 1:
        print(f"--repeat = {a.repeat}: must be >= 1", file=sys.stderr)
        return 2
    rep = wall_report(a.repeat)
    print(format_report(rep))
    return 0


if __name__ == "__main__":
    sys.exit(main())
