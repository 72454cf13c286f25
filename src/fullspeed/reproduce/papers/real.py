"""B-REAL: the catalog of published machines (model.machines.published_machines),
datasheet fields and maps only, every other setting designed.

Per machine, the full range (real_scenario): standstill start under half
the rated torque (an active load), acceleration into flux weakening to 1.5 x
the envelope's base speed (where the envelope holds 1.25 x the half-rated
load, if that is lower), a load step there to 80 % of the envelope's torque,
back to the half-rated load, reversal through zero under it; from the
scenario's initial angle and from the rotor turned TURNED from it. Sensorless
(blend) it either runs (both) with max |angle error| < 10 el.deg outside the 50 ms
after each step and |steady mean| < 2 el.deg, or is refused before the start
naming the physical cause (a ConfigError: the scenario did not load;
sensorless_angle tries blend, then the back-EMF observer with the start
the design chooses). With the encoder, the torque held at six speeds
(held_speeds: the drive started at standstill, a load machine then takes
the shaft to the speed and holds it, the reference above it asks the
drive's most torque) is within 5 % of the envelope (design.envelope);
sensorless, the same run holds what the encoder holds, within 5 % of it.

The envelope's voltage: the drive's flux weakening lets its voltage
reference into the minimum-phase-error over-modulation, whose fundamental
reaches OVERMODULATION = 1.049 x the linear limit u_dc/sqrt3, and how far
it goes there depends on the operating point. So the map's own envelope is
a band: at the linear limit (below it the drive leaves voltage unused) and
at the over-modulation's (above it the drive makes torque the machine
cannot give). The torque held passes within 5 % of that band; sensorless,
at least what the encoder holds less 5 %, and within the band's top.
"""
from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np

from ...design.envelope import OVERMODULATION, envelope, torque_at
from ...design.machine import load_machine, machine_from_dict
from ...design.rules import u_linear
from ...design.scenario import scenario_from_dict
from ...model.errors import ConfigError
from ...model.machines import published_machines
from ...model.units import rad_s_to_rpm
from ...sim.metrics import SENSORLESS_STAGES, sensorless_error_max, sensorless_from, stepping_channels
from ...sim.runner import simulate
from ...workflows.journal import run_tasks
from ..registry import Measurement, register
from .common import plt, save_figure, sweep_dir

ANGLE_MAX = 10.0        # el.deg: the largest error outside the 50 ms after each step
STEADY_MEAN = 2.0       # el.deg: |mean error| in the steady window
HELD_TOL = 0.05         # the torque held against the envelope's band, and sensorless against the encoder
BELOW = (0.25, 0.5, 1.0)   # x base speed: three of the six speeds the torque is held at, three more above base
TOP_SHARE = 0.9          # the speeds above base reach 2 x base or this share of the envelope's top speed, the lower
HOLD = 0.3              # s: each speed held; the torque is its mean over the last half
START = 0.3             # s: the drive's start at standstill (the polarity test: 0.2 s on the Baldor) before the load machine turns the shaft
RAMP_MIN = 0.1          # s: the shortest ramp to a held speed
IF_WAIT = 0.5           # of the I/f start's timeout: the shaft at its hand-over speed while the observer converges
SETTLE = 0.1            # s: the shaft at its held speed before the reference steps up (a sensorless drive's hand-over done by then)
T_WIND = 0.05           # s: after the step the speed loop asks twice its T_max within this (held_reference)
TURNED = 90.0           # el.deg: each full range also from the rotor turned by this from the scenario's own angle: the
                        # injection's worst start (its angle error's unstable equilibrium, the loops' d and q swapped), where
                        # the Baldor and THOR stopped while the one angle the claim ran passed


def _top(env, T_half: float) -> tuple[float, str]:
    """The full range's top speed: 1.5 x base, or where the envelope still
    holds 1.25 x the half-rated load where that is lower."""
    w = 1.5 * env.w_base
    if torque_at(env, w) >= 1.25 * T_half:
        return w, "1.5 x base speed"
    lo, hi = env.w_base, w
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if torque_at(env, mid) >= 1.25 * T_half else (lo, mid)
    return lo, f"{lo / env.w_base:.2f} x base speed (1.5 x is beyond the envelope under the half-rated load)"


