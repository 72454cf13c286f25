"""fullspeed's designed blended drive against motulator's saturation-aware
sensorless control on two saturated PM-SyRMs (issue 33's last 'done when'
item): SyR-e's THOR (5 kW, FEA flux map, catalog `syre-thor`) and the Baldor
ECS101M0H7EF4 (5.6 kW, measured flux map, `baldor-ecs101m0h7ef4`).

One job per machine, the same on both sides (syrm_job):
  standstill for START s (fullspeed's start: its polarity or motion test),
  a speed ramp to TOP x the rated speed (motulator's base speed, its
  examples' 2 p.u.) in twice the time the envelope's torque would take
  (at least ACC_MIN s), HOLD s at that speed, then a step of the load to
  the rated torque or LOAD_SHARE of the envelope's torque at the top speed
  (design.envelope at the drive's designed current limit), the lower,
  held for LOAD_WINDOW + STEADY s.
The stretches (windows): start-up from 0 until the reference reaches
START_SHARE of the top speed, acceleration from there to the load step,
load step LOAD_WINDOW s from it, steady the rest; beside them the
start-up's two parts, at standstill (fullspeed's estimator settling and
its start's test) and on the ramp.

Both sides: the catalog machine's flux map, R_s, J and link, the same
current limit (fullspeed's designed i_max), averaged converter (no dead
time, no switching ripple), ideal current and position sensors on the
peer's side; fullspeed's side keeps its catalog bench's 12-bit current ADC
(its injection is designed on it), the only non-ideality, and on its side
alone. The peer side (bench/syrm_peer_motulator.py) is motulator 0.18's own
example drive per machine (THOR: current-vector control on the FEA map;
Baldor: flux-vector and current-vector control on the example's fitted
saturation model), started, as its examples start, with its estimate at
the rotor's angle. fullspeed runs angle = "blend" with the designed
defaults only (no injection, blending, observer or bandwidth setting;
flux weakening on, which the top speed needs), three times (VARIANTS): as
designed (its own polarity or motion test, the 12-bit ADC); as the peer
starts, with the rotor at the estimate (polarity detection off); and with
ideal current sensors as the peer's (the design then forms its carrier
without the ADC's steps).

Per stretch: max and RMS angle error (true minus the angle the loops use,
el.deg) of each run and the difference to the best peer (the lower of the
peers' figures on that stretch); within GOAL_DEG or not. And the encoder's
acceleration: fullspeed's encoder drive and the peer's sensored drive on a
step of the reference to the top speed at START (no load): the time to
90 % and 98 % of it, against the least time the envelope allows (the
envelope's torque all the way, no load), and the current magnitude over
the acceleration against the limit (its mean share and the time at 95 %
of it or more).

Writes syrm_peer.json and one figure per machine into --out; motulator
runs in the virtual environment bench/wall.py makes (where it cannot run,
fullspeed's side still runs and the peer's entries say why).

Usage: python bench/syrm_peer.py [--out DIR] [--machines syre-thor,baldor-ecs101m0h7ef4]
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import estimators  # noqa: E402  (window statistics, the peer's runs, the atomic writes)

PEER = HERE / "syrm_peer_motulator.py"
MAPS = HERE.parent / "src" / "fullspeed" / "machines"
RPM = 30.0 / np.pi

START = 0.5          # s at standstill before the ramp: fullspeed's designed start (motion test, polarity pulses) is done
TOP = 2.0            # x the rated speed: motulator's examples run to 2 p.u. of their base speed, the rated one
ACC_MARGIN = 2.0     # the ramp takes this times the least time the envelope's torque would take (half the torque spare)
ACC_MIN = 0.4        # s: the shortest ramp
HOLD = 0.3           # s at the top speed before the load step
LOAD_SHARE = 0.9     # the load at most this share of the envelope's torque at the top speed (the speed loop's margin)
LOAD_WINDOW = 0.3    # s: the load step's stretch
STEADY = 0.5         # s: the steady stretch after it
START_SHARE = 0.1    # the start-up stretch ends where the reference reaches this share of the top speed
STRETCHES = ("start-up", "acceleration", "load step", "steady")   # the goal's; the windows' first four
PARTS = ("start-up: standstill", "start-up: ramp")                 # the start-up's two parts, reported beside
GOAL_DEG = 3.0       # el.deg: fullspeed's figure at most the best peer's plus this, in every stretch
ACC_LEVELS = (0.9, 0.98)   # the acceleration's time to these shares of the top speed
AT_LIMIT = 0.95      # |i| at or above this share of the limit counts as using it
ENCODER_TAIL = 1.0   # s after the envelope's least time to the top speed, for the encoder runs

MACHINES = {
    "syre-thor": {"peers": ("thor-cvc",), "map": "syre-thor.csv"},
    "baldor-ecs101m0h7ef4": {"peers": ("baldor-fvc", "baldor-cvc"), "map": "baldor-ecs101m0h7ef4.csv"},
}
VARIANTS = ("", "known start", "ideal ADC")   # the blended runs: as designed, and fullspeed_data's two variants
PEER_LABEL = {"thor-cvc": "motulator CVC", "baldor-fvc": "motulator FVC", "baldor-cvc": "motulator CVC"}


class Job(NamedTuple):
    """One machine's job, SI (rad/s mechanical, N m, A, s)."""
    machine: str
    n_p: int
    R_s: float
    J: float
    u_dc: float
    i_max: float
    w_rated: float
    w_top: float
    T_rated: float
    T_env_top: float      # the envelope's torque at the top speed, at i_max
    T_load: float
    t_acc_min: float      # the envelope's least time from standstill to the top speed, no load
    t_least: tuple        # the same to each of ACC_LEVELS x the top speed
    t0: float             # the ramp's start
    t1: float             # the ramp's end
    t_step: float         # the load step
    t_end: float
    windows: tuple        # (name, from, to) per stretch (stretches)


