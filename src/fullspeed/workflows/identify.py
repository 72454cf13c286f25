"""Self-commissioning on the simulated machine: the drive's identification
mode (csrc/control/fs_ident.h) run on a scenario's machine, converter and
sensors (dead time, noise and quantization as the scenario has them), and
the identified values beside the truth.

Each quantity comes with its status and, when it failed, the reason and the
step; no value is reported without a status. A value identified but
outside its goal against the truth has the status "outside goal" (the
simulation knows the truth; a drive on a real machine would not). The
scenario's [identify] table says what the commissioning may do: whether the
rotor may turn, whether it is locked, the test currents and windows, and
whether the flux map is identified (workflows/mapid.py makes the drive's
readings a map)."""
from __future__ import annotations

import math
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core import ffi, lib
from ..design.machine import load_machine, machine_from_dict
from ..design.scenario import load_scenario, scenario_from_dict
from ..design.start import largest_on
from ..model.errors import ConfigError, SimulationError
from ..model.files import replace_folder
from ..model.scenario import Scenario
from ..model.schema import toml_string
from ..model.zoo import SEED as ZOO_SEED
from ..model.zoo import machine as zoo_machine
from ..sim.config import build_config, set_fluxmap
from ..sim.runner import CHANNELS, simulate
from . import mapid
from .journal import run_tasks


QUANTITIES = ["verr", "R_s", "L_d", "L_q", "map", "psi_f", "J", "friction"]   # fs_ident_quantity order
IDENT_QUANTITIES = [q for q in QUANTITIES if q != "map"]   # claim B-IDENT's (the map is B-MAPID's)
STEP_NAMES = [ffi.string(lib.fs_ident_step_str(k)).decode() for k in range(lib.FS_IDENT_NSTEPS)]
# the step that measures each quantity (for a failure's report)
STEP_OF = {"verr": "levels", "R_s": "levels", "L_d": "ldq", "L_q": "ldq", "map": "map", "psi_f": "flux", "J": "coast",
           "friction": "coast"}
# the steps each quantity's measurement takes (its time), in the sequence's order
STEPS_OF = {"verr": ("levels",), "R_s": ("levels",), "L_d": ("axis", "align", "ldq"), "L_q": ("ldq",),
            "map": ("map", "check", "dcurve"), "psi_f": ("spin", "flux"), "J": ("accel", "coast"), "friction": ("coast",)}
STANDSTILL = ("probe", "axis", "align", "polarity", "levels", "ldq", "map", "check")
GOALS_PCT = {"R_s": 3.0, "L_d": 5.0, "L_q": 5.0, "psi_f": 3.0, "J": 10.0}
MAP_GOAL_PCT = mapid.GOAL_PCT   # the map's RMS error over the disc, % of psi_f
OUTSIDE = "outside goal"


@dataclass
class Identification:
    """What the sequence returned, the truth, and the run's facts."""
    machine: str
    status: dict[str, str]            # quantity -> "ok" | "outside goal" | "failed" | "skipped" | "pending"
    reason: dict[str, str]            # quantity -> reason text ("" when ok)
    values: dict[str, float]          # only quantities identified (friction: B, T_c; verr: u_e, i_e)
    truth: dict[str, float]
    step: str                         # where the sequence ended: done, failed, or the step it timed out in
    sim_time: float
    wall_time: float
    details: dict = field(default_factory=dict)
    map: dict | None = None           # the identified map: grid, readings, errors, polarity (workflows/mapid.py)
    motion: dict = field(default_factory=dict)   # the rotor's motion at standstill: the drive's and the truth's
    times: dict = field(default_factory=dict)    # s on the drive: per step, per quantity, total

    @property
    def ok(self) -> bool:
        """Done, every quantity identified within its goal or skipped as configured."""
        return self.step == "done" and all(s in ("ok", "skipped") for s in self.status.values())

    def errors_pct(self) -> dict[str, float]:
        """Relative errors of the quantities with a goal, where identified."""
        return {q: 100.0 * (self.values[q] - self.truth[q]) / self.truth[q]
                for q in GOALS_PCT if q in self.values and self.truth.get(q)}

    def failures(self) -> list[str]:
        """'quantity (step): reason' for every quantity not identified (or outside its goal)."""
        return [f"{q} ({STEP_OF[q]}): {self.reason[q] or self.status[q]}" for q in QUANTITIES
                if self.status[q] not in ("ok", "skipped")]


def _mag(m):
    """The plant's magnetic model of machine m (fs_mag) and what it points into."""
    cfg = ffi.new("fs_mag_config *")
    mag = m.magnetic
    cfg.kind = {"linear": lib.FS_MAG_LINEAR, "algebraic": lib.FS_MAG_ALGEBRAIC, "fluxmap": lib.FS_MAG_FLUXMAP}[mag["model"]]
    cfg.L_d, cfg.L_q, cfg.psi_f = m.L_d, m.L_q, m.psi_f
    keep = [cfg]
    if mag["model"] == "algebraic":
        for k in ("a_dd", "a_qq", "a_dq", "S", "T", "U", "V"):
            setattr(cfg, k, mag[k])
    elif mag["model"] == "fluxmap":
        set_fluxmap(cfg, mag, lambda x: keep.append(x) or x)   # the buffers live as long as keep
    st = ffi.new("fs_mag *")
    if lib.fs_mag_init(st, cfg) != lib.FS_OK:
        return None, keep
    return st, keep


def true_flux(m):
    """(i_d, i_q) -> (psi_d, psi_q) of the plant's magnetics of machine m, for
    arrays (the truth the identified map is held against)."""
    st, keep = _mag(m)
    if st is None:
        raise SimulationError(f"{m.name}: its magnetic model does not initialise")
    pd, pq = ffi.new("double *"), ffi.new("double *")

    def flux(i_d, i_q):
        a, b = np.broadcast_arrays(np.asarray(i_d, float), np.asarray(i_q, float))
        out_d, out_q = np.empty(a.shape), np.empty(a.shape)
        for idx in np.ndindex(a.shape):
            lib.fs_mag_flux(st, a[idx], b[idx], pd, pq)
            out_d[idx], out_q[idx] = pd[0], pq[0]
        return out_d, out_q
    flux.keep = (st, keep)
    return flux


def small_signal_inductances(m) -> tuple[float, float]:
    """The plant's incremental L_d, L_q at zero current (the unsaturated
    values at the magnet's own flux: what a standstill test at zero bias
    sees), from its magnetic model by central differences."""
    st, keep = _mag(m)
    if st is None:
        return m.L_d, m.L_q
    pd, pq = ffi.new("double *"), ffi.new("double *")
    h = 1e-4 * m.i_rated

    def flux(i_d, i_q):
        lib.fs_mag_flux(st, i_d, i_q, pd, pq)
        return pd[0], pq[0]
    L_d = (flux(h, 0.0)[0] - flux(-h, 0.0)[0]) / (2 * h)
    L_q = (flux(0.0, h)[1] - flux(0.0, -h)[1]) / (2 * h)
    return L_d, L_q


def _plant(sc: Scenario):
    """The machine the simulation turns (the scenario's plant_machine, else
    its machine): the truth an identification is judged against. The drive
    knows `machine` (the nameplate it starts from); where plant_machine
    differs, the identification finds the plant's values, and judging them
    against the nameplate called right values failures (the new-user trial:
    psi_f and J found within 0.2 %, reported +10.9 % and +48.9 %)."""
    return sc.plant or sc.machine


