"""The efficiency map: where the power goes over a drive's torque-speed
envelope, at the controller's own operating points.

Each point of the map is a closed-loop run: the drive in speed mode holds
the speed (it starts there) while a load torque ramps in, with its own MTPA
and flux weakening choosing the currents; over the run's last stretch the
loss meters (csrc/sim/fs_sim.h, the scenario's [losses] on) give the powers:
the shaft's, the machine's terminals', the converter's source's, and every
loss by kind (copper, iron, friction; conduction, commutation, the matrix
converter's rectifier and filter). Efficiencies (motoring):

    machine   = P_shaft / P_in,   converter = P_in / P_source,   drive = P_shaft / P_source.

The torques of each speed are fractions of the analytic envelope there
(`envelope`: the most torque within the current limit and the modulator's
linear voltage, steady state with R_s); a point the drive does not hold
(its speed off by more than HELD of the reference over the window, or a
stop) is kept with `held` false and left out of the contours. The points run
through the sweep engine's journal (workflows/journal.py): in parallel,
and a map stopped midway resumes where it stopped.
"""
from __future__ import annotations

import csv
import math
import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .._core import lib  # noqa: E402
from ..design.drawing import save_figure  # noqa: E402
from ..design.envelope import limits  # noqa: E402
from ..design.rules import u_linear  # noqa: E402
from ..design.scenario import scenario_from_dict  # noqa: E402
from ..model.errors import ConfigError  # noqa: E402
from ..model.files import write_json, write_with  # noqa: E402
from ..model.fluxmap import interp  # noqa: E402
from ..model.machines import catalog_names  # noqa: E402
from ..model.scenario import Scenario, check_target, scenario_data, scenario_names  # noqa: E402
from ..model.schema import deep_merge, read_toml  # noqa: E402
from ..model.units import rad_s_to_rpm, rpm_to_rad_s  # noqa: E402
from ..sim.metrics import window_mask  # noqa: E402
from ..sim.runner import simulate  # noqa: E402
from .journal import run_tasks  # noqa: E402

SENSED = ("encoder", "true")   # the angles a point can start on at its speed
HELD = 0.01          # the speed's mean over the window within 1 % of the reference
T_RAMP = 0.3         # s: the load torque's ramp from zero, slow enough for the loops to stay on track (a 20 ms ramp drives the Prius's into voltage saturation they do not leave)
SPEED_FRACTIONS = 8  # speeds, evenly to the top speed
TORQUE_FRACTIONS = (0.1, 0.25, 0.4, 0.55, 0.7, 0.85, 0.97)   # of the envelope's torque at each speed
COLUMNS = ["speed_rpm", "torque_Nm", "held", "stop_reason", "speed_mean_rpm", "P_shaft_W", "P_in_W", "P_source_W",
           "eta_machine", "eta_converter", "eta_drive", "P_cu_W", "P_fe_W", "P_mech_W", "P_cond_W", "P_sw_W", "P_rect_W",
           "P_filter_W", "i_d_A", "i_q_A", "i_s_A", "i_d_fw_A", "u_s_V", "wall_s"]
LOSSES = {"P_cu_W": "copper", "P_fe_W": "iron", "P_mech_W": "friction", "P_cond_W": "conduction",
          "P_sw_W": "commutation", "P_rect_W": "rectifier", "P_filter_W": "input filter"}


def voltage_limit(sc: Scenario) -> float:
    """The modulator's largest peak phase voltage without over-modulation:
    the inverter's linear limit, or the matrix converter's transfer ratio of
    its highest region times the grid's amplitude (zou2021 sec. 3.3)."""
    conv = sc.data["converter"]
    if conv["kind"] == "imc":
        region = {"linear": lib.FS_IMC_LINEAR, "om1": lib.FS_IMC_OM1, "om2": lib.FS_IMC_OM2}[conv["modulation"]]
        return lib.fs_imc_vtr_max(region, math.pi / 6) * conv["grid_ll_rms"] * math.sqrt(2.0 / 3.0)
    return u_linear(conv["u_dc"], sc.machine.phases)


