"""The FMUs (workflows.fmu) checked by an independent FMI tool, FMPy (a test
dependency: `pip install fmpy`; these functions import it when called):

- validate: FMPy's validate_fmu (the model description against the
  standard's schema, names, units, start values, causality and variability,
  the model structure);
- system_vs_run: FMPy simulates the closed loop's FMU, its inputs the
  scenario's reference and load profiles at every control instant (with
  the runner's own arithmetic, fmu.profile_values); its outputs are compared
  with fullspeed's run of the scenario, channel by channel;
- drive_vs_host: the drive's FMU stepped through FMPy's API against
  fullspeed's plant (the runner with the drive outside it: fs_sim_sample,
  fs_sim_actuate), the host's drive (the C core's fs_drive_step) stepped
  alongside on the same inputs; their outputs are compared, and the closed
  loop the FMU's duties drive with fullspeed's own run.

Each returns a dict of figures: the largest absolute difference of each
output ("bitwise": all zero), the steps compared, the stages passed.
"""
from __future__ import annotations

import numpy as np

from .._core import ffi, lib
from ..model.scenario import Scenario
from ..sim.config import build_config
from ..sim.runner import simulate
from .fmu import MODELS, control_period, profile_values, variables

# The closed loop's outputs: the plant's at the step's end (row j of the
# run), the drive's of the step's sample (row j - 1).
SYSTEM_AT_END = ("w_m", "theta_e", "T_e", "i_a", "i_b", "i_c", "i_d", "i_q")
SYSTEM_AT_SAMPLE = ("theta_err", "est_err", "w_m_hat", "T_ref", "duty_a", "duty_b", "duty_c", "stage", "lock_lost")
# The system's inputs and the profile each stands for (fs_sim_config's)
SYSTEM_INPUTS = {"w_m_ref": "w_m_ref", "i_d_ref": "i_d_ref", "i_q_ref": "i_q_ref", "u_d_ref": "u_d_ref",
                 "u_q_ref": "u_q_ref", "w_e_ref": "w_e_ref", "T_load": "T_load", "w_load": "w_load"}


def validate(path) -> list[str]:
    """FMPy's problems with the FMU (empty: it validates)."""
    from fmpy.validation import validate_fmu
    return list(validate_fmu(str(path)))