def _truth(sc: Scenario) -> dict[str, float]:
    m, conv = _plant(sc), sc.data["converter"]
    L_d, L_q = small_signal_inductances(m)
    return {"R_s": m.R_s, "L_d": L_d, "L_q": L_q, "psi_f": m.psi_f, "J": m.J, "B": m.B, "T_c": m.T_coulomb,
            "u_e": conv["t_dead"] * conv["f_pwm"] * conv["u_dc"] + conv["u_on"],
            "L_d_nominal": m.L_d, "L_q_nominal": m.L_q}


def settings(sc: Scenario, speed_frac: float | None = None, t_ramp: float | None = None) -> dict:
    """The scenario's [identify] table with the command line's overrides, checked
    against the machine and bench (a ConfigError before anything runs)."""
    s = dict(sc.data.get("identify") or {})
    if speed_frac is not None:
        s["speed_frac"] = speed_frac
    if t_ramp is not None:
        s["t_ramp"] = t_ramp
    s.setdefault("speed_frac", 0.3)
    s.setdefault("t_ramp", 1.0)
    for k, v in (("may_turn", True), ("locked", False), ("map", True), ("i_test", None), ("t_level", None),
                 ("motion_max_deg", 1.0), ("t_limit", 30.0)):
        s.setdefault(k, v)
    if not (0.0 < s["speed_frac"] <= 1.0):
        raise ConfigError("speed_frac", s["speed_frac"], "must be in (0, 1]", sc.source)
    i_max = sc.data["controller"]["i_max"]
    if s["i_test"] is not None and s["i_test"] > i_max:
        raise ConfigError("identify.i_test", s["i_test"], f"must be <= the current limit controller.i_max = {i_max:g} A", sc.source)
    Ts = 1.0 / sc.data["converter"]["f_pwm"] / (2 if sc.data["timing"]["sampling"] == "double" else 1)
    for key in ("t_level", "t_ramp"):
        if s[key] is not None and s[key] < 100 * Ts:
            raise ConfigError(f"identify.{key}", s[key], f"must be at least 100 control periods ({100 * Ts:g} s)", sc.source)
    return s


def identify(scenario: Scenario | str, overrides: dict | None = None, speed_frac: float | None = None,
             t_ramp: float | None = None, t_limit: float | None = None, trace_decimation: int = 0) -> Identification:
    """Run the identification mode on a scenario's machine and bench.

    The scenario's [identify] table (model/scenario.py) says what it may do;
    speed_frac, t_ramp and t_limit override it (the running steps' speed as
    a fraction of rated, lowered where the EMF would pass half the linear
    voltage; s of the I/f ramp to it; simulated seconds before the run
    counts as stuck, reported with the step it was in)."""
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario, overrides)
    m = sc.machine
    if m.phases != 3:
        raise ConfigError("machine.phases", m.phases, "identification runs on three-phase machines", sc.source)
    if sc.data["converter"]["kind"] != "inverter":
        raise ConfigError("converter.kind", sc.data["converter"]["kind"], "identification runs on the inverter", sc.source)
    s = settings(sc, speed_frac, t_ramp)
    if t_limit is not None:
        s["t_limit"] = t_limit
    if sc.data["load"]["kind"] != "torque" and not s["locked"]:
        raise ConfigError("load.kind", sc.data["load"]["kind"], "identification needs a free shaft (kind = \"torque\"), or "
                          "[identify] locked = true", sc.source)
    notes = []
    T_load = largest_on(sc.data["load"]["torque"], math.inf)
    if T_load > 0.0 and not s["locked"]:   # the profile is the scenario's own run's: said, not dropped unsaid
        notes.append(f"load.torque: the scenario's load (up to {T_load:.4g} N m) is not applied: the identification turns "
                     "a free shaft with no load; where that load acts on the real rotor at standstill it turns it: "
                     "[identify] locked = true")
    cfg, keep = build_config(sc)
    dc = cfg.drive
    dc.mode = lib.FS_MODE_IDENTIFY
    dc.t_dead_comp = 0.0                       # the sequence measures the inverter's error itself
    dc.ident.w_spin = m.pole_pairs * s["speed_frac"] * m.w_m_rated
    dc.ident.t_ramp = s["t_ramp"]
    dc.ident.u_dc_min = 0.0
    dc.ident.psi_f_hint, dc.ident.J_hint = m.psi_f, m.J   # the machine file's: size the map's q sweeps
    dc.ident.standstill_only = 0 if s["may_turn"] else 1
    dc.ident.locked = 1 if s["locked"] else 0
    dc.ident.skip_map = 0 if s["map"] else 1
    dc.ident.i_test = s["i_test"] or 0.0
    dc.ident.t_level = s["t_level"] or 0.0
    dc.ident.motion_max = math.radians(s["motion_max_deg"])
    if s["locked"]:   # the shaft held at zero speed
        cfg.plant.load_kind = lib.FS_LOAD_SPEED_IDEAL
    # traces: the rotor's angle and speed and the current every ~0.5 ms for the motion's report, or
    # every channel at trace_decimation (details["traces"])
    Ts = dc.Ts
    dec = trace_decimation or max(1, int(round(5e-4 / Ts)))
    cfg.decimation = dec
    # a free shaft: no load torque (the scenario's profile is for its own run), no references
    for name in ("w_m_ref", "i_d_ref", "i_q_ref", "u_d_ref", "u_q_ref", "w_e_ref", "sensorless", "T_load", "w_load"):
        getattr(cfg, name).n = 0
    err = ffi.new("char[]", 512)
    ptr = lib.fs_sim_create(cfg, err, 512)
    if ptr == ffi.NULL:
        raise SimulationError(f"{sc.source or sc.name}: {ffi.string(err).decode()}")
    sim = ffi.gc(ptr, lib.fs_sim_destroy)
    drv = lib.fs_sim_drive(sim)
    chunk = 0.05
    n_chunk = int(chunk / (Ts * dec)) + 4
    n_buf = n_chunk if not trace_decimation else int(s["t_limit"] / (Ts * dec)) + 4
    buf = np.empty((n_buf, lib.FS_CH_N))
    col = {c: CHANNELS.index(c) for c in ("t", "theta_e", "w_m", "i_d", "i_q")}
    kept = []
    n_rows = 0
    rows = ffi.new("int *")
    t0 = time.perf_counter()
    stop = "done"
    t = 0.0
    while drv.ident.step not in (lib.FS_IDENT_DONE, lib.FS_IDENT_FAILED) and t < s["t_limit"]:
        t = min(t + chunk, s["t_limit"])
        at = n_rows if trace_decimation else 0
        rc = lib.fs_sim_run(sim, t, ffi.cast("double *", buf.ctypes.data) + at * lib.FS_CH_N, n_buf - at, rows)
        got = buf[at:at + rows[0]]
        kept.append(got[:, [col["t"], col["theta_e"], col["w_m"], col["i_d"], col["i_q"]]].copy())
        n_rows = at + rows[0]
        if rc not in (lib.FS_RUN_DONE, lib.FS_RUN_BUFFER_FULL):
            stop = {lib.FS_STOP_NAN: "nan", lib.FS_STOP_OVERCURRENT: "overcurrent"}.get(rc, f"stop {rc}")
            break
    wall = time.perf_counter() - t0
    res = _result(sc, s, drv, stop, lib.fs_sim_time(sim), wall, np.vstack(kept) if kept else np.zeros((0, 5)))
    i_top = res.details.get("i_level_top", 0.0)
    if s["i_test"] and 0.0 < i_top < 0.99 * s["i_test"]:   # held lower by the drive (schema: identify.i_test)
        psi_f, dL = m.psi_f, m.L_q - m.L_d
        why = (f"half of psi_f / (L_q - L_d) = {psi_f:.4g} Wb / {1e3 * dL:.4g} mH on a free rotor: above it the "
               "reluctance torque's push beats the magnet's pull" if dL > 0 and not s["locked"] else "the drive's bound")
        notes.append(f"identify.i_test: {s['i_test']:.4g} A asked, the levels ran to {i_top:.4g} A: {why}")
    res.details["notes"] = notes
    if trace_decimation:
        res.details["traces"] = dict(zip(CHANNELS, buf[:n_rows].T.copy()))
    return res


