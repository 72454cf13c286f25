"""Where fullspeed's time goes on the wall bench's example, per simulated sample.

The example is bench/wall.py's: catalog scenario bench-motulator-2kw (1.6 s,
125 us sampling: 12,800 samples), averaged and switching inverter. Each
simulate() call is split into

  control   fs_drive_step: the drive's step (csrc/control)
  plant     the plant's integration over each period: fs_sim.c's
            integrate_period (integrate_period_imc with the matrix
            converter) with all it runs: the RK4 steps, the inverter's
            model (fs_inverter_*), the phase currents the switching model
            needs at each segment, the load's profile look-ups
  tracing   writing the trace rows (csrc/sim: row_plant, row_drive): the
            difference between the run as it is and the same run tracing
            one row in all
  runner    the rest of fs_sim_run (csrc/sim): sampling the sensors and the
            profiles, the delay, the stop checks, the angle's wrap
  metrics   compute_metrics on the traces (src/fullspeed/sim/metrics.py),
            which simulate() leaves to the first read of Result.metrics:
            counted here as read (each simulate() below is followed by it)
  front     the rest of simulate(): the C config, fs_sim_create (the drive's
            design), the chunked calls, the trace buffer, the Result

counted in instructions by valgrind's callgrind (deterministic: the same on
a busy machine), each part as the difference between a Python driver that
does N more of it and one that does not (imports, scenario loading and a
warm-up are in both and cancel). Instructions are not time: the parts run at
different rates (the plant's doubles pipeline well, the metrics' NumPy calls
stream memory), so the report gives each part's nanoseconds as its share of
a wall time measured here alongside (the C loop timed apart from the metrics
and the front), and says so.

Usage: python bench/breakdown.py [--runs N] [--timing-runs N]
       python bench/breakdown.py --driver WHAT INVERTER N   (what callgrind runs)
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve()
SCENARIO = "bench-motulator-2kw"
MODES = ("averaged", "switching")
WHATS = ("base", "simulate", "metrics", "notrace")
# The plant: the function that holds the integration, counted inclusive. Not the plant's own functions by
# name (fs_pmsm_rk4_at, fs_inverter_segments, ...): the core is built with link-time optimisation, and the
# inliner takes some of them into their caller (at 200 instructions, fs_inverter_segments went into
# integrate_period, and the split by names moved 498 instructions a sample from the plant to the runner).
PLANT_FNS = ("integrate_period", "integrate_period_general", "integrate_period_imc")
# Where the runner inlines the integration itself (fs_sim.c's FS_SPECIALISE: the averaged inverter's ideal
# period, integrate_period_ideal, since 28e53ed) no function holds it: the plant is then the machine's RK4 step,
# which it calls, and the period's own few instructions around it (the inputs, the mean voltage) are the runner's
PLANT_CALLEES = ("fs_pmsm_rk4_at",)
ONE_ROW = 1_000_000          # trace.decimation that leaves one row of the run
LOOP_FNS = ("fs_sim_run_steps", "fs_sim_run_cols")   # the runner's loop: row-major (fs_sim_run's), column-major (the front's)
WARM_RUNS = 2                # runs every driver makes first: simulate() and the one-row run


# --- the driver callgrind runs ---------------------------------------------------

def advance_all(sim, T: float) -> str:
    """The chunked advance of simulate() (chunks of T / 100, counted in
    periods by the core's rule), without the metrics: the run's status."""
    n_end, st = sim.steps(T), "running"
    n_chunk = max(1, sim.steps(max(T / 100.0, 1e-3)))
    while sim.step_count < n_end and st == "running":
        st = sim.advance_steps(min(sim.step_count + n_chunk, n_end))
    return st


def driver(what: str, inverter: str, n: int) -> None:
    import fullspeed.sim as fs
    from fullspeed.design.scenario import load_scenario
    from fullspeed.sim.metrics import compute_metrics
    from fullspeed.sim.runner import Simulation
    ov = {"converter": {"inverter": inverter}}
    sc = load_scenario(SCENARIO, ov)
    sc_one = load_scenario(SCENARIO, {**ov, "trace": {"decimation": ONE_ROW}})

    def bare(s):     # the C loop as simulate() drives it, without the metrics
        sim = Simulation(s)
        advance_all(sim, s.duration)
        return sim

    res = fs.simulate(sc)          # warm-up, in every driver
    bare(sc_one)
    for _ in range(n if what != "base" else 0):
        if what == "simulate":
            fs.simulate(sc).metrics   # the call and its metrics' first read
        elif what == "metrics":
            compute_metrics(res)
        else:
            bare(sc_one)


# --- callgrind and its annotation -------------------------------------------------

def callgrind(what: str, inverter: str, n: int, workdir: Path) -> Path:
    out = workdir / f"cg.{what}.{inverter}.{n}"
    env = dict(os.environ, PYTHONHASHSEED="0")
    cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", sys.executable, str(HERE),
           "--driver", what, inverter, str(n)]
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise RuntimeError(f"callgrind {what} {inverter}: {(r.stderr.strip().splitlines() or ['?'])[-1]}")
    return out


_LINE = re.compile(r"^\s*([\d,]+)\s+(?:\([^)]*\)\s+)?([<*>])?\s*(\S+?):(\S+?)(?:\s+\((\d[\d,]*)x\))?(?:\s+\[|\s*$)")


def parse_annotation(text: str) -> dict:
    """callgrind_annotate --inclusive=yes --tree=caller output: the total,
    each function's inclusive count and, per (caller, callee), the count of
    the calls and their inclusive instructions."""
    total = None
    m = re.search(r"^\s*([\d,]+)(?:\s+\([^)]*\))?\s+PROGRAM TOTALS", text, re.M)
    if m:
        total = int(m.group(1).replace(",", ""))
    incl, calls, caller_block = {}, {}, []
    for line in text.splitlines():
        g = _LINE.match(line)
        if not g:
            if not line.strip():
                caller_block = []
            continue
        cost, mark, fn = int(g.group(1).replace(",", "")), g.group(2), g.group(4)
        if mark == "<":
            caller_block.append((fn, cost, int((g.group(5) or "0").replace(",", ""))))
        elif mark == "*":
            incl[fn] = max(incl.get(fn, 0), cost)
            for caller, c, k in caller_block:
                calls[(caller, fn)] = (c, k)
            caller_block = []
    return {"total": total, **by_base_name(incl, calls)}


def base_name(fn: str) -> str:
    """A function's name without the suffixes GCC gives its copies under
    link-time optimisation and cloning (fs_sim_run_cols.part.0.constprop.0,
    advance.lto_priv.0, fs_drive_step.localalias): the name in the source."""
    return fn.split(".", 1)[0]


def by_base_name(incl: dict, calls: dict) -> dict:
    """incl and calls keyed by base_name: a function's copies (a clone and the
    wrapper that calls it, an alias) summed, less the calls between copies
    (the wrapper's inclusive count holds its clone's)."""
    out_incl, out_calls = {}, {}
    for fn, cost in incl.items():
        out_incl[base_name(fn)] = out_incl.get(base_name(fn), 0) + cost
    for (caller, callee), (cost, count) in calls.items():
        a, b = base_name(caller), base_name(callee)
        if a == b:
            out_incl[a] -= cost
            continue
        c0, k0 = out_calls.get((a, b), (0, 0))
        out_calls[(a, b)] = (c0 + cost, k0 + count)
    return {"incl": out_incl, "calls": out_calls}


def annotate(path: Path) -> dict:
    r = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--tree=caller", "--threshold=100", str(path)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"callgrind_annotate {path.name}: {(r.stderr.strip().splitlines() or ['?'])[-1]}")
    return parse_annotation(r.stdout)


def plant_ir(a: dict, fns: tuple[str, ...] = PLANT_FNS) -> int:
    """The plant's instructions in one annotation: the integration's
    function, inclusive (PLANT_FNS), or where the runner inlined it the
    functions it calls (PLANT_CALLEES). The runner's stop check's phase
    currents, computed outside it, stay the runner's."""
    return sum(a["incl"].get(f, 0) for f in fns)