def fluxes(m, i_d, i_q):
    """psi_d, psi_q of the machine at currents (its flux map, else its
    [electrical] L_d, L_q, psi_f: the algebraic model's unsaturated values)."""
    if m.magnetic["model"] == "fluxmap":
        return interp(m.magnetic, "psi_d", i_d, i_q), interp(m.magnetic, "psi_q", i_d, i_q)
    return m.L_d * i_d + m.psi_f, m.L_q * i_q


def envelope(m, speeds_rpm, i_max: float, u_max: float) -> np.ndarray:
    """The most torque (N m) at each speed within |i| <= i_max and the
    steady-state voltage |R i + j w psi| <= u_max: the MTPA, flux-weakening
    and MTPV limits, on the machine's own magnetics (its flux map or its
    saturation model). `fullspeed design`'s search (design.envelope), so
    that a map's torques are fractions of the envelope design prints: with
    the unsaturated L_d, L_q and psi_f of an algebraic model the map's
    envelope was 8 % above design's on yang2022's machine, and its top
    points could not be held by construction."""
    lim = limits(m, u_max / u_linear(1.0, m.phases), i_max, u_max)   # the link whose linear limit is u_max
    T, _, _ = lim.best(m.pole_pairs * rpm_to_rad_s(np.atleast_1d(np.asarray(speeds_rpm, float))))
    return np.nan_to_num(T, nan=0.0)   # beyond the top speed: none


def base_data(target: str, overrides: dict | None = None) -> tuple[dict, str]:
    """The map's base scenario: a scenario (catalog name or file) as given,
    or, for a machine (catalog name or machine file), speed control on the
    encoder with flux weakening on the machine's bench."""
    check_target(target)
    p = Path(target)
    if p.suffix == ".toml":
        table = read_toml(p, "target")
        if "machine" in table:   # a scenario file
            return scenario_data(p, overrides)
        machine, name = str(p.resolve()), str(table.get("name", p.stem))
    elif target in scenario_names() or target not in catalog_names():
        return scenario_data(target, overrides)
    else:
        machine, name = target, target
    data = {"name": f"map-{name}", "duration": 1.0, "machine": machine,
            "controller": {"mode": "speed", "angle": "encoder", "flux_weakening": True}}
    return deep_merge(data, overrides or {}), str(p)


def map_scenarios(data: dict, source: str, top_rpm: float | None) -> tuple[Scenario, dict]:
    """The base scenario checked for a map, and the overrides every point
    shares: every loss the machine has drawn and metered, the flux
    weakening's and the observer's top speed at the map's."""
    sc = scenario_from_dict(data, source)
    ctl = sc.data["controller"]
    if ctl["mode"] != "speed":
        raise ConfigError("controller.mode", ctl["mode"], "must be \"speed\": each point of the map is the drive "
                          "holding a speed under a load torque with its own loops", source)
    if ctl["angle"] not in SENSED:
        raise ConfigError("controller.angle", ctl["angle"], "must be a sensor's (\"encoder\") for a map: each point "
                          "starts with the rotor at its speed, and the sensorless drive starts only from standstill (it "
                          "has no start on a turning rotor: every point of beyond-full-range stopped, overcurrent or "
                          "polarity undetermined); --set controller.angle=encoder maps the same loops, MTPA and flux "
                          "weakening on the encoder's angle", source)
    m = sc.machine
    top = top_rpm or float(sc.data["observer"]["top_speed_rpm"])
    if not top > 0:
        raise ConfigError("--top-rpm", top, "must be > 0 rpm", source)
    shared = {"losses": {"devices": m.converter is not None, "iron": m.losses is not None, "trace": True},
              "observer": {"top_speed_rpm": max(top, float(sc.data["observer"]["top_speed_rpm"]))}}
    if ctl["flux_weakening"] and ctl["fw_method"] == "feedback" and "fw_top_speed_rpm" not in data.get("controller", {}):
        shared["controller"] = {"fw_top_speed_rpm": top}
    return scenario_from_dict(deep_merge(data, shared), source), shared


