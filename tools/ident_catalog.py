"""Identify, then run, on every machine of the published catalog and on
examples/own-machine, as a new user would (issue 35's per-machine table).

Per machine:
1. `fullspeed identify SCENARIO --out DIR` on a free shaft, SCENARIO the
   machine's own: B-REAL's full-range scenario (reproduce/papers/real.py,
   written to DIR/../scenario-*.toml), the own machine's README scenario;
   where B-REAL's scenario does not load (the H27: its I/f start cannot
   carry the load), the machine alone with the controller off.
2. Where the free identification names the cure "lock it" (the standstill
   steps turned the rotor, or the map's d sweep would), or its map is not
   within its goal, again with `[identify] locked = true`.
3. The same full-range scenario on the true machine file, and on each
   identified machine.toml with the true machine as `plant_machine` (the
   drive designed from the identified file, the simulation turning the
   true machine), judged as B-REAL judges it: the largest angle error
   outside the 50 ms after each step (from the I/f start's hand-over where
   the machine starts by I/f), the steady mean, how it stopped.

Writes OUT/table.json and OUT/table.md and prints the table. Takes about
two minutes on 2 cores (one process).

    .venv/bin/python tools/ident_catalog.py --out out/ident-catalog [--only NAME ...]
"""
from __future__ import annotations

import argparse
import copy
import json
import subprocess
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OWN = ROOT / "examples" / "own-machine"
sys.path.insert(0, str(ROOT / "tests"))   # tomlw: the tests' TOML writer

from tomlw import dumps  # noqa: E402

from fullspeed.design.scenario import scenario_from_dict  # noqa: E402
from fullspeed.model.errors import ConfigError  # noqa: E402
from fullspeed.model.machines import published_machines  # noqa: E402
from fullspeed.reproduce.papers.real import real_scenario, sensorless_angle  # noqa: E402
from fullspeed.sim.metrics import (SENSORLESS_STAGES, sensorless_error_max, sensorless_from,  # noqa: E402
                                   stepping_channels)
from fullspeed.sim.runner import simulate  # noqa: E402

FS = str(Path(sys.executable).with_name("fullspeed"))
KEYS = ("R_s", "L_d", "L_q", "psi_f", "J")


def scenarios(name: str) -> tuple[dict, str]:
    """The machine's full-range scenario (TOML data, the machine as a
    catalog name or an absolute file) and what it is."""
    if name == "own":
        data = tomllib.loads((OWN / "my48v-full-range.toml").read_text())
        data["machine"] = str(OWN / "my48v.toml")
        return data, "examples/own-machine/my48v-full-range.toml"
    angle, _ = sensorless_angle(name)
    data, _ = real_scenario(name, angle or "blend")
    return data, f"B-REAL's ({angle or 'blend: refused'})"