def stretches(t0: float, t1: float, t_step: float) -> tuple:
    """The four stretches of a job whose ramp runs t0..t1 and whose load
    steps at t_step: they tile 0..t_step + LOAD_WINDOW + STEADY; then the
    start-up's two parts, at standstill (before t0) and on the ramp."""
    t_su = t0 + START_SHARE * (t1 - t0)
    return (("start-up", 0.0, t_su), ("acceleration", t_su, t_step),
            ("load step", t_step, t_step + LOAD_WINDOW), ("steady", t_step + LOAD_WINDOW, t_step + LOAD_WINDOW + STEADY),
            (PARTS[0], 0.0, t0), (PARTS[1], t0, t_su))


def least_time(J: float, w: np.ndarray, T: np.ndarray, T_load: float = 0.0) -> float:
    """The least time from w[0] to w[-1] with torque T(w) against T_load:
    the integral of J / (T - T_load) dw (trapezoid; w rising, T above T_load)."""
    return float(np.trapezoid(J / (np.asarray(T) - T_load), np.asarray(w)))


def syrm_job(machine: str) -> Job:
    """The job of catalog machine `machine` (module docstring)."""
    from fullspeed.design.envelope import envelope, torque_at
    from fullspeed.design.machine import load_machine
    m = load_machine(machine)
    i_max = m.bench["i_max"]
    w_top = TOP * m.w_m_rated
    env = envelope(m, m.bench["u_dc"], i_max, w_end=1.5 * w_top)
    T_env_top = float(torque_at(env, w_top))
    ws = np.linspace(0.0, w_top, 201)
    t_acc_min = least_time(m.J, ws, torque_at(env, ws))
    t_least = tuple(least_time(m.J, w, torque_at(env, w)) for w in (np.linspace(0.0, lv * w_top, 201) for lv in ACC_LEVELS))
    t_acc = max(ACC_MIN, round(ACC_MARGIN * t_acc_min, 2))
    t0, t1 = START, START + t_acc
    t_step = t1 + HOLD
    windows = stretches(t0, t1, t_step)
    return Job(machine=machine, n_p=m.pole_pairs, R_s=m.R_s, J=m.J, u_dc=m.bench["u_dc"], i_max=i_max,
               w_rated=m.w_m_rated, w_top=w_top, T_rated=m.T_rated, T_env_top=T_env_top,
               T_load=min(m.T_rated, LOAD_SHARE * T_env_top), t_acc_min=t_acc_min, t_least=t_least,
               t0=t0, t1=t1, t_step=t_step, t_end=windows[len(STRETCHES) - 1][2], windows=windows)


