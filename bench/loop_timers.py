"""Wall time of the C loop's parts on the wall bench's example, per sample.

bench/breakdown.py counts instructions (deterministic) and shares the loop's
time out by them; this measures the time itself. A copy of a checkout's
src/ and csrc/ is built in a temporary folder with the processor's time
stamp counter (rdtsc) read around each part of fs_sim.c's loop:

  sample      the sampling instant: the sensors, the encoder, the
              references, the dc link (fs_sim.c sample)
  drive       fs_drive_step, the firmware's step (csrc/control)
  row         the duties' hand-over and the trace row (command, row_plant,
              row_drive)
  plant       the plant over the period (integrate_period), of which
  rk4         the machine's RK4 steps (fs_pmsm_rk4_at)
  checks      the rest of advance: the delayed duties, the angle's wrap, the
              finite and overcurrent checks (their phase currents, which the
              next sample takes)

and a plain copy beside it, built the same way without the counters: the
difference of the two loops is what the counters cost (a few ns a part),
which the parts include. The same copies time simulate() and the metrics'
first read, so that the front (simulate() less its loop) is measured too.
Each figure is the least of --runs runs (the least disturbed), with the
parts of the least-disturbed timed run. x86-64 with GCC only; the build
flags are the checkout's own (src/fullspeed/_build.py).

Usage: python bench/loop_timers.py [--runs N] [--inverter averaged|switching] [--src CHECKOUT]
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = "bench-motulator-2kw"
PARTS = ("sample", "drive", "row", "plant", "rk4", "checks")
COUNTERS = 8
# (anchor in fs_sim.c, its timed replacement): each anchor must stand exactly once
PATCHES = (
    ('#include "fs_profile.h"\n',
     '#include "fs_profile.h"\n#include <x86intrin.h>\nunsigned long long fs_tm[8];\n'),
    ("        double t = (double)s->k * s->Tc;\n        double i_ph[FS_INV_MAX_LEGS];\n",
     "        unsigned long long c0 = __rdtsc();\n        double t = (double)s->k * s->Tc;\n"
     "        double i_ph[FS_INV_MAX_LEGS];\n"),
    ("        fs_drive_step(&s->drive, &din, &dout);\n        command(s, dout.duty, &dout.rect);\n",
     "        unsigned long long c1 = __rdtsc();\n        fs_drive_step(&s->drive, &din, &dout);\n"
     "        unsigned long long c2 = __rdtsc();\n        fs_tm[0] += c1 - c0;\n        fs_tm[1] += c2 - c1;\n"
     "        command(s, dout.duty, &dout.rect);\n"),
    ("        int st = advance(s, t);\n",
     "        unsigned long long c3 = __rdtsc();\n        fs_tm[2] += c3 - c2;\n        int st = advance(s, t);\n"
     "        fs_tm[3] += __rdtsc() - c3;\n        fs_tm[7] += 1;\n"),
    ("    if (s->imc) integrate_period_imc(s, t); else integrate_period(s, t, cur_ok);\n",
     "    unsigned long long a0 = __rdtsc();\n"
     "    if (s->imc) integrate_period_imc(s, t); else integrate_period(s, t, cur_ok);\n"
     "    fs_tm[4] += __rdtsc() - a0;\n"),
    ("                fs_pmsm_rk4_at(&s->pmsm, s->x, &in, hstep, first);\n",
     "                unsigned long long r0 = __rdtsc();\n"
     "                fs_pmsm_rk4_at(&s->pmsm, s->x, &in, hstep, first);\n                fs_tm[5] += __rdtsc() - r0;\n"),
    ("                for (int m = 0; m < steps; ++m) fs_pmsm_rk4_at(&s->pmsm, s->x, &in, hstep, m == 0 ? &at : NULL);\n",
     "                unsigned long long r0 = __rdtsc();\n"
     "                for (int m = 0; m < steps; ++m) fs_pmsm_rk4_at(&s->pmsm, s->x, &in, hstep, m == 0 ? &at : NULL);\n"
     "                fs_tm[5] += __rdtsc() - r0;\n"),
)
# Anchors a checkout may lack (an older runner): timed where they stand, once at most.
OPTIONAL = (
    ("    for (int m = 0; m < steps; ++m) fs_pmsm_rk4_at(&s->pmsm, s->x, &in, hstep, m == 0 ? at : NULL);\n",
     "    unsigned long long r0 = __rdtsc();\n"
     "    for (int m = 0; m < steps; ++m) fs_pmsm_rk4_at(&s->pmsm, s->x, &in, hstep, m == 0 ? at : NULL);\n"
     "    fs_tm[5] += __rdtsc() - r0;\n"),
)
READER = "\nvoid fs_sim_timers(double *out)\n{\n    for (int k = 0; k < 8; ++k) {\n        out[k] = (double)fs_tm[k];\n" \
         "        fs_tm[k] = 0;\n    }\n}\n"


class Skip(Exception):
    """The timers cannot run here; the message says why."""


def patched(text: str) -> str:
    """fs_sim.c with the counters: every anchor must stand once (a changed
    runner fails here, not with a silently untimed part)."""
    for anchor, timed in PATCHES:
        if text.count(anchor) != 1:
            raise ValueError(f"fs_sim.c: the anchor {anchor.strip()[:60]!r} stands {text.count(anchor)} times, not once")
        text = text.replace(anchor, timed)
    for anchor, timed in OPTIONAL:
        if text.count(anchor) > 1:
            raise ValueError(f"fs_sim.c: the anchor {anchor.strip()[:60]!r} stands {text.count(anchor)} times")
        text = text.replace(anchor, timed)
    return text + READER


def build_copy(src: Path, work: Path, timed: bool) -> Path:
    """src/ and csrc/ of a checkout copied into work and built there (the
    checkout's own flags); the folder to put on PYTHONPATH."""
    for d in ("src", "csrc"):
        shutil.copytree(src / d, work / d, ignore=shutil.ignore_patterns("*.so", "__pycache__"))
    if timed:
        sim = work / "csrc" / "sim" / "fs_sim.c"
        sim.write_text(patched(sim.read_text()))
        header = work / "csrc" / "sim" / "fs_sim.h"
        text = header.read_text()
        header.write_text(text.replace("void fs_sim_destroy(fs_sim *sim);",
                                       "void fs_sim_destroy(fs_sim *sim);\nvoid fs_sim_timers(double *out);"))
    code = ("import importlib.util as u; s = u.spec_from_file_location('b', 'src/fullspeed/_build.py'); "
            "b = u.module_from_spec(s); s.loader.exec_module(b); b.ffibuilder.compile(tmpdir='.')")
    r = subprocess.run([sys.executable, "-c", code], cwd=work, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"build of {'the timed' if timed else 'the plain'} copy: "
                           f"{(r.stderr.strip().splitlines() or ['?'])[-1]}")
    for so in (work / "fullspeed").glob("_core*"):
        shutil.copy(so, work / "src" / "fullspeed" / so.name)
    return work / "src"


def driver(inverter: str, runs: int, timed: bool) -> dict:
    """In the copy's interpreter: the least loop, simulate() and metrics of
    `runs`, and with the counters each part's ns a sample in the least loop."""
    import time

    import fullspeed.sim as fs
    from fullspeed._core import ffi, lib
    from fullspeed.design.scenario import load_scenario
    from fullspeed.sim.metrics import compute_metrics
    from fullspeed.sim.runner import Simulation
    sc = load_scenario(SCENARIO, {"converter": {"inverter": inverter}})
    fs.simulate(sc)
    out = ffi.new(f"double[{COUNTERS}]") if timed else None
    loops, sims, metrics, best = [], [], [], None
    for _ in range(runs):
        sim = Simulation(sc)
        if timed:
            lib.fs_sim_timers(out)
        t0 = time.perf_counter()
        sim.advance_steps(sim.steps(sc.duration))
        loop = time.perf_counter() - t0
        if timed:
            lib.fs_sim_timers(out)
            if best is None or loop < best[0]:
                best = (loop, list(out))
        t0 = time.perf_counter()
        res = fs.simulate(sc)
        t1 = time.perf_counter()
        compute_metrics(res)
        t2 = time.perf_counter()
        loops.append(loop), sims.append(t1 - t0), metrics.append(t2 - t1)
    rep = {"samples": sim.step_count, "loop_s": min(loops), "simulate_s": min(sims), "metrics_s": min(metrics)}
    if timed:
        loop, c = best
        n, ticks = c[7], c[0] + c[1] + c[2] + c[3]
        ns = 1e9 * loop / ticks / n        # the counter's ticks as the loop's wall time
        rep["tsc_ghz"] = ticks / loop / 1e9
        rep["ns"] = {"sample": c[0] * ns, "drive": c[1] * ns, "row": c[2] * ns, "plant": c[4] * ns, "rk4": c[5] * ns,
                     "checks": (c[3] - c[4]) * ns}
    return rep


def run_copy(path: Path, inverter: str, runs: int, timed: bool) -> dict:
    env = dict(os.environ, PYTHONPATH=str(path))
    r = subprocess.run([sys.executable, __file__, "--driver", inverter, str(runs), "1" if timed else "0"],
                       capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise RuntimeError(f"timed run: {(r.stderr.strip().splitlines() or ['?'])[-1]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def loop_report(src: Path = ROOT, inverter: str = "averaged", runs: int = 25) -> dict:
    if platform.machine() not in ("x86_64", "AMD64"):
        raise Skip(f"rdtsc is x86-64's; this machine is {platform.machine()}")
    with tempfile.TemporaryDirectory(prefix="fs-loop-timers-") as tmp:
        timed_src = build_copy(src, Path(tmp) / "timed", True)
        plain_src = build_copy(src, Path(tmp) / "plain", False)
        timed, plain = {}, {}
        for _ in range(2):     # alternated, each the least of its runs
            for rep, path, t in ((timed, timed_src, True), (plain, plain_src, False)):
                r = run_copy(path, inverter, runs, t)
                if not rep or r["loop_s"] < rep["loop_s"]:
                    rep.update(r)
    n = plain["samples"]
    return {"status": "ok", "scenario": SCENARIO, "inverter": inverter, "src": str(src), "samples": n, "runs": runs,
            "ns": timed["ns"], "tsc_ghz": timed["tsc_ghz"],
            "loop_ns": 1e9 * plain["loop_s"] / n, "timed_loop_ns": 1e9 * timed["loop_s"] / n,
            "metrics_ns": 1e9 * plain["metrics_s"] / n,
            "front_ns": 1e9 * (plain["simulate_s"] - plain["loop_s"]) / n,
            "simulate_ms": 1e3 * plain["simulate_s"], "loop_ms": 1e3 * plain["loop_s"],
            "metrics_ms": 1e3 * plain["metrics_s"], "load_average": list(os.getloadavg())}


def format_report(rep: dict) -> str:
    ns = rep["ns"]
    lines = [f"the C loop's parts on {rep['scenario']} ({rep['inverter']}, {rep['samples']} samples, {rep['src']}), "
             f"ns a sample, the least of {rep['runs']} runs; load average {rep['load_average'][0]:.2f}",
             "  " + "".join(f"{p:>9}" for p in PARTS) + f"{'sum':>9}",
             "  " + "".join(f"{ns[p]:9.1f}" for p in PARTS)
             + f"{sum(ns[p] for p in PARTS if p != 'rk4'):9.1f}   (rk4 is within plant)",
             f"  the loop {rep['loop_ns']:.1f} ns a sample without the counters ({rep['loop_ms']:.3f} ms), "
             f"{rep['timed_loop_ns']:.1f} with them (their cost is in the parts)",
             f"  simulate() {rep['simulate_ms']:.3f} ms: the loop and the front ({rep['front_ns']:.1f} ns a sample: the "
             f"configuration, fs_sim_create, the chunked calls, the Result); the metrics at their first read "
             f"{rep['metrics_ms']:.3f} ms ({rep['metrics_ns']:.1f} ns a sample)"]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=25, help="runs a copy, the least taken (default 25)")
    ap.add_argument("--inverter", choices=("averaged", "switching"), default="averaged")
    ap.add_argument("--src", type=Path, default=ROOT, help="the checkout to time (default this one)")
    ap.add_argument("--driver", nargs=3, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.driver:
        print(json.dumps(driver(a.driver[0], int(a.driver[1]), a.driver[2] == "1")))
        return 0
    if a.runs < 1:
        print(f"--runs = {a.runs}: must be >= 1", file=sys.stderr)
        return 2
    try:
        rep = loop_report(a.src.resolve(), a.inverter, a.runs)
    except Skip as exc:
        print(f"loop timers: skipped: {exc}")
        return 0
    print(format_report(rep))
    return 0


if __name__ == "__main__":
    sys.exit(main())
