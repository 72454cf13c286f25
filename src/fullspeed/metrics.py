"""Metrics of a run, all measured from its traces."""
from __future__ import annotations

import math

import numpy as np

from .units import rad_s_to_rpm


def steady_window(res) -> tuple[float, float]:
    """The scenario's [metrics] steady window, else the last 20 % of the run."""
    w = res.scenario.data["metrics"]["steady"]
    if w is not None:
        return float(w[0]), float(w[1])
    T = res.scenario.duration
    return 0.8 * T, T


def window_mask(t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    return (t >= t0 - 1e-12) & (t <= t1 + 1e-12)


def angle_error_stats(err_rad: np.ndarray) -> dict:
    """mean, pp (max - min) and max |.| of an angle error, in el.deg."""
    if err_rad.size == 0:
        return {"mean": None, "pp": None, "max": None}
    e = np.degrees(err_rad)
    return {"mean": float(np.mean(e)), "pp": float(np.ptp(e)), "max": float(np.max(np.abs(e)))}


# The stages in which the loops run on an estimate with current flowing
# (fs_drive_stage): where a wrong angle is a loss of lock. Polarity detection,
# the I/f start (its frame lags by design) and the zero-current recovery are not.
SENSORLESS_STAGES = (4, 5, 6, 7)


def true_loss_at(tr, threshold: float = math.pi / 2, t_net: float = 0.02) -> float | None:
    """When the simulation's truth says lock was lost: the loops' angle more
    than `threshold` (rad) from the rotor's, in a sensorless stage, for
    `t_net` s net (time off counts up, time on counts down to no less than 0,
    as fs_lock.h counts its residual); None if never. The drive cannot know
    this; the campaigns compare its flags against it."""
    t = np.asarray(tr["t"])
    if t.size < 2:
        return None
    dt = float(t[1] - t[0])
    off = (np.abs(np.asarray(tr["theta_err"])) > threshold) & np.isin(np.asarray(tr["stage"]).astype(int), SENSORLESS_STAGES)
    # segments of equal state: the counter moves linearly within each
    edges = np.r_[0, np.flatnonzero(np.diff(off.astype(np.int8))) + 1, off.size]
    acc = 0.0
    for a, b in zip(edges[:-1], edges[1:]):
        if off[a]:
            if acc + (b - a) * dt >= t_net - 1e-12:
                return float(t[a + max(0, math.ceil((t_net - acc) / dt - 1e-9) - 1)])
            acc += (b - a) * dt
        else:
            acc = max(0.0, acc - (b - a) * dt)
    return None


def step_times(tr, channels=("w_m_ref", "T_L", "i_d_ref", "i_q_ref")) -> list[float]:
    """The instants a reference or the load jumps (between two samples by
    more than 5 % of its range): the steps a run's error is forgiven after."""
    out = []
    for ch in channels:
        if ch not in tr:
            continue
        y = np.asarray(tr[ch])
        span = float(np.ptp(y)) if y.size else 0.0
        if span > 0:
            out += [float(tr["t"][k + 1]) for k in np.flatnonzero(np.abs(np.diff(y)) > 0.05 * span)]
    return sorted(out)


def sensorless_error_max(tr, after_step: float = 0.05) -> float | None:
    """The largest |angle error| (el.deg) while the loops run on an estimate
    (SENSORLESS_STAGES), outside the `after_step` s after each step of a
    reference or the load and after each entry from a stage without an
    estimate (polarity detection, the I/f start, a recovery); None if the
    run never ran sensorless."""
    t = np.asarray(tr["t"])
    on = np.isin(np.asarray(tr["stage"]).astype(int), SENSORLESS_STAGES)
    entries = [float(t[k + 1]) for k in np.flatnonzero(on[1:] & ~on[:-1])]
    keep = on.copy()
    for t0 in step_times(tr) + entries:
        keep &= ~((t >= t0) & (t < t0 + after_step))
    if not keep.any():
        return None
    return float(np.degrees(np.max(np.abs(np.asarray(tr["theta_err"])[keep]))))


def compute_metrics(res) -> dict:
    tr = res.traces
    t = tr["t"]
    out: dict = {
        "stop_reason": res.stop_reason,
        "stop_time": res.stop_time,
        "sim_time": res.sim_time,
        "wall_time": res.wall_time,
        "speed_ratio": res.speed_ratio,
    }
    if t.size == 0:
        return out
    t0, t1 = steady_window(res)
    m = window_mask(t, t0, t1)
    out["steady_window"] = [t0, t1]
    out["i_phase_max"] = float(np.max(np.abs(np.stack([tr["i_a"], tr["i_b"], tr["i_c"]]))))
    lost = np.flatnonzero(tr["lock_lost"] > 0)
    out["lock_lost_at"] = float(t[lost[0]]) if lost.size else None
    out["recoveries"] = int(tr["recoveries"][-1])
    if res.polarity is not None:
        out["polarity"] = res.polarity
    from .checks import ideal_hardware
    out["ideal_hardware"] = ideal_hardware(res.scenario.data)
    out["warnings"] = list(res.scenario.warnings)
    out["true_loss_at"] = true_loss_at(tr)
    out["sensorless_err_deg_max"] = sensorless_error_max(tr)
    # a loss the simulation's truth sees and nothing in the run flagged
    out["silent_failure"] = bool(out["true_loss_at"] is not None and res.stop_reason == "done"
                                 and out["lock_lost_at"] is None)
    faults = fault_report(res)
    if faults is not None:
        out["faults"] = faults
    if not m.any():
        return out
    mode = res.scenario.data["controller"]["mode"]
    if mode == "speed":
        w_ref = float(np.mean(tr["w_m_ref"][m]))
        w = float(np.mean(tr["w_m"][m]))
        out["speed_ref_rpm"] = rad_s_to_rpm(w_ref)
        out["speed_rpm"] = rad_s_to_rpm(w)
        out["speed_error_pct"] = 100.0 * (w - w_ref) / abs(w_ref) if w_ref != 0 else None
    if mode in ("speed", "current"):
        out["i_d_error_rms"] = float(np.sqrt(np.mean((tr["i_d_ref"][m] - tr["i_d"][m]) ** 2)))
        out["i_q_error_rms"] = float(np.sqrt(np.mean((tr["i_q_ref"][m] - tr["i_q"][m]) ** 2)))
    out["T_e_mean"] = float(np.mean(tr["T_e"][m]))
    out["T_e_pp"] = float(np.ptp(tr["T_e"][m]))
    out["theta_err_deg"] = angle_error_stats(tr["theta_err"][m])
    out["est_err_deg"] = angle_error_stats(tr["est_err"][m])
    return out


def fault_events(res) -> list[tuple[str, float]]:
    """The faults of the run's [faults] table that acted, with their times."""
    f, tr = res.scenario.data["faults"], res.traces
    ev = []
    if any(f["i_offset"]) or any(f["i_gain"]):
        ev.append(("current_sensor", f["t_sensor"]))
    if res.adc_saturated_at is not None:
        ev.append(("adc_saturation", res.adc_saturated_at))
    u0 = res.scenario.data["converter"]["u_dc"]
    moved = np.flatnonzero(np.abs(tr["u_dc"] - u0) > 1e-6 * u0) if res.scenario.data["converter"]["kind"] == "inverter" else []
    if len(moved):
        ev.append(("dc_link", float(tr["t"][moved[0]])))
    if f["open_phase"] != "none":
        ev.append((f"open_phase_{f['open_phase']}", f["t_open"]))
    if f["t_encoder_stop"] is not None:
        ev.append(("encoder_stop", f["t_encoder_stop"]))
    return [(k, t) for k, t in ev if t <= res.sim_time]


def fault_report(res) -> dict | None:
    """How the drive came out of its faults: tripped (the stop and its time),
    kept control, or lost it (the time its error first left the band and
    stayed out until the end). The band: speed within 10 % of the reference
    or 5 % of the rated speed; current within 10 % of i_max (true currents)."""
    ev = fault_events(res)
    if not ev:
        return None
    t0 = min(t for _, t in ev)
    out = {"events": [[k, t] for k, t in sorted(ev, key=lambda e: e[1])]}
    if res.stop_reason != "done":
        out.update(outcome=f"tripped: {res.stop_reason}", t_outcome=res.stop_time)
        return out
    tr, sc = res.traces, res.scenario
    mode = sc.data["controller"]["mode"]
    after = tr["t"] >= t0
    if mode == "speed":
        err = np.abs(tr["w_m"] - tr["w_m_ref"])
        band = np.maximum(0.1 * np.abs(tr["w_m_ref"]), 0.05 * sc.machine.w_m_rated)
    elif mode == "current":
        err = np.hypot(tr["i_d"] - tr["i_d_ref"], tr["i_q"] - tr["i_q_ref"])
        band = np.full_like(err, 0.1 * sc.data["controller"]["i_max"])
    else:
        out.update(outcome="reported", t_outcome=None)
        return out
    bad = after & (err > band)
    if not bad[-1]:
        out.update(outcome="kept control", t_outcome=None)
    else:
        good = np.flatnonzero(after & ~bad)
        k = good[-1] + 1 if good.size else np.flatnonzero(after)[0]
        out.update(outcome="lost control", t_outcome=float(tr["t"][k]))
    return out


# The scalars of compute_metrics, by flat name ("theta_err_deg.mean"): what a
# sweep may keep. Those a run's mode does not give are empty for it.
METRIC_NAMES = (
    "stop_reason", "stop_time", "sim_time", "wall_time", "speed_ratio", "i_phase_max",
    "lock_lost_at", "recoveries", "true_loss_at", "silent_failure", "sensorless_err_deg_max",
    "speed_ref_rpm", "speed_rpm", "speed_error_pct", "i_d_error_rms", "i_q_error_rms",
    "T_e_mean", "T_e_pp",
    "theta_err_deg.mean", "theta_err_deg.pp", "theta_err_deg.max",
    "est_err_deg.mean", "est_err_deg.pp", "est_err_deg.max",
)


def flat_metrics(metrics: dict) -> dict:
    """compute_metrics' scalars under their flat names (METRIC_NAMES)."""
    out = {}
    for k, v in metrics.items():
        if isinstance(v, dict):
            out.update({f"{k}.{kk}": vv for kk, vv in v.items()})
        elif not isinstance(v, (list, tuple)):
            out[k] = v
    return {k: out.get(k) for k in METRIC_NAMES}


def json_safe(x):
    """Metrics as JSON: NaN and infinities become null."""
    if isinstance(x, dict):
        return {k: json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, (np.floating, np.integer)):
        return json_safe(x.item())
    return x


# fs_drive_stage, by value (csrc/control/fs_drive.h)
STAGES = ("open", "sensor", "polarity", "start", "injection", "blend", "backemf", "flux_weakening", "recovery")


def stage_changes(tr) -> list[tuple[float, str]]:
    """The drive's operating stages in the order it passed them: (time
    entered, name), the first at the first sample."""
    s = np.asarray(tr["stage"]).astype(int)
    k = np.r_[0, np.flatnonzero(np.diff(s)) + 1] if s.size else np.array([], int)
    return [(float(tr["t"][i]), STAGES[s[i]]) for i in k]
