"""Self-commissioning on the simulated machine: the drive's identification
mode (csrc/control/fs_ident.h) run on a scenario's machine, converter and
sensors (dead time, noise and quantization as the scenario has them), and
the identified values beside the truth.

Each quantity comes with its status and, when it failed, the reason and the
step; no value is reported without a status."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core import ffi, lib
from ..design.machine import machine_from_dict
from ..design.scenario import load_scenario, scenario_from_dict
from ..model.errors import ConfigError, SimulationError
from ..model.files import replace_folder
from ..model.scenario import Scenario
from ..model.schema import toml_string
from ..model.zoo import SEED as ZOO_SEED
from ..model.zoo import machine as zoo_machine
from ..sim.config import build_config, set_fluxmap
from ..sim.runner import CHANNELS, simulate
from .journal import run_tasks


QUANTITIES = ["verr", "R_s", "L_d", "L_q", "psi_f", "J", "friction"]   # fs_ident_quantity order
STEP_NAMES = ["start", "probe", "align", "levels", "ldq", "spin", "flux", "accel", "coast", "done", "failed"]
# the step that measures each quantity (for a failure's report)
STEP_OF = {"verr": "levels", "R_s": "levels", "L_d": "ldq", "L_q": "ldq", "psi_f": "flux", "J": "coast",
           "friction": "coast"}
GOALS_PCT = {"R_s": 3.0, "L_d": 5.0, "L_q": 5.0, "psi_f": 3.0, "J": 10.0}


@dataclass
class Identification:
    """What the sequence returned, the truth, and the run's facts."""
    machine: str
    status: dict[str, str]            # quantity -> "ok" | "failed" | "pending"
    reason: dict[str, str]            # quantity -> reason text ("" when ok)
    values: dict[str, float]          # only quantities whose status is "ok" (friction: B, T_c; verr: u_e, i_e)
    truth: dict[str, float]
    step: str                         # where the sequence ended: done, failed, or the step it timed out in
    sim_time: float
    wall_time: float
    details: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.step == "done" and all(s == "ok" for s in self.status.values())

    def errors_pct(self) -> dict[str, float]:
        """Relative errors of the quantities with a goal, where identified."""
        return {q: 100.0 * (self.values[q] - self.truth[q]) / self.truth[q]
                for q in GOALS_PCT if q in self.values and self.truth.get(q)}

    def failures(self) -> list[str]:
        """'quantity (step): reason' for every quantity not identified."""
        return [f"{q} ({STEP_OF[q]}): {self.reason[q] or self.status[q]}" for q in QUANTITIES if self.status[q] != "ok"]


def small_signal_inductances(m) -> tuple[float, float]:
    """The plant's incremental L_d, L_q at zero current (the unsaturated
    values at the magnet's own flux: what a standstill test at zero bias
    sees), from its magnetic model by central differences."""
    cfg = ffi.new("fs_mag_config *")
    mag = m.magnetic
    cfg.kind = {"linear": lib.FS_MAG_LINEAR, "algebraic": lib.FS_MAG_ALGEBRAIC, "fluxmap": lib.FS_MAG_FLUXMAP}[mag["model"]]
    cfg.L_d, cfg.L_q, cfg.psi_f = m.L_d, m.L_q, m.psi_f
    keep = []
    if mag["model"] == "algebraic":
        for k in ("a_dd", "a_qq", "a_dq", "S", "T", "U", "V"):
            setattr(cfg, k, mag[k])
    elif mag["model"] == "fluxmap":
        set_fluxmap(cfg, mag, keep.append)
    st = ffi.new("fs_mag *")
    if lib.fs_mag_init(st, cfg) != lib.FS_OK:
        return m.L_d, m.L_q
    pd, pq = ffi.new("double *"), ffi.new("double *")
    h = 1e-4 * m.i_rated

    def flux(i_d, i_q):
        lib.fs_mag_flux(st, i_d, i_q, pd, pq)
        return pd[0], pq[0]
    L_d = (flux(h, 0.0)[0] - flux(-h, 0.0)[0]) / (2 * h)
    L_q = (flux(0.0, h)[1] - flux(0.0, -h)[1]) / (2 * h)
    return L_d, L_q


def _truth(sc: Scenario) -> dict[str, float]:
    m, conv = sc.machine, sc.data["converter"]
    L_d, L_q = small_signal_inductances(m)
    return {"R_s": m.R_s, "L_d": L_d, "L_q": L_q, "psi_f": m.psi_f, "J": m.J, "B": m.B, "T_c": m.T_coulomb,
            "u_e": conv["t_dead"] * conv["f_pwm"] * conv["u_dc"] + conv["u_on"],
            "L_d_nominal": m.L_d, "L_q_nominal": m.L_q}