def speed_points(job: Job, step: bool) -> list:
    """The speed reference (rad/s): the ramp, or (step) the top speed at once at t0."""
    t1 = job.t0 if step else job.t1
    return [[0.0, 0.0], [job.t0, 0.0], [t1, job.w_top], [job.t_end, job.w_top]]


def load_points(job: Job, step: bool) -> list:
    """The load torque (N m): the step at t_step (none on an encoder step run)."""
    return [[0.0, 0.0]] if step else [[0.0, 0.0], [job.t_step, 0.0], [job.t_step, job.T_load]]


def encoder_end(job: Job) -> float:
    return round(job.t0 + job.t_acc_min + ENCODER_TAIL, 3)


def fullspeed_data(job: Job, angle: str, variant: str = "") -> dict:
    """fullspeed's scenario of the job: the catalog machine, the designed
    defaults only (angle, flux weakening, the averaged converter); angle
    encoder runs the step to the top speed. A VARIANTS entry changes one
    thing: "known start" turns polarity detection off (the rotor at the
    estimate, as the peer starts), "ideal ADC" makes the current sensors
    ideal as the peer's are (the design then forms the carrier without the
    ADC's steps)."""
    step = angle == "encoder"
    dur = encoder_end(job) if step else job.t_end
    data = {"name": f"syrm-peer-{job.machine}-{angle}{'-' + variant.replace(' ', '-') if variant else ''}", "duration": dur,
            "machine": job.machine, "converter": {"inverter": "averaged"},
            "controller": {"mode": "speed", "angle": angle, "flux_weakening": True},
            "references": {"speed_rpm": [[t, w * RPM] for t, w in speed_points(job, step)]},
            "load": {"kind": "torque", "torque": load_points(job, step)}}
    if not step:
        steady = job.windows[len(STRETCHES) - 1]
        data["metrics"] = {"steady": [steady[1], steady[2]]}
    if variant == "known start":
        data["polarity"] = {"enabled": False}
    elif variant == "ideal ADC":
        data["sensors"] = {"adc_bits": 0}
    return data


def peer_job(job: Job, case: str, sensorless: bool) -> dict:
    """The peer runner's job (syrm_peer_motulator.py): the same machine data,
    limit, reference and load; sensored runs take the encoder's step."""
    step = not sensorless
    return {"case": case, "map_csv": str(MAPS / MACHINES[job.machine]["map"]), "n_p": job.n_p, "R_s": job.R_s,
            "J": job.J, "u_dc": job.u_dc, "i_s_max": job.i_max, "sensorless": sensorless,
            "speed": speed_points(job, step), "load": load_points(job, step),
            "t_stop": encoder_end(job) if step else job.t_end}


def acceleration(t: np.ndarray, w: np.ndarray, i_abs: np.ndarray, t0: float, w_top: float, i_max: float) -> dict:
    """The acceleration from t0 on a step to w_top: the time to each of
    ACC_LEVELS of it (None where never reached), and over t0 .. the first
    level the current magnitude's mean share of i_max and the share of that
    time at AT_LIMIT x i_max or more."""
    out = {}
    for lv in ACC_LEVELS:
        hit = np.flatnonzero((t >= t0) & (w >= lv * w_top))
        out[f"t_{round(lv * 100)}"] = None if hit.size == 0 else float(t[hit[0]] - t0)
    first = out[f"t_{round(ACC_LEVELS[0] * 100)}"]
    m = (t >= t0) & (t < t0 + (first if first is not None else t[-1] - t0))
    out["i_mean_share"] = float(np.mean(i_abs[m]) / i_max) if m.any() else None
    out["at_limit_share"] = float(np.mean(i_abs[m] >= AT_LIMIT * i_max)) if m.any() else None
    out["i_peak"] = float(np.max(i_abs[m])) if m.any() else None
    return out


