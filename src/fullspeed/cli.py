"""Command line: fullspeed run | list | sweep | map | reproduce | calibrate | export.

Exit status: 0 done; 1 a run that stopped (a protection, lost lock, an
interrupt during the simulation) or a sweep with points not run; 2 bad input
(ConfigError, found before any work starts) or a configuration the C core
refuses; 3 an internal error (a bug: please report it); 130 Ctrl-C.

Every output is written to a temporary file in its folder and renamed into
place (model/files.py); a folder named after an input's name stays inside
out/ or the name is refused.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import re
import shlex
import sys
import time
import tomllib
import warnings
from importlib import resources
from pathlib import Path

import numpy as np

from .design.checks import inertia_implausible
from .design.start import polarity_blind
from .design.report import design_report, envelope_report, scenario_envelope
from .design.scenario import load_scenario, scenario_from_dict
from .model.errors import ConfigError, EngineError, SimulationError, one_line
from .model.files import (MAX_TOML_BYTES, claim, file_name, json_safe, out_file, out_folder, out_path, owned_folder,
                          package_names, path_kind, safe_name, write_atomic, write_json, write_npz, write_with)
from .model.machines import catalog_data, catalog_names
from .model.reference import machine_template, reference_text, section_names
from .model.scenario import check_target, scenario_data
from .model.schema import deep_merge, parse_toml, read_toml

# A command imports the layers above design when it runs (the simulator, the
# workflows, the reproduction): `fullspeed list` or `schema` does not load
# matplotlib and the papers (0.25 s instead of 0.8). Only the top may import
# inside a function: nothing imports it, so no circle hides there
# (tests/test_layers.py).

OUT = Path("out")


def _set_overrides(pairs: list[str] | None) -> dict:
    """--set key=value, repeatable: dotted scenario keys, TOML values
    (`controller.bw_speed=50`, `references.speed_rpm=[[0, 0], [0.1, 1000]]`);
    a value that is not TOML is taken as a string (`controller.angle=blend`)."""


    out: dict = {}
    for pair in pairs or []:
        key, eq, text = pair.partition("=")
        parts = key.strip().split(".")
        if not eq or not all(parts):
            raise ConfigError("--set", pair, "must be key=value with a dotted scenario key, e.g. controller.bw_speed=50")
        if len(text.encode("utf-8", "surrogatepass")) > MAX_TOML_BYTES:
            raise ConfigError(f"--set {key}", f"{len(text)} characters", f"at most {MAX_TOML_BYTES} bytes, as a file")
        try:
            value = tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:
            if any(c in text for c in "[]{}\"'=") or not text.strip():
                raise ConfigError(f"--set {key}", text, "is not a TOML value (a number, true/false, \"text\", [list] or {table})") from None
            value = text.strip()
        except (ValueError, RecursionError):   # beyond the parser's limits (digits, depth): a file's one line
            value = parse_toml(f"v = {text}", f"--set {key}", None)
        for k in reversed(parts):
            value = {k: value}
        out = deep_merge(out, value)
    return out


# `fullspeed run`'s exit status (README, "Exit status"): 0 only for a run that
# completed with the drive in control; 2 is bad input, 3 an internal error.
EXIT_FAILED = 1   # a protection stop, a refusal, a loss of lock (flagged, or seen by the simulation's truth)


def print_warnings(sc) -> None:
    """A designed scenario's warnings (its machine data's, its references'
    against the envelope), one line each on stderr, before a command works."""
    for w in sc.warnings:
        print(f"fullspeed: warning: {one_line(w)}", file=sys.stderr)


def run_verdict(res) -> list[str]:
    """Why a run failed, one line each; empty for a run that completed with
    the drive in control."""
    m, out = res.metrics, []
    t_stop = res.stop_time if res.stop_time is not None else res.sim_time
    if res.stop_reason == "polarity_undetermined" and (res.polarity or {}).get("method") == "motion":
        p = res.polarity
        why = ("the rotor turned on its own before or after the doublet (a load moves it)" if p["moved"] else
               f"the estimate's spread asks a threshold of {p['threshold_deg']:.3g} el.deg, beyond the motion allowed"
               if p["attempts"] == 0 else
               f"the rotor turned {abs(p['turn_deg']):.3g} el.deg of the {p['threshold_deg']:.3g} needed at "
               f"{p['i_push']:.3g} A, the largest push (held: stiction, a brake)")
        j = inertia_implausible(res.scenario.machine)
        if j:   # the doublet's push and time are sized on J (design.start.design_motion)
            why += f"; its doublet is sized on the machine's {j}"
        out.append(f"stopped at t = {t_stop:.4f} s: polarity undetermined by the motion test ({why}): the drive refused "
                   "to start sensorless")
    elif res.stop_reason == "start_failed":
        obs = res.scenario.data["observer"]
        out.append(f"stopped at t = {t_stop:.4f} s: the I/f start waited observer.start_timeout = {obs['start_timeout']:.3g} s at "
                   f"the hand-over speed ({obs['start_handover_rpm']:.4g} rpm) without the back-EMF observer agreeing with "
                   "the frame: the rotor is not following it (pulled out by the load or the acceleration)")
    elif res.stop_reason == "polarity_undetermined":
        p = res.polarity or {}
        why = "the pulses spun the rotor" if p.get("moved") else \
            f"margin {p.get('margin', 0):.2f} < 1 at {p.get('i_pulse', 0):.3g} A (D = {100 * p.get('d', 0):.2f} %)"
        mach = getattr(res.scenario, "machine", None)
        blind = polarity_blind(mach, p["i_pulse"]) if mach is not None and p.get("i_pulse") else None
        if blind:   # the cause beneath: larger or slower pulses would not help (the load-time warning said so)
            why += f"; {mach.name}'s {blind}, so the pulses have no saturation asymmetry to decide on"
        out.append(f"stopped at t = {t_stop:.4f} s: polarity undetermined ({why}): the drive refused to start sensorless")
    elif res.stop_reason == "interrupted":
        out.append(f"interrupted at t = {t_stop:.6f} s (traces up to there were written)")
    elif res.stop_reason in ("overspeed", "loss_of_lock"):
        out.append(f"stopped at t = {t_stop:.4f} s with the PWM off: {_protection_stop(res)} (traces up to the stop were written)")
    elif res.stop_reason != "done":
        out.append(f"stopped at t = {t_stop:.6f} s: {res.stop_reason} (traces up to the stop were written)")
    latched = np.flatnonzero(res["lock_lost"] > 0) if res["t"].size else []
    if len(latched):
        went_on = res.stop_reason == "done" and res.scenario.data["controller"]["lock"] == "detect"
        out.append(f"loss of lock flagged by the drive's monitor at t = {res['t'][latched[0]]:.4f} s"
                   + ("; the drive went on (controller.lock = \"detect\")" if went_on else ""))
    if m.get("true_loss_unanswered_at") is not None:
        flagged = len(latched) > 0 or res.stop_reason != "done"
        out.append(f"the estimate was 90 el.deg off the rotor for 20 ms net by t = {m['true_loss_unanswered_at']:.4f} s (the simulation's truth)"
                   + ("" if flagged else ": the drive did not flag it (a silent failure)"))
    start = m.get("start_unfinished")
    if start:
        out.append(f"the run ended in the start stage {start['stage']} (since t = {start['since']:.4f} s): the drive "
                   + ("never closed its loops on the estimate" if start["never_left"] else "had not closed its loops on the estimate again"))
    for r in m.get("steps", []):
        u = r.get("unheld")
        if u:
            out.append(f"the load's change at t = {r['t']:.4g} s ({r['from']:.4g} -> {r['to']:.4g} N m): the speed was "
                       f"{u['error_rpm']:+.1f} rpm off its reference when the next change came at {u['until']:.4g} s, "
                       f"{1e3 * (u['until'] - u['since']):.4g} ms after it, past the loop's settling in "
                       f"{1e3 * u['settle']:.4g} ms: beyond the +-{u['band_rpm']:.1f} rpm a settled speed loop keeps "
                       "(2 % of the reference, at least 0.5 % of rated speed): the drive did not hold the speed under that load")
    end, steady = m.get("speed_end"), m.get("speed_steady")
    if steady and not (end and (end["far"] or end.get("unheld"))):
        w = steady["window"]
        out.append(f"the speed's mean over the steady window {w[0]:.4g}..{w[1]:.4g} s is {steady['speed_rpm']:.1f} rpm "
                   f"against its reference {steady['ref_rpm']:.1f} rpm, {steady['speed_rpm'] - steady['ref_rpm']:+.1f} rpm "
                   f"off: beyond the +-{steady['band_rpm']:.1f} rpm a settled speed loop keeps (2 % of the reference, at "
                   "least 0.5 % of rated speed): the drive did not hold the speed")
    if end and end["far"]:
        w = end["window"]
        out.append(f"the speed ends at {end['speed_rpm']:.1f} rpm against its reference {end['ref_rpm']:.1f} rpm (means over "
                   f"{w[0]:.4g}..{w[1]:.4g} s), {abs(end['speed_rpm'] - end['ref_rpm']):.1f} rpm off: outside the "
                   f"+-{end['band_rpm']:.1f} rpm of a speed loop in control (10 % of the reference, at least 5 % of rated speed)")
    elif end and end.get("unheld"):
        u = end["unheld"]
        how = (f"and moving away ({u['error_before_rpm']:+.1f} rpm a loop time constant, {1e3 * u['tau']:.3g} ms, before)"
               if u["how"] == "moving away" else
               f"{1e3 * (res['t'][-1] - u['since']):.4g} ms after the last change of its reference or load, past the "
               f"loop's settling in {1e3 * u['settle']:.4g} ms")
        out.append(f"the speed ends at {end['speed_rpm']:.1f} rpm against its reference {end['ref_rpm']:.1f} rpm, "
                   f"{u['error_rpm']:+.1f} rpm off {how}: beyond the +-{u['band_rpm']:.1f} rpm a settled speed loop keeps "
                   f"(2 % of the reference, at least 0.5 % of rated speed): the drive is not holding the speed")
    return out


def _protection_stop(res) -> str:
    """Why the drive halted (fs_drive_protect.h), for a stop reason
    overspeed or loss_of_lock."""
    ctl, m = res.scenario.data["controller"], res.metrics
    rotor = abs(float(res["w_m"][-1])) * 60.0 / (2.0 * math.pi) if res["t"].size else float("nan")
    if res.stop_reason == "overspeed":
        w = abs(float(res["w_m_hat"][-1])) * 60.0 / (2.0 * math.pi)
        return (f"overspeed, the drive's speed {w:.0f} rpm past its limit {ctl['overspeed_rpm']:.0f} rpm "
                f"(controller.overspeed_rpm; the rotor at {rotor:.0f} rpm)")
    if ctl["lock"] == "stop":
        return "loss of lock (controller.lock = \"stop\")"
    events = m.get("lock_events", [])
    if events and events[-1]["action"] == "stopped" and events[-1]["halted"]:
        h = m.get("halt") or {}
        low = {"blend": ("blending.lower_rpm", res.scenario.data["blending"].get("lower_rpm")),
               "smo": ("observer.start_handover_rpm", res.scenario.data["observer"].get("start_handover_rpm"))
               if res.scenario.data["observer"]["start"] == "if" else (None, None)}.get(ctl["angle"], (None, None))
        return (f"loss of lock not re-acquired: at the end of the zero-current wait the back-EMF measured "
                f"{h.get('emf_V', float('nan')):.3g} V, {abs(h.get('emf_rpm', float('nan'))):.0f} rpm by psi_f (the rotor's "
                f"{events[-1]['rotor_rpm']:.0f} rpm), where the back-EMF observer had not caught the rotor; "
                + (f"below {low[1]:.0f} rpm ({low[0]}) the start sequence would have found it" if low[0]
                   else "the drive has no start sequence to find it again (the observer started on the encoder)"))
    return (f"loss of lock again after {len(events)} re-acquisition{'s' if len(events) != 1 else ''} "
            f"(controller.lock_retries = {ctl['lock_retries']})")


def _cmd_run(args) -> int:
    from .sim import simulate
    from .sim.metrics import summary_lines
    from .sim.plots import plot_run


    overrides = _set_overrides(args.set)
    if args.inverter:
        overrides.setdefault("converter", {})["inverter"] = args.inverter
    sc = load_scenario(args.scenario, overrides or None)
    out = out_folder(args.out) if args.out else out_path(OUT, sc.name, "name", sc.source)   # before the run, not after
    print_warnings(sc)
    with claim(out):   # one run a folder: two would mix their files
        res = simulate(sc, progress=not args.quiet)
        # metrics.json last: its presence marks the folder complete (an older one goes first)
        (out / "metrics.json").unlink(missing_ok=True)
        write_npz(out / "traces.npz", res.traces)
        if args.mat:
            write_with(out / "traces.mat", res.to_mat)
        write_with(out / "run.png", lambda tmp: plot_run(res, tmp))
        write_json(out / "metrics.json", json_safe(res.metrics), indent=2)
    print(f"{res.scenario.name}: {res.sim_time:.3f} s simulated in {res.wall_time:.3f} s wall "
          f"= {res.speed_ratio:.1f} simulated s per wall s ({res.scenario.data['converter']['inverter']} inverter)")
    print("\n".join(summary_lines(res.metrics)))
    if res.polarity is not None and res.polarity["stage"] == "done" and res.polarity["method"] == "motion":
        print(f"polarity: decided by the motion test, the estimate turned {res.polarity['turn_deg']:+.2f} el.deg "
              f"(threshold {res.polarity['threshold_deg']:.2f}) at {res.polarity['i_push']:.3g} A"
              + (" (the estimate turned by pi)" if res.polarity["flip"] else ""))
    elif res.polarity is not None and res.polarity["stage"] == "done":
        print(f"polarity: decided with margin {res.polarity['margin']:.2f} at {res.polarity['i_pulse']:.3g} A"
              + (" (the estimate turned by pi)" if res.polarity["flip"] else ""))
    if res.metrics.get("ideal_hardware"):
        print("ideal hardware: " + ", ".join(res.metrics["ideal_hardware"]))
    print(f"wrote {out}/metrics.json, traces.npz{', traces.mat' if args.mat else ''}, run.png")
    failed = run_verdict(res)
    for line in failed:
        print(f"fullspeed: run failed: {line}", file=sys.stderr)
    return EXIT_FAILED if failed else 0


def _cmd_design(args) -> int:

    target = args.target
    check_target(target)
    overrides = _set_overrides(args.set)
    if target.endswith(".toml") or target in catalog_names():
        data = read_toml(target, "machine") if target.endswith(".toml") else None
        if data is not None and "machine" in data:   # a scenario file
            sc = load_scenario(target, overrides)
        else:
            # the sensorless drive on the machine's own injection: a square wave's (yu2022's, its f_h a quarter of
            # the sampling rate, which a rotating carrier cannot take), else the blend
            table = data if data is not None else catalog_data(target)
            angle = "swvi" if (table.get("injection") or {}).get("kind") == "square" else "blend"
            sc = scenario_from_dict(deep_merge({"name": f"design-{Path(target).stem}", "duration": 1.0,
                                                "machine": str(Path(target).resolve()) if data is not None else target,
                                                "controller": {"mode": "speed", "angle": angle, "flux_weakening": True}},
                                               overrides), target)
    else:
        sc = load_scenario(target, overrides)
    out = out_folder(args.out) if args.out else out_path(OUT, sc.name, "name", sc.source)
    print_warnings(sc)
    print(design_report(sc))
    from .design.figure import plot_envelope
    env, how = scenario_envelope(sc)
    print(envelope_report(env, how))
    write_with(out / "envelope.png", lambda tmp: plot_envelope(env, tmp, how))
    print(f"wrote {out}/envelope.png")
    return 0


def _cmd_list(args) -> int:
    for folder in ("machines", "scenarios", "sweeps"):
        print(f"{folder}:")
        for name in package_names(folder):
            d = tomllib.loads((resources.files("fullspeed") / folder / f"{name}.toml").read_text())
            print(f"  {name:28s} {d.get('description', '')}")
    return 0


def _cmd_sweep(args) -> int:
    from .workflows.journal import JOURNAL, default_workers, read_journal
    from .workflows.sweep import load_sweep_file, point_result_ok, run_sweep



    if args.dask:
        _check_dask_address(args.dask)
    if not args.dask_timeout > 0:
        raise ConfigError("--dask-timeout", args.dask_timeout, "must be > 0 s")
    sw = load_sweep_file(args.file)
    if args.set:
        sw = _with_overrides(sw, _set_overrides(args.set))
    if args.workers is not None and args.workers < 1:
        raise ConfigError("--workers", args.workers, "must be at least 1")
    out = out_folder(args.out) if args.out else out_path(OUT / "sweeps", sw.name, "name", args.file)
    n = len(sw.points())
    where = f"on Dask at {args.dask}" if args.dask else f"in {args.workers or default_workers()} worker process(es)"
    t0 = time.perf_counter()
    resume = f"resume with: fullspeed sweep {args.file} --out {out}"
    try:
        with claim(out):   # the banner once the folder is this sweep's: a refused one says only why
            print(f"sweep {sw.name}: {n} points {where} -> {out}", file=sys.stderr)
            path, rows = run_sweep(sw, out, workers=args.workers, dask=args.dask, progress=not args.quiet,
                                   dask_timeout=args.dask_timeout)
    except (KeyboardInterrupt, EngineError):
        kept = len(read_journal(out / JOURNAL, n, point_result_ok))
        print(f"fullspeed: sweep stopped: {kept} of {n} points finished and kept in {out / JOURNAL}; {resume}",
              file=sys.stderr)
        raise
    wall = time.perf_counter() - t0
    failed = [r for r in rows if r["stop_reason"] != "done"]
    print(f"{len(rows)} of {n} points in {wall:.1f} s wall; {len(failed)} did not finish normally; wrote {path}")
    for r in failed[:10]:
        print(f"  point {r['point']}: {r['stop_reason']}" + (f" ({r['error']})" if r.get("error") else "")
              + (f" at t = {r['stop_time']:.4f} s" if r.get("stop_time") is not None else ""))
    if len(rows) != n:
        print(f"fullspeed: {n - len(rows)} points not run; {resume}", file=sys.stderr)
    if rows and all(r["stop_reason"] == "error" for r in rows):   # a table of refusals: no point was simulated
        print(f"fullspeed: every point ended in an error, none was simulated (the errors are in {path})", file=sys.stderr)
        return 1
    return 0 if len(rows) == n else 1


def _check_dask_address(address: str) -> None:
    """[scheme://]host:port, before anything runs (Dask's own error is a traceback)."""
    m = re.fullmatch(r"(?:[a-z][a-z0-9+.-]*://)?(\[[0-9A-Fa-f:.]+\]|[^\s:/\[\]]+):(\d{1,5})/?", address)
    if m is None or not 0 < int(m.group(2)) < 65536:
        raise ConfigError("--dask", address, "must be a scheduler address with a port: tcp://HOST:PORT")


def _with_overrides(sw, extra: dict):
    """The sweep with --set merged into its [overrides] (checked as the file's are)."""
    from .workflows.sweep import check_points



    sw = dataclasses.replace(sw, overrides=deep_merge(sw.overrides, extra))
    check_points(sw, sw.base_source)
    return sw


def _cmd_reproduce(args) -> int:
    from .reproduce.report import reproduce


    out = out_folder(args.out)
    t0 = time.perf_counter()
    with claim(out):
        rows = reproduce(args.paper, out, progress=not args.quiet)
    n_pass = sum(r["pass"] for r in rows)
    n_meas = sum(r["value"] is not None for r in rows)
    print(f"{len(rows)} claims, {n_meas} measured, {n_pass} passing in {time.perf_counter() - t0:.0f} s; "
          f"wrote {out}/claims.json and {out}/report.md")
    return 0


def _cmd_map(args) -> int:
    from .workflows.effmap import TORQUE_FRACTIONS, efficiency_map
    from .workflows.journal import JOURNAL


    overrides = _set_overrides(args.set)
    target = args.target
    name = Path(target).stem if target.endswith(".toml") else target
    out = out_folder(args.out) if args.out else out_path(OUT / "maps", name, "target", None)
    torques = tuple(args.torques) if args.torques else TORQUE_FRACTIONS
    def start(sc) -> None:   # the input checked: its warnings (the machine's data among them) and the banner
        print_warnings(sc)
        print(f"map {target} -> {out}", file=sys.stderr)

    try:   # the banner once the input is checked: a refused map says only why
        with claim(out):   # one map a folder, as a sweep's: two would write one journal
            em = efficiency_map(target, out, speeds=args.speeds, torques=torques, top_rpm=args.top_rpm,
                                overrides=overrides or None, workers=args.workers, progress=not args.quiet,
                                start=start)
    except KeyboardInterrupt:
        print(f"fullspeed: map stopped: what finished is kept in {out / JOURNAL}; run the same command to resume",
              file=sys.stderr)
        raise
    s = em.summary
    stopped = ", ".join(f"{n} {reason}" for reason, n in sorted(s["stops"].items(), key=lambda kv: -kv[1]))
    print(f"{em.name}: {s['points']} points, {s['held']} held"
          + (f" ({sum(s['stops'].values())} stopped: {stopped})" if stopped else "")
          + f"; module: {s.get('module') or 'ideal switches'}; iron loss: {s.get('iron_source') or 'none'}")
    if s.get("iron_reason"):   # the machine file's why, where its source says "(reasons below)"
        print(f"iron loss, the machine file's reason: {one_line(s['iron_reason'])}")
    for key, label in (("eta_machine", "machine"), ("eta_converter", "converter"), ("eta_drive", "drive")):
        p = s.get(f"{key}_peak")
        if p and key == "eta_converter" and not s.get("module"):   # no device data: the converter meters no loss
            print("converter: ideal switches, no loss metered (the machine file's [converter] gives its devices)")
        elif p:
            print(f"peak {label} efficiency {100 * p['eta']:.2f} % at {p['speed_rpm']:.0f} rpm, {p['torque_Nm']:.1f} N m")
    print("wrote " + ", ".join(str(p) for p in em.paths))
    not_run = [r for r in em.rows if r.get("stop_reason") == "not run"]
    if not_run:
        print(f"fullspeed: {len(not_run)} points not run; run the same command again to run them", file=sys.stderr)
    if s["stops"]:   # a point's drive failed: no map of that drive's efficiency there (a sag at the envelope's edge is no failure)
        print(f"fullspeed: map failed: {sum(s['stops'].values())} of {s['points']} points stopped ({stopped}); "
              f"map.csv gives each point's stop_reason, `fullspeed run` with the point's speed and load shows why",
              file=sys.stderr)
    return 1 if not_run or s["stops"] else 0


def _cmd_calibrate(args) -> int:
    import numpy as np

    from .workflows.calibrate import write_table, xsat_table



    if args.out:   # a file (a device or a FIFO there is refused, not replaced)
        target = out_file(args.out)
    else:   # the machine's name makes the file's: checked before the calibration runs
        sc = load_scenario(args.scenario)
        target = out_file(out_path(OUT, sc.machine.name, "machine.name", sc.source, suffix="-xsat.toml"), "machine.name")
    table, sc = xsat_table(args.scenario, i_q_max=args.i_q_max, points=args.points, speed_rpm=args.speed_rpm)
    path = write_table(table, target)
    print(f"{sc.machine.name} at {table['speed_rpm']:g} rpm held by the load machine:")
    for i, dlt, s, r in zip(table["i_q"], table["delta_deg"], table["spread_deg"], table["residual_deg"]):
        print(f"  i_q = {i:7.2f} A   delta = {dlt:+8.3f} el.deg   scatter {s:5.2f}   compensated {r:+6.2f}")
    res = np.abs(table["residual_deg"])
    print(f"table {min(table['delta_deg']):+.2f}..{max(table['delta_deg']):+.2f} el.deg, scatter at most "
          f"{max(table['spread_deg']):.2f}; with it the estimate's mean error is at most {res.max():.2f} el.deg "
          f"(mean {np.mean(table['residual_deg']):+.3f})")
    print(f"wrote {path}; use it with [injection] xcomp = \"{path}\"")
    return 0


def _cmd_identify(args) -> int:
    from .workflows.identify import OUTPUTS, identify, print_identification, write_identification

    # the sequence runs its own course: a scenario's duration and mode are its run's, defaulted where a file
    # names only its machine for identification (the new-user trial was refused for both, which identify ignores)
    data, source = scenario_data(args.scenario)
    data.setdefault("duration", 1.0)
    if isinstance(data.setdefault("controller", {}), dict):
        data["controller"].setdefault("mode", "off")
    sc = scenario_from_dict(data, source)
    # the folder is replaced as a whole (a failed identification leaves no earlier machine.toml): checked first
    out = out_folder(args.out) if args.out else OUT / f"identify-{safe_name(sc.machine.name, 'machine.name', sc.source)}"
    owned_folder(out, OUTPUTS)
    with claim(out):
        res = identify(sc, speed_frac=args.speed_frac, t_ramp=args.t_ramp)
        paths = write_identification(res, sc, out)
    print_identification(res)
    print("wrote " + ", ".join(str(p) for p in paths))
    for line in res.failures():
        print(f"fullspeed: identification failed: {line}", file=sys.stderr)
    refused = res.details.get("machine_file", {}).get("refused")
    if refused:   # identified, but nothing to run on: no success without the machine file
        print(f"fullspeed: identification failed: machine.toml not written, the loader refuses it: {refused}", file=sys.stderr)
    return 0 if res.ok and not refused else 1


def _cmd_export(args) -> int:
    from .workflows.export import export

    if args.fmu or args.fmu_system:
        return _cmd_export_fmu(args)
    out = out_folder(args.out)
    with claim(out):
        paths = export(args.scenario, out, args.name, _set_overrides(args.set), force=args.force)
    print(f"wrote {' and '.join(str(p) for p in paths)}: the fs_drive_config of {args.scenario} "
          f"(compile the .c with csrc/control; fs_drive_init(&drive, &{args.name}))")
    return 0


def _cmd_export_fmu(args) -> int:
    from .workflows.fmu import export_fmu

    if args.name != "fs_config":
        raise ConfigError("--name", args.name, "names the C configuration of the plain export; an FMU is named after "
                          "its scenario (<scenario name>-drive.fmu, <scenario name>-system.fmu)")
    kinds = (["drive"] if args.fmu else []) + (["system"] if args.fmu_system else [])
    out = out_folder(args.out)
    with claim(out):
        paths = export_fmu(args.scenario, out, kinds, args.fmi, _set_overrides(args.set))
    for p in paths:
        print(f"wrote {p} (FMI {args.fmi}.0 co-simulation, {p.stat().st_size:,} B)")
    return 0


def _cmd_schema(args) -> int:

    if args.section is not None and not reference_text(args.section):
        raise ConfigError("section", args.section, "unknown; the sections are " + ", ".join(section_names()))
    print(reference_text(args.section), end="")
    return 0


def _cmd_new_machine(args) -> int:

    # the machine's name names its outputs (identify-<name>/, <name>-xsat.toml): refused as run's and sweep's
    # names are, not rewritten into a file name beside it (mach/motor wrote ./mach_motor.toml); the folder is --out's
    where = "--out FILE writes the file elsewhere"
    if Path(args.name).name and Path(args.name).name != args.name:   # a path: its last part the name, the path --out's
        where += f": fullspeed new-machine {shlex.quote(Path(args.name).name)} --out {shlex.quote(args.name + '.toml')}"
    safe_name(args.name, "name", what="a machine", how="a machine's name is one file name: no path separator or "
              f"control character, not '.' or '..'; {where}")
    # a file (not a device, a FIFO or a folder), in a folder that takes one; the name's file name bounded
    path = out_file(args.out) if args.out else out_file(out_path(".", file_name(args.name), "name", suffix=".toml"), "name")
    if path_kind(path) is not None and not args.force:   # named as the user gave it: --out, or the name's file
        field, value = ("--out", args.out) if args.out else ("name", args.name)
        raise ConfigError(field, value, f"{path} exists; --force overwrites it")
    write_atomic(path, machine_template(args.name))
    print(f"wrote {path}: fill in every \"?\"; `fullspeed schema machine` lists the optional fields")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fullspeed", description="Wide-speed-range sensorless PMSM drives")
    ap.add_argument("--debug", action="store_true", help="show tracebacks")
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run a scenario (catalog name or TOML file)",
                       description="Run a scenario. Exit status: 0 the run completed with the drive in control; "
                                   "1 it failed (a protection stop, polarity undetermined, a loss of lock the drive "
                                   "flagged or the simulation's truth saw, an interrupt); 2 bad input; 3 internal error.")
    r.add_argument("scenario")
    r.add_argument("--out", help="output folder (default out/<name>)")
    r.add_argument("--inverter", choices=["averaged", "switching"], help="override the inverter model")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    r.add_argument("--mat", action="store_true", help="also write traces.mat (MATLAB: traces, metrics and units)")
    r.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a scenario field, repeatable: dotted key, TOML value (controller.bw_speed=50)")
    r.set_defaults(func=_cmd_run)
    dz = sub.add_parser("design", help="print every designed setting of a machine or scenario, with its reason, and the machine's envelope")
    dz.add_argument("target", help="a catalog machine, a machine TOML (datasheet fields), or a scenario (name or TOML)")
    dz.add_argument("--out", help="output folder for envelope.png (default out/<name>)")
    dz.add_argument("--set", action="append", metavar="KEY=VALUE",
                    help="as run's: a scenario field, repeatable (controller.angle=hfi, injection.tracking=paper)")
    dz.set_defaults(func=_cmd_design)
    ls = sub.add_parser("list", help="list catalog machines and scenarios")
    ls.set_defaults(func=_cmd_list)
    sw = sub.add_parser("sweep", help="run a sweep (catalog name or TOML file): maps and Monte Carlo, resumable")
    sw.add_argument("file")
    sw.add_argument("--workers", type=int, help="local worker processes (default: the cores)")
    sw.add_argument("--dask", metavar="ADDRESS", help="run on the Dask scheduler at ADDRESS (tcp://HOST:PORT) instead")
    sw.add_argument("--dask-timeout", type=float, default=60.0, metavar="S",
                    help="stop with an error when the Dask cluster has had no worker for S seconds (default 60)")
    sw.add_argument("--out", help="output folder (default out/sweeps/<name>); run again to resume")
    sw.add_argument("--quiet", action="store_true", help="no progress bar")
    sw.add_argument("--set", action="append", metavar="KEY=VALUE",
                    help="add to the sweep's [overrides], repeatable: dotted scenario key, TOML value")
    sw.set_defaults(func=_cmd_sweep)
    about = "measure the claims of docs/CLAIMS.md (generated from src/fullspeed/reproduce/claims.py)"
    rp = sub.add_parser("reproduce", help=about, description=about)
    rp.add_argument("--paper", choices=["yang2022", "zou2021", "yu2022", "beyond"])
    rp.add_argument("--out", default="out/reproduce")
    rp.add_argument("--quiet", action="store_true")
    rp.set_defaults(func=_cmd_reproduce)
    mp = sub.add_parser("map", help="the efficiency map (machine, converter, drive) over the torque-speed envelope, losses by kind",
                        description="Each point: the drive in speed mode holds a speed while a load torque ramps in, "
                                    "every loss the machine file has acting and metered (its [converter] module, its "
                                    "[losses] iron loss, friction). Writes map.csv, map.json and map.png; resumable.")
    mp.add_argument("target", help="a scenario (speed mode) or a machine (catalog name or machine file: encoder, flux weakening)")
    mp.add_argument("--speeds", type=int, default=8, help="speeds, evenly up to the top speed (default 8)")
    mp.add_argument("--torques", type=float, nargs="+", metavar="F",
                    help="torques as fractions of the envelope at each speed (default 0.1 0.25 0.4 0.55 0.7 0.85 0.97)")
    mp.add_argument("--top-rpm", type=float, help="the map's top speed (default the scenario's observer top speed)")
    mp.add_argument("--workers", type=int, help="local worker processes (default: the cores)")
    mp.add_argument("--out", help="output folder (default out/maps/<target>); run again to resume")
    mp.add_argument("--quiet", action="store_true", help="no progress bar")
    mp.add_argument("--set", action="append", metavar="KEY=VALUE", help="as run's: a scenario field, repeatable")
    mp.set_defaults(func=_cmd_map)
    cal = sub.add_parser("calibrate", help="measure the injection estimator's cross-saturation table (encoder in the loop)")
    cal.add_argument("scenario", help="a scenario with angle = \"hfi\" or \"blend\" (its machine, speed and injection)")
    cal.add_argument("--i-q-max", type=float, default=40.0, help="A: the table spans -i_q_max..i_q_max")
    cal.add_argument("--points", type=int, default=17)
    cal.add_argument("--speed-rpm", type=float, help="speed held by the load machine (default: the scenario's speed load, else 100)")
    cal.add_argument("--out", help="TOML file (default out/<machine>-xsat.toml)")
    cal.set_defaults(func=_cmd_calibrate)
    idf = sub.add_parser("identify", help="self-commissioning on the scenario's machine and bench: identified values beside the truth")
    idf.add_argument("scenario", help="any scenario: its machine, converter and sensors (a free shaft)")
    idf.add_argument("--out", help="output folder (default out/identify-<machine>)")
    idf.add_argument("--speed-frac", type=float, help="the running steps' speed, of rated (default the scenario's [identify] speed_frac, 0.3)")
    idf.add_argument("--t-ramp", type=float, help="s of the I/f ramp to that speed (default the scenario's [identify] t_ramp, 1)")
    idf.set_defaults(func=_cmd_identify)
    ex = sub.add_parser("export", help="write the fs_drive_config a scenario's simulation uses as C source for a firmware")
    ex.add_argument("scenario", help="catalog name or TOML file")
    ex.add_argument("--out", required=True, help="output folder: <name>.h and <name>.c are written there, replacing "
                    "an earlier export's; a file of those names that is not an export's is refused without --force")
    ex.add_argument("--name", default="fs_config", help="the C constant and the files' name (default fs_config); "
                    "not with --fmu, --fmu-system: an FMU is named after its scenario")
    ex.add_argument("--set", action="append", metavar="KEY=VALUE",
                    help="as run's: a scenario field, repeatable (controller.bw_current=4000)")
    ex.add_argument("--fmu", action="store_true",
                    help="write <scenario name>-drive.fmu instead: the drive as an FMI co-simulation unit (one step a control period)")
    ex.add_argument("--fmu-system", action="store_true",
                    help="write <scenario name>-system.fmu: plant, converter and drive as fullspeed simulates them")
    ex.add_argument("--force", action="store_true",
                    help="overwrite <name>.h and <name>.c in --out even if they are not an earlier export's (hand-written)")
    ex.add_argument("--fmi", type=int, choices=[2, 3], default=3, help="the FMI version of the FMUs (default 3)")
    ex.set_defaults(func=_cmd_export)
    sch = sub.add_parser("schema", help="the scenario and machine fields: unit, default, range, meaning (docs/reference.md)")
    sch.add_argument("section", nargs="?", help="e.g. controller, injection, machine, machine.bench (default: all)")
    sch.set_defaults(func=_cmd_schema)
    nm = sub.add_parser("new-machine", help="write a machine file template with the fields a machine requires")
    nm.add_argument("name")
    nm.add_argument("--out", help="file (default <name>.toml)")
    nm.add_argument("--force", action="store_true", help="overwrite an existing file")
    nm.set_defaults(func=_cmd_new_machine)
    args = ap.parse_args(argv)
    warnings.formatwarning = lambda msg, cat, *a, **k: f"fullspeed: warning: {one_line(str(msg))}\n"   # one line, as the errors
    try:
        return args.func(args)
    except (ConfigError, SimulationError) as exc:
        if args.debug:
            raise
        print(f"fullspeed: error: {one_line(str(exc))}", file=sys.stderr)
        return 2
    except EngineError as exc:   # the workers or the cluster were lost: what finished is kept
        if args.debug:
            raise
        print(f"fullspeed: error: {one_line(str(exc))}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("fullspeed: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:   # a bug, not bad input: still one line, the traceback on request
        if args.debug:
            raise
        text = one_line(" ".join(str(exc).split()))[:300]
        print(f"fullspeed: internal error: {type(exc).__name__}: {text} (rerun with --debug for the traceback, "
              "and please report it)", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