def _times(n_step: list[int], Ts: float) -> dict:
    """s on the drive: per step, per quantity (the steps it takes), at
    standstill and in all."""
    per = {STEP_NAMES[k]: n * Ts for k, n in enumerate(n_step) if n and STEP_NAMES[k] not in ("start", "done", "failed")}
    return {"steps": per, "quantities": {q: sum(per.get(st, 0.0) for st in STEPS_OF[q]) for q in QUANTITIES},
            "standstill": sum(per.get(st, 0.0) for st in STANDSTILL), "total": sum(per.values())}


def _visits(r) -> list[tuple[str, int, int]]:
    """The steps in the order they ran, each with its first and past-last
    control period (CHECK before MAP is "check_premap")."""
    n = min(r.n_visit, lib.FS_IDENT_NVISIT)
    at = [0] + [r.visit_at[k] for k in range(n)] + [r.n_total]
    names = ["start"] + [STEP_NAMES[r.visit_step[k]] for k in range(n)]
    out = []
    for k, name in enumerate(names):
        if name == "check" and "map" not in names[:k]:
            name = "check_premap"
        out.append((name, at[k], at[k + 1]))
    return out


def _motion(tr: np.ndarray, visits: list[tuple[str, int, int]], Ts: float, ident) -> dict:
    """The rotor's motion at standstill: the simulation's truth per step (the
    largest |angle - the angle the step began at|, el.deg, and the largest
    current in it), and what the drive saw itself (the d carrier's cross
    response after LEVELS, before MAP and after it)."""
    r = ident.res
    out = {"drive_ldq_deg": math.degrees(r.motion_ldq), "drive_premap_deg": math.degrees(r.motion_premap),
           "drive_check_deg": math.degrees(r.motion_check), "steps": {}}
    if tr.size == 0:
        return out
    t, th = tr[:, 0], np.unwrap(tr[:, 1])
    th0 = th[0]
    i_abs = np.hypot(tr[:, 3], tr[:, 4])
    for name, a, b in visits:
        sel = (t >= (a - 0.5) * Ts) & (t < (b - 0.5) * Ts)
        if b == a or name.split("_")[0] not in STANDSTILL or not sel.any():
            continue
        d = np.degrees(th[sel] - th[sel][0])   # from where the step found the rotor
        out["steps"][name] = {"max_deg": float(np.max(np.abs(d))), "end_deg": float(d[-1]),
                              "from_start_deg": float(np.degrees(th[sel][-1] - th0)), "i_peak": float(np.max(i_abs[sel]))}
    if out["steps"]:
        worst = max(out["steps"], key=lambda st: out["steps"][st]["max_deg"])
        out["max_deg"], out["max_step"] = out["steps"][worst]["max_deg"], worst
        out["max_i_peak"] = out["steps"][worst]["i_peak"]
        out["end_deg"] = out["steps"][list(out["steps"])[-1]]["from_start_deg"]
    return out


def _result(sc: Scenario, s: dict, drv, stop: str, sim_time: float, wall: float, tr: np.ndarray) -> Identification:
    r = drv.ident.res
    step = STEP_NAMES[drv.ident.step]
    status, reason, values = {}, {}, {}
    for k, q in enumerate(QUANTITIES):
        st = {lib.FS_IDS_OK: "ok", lib.FS_IDS_FAILED: "failed", lib.FS_IDS_SKIPPED: "skipped"}.get(r.status[k], "pending")
        why = ffi.string(lib.fs_ident_reason_str(r.reason[k])).decode() if st in ("failed", "skipped") else ""
        if st == "pending":   # the run ended before the sequence reached it
            st, why = "failed", (f"the simulation stopped ({stop}) in step {step}" if stop != "done"
                                 else f"not reached: step {step} did not finish in time")
        status[q], reason[q] = st, why
    if status["verr"] == "ok":
        values["u_e"], values["i_e"] = r.u_e, r.i_e
    for q in ("R_s", "L_d", "L_q", "psi_f", "J"):
        if status[q] == "ok":
            values[q] = getattr(r, q)
    if status["friction"] == "ok":
        values["B"], values["T_c"] = r.B, r.T_c
    if status["L_q"] == "ok":   # L_q's change with i_d (H/A), between the two biases of its carrier
        values["dL_q_di_d"] = r.dL_q
    Ts = drv.cfg.Ts
    n_step = [r.n_step[k] for k in range(lib.FS_IDENT_NSTEPS)]
    details = {"snr_rs": r.snr_rs, "r_fit_rs": r.r_fit_rs, "snr_l": r.snr_l, "snr_psi": r.snr_psi,
               "eps_align_deg": math.degrees(r.eps_align), "w_flux": r.w_flux, "a_acc": r.a_acc, "a_coast": r.a_coast,
               "L_probe": drv.ident.L0, "i_acc": drv.ident.i_acc, "i_e": r.i_e, "bw_pll": drv.ident.bw_pll, "w_c": drv.ident.w_c,
               "I_bias": list(r.I_bias), "L_q_bias": list(r.L_q_bias), "dL_q": r.dL_q,
               "ld_carrier_A": r.ld_carrier, "ld_second_harmonic": r.ld_h2,
               "theta_axis_deg": math.degrees(r.theta_axis), "theta_hf_deg": math.degrees(r.theta_hf), "saliency": r.saliency,
               "L_d_axis": r.L_d_axis, "L_q_axis": r.L_q_axis, "pol_asym": r.pol_asym, "pol_decided": bool(r.pol_decided),
               "pol_flipped": bool(r.pol_flipped), "pol_amp": r.pol_amp, "i_level_top": r.i_level_top,
               "I_lev": [r.I_lev[k] for k in range(lib.FS_IDENT_NLEV)], "U_lev": [r.U_lev[k] for k in range(lib.FS_IDENT_NLEV)],
               "I_levn": [r.I_levn[k] for k in range(lib.FS_IDENT_NLEV)], "U_levn": [r.U_levn[k] for k in range(lib.FS_IDENT_NLEV)],
               "settings": s}
    if stop != "done" and step not in ("done", "failed"):
        step = f"{step} (simulation stopped: {stop})"
    res = Identification(sc.machine.name, status, reason, values, _truth(sc), step, sim_time, wall, details)
    res.times = _times(n_step, Ts)
    visits = _visits(r)
    res.details["visits"] = [(name, a * Ts, b * Ts) for name, a, b in visits]   # step, s from, s to
    res.motion = _motion(tr, visits, Ts, drv.ident)
    for k, q in enumerate(QUANTITIES):   # a rotor that moved: the current that moved it and how far it went
        if r.reason[k] == lib.FS_IDR_MOVED and status[q] == "failed":
            st = STEP_NAMES[drv.ident.step] if step != "failed" else (visits[-1][0] if visits else "?")
            turned = res.motion.get("steps", {}).get(st, {}).get("max_deg")
            reason[q] += (f" (at {abs(r.i_moved):.3g} A on the d axis, sign {'+' if r.i_moved >= 0 else '-'}"
                          + (f"; it turned {turned:.1f} el.deg in step {st}" if turned is not None else "") + ")")
    _turned_cause(res, sc)
    _numbers(res, sc, drv.ident, tr)
    if status["map"] == "ok":
        res.map = _map(sc, res, drv.ident)
        _stopped_turning(res, drv.ident, sc)
    elif _partial_map(res, drv.ident, sc):
        res.map = _map(sc, res, drv.ident)
        res.reason["map"] += (f"; beyond what was read the q flux is open by {res.map['spread_pct']:.3g} % of psi_f RMS over "
                              f"the disc (carried on falling as read against straight on)")
    _goals(res)
    return res