def identify(scenario: Scenario | str, overrides: dict | None = None, speed_frac: float = 0.3,
             t_ramp: float = 1.0, t_limit: float = 30.0, trace_decimation: int = 0) -> Identification:
    """Run the identification mode on a scenario's machine and bench.

    speed_frac: the running steps' speed as a fraction of the rated speed (the
    sequence lowers it where the EMF would pass half the linear voltage);
    t_ramp: s of the I/f ramp to it; t_limit: simulated seconds before the run
    counts as stuck (reported with the step it was in)."""
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario, overrides)
    m = sc.machine
    if m.phases != 3:
        raise ConfigError("machine.phases", m.phases, "identification runs on three-phase machines", sc.source)
    if sc.data["converter"]["kind"] != "inverter":
        raise ConfigError("converter.kind", sc.data["converter"]["kind"], "identification runs on the inverter", sc.source)
    if sc.data["load"]["kind"] != "torque":
        raise ConfigError("load.kind", sc.data["load"]["kind"], "identification needs a free shaft (kind = \"torque\")", sc.source)
    if not (0.0 < speed_frac <= 1.0):
        raise ConfigError("speed_frac", speed_frac, "must be in (0, 1]", sc.source)
    cfg, keep = build_config(sc)
    dc = cfg.drive
    dc.mode = lib.FS_MODE_IDENTIFY
    dc.t_dead_comp = 0.0                       # the sequence measures the inverter's error itself
    dc.ident.w_spin = m.pole_pairs * speed_frac * m.w_m_rated
    dc.ident.t_ramp = t_ramp
    dc.ident.u_dc_min = 0.0
    # no traces are kept unless asked for (details["traces"]): the result is read from the drive
    cfg.decimation = trace_decimation or 10**6
    # a free shaft: no load torque (the scenario's profile is for its own run), no references
    for name in ("w_m_ref", "i_d_ref", "i_q_ref", "u_d_ref", "u_q_ref", "w_e_ref", "sensorless", "T_load", "w_load"):
        getattr(cfg, name).n = 0
    err = ffi.new("char[]", 512)
    ptr = lib.fs_sim_create(cfg, err, 512)
    if ptr == ffi.NULL:
        raise SimulationError(f"{sc.source or sc.name}: {ffi.string(err).decode()}")
    sim = ffi.gc(ptr, lib.fs_sim_destroy)
    drv = lib.fs_sim_drive(sim)
    n_buf = 4 if not trace_decimation else int(t_limit / (dc.Ts * trace_decimation)) + 4
    buf = np.empty((n_buf, lib.FS_CH_N))
    n_rows = 0
    rows = ffi.new("int *")
    t0 = time.perf_counter()
    stop = "done"
    t = 0.0
    while drv.ident.step not in (lib.FS_IDENT_DONE, lib.FS_IDENT_FAILED) and t < t_limit:
        t = min(t + 0.05, t_limit)
        at = n_rows if trace_decimation else 0
        rc = lib.fs_sim_run(sim, t, ffi.cast("double *", buf.ctypes.data) + at * lib.FS_CH_N, n_buf - at, rows)
        n_rows = at + rows[0]
        if rc not in (lib.FS_RUN_DONE, lib.FS_RUN_BUFFER_FULL):
            stop = {lib.FS_STOP_NAN: "nan", lib.FS_STOP_OVERCURRENT: "overcurrent"}.get(rc, f"stop {rc}")
            break
    wall = time.perf_counter() - t0
    res = _result(sc, drv, stop, lib.fs_sim_time(sim), wall)
    if trace_decimation:
        res.details["traces"] = dict(zip(CHANNELS, buf[:n_rows].T.copy()))
    return res


