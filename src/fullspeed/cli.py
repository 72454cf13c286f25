"""Command line: fullspeed run | list | sweep | reproduce | calibrate | export.

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
import re
import sys
import time
import tomllib
import warnings
from importlib import resources
from pathlib import Path

from .design.checks import polarity_blind
from .design.report import design_report
from .design.scenario import load_scenario, scenario_from_dict
from .model.errors import ConfigError, EngineError, SimulationError
from .model.files import file_name, json_safe, package_names, out_folder, out_path, path_kind, write_atomic, write_json, write_npz, write_with
from .model.machines import catalog_names
from .model.reference import machine_template, reference_text, section_names
from .model.schema import deep_merge, read_toml

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
        try:
            value = tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:
            if any(c in text for c in "[]{}\"'=") or not text.strip():
                raise ConfigError(f"--set {key}", text, "is not a TOML value (a number, true/false, \"text\", [list] or {table})") from None
            value = text.strip()
        for k in reversed(parts):
            value = {k: value}
        out = deep_merge(out, value)
    return out


# `fullspeed run`'s exit status (README, "Exit status"): 0 only for a run that
# completed with the drive in control; 2 is bad input, 3 an internal error.
EXIT_FAILED = 1   # a protection stop, a refusal, a loss of lock (flagged, or seen by the simulation's truth)


def run_verdict(res) -> list[str]:
    """Why a run failed, one line each; empty for a run that completed with
    the drive in control."""
    m, out = res.metrics, []
    t_stop = res.stop_time if res.stop_time is not None else res.sim_time
    if res.stop_reason == "polarity_undetermined":
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
    elif res.stop_reason != "done":
        out.append(f"stopped at t = {t_stop:.6f} s: {res.stop_reason} (traces up to the stop were written)")
    if m.get("lock_lost_at") is not None:
        out.append(f"loss of lock flagged by the drive's monitor at t = {m['lock_lost_at']:.4f} s")
    if m.get("true_loss_at") is not None:
        flagged = m.get("lock_lost_at") is not None or res.stop_reason != "done"
        out.append(f"the estimate was 90 el.deg off the rotor for 20 ms net by t = {m['true_loss_at']:.4f} s (the simulation's truth)"
                   + ("" if flagged else ": the drive did not flag it (a silent failure)"))
    return out


def _cmd_run(args) -> int:
    from .sim import simulate
    from .sim.metrics import summary_lines
    from .sim.plots import plot_run


    overrides = _set_overrides(args.set)
    if args.inverter:
        overrides.setdefault("converter", {})["inverter"] = args.inverter
    sc = load_scenario(args.scenario, overrides or None)
    out = out_folder(args.out) if args.out else out_path(OUT, sc.name, "name", sc.source)   # before the run, not after
    for w in sc.warnings:
        print(f"fullspeed: warning: {w}", file=sys.stderr)
    res = simulate(sc, progress=not args.quiet)
    # metrics.json last: its presence marks the folder complete (an older one goes first)
    (out / "metrics.json").unlink(missing_ok=True)
    write_npz(out / "traces.npz", res.traces)
    write_with(out / "run.png", lambda tmp: plot_run(res, tmp))
    write_json(out / "metrics.json", json_safe(res.metrics), indent=2)
    print(f"{res.scenario.name}: {res.sim_time:.3f} s simulated in {res.wall_time:.3f} s wall "
          f"= {res.speed_ratio:.1f} simulated s per wall s ({res.scenario.data['converter']['inverter']} inverter)")
    print("\n".join(summary_lines(res.metrics)))
    if res.metrics.get("sensorless_err_deg_max") is not None:
        print(f"largest angle error while sensorless: {res.metrics['sensorless_err_deg_max']:.2f} el.deg")
    if res.polarity is not None and res.polarity["stage"] == "done":
        print(f"polarity: decided with margin {res.polarity['margin']:.2f} at {res.polarity['i_pulse']:.3g} A"
              + (" (the estimate turned by pi)" if res.polarity["flip"] else ""))
    if res.metrics.get("ideal_hardware"):
        print("ideal hardware: " + ", ".join(res.metrics["ideal_hardware"]))
    print(f"wrote {out}/metrics.json, traces.npz, run.png")
    failed = run_verdict(res)
    for line in failed:
        print(f"fullspeed: run failed: {line}", file=sys.stderr)
    return EXIT_FAILED if failed else 0


def _cmd_design(args) -> int:

    target = args.target
    overrides = _set_overrides(args.set)
    if target.endswith(".toml") or target in catalog_names():
        data = read_toml(target, "machine") if target.endswith(".toml") else None
        if data is not None and "machine" in data:   # a scenario file
            sc = load_scenario(target, overrides)
        else:
            sc = scenario_from_dict(deep_merge({"name": f"design-{Path(target).stem}", "duration": 1.0,
                                                "machine": str(Path(target).resolve()) if data is not None else target,
                                                "controller": {"mode": "speed", "angle": "blend", "flux_weakening": True}},
                                               overrides), target)
    else:
        sc = load_scenario(target, overrides)
    for w in sc.warnings:
        print(f"fullspeed: warning: {w}", file=sys.stderr)
    print(design_report(sc))
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
    from .workflows.sweep import load_sweep_file, run_sweep



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
    print(f"sweep {sw.name}: {n} points {where} -> {out}", file=sys.stderr)
    t0 = time.perf_counter()
    resume = f"resume with: fullspeed sweep {args.file} --out {out}"
    try:
        path, rows = run_sweep(sw, out, workers=args.workers, dask=args.dask, progress=not args.quiet,
                               dask_timeout=args.dask_timeout)
    except (KeyboardInterrupt, EngineError):
        kept = len(read_journal(out / JOURNAL, n))
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
    return 0 if len(rows) == n else 1


def _check_dask_address(address: str) -> None:
    """[scheme://]host:port, before anything runs (Dask's own error is a traceback)."""
    m = re.fullmatch(r"(?:[a-z][a-z0-9+.-]*://)?(\[[0-9A-Fa-f:.]+\]|[^\s:/\[\]]+):(\d{1,5})/?", address)
    if m is None or not 0 < int(m.group(2)) < 65536:
        raise ConfigError("--dask", address, "must be a scheduler address with a port: tcp://HOST:PORT")


def _with_overrides(sw, extra: dict):
    """The sweep with --set merged into its [overrides] (checked as the file's are)."""
    from .workflows.sweep import check_points



    overrides = deep_merge(sw.overrides, extra)
    check_points(sw.base, overrides, sw.axes, sw.base_source)
    return dataclasses.replace(sw, overrides=overrides)


def _cmd_reproduce(args) -> int:
    from .reproduce.report import reproduce


    out = out_folder(args.out)
    rows = reproduce(args.paper, out, progress=not args.quiet)
    n_pass = sum(r["pass"] for r in rows)
    n_meas = sum(r["value"] is not None for r in rows)
    print(f"{len(rows)} claims, {n_meas} measured, {n_pass} passing; wrote {out}/claims.json and {out}/report.md")
    return 0


def _cmd_calibrate(args) -> int:
    import numpy as np

    from .workflows.calibrate import write_table, xsat_table



    if args.out:
        target = Path(args.out)
        if path_kind(target) == "dir":
            raise ConfigError("--out", str(target), "is a folder; give the table's file name (a .toml)")
        out_folder(target.parent)
    else:   # the machine's name makes the file's: checked before the calibration runs
        sc = load_scenario(args.scenario)
        target = out_path(OUT, sc.machine.name, "machine.name", sc.source, suffix="-xsat.toml")
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
    from .workflows.identify import identify, print_identification, write_identification


    sc = load_scenario(args.scenario)
    out = out_folder(args.out) if args.out else Path("out") / f"identify-{sc.machine.name}"
    res = identify(sc, speed_frac=args.speed_frac, t_ramp=args.t_ramp)
    paths = write_identification(res, sc, out)
    print_identification(res)
    print("wrote " + ", ".join(str(p) for p in paths))
    for line in res.failures():
        print(f"fullspeed: identification failed: {line}", file=sys.stderr)
    return 0 if res.ok else 1


def _cmd_export(args) -> int:
    from .workflows.export import export


    paths = export(args.scenario, args.out, args.name, _set_overrides(args.set))
    print(f"wrote {' and '.join(str(p) for p in paths)}: the fs_drive_config of {args.scenario} "
          f"(compile the .c with csrc/control; fs_drive_init(&drive, &{args.name}))")
    return 0


def _cmd_schema(args) -> int:

    if args.section is not None and not reference_text(args.section):
        raise ConfigError("section", args.section, "unknown; the sections are " + ", ".join(section_names()))
    print(reference_text(args.section), end="")
    return 0


def _cmd_new_machine(args) -> int:

    path = Path(args.out or f"{file_name(args.name)}.toml")
    if path.exists() and not args.force:
        raise ConfigError("--out", str(path), "exists; --force to overwrite")
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
    r.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a scenario field, repeatable: dotted key, TOML value (controller.bw_speed=50)")
    r.set_defaults(func=_cmd_run)
    dz = sub.add_parser("design", help="print every designed setting of a machine or scenario, with its reason")
    dz.add_argument("target", help="a catalog machine, a machine TOML (datasheet fields), or a scenario (name or TOML)")
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
    ex.add_argument("--out", required=True, help="output folder: <name>.h and <name>.c are written there")
    ex.add_argument("--name", default="fs_config", help="the C constant and the files' name (default fs_config)")
    ex.add_argument("--set", action="append", metavar="KEY=VALUE",
                    help="as run's: a scenario field, repeatable (controller.bw_current=4000)")
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
    warnings.formatwarning = lambda msg, cat, *a, **k: f"fullspeed: warning: {msg}\n"   # one line, as the errors
    try:
        return args.func(args)
    except (ConfigError, SimulationError) as exc:
        if args.debug:
            raise
        print(f"fullspeed: error: {exc}", file=sys.stderr)
        return 2
    except EngineError as exc:   # the workers or the cluster were lost: what finished is kept
        if args.debug:
            raise
        print(f"fullspeed: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("fullspeed: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:   # a bug, not bad input: still one line, the traceback on request
        if args.debug:
            raise
        text = " ".join(str(exc).split())[:300]
        print(f"fullspeed: internal error: {type(exc).__name__}: {text} (rerun with --debug for the traceback, "
              "and please report it)", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