def _partial_map(res: Identification, ident, sc: Scenario) -> bool:
    """A map the drive refused to call identified (its d sweep did not read
    the whole axis: a free rotor the d current would turn away), but whose
    sweeps read the axis about zero (+-i_max/4) and the q axis at i_d = 0:
    the map made of them, the rest carried on from them (mapid.assemble),
    is written (status "outside goal", the reason saying what was read and
    what not), since on a saturating machine the constants the machine file
    holds otherwise describe it only near zero current: the Prius MG2 free,
    its q sweep read to 68 A of 271 (L_q already 26 % below its
    zero-current value there), lost the full-range run on the constants at
    its first load step, even on the true constants. True where it is made."""
    k0 = mapid.ND // 2
    if res.status["map"] != "failed" or res.status["L_d"] != "ok" or res.status["L_q"] != "ok":
        return False
    if ident.res.reason[QUANTITIES.index("map")] not in (lib.FS_IDR_UNSTABLE, lib.FS_IDR_INCOMPLETE):
        return False
    m = ident.map.res
    if not (m.n_d[k0 - 1] and m.n_d[k0 + 1] and m.n_q[k0][0]):
        return False
    res.status["map"] = OUTSIDE
    res.reason["map"] = f"partial: {res.reason['map']}; {_what_was_read(m, sc.data['controller']['i_max'])}"
    return True


def _what_was_read(m, i_max: float) -> str:
    """What a partial map's sweeps read (fs_mapid_result m), and the cure."""
    k0 = mapid.ND // 2
    read_d = [0.25 * (k - k0) * i_max for k in range(mapid.ND) if m.n_d[k]]
    q_levels = [k for k in range(mapid.ND) if any(m.n_q[k])]
    q0 = max((j + 1 for j in range(mapid.NQ) if m.n_q[k0][j]), default=0) * i_max / mapid.NQ
    return (f"what the sweeps read is written, the rest of the disc carried on from it, not measured: the d axis "
            f"from {min(read_d):+.3g} to {max(read_d):+.3g} A of +-{i_max:.4g} A, the q axis to {q0:.3g} A at i_d = 0 "
            f"({len(q_levels)} of 7 d levels read); lock the rotor to measure the rest ([identify] locked = true)")


def _stopped_turning(res: Identification, ident, sc: Scenario) -> None:
    """A map the drive called identified (its d sweep read the whole axis)
    whose q sweeps stopped because the rotor was turning at a level's end
    (fs_mapid.h: a back-EMF beyond the inverter's error): partial, outside
    its goal, saying so from the drive's own readings, where only the truth
    a simulation knows said it before (syre-thor free: 1 of 7 levels read,
    to 11 A of 44, 11 of the grid's 209 points measured; on a real machine
    it read "ok")."""
    m = ident.map.res
    stopped = [k for k in range(mapid.ND) if m.limit[k] == lib.FS_MAPID_LIM_MOVING]
    if res.status["map"] != "ok" or not stopped or res.map is None:
        return
    i_max = sc.data["controller"]["i_max"]
    spread = res.map["spread_pct"]
    if spread <= MAP_GOAL_PCT:   # what was read carries on straight (a linear machine's: anaheim, grin): the map stands
        return
    k = stopped[0]
    res.status["map"] = OUTSIDE
    res.reason["map"] = (f"partial: the q sweeps stopped after the level i_d = {0.25 * (k - mapid.ND // 2) * i_max:+.3g} A "
                         f"(swept to {m.i_q_amp[k]:.3g} A): the rotor was turning at its end (its back-EMF above the "
                         f"inverter's error), and the flux beyond what was read is open by {spread:.3g} % of psi_f RMS "
                         f"over the disc (carried on falling as read against straight on), above the "
                         f"{MAP_GOAL_PCT:g} % goal; {_what_was_read(m, i_max)}")


# el.deg a free rotor may turn in a standstill step before what the step
# measured is put down to the motion: a quarter turn puts the step's d current
# on the rotor's q axis. A swing about the axis is not a turn (ALIGN's last one
# on the frictionless Prius-like rotor reaches 11 el.deg in LEVELS, its values
# within their goals); a rotor the steps do not hold turns on for thousands.
TURNED_DEG = 90.0


def _turned_cause(res: Identification, sc: Scenario) -> None:
    """A quantity of a standstill step (the map aside: its error against the
    truth is reported) whose step turned the rotor more than TURNED_DEG:
    failed, unless an earlier quantity failed or the drive saw the motion
    itself, with the physical cause added to its reason: the motion, the
    current and the cure. The drive reads a turning rotor's back-EMF as
    noise or a misfit, or not at all (the inverter's error of a Prius-like
    rotor spinning through LEVELS came out "ok", 21 % off); the simulation
    knows the angle."""
    m = sc.machine
    for q in QUANTITIES:
        mo = res.motion.get("steps", {}).get(STEP_OF[q])
        if (q == "map" or mo is None or mo["max_deg"] <= TURNED_DEG
                or "earlier quantity" in res.reason[q] or "moved" in res.reason[q] or res.status[q] == "skipped"):
            continue
        cause = (f"the rotor turned {mo['max_deg']:.0f} el.deg in step {STEP_OF[q]}, currents up to {mo['i_peak']:.3g} A: "
                 f"the drive read its back-EMF as noise or misfit; the standstill steps do not hold this free rotor "
                 f"(J = {m.J:.3g} kg m^2): lock it, [identify] locked = true")
        if res.status[q] == "failed":
            res.reason[q] += f" ({cause})"
        else:
            res.status[q], res.reason[q] = "failed", cause
            for k in {"verr": ("u_e", "i_e"), "friction": ("B", "T_c")}.get(q, (q,)):
                res.values.pop(k, None)


D_MIN = 0.55   # fs_mapid.c: the smallest d sweep (of i_max) where a free rotor's motion bounds it


