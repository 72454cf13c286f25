"""How far B-REAL's held torques are from failing: each sensorless held run
of the claim (reproduce/papers/real.py, held_scenario: the load machine
holds the shaft at a speed and the speed loop asks its most torque at
once) again at speeds a little beside the claim's, k x STEP apart
(k = -K..K), the rest unchanged.

A held run that passes at the claim's speed and fails 0.1 % beside it is
no margin: the drive's trajectory after a full-torque step on a held shaft
is chaotic there, and any change before the step (a start a few ms later,
a rounding) moves the claim's one run to a neighbour's outcome. Per
machine and speed: how many of the 2K + 1 runs hold the encoder's torque
less HELD_TOL (B-REAL's own test), the torque's range, how the others
stopped, and the largest angle error outside the step's first 50 ms.

    .venv/bin/python bench/held_margin.py --out out/held-margin [--machines prius2004-mg2,syre-thor] [--k 3]

Writes OUT/held_margin.json and prints the table (about 4 minutes on 2
cores for the whole catalog at K = 2).
"""
from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

STEP = 1e-3   # the speed's relative step between neighbouring runs


def _run(task: dict) -> dict:
    from fullspeed.reproduce.papers.real import held_torque
    r = held_torque({"machine": task["machine"], "rpm": task["rpm"], "angle": task["angle"]})
    return {**task, **r}


def tasks(machines: list[str], k: int) -> list[dict]:
    from fullspeed.design.envelope import envelope
    from fullspeed.design.machine import load_machine
    from fullspeed.model.units import rad_s_to_rpm
    from fullspeed.reproduce.papers.real import held_speeds, sensorless_angle
    out = []
    for n in machines:
        angle, refused = sensorless_angle(n)
        if angle is None:
            continue
        m = load_machine(n)
        env = envelope(m, m.bench["u_dc"], m.bench["i_max"], w_end=4.0 * m.w_m_rated)
        for w in held_speeds(env):
            rpm = rad_s_to_rpm(w)
            out.append({"machine": n, "rpm0": rpm, "rpm": rpm, "angle": "encoder", "k": 0})
            out += [{"machine": n, "rpm0": rpm, "rpm": rpm * (1.0 + j * STEP), "angle": angle, "k": j} for j in range(-k, k + 1)]
    return out


def summarise(rows: list[dict]) -> list[dict]:
    from fullspeed.reproduce.papers.real import HELD_TOL
    table = []
    for key in sorted({(r["machine"], r["rpm0"]) for r in rows}):
        enc = [r for r in rows if (r["machine"], r["rpm0"]) == key and r["angle"] == "encoder"][0]
        sl = sorted((r for r in rows if (r["machine"], r["rpm0"]) == key and r["angle"] != "encoder"), key=lambda r: r["k"])
        T_enc = enc.get("T")
        ok = [r.get("T") is not None and T_enc is not None and r["T"] >= (1.0 - HELD_TOL) * T_enc for r in sl]
        Ts = [r["T"] for r in sl if r.get("T") is not None]
        table.append({"machine": key[0], "rpm": key[1], "T_encoder": T_enc, "held": sum(ok), "runs": len(sl),
                      "claim_run_held": bool(ok[len(ok) // 2]), "T_min": min(Ts) if Ts else None, "T_max": max(Ts) if Ts else None,
                      "stops": {r["k"]: r.get("stop_reason") for r in sl if r.get("stop_reason") != "done"}})
    return table


def main(argv: list[str] | None = None) -> int:
    from fullspeed.model.machines import published_machines
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("out/held-margin"))
    ap.add_argument("--machines", default=",".join(published_machines()))
    ap.add_argument("--k", type=int, default=2, help="runs each side of the claim's speed")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    ts = tasks(a.machines.split(","), a.k)
    with ProcessPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(_run, ts))
    table = summarise(rows)
    a.out.mkdir(parents=True, exist_ok=True)
    tmp = a.out / "held_margin.json.tmp"
    tmp.write_text(json.dumps({"step": STEP, "k": a.k, "table": table, "runs": rows}, indent=1, default=float))
    tmp.replace(a.out / "held_margin.json")
    print(f"{'machine':22s} {'rpm':>7s} {'T_enc':>9s} {'held':>6s}  claim's  T sensorless min..max  stops (k: how)")
    for r in table:
        T = f"{r['T_min']:.4g}..{r['T_max']:.4g}" if r["T_min"] is not None else "-"
        print(f"{r['machine']:22s} {r['rpm']:7.0f} {r['T_encoder'] or float('nan'):9.4g} {r['held']:>2d}/{r['runs']:<3d}  "
              f"{'held' if r['claim_run_held'] else 'NOT':7s}  {T:22s} {r['stops'] or ''}")
    fragile = [r for r in table if r["held"] < r["runs"]]
    print(f"{len(fragile)} of {len(table)} speeds with a neighbour that does not hold ({STEP:g} x k apart, k = -{a.k}..{a.k})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