def _err_stats(t, err, w, w_hat, w_ref, windows) -> dict:
    return {"t_err_over_90deg_s": float(np.sum(np.abs(err) > np.pi / 2) * np.median(np.diff(t))),
            "windows": estimators.window_stats(t, err, w, w_hat, w_ref, windows)}


def run_fullspeed(job: Job, angle: str, variant: str = "") -> tuple[dict, dict]:
    import fullspeed.sim as fs
    from fullspeed.design.scenario import scenario_from_dict
    data = fullspeed_data(job, angle, variant)
    sc = scenario_from_dict(data, f"bench/syrm_peer.py {job.machine}")
    res = fs.simulate(sc)
    t, w = np.asarray(res["t"]), np.asarray(res["w_m"])
    i_abs = np.hypot(res["i_d"], res["i_q"])
    rep = {"scenario": data, "stop": res.stop_reason, "stop_time": res.stop_time, "wall_s": res.wall_time,
           "start": sc.data.get("start", {}).get("kind"), "settings": estimators.designed_settings(sc)}
    tr = {"t": t, "w_m": w, "w_ref": np.asarray(res["w_m_ref"]), "i_abs": i_abs}
    if angle == "encoder":
        rep["acceleration"] = acceleration(t, w, i_abs, job.t0, job.w_top, job.i_max)
    else:
        err = estimators._wrap(res["theta_err"])
        rep.update(_err_stats(t, err, w, np.asarray(res["w_m_hat"]), tr["w_ref"], job.windows))
        tr["err"] = err
    rep["i_peak"] = float(np.max(i_abs))
    return rep, tr


def run_peer(job: Job, case: str, sensorless: bool) -> tuple[dict, dict | None]:
    info, d = estimators.peer_run(PEER, ["--job", "{job}"], {"job": json.dumps(peer_job(job, case, sensorless))})
    if info.get("status") == "missing":
        return info, None
    rep = {"status": "ok", "peer": estimators.wall.PEERS[0], "case": case, "wall_s": info["wall_s"], "T_s": info["T_s"],
           "i_peak": float(np.max(d["i_abs_model"]))}
    tr = {"t": d["t_model"], "w_m": d["w_m_model"], "i_abs": d["i_abs_model"],
          "w_ref": np.interp(d["t_model"], d["t"], d["w_m_ref"])}
    if sensorless:
        err = estimators._wrap(d["theta_e"] - d["theta_hat"])
        rep.update(_err_stats(d["t"], err, d["w_m"], d["w_m_hat"], d["w_m_ref"], job.windows))
        tr.update(t_c=d["t"], err=err)
    else:
        rep["acceleration"] = acceleration(d["t_model"], d["w_m_model"], d["i_abs_model"], job.t0, job.w_top, job.i_max)
    return rep, tr


def against_best_peer(windows: tuple, run: dict, peers: dict) -> list[dict]:
    """Per stretch: the run's max and RMS error, the best peer's (the lowest
    of the peers that ran, per figure) and the differences; within: the
    run's max at most the best peer's plus GOAL_DEG (None: nothing to
    compare)."""
    rows = []
    for name, _, _ in windows:
        ours = run.get("windows", {}).get(name)
        theirs = [(k, p["windows"][name]) for k, p in peers.items() if p.get("status") == "ok" and p["windows"].get(name)]
        row = {"stretch": name, "max": None if ours is None else ours["max"], "rms": None if ours is None else ours["rms"]}
        if theirs and ours is not None:
            best_max = min(theirs, key=lambda kv: kv[1]["max"])
            best_rms = min(theirs, key=lambda kv: kv[1]["rms"])
            row.update(peer_max=best_max[1]["max"], peer_max_by=best_max[0], peer_rms=best_rms[1]["rms"],
                       peer_rms_by=best_rms[0], d_max=ours["max"] - best_max[1]["max"],
                       d_rms=ours["rms"] - best_rms[1]["rms"])
            row["within"] = bool(row["d_max"] <= GOAL_DEG) if name in STRETCHES else None
        else:
            row["within"] = None
        rows.append(row)
    return rows


