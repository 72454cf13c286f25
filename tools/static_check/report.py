"""docs/static-analysis.md from static_check.py's results: the compliance
summary (rules, findings, deviations). Written by
`python tools/static_check/static_check.py --write-doc`; the notes per
rule below and the records of deviations.toml are its hand-written parts."""
from __future__ import annotations

import json
from collections import Counter, defaultdict
from pathlib import Path

import static_check as sc

BEFORE = Path(__file__).resolve().parent / "before.json"   # csrc/control at a667551: the form-only pass's "before"

# What the form-only pass (issue 39, two sessions) did about each required
# rule csrc/control had findings against, or the record that keeps it. Form
# only: every float operation stays as it is, in the same order, so that every
# claim and trace is bit for bit the same (bench/trace_hashes.py).
PLANS = {
    "5.7": "Kept: a false positive of the addon, record FP-01 (the eight untagged constant enums declare no tag; "
           "cppcheck names each 'Anonymous<n>' per translation unit and the whole-program check compares those "
           "names). Tagging them clears 5.7 and adds 75 findings of 10.4 (measured).",
    "9.2": "Done: fs_xyctrl.c's fs_vsd5 by its parts (first pass); fs_drive.c's monitor input gives u_next by "
           "its parts: the addon loses its place after a struct-valued member (a false positive); given by "
           "parts GCC copies two floats instead of a block: the firmware 76 B shorter, the blended mean 5 "
           "instructions a step lower.",
    "10.1": "Done: fs_ident.c's `n_meas << (2 * sub)` shifted as uint32_t; fs_drive.c's field table's second byte "
            "shifted and or-ed as uint32_t (compile-time constants: the same bytes).",
    "10.3": "Done: comparisons' results stored in `bool`, counts by `if (...) { ++n; }`.",
    "10.4": "Done: an int holding an enumeration compared with the constant cast to int (92 in fs_drive*.c and "
            "fs_smo.c, as fs_drive_protect.c and fs_polarity.c first); `u` suffixes; the field table's offsetof / "
            "sizeof as uint32_t.",
    "10.6": "Done: the square wave's delay chosen between (int)1 and (int)0 (an if/else assignment changed "
            "fs_drive.o's code, so not that).",
    "10.8": "Done: a rounding or conversion of a named value of its own type, each store where the cast was "
            "(fs_polarity.c's step counts first; the carrier's period, n_carrier, the monitor's delay, the square "
            "wave's samples to its window's middle).",
    "12.2": "Done: shifts of a constant of the width meant (`(uint32_t)1u << 30`).",
    "13.5": "Done: fs_mapid.c's side effects on the right of && and || split into nested ifs, same order.",
    "14.1": "Kept: four init-time searches controlled by a float, records DEV-01 (fs_hfi_w_h_max's step down the "
            "float grid; for some Ts from 3.19e31 s up it never returns, a defect reported), DEV-02 (fs_mtpa.c's "
            "golden section: 27 iterations), DEV-03 (fs_fwmap.c's descent: at most 255), DEV-04 (fs_mapid.c's "
            "back-off: at most 13).",
    "14.4": "Done: int flags compared with 0, pointers with NULL.",
    "15.6": "Done: every body in braces (552 findings over both sessions).",
    "15.7": "Done: every if ... else if chain ends in an else whose comment says why nothing is done there.",
    "17.2": "Kept: fs_cis -> cis_far -> fs_cis, depth one, record DEV-05; both ways out cost instructions a step "
            "(+3 and +8 on the blended mean, measured on this tree).",
    "17.7": "Done: results used only through the instance cast to (void).",
    "20.7": "Kept: fs_drive.c's X-macro field table, record DEV-06 (its parameter is a macro name invoked, which "
            "parentheses would stop).",
}
OWN_PLANS = {
    "objectIndex": "Cleared: fs_math.h reads a float _Complex's parts through a union with float[2] and "
                   "builds one with fs_cplx (GCC's __builtin_complex), the same instructions; advisory 19.2 "
                   "counts the union (+4).",
    "uninitvar": "Cleared with objectIndex.",
}

def _row(*cells) -> str:
    return "| " + " | ".join(str(c) for c in cells) + " |"


def _own_lines(findings) -> list[str]:
    own = sorted((f for f in findings if f.rule is None), key=lambda f: (f.file, f.line, f.id))
    if not own:
        return ["None."]
    return [_row("file:line", "severity", "check", "message"), _row("---", "---", "---", "---")] + [
        _row(f"{f.file}:{f.line}", f.severity, f.id, f.msg.replace("|", "\\|")) for f in own]