def _numbers(res: Identification, sc: Scenario, ident, tr: np.ndarray) -> None:
    """The physical numbers beside a refusal the drive names by its kind
    alone: the map's d sweep that would turn a free rotor away (the currents
    at which the d current pushes the magnet off the axis, against the
    sweep's), and a spin the rotor did not follow (the I/f current, the
    speed the frame and the rotor reached, the rotor's own speed when the
    spin began)."""
    m, r = sc.machine, ident.res
    i_max = sc.data["controller"]["i_max"]
    if res.status["map"] == "failed" and r.reason[QUANTITIES.index("map")] == lib.FS_IDR_UNSTABLE:
        L_d, L_q = res.values.get("L_d", m.L_d), res.values.get("L_q", m.L_q)
        dL = L_q - L_d
        where = (f"below 0 A and above psi_f / (L_q - L_d) = {m.psi_f:.4g} Wb / {dL * 1e3:.4g} mH = {m.psi_f / dL:.3g} A"
                 if dL > 0 else "below 0 A")
        res.reason["map"] += (f" (a d current {where} pushes the magnet off the axis, the reluctance torque beating the "
                              f"magnet's; the d sweep must reach +-{i_max:.4g} A, at least +-{D_MIN * i_max:.3g} A, where a "
                              f"misalignment of this rotor, J = {m.J:.3g} kg m^2, grows more than "
                              f"{math.cosh(1.7627472):.0f}-fold over the sweep)")
    q = QUANTITIES.index("psi_f")
    if res.status["psi_f"] == "failed" and r.reason[q] in (lib.FS_IDR_LOST_SYNC, lib.FS_IDR_NOT_TURNING):
        visits = res.details.get("visits", [])
        spin = next((v for v in visits if v[0] == "spin"), None)
        p = m.pole_pairs
        extra = f"the I/f frame at {ident.i_if:.3g} A ({100 * ident.i_if / i_max:.0f} % of i_max)"
        if r.w_flux:
            extra += f", the rotor at {r.w_flux:.4g} el. rad/s where psi_f was read against the frame's {ident.w_target:.4g}"
            if abs(r.w_flux) > 1.2 * abs(ident.w_target) > 0.0:
                # ahead of the frame: not pulled out (a rotor the frame's torque cannot carry falls behind) but
                # swinging about it, undamped, from the ramp's acceleration (the trial's datasheet-only file, no
                # dead time or friction to damp it, read 230..238 against 113; a 3 s ramp identified it)
                extra += (f": ahead of the frame, a swing about it that nothing damps, not a pull-out; a slower ramp "
                          f"excites it less ([identify] t_ramp, {ident.cfg.t_ramp:.3g} s now)")
        if spin is not None and tr.size:
            k0 = int(np.searchsorted(tr[:, 0], spin[1]))
            k1 = int(np.searchsorted(tr[:, 0], spin[2]))
            if k0 < tr.shape[0]:
                w0 = p * tr[k0, 2]
                extra += f"; the rotor turned at {w0:+.4g} el. rad/s when the spin began"
                if k1 > k0:
                    w = p * tr[k0:k1, 2]
                    extra += f", between {w.min():+.4g} and {w.max():+.4g} in it"
                mo = res.motion.get("steps", {}).get("check")
                if mo and mo["max_deg"] > 10.0:
                    extra += (f" (the standstill steps before it left it turning: {mo['max_deg']:.0f} el.deg in CHECK, "
                              f"after the map's sweeps)")
        res.reason["psi_f"] += f" ({extra})"


def _map(sc: Scenario, res: Identification, ident) -> dict:
    """The identified map (workflows/mapid.py) and its errors against the truth."""
    m = sc.machine
    i_max = sc.data["controller"]["i_max"]
    rd = mapid.readings(ident)
    psi_f = res.values.get("psi_f", m.psi_f)   # the machine file's where it was not identified (the rotor may not turn)
    L_d = res.values.get("L_d", res.truth["L_d"])
    grid = mapid.assemble(rd, i_max, psi_f, L_d)
    pm = _plant(sc)   # the truth (psi_f above is the drive's: the identified one or the machine file's)
    flux = true_flux(pm)
    out = {"readings": rd, "grid": grid, "i_max": i_max, "psi_f_from": "identified" if "psi_f" in res.values else "machine file",
           # the grid made to rise with its own currents (mapid._rising): the largest change that took, % of psi_f
           "rise_moved_pct": 100.0 * grid["rise_moved"] / psi_f}
    out["errors"] = mapid.map_errors(grid, flux, pm.psi_f, i_max)
    out["spread_pct"] = mapid.spread_pct(grid, psi_f, i_max)   # the readings' own measure of what they leave open
    if all(q in res.values for q in ("L_d", "L_q")):
        out["constant_errors"] = mapid.constant_errors(res.values["L_d"], res.values["L_q"], psi_f, flux, pm.psi_f, i_max)
    i_pulse = 0.5 * i_max   # the polarity detection's pulses by default (fs_drive.h: half the current limit)
    out["polarity"] = mapid.polarity_report(grid, mapid.true_grid(flux, i_max), i_pulse)
    counts = {}
    for v in grid["source"].ravel():
        counts[v] = counts.get(v, 0) + 1
    out["points"] = counts
    return out


def _goals(res: Identification) -> None:
    """A quantity identified but outside its goal against the truth gets the
    status "outside goal" and says by how much."""
    for q, e in res.errors_pct().items():
        if res.status[q] == "ok" and abs(e) > GOALS_PCT[q]:
            res.status[q] = OUTSIDE
            res.reason[q] = f"{e:+.2f} % against the truth, outside its {GOALS_PCT[q]:g} % goal"
    if res.map is not None and res.status["map"] == "ok" and res.map["errors"]["rms_pct"] > MAP_GOAL_PCT:
        res.status["map"] = OUTSIDE
        res.reason["map"] = (f"RMS error {res.map['errors']['rms_pct']:.2f} % of psi_f over the disc, outside its "
                             f"{MAP_GOAL_PCT:g} % goal")


# ---- the files ----

def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(float(v)) if math.isfinite(v) else ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf"))
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


IDENTIFIED = ("ok", OUTSIDE)   # a value the drive measured (outside goal: against the truth only a simulation knows)