def held_speeds(env) -> list[float]:
    """The six speeds (rad/s) the torque is held at: 0.25, 0.5 and 1 x base
    speed, and three evenly above base up to 2 x base or TOP_SHARE of the
    envelope's top speed where it is finite (a hub motor whose
    characteristic current exceeds i_max has no torque beyond it; its
    back-EMF there would drive current into the link)."""
    w_hi = 2.0 * env.w_base
    if env.top_finite:
        w_hi = min(w_hi, TOP_SHARE * env.w_top)
    return [b * env.w_base for b in BELOW] + list(np.linspace(env.w_base, w_hi, 4)[1:])


def sensorless_angle(name: str | dict) -> tuple[str | None, str | None]:
    """The sensorless angle the design accepts for machine `name`: blend
    (injection below the band, the back-EMF observer above), else the
    back-EMF observer alone with the start the design chooses; None and
    both refusals where neither loads."""
    refusals = []
    for angle in ("blend", "smo"):
        try:
            scenario_from_dict(real_scenario(name, angle)[0], f"B-REAL {name if isinstance(name, str) else name.get('name')}",
                               warn=False)   # whether it loads: its warnings are the run's
            return angle, None
        except ConfigError as exc:
            refusals.append(str(exc))
    return None, " / ".join(refusals)


def real_scenario(name: str | dict, angle: str = "blend") -> tuple[dict, dict]:
    """The full-range scenario of catalog machine `name` (TOML data) and what
    it was built from (base and top speed, the load step's torque); name may
    be a machine file's path, or a machine table (a zoo machine's)."""
    m = load_machine(name) if isinstance(name, str) else machine_from_dict(copy.deepcopy(name))
    label = m.name if isinstance(name, dict) else Path(name).stem if name.endswith(".toml") else name
    env = envelope(m, m.bench["u_dc"], m.bench["i_max"], w_end=4.0 * m.w_m_rated)
    T_half = 0.5 * m.T_rated
    w_top, why = _top(env, T_half)
    T_step = 0.8 * torque_at(env, w_top)
    # the time to the top speed with the envelope's spare torque over the load, twice (the speed loop's share), >= 0.4 s
    ws = np.linspace(0.0, w_top, 41)
    spare = torque_at(env, ws) - T_half
    t_acc = max(0.4, round(2.0 * float(np.trapezoid(m.J / np.maximum(spare, 1e-9 * m.T_rated), ws)), 2))
    t0, t1 = 0.5, 0.5 + t_acc
    t_step, t2 = t1 + 0.5, t1 + 1.1
    t3, t4 = t2 + 0.2, t2 + 0.2 + t_acc
    dur = round(t4 + 0.4, 3)
    top, rev = rad_s_to_rpm(w_top), -0.3 * rad_s_to_rpm(env.w_base)
    data = {"name": f"real-{label}-{angle}", "duration": dur, "machine": copy.deepcopy(name),
            "controller": {"mode": "speed", "angle": angle, "flux_weakening": True},
            # the back-EMF observer alone from standstill by its I/f start (its default start is the encoder's angle)
            **({"observer": {"start": "if"}} if angle == "smo" else {}),
            "references": {"speed_rpm": [[0.0, 0.0], [t0, 0.0], [t1, top], [t3, top], [t4, rev], [dur, rev]]},
            "load": {"kind": "torque", "torque": [[0.0, 0.0], [0.2, 0.0], [0.35, T_half], [t_step, T_half],
                                                  [t_step + 1e-3, T_step], [t2, T_step], [t2 + 0.1, T_half]]},
            "metrics": {"steady": [t_step + 0.3, t2]}}
    return data, {"base_rpm": rad_s_to_rpm(env.w_base), "top_rpm": top, "top_is": why, "T_step": T_step}


def _turned(built: tuple) -> tuple:
    """A full-range scenario (real_scenario's) from the rotor turned by TURNED."""
    data, info = built
    data = copy.deepcopy(data)
    initial = data.setdefault("initial", {})
    initial["theta_e_deg"] = initial.get("theta_e_deg", 0.0) + TURNED
    return data, info


