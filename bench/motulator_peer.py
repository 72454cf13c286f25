"""motulator's own example examples/drive/flux_vector/plot_2kw_ipmsm_fvc.py,
run headless and timed: the peers' side of bench/wall.py.

This file runs in the peers' virtual environment (Python >= 3.12), not in
fullspeed's; it imports nothing of fullspeed. It builds the example's drive
exactly as the example does (motulator 0.18 API) and simulates it with one
of two engines:

  python  motulator's own Simulation (Python, scipy's RK45);
  native  motulator-export's native.Simulation: the same system, the same
          solver steps, in C (compiled on first use and cached by it).

Before the timed run it simulates 10 ms of a separately built drive with the
same engine, untimed, so that what a first call pays once (the native
library's compile or load, import-time caches) is not in the figure; the
bench's fullspeed side has the same warm-up. It times sim.simulate() alone
and prints one JSON line: the wall time and what the drive did (its speed at
a few instants), so that the bench can show every engine ran the same job.

Usage: python motulator_peer.py --engine python|native --pwm 0|1 [--runs N]
(--runs: timed runs in this process, each on a newly built drive.)
"""
import argparse
import json
import os
import time
from math import pi

os.environ.setdefault("TQDM_DISABLE", "1")

import numpy as np  # noqa: E402
import motulator.drive.control.sm as control  # noqa: E402
from motulator.drive import model, utils  # noqa: E402

INSTANTS = (0.4, 0.8, 1.2, 1.59)   # s, where the bench compares the speed


def build(pwm: bool):
    """The example's drive and control system (its own numbers)."""
    nom = utils.NominalValues(U=370, I=4.3, f=75, P=2.2e3, tau=14)
    base = utils.BaseValues.from_nominal(nom, n_p=3)
    par = model.SynchronousMachinePars(n_p=3, R_s=3.6, L_d=0.036, L_q=0.051, psi_f=0.545)
    mdl = model.Drive(model.SynchronousMachine(par), model.MechanicalSystem(J=0.015),
                      model.VoltageSourceConverter(u_dc=540), pwm=pwm)
    cfg = control.FluxVectorControllerCfg(i_s_max=1.5 * base.i, sensorless=True)
    ctrl = control.VectorControlSystem(control.FluxVectorController(par, cfg),
                                       control.SpeedController(J=0.015, alpha_s=2 * pi * 4))
    ctrl.set_speed_ref(lambda t: (t > 0.2) * 2 * base.w_M)
    mdl.mechanics.set_external_load_torque(lambda t: (t > 0.8) * 0.7 * nom.tau)
    return mdl, ctrl, cfg.T_s


def simulation(engine: str, mdl, ctrl):
    if engine == "native":
        from motulator_export import native
        return native.Simulation(mdl, ctrl, show_progress=False)
    return model.Simulation(mdl, ctrl, show_progress=False)


def run(engine: str, pwm: bool) -> dict:
    mdl, ctrl, T_s = build(pwm)
    sim = simulation(engine, mdl, ctrl)
    t0 = time.perf_counter()
    res = sim.simulate(t_stop=1.6)
    wall = time.perf_counter() - t0
    t = np.asarray(res.mdl.t)
    w = np.asarray(res.mdl.mechanics.w_M)
    return {"wall_s": wall, "T_s": T_s, "samples": len(res.ctrl.t) if hasattr(res.ctrl, "t") else None,
            "speed_rpm": {f"{x:g}": float(np.interp(x, t, w) * 60 / (2 * pi)) for x in INSTANTS}}


def warm_up(engine: str, pwm: bool) -> None:
    mdl, ctrl, _ = build(pwm)
    simulation(engine, mdl, ctrl).simulate(t_stop=0.01)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", choices=("python", "native"), default="python")
    ap.add_argument("--pwm", type=int, choices=(0, 1), required=True)
    ap.add_argument("--runs", type=int, default=1)
    a = ap.parse_args()
    warm_up(a.engine, bool(a.pwm))
    for _ in range(max(a.runs, 1)):
        print(json.dumps({"engine": a.engine, **run(a.engine, bool(a.pwm))}), flush=True)
