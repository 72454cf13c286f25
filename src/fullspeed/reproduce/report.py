"""`fullspeed reproduce`: measure every claim of CLAIMS.md and write
claims.json and report.md.

A claim is measured by a function the papers' modules register under its
id (registry.MEASURES). It returns a Measurement; a claim with no function
yet (or whose function fails) is still listed, with value null and pass
false, and the reason.

The claims run concurrently in LANES processes, the longest first
(registry.COST); the claims that share runs in memory (registry.SHARES) in
one process, one after the other. The lane that runs the first (the
longest) runs at the command's priority, the others below it
(BACKGROUND_NICE): a campaign runs its own pool of workers on every core
(workflows.journal), and a claim in the background takes only what the
foreground leaves idle (its pool's last tasks, a claim's serial part)
instead of slowing it; the longest, in the foreground, is not left to run
alone at the end with its serial parts idling a core. Each claim's row
says its lane and when it started, beside its wall and CPU time, so that
the report shows how the claims packed. claims.json is written after
every claim that finishes, in CLAIMS order, and says whether the
reproduction is complete and which claims did not run (an interrupted one
keeps what it measured and says so).
"""
from __future__ import annotations

import multiprocessing
import os
import time
import traceback
from pathlib import Path

from ..model.errors import EngineError
from ..model.files import json_safe, write_atomic, write_json
from ..workflows.journal import cpu_spent, default_workers, in_pool, preload
from .claims import Claim, claims_for
from . import papers  # noqa: F401  (importing the papers registers their measurements)
from .registry import COST, COST_DEFAULT, MEASURES, NOT_YET, SHARES

LANES = 2             # claim processes at most: one in the foreground, one filling what it leaves idle; more
                      # would each start a campaign pool of every core (memory) for no core left to run them
BACKGROUND_NICE = 19  # the background lane's niceness over the command's: the scheduler's smallest share


def measure(claim: Claim, out: Path, fn) -> dict:
    """claim's row, measured by fn(out) (None: not yet measurable), with
    its wall time."""
    t0, c0 = time.perf_counter(), cpu_spent()
    row = {"id": claim.id, "paper": claim.paper, "text": claim.text, "target": claim.target,
           "value": None, "unit": claim.unit, "pass": False, "scenario": claim.scenario,
           "note": "", "figures": []}
    if fn is None:
        row["note"] = "not yet measurable: " + NOT_YET.get(claim.id, NOT_YET.get(claim.paper, "no measurement yet"))
    else:
        try:
            m = fn(out)
        except Exception as exc:  # a failing measurement is reported, not fatal
            row["note"] = f"measurement failed: {type(exc).__name__}: {exc}"
            row["traceback"] = traceback.format_exc()
        else:
            row.update(value=json_safe(m.value), note=m.note, figures=m.figures)
            row["pass"] = bool(m.passed)
    row["wall_s"] = round(time.perf_counter() - t0, 2)
    row["cpu_s"] = round(cpu_spent() - c0, 2)   # its campaigns' workers and its compilers included: what it costs
    return row


# in a claim process: the background lanes' shared count (_lane), then this process's lane (_take_lane)
_LANE: list = [None, None]


def _take_lane(k: int) -> int:
    """This process's lane, fixed when it starts its first unit (the k-th of
    units()): 0, the foreground, for the one that runs unit 0 (the longest);
    the others numbered from 1 and below it (BACKGROUND_NICE). Here (no
    claim processes): 0."""
    if _LANE[1] is None:
        if k == 0 or _LANE[0] is None:
            _LANE[1] = 0
        else:
            with _LANE[0].get_lock():
                _LANE[0].value += 1
                _LANE[1] = _LANE[0].value
            os.nice(BACKGROUND_NICE)
    return _LANE[1]


def _measure_unit(k: int, unit: list[tuple[Claim, object]], out: Path, t0: float) -> list[dict]:
    """A lane's job, the k-th unit: its claims (claim, its function) in
    order, each row with its lane and its start (s after t0, time.time())."""
    lane = _take_lane(k)
    rows = []
    for claim, fn in unit:
        start = time.time() - t0
        rows.append(dict(measure(claim, out, fn), lane=lane, start_s=round(start, 2)))
    return rows


def _lane(background) -> None:
    """A claim process starts: the count of background lanes kept for
    _take_lane, every paper's module imported for its pools' workers."""
    _LANE[0] = background
    preload(papers.__name__)   # the campaigns' pools fork their workers with every paper's module imported


def units(claims) -> list[list[Claim]]:
    """The claims grouped by the runs they share (registry.SHARES), each
    group in CLAIMS order; the groups longest first (registry.COST)."""
    groups: dict[str, list[Claim]] = {}
    for c in claims:
        groups.setdefault(SHARES.get(c.id, c.id), []).append(c)
    return sorted(groups.values(), key=lambda u: -sum(COST.get(c.id, COST_DEFAULT) for c in u))


def claims_file(claims, done: dict[str, dict], wall_s: float, lanes: int) -> dict:
    """claims.json: the rows measured so far in CLAIMS order, whether every
    claim ran, the ones that did not (an interrupted reproduction) and the
    wall time."""
    return {"complete": all(c.id in done for c in claims), "claims": [done[c.id] for c in claims if c.id in done],
            "not_run": [c.id for c in claims if c.id not in done], "wall_s": round(wall_s, 1), "lanes": lanes}


def _fmt(v) -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, dict):
        return ", ".join(f"{k}: {_fmt(x)}" for k, x in v.items())
    return str(v)


COSTLIEST = 8   # claims named by their CPU time at the report's head


