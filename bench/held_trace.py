"""The estimators inside one of B-REAL's held runs through its torque step
(reproduce/papers/real.py, held_scenario: the load machine holds the shaft
at a speed, the speed loop asks its most torque at once): per sample the
shaft's speed, and for each estimator of the blended drive its speed and
angle error (true less estimated, el.deg), the load torque it carries,
with the back-EMF observer's own EMF speed, hold and convergence, the
torque fed forward, the injection's state and the blend's weight; and the
loss-of-lock monitor's reading of the torque's answer (check 6,
fs_monitor.c: c_xy / c_xx, the inertial torque's rate over the torque's,
about J / J_eff: 1 on a free rotor, 0 on a shaft held; None until the
torque has moved enough to read it).

What it is for: bench/held_margin.py says whether a held run survives at
speeds 0.1 % apart; this says how the one that did not was lost (which
estimator swung first, and when the injection stopped or resumed).

    .venv/bin/python bench/held_trace.py --machine prius2004-mg2 --rpm 293.706 [--out DIR] [--before 0.002] [--after 0.03] [--every 0.0005]

Prints the table; with --out writes DIR/held_trace.json. Blended drives
only (the machine's sensorless angle "blend"); exit 2 otherwise.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

RPM = 60.0 / (2.0 * math.pi)


def step_time(data: dict) -> float:
    """The instant the speed reference steps to the held run's ask (held_scenario: its
    last three points are the step's start, the ask 1 ms on, and the run's end)."""
    return float(data["references"]["speed_rpm"][-3][0])


def _deg(x: float) -> float:
    return math.degrees(math.remainder(x, 2.0 * math.pi))


def trace(machine: str, rpm: float, before: float = 2e-3, after: float = 30e-3, every: float = 5e-4) -> list[dict]:
    """The rows (module docstring) from `before` ahead of the step to `after` past it, one each `every`
    seconds (at the control period's grid); the run stops early where the drive stopped."""
    from fullspeed._core import lib
    from fullspeed.design.scenario import scenario_from_dict
    from fullspeed.model.errors import ConfigError
    from fullspeed.reproduce.papers.real import held_scenario
    from fullspeed.sim.runner import Simulation

    data = held_scenario(machine, rpm, "blend")
    sim = Simulation(scenario_from_dict(data, f"held-trace {machine}", warn=False))
    drv = lib.fs_sim_drive(sim._sim)
    if drv.cfg.angle_source != lib.FS_ANGLE_BLEND:
        raise ConfigError("machine", machine, "must be one whose held run is blended (the injection and the back-EMF observer)")
    p = drv.cfg.pole_pairs
    t_s = step_time(data)
    status = sim.advance(t_s - before)
    rows = []
    while status == "running" and sim.time < t_s + after - 0.5 * sim.period:
        status = sim.advance(sim.time + every)
        tr = sim.traces()
        th, w_m = float(tr["theta_e"][-1]), float(tr["w_m"][-1])
        smo, hfi, bl, mon = drv.smo, drv.hfi, drv.blend, drv.mon
        rows.append({
            "t": sim.time, "w_m_rpm": w_m * RPM, "status": status,
            "smo": {"w_rpm": smo.w * RPM / p, "err_deg": _deg(th - smo.theta), "w_emf_rpm": smo.w_emf * RPM / p,
                    "T_d": float(smo.mo.T_d_hat), "hold": int(smo.n_hold), "converged": bool(smo.converged)},
            "hfi": {"w_rpm": hfi.w * RPM / p, "err_deg": _deg(th - hfi.theta), "T_d": float(hfi.obs.T_d_hat)},
            "blend": {"w_rpm": bl.w_hat * RPM / p, "err_deg": _deg(th - bl.theta_hat), "g_w": float(bl.g_w)},
            "est_err_deg": math.degrees(float(tr["est_err"][-1])),   # the simulator's own, for the blend's
            "T_ff": float(drv.T_ff), "inject_on": bool(drv.inject_on), "injecting": bool(drv.injecting),
            "torque_answer": float(mon.c_xy / mon.c_xx) if mon.c_xx >= mon.c_exc > 0.0 else None,
        })
    return rows


def main(argv: list[str] | None = None) -> int:
    from fullspeed.model.errors import ConfigError
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--machine", required=True)
    ap.add_argument("--rpm", type=float, required=True)
    ap.add_argument("--before", type=float, default=2e-3, help="s ahead of the step")
    ap.add_argument("--after", type=float, default=30e-3, help="s past the step")
    ap.add_argument("--every", type=float, default=5e-4, help="s between rows")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    try:
        rows = trace(a.machine, a.rpm, a.before, a.after, a.every)
    except ConfigError as exc:
        print(f"held_trace: {exc}", file=sys.stderr)
        return 2
    print("t        w_m |  smo_w  smo_err  w_emf   T_d hold cv |  hfi_w hfi_err   T_d |  bl_w bl_err  g_w |  T_ff inj answer")
    for r in rows:
        s, h, b = r["smo"], r["hfi"], r["blend"]
        ans = f"{r['torque_answer']:6.2f}" if r["torque_answer"] is not None else "     -"
        print(f"{r['t']:.4f} {r['w_m_rpm']:5.0f} | {s['w_rpm']:6.0f} {s['err_deg']:7.1f} {s['w_emf_rpm']:6.0f} {s['T_d']:5.0f} {s['hold']:4d} "
              f"{int(s['converged']):2d} | {h['w_rpm']:6.0f} {h['err_deg']:7.1f} {h['T_d']:5.0f} | {b['w_rpm']:5.0f} {b['err_deg']:6.1f} "
              f"{b['g_w']:4.2f} | {r['T_ff']:5.0f} {int(r['inject_on']):3d} {ans}")
    last = rows[-1]["status"] if rows else "not run"
    print(f"ended: {last}")
    if a.out:
        a.out.mkdir(parents=True, exist_ok=True)
        (a.out / "held_trace.json").write_text(json.dumps({"machine": a.machine, "rpm": a.rpm, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