def identify(scen: Path, out: Path) -> dict:
    t0 = time.perf_counter()
    p = subprocess.run([FS, "identify", str(scen), "--out", str(out)], capture_output=True, text=True)
    row = {"command": f"fullspeed identify {scen.relative_to(ROOT) if scen.is_relative_to(ROOT) else scen} --out {out.relative_to(ROOT) if out.is_relative_to(ROOT) else out}",
           "rc": p.returncode, "wall_s": round(time.perf_counter() - t0, 2), "stderr": p.stderr.strip()[-2000:]}
    rep = out / "identification.toml"
    if p.returncode in (0, 1) and rep.is_file():
        tab = tomllib.loads(rep.read_text())
        row["sim_s"] = tab[""]["sim_time_s"] if "" in tab else tab.get("sim_time_s")
        row["ended_in"] = tab.get("ended_in")
        row["status"] = {q: tab[q]["status"] for q in ("verr", "R_s", "L_d", "L_q", "map", "psi_f", "J", "friction")}
        row["reason"] = {q: tab[q].get("reason", "") for q in row["status"] if tab[q].get("reason")}
        row["error_pct"] = {q: tab[q]["error_pct"] for q in KEYS if "error_pct" in tab[q]}
        if "rms_error_pct_of_psi_f" in tab["map"]:
            row["map_rms_pct"] = tab["map"]["rms_error_pct_of_psi_f"]
        mo, tm = tab.get("motion", {}), tab.get("time", {})
        steps = {k[:-8]: (v, mo.get(k[:-8] + "_i_peak_A")) for k, v in mo.items()
                 if k.endswith("_max_deg") and not k.startswith(("truth", "drive"))}
        # the steps meant to keep the rotor still (ALIGN turns it on purpose where the polarity does not show)
        still = {k: v for k, v in steps.items() if k != "align"}
        worst = max(still, key=lambda k: still[k][0]) if still else None
        row["motion"] = {"max_deg": still[worst][0] if worst else None, "step": worst, "i_peak_A": still[worst][1] if worst else None,
                         "align_deg": steps.get("align", (None,))[0], "steps": steps}
        row["time_s"] = {"total": tm.get("total_s"), "standstill": tm.get("standstill_s")}
        row["machine_file"] = (out / "machine.toml").is_file()
    return row


def run(data: dict, label: str) -> dict:
    """The full range, judged as B-REAL's run_machine judges it."""
    try:
        sc = scenario_from_dict(copy.deepcopy(data), label, warn=False)
    except ConfigError as exc:
        return {"refused": str(exc)}
    t0 = time.perf_counter()
    res = simulate(sc)
    mt = res.metrics
    row = {"stop": res.stop_reason, "lock_lost_at": mt.get("lock_lost_at"), "true_loss_at": mt.get("true_loss_at"),
           "start": sc.data["start"]["kind"], "angle": sc.data["controller"]["angle"],
           "err_max": mt.get("sensorless_err_deg_max"), "steady_mean": (mt.get("theta_err_deg") or {}).get("mean"),
           "wall_s": round(time.perf_counter() - t0, 2)}
    if row["start"] == "if":
        row["err_max"] = sensorless_error_max(res.traces, t_from=sensorless_from(sc), stages=SENSORLESS_STAGES,
                                              channels=stepping_channels(sc))
    return row


def machine(name: str, out: Path) -> dict:
    data, what = scenarios(name)
    out.mkdir(parents=True, exist_ok=True)
    base = {"name": f"identify-{name}", "duration": 1.0, "machine": data["machine"], "controller": {"mode": "off"}}
    scen = out / f"scenario-{name}.toml"
    try:   # the full-range scenario itself, where it loads
        scenario_from_dict(copy.deepcopy(data), str(scen), warn=False)
        scen.write_text(dumps(data))
        used = what
    except ConfigError as exc:
        scen.write_text(dumps(base))
        used = f"the machine alone (its full-range scenario refused: {exc})"
    row = {"machine": name, "identify_scenario": used, "runs": {}}
    row["true_run"] = run(data, f"{name} true")
    if "refused" in row["true_run"]:   # B-REAL's refusal (the H27: its I/f start cannot carry the load): half the load
        refused = row["true_run"]["refused"]
        data = copy.deepcopy(data)
        data["load"]["torque"] = [[t, 0.5 * T] for t, T in data["load"]["torque"]]
        row["true_run"] = run(data, f"{name} true, half load")
        row["true_run"]["note"] = f"half of B-REAL's load: B-REAL's scenario refused ({refused[:120]})"
        row["run_scenario"] = "B-REAL's at half load"
        (out / f"scenario-{name}-run.toml").write_text(dumps(data))
    ids = {"free": identify(scen, out / f"id-{name}")}
    text = " ".join(ids["free"].get("reason", {}).values()) + ids["free"]["stderr"]
    # the cure the identification named, or a map not within its goal (README: the map of a rotor the sweeps
    # leave turning is identified locked)
    if "lock" in text or ids["free"].get("status", {}).get("map") not in (None, "ok", "skipped"):
        locked = copy.deepcopy(tomllib.loads(scen.read_text()))
        locked["identify"] = {"locked": True}
        lscen = out / f"scenario-{name}-locked.toml"
        lscen.write_text(dumps(locked))
        ids["locked"] = identify(lscen, out / f"id-{name}-locked")
    row["identify"] = ids
    for kind, r in ids.items():
        if r.get("machine_file"):
            d = copy.deepcopy(data)
            d["machine"], d["plant_machine"] = str(out / (f"id-{name}" + ("" if kind == "free" else "-locked")) / "machine.toml"), data["machine"]
            row["runs"][kind] = run(d, f"{name} identified ({kind})")
    return row