def report_tables(res: Identification) -> dict[str, dict]:
    """Per quantity: status, reason, step, and where identified the value,
    the truth and the error; the map's errors and points, the rotor's
    motion at standstill and the time each step took."""
    tabs: dict[str, dict] = {"": {"machine": res.machine, "ended_in": res.step, "sim_time_s": res.sim_time}}
    if res.details.get("notes"):
        tabs[""]["notes"] = list(res.details["notes"])
    keys = {"verr": ["u_e", "i_e"], "friction": ["B", "T_c"], "map": []}
    for q in QUANTITIES:
        t = {"status": res.status[q], "step": STEP_OF[q]}
        if res.status[q] not in ("ok",):
            t["reason"] = res.reason[q]
        for k in keys.get(q, [q]):
            tail = "" if k == q else f"_{k}"
            if k in res.values:
                t[f"identified{tail}"] = res.values[k]
            if k in res.truth:
                t[f"truth{tail}"] = res.truth[k]
            if k in res.values and res.truth.get(k):
                t[f"error_pct{tail}"] = 100.0 * (res.values[k] - res.truth[k]) / res.truth[k]
        if q in GOALS_PCT:
            t["goal_pct"] = GOALS_PCT[q]
        if q == "L_q" and "dL_q_di_d" in res.values:
            t["identified_dL_q_di_d"] = res.values["dL_q_di_d"]   # H/A, between d biases of details["I_bias"]
        if q == "L_d" and res.details.get("ld_carrier_A"):   # the d carrier's current it was read at (fs_ident.c step_ldq)
            t["carrier_A"] = res.details["ld_carrier_A"]
            t["carrier_second_harmonic"] = res.details["ld_second_harmonic"]
        if q in ("L_d", "L_q"):
            t["truth_nominal"] = res.truth[f"{q}_nominal"]
            t["truth_is"] = "the plant's incremental inductance at zero current (the unsaturated value the standstill test sees)"
        if q == "map" and res.map is not None:
            e = res.map["errors"]
            t.update({"goal_pct": MAP_GOAL_PCT, "extrapolation_spread_pct_of_psi_f": res.map["spread_pct"],
                      "rms_error_pct_of_psi_f": e["rms_pct"], "rms_error_d_pct": e["rms_d_pct"],
                      "rms_error_q_pct": e["rms_q_pct"], "max_error_pct": e["max_pct"], "disc_points": e["points"],
                      "psi_f_from": res.map["psi_f_from"], "file": "fluxmap.csv", "points_file": "fluxmap-measured.csv",
                      "rise_moved_pct_of_psi_f": res.map["rise_moved_pct"]})
            if "constant_errors" in res.map:
                t["constant_model_rms_error_pct"] = res.map["constant_errors"]["rms_pct"]
            t.update({f"grid_{k.replace(' ', '_')}": v for k, v in res.map["points"].items()})
            pol = res.map["polarity"]
            t.update({"d_asymmetry_at_i_pulse": pol["asymmetry"], "d_asymmetry_truth": pol.get("asymmetry_truth"),
                      "d_asymmetry_needed": pol["needed"], "i_pulse": pol["i_pulse"],
                      "polarity_detection_decides": pol["decides"], "d_asymmetry_signed": pol["signed"],
                      "polarity_detection_reversed": pol["reversed"]})
        tabs[q] = t
    mo = res.motion
    mt = {"drive_ldq_deg": mo.get("drive_ldq_deg"), "drive_premap_deg": mo.get("drive_premap_deg"),
          "drive_check_deg": mo.get("drive_check_deg"),
          "truth_max_deg": mo.get("max_deg"), "truth_max_step": mo.get("max_step"), "truth_max_i_peak_A": mo.get("max_i_peak"),
          "truth_end_deg": mo.get("end_deg")}
    for st, v in mo.get("steps", {}).items():
        mt[f"{st}_max_deg"], mt[f"{st}_i_peak_A"] = v["max_deg"], v["i_peak"]
    tabs["motion"] = mt
    tm = {"total_s": res.times.get("total"), "standstill_s": res.times.get("standstill")}
    tm.update({f"step_{k}_s": v for k, v in res.times.get("steps", {}).items()})
    tm.update({f"quantity_{k}_s": v for k, v in res.times.get("quantities", {}).items()})
    tabs["time"] = tm
    return tabs


def machine_table(res: Identification, sc: Scenario) -> tuple[dict | None, list[str]]:
    """The machine file of the identified values (its bench as the scenario's
    machine file gives it, its ratings, and the map's file where the map was
    identified), or None unless R_s, L_d and L_q are identified and psi_f
    and J are too or were not to be (the rotor may not turn: then the
    machine file's, said in its source); and what was done to fit the
    schema (a friction fitted below zero is zero)."""
    notes = []
    turns = res.status["psi_f"] != "skipped"
    need = ("R_s", "L_d", "L_q") + (("psi_f", "J") if turns else ())
    if not all(res.status[q] in IDENTIFIED for q in need):
        return None, notes
    m = sc.machine
    v = dict(res.values)
    if not turns:
        v.update(psi_f=m.psi_f, J=m.J)
        notes.append(f"psi_f, J and friction from {m.name}'s machine file: not identified ({res.reason['psi_f']})")
    kind = "ipmsm" if v["L_d"] < v["L_q"] and not math.isclose(v["L_d"], v["L_q"], rel_tol=0.05) else "spmsm"
    if kind == "spmsm":
        v = dict(v, L_q=v["L_d"]) if abs(v["L_q"] - v["L_d"]) > 0.05 * v["L_d"] else v
    mech = {"J": v["J"], "B": v.get("B", 0.0), "T_coulomb": v.get("T_c", 0.0)}
    for k, label in (("B", "B"), ("T_coulomb", "T_coulomb")):
        if mech[k] < 0.0:   # the coast's fit below zero: within its noise of no friction (the schema's >= 0)
            notes.append(f"{label} fitted {mech[k]:.3g} set to 0 (the schema's >= 0)")
            mech[k] = 0.0
    tab = {
        "name": f"{m.name}-identified", "kind": kind, "phases": 3, "pole_pairs": m.pole_pairs,
        "description": f"{m.name} as identified by `fullspeed identify` (fs_ident.h)",
        "source": "fullspeed identify" + ("; " + "; ".join(notes) if notes else ""),
        "electrical": {"R_s": v["R_s"], "L_d": v["L_d"], "L_q": v["L_q"], "psi_f": v["psi_f"]},
        "mechanical": mech,
        "rated": {k: val for k, val in {"torque": m.T_rated, "current": m.i_rated,
                                        "speed_rpm": m.w_m_rated * 60 / (2 * math.pi)}.items()},
        # the bench as its file gave it: a value the design formed (m.design: the limits and bandwidths left
        # out) is formed again where the file is used, against that scenario (a speed loop held to the
        # sensorless observer's speed); written, it would read as given and freeze the identification's design
        "bench": {k: val for k, val in m.bench.items() if k != "reasons" and val is not None
                  and not (k in m.design and not m.design[k].given)},
    }
    if res.map is not None and res.status["map"] in IDENTIFIED:
        tab["magnetic"] = {"file": "fluxmap.csv"}
    return tab, notes


def _machine_toml(tab: dict) -> str:
    top = {k: v for k, v in tab.items() if not isinstance(v, dict)}
    subs = {k: v for k, v in tab.items() if isinstance(v, dict)}
    return _toml({"": top, **subs})


OUTPUTS = ("identification.toml", "machine.toml", "fluxmap.csv", "fluxmap-measured.csv")   # what an identification's folder holds


def write_identification(res: Identification, sc: Scenario, out: Path) -> list[Path]:
    """identification.toml (every quantity with its status), the map's
    fluxmap.csv and fluxmap-measured.csv where it was identified, and
    machine.toml when the quantities a machine file needs are there. The
    machine file is loaded back first (beside its map, in a scratch
    folder): one the loader refuses is left out and the refusal reported
    (res.details["machine_file"]). The folder is replaced as a whole
    (files.replace_folder), so that it never pairs one identification's
    report with another's machine or map, and a failed identification
    leaves none of an earlier one's."""
    files: dict[str, str] = {}
    m = sc.machine
    if res.map is not None:
        psi_f = res.values.get("psi_f", m.psi_f)
        files[OUTPUTS[2]] = mapid.csv_text(res.map["grid"], m.name)
        files[OUTPUTS[3]] = mapid.measured_csv_text(res.map["readings"], res.map["i_max"], psi_f, m.name)
    tab, notes = machine_table(res, sc)
    res.details["machine_file"] = {"written": False, "notes": notes}
    if tab is not None:
        text = _machine_toml(tab)
        with tempfile.TemporaryDirectory(prefix="fullspeed-identify-") as scratch:
            for name, data in files.items():
                (Path(scratch) / name).write_text(data)
            (Path(scratch) / OUTPUTS[1]).write_text(text)
            try:
                with warnings.catch_warnings(record=True) as caught:
                    warnings.simplefilter("always")
                    load_machine(Path(scratch) / OUTPUTS[1])
                res.details["machine_file"].update(written=True, warnings=[str(w.message) for w in caught])
                files[OUTPUTS[1]] = text
            except ConfigError as exc:   # the loader's refusal: no file it refuses is written
                res.details["machine_file"]["refused"] = str(exc)
    tabs = report_tables(res)
    tabs["machine_file"] = {k: (v if not isinstance(v, list) else "; ".join(v)) for k, v in res.details["machine_file"].items()}
    report = {OUTPUTS[0]: _toml(tabs)}
    return replace_folder(out, {**report, **files}, OUTPUTS)


