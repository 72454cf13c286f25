"""Metrics of a run, all measured from its traces."""
from __future__ import annotations

import bisect
import math

import numpy as np

from ..design.checks import ideal_hardware
from ..model.units import rad_s_to_rpm, rpm_to_rad_s


# The loop each closed-loop mode follows: its reference channels (name in
# [references], trace channel, scale to SI, unit) and the bandwidth whose
# settling the steady window waits out.
FOLLOWED = {
    "speed": ([("speed_rpm", "w_m", "w_m_ref", "rpm")], "bw_speed"),
    "current": ([("i_q", "i_q", "i_q_ref", "A"), ("i_d", "i_d", "i_d_ref", "A")], "bw_current"),
    "voltage": ([("u_d", None, None, "V"), ("u_q", None, None, "V")], None),
    "vf": ([("frame_rpm", None, None, "rpm")], None),
    "off": ([], None),
}
SETTLE_TAUS = 5.0        # time constants of the loop's bandwidth: a first-order response is within 0.7 %
SETTLE_BAND = 0.02       # settling and recovery: within 2 % (of the step; of the reference speed for a load change)
SPEED_FLOOR = 0.005      # ... but never a band narrower than 0.5 % of rated speed (standstill, sensor noise)
# A speed loop in control: within 10 % of its reference or 5 % of rated speed (near standstill). The claims'
# steady errors are below 0.1 %, a drive at the edge of its voltage envelope sags a few % (the Prius MG2 held
# 240 N m at 1393 rpm 9.5 % short); outside it the loops do not follow (a start that never handed over, a rotor
# an active load turned, an estimate that lost the rotor: -1030 rpm against 3600)
CONTROL_BAND, CONTROL_FLOOR = 0.10, 0.05


def _changes(profile) -> list[tuple[float, float, float, float]]:
    """The changes of a profile (t, y lists, held after the last point):
    (t_start, t_end, y_before, y_after), consecutive changing segments in one
    direction merged (a ramp drawn in several pieces is one change)."""
    ts, ys = profile
    out: list[list[float]] = []
    for k in range(1, len(ts)):
        dy = ys[k] - ys[k - 1]
        if dy == 0.0:
            continue
        if out and out[-1][1] == ts[k - 1] and (out[-1][3] - out[-1][2]) * dy > 0:
            out[-1][1], out[-1][3] = ts[k], ys[k]
        else:
            out.append([ts[k - 1], ts[k], ys[k - 1], ys[k]])
    return [tuple(c) for c in out]


def _followed_profiles(sc) -> list:
    """The profiles the run's loops follow, and the load's (a change of
    either is not steady)."""
    d = sc.data
    refs, _ = FOLLOWED[d["controller"]["mode"]]
    profiles = [d["references"][name] for name, *_ in refs]
    load = d["load"]
    profiles.append(load["torque"] if load["kind"] in ("torque", "brake") else load["speed_rpm"])
    return profiles


def _last_change(sc) -> float:
    """When what the loops follow (references and load) last stops changing, s."""
    return max((c[1] for p in _followed_profiles(sc) for c in _changes(p)), default=0.0)


def _settle_time(sc) -> float | None:
    """SETTLE_TAUS time constants of the mode's loop; None without one."""
    key = FOLLOWED[sc.data["controller"]["mode"]][1]
    bw = sc.data["controller"].get(key) if key else None
    return SETTLE_TAUS / bw if bw else None


def steady_window(res) -> tuple[float, float] | None:
    """The scenario's [metrics] steady window, else the last flat stretch of
    what the loops follow (their references and the load) after a settling
    margin: SETTLE_TAUS time constants of the mode's loop (a fifth of the
    stretch in the open-loop modes). None when no such stretch is left
    (the run ends on a ramp or right after a step): steady_basis says why."""
    return _steady(res)[0]


def _steady(res) -> tuple[tuple[float, float] | None, str]:
    win, basis = _steady_planned(res)
    t_stop = res.stop_time if res.stop_time is not None else res.sim_time
    if win is not None and res.stop_reason != "done" and t_stop < win[1] - 1e-12:
        return None, (f"none: the run stopped at t = {t_stop:.4g} s ({res.stop_reason}), before the end of the "
                      f"window {win[0]:g}..{win[1]:g} s ({basis})")
    return win, basis


def _steady_planned(res) -> tuple[tuple[float, float] | None, str]:
    """The steady window the scenario plans for, whatever the run did."""
    sc = res.scenario
    w = sc.data["metrics"]["steady"]
    if w is not None:
        return (float(w[0]), float(w[1])), "given: [metrics] steady"
    T = sc.duration
    t_flat = _last_change(sc)
    settle = _settle_time(sc)
    margin = settle if settle is not None else 0.2 * (T - t_flat)
    if t_flat + margin >= T - 1e-12:
        return None, (f"none: the references or the load change until {t_flat:g} s and the loop settles in "
                      f"{margin:.3g} s, past the end ({T:g} s); set [metrics] steady")
    # a mean over less than one time constant of the loop is a snapshot of its transient, not a steady state
    # (the speed loop's end check, job_checks, averages over the same 1 / bw)
    tau = settle / SETTLE_TAUS if settle is not None else 0.0
    if T - (t_flat + margin) < tau - 1e-12:
        return None, (f"none: the references or the load change until {t_flat:g} s and the loop settles in "
                      f"{margin:.3g} s, which leaves {1e3 * (T - t_flat - margin):.3g} ms before the end ({T:g} s), "
                      f"less than the loop's time constant {1e3 * tau:.3g} ms (1 / "
                      f"{FOLLOWED[sc.data['controller']['mode']][1]}): no steady state to measure; lengthen the run "
                      f"or set [metrics] steady")
    return (t_flat + margin, T), (f"the last flat stretch, from {t_flat:g} s, after a settling margin of {margin:.3g} s"
                                  + (f" ({SETTLE_TAUS:g} / {FOLLOWED[sc.data['controller']['mode']][1]})" if settle else ""))


