"""docs/static-analysis.md from static_check.py's results: the compliance
summary (rules, findings, deviations). Written by
`python tools/static_check/static_check.py --write-doc`; the plans per
rule below are the only hand-written part of it."""
from __future__ import annotations

import json
from collections import Counter, defaultdict
from pathlib import Path

import static_check as sc

BEFORE = Path(__file__).resolve().parent / "before.json"   # csrc/control at a667551: the form-only pass's "before"

# How the form-only pass (issue 39, a later session) clears each required
# rule csrc/control has findings against, or which deviation it needs. Form
# only: every float operation stays as it is, in the same order, so that
# every claim and trace is bit for bit the same (bench/trace_hashes.py).
PLANS = {
    "5.7": "Tool artefact: cppcheck 2.10 reports the eight untagged constant enums (`enum { FS_XCOMP_MAX = 33 }` "
           "and those of fs_fluxmap.h, fs_fwmap.h, fs_ident.h, fs_mapid.h, fs_motion_test.h, fs_mtpa.h, "
           "fs_types.h) as one repeated tag, though they declare none. Not to be tagged: a tag gives the "
           "constants the enumeration's essential type instead of signed int, and each comparison with an "
           "int then counts under 10.4 (tried: 10.4 92 -> 167). A false-positive record (no tag declared).",
    "9.2": "Two initialisers whose member is a struct given by a struct value (fs_drive.c's monitor input, "
           "fs_xyctrl.c's fs_vsd5). No brace is elided there; if the addon still reports them once the rest is "
           "clean, set those members by assignment after a zero initialiser, or record a deviation "
           "(false positive: a struct-typed expression initialises the whole member).",
    "10.1": "Left: fs_drive.c's field table (`DRIVE_FIELDS(FIELD_ENTRY)`, uint8_t entries from the "
            "X-macro). Done: fs_ident.c's `n_meas << (2 * sub)`, shifted as uint32_t (both >= 0: the same "
            "values). Integers only, no float touched.",
    "10.3": "A comparison's result stored in an `int` (`const int dbl = ... <= ...`, `n_read += n_d[k] > 0`): "
            "store it in a `bool`, count with `if (...) { ++n_read; }`.",
    "10.4": "Mixed essential types across an operator: an enum against an int constant or macro "
            "(`FS_WITH_IF_START && ...`, status and mode comparisons), `int` against `unsigned`, a boolean "
            "flag in arithmetic. Give constants the operand's type (enum constants, `u` suffixes, `bool` "
            "macros as `(x != 0)`); where a float meets an integer, an explicit `(float)` cast of the "
            "integer, which is the conversion C already makes, so the float result is the same.",
    "10.6": "A composite int expression stored wider (`const int d = c->delay > 0.5f ? 1 : 0`): the "
            "constants are char-sized essentially; write the choice as an if/else assignment or `bool`.",
    "10.8": "A composite expression cast to another type (`(int)(cfg->delay + 0.5f)`, "
            "`(int)(2.0f * FS_PI / (w_h * Ts) + 0.5f)`, `(float)(2 * d + 1)`): bind it to a `const` of its "
            "own type first and cast that, as fs_polarity.c's step counts now do. Same float rounding "
            "(FLT_EVAL_METHOD 0 on the Cortex-M4F and x86-64 SSE), same integer; keep each store where the "
            "cast was (computing both roundings before both stores moved -Os's scheduling).",
    "12.2": "`1 << 30` and `1u << FS_MAPID_NQ` (fs_mapid.c): the addon takes the constant 1's essential "
            "type (8 bits) as the shifted width. Shift a constant of the width meant (`(uint32_t)1u << 30`, "
            "converted once where an int is wanted); the same integer values.",
    "13.5": "A decrement or increment on the right of && or || (fs_mapid.c: `n_trim > 0 && --n_trim == 0`, "
            "`... || ++k > n_settle`): split into nested ifs that run the same side effect under the same "
            "condition, in the same order.",
    "14.1": "Float-controlled while loops (bisection in fs_mtpa.c and fs_fwmap.c, the nextafterf step down "
            "in fs_hfi.c, the current back-off in fs_mapid.c), which the addon reads as float loop counters. "
            "An integer-counted loop whose bound is the most iterations the float test can take (a bisection's "
            "log2(range / tolerance); the back-off's log(D_MIN) / log(0.95)), the float test as its exit: "
            "the same iterations on every input that ends today. Deviation (14.1, with the bound as its "
            "guard) where the bound cannot be shown.",
    "14.4": "Conditions on an `int` flag or a pointer (`if (c->predict)`, `if (u_real)`): compare "
            "explicitly (`!= 0`, `!= NULL`) or make the flags `bool` (with 10.1's).",
    "15.6": "Bodies of if/for/while without braces: add the braces. Pure form; clang-format can do most.",
    "15.7": "`if ... else if` chains without a final `else`: add `else { /* nothing: <why> */ }` "
            "where the chain's last case is deliberate.",
    "17.2": "fs_cis -> cis_far -> fs_cis (fs_transforms.c): the second call's argument is wrapped to "
            "[-pi, pi], so it never reaches cis_far again (depth 1). Both ways out of the cycle were measured "
            "and cost what the recursion does not: fs_cis's reduced-argument path as a static kernel that "
            "both call is inlined into cis_far too (+324 B at -O2: the image 32,752 of 32,768 B); the wrap "
            "moved into fs_cis itself (-16 B) gives fs_cis's common path, nine calls a step, a stack frame "
            "(push/pop) that cis_far out of line avoids. Deviation record: rule 17.2, fs_cis/cis_far; guard: "
            "fs_wrap_pi's result |x| <= pi < 199 rad, so the depth is one (test_trig.c's far arguments).",
    "17.7": "Results of step functions ignored where only their state update is wanted "
            "(`fs_hfi_step(...)`, `fs_motion_obs_step(...)`, `fs_smo_step(...)`): cast to `(void)`.",
    "20.7": "fs_drive.c's field table (`DRIVE_FIELDS(X)`, an X-macro): the parameter `f` is a member "
            "designator in `offsetof` and a `#` operand, where parentheses are not allowed. Deviation "
            "record: rule 20.7, fs_drive.c DRIVE_FIELDS/FIELD_ENTRY; why: one table gives offsets, kinds, "
            "statuses and names, which cannot drift apart; guard: test_c_defends (every field refused by "
            "name) and the compile-time size check beside the table.",
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


def markdown(res: dict, baseline: dict, table: dict) -> str:
    control = res[sc.CONTROL]
    before = json.loads(BEFORE.read_text())
    out = [
        "# Static analysis of the C core",
        "",
        "Generated by `python tools/static_check/static_check.py --write-doc` (do not edit by hand; the plans",
        "per rule are in tools/static_check/report.py). The CI's test run (tests/test_static_check.py, with",
        "cppcheck installed by .ci/run) fails when a count held by the ratchet grows.",
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
    out += ["", "Deviations in force: none. Each rule the form-only pass keeps will get a record here",
            "(rule, where, why, what guards it), in the form of the MISRA Compliance guidance; the",
            "candidates are named in the plans below.", ""]

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

    out += ["## Plan of the form-only pass, per required rule", "",
            "Form only: no float operation changes or moves, so every claim and trace stays bit for bit",
            "the same (bench/trace_hashes.py before and after; `fullspeed reproduce`'s claims.json), and the",
            "B-PIL instruction count and flash are measured before and after.", "",
            _row("rule", "findings now", "plan"), _row("---", "---:", "---")]
    for r in sorted(set(by_rule) | set(PLANS), key=sc.rule_key):
        out.append(_row(r, sum(by_rule[r].values()), PLANS.get(r, "No plan yet: a new required-rule finding.")))
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