def point_overrides(rpm: float, torque: float, duration: float, window: float) -> dict:
    """One point: the rotor at the speed from the start, the reference
    there, the load ramped in, the powers measured over the last window."""
    return {"duration": duration, "initial": {"speed_rpm": rpm}, "references": {"speed_rpm": rpm},
            "load": {"kind": "torque", "torque": [[0.0, 0.0], [T_RAMP, torque], [duration, torque]]},
            "metrics": {"steady": [duration - window, duration]}}


def map_point(task: dict) -> dict:
    """Run one point and measure it over its window (a journal task)."""
    data = deep_merge(task["data"], point_overrides(task["rpm"], task["torque"], task["duration"], task["window"]))
    res = simulate(scenario_from_dict(data, task["source"]))
    if res.stop_reason == "interrupted":   # Ctrl-C: not a finished point (the map stops, the point runs on resume)
        raise KeyboardInterrupt
    out = {"stop_reason": res.stop_reason, "wall_s": res.wall_time}
    p = res.metrics.get("power")
    if res.stop_reason != "done" or p is None:
        return {**out, "held": False}
    m = window_mask(res["t"], task["duration"] - task["window"], task["duration"])
    n_mean = float(rad_s_to_rpm(np.mean(res["w_m"][m])))
    held = abs(n_mean - task["rpm"]) <= HELD * task["rpm"] and p["P_shaft_W"] > 0.0
    # a point not held is no steady state (the kinetic energy it gives up is not a loss): no efficiency
    eta = {k: p[k] if held else None for k in ("eta_machine", "eta_converter", "eta_drive")}
    return {**out, **{k: v for k, v in p.items() if k.startswith("P_")}, **eta, "held": bool(held),
            "speed_mean_rpm": n_mean, "i_d_A": float(np.mean(res["i_d"][m])), "i_q_A": float(np.mean(res["i_q"][m])),
            "i_s_A": float(np.mean(np.hypot(res["i_d"][m], res["i_q"][m]))),
            "i_d_fw_A": float(np.mean(res["i_d_fw"][m])), "u_s_V": float(np.mean(np.hypot(res["u_d"][m], res["u_q"][m])))}


map_point.journal_name = "fullspeed.map.map_point"


@dataclass
class EffMap:
    name: str
    rows: list[dict]
    speeds_rpm: list[float]
    envelope_Nm: list[float]           # the analytic envelope at speeds_rpm
    summary: dict
    paths: list[Path]


def run_length(sc: Scenario, rpm_low: float) -> tuple[float, float]:
    """A point's run and its window, s: the speed loop settles after the
    load's ramp in a dozen of its time constants; the window is 10
    electrical periods at the lowest speed, at least 50 ms."""
    bw = sc.data["controller"]["bw_speed"]
    w_e = sc.machine.pole_pairs * rpm_to_rad_s(rpm_low)
    window = max(0.05, 10 * 2 * math.pi / w_e)
    return T_RAMP + 12.0 / bw + window, window