def _align_why(details: dict, steps: dict) -> str:
    """Why ALIGN ran (fs_ident.h): no axis to see standing (AXIS found no
    saliency, so POLARITY did not run), or the polarity POLARITY's d sweep
    did not decide, with the drive's readings."""
    if "polarity" not in steps:
        return (f"the saliency AXIS read, {100 * details.get('saliency', 0.0):.1f} %, showed no axis to find standing, "
                "so the magnet was turned onto alpha")
    return (f"the d sweep's saturation asymmetry, {100 * details.get('pol_asym', 0.0):+.1f} %, did not decide the "
            "polarity standing, so the magnet's north was turned onto the axis (a free rotor may turn; "
            "[identify] locked = true keeps it, the polarity then from +i and -i)")


def print_identification(res: Identification) -> None:
    """One line per quantity: identified, truth and error, or the failure;
    the map's error, the rotor's motion at standstill and the time taken."""
    rows = [("u_e", "V"), ("R_s", "ohm"), ("L_d", "H"), ("L_q", "H"), ("psi_f", "Wb"), ("J", "kg m^2"),
            ("B", "N m s/rad"), ("T_c", "N m")]
    quantity = {"u_e": "verr", "B": "friction", "T_c": "friction"}
    print(f"{res.machine}: identification ended in step '{res.step}' after {res.sim_time:.2f} s simulated "
          f"({res.wall_time:.1f} s wall)")
    for note in res.details.get("notes", []):
        print(f"  note: {note}")
    for key, unit in rows:
        q = quantity.get(key, key)
        if res.status[q] not in IDENTIFIED:
            print(f"  {key:6s} {res.status[q]} in step {STEP_OF[q]}: {res.reason[q]}")
            continue
        v, t = res.values[key], res.truth.get(key)
        err = f"{100.0 * (v - t) / t:+7.2f} %" if t else "   (truth 0)"
        goal = f"   goal {GOALS_PCT[key]:g} %" if key in GOALS_PCT else ""
        flag = "   OUTSIDE GOAL" if res.status[q] == OUTSIDE and key in GOALS_PCT else ""
        print(f"  {key:6s} {v:12.5g} {unit:9s} truth {t:12.5g}  error {err}{goal}{flag}")
    if res.map is not None:
        e, pol = res.map["errors"], res.map["polarity"]
        const = f" (constant L_d, L_q, psi_f: {res.map['constant_errors']['rms_pct']:.2f} %)" if "constant_errors" in res.map else ""
        flag = "   OUTSIDE GOAL" if res.status["map"] == OUTSIDE else ""
        print(f"  map    RMS error {e['rms_pct']:.2f} % of psi_f over the disc (psi_d {e['rms_d_pct']:.2f}, psi_q "
              f"{e['rms_q_pct']:.2f}, largest {e['max_pct']:.2f} %)   goal {MAP_GOAL_PCT:g} %{const}{flag}")
        if res.reason["map"].startswith("partial: "):   # the drive's own verdict, truth or not
            print(f"         {res.reason['map']}")
        pts = res.map["points"]
        print(f"         {pts.get('measured', 0)} grid points measured, {pts.get('at speed', 0)} at speed, "
              f"{pts.get('extrapolated', 0)} extrapolated (outside the disc or beyond the sweeps)")
        if res.map["rise_moved_pct"] > 0.0:
            print(f"         readings that fell against their current moved to the nearest rising map: up to "
                  f"{res.map['rise_moved_pct']:.3g} % of psi_f")
        rd, i_max = res.map["readings"], res.map["i_max"]
        cut = {1: "the rotor's swing", 2: "the voltage", 3: "not swept: the d level would turn the free rotor away",
               4: "the sweeps stopped: the rotor turning at the level's end"}
        lim = [f"i_d {0.25 * (k - mapid.ND // 2) * i_max:+.3g} A: "
               + (f"{cut[v]}" + (f" (to {rd['i_q_amp'][k]:.3g} A)" if v in (1, 2, 4) else "") if v in cut
                  else "not reached (the sweeps stopped before it)")
               for k, v in enumerate(rd["limit"]) if 0 < k < mapid.ND - 1 and (v in cut or not any(rd["n_q"][k]))]
        if lim:
            print("         q sweeps short of the disc: " + "; ".join(lim))
        a, at, D = pol["asymmetry"], pol.get("asymmetry_truth"), pol["signed"] or 0.0
        verdict = ("decides" if pol["decides"] else
                   "would read the south pole: the carrier is smaller where the d current adds to the magnet"
                   if pol["reversed"] else "cannot decide")
        print(f"         d-axis asymmetry at +-{pol['i_pulse']:.3g} A: {100 * a:.1f} % (truth on the same grid "
              f"{100 * at:.1f} %), {100 * D:+.1f} % as the pulses read it; they need +{100 * pol['needed']:.0f} %: "
              f"{verdict} (`fullspeed design` on the machine file says which start the drive takes)")
    elif res.status["map"] not in IDENTIFIED:
        print(f"  map    {res.status['map']} in step map: {res.reason['map']}")
    mo = res.motion
    if "max_deg" in mo:
        print(f"  motion at standstill: at most {mo['max_deg']:.2f} el.deg (in step {mo['max_step']}, currents up to "
              f"{mo['max_i_peak']:.3g} A), {mo['end_deg']:+.2f} el.deg at the end; the drive saw "
              f"{mo['drive_ldq_deg']:+.2f} el.deg by LDQ, {mo['drive_premap_deg']:+.2f} before the map and "
              f"{mo['drive_check_deg']:+.2f} after it")
        print("         per step (el.deg, largest |angle - the step's start|): "
              + ", ".join(f"{st} {v['max_deg']:.2f}" for st, v in mo["steps"].items()))
        if "align" in mo["steps"]:   # the step that turns the rotor on purpose: why it ran
            print(f"         align turned the rotor {mo['steps']['align']['max_deg']:.0f} el.deg on purpose: "
                  + _align_why(res.details, mo["steps"]))
    tm = res.times
    if tm:
        per_q = ", ".join(f"{q} {tm['quantities'][q]:.2f}" for q in QUANTITIES if tm["quantities"].get(q))
        print(f"  time on the drive: {tm['total']:.2f} s ({tm['standstill']:.2f} s at standstill); per quantity (s): {per_q}")
    mf = res.details.get("machine_file")
    if mf and mf.get("refused"):
        print(f"  machine.toml not written: the loader refuses it: {mf['refused']}")
    for note in (mf or {}).get("notes", []):
        print(f"  machine.toml: {note}")


# ---- the zoo campaign (claim B-IDENT) ----