def _result(sc: Scenario, drv, stop: str, sim_time: float, wall: float) -> Identification:
    r = drv.ident.res
    step = STEP_NAMES[drv.ident.step]
    status, reason, values = {}, {}, {}
    for k, q in enumerate(QUANTITIES):
        s = {lib.FS_IDS_OK: "ok", lib.FS_IDS_FAILED: "failed"}.get(r.status[k], "pending")
        why = ffi.string(lib.fs_ident_reason_str(r.reason[k])).decode() if s == "failed" else ""
        if s == "pending":   # the run ended before the sequence reached it
            s, why = "failed", (f"the simulation stopped ({stop}) in step {step}" if stop != "done"
                                else f"not reached: step {step} did not finish in time")
        status[q], reason[q] = s, why
    if status["verr"] == "ok":
        values["u_e"], values["i_e"] = r.u_e, r.i_e
    for q in ("R_s", "L_d", "L_q", "psi_f", "J"):
        if status[q] == "ok":
            values[q] = getattr(r, q)
    if status["friction"] == "ok":
        values["B"], values["T_c"] = r.B, r.T_c
    if status["L_q"] == "ok":   # L_q's change with i_d (H/A), between the two biases of its carrier
        values["dL_q_di_d"] = r.dL_q
    details = {"snr_rs": r.snr_rs, "r_fit_rs": r.r_fit_rs, "snr_l": r.snr_l, "snr_psi": r.snr_psi,
               "eps_align_deg": math.degrees(r.eps_align), "w_flux": r.w_flux, "a_acc": r.a_acc, "a_coast": r.a_coast,
               "L_probe": drv.ident.L0, "i_acc": drv.ident.i_acc, "i_e": r.i_e,
               "I_bias": list(r.I_bias), "L_q_bias": list(r.L_q_bias), "dL_q": r.dL_q,
               "I_lev": [r.I_lev[k] for k in range(lib.FS_IDENT_NLEV)], "U_lev": [r.U_lev[k] for k in range(lib.FS_IDENT_NLEV)]}
    if stop != "done" and step not in ("done", "failed"):
        step = f"{step} (simulation stopped: {stop})"
    return Identification(sc.machine.name, status, reason, values, _truth(sc), step, sim_time, wall, details)


# ---- the files ----