def run_machine(task: dict) -> dict:
    """journal.run_tasks' worker: one machine's sensorless full range, with
    the angle sensorless_angle chose (None: refused, task["refused"] why)."""
    name, angle = task["machine"], task["angle"]
    # the scenario as the caller built it (task["built"]: its envelope searched there once), else built here
    data, info = task["built"] if task.get("built") else real_scenario(name, angle or "blend")
    if angle is None:
        return {"machine": name, "refused": task["refused"], **info}
    sc = scenario_from_dict(data, f"B-REAL {name}")
    res = simulate(sc)
    mt = res.metrics
    steady = mt.get("theta_err_deg", {}) or {}
    row = {"machine": name, "angle": angle, "refused": None, "stop_reason": res.stop_reason,
           "lock_lost_at": mt.get("lock_lost_at"), "start": sc.data["start"]["kind"],
           "err_max": mt.get("sensorless_err_deg_max"), "steady_mean": steady.get("mean"),
           "stages": mt.get("stages"), **info}
    if row["start"] == "if":
        # a machine without usable saliency starts by I/f (the start's claim, B-START): its frame is no
        # estimate, the rotor follows it at its load angle; the estimator's error counts from its hand-over
        # on, the start's motion against its designed bound beside it
        sm = mt.get("start_motion") or {}
        row.update(err_max=sensorless_error_max(res.traces, t_from=sensorless_from(sc), stages=SENSORLESS_STAGES,
                                               channels=stepping_channels(sc)),
                   if_err_max=mt.get("sensorless_err_deg_max"), turn_deg=sm.get("turn_deg"), bound_deg=sm.get("bound_deg"))
    return row


def held_reference(designed: dict, J: float) -> float:
    """The speed above the held one (rad/s, mechanical) that makes the
    drive's speed loop ask twice its T_max within T_WIND of the step: its
    2DOF design gives k_t ~ alpha J at once and k_i ~ alpha^2 J per second
    of error (fs_speed_ctrl.h), so dw (alpha J + alpha^2 J T_WIND) = 2 T_max.
    A fixed 20 % above the speed asked a sensorless drive, whose speed loop
    is slower (alpha 25 rad/s on syre-thor against 84 with the encoder), for
    torque that grew by k_i dw: 29 N m/s at 518 rpm, 1.7 s to its 43 N m,
    so the hold measured the loop's wind-up, not the torque the drive holds."""
    a, T_max = designed["controller"]["bw_speed"], designed["controller"]["T_max"]
    return 2.0 * T_max / (a * J * (1.0 + a * T_WIND))


