"""What each optional plant effect costs: the same scenario with the effect
on and off, wall time in the same run (ratios, not seconds).

Effects: the two-node thermal model (csrc/plant/fs_thermal.h, the
scenario's [thermal]), the online R_s / psi_f correction in the drive
(csrc/control/fs_param_adapt.h, controller.param_adapt), and the spatial
harmonics (csrc/plant/fs_pmsm.h, the scenario's [harmonics]). The scenario is
beyond-thermal (the yang2022 machine, blended sensorless, switching
inverter) cut to a few seconds. Runs alternate between the variants so a
slow moment of the machine hits all of them; each variant's time is the
median of its runs, and the cost is its ratio to the run with every effect
off.

Usage: python bench/effects.py [--repeat N] [--duration S]
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys

from fullspeed.sim import simulate

SCENARIO = "beyond-thermal"
OFF = {"thermal": {"enabled": False}, "controller": {"param_adapt": False}, "harmonics": {"enabled": False}}
VARIANTS = {
    "off": OFF,
    "thermal": {**OFF, "thermal": {"enabled": True}},
    "thermal+adapt": {**OFF, "thermal": {"enabled": True}, "controller": {"param_adapt": True}},
    "harmonics": {**OFF, "harmonics": {"enabled": True}},
}


def effects_report(repeat: int = 3, duration: float = 4.0) -> dict:
    times: dict[str, list[float]] = {k: [] for k in VARIANTS}
    for _ in range(repeat):
        for name, ov in VARIANTS.items():
            ov = {**ov, "duration": duration, "metrics": {"steady": [0.0, duration]}}
            res = simulate(SCENARIO, overrides=ov)
            if res.stop_reason != "done":
                return {"status": "fail", "why": f"{name}: stopped ({res.stop_reason})"}
            times[name].append(res.wall_time)
    med = {k: statistics.median(v) for k, v in times.items()}
    return {"status": "ok", "scenario": SCENARIO, "duration_s": duration, "repeat": repeat,
            "median_wall_s": med, "cost_vs_off": {k: med[k] / med["off"] for k in VARIANTS}}


def format_report(rep: dict) -> str:
    if rep["status"] != "ok":
        return f"effects: {rep['status']}: {rep['why']}"
    lines = [f"effects on {rep['scenario']} ({rep['duration_s']:g} s simulated, median of {rep['repeat']}):"]
    for k, r in rep["cost_vs_off"].items():
        lines.append(f"  {k:14s} {rep['median_wall_s'][k]:.3f} s wall, x{r:.3f} of all effects off")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--duration", type=float, default=4.0)
    a = ap.parse_args(argv)
    if a.repeat < 1 or not a.duration > 0:
        print(f"--repeat = {a.repeat}, --duration = {a.duration}: must be >= 1 and > 0", file=sys.stderr)
        return 2
    rep = effects_report(a.repeat, a.duration)
    print(format_report(rep))
    print(json.dumps(rep))
    return 0 if rep["status"] == "ok" else 1


if __name__ == "__main__":
    sys.exit(main())