def _worst(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return float("inf")
    d = np.abs(a - b)
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    return float(np.max(np.where(same, 0.0, d), initial=0.0))


def system_vs_run(path, sc: Scenario) -> dict:
    """FMPy's simulation of the system FMU against fullspeed's run of sc."""
    from fmpy import simulate_fmu
    cfg, _keep = build_config(sc)
    Tc = control_period(cfg)
    n = int(round(sc.duration / Tc))
    t = np.arange(n + 1) * Tc
    inputs = [v.name for _, v in variables("system", sc) if v.causality == "input"]
    cols = [("time", np.float64)] + [(name, np.float64) for name in inputs]
    signals = np.zeros(n + 1, dtype=cols)
    signals["time"] = t
    for name in inputs:
        if name in SYSTEM_INPUTS:
            signals[name] = profile_values(getattr(cfg, SYSTEM_INPUTS[name]), t)
        else:   # dw_load: the runner's slope of w_load at each sample
            signals[name] = _slopes(cfg.w_load, t)
    outputs = [v.name for _, v in variables("system", sc) if v.causality == "output"]
    res = simulate_fmu(str(path), stop_time=n * Tc, output_interval=Tc, input=signals, output=outputs,
                       fmi_type="CoSimulation")
    run = simulate(sc)
    tr = run.traces
    m = min(len(res), len(tr["t"]))
    out = {"steps": int(m - 1), "run_stop": run.stop_reason, "fmu_stop": int(res["stop"][-1]),
           "time": _worst(res["time"][:m], tr["t"][:m])}
    for name in SYSTEM_AT_END:
        out[name] = _worst(res[name][:m], tr[name][:m])
    for name in SYSTEM_AT_SAMPLE:
        out[name] = _worst(res[name][1:m], tr[name][:m - 1])
    p_dc = np.diff(tr["E_in"][:m]) / Tc   # the ideal devices' link power: the machine's input energy
    out["P_dc"] = _worst(res["P_dc"][1:m], p_dc) if cfg.inverter.u_on == 0.0 and cfg.inverter.r_on == 0.0 else None
    out["u_dc"] = _worst(res["u_dc"][1:m], tr["u_dc"][:m - 1])
    out["bitwise"] = all(v == 0.0 for k, v in out.items() if k not in ("steps", "run_stop", "fmu_stop") and v is not None)
    out["stages"] = sorted({int(s) for s in res["stage"]})
    return out


def _slopes(prof, t):
    """fs_pwl_eval's slope of a profile at t (0 outside its breakpoints)."""
    if prof.n < 2:
        return np.zeros_like(t)
    h = np.diff(np.array([prof.t[k] for k in range(prof.n)]))
    dy = np.diff(np.array([prof.y[k] for k in range(prof.n)]))
    tp = np.array([prof.t[k] for k in range(prof.n)])
    k = np.clip(np.searchsorted(tp, t, side="right") - 1, 0, prof.n - 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(h[k] > 0, dy[k] / h[k], 0.0)
    return np.where((t <= tp[0]) | (t >= tp[-1]), 0.0, s)


def drive_vs_host(path, sc: Scenario) -> dict:
    """The drive FMU through FMPy's API on fullspeed's plant, the host's
    drive alongside on the same inputs; and the loop against fullspeed's run."""
    from fmpy import extract, instantiate_fmu, read_model_description
    cfg, _keep = build_config(sc)
    Tc = control_period(cfg)
    n = int(round(sc.duration / Tc))
    err = ffi.new("char[]", 512)
    sim = lib.fs_sim_create(cfg, err, 512)
    if sim == ffi.NULL:
        raise RuntimeError(ffi.string(err).decode())
    sim = ffi.gc(sim, lib.fs_sim_destroy)
    host = ffi.new("fs_drive *")
    if lib.fs_drive_init(host, ffi.addressof(cfg, "drive")) != lib.FS_OK:
        raise RuntimeError("the host's fs_drive_init refused the configuration")
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(str(path))
    fmu = instantiate_fmu(unzipped, md, fmi_type="CoSimulation")
    fmi3 = md.fmiVersion.startswith("3")
    set_real = fmu.setFloat64 if fmi3 else fmu.setReal
    get_real = fmu.getFloat64 if fmi3 else fmu.getReal
    get_int = fmu.getInt32 if fmi3 else fmu.getInteger
    if fmi3:
        fmu.enterInitializationMode(startTime=0.0)
    else:
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    phases = sc.machine.phases
    names = {v.name for _, v in variables("drive", sc)}
    real_in = [f"i_{p}" for p in "abcde"[:phases]] + [k for k in ("u_dc", "theta_m_enc", "theta_e_ext", "w_e_ext",
                                                                     "w_m_ref", "i_d_ref", "i_q_ref", "u_d_ref",
                                                                     "u_q_ref", "w_e_ref") if k in names]
    real_out = [f"duty_{p}" for p in "abcde"[:phases]] + ["theta_e", "w_e", "theta_est", "w_est", "T_ref"]
    in_vr, out_vr = [vr[k] for k in real_in], [vr[k] for k in real_out]
    din, dout, t = ffi.new("fs_drive_in *"), ffi.new("fs_drive_out *"), ffi.new("double *")
    duty = ffi.new("float[]", phases)
    got, want, stages = np.empty((n, len(real_out) + 1)), np.empty((n, len(real_out) + 1)), set()
    stop = "done"
    k = 0
    for k in range(n):
        if lib.fs_sim_sample(sim, din, t) != lib.FS_RUN_DONE:
            stop = "sample refused"
            break
        values = [din.i_ph[j] for j in range(phases)] + [float(getattr(din, name)) for name in real_in[phases:]]
        set_real(in_vr, values)
        if "sensorless" in names:
            fmu.setBoolean([vr["sensorless"]], [bool(din.sensorless)])
        fmu.doStep(currentCommunicationPoint=t[0], communicationStepSize=Tc)
        got[k, :-1] = get_real(out_vr)
        got[k, -1] = get_int([vr["stage"]])[0]
        lib.fs_drive_step(host, din, dout)
        want[k, :-1] = [dout.duty[j] for j in range(phases)] + [dout.theta_e, dout.w_e, dout.theta_est, dout.w_est,
                                                              dout.T_ref]
        want[k, -1] = dout.stage
        stages.add(int(dout.stage))
        for j in range(phases):
            duty[j] = got[k, j]
        rc = lib.fs_sim_actuate(sim, duty, ffi.NULL)
        if rc != lib.FS_RUN_DONE:
            stop = {lib.FS_STOP_NAN: "nan", lib.FS_STOP_OVERCURRENT: "overcurrent"}.get(rc, f"stop {rc}")
            k += 1
            break
    else:
        k = n
    fmu.terminate()
    fmu.freeInstance()
    out = {"steps": int(k), "stop": stop, "stages": sorted(stages)}
    for j, name in enumerate(real_out + ["stage"]):
        out[name] = _worst(got[:k, j], want[:k, j])
    run = simulate(sc)   # fullspeed's own run: the duties the loop with the FMU must have reproduced
    m = min(k, len(run.traces["t"]))
    out["vs_run_duty"] = max(_worst(got[:m, j], run.traces[f"duty_{p}"][:m]) for j, p in enumerate("abc"))
    out["run_stop"] = run.stop_reason
    out["bitwise"] = all(out[name] == 0.0 for name in real_out + ["stage", "vs_run_duty"])
    return out


def outputs_of(kind: str) -> list[str]:
    """The output names an FMU of kind can have."""
    return [v.name for v in MODELS[kind] if v.causality == "output"]
