"""motulator's two sensorless examples for its 2.2 kW IPMSM, run headless:
the peer side of bench/estimators.py.

  a: examples/drive/flux_vector/plot_2kw_ipmsm_fvc.py (flux-vector control,
     sensorless: its flux observer), 0 -> 2 p.u. at 0.2 s, 0.7 x 14 N m at 0.8 s
  b: examples/drive/signal_inj/plot_2kw_ipmsm_signal_inj.py (square-wave
     injection with a PLL), +-0.1 p.u. speed, 14 N m from 0.5 to 3.5 s

This file runs in motulator's virtual environment (Python >= 3.12) and
imports nothing of fullspeed. The drives are built as the examples build
them (motulator 0.18 API). It writes, at the control instants, the true
electrical angle (the model's theta_m, unwrapped and interpolated), the
angle the controller used (fbk.theta_m, electrical), the true and the
estimated mechanical speed and the speed reference, as an .npz file.

Usage: python estimators_peer.py --case a|b --out FILE.npz
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

NOM = utils.NominalValues(U=370, I=4.3, f=75, P=2.2e3, tau=14)
BASE = utils.BaseValues.from_nominal(NOM, n_p=3)
PAR = model.SynchronousMachinePars(n_p=3, R_s=3.6, L_d=0.036, L_q=0.051, psi_f=0.545)
T_STOP = {"a": 1.6, "b": 4.0}


def build(case: str):
    mdl = model.Drive(model.SynchronousMachine(PAR), model.MechanicalSystem(J=0.015),
                      model.VoltageSourceConverter(u_dc=540))
    speed_ctrl = control.SpeedController(J=0.015, alpha_s=2 * pi * 4)
    if case == "a":
        cfg = control.FluxVectorControllerCfg(i_s_max=1.5 * BASE.i, sensorless=True)
        ctrl = control.VectorControlSystem(control.FluxVectorController(PAR, cfg), speed_ctrl)
        ctrl.set_speed_ref(lambda t: (t > 0.2) * 2 * BASE.w_M)
        mdl.mechanics.set_external_load_torque(lambda t: (t > 0.8) * 0.7 * NOM.tau)
    else:
        # the upstream example's observer poles, alpha_o = 2 pi 40 (0.18's default is 2 pi 50)
        cfg = control.CurrentVectorControllerCfg(i_s_max=2 * BASE.i, alpha_o=2 * pi * 40)
        ctrl = control.VectorControlSystem(control.SignalInjectionController(PAR, cfg), speed_ctrl)
        t_stop = T_STOP["b"]
        times = np.array([0, 0.25, 0.25, 0.375, 0.5, 0.625, 0.75, 0.75, 1]) * t_stop
        values = np.array([0, 0, 1, 1, 0, -1, -1, 0, 0]) * 0.1 * BASE.w_M
        ctrl.set_speed_ref(utils.SequenceGenerator(times, values))
        times = np.array([0, 0.125, 0.125, 0.875, 0.875, 1]) * t_stop
        values = np.array([0, 0, 1, 1, 0, 0]) * NOM.tau
        mdl.mechanics.set_external_load_torque(utils.SequenceGenerator(times, values))
    return mdl, ctrl


def run(case: str, out: str) -> dict:
    mdl, ctrl = build(case)
    sim = model.Simulation(mdl, ctrl)
    t0 = time.perf_counter()
    res = sim.simulate(t_stop=T_STOP[case])
    wall = time.perf_counter() - t0
    t_m = np.asarray(res.mdl.t)
    t_c = np.asarray(res.ctrl.t)
    # the true angle, unwrapped before it is interpolated to the control instants
    theta = np.interp(t_c, t_m, np.unwrap(np.asarray(res.mdl.machine.theta_m)))
    w_M = np.interp(t_c, t_m, np.asarray(res.mdl.mechanics.w_M))
    np.savez(out, t=t_c, theta_e=theta, theta_hat=np.asarray(res.ctrl.fbk.theta_m),
             w_m=w_M, w_m_hat=np.asarray(res.ctrl.fbk.w_M), w_m_ref=np.asarray(res.ctrl.ref.w_M))
    return {"wall_s": wall, "T_s": float(np.median(np.diff(t_c)))}


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", choices=("a", "b"), required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    print(json.dumps(run(a.case, a.out)))