def held_scenario(name: str, rpm: float, angle: str) -> dict:
    """The held-torque run at `rpm`, a dynamometer's test: the drive starts
    at standstill as it always does, and the load machine (an ideal speed
    source) then takes the shaft to the speed and holds it, the drive asked
    for 1.2 x the speed once the shaft turns. (Asked for it from the start
    instead, the drive stalled against the shaft held at standstill at its
    full torque for START: a locked-rotor test, which is not the torque
    held at the speed, and which lost SyR-e's THOR from 1,037 rpm up. The
    reference on the shaft's own speed made the encoder drive brake at its
    full torque on the ramp: the 2DOF speed loop without the ramp's
    acceleration lags it, and the step from there tripped the Baldor.) The
    ramp is no faster than the machine's own acceleration at rated torque
    (J w / T_rated, at least RAMP_MIN), so that the sensorless
    drive passes its hand-over as it would alone; a flying start at speed is
    not what is measured. SETTLE after the shaft is at speed the reference
    steps to where the speed loop asks for its most torque at once
    (held_reference), and the torque is the mean over the last half of the
    HOLD that follows."""
    m = load_machine(name)
    w = rpm * 2.0 * math.pi / 60.0
    data = {"name": f"real-held-{name}", "machine": name,
            "controller": {"mode": "speed", "angle": angle, "flux_weakening": True},
            **({"observer": {"start": "if"}} if angle == "smo" else {})}
    shaft = [[0.0, 0.0], [START, 0.0]]   # rpm against time: standstill while the drive starts
    # designed for the held speed and 20 % above it (the speeds asked set the observer's top speed, which
    # the flux weakening's plan also reaches, and the overspeed stop): the reference past it only winds the speed loop up
    designed = scenario_from_dict({**data, "duration": 1.0, "references": {"speed_rpm": 1.2 * rpm}},
                                  f"B-REAL {name}", warn=False).data
    data["observer"] = {**data.get("observer", {}), "top_speed_rpm": designed["observer"]["top_speed_rpm"]}
    data["controller"]["overspeed_rpm"] = designed["controller"]["overspeed_rpm"]
    if angle != "encoder":
        ob = designed["observer"]
        if designed["start"]["kind"] == "motion":
            # the motion test reads the rotor's turn under a doublet, which a held shaft does not make: the
            # polarity given (the start itself is judged in the full-range run, where the rotor is free)
            data["polarity"] = {"enabled": False}
        if ob["start"] == "if":
            # an I/f start turns the rotor with its frame: a shaft held still would hold the rotor off it,
            # so the load machine turns it as the frame does (from standstill at the start's acceleration
            # to its hand-over speed, where the frame waits for the observer: IF_WAIT of the start's
            # timeout) and on from there as for every machine
            n_h = ob["start_handover_rpm"]
            t_h = n_h / ob["start_accel_rpm_s"]
            shaft = [[0.0, 0.0], [t_h, n_h], [t_h + IF_WAIT * ob["start_timeout"], n_h]]
    # asked for 1.2 x the speed once the shaft turns; nothing while the load machine holds it at standstill
    asked = [[0.0, 1.2 * rpm]] if shaft[-1][1] > 0.0 else [[0.0, 0.0], [shaft[-1][0], 0.0], [shaft[-1][0] + 1e-3, 1.2 * rpm]]
    t1 = shaft[-1][0] + max(RAMP_MIN, m.J * w / m.T_rated)
    t_step = t1 + SETTLE
    dur = round(t_step + HOLD, 3)
    shaft += [[t1, rpm], [t_step, rpm]]
    rpm_asked = max(1.2 * rpm, rpm + rad_s_to_rpm(held_reference(designed, m.J)))
    data.update(duration=dur, metrics={"steady": [t_step + 0.5 * HOLD, dur]},
                load={"kind": "speed", "speed_rpm": shaft + [[dur, rpm]]},
                references={"speed_rpm": asked + [[t_step, 1.2 * rpm], [t_step + 1e-3, rpm_asked], [dur, rpm_asked]]})
    return data


def held_torque(task: dict) -> dict:
    """journal.run_tasks' worker: the torque machine `name` holds at a speed
    (rpm) with the encoder or sensorless (held_scenario); its mean over the
    last half of the hold."""
    name, rpm, angle = task["machine"], task["rpm"], task["angle"]
    data = held_scenario(name, rpm, angle)
    try:
        res = simulate(scenario_from_dict(data, f"B-REAL {name}", warn=False))   # its torque alone is read
    except ConfigError as exc:
        return {"refused": str(exc)}
    t = np.asarray(res["t"])
    m = t >= data["metrics"]["steady"][0]
    done = res.stop_reason == "done" and m.any()
    return {"T": float(np.mean(res["T_e"][m])) if done else None, "stop_reason": res.stop_reason}


def held_within(T: float | None, T_low: float, T_high: float) -> bool:
    """Whether a torque held is within HELD_TOL of the band T_low..T_high
    (the envelope at the linear limit and at the over-modulation's; the
    encoder's torque and that top, sensorless)."""
    return T is not None and (1.0 - HELD_TOL) * T_low <= T <= (1.0 + HELD_TOL) * T_high


def _machine_ok(r: dict) -> bool:
    if r.get("refused"):
        return True   # refused before the start, naming the cause
    start_ok = r.get("start") != "if" or (r.get("turn_deg") is not None and r.get("bound_deg") is not None
                                         and r["turn_deg"] <= r["bound_deg"])
    return (r["stop_reason"] == "done" and r["lock_lost_at"] is None and r["err_max"] is not None and start_ok
            and r["err_max"] < ANGLE_MAX and r["steady_mean"] is not None and abs(r["steady_mean"]) < STEADY_MEAN)