def fmt(v, f="{:+.2f}"):
    return "-" if v is None else f.format(v)


def table(rows: list[dict]) -> str:
    out = ["| machine | identify | exit | R_s % | L_d % | L_q % | psi_f % | J % | map RMS % psi_f | status not ok | motion el.deg, largest outside ALIGN (step, A); ALIGN's | time sim s (standstill) / wall s | run on true: max / mean el.deg, stop | run on identified: max / mean el.deg, stop |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        t = r["true_run"]
        tr = (f"{fmt(t.get('err_max'), '{:.2f}')} / {fmt(t.get('steady_mean'))}, {t.get('stop')}" if "refused" not in t
              else "refused: " + t["refused"][:90]) + (" (half load)" if t.get("note") else "")
        for kind, i in r["identify"].items():
            e = i.get("error_pct", {})
            bad = "; ".join(f"{q}: {i['status'][q]}" for q in i.get("status", {}) if i["status"][q] not in ("ok", "skipped"))
            skipped = ", ".join(q for q in i.get("status", {}) if i["status"][q] == "skipped")
            mo = i.get("motion", {})
            mot = (f"{fmt(mo.get('max_deg'), '{:.2f}')} ({mo.get('step')}, {fmt(mo.get('i_peak_A'), '{:.3g}')})"
                   + (f"; align {mo['align_deg']:.0f}" if mo.get("align_deg") is not None else "")) if mo else "-"
            tm = i.get("time_s", {})
            ru = r["runs"].get(kind)
            rs = ("no machine.toml" if ru is None else "refused: " + ru["refused"][:90] if "refused" in ru
                  else f"{fmt(ru.get('err_max'), '{:.2f}')} / {fmt(ru.get('steady_mean'))}, {ru.get('stop')}"
                  + (f" (lock lost {ru['lock_lost_at']:.3f} s)" if ru.get("lock_lost_at") else ""))
            out.append(f"| {r['machine']} | {kind} | {i['rc']} | {fmt(e.get('R_s'))} | {fmt(e.get('L_d'))} | {fmt(e.get('L_q'))} | "
                       f"{fmt(e.get('psi_f'))} | {fmt(e.get('J'))} | {fmt(i.get('map_rms_pct'), '{:.2f}')} | "
                       f"{bad or '-'}{(' (skipped: ' + skipped + ')') if skipped else ''} | {mot} | "
                       f"{fmt(tm.get('total'), '{:.2f}')} ({fmt(tm.get('standstill'), '{:.2f}')}) / {i['wall_s']:.1f} | {tr} | {rs} |")
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "ident-catalog")
    ap.add_argument("--only", nargs="*", default=None, help="catalog names (and/or 'own')")
    a = ap.parse_args(argv)
    names = a.only or (published_machines() + ["own"])
    out = a.out.resolve()
    rows = []
    for n in names:
        rows.append(machine(n, out))
        print(f"{n}: done", file=sys.stderr, flush=True)
    (out / "table.json").write_text(json.dumps(rows, indent=1, default=str))
    md = table(rows)
    (out / "table.md").write_text(md)
    print(md)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