def split(base: dict, sim: dict, met: dict, one: dict, n: int, samples: int) -> dict:
    """Per sample, each part's instructions, from the four annotations."""
    def d(a, *keys):      # per run, the difference to the base driver
        return sum(a["incl"].get(k, 0) - base["incl"].get(k, 0) for k in keys) / n

    total = (sim["total"] - base["total"]) / n
    c_loop = d(sim, *LOOP_FNS)
    control = d(sim, "fs_drive_step")
    fns = PLANT_FNS if any(f in sim["incl"] for f in PLANT_FNS) else PLANT_CALLEES
    if not any(f in sim["incl"] for f in fns):
        raise RuntimeError(f"none of {', '.join(PLANT_FNS + PLANT_CALLEES)} in the profile: "
                           "the plant cannot be told apart from the runner")
    plant = (plant_ir(sim, fns) - plant_ir(base, fns)) / n
    tracing = c_loop - d(one, *LOOP_FNS)
    metrics = (met["total"] - base["total"]) / n
    parts = {"control": control, "plant": plant, "tracing": tracing,
             "runner": c_loop - control - plant - tracing, "metrics": metrics, "front": total - c_loop - metrics}
    return {"per_run": total, "c_loop_per_run": c_loop, "plant_counted_as": list(fns),
            "per_sample": {k: v / samples for k, v in parts.items()}, "total_per_sample": total / samples}


# --- wall time beside the counts ---------------------------------------------------

