"""`fullspeed reproduce`: measure every claim of CLAIMS.md and write
claims.json and report.md.

A claim is measured by a function the papers' modules register under its
id (registry.MEASURES). It returns a Measurement; a claim with no function
yet (or whose function fails) is still listed, with value null and pass
false, and the reason.
"""
from __future__ import annotations

import traceback
from pathlib import Path

from ..model.files import json_safe, write_atomic, write_json
from .claims import Claim, claims_for
from . import papers  # noqa: F401  (importing the papers registers their measurements)
from .registry import MEASURES, NOT_YET


def measure(claim: Claim, out: Path) -> dict:
    row = {"id": claim.id, "paper": claim.paper, "text": claim.text, "target": claim.target,
           "value": None, "unit": claim.unit, "pass": False, "scenario": claim.scenario,
           "note": "", "figures": []}
    fn = MEASURES.get(claim.id)
    if fn is None:
        row["note"] = "not yet measurable: " + NOT_YET.get(claim.id, NOT_YET.get(claim.paper, "no measurement yet"))
        return row
    try:
        m = fn(out)
    except Exception as exc:  # a failing measurement is reported, not fatal
        row["note"] = f"measurement failed: {type(exc).__name__}: {exc}"
        row["traceback"] = traceback.format_exc()
        return row
    row.update(value=json_safe(m.value), note=m.note, figures=m.figures)
    row["pass"] = bool(m.passed)
    return row


def _fmt(v) -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, dict):
        return ", ".join(f"{k}: {_fmt(x)}" for k, x in v.items())
    return str(v)


def write_report(rows: list[dict], out: Path, paper: str | None) -> Path:
    n_pass = sum(r["pass"] for r in rows)
    n_meas = sum(r["value"] is not None for r in rows)
    lines = [
        "# fullspeed reproduction report",
        "",
        f"Part: {paper or 'all papers'}. {len(rows)} claims; {n_meas} measured; {n_pass} passing.",
        "Every value below was measured in this run; a claim that cannot be measured yet",
        "is listed with no value and `pass: false`. The claims and their conditions: docs/CLAIMS.md",
        "in the repository (generated from src/fullspeed/reproduce/claims.py).",
        "",
        "| id | paper | target | measured | unit | pass | scenario |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['id']} | {r['paper']} | {r['target']} | {_fmt(r['value'])} | {r['unit']} | "
                     f"{'yes' if r['pass'] else 'no'} | {r['scenario']} |")
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


def reproduce(paper: str | None, out: Path, progress: bool = True) -> list[dict]:
    claims = claims_for(paper)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    it = claims
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(claims, desc="claims", unit="claim", leave=False)
        it = bar
    for claim in it:
        rows.append(measure(claim, out))
        # written after every claim: an interrupted reproduction keeps what it measured
        write_json(out / "claims.json", rows, indent=2)
    if bar is not None:
        bar.close()
    write_report(rows, out, paper)
    return rows
