"""motulator's own example examples/drive/flux_vector/plot_2kw_ipmsm_fvc.py,
run headless and timed: the peer side of bench/wall.py.

This file runs in motulator's virtual environment (Python >= 3.12), not in
fullspeed's; it imports nothing of fullspeed. It builds the example's drive
exactly as the example does (motulator 0.18 API), times sim.simulate() alone
and prints one JSON line: the wall time and what the drive did (speed at a
few instants), so that the bench can show both tools ran the same job.

Usage: python motulator_peer.py --pwm 0|1
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


def run(pwm: bool) -> dict:
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
    sim = model.Simulation(mdl, ctrl)
    t0 = time.perf_counter()
    res = sim.simulate(t_stop=1.6)
    wall = time.perf_counter() - t0
    out = {"wall_s": wall, "T_s": cfg.T_s}
    try:  # what the drive did, if this motulator version exposes it so
        t = np.asarray(res.mdl.t)
        w = np.asarray(res.mdl.mechanics.w_M)
        out["speed_rpm"] = {f"{x:g}": float(np.interp(x, t, w) * 60 / (2 * pi)) for x in (0.4, 0.8, 1.2, 1.59)}
    except AttributeError:
        pass
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--pwm", type=int, choices=(0, 1), required=True)
    print(json.dumps(run(bool(ap.parse_args().pwm))))