def lanes_summary(rows: list[dict]) -> list[str]:
    """The report's lines on where the time went: the costliest claims by
    CPU time, and per lane its claims, their CPU time and when its last
    claim ended (a lane that ends early left its core to the others' pools,
    or idle)."""
    top = sorted(rows, key=lambda r: -r.get("cpu_s", 0.0))[:COSTLIEST]
    out = ["By CPU time: " + ", ".join(f"{r['id']} {r.get('cpu_s', 0.0):.1f} s" for r in top) + "."]
    lanes = sorted({r["lane"] for r in rows if r.get("lane") is not None})
    for k in lanes:
        mine = [r for r in rows if r.get("lane") == k]
        end = max(r["start_s"] + r.get("wall_s", 0.0) for r in mine)
        out.append(f"Lane {k}{' (foreground)' if k == 0 else ''}: {len(mine)} claim{'s' if len(mine) > 1 else ''}, "
                   f"{sum(r.get('cpu_s', 0.0) for r in mine):.0f} s of CPU, its last ended at {end:.0f} s.")
    return out


def write_report(rows: list[dict], out: Path, paper: str | None, not_run=(), wall_s: float | None = None,
                 lanes: int = 1) -> Path:
    n_pass = sum(r["pass"] for r in rows)
    n_meas = sum(r["value"] is not None for r in rows)
    lines = [
        "# fullspeed reproduction report",
        "",
        f"Part: {paper or 'all papers'}. {len(rows)} claims; {n_meas} measured; {n_pass} passing.",
    ]
    if not_run:
        lines += ["", f"**Incomplete**: the reproduction stopped before {len(not_run)} claims ran: {', '.join(not_run)}.", ""]
    if wall_s is not None:
        cpu = sum(r.get("cpu_s", 0.0) for r in rows)
        lines += [f"Wall time {wall_s:.0f} s, the claims in {lanes} concurrent processes; each claim's wall time",
                  "is from its start to its end (with others running beside it), its CPU time what it cost, its",
                  f"campaigns' workers and its compilers included ({cpu:.0f} s over all claims)."]
        lines += lanes_summary(rows)
    lines += [
        "Every value below was measured in this run; a claim that cannot be measured yet",
        "is listed with no value and `pass: false`. The claims and their conditions: docs/CLAIMS.md",
        "in the repository (generated from src/fullspeed/reproduce/claims.py).",
        "",
        "| id | paper | target | measured | unit | pass | scenario | wall (s) | CPU (s) | lane | start (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['id']} | {r['paper']} | {r['target']} | {_fmt(r['value'])} | {r['unit']} | "
                     f"{'yes' if r['pass'] else 'no'} | {r['scenario']} | {r.get('wall_s', 0.0):.1f} | "
                     f"{r.get('cpu_s', 0.0):.1f} | {r.get('lane', '—')} | {_fmt(r.get('start_s'))} |")
    lines.append("")
    for r in rows:
        lines += [f"## {r['id']} ({r['paper']})", "", f"Conditions: {r['text']}", "",
                  f"Target: {r['target']}. Measured: {_fmt(r['value'])} {r['unit']}. "
                  f"Pass: {'yes' if r['pass'] else 'no'}.", ""]
        if r["note"]:
            lines += [r["note"], ""]
        for fig in r["figures"]:
            lines += [f"![{r['id']}]({fig})", ""]
    return write_atomic(out / "report.md", "\n".join(lines))


def reproduce(paper: str | None, out: Path, progress: bool = True, lanes: int | None = None) -> list[dict]:
    """Every claim of the part measured into out (claims.json, report.md,
    the figures), in `lanes` processes (default: LANES, at most the cores;
    1: here, one after the other); the rows in CLAIMS order."""
    claims = claims_for(paper)
    out.mkdir(parents=True, exist_ok=True)
    lanes = max(1, min(LANES, default_workers()) if lanes is None else lanes)
    jobs = [[(c, MEASURES.get(c.id)) for c in u] for u in units(claims)]
    done: dict[str, dict] = {}
    t0 = time.perf_counter()

    def save() -> dict:   # after every claim: an interrupted reproduction keeps what it measured, and says so
        f = claims_file(claims, done, time.perf_counter() - t0, lanes)
        write_json(out / "claims.json", f, indent=2)
        write_report(f["claims"], out, paper, f["not_run"], f["wall_s"], lanes)
        return f

    save()   # a previous run's files in out are replaced at once: none is left looking complete
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(claims), desc="claims", unit="claim", leave=False)
    t_start = time.time()   # the lanes' clock for each claim's start (start_s)
    if lanes > 1 and len(jobs) > 1:
        stream = in_pool(_measure_unit, {k: (k, j, out, t_start) for k, j in enumerate(jobs)}, lanes, _lane,
                         (multiprocessing.get_context("forkserver").Value("i", 0),), (__name__,), "groups of claims")
    else:
        stream = ((k, _measure_unit(k, j, out, t_start)) for k, j in enumerate(jobs))
    try:
        for _, rows in stream:
            done.update((r["id"], r) for r in rows)
            save()
            if bar is not None:
                bar.update(len(rows))
    finally:
        stream.close()   # stops the lanes at once when we leave early (Ctrl-C)
        if bar is not None:
            bar.close()
    f = save()
    if not f["complete"]:   # lanes that died for good (in_pool said how)
        raise EngineError(f"{len(f['not_run'])} claims not run ({', '.join(f['not_run'])}): their process died; "
                          f"{out / 'claims.json'} holds the others and says it is incomplete")
    return f["claims"]