def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf"))
    if isinstance(v, str):
        return toml_string(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(type(v))


def _toml(tables: dict[str, dict]) -> str:
    out = []
    for name, tab in tables.items():
        if name:
            out.append(f"\n[{name}]")
        for k, v in tab.items():
            if v is not None:
                out.append(f"{k} = {_toml_value(v)}")
    return "\n".join(out).lstrip() + "\n"


def report_tables(res: Identification) -> dict[str, dict]:
    """Per quantity: status, reason, step, and where identified the value,
    the truth and the error."""
    tabs: dict[str, dict] = {"": {"machine": res.machine, "ended_in": res.step, "sim_time_s": res.sim_time}}
    keys = {"verr": ["u_e", "i_e"], "friction": ["B", "T_c"]}
    for q in QUANTITIES:
        t = {"status": res.status[q], "step": STEP_OF[q]}
        if res.status[q] != "ok":
            t["reason"] = res.reason[q]
        for k in keys.get(q, [q]):
            tail = "" if k == q else f"_{k}"
            if k in res.values:
                t[f"identified{tail}"] = res.values[k]
            if k in res.truth:
                t[f"truth{tail}"] = res.truth[k]
            if k in res.values and res.truth.get(k):
                t[f"error_pct{tail}"] = 100.0 * (res.values[k] - res.truth[k]) / res.truth[k]
        if q == "L_q" and "dL_q_di_d" in res.values:
            t["identified_dL_q_di_d"] = res.values["dL_q_di_d"]   # H/A, between d biases of details["I_bias"]
        if q in ("L_d", "L_q"):
            t["truth_nominal"] = res.truth[f"{q}_nominal"]
            t["truth_is"] = "the plant's incremental inductance at zero current (the unsaturated value the standstill test sees)"
        tabs[q] = t
    return tabs


def machine_table(res: Identification, sc: Scenario) -> dict | None:
    """The machine file of the identified values (its bench and ratings from
    the scenario's machine), or None unless R_s, L_d, L_q, psi_f and J are all
    identified."""
    need = ("R_s", "L_d", "L_q", "psi_f", "J")
    if not all(res.status[q] == "ok" for q in need):
        return None
    m = sc.machine
    v = res.values
    kind = "ipmsm" if v["L_d"] < v["L_q"] and not math.isclose(v["L_d"], v["L_q"], rel_tol=0.05) else "spmsm"
    if kind == "spmsm":
        v = dict(v, L_q=v["L_d"]) if abs(v["L_q"] - v["L_d"]) > 0.05 * v["L_d"] else v
    return {
        "name": f"{m.name}-identified", "kind": kind, "phases": 3, "pole_pairs": m.pole_pairs,
        "description": f"{m.name} as identified by `fullspeed identify` (fs_ident.h)",
        "electrical": {"R_s": v["R_s"], "L_d": v["L_d"], "L_q": v["L_q"], "psi_f": v["psi_f"]},
        "mechanical": {"J": v["J"], "B": v.get("B", 0.0), "T_coulomb": v.get("T_c", 0.0)},
        "rated": {k: val for k, val in {"torque": m.T_rated, "current": m.i_rated,
                                        "speed_rpm": m.w_m_rated * 60 / (2 * math.pi)}.items()},
        "bench": {k: val for k, val in m.bench.items() if k != "reasons" and val is not None},
    }


def _machine_toml(tab: dict) -> str:
    top = {k: v for k, v in tab.items() if not isinstance(v, dict)}
    subs = {k: v for k, v in tab.items() if isinstance(v, dict)}
    return _toml({"": top, **subs})


OUTPUTS = ("identification.toml", "machine.toml")   # what an identification's folder holds


def write_identification(res: Identification, sc: Scenario, out: Path) -> list[Path]:
    """identification.toml (every quantity with its status) and, when the
    electrical and mechanical quantities are all identified, machine.toml:
    the folder replaced as a whole (files.replace_folder), so that it never
    pairs one identification's report with another's machine, and a failed
    identification leaves no machine.toml of an earlier one."""
    files = {OUTPUTS[0]: _toml(report_tables(res))}
    tab = machine_table(res, sc)
    if tab is not None:
        files[OUTPUTS[1]] = _machine_toml(tab)
    return replace_folder(out, files, OUTPUTS)


def print_identification(res: Identification) -> None:
    """One line per quantity: identified, truth and error, or the failure."""
    rows = [("u_e", "V"), ("R_s", "ohm"), ("L_d", "H"), ("L_q", "H"), ("psi_f", "Wb"), ("J", "kg m^2"),
            ("B", "N m s/rad"), ("T_c", "N m")]
    quantity = {"u_e": "verr", "B": "friction", "T_c": "friction"}
    print(f"{res.machine}: identification ended in step '{res.step}' after {res.sim_time:.2f} s simulated "
          f"({res.wall_time:.1f} s wall)")
    for key, unit in rows:
        q = quantity.get(key, key)
        if res.status[q] != "ok":
            print(f"  {key:6s} failed in step {STEP_OF[q]}: {res.reason[q]}")
            continue
        v, t = res.values[key], res.truth.get(key)
        err = f"{100.0 * (v - t) / t:+7.2f} %" if t else "   (truth 0)"
        goal = f"   goal {GOALS_PCT[key]:g} %" if key in GOALS_PCT else ""
        print(f"  {key:6s} {v:12.5g} {unit:9s} truth {t:12.5g}  error {err}{goal}")


# ---- the zoo campaign (claim B-IDENT) ----

def zoo_identification(k: int, seed: int | None = None) -> dict:
    """Identify zoo machine k (fullspeed.model.zoo) from a seeded initial rotor
    angle: one row of the campaign, every quantity with its status."""
    seed = ZOO_SEED if seed is None else seed
    theta0 = float(np.random.default_rng([seed, k, 25]).uniform(-180.0, 180.0))   # the rotor rests anywhere
    sc = scenario_from_dict({"name": f"identify-zoo-{seed}-{k}", "duration": 1.0,
                             "machine": {"zoo": k, "zoo_seed": seed}, "controller": {"mode": "off"},
                             "initial": {"theta_e_deg": theta0}})
    res = identify(sc)
    return {"k": k, "machine": res.machine, "description": sc.machine.description, "theta_e0_deg": theta0,
            "ended_in": res.step, "status": res.status, "reason": res.reason, "errors_pct": res.errors_pct(),
            "failures": res.failures(), "sim_time": res.sim_time, "wall_time": res.wall_time}


def _zoo_task(task: dict) -> dict:
    """journal.run_tasks' worker: one zoo machine (a refusal comes back as a
    row with stop_reason "error" and its reason: journal.guarded)."""
    return zoo_identification(task["k"], task["seed"])


_zoo_task.journal_name = "fullspeed.identify._zoo_task"   # its module before the layers (journal._identity)


def zoo_campaign(ks, out: Path, seed: int | None = None, workers: int | None = None,
                 progress: bool = False, fresh: bool = True) -> list[dict]:
    """The identification of zoo machines ks, in parallel processes,
    journaled in out (workflows.journal: a killed campaign resumes with
    fresh=False). A machine that could not be run is a row with its reason."""
    ks = [int(k) for k in ks]
    results = run_tasks(_zoo_task, [{"k": k, "seed": seed} for k in ks], out, workers=workers,
                        progress=progress, fresh=fresh, desc="identify")
    rows = []
    for k, r in zip(ks, results):
        if r is None or r.get("stop_reason") == "error":
            why = (r or {}).get("error", "not run")
            r = {"k": k, "machine": f"zoo-{k}", "ended_in": "refused", "status": {q: "failed" for q in QUANTITIES},
                 "reason": {q: why for q in QUANTITIES}, "errors_pct": {}, "failures": [f"refused: {why}"]}
        rows.append(r)
    return rows


def campaign_summary(rows: list[dict]) -> dict:
    """Per quantity with a goal: how many were identified and the 50th,
    95th percentile and worst |error|, %; the share of identifications that
    failed (each with a reason) and the failures themselves."""
    out: dict = {"machines": len(rows)}
    for q in GOALS_PCT:
        e = np.abs([r["errors_pct"][q] for r in rows if q in r["errors_pct"]])
        out[q] = {"identified": int(e.size), "p50": float(np.percentile(e, 50)) if e.size else None,
                  "p95": float(np.percentile(e, 95)) if e.size else None, "max": float(e.max()) if e.size else None}
    failed = [r for r in rows if any(s != "ok" for s in r["status"].values())]
    out["failed_pct"] = 100.0 * len(failed) / max(len(rows), 1)
    out["failed_with_reason"] = sum(all(r["reason"][q] for q in QUANTITIES if r["status"][q] != "ok") for r in failed)
    out["failures"] = {r["machine"]: r["failures"] for r in failed}
    return out


def identified_scales(row: dict, k: int, seed: int | None = None) -> dict | None:
    """The controller's parameter scales (controller.R_s_scale, ...) that put
    zoo machine k's identified values in the controller, from a campaign row;
    None if a quantity was not identified. The inductances' truth is the
    small-signal one the identification measures (identified = truth x (1 +
    error)), the scale against the machine file's nominal values."""
    if any(row["status"].get(q) != "ok" for q in ("R_s", "L_d", "L_q", "psi_f", "J")):
        return None
    m = machine_from_dict(zoo_machine(k, ZOO_SEED if seed is None else seed))
    L_d, L_q = small_signal_inductances(m)
    e = {q: 1.0 + row["errors_pct"][q] / 100.0 for q in ("R_s", "L_d", "L_q", "psi_f", "J")}
    return {"R_s_scale": e["R_s"], "L_d_scale": e["L_d"] * L_d / m.L_d, "L_q_scale": e["L_q"] * L_q / m.L_q,
            "psi_f_scale": e["psi_f"], "J_scale": e["J"]}


def _sensorless_task(task: dict) -> dict:
    """journal.run_tasks' worker: the zoo's sensorless run (scenario
    beyond-zoo) of machine k with the controller's parameters scaled (the
    identified ones) or not (the true ones)."""
    r = simulate(load_scenario("beyond-zoo", {"machine": {"zoo": task["k"]}, "controller": task["scales"]}))
    m = r.metrics
    return {"stop_reason": r.stop_reason, "lock_lost_at": m["lock_lost_at"], "true_loss_at": m["true_loss_at"],
            "sensorless_err_deg_max": m["sensorless_err_deg_max"]}


def sensorless_on_identified(rows: list[dict], out: Path, workers: int | None = None) -> dict:
    """The zoo's saturating machines (the linear ones refuse to start by
    their polarity detection) run sensorless on their true and on their
    identified parameters: how often each keeps lock (completed, no loss of
    lock flagged or seen by the simulation's truth)."""
    tasks = []
    for row in rows:
        k = int(row["k"])
        if k % 2:   # the zoo's linear machines
            continue
        scales = identified_scales(row, k)
        if scales is not None:
            tasks += [{"k": k, "scales": {}}, {"k": k, "scales": scales}]
    res = run_tasks(_sensorless_task, tasks, out, workers=workers, fresh=True, desc="sensorless")

    def kept(r):
        return r is not None and r.get("stop_reason") == "done" and r.get("lock_lost_at") is None \
            and r.get("true_loss_at") is None
    true_kept = sum(kept(r) for t, r in zip(tasks, res) if not t["scales"])
    ident_kept = sum(kept(r) for t, r in zip(tasks, res) if t["scales"])
    differ = [t["k"] for t, r, r0 in zip(tasks[1::2], res[1::2], res[0::2]) if kept(r) != kept(r0)]
    return {"machines": len(tasks) // 2, "kept_true": true_kept, "kept_identified": ident_kept, "differ": differ}