def wall_parts(inverter: str, runs: int) -> dict:
    """Median wall seconds of the C loop alone (the chunked advance), of
    compute_metrics and of the whole simulate() with its metrics read, in
    alternation."""
    import fullspeed.sim as fs
    from fullspeed.design.scenario import load_scenario
    from fullspeed.sim.metrics import compute_metrics
    from fullspeed.sim.runner import Result, Simulation
    sc = load_scenario(SCENARIO, {"converter": {"inverter": inverter}})
    fs.simulate(sc)
    loop, metrics, whole = [], [], []
    for _ in range(runs):
        sim = Simulation(sc)
        t0 = time.perf_counter()
        st = advance_all(sim, sc.duration)
        t1 = time.perf_counter()
        res = Result(sc, sim.traces(), st, sim.stop_time, t1 - t0, sim.time)
        t2 = time.perf_counter()
        compute_metrics(res)
        t3 = time.perf_counter()
        fs.simulate(sc).metrics
        t4 = time.perf_counter()
        loop.append(t1 - t0), metrics.append(t3 - t2), whole.append(t4 - t3)
    return {"c_loop_s": statistics.median(loop), "metrics_s": statistics.median(metrics),
            "simulate_s": statistics.median(whole), "runs": runs}


def nanoseconds(per_sample: dict, wall: dict, samples: int) -> dict:
    """Each part's ns per sample: the C parts share the C loop's measured
    time by their instructions; metrics measured; the front the remainder."""
    c_parts = ("control", "plant", "tracing", "runner")
    c_ir = sum(per_sample[k] for k in c_parts)
    ns_loop = 1e9 * wall["c_loop_s"] / samples
    out = {k: ns_loop * per_sample[k] / c_ir for k in c_parts}
    out["metrics"] = 1e9 * wall["metrics_s"] / samples
    out["front"] = max(1e9 * wall["simulate_s"] / samples - ns_loop - out["metrics"], 0.0)
    return out


def breakdown_report(runs: int = 2, timing_runs: int = 20) -> dict:
    missing = [t for t in ("valgrind", "callgrind_annotate") if shutil.which(t) is None]
    if missing:
        return {"status": "skipped", "reason": f"{', '.join(missing)} not found (apt-get install valgrind)"}
    import fullspeed.sim as fs
    samples = len(fs.simulate(SCENARIO)["t"])     # one row a sample: 12,800
    modes = {}
    with tempfile.TemporaryDirectory(prefix="fs-breakdown-") as tmp:
        for inverter in MODES:
            a = {w: annotate(callgrind(w, inverter, runs, Path(tmp))) for w in WHATS}
            rep = split(a["base"], a["simulate"], a["metrics"], a["notrace"], runs, samples)
            rep["wall"] = wall_parts(inverter, timing_runs)
            rep["ns_per_sample"] = nanoseconds(rep["per_sample"], rep["wall"], samples)
            modes[inverter] = rep
    return {"status": "ok", "scenario": SCENARIO, "samples": samples, "runs": runs, "modes": modes,
            "load_average": list(os.getloadavg())}


def format_report(rep: dict) -> str:
    if rep["status"] != "ok":
        return f"per-sample breakdown: skipped: {rep['reason']}"
    lines = [f"where fullspeed's time goes per simulated sample ({rep['scenario']}, {rep['samples']} samples; "
             f"instructions by callgrind, ns as each part's share of the wall time measured beside, "
             f"load average {rep['load_average'][0]:.2f})"]
    parts = ("control", "plant", "runner", "tracing", "metrics", "front")
    lines.append(f"  {'mode':<11}" + "".join(f"{p:>16}" for p in parts) + f"{'total':>16}")
    for mode, m in rep["modes"].items():
        ir, ns = m["per_sample"], m["ns_per_sample"]
        cells = "".join(f"{'%6.0f /%5.0f ns' % (ir[p], ns[p]):>16}" for p in parts)
        lines.append(f"  {mode:<11}{cells}{'%6.0f /%5.0f ns' % (m['total_per_sample'], sum(ns.values())):>16}")
    lines.append("  (instructions / ns per sample; the C loop's ns apportioned by instructions)")
    for mode, m in rep["modes"].items():
        if m["plant_counted_as"] == list(PLANT_CALLEES):
            lines.append(f"  {mode}: the period's integration is inlined into the runner; the plant is "
                         f"{', '.join(PLANT_CALLEES)}, the period's own instructions around it the runner's")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=2, help="simulate() calls each callgrind driver adds (default 2)")
    ap.add_argument("--timing-runs", type=int, default=20, help="timed runs for the ns (default 20)")
    ap.add_argument("--driver", nargs=3, metavar=("WHAT", "INVERTER", "N"), help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.driver:
        driver(a.driver[0], a.driver[1], int(a.driver[2]))
        return 0
    if a.runs < 1 or a.timing_runs < 1:
        print(f"--runs = {a.runs}, --timing-runs = {a.timing_runs}: must be >= 1", file=sys.stderr)
        return 2
    rep = breakdown_report(a.runs, a.timing_runs)
    print(format_report(rep))
    return 0


if __name__ == "__main__":
    sys.exit(main())