def zoo_identification(k: int, seed: int | None = None, folder: str | None = None) -> dict:
    """Identify zoo machine k (fullspeed.model.zoo) from a seeded initial rotor
    angle: one row of the campaign, every quantity with its status; with a
    folder, the identification written there as `identify` writes it
    (row["machine_file"]: its machine.toml, None where none was written)."""
    seed = ZOO_SEED if seed is None else seed
    theta0 = float(np.random.default_rng([seed, k, 25]).uniform(-180.0, 180.0))   # the rotor rests anywhere
    sc = scenario_from_dict({"name": f"identify-zoo-{seed}-{k}", "duration": 1.0,
                             "machine": {"zoo": k, "zoo_seed": seed}, "controller": {"mode": "off"},
                             "initial": {"theta_e_deg": theta0}})
    res = identify(sc)
    mo = res.motion
    row = {"k": k, "machine": res.machine, "description": sc.machine.description, "theta_e0_deg": theta0,
           "ended_in": res.step, "status": res.status, "reason": res.reason, "errors_pct": res.errors_pct(),
           "failures": res.failures(), "sim_time": res.sim_time, "wall_time": res.wall_time,
           "saturates": sc.machine.magnetic["model"] != "linear",
           "motion": {"max_deg": mo.get("max_deg"), "max_step": mo.get("max_step"), "max_i_peak": mo.get("max_i_peak"),
                      "steps": {st: v["max_deg"] for st, v in mo.get("steps", {}).items()}},
           "times": {"total": res.times.get("total"), "standstill": res.times.get("standstill"),
                     "quantities": res.times.get("quantities", {})}}
    if res.map is not None:
        e, pol = res.map["errors"], res.map["polarity"]
        row["map"] = {"rms_pct": e["rms_pct"], "rms_d_pct": e["rms_d_pct"], "rms_q_pct": e["rms_q_pct"], "max_pct": e["max_pct"],
                      "constant_rms_pct": res.map.get("constant_errors", {}).get("rms_pct"), "points": res.map["points"],
                      "asymmetry": pol["asymmetry"], "asymmetry_truth": pol.get("asymmetry_truth")}
    if folder is not None:
        write_identification(res, sc, Path(folder))
        written = res.details["machine_file"]["written"]
        row["machine_file"] = str(Path(folder) / OUTPUTS[1]) if written else None
    return row


def _zoo_task(task: dict) -> dict:
    """journal.run_tasks' worker: one zoo machine (a refusal comes back as a
    row with stop_reason "error" and its reason: journal.guarded)."""
    return zoo_identification(task["k"], task["seed"], task.get("folder"))


_zoo_task.journal_name = "fullspeed.identify._zoo_task"   # its module before the layers (journal._identity)


def zoo_campaign(ks, out: Path, seed: int | None = None, workers: int | None = None,
                 progress: bool = False, fresh: bool = True, keep=()) -> list[dict]:
    """The identification of zoo machines ks, in parallel processes,
    journaled in out (workflows.journal: a killed campaign resumes with
    fresh=False). A machine that could not be run is a row with its reason.
    The machines in keep have their identification written in
    out/machines/zoo-<k> (zoo_identification's folder)."""
    ks, keep = [int(k) for k in ks], {int(k) for k in keep}
    tasks = [{"k": k, "seed": seed, **({"folder": str((out / "machines" / f"zoo-{k}").resolve())} if k in keep else {})}
             for k in ks]
    results = run_tasks(_zoo_task, tasks, out, workers=workers, progress=progress, fresh=fresh, desc="identify")
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
    failed = [r for r in rows if any(r["status"][q] != "ok" for q in IDENT_QUANTITIES)]
    out["failed_pct"] = 100.0 * len(failed) / max(len(rows), 1)
    out["failed_with_reason"] = sum(all(r["reason"][q] for q in IDENT_QUANTITIES if r["status"][q] != "ok") for r in failed)
    out["failures"] = {r["machine"]: [f for f in r["failures"] if not f.startswith("map ")] for r in failed}
    out["map"] = map_summary(rows)
    return out


def map_summary(rows: list[dict], saturating_only: bool = True) -> dict:
    """The identified maps' RMS error over the disc (% of psi_f) on the
    saturating machines (or all): how many were identified, the 50th and
    95th percentile and the worst; the constant-parameter model's beside
    them; the maps not identified, each with its reason."""
    sel = [r for r in rows if r.get("saturates", True) or not saturating_only]
    got = [r for r in sel if r.get("map")]
    e = np.array([r["map"]["rms_pct"] for r in got])
    c = np.array([r["map"]["constant_rms_pct"] for r in got if r["map"].get("constant_rms_pct") is not None])

    def pct(x, q):
        return float(np.percentile(x, q)) if x.size else None
    return {"machines": len(sel), "identified": int(e.size), "p50": pct(e, 50), "p95": pct(e, 95),
            "max": float(e.max()) if e.size else None, "constant_p50": pct(c, 50), "constant_p95": pct(c, 95),
            "not_identified": {r["machine"]: f"{r['status']['map']}: {r['reason']['map']}" for r in sel if not r.get("map")}}


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
    r = simulate(load_scenario("beyond-zoo", {"machine": {"zoo": task["k"]}, "controller": task["scales"]},
                               warn=False))   # its four metrics alone are read
    m = r.metrics
    return {"stop_reason": r.stop_reason, "lock_lost_at": m["lock_lost_at"], "true_loss_at": m["true_loss_at"],
            "sensorless_err_deg_max": m["sensorless_err_deg_max"]}


def sensorless_on_identified(rows: list[dict], out: Path, workers: int | None = None,
                             true_runs: dict[int, dict] | None = None) -> dict:
    """The zoo's saturating machines (the linear ones refuse to start by
    their polarity detection) run sensorless on their true and on their
    identified parameters: how often each keeps lock (completed, no loss of
    lock flagged or seen by the simulation's truth). true_runs: machine k's
    run on its true parameters where it was made already (scenario
    beyond-zoo as it is: the sweep beyond-zoo's point k, claim B-ZOO), at
    least _sensorless_task's results; those are not run again."""
    tasks = []
    for row in rows:
        k = int(row["k"])
        if k % 2:   # the zoo's linear machines
            continue
        scales = identified_scales(row, k)
        if scales is not None:
            tasks += [{"k": k, "scales": {}}, {"k": k, "scales": scales}]
    known = {n: (true_runs or {}).get(t["k"]) for n, t in enumerate(tasks) if not t["scales"]}
    known = {n: r for n, r in known.items() if r is not None}
    todo = [t for n, t in enumerate(tasks) if n not in known]
    ran = iter(run_tasks(_sensorless_task, todo, out, workers=workers, fresh=True, desc="sensorless"))
    res = [known[n] if n in known else next(ran) for n in range(len(tasks))]

    def kept(r):
        return r is not None and r.get("stop_reason") == "done" and r.get("lock_lost_at") is None \
            and r.get("true_loss_at") is None
    true_kept = sum(kept(r) for t, r in zip(tasks, res) if not t["scales"])
    ident_kept = sum(kept(r) for t, r in zip(tasks, res) if t["scales"])
    differ = [t["k"] for t, r, r0 in zip(tasks[1::2], res[1::2], res[0::2]) if kept(r) != kept(r0)]
    return {"machines": len(tasks) // 2, "kept_true": true_kept, "kept_identified": ident_kept, "differ": differ}