def held_rows(runs: list[tuple[dict, dict | None]], env, env_om, sensorless: bool) -> tuple[list[dict], bool]:
    """One machine's held runs (task, result or None where it did not run)
    as a table per speed, and whether every speed held its torque: the
    encoder within the envelope's band, sensorless (where the machine runs
    sensorless) within the encoder's and the band's top. A run that did not
    run holds nothing, and a machine none of whose speeds ran has held
    nothing: not held."""
    speeds = [(task["rpm"], task["angle"], h.get("T") if h else None) for task, h in runs]
    enc = {rpm: T for rpm, a, T in speeds if a == "encoder"}
    sl = {rpm: T for rpm, a, T in speeds if a != "encoder"}
    table, held_ok = [], bool(enc)
    for rpm in sorted(enc):
        T_env, T_om = (torque_at(e, rpm * 2 * math.pi / 60) for e in (env, env_om))
        T_e, T_s = enc[rpm], sl.get(rpm)
        e_ok = held_within(T_e, T_env, T_om)
        # a machine refused sensorless has no sensorless torque to hold
        s_ok = not sensorless or (T_e is not None and held_within(T_s, T_e, T_om))
        held_ok &= e_ok and s_ok
        table.append({"rpm": rpm, "T_envelope": T_env, "T_envelope_om": T_om, "T_encoder": T_e, "T_sensorless": T_s})
    return table, held_ok