def efficiency_map(target: str, out: Path, speeds: int = SPEED_FRACTIONS, torques: tuple = TORQUE_FRACTIONS,
                   top_rpm: float | None = None, overrides: dict | None = None, workers: int | None = None,
                   progress: bool = False, start=None) -> EffMap:
    """The map of a scenario or a machine into out: map.csv, map.png, map.json
    (start(sc): called with the checked base scenario, whose warnings its
    caller prints, before the points run)."""
    if not isinstance(speeds, int) or not 2 <= speeds <= 100:
        raise ConfigError("--speeds", speeds, "must be an integer from 2 to 100")
    if not torques or not all(0.0 < f <= 1.0 for f in torques):
        raise ConfigError("--torques", list(torques), "must be fractions of the envelope in (0, 1]")
    if workers is not None and (not isinstance(workers, int) or workers < 1):   # 0 ran on every core, as no --workers
        raise ConfigError("--workers", workers, "must be at least 1")
    data, source = base_data(target, overrides)
    sc, shared = map_scenarios(data, source, top_rpm)
    base = deep_merge(data, shared)
    top = top_rpm or float(sc.data["observer"]["top_speed_rpm"])
    rpm = [top * (k + 1) / speeds for k in range(speeds)]
    ctl = sc.data["controller"]
    env = envelope(sc.machine, rpm, ctl["i_max"], voltage_limit(sc))
    duration, window = run_length(sc, rpm[0])
    tasks = [{"data": base, "source": source, "rpm": n, "torque": f * T, "duration": duration, "window": window}
             for n, T in zip(rpm, env) for f in torques if T > 0.0]
    if start is not None:
        start(sc)
    results = run_tasks(map_point, tasks, out, workers=workers, progress=progress, desc=f"map {sc.name}")
    rows = [{c: None for c in COLUMNS} | {"speed_rpm": t["rpm"], "torque_Nm": t["torque"]} | (r or {"stop_reason": "not run"})
            for t, r in zip(tasks, results)]
    summary = summarise(rows)
    summary.update(scenario=sc.name, machine=sc.machine.name, points=len(rows), duration_s=duration, window_s=window,
                   voltage_limit_V=voltage_limit(sc), i_max_A=ctl["i_max"],
                   module=(sc.machine.converter or {}).get("module"))
    summary["iron_source"], summary["iron_reason"] = iron_loss_note(sc.machine.losses)
    paths = [write_table(rows, out / "map.csv"),
             write_json(out / "map.json", {"summary": summary, "speeds_rpm": rpm, "envelope_Nm": list(env)}, indent=2)]
    fig = write_with(out / "map.png", lambda tmp: plot_map(rows, rpm, env, summary, tmp))
    if fig is not None:
        paths.append(fig)
    return EffMap(sc.name, rows, rpm, list(env), summary, paths)


def iron_loss_note(losses: dict | None) -> tuple[str | None, str | None]:
    """The machine's [losses] source as the map states it, and the file's
    reason for the iron loss (reasons.P_fe_ref, its size; else the table's
    first), each one line. The source's "(reasons below)" points into the
    machine file, which the map's reader does not have before them: it is
    dropped, and the reason given beside the source instead."""
    if not losses:
        return None, None
    reasons = losses.get("reasons") or {}
    reason = reasons.get("P_fe_ref") or next(iter(reasons.values()), None)
    source = losses.get("source")
    if source:
        source = re.sub(r"\s*\((?:see )?(?:the )?reasons(?: below)?\)", "", source, flags=re.I)
    return (" ".join(source.split()) if source else None), (" ".join(reason.split()) if reason else None)


def stops(rows: list[dict]) -> dict[str, int]:
    """The points whose run stopped (a protection, a lost or undetermined
    angle), by stop reason: the drive failed there, unlike a point whose
    speed sags below its reference at a torque the drive does not reach."""
    return dict(Counter(r["stop_reason"] for r in rows if r.get("stop_reason") not in (None, "done", "not run")))


def summarise(rows: list[dict]) -> dict:
    """Each efficiency's peak and where it sits, over the held points."""
    held = [r for r in rows if r.get("held")]
    out = {"held": len(held), "not_held": len(rows) - len(held), "stops": stops(rows)}
    for key in ("eta_machine", "eta_converter", "eta_drive"):
        ok = [r for r in held if r.get(key) is not None]
        if ok:
            best = max(ok, key=lambda r: r[key])
            out[f"{key}_peak"] = {"eta": best[key], "speed_rpm": best["speed_rpm"], "torque_Nm": best["torque_Nm"]}
    return out


def write_table(rows: list[dict], path: Path) -> Path:
    def write(tmp: Path):
        with open(tmp, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=COLUMNS, extrasaction="ignore")
            w.writeheader()
            w.writerows(rows)
    return write_with(path, write)


def grid_triangles(rows: list[dict], ok: np.ndarray) -> np.ndarray | None:
    """The map's points are a grid, speeds by torque fractions (as listed):
    its cells' triangles whose three corners are all ok, so that a contour
    does not reach across points not held."""
    speeds = sorted({r["speed_rpm"] for r in rows})
    n_f = len(rows) // len(speeds)
    if n_f < 2 or len(speeds) < 2 or n_f * len(speeds) != len(rows):
        return None
    tris = []
    for k in range(len(speeds) - 1):
        for j in range(n_f - 1):
            a, b, c, d = k * n_f + j, k * n_f + j + 1, (k + 1) * n_f + j, (k + 1) * n_f + j + 1
            tris += [t for t in ((a, b, c), (b, d, c)) if ok[list(t)].all()]
    return np.array(tris) if tris else None