def within_everywhere(rows: list[dict]) -> bool | None:
    """Whether a run is within the goal in every one of the STRETCHES
    (None where any of them had nothing to compare)."""
    verdicts = [r["within"] for r in rows if r["stretch"] in STRETCHES]
    return None if None in verdicts or len(verdicts) < len(STRETCHES) else all(verdicts)


def figure(job: Job, traces: dict, out: Path) -> str | None:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:
        return f"no figure: {exc}"
    fig, (ax1, ax2, ax3) = plt.subplots(3, 1, figsize=(10, 9))
    for label, tr in traces.items():
        if "err" in tr:
            ax1.plot(tr.get("t_c", tr["t"]), np.degrees(tr["err"]), lw=0.7, label=label)
            ax2.plot(tr["t"], tr["w_m"] * RPM, lw=0.7, label=label)
        else:
            ax3.plot(tr["t"], tr["i_abs"], lw=0.7, label=label)
    ax2.plot(*zip(*[(t, w * RPM) for t, w in speed_points(job, False)]), "k--", lw=0.6, label="reference")
    for ax in (ax1, ax2):
        for _, a, _b in job.windows[1:len(STRETCHES)]:
            ax.axvline(a, color="grey", lw=0.4)
    ax3.axhline(job.i_max, color="k", ls="--", lw=0.6, label="i_max")
    ax1.set_ylim(-20, 20)
    ax1.set_ylabel("angle error (el.deg)")
    ax2.set_ylabel("speed (rpm)")
    ax2.set_xlabel("time (s)")
    ax3.set_ylabel("|i| (A), encoder step")
    ax3.set_xlabel("time (s)")
    ax1.set_title(f"{job.machine}: 0 -> {job.w_top * RPM:.0f} rpm, {job.T_load:.1f} N m step at {job.t_step:.2f} s")
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    return estimators.save_figure(fig, out / f"syrm_peer_{job.machine}.png")


def machine_report(machine: str, out: Path) -> dict:
    job = syrm_job(machine)
    peers, enc, traces = {}, {}, {}
    for case in MACHINES[machine]["peers"]:
        peers[case], tr = run_peer(job, case, sensorless=True)
        if tr is not None:
            traces[f"{PEER_LABEL[case]} ({case})"] = tr
        enc[f"peer {case}"], tr = run_peer(job, case, sensorless=False)
        if tr is not None:
            traces[f"{PEER_LABEL[case]} sensored"] = tr
    runs = {}
    for variant in VARIANTS:
        label = "blend designed" + (f", {variant}" if variant else "")
        runs[label], traces[f"fullspeed {label}"] = run_fullspeed(job, "blend", variant)
    enc["fullspeed encoder"], traces["fullspeed encoder"] = run_fullspeed(job, "encoder")
    ok = all(r["stop"] == "done" for r in (*runs.values(), enc["fullspeed encoder"]))
    info = {k: (v if not isinstance(v, float) else float(v)) for k, v in job._asdict().items()}
    info.update(base_rpm=job.w_rated * RPM, top_rpm=job.w_top * RPM)
    comparison = {label: against_best_peer(job.windows, r, peers) for label, r in runs.items()}
    return {"status": "ok" if ok else "fail", "job": info, "peers": peers, "fullspeed": runs, "encoder": enc,
            "comparison": comparison, "within_everywhere": {k: within_everywhere(v) for k, v in comparison.items()},
            "figure": figure(job, traces, out)}