def _record_lines(records, control, table) -> list[str]:
    """The records in force: a table, then each in full."""
    if not records:
        return ["None.", ""]
    cov = sc.covered(control, records)
    problems = sc.record_problems(control, records)
    out = [_row("record", "rule", "category", "kind", "files", "findings covered"),
           _row("---", "---", "---", "---", "---", "---:")]
    for r in records:
        n = len(cov[r.id])
        state = "" if n == r.findings else (" (stale: none left)" if n == 0 else f" (written for {r.findings})")
        out.append(_row(r.id, r.rule, table[r.rule][0], r.kind,
                        ", ".join(Path(f).name for f in r.files), f"{n}{state}"))
    out.append("")
    if problems:
        out += ["Records not in force (the check fails until they are mended):", ""]
        out += [f"- {p}" for p in problems] + [""]
    for r in records:
        lines = ", ".join(sorted(f"{Path(f.file).name}:{f.line}" for f in cov[r.id])) or "none"
        out += [f"### {r.id}: rule {r.rule} ({table[r.rule][0].lower()}, {table[r.rule][1]}), {r.kind}", "",
                f"- Where: {r.where}",
                f"- Findings covered: {len(cov[r.id])} ({lines}); written for {r.findings}.",
                f"- Why: {r.why}"]
        if r.evidence:
            out.append(f"- Evidence: {r.evidence}")
        out.append(f"- Guard: {r.guard}")
        if r.cost:
            out.append(f"- Cost of complying: {r.cost}")
        out.append(f"- Raised by {r.by}, {r.date}" + (f"; approval: {r.approval}." if r.approval else "."))
        out.append("")
    return out