def plot_map(rows: list[dict], rpm: list[float], env, summary: dict, path: Path):
    """Contours of the machine's, the converter's and the drive's efficiency
    over the held points, with the analytic envelope and the points not
    held; and the losses by kind at the largest torque held at each speed."""
    held = [r for r in rows if r.get("held")]
    fig, ax = plt.subplots(2, 2, figsize=(12, 9))
    n_env = np.concatenate([[0.0], rpm])
    T_env = np.concatenate([[env[0]], env])
    x = np.array([r["speed_rpm"] for r in rows])
    y = np.array([r["torque_Nm"] for r in rows])
    for a, (key, title) in zip(ax.flat, (("eta_machine", "machine"), ("eta_converter", "converter"),
                                         ("eta_drive", "drive"))):
        ok = np.array([bool(r.get("held")) and r.get(key) is not None for r in rows])
        z = 100.0 * np.array([r[key] if o else 0.0 for r, o in zip(rows, ok)])
        tri = grid_triangles(rows, ok)
        if tri is not None and ok.sum() >= 3:
            levels = np.unique(np.clip(np.percentile(z[ok], [5, 15, 30, 45, 60, 75, 85, 92, 97, 100]), None, 100.0))
            if levels.size >= 2:
                cs = a.tricontourf(x, y, tri, z, levels=levels, cmap="viridis")
                a.tricontour(x, y, tri, z, levels=levels, colors="k", linewidths=0.4)
                fig.colorbar(cs, ax=a, label="efficiency (%)")
        a.plot(x[ok], y[ok], "k.", ms=3)
        miss = [r for r in rows if not r.get("held")]
        if miss:
            a.plot([r["speed_rpm"] for r in miss], [r["torque_Nm"] for r in miss], "rx", ms=5, label="not held")
        a.plot(n_env, T_env, "r-", lw=1.2, label="envelope (T_e at i_max and the linear voltage, as design)")
        peak = summary.get(f"{key}_peak")
        if peak:
            a.plot(peak["speed_rpm"], peak["torque_Nm"], "w*", ms=12, mec="k",
                   label=f"peak {100 * peak['eta']:.1f} % at {peak['speed_rpm']:.0f} rpm, {peak['torque_Nm']:.1f} N m")
        a.set_title(f"{title} efficiency")
        a.set_xlabel("speed (rpm)")
        a.set_ylabel("torque (N m)")
        a.legend(fontsize=7, loc="upper right")
        a.grid(True, alpha=0.3)
    b = ax[1, 1]
    edge = []
    for n in rpm:
        at = [r for r in held if r["speed_rpm"] == n]
        if at:
            edge.append(max(at, key=lambda r: r["torque_Nm"]))
    bottom = np.zeros(len(edge))
    for k, (col, label) in enumerate(LOSSES.items()):
        v = np.array([r.get(col) or 0.0 for r in edge])
        if np.any(v > 0):
            b.bar([r["speed_rpm"] for r in edge], v, width=0.6 * (rpm[1] - rpm[0]) if len(rpm) > 1 else 100.0,
                  bottom=bottom, label=label, color=f"C{k}")
            bottom += v
    b.set_title("losses by kind at the largest torque held")
    b.set_xlabel("speed (rpm)")
    b.set_ylabel("loss (W)")
    if bottom.any():   # no point held, or no loss metered: no bars to name
        b.legend(fontsize=7)
    b.grid(True, alpha=0.3)
    fig.suptitle(f"{summary.get('scenario', '')}: efficiency map ({summary.get('held', 0)} points held of "
                 f"{summary.get('held', 0) + summary.get('not_held', 0)})")
    return save_figure(fig, path, 100, f"{summary.get('scenario', '')}: efficiency map")