def syrm_report(out: Path, machines=tuple(MACHINES)) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    rep = {"status": "ok", "goal_deg": GOAL_DEG, "machines": {}}
    for m in machines:
        rep["machines"][m] = machine_report(m, out)
        if rep["machines"][m]["status"] != "ok":
            rep["status"] = "fail"   # a run that stopped early is not a comparison
    estimators._write_atomic(out / "syrm_peer.json", json.dumps(rep, indent=2, default=str).encode())
    return rep


def _f(x, fmt="6.2f") -> str:
    return "   n/a" if x is None else format(x, fmt)


def format_report(rep: dict) -> str:
    lines = []
    for m, r in rep["machines"].items():
        j = r["job"]
        lines.append(f"{m}: 0 -> {j['top_rpm']:.0f} rpm ({TOP:g} x {j['base_rpm']:.0f}) in {j['t1'] - j['t0']:.2f} s from "
                     f"{j['t0']:g} s, {j['T_load']:.2f} N m step at {j['t_step']:.2f} s (rated {j['T_rated']:g}, "
                     f"envelope at the top {j['T_env_top']:.2f}), i_max {j['i_max']:.2f} A")
        for case, p in r["peers"].items():
            if p["status"] != "ok":
                lines.append(f"  peer {case}: missing: {p['reason']}")
                continue
            lines.append(f"  peer {case}: max / rms el.deg per stretch: " + "; ".join(
                f"{w} {s['max']:.2f} / {s['rms']:.2f}" for w, s in p["windows"].items() if s is not None))
        for label, rows in r["comparison"].items():
            run = r["fullspeed"][label]
            lines.append(f"  fullspeed {label} (start {run['start']}, stop {run['stop']}) vs best peer: "
                         "max / rms el.deg, peer's, difference")
            for row in rows:
                verdict = {True: "within", False: "NOT within", None: "n/a"}[row["within"]]
                lines.append(f"    {row['stretch']:<13}{_f(row['max'])} /{_f(row['rms'])}   peer {_f(row.get('peer_max'))} /"
                             f"{_f(row.get('peer_rms'))} ({row.get('peer_max_by', '-')})   d {_f(row.get('d_max'), '+6.2f')} /"
                             f"{_f(row.get('d_rms'), '+6.2f')}   {verdict} {GOAL_DEG:g}")
            everywhere = {True: "within", False: "NOT within", None: "n/a"}[r["within_everywhere"][label]]
            lines.append(f"    every stretch: {everywhere} {GOAL_DEG:g} el.deg of the best peer")
        least = ", ".join(f"{t:.3f} s to {lv:.0%}" for lv, t in zip(ACC_LEVELS, j["t_least"]))
        lines.append(f"  acceleration on a step to the top speed (no load; the envelope's least time {least}):")
        for label, e in r["encoder"].items():
            if e.get("status") == "missing":
                lines.append(f"    {label}: missing: {e['reason']}")
                continue
            a = e["acceleration"]
            lines.append(f"    {label:<20} t90 {_f(a['t_90'], '.3f')} s, t98 {_f(a['t_98'], '.3f')} s; |i| to t90: mean "
                         f"{_f(a['i_mean_share'], '.2f')} x i_max, at >= {AT_LIMIT:g} x i_max {_f(a['at_limit_share'], '.2f')} of "
                         f"the time, peak {_f(a['i_peak'], '.1f')} A")
        if r["figure"]:
            lines.append(f"  figure: {r['figure']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("out/bench"))
    ap.add_argument("--machines", default=",".join(MACHINES), help="comma-separated among " + ", ".join(MACHINES))
    a = ap.parse_args(argv)
    machines = estimators.pick("--machines", a.machines, MACHINES)
    if machines is None:
        return 2
    rep = syrm_report(a.out, tuple(machines))
    print(format_report(rep))
    return 1 if rep["status"] == "fail" else 0


if __name__ == "__main__":
    sys.exit(main())