def window_mask(t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    return (t >= t0 - 1e-12) & (t <= t1 + 1e-12)


def window_slice(t: np.ndarray, t0: float, t1: float) -> slice:
    """window_mask of rising times as a slice: found by bisection, so that
    one window costs log(len(t)) and not len(t)."""
    return slice(int(np.searchsorted(t, t0 - 1e-12, "left")), int(np.searchsorted(t, t1 + 1e-12, "right")))


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
# The stages in which the loops make torque on an angle they did not measure:
# those and the I/f start (its frame, which the rotor follows at a load
# angle; 180 el.deg there is a start that failed). Not polarity detection
# (its current is on the estimate's d axis, the polarity it decides pi-ambiguous
# until it has) nor the recovery (zero current).
TORQUE_STAGES = (3, *SENSORLESS_STAGES)
START_STAGES = (2, 3)    # polarity detection, the I/f start
RECOVERY = 8


def in_stages(stage, stages: tuple) -> np.ndarray:
    """np.isin(stage as int, stages), by two comparisons where the stages
    are a run of consecutive codes (all of the sets above: a tenth of
    isin's time over a run's samples)."""
    s = np.asarray(stage).astype(int)
    lo, hi = min(stages), max(stages)
    if tuple(stages) == tuple(range(lo, hi + 1)):
        return (s >= lo) & (s <= hi)
    return np.isin(s, stages)


def unwrap(p: np.ndarray) -> np.ndarray:
    """np.unwrap(p) (period 2 pi), the same bits: its correction formed only
    where a step is not below pi (elsewhere numpy zeroes it), so the
    remainder runs over the few jumps and not over every sample."""
    p = np.asarray(p, dtype=float)
    if p.size < 2:
        return p.copy()
    dd = np.diff(p)
    jump = np.flatnonzero(~(np.abs(dd) < np.pi))         # NaN steps too, as numpy leaves them
    ph_correct = np.zeros(dd.size)
    d = dd[jump]
    ddmod = np.mod(d + np.pi, 2.0 * np.pi) - np.pi        # numpy: mod(dd - interval_low, period) + interval_low
    np.copyto(ddmod, np.pi, where=(ddmod == -np.pi) & (d > 0))
    ph_correct[jump] = ddmod - d
    up = p.copy()
    up[1:] = p[1:] + ph_correct.cumsum()
    return up


def true_loss_at(tr, threshold: float = math.pi / 2, t_net: float = 0.02) -> float | None:
    """When the simulation's truth says lock was lost: the loops' angle more
    than `threshold` (rad) from the rotor's, in a sensorless stage, for
    `t_net` s net; None if never. Net as fs_lock.h counts: time off counts
    up; time back on track (within half the threshold) counts down to no
    less than 0; time in between holds, so that an estimate slipping round
    and round (a quarter of its time within 45 deg, half beyond 90) counts
    as lost and not as on track half the time. The drive cannot know this;
    the campaigns compare its flags against it."""
    t = np.asarray(tr["t"])
    if t.size < 2:
        return None
    dt = float(t[1] - t[0])
    e = np.abs(np.asarray(tr["theta_err"]))
    sensorless = in_stages(tr["stage"], SENSORLESS_STAGES)
    state = np.where(sensorless & (e > threshold), 1, np.where(~sensorless | (e < 0.5 * threshold), -1, 0)).astype(np.int8)
    # segments of equal state: the counter moves linearly within each
    edges = np.concatenate(([0], np.flatnonzero(np.diff(state)) + 1, [state.size]))   # np.r_'s, without its parsing
    acc = 0.0
    for a, b in zip(edges[:-1], edges[1:]):
        if state[a] == 1:
            if acc + (b - a) * dt >= t_net - 1e-12:
                return float(t[a + max(0, math.ceil((t_net - acc) / dt - 1e-9) - 1)])
            acc += (b - a) * dt
        elif state[a] == -1:
            acc = max(0.0, acc - (b - a) * dt)
    return None


def _first_cross(t: np.ndarray, x: np.ndarray, level: float) -> float | None:
    k = np.flatnonzero(x >= level)
    return float(t[k[0]]) if k.size else None


def step_response(t: np.ndarray, y: np.ndarray, t0: float, y0: float, y1: float, band: float) -> dict:
    """A step from y0 to y1 at t0, the response y over t (from t0 to the next
    change): overshoot (% of the step), rise time (10 to 90 %), settling time
    (from t0 until |y - y1| stays within band), and the final value (the
    mean over the window's last tenth). A time that did not happen
    within the window is None, with `note` saying which."""
    dy = y1 - y0
    x = (y - y0) / dy                      # 0 before, 1 on target, in the step's direction
    out = {"overshoot_pct": float(max(0.0, 100.0 * (np.max(x) - 1.0))) if x.size else None}
    t10, t90 = _first_cross(t, x, 0.1), _first_cross(t, x, 0.9)
    out["rise_time"] = t90 - t10 if t10 is not None and t90 is not None else None
    out["settling_time"] = _settled_from(t, np.abs(y - y1) > band, t0)
    out["final"] = float(np.mean(y[-max(1, y.size // 10):])) if y.size else None   # the last tenth's mean
    notes = [w for w, v in (("did not reach 90 %", t90), ("did not settle", out["settling_time"])) if v is None]
    if notes:
        out["note"] = " and ".join(notes) + " before the next change"
    return out


def _settled_from(t: np.ndarray, out_of_band: np.ndarray, t0: float) -> float | None:
    """Time from t0 until out_of_band stays false to the end of t; None if it is true at the end."""
    if not out_of_band.size or out_of_band[-1]:
        return None
    k = np.flatnonzero(out_of_band)
    return float(t[k[-1] + 1] - t0) if k.size else 0.0


def step_metrics(res) -> list[dict]:
    """Per reference step (a change completing within the loop's settling
    time, SETTLE_TAUS / bandwidth) and per load change (any, step or ramp, in
    speed mode): the step response, or the speed's dip against its reference
    (more load) or rise (less load) over the change and the loop's settling
    time after it, none where a reference changes meanwhile, and its
    recovery time. Each is measured up to the next change of any reference
    or the load (or the end of the run)."""
    sc, tr = res.scenario, res.traces
    d = sc.data
    mode = d["controller"]["mode"]
    refs, _ = FOLLOWED[mode]
    settle = _settle_time(sc)
    t = np.asarray(tr["t"])
    if settle is None or t.size < 2:
        return []
    starts = sorted({c[0] for p in _followed_profiles(sc) for c in _changes(p)})
    t_end = float(t[-1])

    def window(c):
        """From the change to the next start (the first s > c[0] with s >
        c[1] - 1e-12, by bisection: a profile of n changes costs n log n, not
        n^2): an empty slice for a change after the run's end."""
        lo = c[1] - 1e-12
        k = bisect.bisect_right(starts, c[0]) if lo <= c[0] else bisect.bisect_left(starts, lo)
        return window_slice(t, c[0], min(starts[k], t_end) if k < len(starts) else t_end)

    w_floor = SPEED_FLOOR * sc.machine.w_m_rated
    injecting = d["controller"]["angle"] in ("hfi", "blend", "swvi")
    n_carrier = round(1.0 / (d["injection"]["f_h"] * float(t[1] - t[0]))) if injecting else 0
    out = []
    seen: dict[str, np.ndarray] = {}   # each channel as measured (averaged once, not per change)
    for name, ch, ref_ch, unit in refs:
        to_si = rpm_to_rad_s(1.0) if unit == "rpm" else 1.0
        for c in _changes(d["references"][name]):
            if c[1] - c[0] > settle or c[0] >= t_end:
                continue   # a ramp, not a step; or after the run's end
            m = window(c)
            y0, y1 = c[2] * to_si, c[3] * to_si
            band = max(SETTLE_BAND * abs(y1 - y0), w_floor if unit == "rpm" else 0.0)
            r = {"kind": "reference", "signal": ch, "t": c[0], "ramp": c[1] - c[0], "from": c[2], "to": c[3], "unit": unit}
            if ch not in seen:
                seen[ch] = np.asarray(tr[ch])
                if unit == "A" and n_carrier > 1:
                    # the carrier's current would read as overshoot: its one-period mean (adds up to a period to the times)
                    seen[ch] = np.convolve(seen[ch], np.full(n_carrier, 1.0 / n_carrier), mode="same")
            y = seen[ch]
            if unit == "A" and n_carrier > 1:
                r["averaged_over"] = n_carrier * float(t[1] - t[0])
            r.update(step_response(t[m], y[m], c[0], y0, y1, band))
            if r["final"] is not None:
                r["final"] /= to_si
            out.append(r)
    load = d["load"]
    if mode == "speed" and load["kind"] in ("torque", "brake"):
        # the reference changes by their ends, with the earliest start among those ending later: the first change
        # overlapping a window by bisection (a profile of n changes costs n log n, not n^2)
        by_end = sorted((c for name, *_ in refs for c in _changes(d["references"][name])), key=lambda c: c[1])
        ends = [c[1] for c in by_end]
        first_after = by_end[:]
        for k in range(len(by_end) - 2, -1, -1):
            first_after[k] = min(by_end[k], first_after[k + 1], key=lambda c: c[0])

        def first_busy(t0, t1):
            """The earliest reference change overlapping (t0, t1), or None."""
            k = bisect.bisect_right(ends, t0)
            return first_after[k] if k < len(by_end) and first_after[k][0] < t1 else None

        for c in _changes(load["torque"]):
            if c[0] >= t_end:
                continue
            m = window(c)
            w_ref = np.asarray(tr["w_m_ref"])[m]
            e = np.asarray(tr["w_m"])[m] - w_ref
            up = abs(c[3]) > abs(c[2])
            sign = -1.0 if c[3] > c[2] else 1.0     # more load torque pulls the speed down
            if load["kind"] == "brake":              # a brake acts against the motion
                sign *= float(np.sign(np.mean(w_ref))) or 1.0
            name = "dip" if up else "rise"           # towards the load's pull, or away from it (less load)
            r = {"kind": "load", "signal": "w_m", "t": c[0], "ramp": c[1] - c[0], "from": c[2], "to": c[3], "unit": "N m",
                 "response": name, f"{name}_rpm": None, f"t_{name}": None, "recovery_time": None}
            # the load's response: over its change and the loop's settling time after it, where no
            # reference changes (a ramp's tracking error is not the load's)
            t_resp = c[1] + settle
            busy = first_busy(c[0], t_resp)
            if busy:
                r["note"] = (f"the speed reference changes from {busy[0]:g} to {busy[1]:g} s: the load's response "
                             "cannot be told from the ramp's tracking")
                out.append(r)
                continue
            dev = sign * e
            near = t[m] <= t_resp + 1e-12
            if dev.size and near.any():
                k = int(np.argmax(np.where(near, dev, -np.inf)))
                r[f"{name}_rpm"] = rad_s_to_rpm(float(max(dev[k], 0.0)))
                r[f"t_{name}"] = float(t[m][k])
            band = np.maximum(SETTLE_BAND * np.abs(w_ref), w_floor)
            r["recovery_time"] = _settled_from(t[m], np.abs(e) > band, c[0])
            if r["recovery_time"] is None:
                last = t[m][-1] >= t_end - 1e-12 if dev.size else True
                r["note"] = ("the speed did not return within its band before "
                             + ("the run's end" if last else "the next change"))
                if not last:   # the run's end is job_checks' (speed_end)
                    r["unheld"] = _load_unheld(t[m], e, band, c[1], settle)
            out.append(r)
    return sorted(out, key=lambda r: r["t"])


def _load_unheld(t, e, band, t_change_end: float, settle: float) -> dict | None:
    """A load change the speed loop did not answer before the next change:
    where that came past the change's end by the loop's settling and a time
    constant more (settle = SETTLE_TAUS time constants), the speed's error
    over the window's last time constant, still beyond the settled band
    (SETTLE_BAND of the reference, at least SPEED_FLOOR of rated speed), in
    rpm with the window's end. None where the window was too short to
    judge or the speed had come back into the band by its end."""
    tau = settle / SETTLE_TAUS
    if t.size == 0 or t[-1] - t_change_end < settle + tau - 1e-12:
        return None
    m = t >= t[-1] - tau - 1e-12
    e_end = float(np.mean(e[m]))
    b_end = float(np.mean(band[m]))
    if abs(e_end) <= b_end:
        return None
    return {"until": float(t[-1]), "error_rpm": rad_s_to_rpm(e_end), "band_rpm": rad_s_to_rpm(b_end),
            "settle": settle, "since": t_change_end}


def stage_metrics(tr) -> dict:
    """Per stage the drive passed (by name, in the order first entered): the
    time spent in it, how often it was entered, and the largest |angle error|
    (true minus used, el.deg) while in it."""
    s = np.asarray(tr["stage"]).astype(int)
    t = np.asarray(tr["t"])
    if s.size < 2:
        return {}
    dt = float(t[1] - t[0])
    err = np.abs(np.asarray(tr["theta_err"]))   # in degrees at the max: rounding is monotone, the same bits
    entries = np.concatenate(([0], np.flatnonzero(np.diff(s)) + 1))
    # each stay's length and largest error, then each stage's over its stays (the max of maxima, NaN as
    # np.max carries it): a pass over the run, not one a stage
    codes, lengths = s[entries], np.diff(np.append(entries, s.size))
    stay_max = np.maximum.reduceat(err, entries)
    out = {}
    for code in dict.fromkeys(codes):
        k = codes == code
        out[STAGES[code]] = {"time": float(int(np.sum(lengths[k])) * dt), "entries": int(np.count_nonzero(k)),
                             "theta_err_max_deg": float(np.degrees(np.max(stay_max[k])))}
    return out


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


def stepping_channels(sc) -> tuple[str, ...]:
    """The trace channels whose jumps are the scenario's own steps: its
    mode's references (FOLLOWED) and a torque or brake load's torque, the
    steps a run's error is forgiven after. Not the loops' own outputs: in
    speed mode i_d_ref and i_q_ref are the speed loop's and the start's (an
    I/f start that lost its rotor moved them by more than 5 % of their
    range at every sample, and every sample was forgiven: 0.00 el.deg
    reported beside 179.99 in the start stage)."""
    d = sc.data
    refs = tuple(ch for _, _, ch, _ in FOLLOWED[d["controller"]["mode"]][0] if ch)
    return refs + (("T_L",) if d["load"]["kind"] in ("torque", "brake") else ())


def sensorless_error_max(tr, after_step: float = 0.05, t_from: float = 0.0,
                         stages: tuple = TORQUE_STAGES, channels: tuple | None = None) -> float | None:
    """The largest |angle error| (el.deg) while the loops make torque on an
    angle they did not measure (TORQUE_STAGES, from t_from: the hand-over
    from the encoder), outside the `after_step` s after each step of a
    reference or the load and after each entry from a stage without
    (polarity detection, a recovery); None if the run never ran sensorless.
    stages = SENSORLESS_STAGES: the loops on an estimate only (an I/f
    start's frame, which the rotor follows at its load angle, left out,
    and the 50 ms after its hand-over with it). channels: those whose jumps
    are steps (stepping_channels of the run's scenario; None: step_times's
    default, every reference and the load)."""
    t = np.asarray(tr["t"])
    on = in_stages(tr["stage"], stages) & (t >= t_from - 1e-12)
    entries = [float(t[k + 1]) for k in np.flatnonzero(on[1:] & ~on[:-1])]
    keep = on.copy()
    starts = np.array((step_times(tr) if channels is None else step_times(tr, channels)) + entries, dtype=float)
    if np.all(t[1:] > t[:-1]):
        # a run's samples rise: each window [t0, t0 + after_step) is a slice, found by bisection and marked at
        # once (the same samples as the masks below; a noisy reference steps tens of thousands of times)
        edges = np.zeros(t.size + 1, dtype=np.int64)
        np.add.at(edges, np.searchsorted(t, starts, side="left"), 1)
        np.add.at(edges, np.searchsorted(t, starts + after_step, side="left"), -1)
        keep &= np.cumsum(edges[:-1]) == 0
    else:
        for t0 in starts:
            keep &= ~((t >= t0) & (t < t0 + after_step))
    if not keep.any():
        return None
    return float(np.degrees(np.max(np.abs(np.asarray(tr["theta_err"])[keep]))))


def sensorless_from(sc) -> float | None:
    """When the loops go sensorless (s): never with the encoder, at the
    observer's hand-over, else from the start."""
    if sc.data["controller"]["angle"] == "encoder":
        return None
    return float(sc.data["observer"]["handover"])


def lock_events(res) -> tuple[float | None, list[dict]]:
    """When the drive's monitor first flagged a loss (latched, or a recovery
    begun), and what the drive did each time it began a recovery
    (fs_drive_protect.h): {"t": its start, "action": "flying restart" (the
    back-EMF observer caught the rotor), "restart" (the start sequence again:
    its first stage in "stage"), or "stopped" (the halt at the end of the
    zero-current wait, "halted", or the run's end within it), "t_done",
    "speed_rpm" (the loops' speed taken up, for a flying restart) and
    "rotor_rpm" (the simulation's truth there)}."""
    tr = res.traces
    t = np.asarray(tr["t"])
    if t.size == 0:
        return None, []
    st = np.asarray(tr["stage"]).astype(int)
    begun = np.flatnonzero(np.diff(np.asarray(tr["recoveries"])) > 0) + 1
    lost = np.flatnonzero(np.asarray(tr["lock_lost"]) > 0)
    first = min([float(t[k]) for k in (*begun[:1], *lost[:1])], default=None)
    events = []
    for k in begun:
        after = np.flatnonzero(st[k:] != RECOVERY)
        e = k + int(after[0]) if after.size else None
        ev = {"t": float(t[k]), "action": "stopped", "t_done": res.stop_time if e is None else float(t[e]),
              "halted": e is not None, "stage": None, "speed_rpm": None,
              "rotor_rpm": rad_s_to_rpm(float(tr["w_m"][e if e is not None else -1]))}
        if e is not None and st[e] in TORQUE_STAGES + START_STAGES:
            ev["stage"] = STAGES[st[e]]
            if st[e] in (5, 6, 7):   # the step that ends the wait used the lost estimate's speed: the next takes the observer's
                ev.update(action="flying restart", speed_rpm=rad_s_to_rpm(float(tr["w_m_hat"][min(e + 1, t.size - 1)])))
            else:
                ev["action"] = "restart"
        events.append(ev)
    return first, events


def true_loss_unanswered(tr, events: list[dict], whole=...) -> float | None:
    """The truth's loss of lock (true_loss_at) after the drive's last
    re-acquisition: a loss before it was answered (the drive's recovery
    followed it). whole: true_loss_at(tr) if the caller has it."""
    t0 = max((ev["t_done"] for ev in events if ev["action"] != "stopped" and ev["t_done"] is not None), default=None)
    if t0 is None:
        return true_loss_at(tr) if whole is ... else whole
    keep = np.asarray(tr["t"]) >= t0
    return true_loss_at({k: np.asarray(tr[k])[keep] for k in ("t", "theta_err", "stage")})


def job_checks(res) -> dict:
    """What says the run did its job beside its stop reason: the start stage
    it ended in (None: it left them), and in speed mode the speed's mean over
    the loop's time constant (1 / bw_speed) before the end against its
    reference's, and the band of a loop in control (CONTROL_BAND of it, at
    least CONTROL_FLOOR of rated speed)."""
    tr, sc = res.traces, res.scenario
    t = np.asarray(tr["t"])
    out: dict = {"start_unfinished": None, "speed_end": None}
    if t.size == 0 or res.stop_reason != "done":
        return out
    st = np.asarray(tr["stage"]).astype(int)
    if st[-1] in START_STAGES:
        since = np.flatnonzero(st != st[-1])
        t_in = float(t[since[-1] + 1]) if since.size else float(t[0])
        out["start_unfinished"] = {"stage": STAGES[st[-1]], "since": t_in,
                                   "never_left": not np.any(in_stages(st, SENSORLESS_STAGES))}
    if sc.data["controller"]["mode"] == "speed":
        tau = 1.0 / sc.data["controller"]["bw_speed"]
        m = t >= t[-1] - tau - 1e-12
        w, w_ref = float(np.mean(tr["w_m"][m])), float(np.mean(tr["w_m_ref"][m]))
        band = max(CONTROL_BAND * abs(w_ref), CONTROL_FLOOR * sc.machine.w_m_rated)
        out["speed_end"] = {"speed_rpm": rad_s_to_rpm(w), "ref_rpm": rad_s_to_rpm(w_ref), "band_rpm": rad_s_to_rpm(band),
                            "window": [float(t[m][0]), float(t[m][-1])], "far": abs(w - w_ref) > band,
                            "unheld": _unheld(res, t, tau, w - w_ref, _settle_band(sc, w_ref))}
        out["speed_steady"] = _steady_unheld(res, t)
    return out


def _settle_band(sc, w_ref: float) -> float:
    """The band a settled speed loop keeps about its reference w_ref (rad/s):
    SETTLE_BAND of it, at least SPEED_FLOOR of rated speed (the step metrics')."""
    return max(SETTLE_BAND * abs(w_ref), SPEED_FLOOR * sc.machine.w_m_rated)


def _steady_unheld(res, t) -> dict | None:
    """The speed's mean over the steady window against its reference's,
    where it is beyond the band a settled loop keeps (SETTLE_BAND of the
    reference, at least SPEED_FLOOR of rated speed): the window starts
    after the loop's settling, so a loop in control holds its mean there.
    The run's end alone does not show it: a drive short of voltage that
    climbs through its reference as the run ends is within the band there
    (a new user's servo with L in mH as H: -5.5 % over the window, exit 0).
    None where the speed was held, there is no window, its reference moves
    (a window given over a ramp), or the drive answered a loss of lock since
    the plan's last change (the window holds its return)."""
    win = _steady(res)[0]
    if win is None:
        return None
    tr, sc = res.traces, res.scenario
    if any(ev["t"] >= _last_change(sc) - 1e-12 for ev in lock_events(res)[1]):
        return None   # a recovery since the plan's last change: the window is its return, which the summary gives
    m = window_mask(t, *win)
    if not np.any(m):
        return None
    ref = np.asarray(tr["w_m_ref"][m])
    if np.ptp(ref) > 0.0:   # a window given over a ramp: the loop's lag behind it, not a hold (yang2022-smo-ramp)
        return None
    w, w_ref = float(np.mean(tr["w_m"][m])), float(ref[0])
    band = _settle_band(sc, w_ref)
    if abs(w - w_ref) <= band:
        return None
    return {"speed_rpm": rad_s_to_rpm(w), "ref_rpm": rad_s_to_rpm(w_ref), "band_rpm": rad_s_to_rpm(band),
            "window": [float(win[0]), float(win[1])]}


def _unheld(res, t, tau: float, e_end: float, band: float) -> dict | None:
    """A speed loop that does not hold its reference at the run's end: its
    error (mean over the last loop time constant tau, e_end) beyond the band
    a settled loop keeps (SETTLE_BAND of the reference, at least SPEED_FLOOR
    of rated speed: the step metrics' band), and either the last flat
    stretch of what the loops follow had the time to settle (its settling
    margin and a time constant: "settled"), or it had not and the error
    grew over the last time constant, read from a time constant after the
    change on ("moving away"). A loop in control
    brings its error into that band; one that stays outside it or recedes
    has run out of torque or voltage, whatever CONTROL_BAND still allows.
    None otherwise (a run that ends while its speed still converges is not
    judged on it)."""
    if abs(e_end) <= band:
        return None
    sc, tr = res.scenario, res.traces
    t_flat = _last_change(sc)
    settled = t[-1] - t_flat >= SETTLE_TAUS * tau + tau - 1e-12
    out = {"error_rpm": rad_s_to_rpm(e_end), "band_rpm": rad_s_to_rpm(band), "tau": tau, "settle": SETTLE_TAUS * tau,
           "since": t_flat,
           "how": "settled" if settled else "moving away", "error_before_rpm": None}
    if not settled:
        # the growth is read from a time constant after the change on: a loop's largest error after a step
        # comes within about two of them (a PI loop's dip), the speed falling away before it in any drive
        if t[-1] - t_flat < 3.0 * tau - 1e-12:
            return None
        before = (t >= t[-1] - 2.0 * tau - 1e-12) & (t < t[-1] - tau - 1e-12)
        e_before = float(np.mean(tr["w_m"][before] - tr["w_m_ref"][before]))
        if e_end * e_before <= 0.0 or abs(e_end) <= abs(e_before):
            return None
        out["error_before_rpm"] = rad_s_to_rpm(e_before)
    return out


# the starts after which the loops run on an estimate from standstill (design.start)
START_KINDS = {"pulses": "polarity pulses", "motion": "motion test", "if": "I/f start", "known": "at a known angle"}


def start_motion(res) -> dict | None:
    """The rotor's motion before the loops first run on an estimate
    (SENSORLESS_STAGES): its largest turn from where it stood, el.deg and
    mechanical degrees, its largest speed, rpm, until when (None: the loops
    never did), and the bound the start's design gives for it (el.deg; None
    where it has none). None for a run that does not start sensorless."""
    st = res.scenario.data.get("start", {})
    kind = st.get("kind")
    tr = res.traces
    t = np.asarray(tr["t"])
    if kind not in START_KINDS or t.size == 0:
        return None
    on = in_stages(tr["stage"], SENSORLESS_STAGES)
    on = on & np.append(on[1:], False)   # for two samples at least: the step a start halts in reads as one
    k = int(np.argmax(on)) if on.any() else t.size - 1
    theta = unwrap(np.asarray(tr["theta_e"])[: k + 1])
    turn = float(np.degrees(np.max(np.abs(theta - theta[0]))))
    p = res.scenario.machine.pole_pairs
    return {"kind": kind, "until": float(t[k]) if on.any() else None, "turn_deg": turn, "turn_deg_mech": turn / p,
            "speed_max_rpm": rad_s_to_rpm(float(np.max(np.abs(np.asarray(tr["w_m"])[: k + 1])))),
            "bound_deg": st.get("c", {}).get("bound_deg")}


def start_given(res) -> dict | None:
    """A sensorless run whose estimator was handed the rotor's true angle
    (the start kind "sensor": the encoder until observer.handover): when it
    ran on the estimate alone (s) and the angle it was given (el.deg). Such
    a run does not show a start from an unknown angle, which its summary
    says. None for every other run."""
    st = res.scenario.data.get("start", {})
    tr = res.traces
    if st.get("kind") != "sensor" or np.asarray(tr["t"]).size == 0:
        return None
    on = in_stages(tr["stage"], SENSORLESS_STAGES)
    if not on.any():
        return None
    k = int(np.argmax(on))
    return {"at": float(tr["t"][k]), "theta_deg": float(np.degrees(tr["theta_e"][k])), "reason": st.get("reason")}


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
    win, out["steady_basis"] = _steady(res)
    out["steady_window"] = list(win) if win else None
    m = window_mask(t, *win) if win else np.zeros(t.size, bool)
    out["i_phase_max"] = float(np.max([np.max(np.abs(tr[ch])) for ch in ("i_a", "i_b", "i_c")]))   # NaN as one
    out["lock_lost_at"], out["lock_events"] = lock_events(res)
    out["recoveries"] = int(tr["recoveries"][-1])
    if res.polarity is not None:
        out["polarity"] = res.polarity
    if getattr(res, "halt", None) is not None:
        out["halt"] = res.halt
    out["ideal_hardware"] = ideal_hardware(res.scenario.data)
    out["warnings"] = list(res.scenario.warnings)
    out["true_loss_at"] = true_loss_at(tr)
    out["true_loss_unanswered_at"] = true_loss_unanswered(tr, out["lock_events"], out["true_loss_at"])
    out["false_alarm_err_deg"] = false_alarm(tr, out["lock_lost_at"], out["true_loss_at"])
    t_sl = sensorless_from(res.scenario)
    out["sensorless_err_deg_max"] = None if t_sl is None else sensorless_error_max(
        tr, t_from=t_sl, channels=stepping_channels(res.scenario))
    # a loss the simulation's truth sees and nothing in the run flagged or answered
    latched = bool(np.any(tr["lock_lost"] > 0))
    out["silent_failure"] = bool(out["true_loss_unanswered_at"] is not None and res.stop_reason == "done" and not latched)
    out.update(job_checks(res))
    faults = fault_report(res)
    if faults is not None:
        out["faults"] = faults
    out["steps"] = step_metrics(res)
    out["stages"] = stage_metrics(tr)
    motion = start_motion(res)
    if motion is not None:
        out["start_motion"] = motion
    given = start_given(res)
    if given is not None:
        out["start_given"] = given
    if not m.any():
        return out
    # the window as a slice where the samples rise (a run's always do): views, not copies of the masked samples;
    # the same samples in the same order, so the same sums
    sel = window_slice(t, *win) if np.all(t[1:] > t[:-1]) else m
    mode = res.scenario.data["controller"]["mode"]
    if mode == "speed":
        w_ref = float(np.mean(tr["w_m_ref"][sel]))
        w = float(np.mean(tr["w_m"][sel]))
        out["speed_ref_rpm"] = rad_s_to_rpm(w_ref)
        out["speed_rpm"] = rad_s_to_rpm(w)
        out["speed_error_pct"] = 100.0 * (w - w_ref) / abs(w_ref) if w_ref != 0 else None
    if mode in ("speed", "current"):
        out["i_d_error_rms"] = float(np.sqrt(np.mean((tr["i_d_ref"][sel] - tr["i_d"][sel]) ** 2)))
        out["i_q_error_rms"] = float(np.sqrt(np.mean((tr["i_q_ref"][sel] - tr["i_q"][sel]) ** 2)))
    out["T_e_mean"] = float(np.mean(tr["T_e"][sel]))
    out["T_e_pp"] = float(np.ptp(tr["T_e"][sel]))
    power = power_metrics(res, m)
    if power is not None:
        out["power"] = power
    out["theta_err_deg"] = angle_error_stats(tr["theta_err"][sel])
    out["est_err_deg"] = angle_error_stats(tr["est_err"][sel])
    return out


# the loss meters (fs_sim.h) by kind: the machine's, then the converter's
LOSS_METERS = {"P_cu_W": ("E_cu", "copper"), "P_fe_W": ("E_fe", "iron"), "P_mech_W": ("E_mech", "friction"),
               "P_cond_W": ("E_cond", "conduction"), "P_sw_W": ("E_sw", "commutation"),
               "P_rect_W": ("E_rect", "rectifier"), "P_filter_W": ("E_rf", "input filter")}


def power_metrics(res, m: np.ndarray) -> dict | None:
    """Where the power goes over the window m, from the loss meters (the
    scenario's [losses] on; else None): the converter's source's power (the
    dc link's, or the grid's for the matrix converter), the machine's
    terminals', the shaft's, each loss, and the efficiencies (motoring:
    out over in; generating: the other way)."""
    if not any(res.scenario.data["losses"].values()):
        return None
    tr, t = res.traces, res.traces["t"]
    k = np.flatnonzero(m)
    if k.size < 2 or not t[k[-1]] > t[k[0]]:
        return None
    dt = t[k[-1]] - t[k[0]]

    def power(ch):
        return float((tr[ch][k[-1]] - tr[ch][k[0]]) / dt)

    imc = res.scenario.data["converter"]["kind"] == "imc"
    out = {"P_source_W": power("E_grid" if imc else "E_dc"), "P_in_W": power("E_in"), "P_shaft_W": power("E_shaft")}
    out.update({key: power(ch) if key != "P_filter_W" or imc else 0.0 for key, (ch, _) in LOSS_METERS.items()})

    def eta(a, b):   # a upstream of b
        if a > 0.0 and b > 0.0:
            return b / a
        return a / b if a < 0.0 and b < 0.0 else None

    out["eta_machine"] = eta(out["P_in_W"], out["P_shaft_W"])
    out["eta_converter"] = eta(out["P_source_W"], out["P_in_W"])
    out["eta_drive"] = eta(out["P_source_W"], out["P_shaft_W"])
    return out


def summary_lines(metrics: dict) -> list[str]:
    """The metrics a person reads after a run, a line each: the steady
    window and what was measured in it, each step, each stage."""
    lines = []
    win = metrics.get("steady_window")
    lines.append(f"steady window: {win[0]:g}..{win[1]:g} s, {metrics['steady_basis']}" if win
                 else f"steady window: {metrics.get('steady_basis', 'none')}")
    if metrics.get("speed_error_pct") is not None:
        lines.append(f"  speed {metrics['speed_rpm']:.2f} rpm against {metrics['speed_ref_rpm']:.2f} rpm: "
                     f"error {metrics['speed_error_pct']:+.4f} %")
    p = metrics.get("power")
    if p is not None:
        losses = ", ".join(f"{label} {p[key]:.4g}" for key, (_, label) in LOSS_METERS.items() if p[key] != 0.0)
        effs = ", ".join(f"{k} {100 * p[f'eta_{k}']:.2f} %" for k in ("machine", "converter", "drive")
                         if p[f"eta_{k}"] is not None)
        lines.append(f"  power: source {p['P_source_W']:.4g} W, machine terminals {p['P_in_W']:.4g} W, shaft "
                     f"{p['P_shaft_W']:.4g} W; losses (W): {losses}" + (f"; efficiency {effs}" if effs else ""))
    if isinstance(metrics.get("theta_err_deg"), dict) and metrics["theta_err_deg"]["mean"] is not None:
        e = metrics["theta_err_deg"]
        lines.append(f"  angle error (true - used) mean {e['mean']:+.2f}, peak-to-peak {e['pp']:.2f}, max |.| {e['max']:.2f} el.deg")

    def opt(v, fmt):
        return "-" if v is None else format(v, fmt)

    for r in metrics.get("steps", []):
        ramp = f" over {r['ramp'] * 1e3:.3g} ms" if r["ramp"] > 0 else ""
        head = f"{r['kind']} step at {r['t']:g} s{ramp}, {r['from']:g} -> {r['to']:g} {r['unit']}"
        if r["kind"] == "reference":
            body = (f"overshoot {opt(r['overshoot_pct'], '.2f')} %, rise {opt(r['rise_time'] and r['rise_time'] * 1e3, '.1f')} ms, "
                    f"settling {opt(r['settling_time'] and r['settling_time'] * 1e3, '.1f')} ms")
        elif r.get(f"{r['response']}_rpm") is None:
            lines.append(f"{head}: speed {r['response']} not measured ({r.get('note', 'no samples')})")
            continue
        else:
            name = r["response"]
            body = (f"speed {name} {r[f'{name}_rpm']:.1f} rpm at {r[f't_{name}']:.4g} s, "
                    f"recovery {opt(r['recovery_time'] and r['recovery_time'] * 1e3, '.1f')} ms")
        if r.get("final") is not None:
            body += f", final {r['final']:.4g} {r['unit']}"
        lines.append(f"{head}: {body}" + (f" ({r['note']})" if r.get("note") else ""))
    for name, st in metrics.get("stages", {}).items():
        lines.append(f"stage {name:15s} {st['time']:8.4f} s in {st['entries']} entr{'y' if st['entries'] == 1 else 'ies'}, "
                     f"max |angle error| {st['theta_err_max_deg']:.2f} el.deg" + STAGE_NOTES.get(name, ""))
    if metrics.get("sensorless_err_deg_max") is not None:
        lines.append(f"largest angle error while sensorless (the stages start, injection, blend, backemf, flux_weakening; "
                     f"outside 50 ms after each step): {metrics['sensorless_err_deg_max']:.2f} el.deg")
    sm = metrics.get("start_motion")
    if sm is not None:
        until = f"before the loops ran on the estimate at {sm['until']:.4f} s" if sm["until"] is not None \
            else "and the loops never ran on the estimate"
        bound = f" (the start's bound {sm['bound_deg']:.1f} el.deg)" if sm.get("bound_deg") is not None else ""
        lines.append(f"start ({START_KINDS[sm['kind']]}): the rotor turned {sm['turn_deg']:.2f} el.deg "
                     f"({sm['turn_deg_mech']:.2f} deg mechanical), at most {sm['speed_max_rpm']:.1f} rpm, {until}{bound}")
    sg = metrics.get("start_given")
    if sg is not None:
        lines.append(f"start: none from an unknown angle: the estimator was given the rotor's angle "
                     f"({sg['theta_deg']:.2f} el.deg) and ran alone from {sg['at']:.4f} s ({sg['reason']}); "
                     f"for a start that does not know it: observer.start = \"if\", or controller.angle = \"hfi\" or \"blend\"")
    lines += lock_lines(metrics)
    return lines


# what a stage's angle error is, where it is not the loops' error on an estimate
STAGE_NOTES = {"polarity": " (the polarity is being decided: pi-ambiguous until then)",
               "recovery": " (zero current: the estimate is being re-acquired)"}


def false_alarm(tr, lock_lost_at: float | None, true_loss: float | None) -> float | None:
    """Where the drive's monitor flagged a loss of lock that the
    simulation's truth never saw (true_loss_at): the largest |angle error|
    (el.deg) in the sensorless stages up to the flag, the evidence that the
    estimate still held the rotor. None where there was no flag, or the
    truth saw a loss too. The drive cannot know it; the run says it."""
    if lock_lost_at is None or true_loss is not None:
        return None
    t = np.asarray(tr["t"])
    on = in_stages(tr["stage"], SENSORLESS_STAGES) & (t <= lock_lost_at + 1e-12)
    return float(np.degrees(np.max(np.abs(np.asarray(tr["theta_err"])[on])))) if on.any() else None


def lock_lines(metrics: dict) -> list[str]:
    """What the drive did on each loss of lock it began a recovery for, and
    whether the simulation's truth saw the loss."""
    out = []
    if metrics.get("false_alarm_err_deg") is not None:
        out.append(f"the simulation's truth saw no loss of lock: the loops' angle was within "
                   f"{metrics['false_alarm_err_deg']:.1f} el.deg of the rotor's up to the flag; the drive's monitor "
                   "flagged a loss that was not (a false alarm, which a drive on hardware could not tell)")
    for ev in metrics.get("lock_events", []):
        head = f"lock lost at {ev['t']:.4f} s: "
        if ev["action"] == "flying restart":
            out.append(head + f"re-acquired at {ev['t_done']:.4f} s by a flying restart (zero current, the back-EMF "
                       f"observer caught the rotor at {ev['speed_rpm']:.0f} rpm; the rotor's {ev['rotor_rpm']:.0f} rpm)")
        elif ev["action"] == "restart":
            out.append(head + f"re-acquired at {ev['t_done']:.4f} s by the start sequence again ({ev['stage']}; "
                       f"the rotor at {ev['rotor_rpm']:.0f} rpm)")
        elif ev["halted"]:
            out.append(head + f"not re-acquired: the drive stopped with the PWM off at {ev['t_done']:.4f} s (the rotor at "
                       f"{ev['rotor_rpm']:.0f} rpm)")
        else:
            out.append(head + f"the run ended during the zero-current wait ({metrics.get('stop_reason')}, the rotor at "
                       f"{ev['rotor_rpm']:.0f} rpm)")
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
    "start_motion.kind", "start_motion.turn_deg", "start_motion.speed_max_rpm", "start_motion.bound_deg",
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


# fs_drive_stage, by value (csrc/control/fs_drive.h)
STAGES = ("open", "sensor", "polarity", "start", "injection", "blend", "backemf", "flux_weakening", "recovery")


def stage_changes(tr) -> list[tuple[float, str]]:
    """The drive's operating stages in the order it passed them: (time
    entered, name), the first at the first sample."""
    s = np.asarray(tr["stage"]).astype(int)
    k = np.r_[0, np.flatnonzero(np.diff(s)) + 1] if s.size else np.array([], int)
    return [(float(tr["t"][i]), STAGES[s[i]]) for i in k]