def markdown(res: dict, baseline: dict, table: dict, records: list | None = None) -> str:
    records = [] if records is None else records
    control = res[sc.CONTROL]
    before = json.loads(BEFORE.read_text())
    out = [
        "# Static analysis of the C core",
        "",
        "Generated by `python tools/static_check/static_check.py --write-doc` (do not edit by hand; the notes",
        "per rule are in tools/static_check/report.py, the records in tools/static_check/deviations.toml).",
        "The CI's test run (tests/test_static_check.py, with cppcheck installed by .ci/run) fails when a",
        "count held by the ratchet grows or a record is no longer true (stale, or another number of findings).",
        "",
        f"- Checker: cppcheck {res['cppcheck']} (Debian's) with its MISRA C:2012 addon (misra.py), "
        f"`--std=c99 --enable={sc.ENABLE}`, no suppressions.",
        "- csrc/control: analysed on its own, as built for the Cortex-M4F (`--platform=unix32`, `-Icsrc/control`).",
        "- csrc/plant and csrc/sim: the host simulator (`--platform=unix64`, `-Icsrc`); findings in",
        "  csrc/control headers are left to the csrc/control run.",
        "- Rule categories and one-line summaries: tools/static_check/misra_c2012.csv, written for this",
        "  project from the rule numbers and categories (MISRA's own rule texts are not reproduced).",
        "- Ratchet (tools/static_check/baseline.json): csrc/control may not gain a finding of any rule or",
        "  check; csrc/plant and csrc/sim stay clean under cppcheck's own analysis (no error, no warning,",
        "  nothing else past the baseline). Their MISRA findings are counted, not held.",
        "- Why the counts exceed issue 39's (1,292 at f52acea): cppcheck 2.10 run as `--addon=misra` without",
        "  a rule-texts file drops findings (fs_smo.c's rule 15.6: 8 reported of 29). With the rule texts",
        "  the findings are, one for one, those of misra.py run directly on cppcheck's dumps, plus the",
        "  whole-program rules (2.3, 2.4, 5.7, 8.7) only the combined run sees.",
        "",
        "## Summary",
        "",
        _row("code", "cppcheck's own findings", "MISRA mandatory", "MISRA required", "MISRA advisory",
             "rules with findings"),
        _row("---", "---:", "---:", "---:", "---:", "---:"),
    ]
    for name, *_ in sc.RUNS:
        fs = res[name]
        own = Counter(f.severity for f in fs if f.rule is None)
        cats = Counter(table[f.rule][0] for f in fs if f.rule is not None)
        own_txt = (f"{sum(own.values())} ("
                   + ", ".join(f"{s} {n}" for s, n in sorted(own.items())) + ")") if own else "0"
        out.append(_row(name, own_txt, *(cats[c] for c in sc.CATEGORIES),
                        len({f.rule for f in fs if f.rule is not None})))
    n_cov = sum(len(v) for v in sc.covered(control, records).values())
    n_open = len(sc.open_findings(control, records, table))
    kinds = Counter(r.kind for r in records)
    out += ["", f"Records in force (tools/static_check/deviations.toml): {len(records)} ("
            + (", ".join(f"{n} {k}{'s' if n > 1 else ''}" for k, n in sorted(kinds.items())) or "none")
            + f"), covering {n_cov} of csrc/control's mandatory and required findings; "
            f"neither cleared nor recorded: {n_open}.", ""]

    out += ["## Deviations and false positives in force", "",
            "From tools/static_check/deviations.toml, in the form the MISRA Compliance guidance asks of a",
            "deviation record: the rule, where, why compliance is not taken, what guards the consequence,",
            "who raised it and when. A finding the checker reports where the code meets the rule is a false",
            "positive, recorded with its evidence, not a deviation. A record covers its rule's findings in",
            "its files; the check fails on a record whose findings are gone (stale) or changed in number.", ""]
    out += _record_lines(records, control, table)

    out += ["## cppcheck's own analysis", ""]
    for name, *_ in sc.RUNS:
        out += [f"### {name}", "", *_own_lines(res[name]), ""]

    now = sc.counts(control)
    base = baseline["counts"][sc.CONTROL]
    out += ["## csrc/control: MISRA C:2012 findings by rule", "",
            f"`before` is main at {before['commit']} (cppcheck {before['cppcheck']}), the figure the form-only "
            "pass starts from; `baseline` is the ratchet's limit; `now` is this run.", ""]
    for cat in sc.CATEGORIES:
        rules = sorted({r for r, (c, _) in table.items() if c == cat
                        and (now.get(sc.MISRA_PREFIX + r) or before["counts"].get(sc.MISRA_PREFIX + r))},
                       key=sc.rule_key)
        total_now = sum(now.get(sc.MISRA_PREFIX + r, 0) for r in rules)
        total_before = sum(before["counts"].get(sc.MISRA_PREFIX + r, 0) for r in rules)
        out += [f"### {cat}: {total_now} findings (before: {total_before})", ""]
        if not rules:
            out += ["None.", ""]
            continue
        out += [_row("rule", "summary", "before", "baseline", "now"), _row("---", "---", "---:", "---:", "---:")]
        for r in rules:
            i = sc.MISRA_PREFIX + r
            out.append(_row(r, table[r][1], before["counts"].get(i, 0), base.get(i, 0), now.get(i, 0)))
        out.append("")

    req = [f for f in control if f.rule is not None and table[f.rule][0] in ("Mandatory", "Required")]
    by_rule = defaultdict(Counter)
    for f in req:
        by_rule[f.rule][Path(f.file).name] += 1
    out += ["## csrc/control: mandatory and required findings by file", ""]
    if not req:
        out += ["None.", ""]
    else:
        out += [_row("rule", "category", "findings", "files (findings)"), _row("---", "---", "---:", "---")]
        for r in sorted(by_rule, key=sc.rule_key):
            files = ", ".join(f"{fn} ({n})" for fn, n in sorted(by_rule[r].items(), key=lambda kv: (-kv[1], kv[0])))
            out.append(_row(r, table[r][0], sum(by_rule[r].values()), files))
        per_file = Counter(Path(f.file).name for f in req)
        out += ["", "By file: " + ", ".join(f"{fn} {n}" for fn, n in per_file.most_common()) + ".", ""]

    out += ["## The form-only pass, per required rule", "",
            "Form only: no float operation changes or moves, so every claim and trace stays bit for bit",
            "the same (bench/trace_hashes.py before and after; `fullspeed reproduce`'s claims.json), and the",
            "B-PIL instruction count and flash are measured before and after.", "",
            _row("rule", "findings now", "done, or kept and recorded"), _row("---", "---:", "---")]
    for r in sorted(set(by_rule) | set(PLANS), key=sc.rule_key):
        out.append(_row(r, sum(by_rule[r].values()), PLANS.get(r, "Nothing yet: a new required-rule finding.")))
    own_ids = sorted({f.id for f in control if f.rule is None and f.severity in ("error", "warning")})
    for i in own_ids:
        out.append(_row(f"cppcheck {i}", sum(1 for f in control if f.id == i),
                        OWN_PLANS.get(i, "No plan yet.")))
    out.append("")

    out += ["## csrc/plant and csrc/sim: MISRA findings (counted, not held)", ""]
    sim = sc.RUNS[1][0]
    sim_counts = Counter(f.rule for f in res[sim] if f.rule is not None)
    for cat in sc.CATEGORIES:
        rules = sorted((r for r in sim_counts if table[r][0] == cat), key=sc.rule_key)
        out.append(f"- {cat}: " + (", ".join(f"{r} ({sim_counts[r]})" for r in rules) or "none") + ".")
    out.append("")
    return "\n".join(out)