@register("B-REAL", cost=16)
def real(out: Path) -> Measurement:
    names = published_machines()
    angles = {n: sensorless_angle(n) for n in names}
    # each machine's scenario built here, where sensorless_angle built it and its envelope is kept (design.memo):
    # a worker would search the envelope again
    tasks = [{"machine": n, "angle": a, "refused": why, "built": real_scenario(n, a or "blend")} for n, (a, why) in angles.items()]
    turned = [{**t, "built": _turned(t["built"])} for t in tasks if t["angle"] is not None]
    runs = run_tasks(run_machine, tasks + turned, sweep_dir(out, "B-REAL-runs"), fresh=True)
    runs, runs_turned = runs[:len(tasks)], dict(zip((t["machine"] for t in turned), runs[len(tasks):]))
    held_tasks, envs = [], {}
    for n in names:
        m = load_machine(n)
        env = envelope(m, m.bench["u_dc"], m.bench["i_max"], w_end=4.0 * m.w_m_rated)
        envs[n] = (env, envelope(m, m.bench["u_dc"], m.bench["i_max"], w_end=4.0 * m.w_m_rated,
                                 u_max=OVERMODULATION * u_linear(m.bench["u_dc"], m.phases)))
        for w in held_speeds(env):
            rpm = rad_s_to_rpm(w)
            held_tasks.append({"machine": n, "rpm": rpm, "angle": "encoder"})
            if angles[n][0] is not None:
                held_tasks.append({"machine": n, "rpm": rpm, "angle": angles[n][0]})
    held = run_tasks(held_torque, held_tasks, sweep_dir(out, "B-REAL-held"), fresh=True)
    rows, ok_all = {}, True
    for n, r in zip(names, runs):
        r = r or {"refused": None, "stop_reason": "not run"}
        env, env_om = envs[n]
        table, held_ok = held_rows([(t, h) for t, h in zip(held_tasks, held) if t["machine"] == n], env, env_om,
                                   angles[n][0] is not None)
        run_ok = _machine_ok(r)
        rows[n] = {**{k: v for k, v in r.items() if k != "machine"}, "held": table, "run_ok": run_ok, "held_ok": held_ok}
        if n in runs_turned:   # the same run from the rotor turned by TURNED: the machine runs only if it runs from both
            t = runs_turned[n] or {"refused": None, "stop_reason": "not run"}
            turned_ok = _machine_ok(t)
            rows[n]["turned"] = {k: t.get(k) for k in ("stop_reason", "lock_lost_at", "err_max", "steady_mean")} | {"run_ok": turned_ok}
            run_ok = run_ok and turned_ok
            rows[n]["run_ok"] = run_ok
        ok_all &= run_ok and held_ok
    fig = _figure(rows, out)
    n_run = sum(v["run_ok"] and not v.get("refused") for v in rows.values())
    n_ref = sum(bool(v.get("refused")) for v in rows.values())
    n_held = sum(v["held_ok"] for v in rows.values())
    value = {"machines": len(rows), "sensorless_ok": n_run, "refused": n_ref, "held_ok": n_held, "per_machine": rows}
    def run_text(r):
        if r.get("refused"):
            return f"refused: {r['refused']}"
        start = (f" (I/f start: its load angle up to {_deg(r.get('if_err_max'))}, the rotor turned {_deg(r.get('turn_deg'))} "
                 f"of its bound {_deg(r.get('bound_deg'))} el.deg)" if r.get("start") == "if" else "")
        t = r.get("turned") or {}
        return (f"{r.get('angle')}: {r.get('stop_reason')}, max {_deg(r.get('err_max'))}, steady mean "
                f"{_deg(r.get('steady_mean'))} el.deg{start}; from {TURNED:g} el.deg further: {t.get('stop_reason')}, "
                f"max {_deg(t.get('err_max'))}, steady mean {_deg(t.get('steady_mean'))}")

    def held_text(v):
        return ", ".join(f"{x['rpm']:.0f} rpm {_nm(x['T_encoder'])}/{_nm(x['T_sensorless'])} of {_nm(x['T_envelope'])}"
                         + (f"..{_nm(x['T_envelope_om'])}" if x["T_envelope_om"] > (1.0 + 1e-3) * x["T_envelope"] else "")
                         for x in v["held"])

    note = (f"{len(rows)} published machines. Sensorless full range (max |error| < {ANGLE_MAX:g} el.deg outside the "
            f"50 ms after each step, |steady mean| < {STEADY_MEAN:g}; from the scenario's initial angle and from the rotor "
            f"turned {TURNED:g} el.deg from it, both): {n_run} run, {n_ref} refused before the start "
            "naming the cause. A machine without saliency the injection can use starts by I/f (the start's claim, "
            "B-START; issue 33 puts it there): its frame is no estimate, so its error counts from the hand-over to "
            "the back-EMF observer on, the start's turn within its designed bound, the I/f's load angle reported; "
            "its held runs turn the shaft with the I/f's frame until the hand-over; where the start is a motion test "
            f"(it needs a free rotor) the held runs are given the polarity. Torque held at six speeds (encoder within {HELD_TOL:.0%} of the "
            f"envelope's band from the linear limit u_dc/sqrt3 to the over-modulation's {OVERMODULATION:.3f} x it, which the drive's flux "
            f"weakening may enter; sensorless at least the encoder's less {HELD_TOL:.0%} and within the band's top): {n_held}. Per machine: " + "; ".join(
                f"{n}: {run_text(v)}; held (encoder/sensorless of envelope, N m) {held_text(v)}"
                for n, v in rows.items()))
    return Measurement(value, ok_all, note, [fig])


def _deg(x) -> str:
    return "n/a" if x is None else f"{x:.2f}"


def _nm(x) -> str:
    return "-" if x is None else f"{x:.4g}"


def _figure(rows: dict, out: Path) -> str:
    fig, axes = plt.subplots(2, 4, figsize=(14, 6))
    for ax, (n, r) in zip(axes.ravel(), rows.items()):
        h = r["held"]
        if h:
            rpm = [x["rpm"] for x in h]
            ax.plot(rpm, [x["T_envelope"] for x in h], "k-", label="envelope")
            ax.plot(rpm, [x["T_envelope_om"] for x in h], "k:", label="over-modulated")
            ax.plot(rpm, [x["T_encoder"] for x in h], "o", label="encoder")
            ax.plot(rpm, [x["T_sensorless"] for x in h], "x", label="sensorless")
        ax.set_title(n, fontsize=8)
        ax.set_xlabel("rpm")
        ax.set_ylabel("N m")
    axes[0, 0].legend(fontsize=7)
    return save_figure(fig, out / "B-REAL.png", "B-REAL: the torque held against the envelope")
