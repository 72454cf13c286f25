"""motulator's saturation-aware sensorless examples for two PM-SyRMs, run
headless on a job given from outside: the peer side of bench/syrm_peer.py.

  thor-cvc    examples/drive/current_vector/plot_5kw_pmsyrm_thor_sat_cvc.py:
              current-vector control on the FEA flux map (SyR-e's THOR),
              the mechanical-model speed observer (J given)
  baldor-fvc  examples/drive/flux_vector/plot_6kw_pmsyrm_sat_fvc.py:
              flux-vector control on the example's algebraic saturation
              model fitted to the measured map, the mechanical-model speed
              observer, no integral action (alpha_i = 0), alpha_o = 2 pi 8
  baldor-cvc  examples/drive/current_vector/plot_6kw_pmsyrm_sat_cvc.py:
              current-vector control on the same fitted model, online
              reference generation

Each is built as its example builds it (motulator 0.18 API: the examples
ship in motulator's source distribution, not in the installed package),
with these differences, which the job sets so that both sides run one job:
the plant's flux map is the one fullspeed's catalog machine has (the CSV
under src/fullspeed/machines: the measured Baldor map as published, THOR's
FEA map at every 5th of SyR-e's points, negative i_q by the map's
symmetry), and so is the THOR controller's map (the example reads the
FEA's thor.mat, which the installed package lacks); R_s, J, the link, the
current limit, the speed reference and the load torque come from the job;
THOR's quadratic load (the example's B_L) is left out (fullspeed's load
has no such kind). The controller's R_s and J are the plant's, as in the
examples.

This file runs in motulator's virtual environment (Python >= 3.12) and
imports nothing of fullspeed. It writes, at the control instants, the true
electrical angle (unwrapped, interpolated), the angle the controller used
(fbk.theta_m), the true and estimated mechanical speed, the speed
reference, and on the model's time base the current magnitude and the
speed, as an .npz file; it prints one JSON line (wall time, sampling).

Usage: python syrm_peer_motulator.py --job JOB.json --out FILE.npz
  JOB: {"case": "thor-cvc" | "baldor-fvc" | "baldor-cvc", "map_csv": path,
        "n_p": int, "R_s": ohm, "J": kg m^2, "u_dc": V, "i_s_max": A (peak),
        "sensorless": bool, "speed": [[t, rad/s mechanical], ...],
        "load": [[t, N m], ...] (linear between points, equal times a step),
        "t_stop": s}
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

CASES = ("thor-cvc", "baldor-fvc", "baldor-cvc")
# The Baldor examples' nominal values (their base flux sets the fitted model's grid)
BALDOR_NOM = utils.NominalValues(U=460, I=8.8, f=60, P=5.6e3, tau=29.7)


def profile(points):
    """A piecewise-linear function of t from [[t, value], ...] (times
    non-decreasing; two equal times make a step, the later value from that
    instant on), held before the first and after the last point."""
    t = np.array([p[0] for p in points], dtype=float)
    v = np.array([p[1] for p in points], dtype=float)

    def f(x):
        k = int(np.searchsorted(t, x, side="right"))
        if k == 0:
            return float(v[0])
        if k == len(t):
            return float(v[-1])
        t0, t1, v0, v1 = t[k - 1], t[k], v[k - 1], v[k]
        return float(v0 if t1 <= t0 else v0 + (v1 - v0) * (x - t0) / (t1 - t0))
    return f


def catalog_flux_map(path: str):
    """fullspeed's catalog map (CSV: i_d, i_q, psi_d, psi_q[, T] on a full
    grid, i_q >= 0 given) as motulator's MagneticModel, negative i_q by the
    symmetry psi_d(i_d, -i_q) = psi_d, psi_q(i_d, -i_q) = -psi_q."""
    rows = np.genfromtxt(path, delimiter=",", comments="#", skip_header=0)
    rows = rows[~np.isnan(rows[:, :4]).any(axis=1)]
    i_d, i_q = np.unique(rows[:, 0]), np.unique(rows[:, 1])
    order = np.lexsort((rows[:, 1], rows[:, 0]))
    psi_d = rows[order, 2].reshape(i_d.size, i_q.size)
    psi_q = rows[order, 3].reshape(i_d.size, i_q.size)
    cut = 1 if i_q[0] == 0.0 else 0
    q = np.r_[-i_q[cut:][::-1], i_q]
    psi_d = np.concatenate([psi_d[:, cut:][:, ::-1], psi_d], axis=1)
    psi_q = np.concatenate([-psi_q[:, cut:][:, ::-1], psi_q], axis=1)
    D, Q = np.meshgrid(i_d, q, indexing="ij")
    return utils.MagneticModel(i_s_dq=D + 1j * Q, psi_s_dq=psi_d + 1j * psi_q, type="flux_map")


def baldor_fitted_flux_map():
    """The Baldor examples' control model: their algebraic saturation model
    (Lelli et al. 2024) with the example's fitted parameters, tabulated and
    inverted as the examples do."""
    base = utils.BaseValues.from_nominal(BALDOR_NOM, n_p=2)
    cur = utils.SaturationModelPMSyRM(a_d0=3.96, a_dd=28.5, S=4, a_q0=1.1 * 5.89, a_qq=2.67, T=6, a_dq=41.5,
                                      U=1, V=1, a_b=81.75, a_bp=1, k_q=0.1, psi_n=0.804, W=2)
    cur = cur.as_magnetic_model(d_range=np.linspace(-0.1 * base.psi, base.psi, 256),
                                q_range=np.linspace(-1.4 * base.psi, 1.4 * base.psi, 256))
    return cur.invert()


def build(job: dict):
    case = job["case"]
    plant_map = catalog_flux_map(job["map_csv"])
    par = model.SaturatedSynchronousMachinePars(n_p=job["n_p"], R_s=job["R_s"], i_s_dq_fcn=plant_map.invert())
    mdl = model.Drive(model.SynchronousMachine(par), model.MechanicalSystem(J=job["J"]),
                      model.VoltageSourceConverter(u_dc=job["u_dc"]))
    ctrl_map = plant_map if case == "thor-cvc" else baldor_fitted_flux_map()
    est_par = control.SaturatedSynchronousMachinePars(n_p=job["n_p"], R_s=job["R_s"], psi_s_dq_fcn=ctrl_map)
    sensorless = bool(job["sensorless"])
    if case == "baldor-fvc":
        cfg = control.FluxVectorControllerCfg(i_s_max=job["i_s_max"], J=job["J"], alpha_i=0,
                                              alpha_o=2 * pi * 8 if sensorless else None, sensorless=sensorless)
        vector_ctrl = control.FluxVectorController(est_par, cfg)
    else:
        cfg = control.CurrentVectorControllerCfg(i_s_max=job["i_s_max"], J=job["J"], sensorless=sensorless,
                                                 online_ref=case == "baldor-cvc")
        vector_ctrl = control.CurrentVectorController(est_par, cfg)
    ctrl = control.VectorControlSystem(vector_ctrl, control.SpeedController(J=job["J"], alpha_s=2 * pi * 4))
    ctrl.set_speed_ref(profile(job["speed"]))
    mdl.mechanics.set_external_load_torque(profile(job["load"]))
    return mdl, ctrl


def run(job: dict, out: str) -> dict:
    mdl, ctrl = build(job)
    sim = model.Simulation(mdl, ctrl)
    t0 = time.perf_counter()
    res = sim.simulate(t_stop=job["t_stop"])
    wall = time.perf_counter() - t0
    t_m = np.asarray(res.mdl.t)
    t_c = np.asarray(res.ctrl.t)
    theta = np.interp(t_c, t_m, np.unwrap(np.asarray(res.mdl.machine.theta_m)))
    w_M_m = np.asarray(res.mdl.mechanics.w_M)
    np.savez(out, t=t_c, theta_e=theta, theta_hat=np.asarray(res.ctrl.fbk.theta_m),
             w_m=np.interp(t_c, t_m, w_M_m), w_m_hat=np.asarray(res.ctrl.fbk.w_M),
             w_m_ref=np.asarray(res.ctrl.ref.w_M), t_model=t_m, w_m_model=w_M_m,
             i_abs_model=np.abs(np.asarray(res.mdl.machine.i_s_ab)))
    return {"wall_s": wall, "T_s": float(np.median(np.diff(t_c)))}


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--job", required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    with open(a.job) as f:
        job = json.load(f)
    if job.get("case") not in CASES:
        raise SystemExit(f"case = {job.get('case')!r}: must be one of {', '.join(CASES)}")
    print(json.dumps(run(job, a.out)))
