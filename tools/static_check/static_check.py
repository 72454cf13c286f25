"""Static analysis of the C core with cppcheck: its own checks and its MISRA
C:2012 addon, counted per rule and per category, held against a ratchet.

Two runs, each with --enable=warning,style,performance,portability and the
MISRA addon (rule texts written for this project, misra_c2012.csv):
- csrc/control, as the controllers are built on their own for the target
  (the Cortex-M4F: 32-bit int, long and pointers, --platform=unix32);
- csrc/plant and csrc/sim, the host simulator (--platform=unix64). Its
  findings located in csrc/control headers are left to the first run,
  which sees every controller file.
A finding belongs to the file of its primary location.

The ratchet (baseline.json, beside this file): for csrc/control, no rule's
count (MISRA rule or cppcheck check) may grow past its baseline and no new
one may appear; for csrc/plant and csrc/sim, cppcheck's own analysis must
stay clean (no error or warning at all, and no other finding past the
baseline). MISRA findings in plant and sim are counted, not held: the
simulator runs on the host in double precision and is not the firmware.

The records (deviations.toml, beside this file): each finding against a
required rule that csrc/control keeps on purpose has a record (rule, kind:
deviation or false positive, files, where, why, guard, by, date). A record
covers its rule's findings in its files; one whose findings are gone is
stale, one whose count changed must be reviewed: both fail the check, so
that the records say what is in force.

Usage (from the repository root, with the project's virtual environment):
    python tools/static_check/static_check.py [--write-doc] [--write-baseline]
Exit status: 0 the ratchet holds and the records are in force; 1 it does
not, or a record is stale or changed (what is printed); 2 a record is
malformed (its id, field and what is allowed); 3 the analysis cannot be
trusted (cppcheck missing, another version than the baseline's, or cppcheck
could not analyse a file), with the reason.
--write-doc writes docs/static-analysis.md (atomically); --write-baseline
records today's counts as the baseline (only after a change that lowered
them, or on a new cppcheck version, with the reason in the commit).
"""
from __future__ import annotations

import argparse
import csv
import datetime
import hashlib
import json
import re
import shutil
import subprocess
import sys
import tomllib
import xml.etree.ElementTree as ET
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from fullspeed.model.files import write_atomic

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
RULES_CSV = HERE / "misra_c2012.csv"
BASELINE = HERE / "baseline.json"
DEVIATIONS = HERE / "deviations.toml"
DOC = ROOT / "docs" / "static-analysis.md"

ENABLE = "warning,style,performance,portability"
CONTROL = "csrc/control"
SIM = ("csrc/plant", "csrc/sim")
# the runs: name, source folders, include folder, platform (see the docstring)
RUNS = (
    (CONTROL, (CONTROL,), CONTROL, "unix32"),
    ("csrc/plant+csrc/sim", SIM, "csrc", "unix64"),
)
# cppcheck findings that say a file was not (fully) analysed: counts beside them mean nothing
TOOL_FAILURES = {"internalError", "syntaxError", "cppcheckError", "preprocessorErrorDirective",
                 "internalAstError", "unknownMacro", "misra-config", "failedToRunAddon",
                 "instantiationError", "bailoutUninitVar", "noValidConfiguration"}
MISRA_PREFIX = "misra-c2012-"
CATEGORIES = ("Mandatory", "Required", "Advisory")
EXIT_OK, EXIT_RATCHET, EXIT_BAD_RECORD, EXIT_UNTRUSTED = 0, 1, 2, 3
# a record's kinds: the code breaks the rule on purpose, or the checker reports a
# breach where the code meets the rule (recorded with the evidence, not deviated)
KINDS = ("deviation", "false positive")
RECORD_TEXT = ("id", "rule", "kind", "where", "why", "guard", "by", "date")   # required strings
RECORD_OPTIONAL = ("evidence", "cost", "approval")                          # optional strings


class Untrusted(RuntimeError):
    """The analysis ran short or could not run: its counts are not a result."""


@dataclass(frozen=True)
class Finding:
    id: str          # cppcheck's check id, or misra-c2012-<rule>
    severity: str    # cppcheck's: error, warning, style, performance, portability, information
    file: str        # repository-relative path of the primary location
    line: int
    msg: str

    @property
    def rule(self) -> str | None:
        return self.id[len(MISRA_PREFIX):] if self.id.startswith(MISRA_PREFIX) else None


class BadRecord(ValueError):
    """A deviation record that does not say what a record must."""


@dataclass(frozen=True)
class Record:
    """One record of deviations.toml (see the docstring and that file)."""
    id: str
    rule: str
    kind: str
    files: tuple[str, ...]
    findings: int
    where: str
    why: str
    guard: str
    by: str
    date: str
    evidence: str = ""
    cost: str = ""
    approval: str = ""


def load_records(path: Path | None = None, table: dict | None = None, root: Path = ROOT) -> list[Record]:
    """The records of path (default DEVIATIONS), each checked: a rule of the
    table (no deviation of a mandatory rule), a kind, files under csrc/control
    that exist, the findings it was written for, and a place, a reason, a
    guard, who and when in words. BadRecord names the record, the field, its
    value and what is allowed."""
    path = DEVIATIONS if path is None else path
    table = rule_table() if table is None else table
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise BadRecord(f"{path.name}: cannot be read: {exc}") from exc
    unknown_top = sorted(set(data) - {"record"})
    if unknown_top:
        raise BadRecord(f"{path.name}: top-level {unknown_top[0]!r}: only [[record]] tables are allowed")
    rows = data.get("record", [])
    if not isinstance(rows, list):
        raise BadRecord(f"{path.name}: record must be an array of tables ([[record]])")
    out, seen = [], set()
    for n, row in enumerate(rows, 1):
        name = f"{path.name}: record {n} ({row.get('id', 'no id')})"

        def bad(field, allowed):
            return BadRecord(f"{name}: {field} = {row.get(field)!r}: {allowed}")

        extra = sorted(set(row) - {*RECORD_TEXT, *RECORD_OPTIONAL, "files", "findings"})
        if extra:
            raise bad(extra[0], "not a field of a record (" + ", ".join((*RECORD_TEXT, "files", "findings", *RECORD_OPTIONAL)) + ")")
        for field in RECORD_TEXT:
            if not isinstance(row.get(field), str) or not row[field].strip():
                raise bad(field, "must be given, in words")
        for field in RECORD_OPTIONAL:
            if field in row and (not isinstance(row[field], str) or not row[field].strip()):
                raise bad(field, "if given, in words")
        if row["id"] in seen:
            raise bad("id", "must be unique")
        seen.add(row["id"])
        if row["rule"] not in table:
            raise bad("rule", f"must be a MISRA C:2012 rule of {RULES_CSV.name}")
        if row["kind"] not in KINDS:
            raise bad("kind", f"must be one of {', '.join(KINDS)}")
        if row["kind"] == "deviation" and table[row["rule"]][0] == "Mandatory":
            raise bad("rule", "a mandatory rule permits no deviation")
        files = row.get("files")
        if not isinstance(files, list) or not files or not all(isinstance(f, str) for f in files):
            raise bad("files", f"must list the files (paths under {CONTROL}/) whose findings the record covers")
        for f in files:
            if not f.startswith(CONTROL + "/") or not (root / f).is_file():
                raise BadRecord(f"{name}: files has {f!r}: must be an existing file under {CONTROL}/")
        if not isinstance(row.get("findings"), int) or isinstance(row["findings"], bool) or row["findings"] < 1:
            raise bad("findings", "must be the number of findings the record was written for, at least 1")
        try:
            datetime.date.fromisoformat(row["date"])
        except ValueError:
            raise bad("date", "must be a date, YYYY-MM-DD") from None
        out.append(Record(row["id"], row["rule"], row["kind"], tuple(files), row["findings"],
                          *(row[f].strip() for f in RECORD_TEXT[3:]),
                          *(row.get(f, "").strip() for f in RECORD_OPTIONAL)))
    return out


def covered(findings: list[Finding], records: list[Record]) -> dict[str, list[Finding]]:
    """Per record id, the findings it covers: its rule's, in its files."""
    return {r.id: [f for f in findings if f.rule == r.rule and f.file in r.files] for r in records}


def record_problems(findings: list[Finding], records: list[Record]) -> list[str]:
    """What makes the records untrue of the findings, one line each (empty:
    every record is in force): a record with no finding of its rule left in
    its files (stale), one covering another number than it was written for,
    and findings two records claim."""
    out = []
    cov = covered(findings, records)
    for r in records:
        got = cov[r.id]
        if not got:
            out.append(f"stale record {r.id}: no finding of rule {r.rule} left in {', '.join(r.files)}: "
                       "remove the record (the code meets the rule, or the checker no longer reports it)")
        elif len(got) != r.findings:
            where = ", ".join(sorted(f"{f.file}:{f.line}" for f in got))
            out.append(f"record {r.id} (rule {r.rule}) was written for {r.findings} finding(s), covers {len(got)} now "
                       f"({where}): review it and set its findings")
    claimed: dict[tuple, str] = {}
    for r in records:
        for f in cov[r.id]:
            key = (f.id, f.file, f.line, f.msg)
            if key in claimed and claimed[key] != r.id:
                out.append(f"{f.file}:{f.line} rule {r.rule}: covered by records {claimed[key]} and {r.id}: one is enough")
            claimed.setdefault(key, r.id)
    return out


def open_findings(findings: list[Finding], records: list[Record], table: dict) -> list[Finding]:
    """Mandatory and required findings neither cleared nor recorded."""
    cov = {id(f) for fs in covered(findings, records).values() for f in fs}
    return [f for f in findings if f.rule is not None and table[f.rule][0] != "Advisory" and id(f) not in cov]


def rule_table() -> dict[str, tuple[str, str]]:
    """rule -> (category, summary), from misra_c2012.csv (comment lines start with #)."""
    with open(RULES_CSV, newline="") as f:
        rows = list(csv.DictReader(ln for ln in f if not ln.startswith("#")))
    return {r["rule"]: (r["category"], r["summary"]) for r in rows}


def rule_key(rule: str) -> tuple[int, int]:
    a, b = rule.split(".")
    return int(a), int(b)


def rule_texts(table: dict[str, tuple[str, str]]) -> str:
    """The rule-texts file in the layout the addon reads (a heading, then per
    rule a 'Rule N.M Category' line and a text line starting with a capital)."""
    out = ["Summaries of the rules, written for fullspeed (tools/static_check/misra_c2012.csv)", "",
           "Appendix A Summary of guidelines", ""]
    for rule in sorted(table, key=rule_key):
        cat, summary = table[rule]
        out += [f"Rule {rule} {cat}", summary[:1].upper() + summary[1:], ""]
    return "\n".join(out)


def cppcheck_version(exe: str) -> str:
    out = subprocess.run([exe, "--version"], capture_output=True, text=True, check=True).stdout
    m = re.search(r"(\d+(?:\.\d+)+)", out)
    if not m:
        raise Untrusted(f"cppcheck --version said {out.strip()!r}: no version number in it")
    return m.group(1)


def run_cppcheck(exe: str, version: str, folders, include: str, platform: str, jobs: int,
                 root: Path = ROOT) -> list[Finding]:
    """One cppcheck run (with the addon) over the .c files of folders (relative
    to root); its findings in those folders. Results are cached in
    root/build/cppcheck/<key>
    (cppcheck's build dir: a file analysed before with the same tokens is
    not analysed again), the key covering the version, the options and the
    rule texts and the headers' contents."""
    table = rule_table()
    texts = rule_texts(table)
    files = sorted(str(p.relative_to(root)) for d in folders for p in (root / d).glob("*.c"))
    if not files:
        raise Untrusted(f"no .c file under {', '.join(folders)}")
    opts = ["--std=c99", f"--platform={platform}", f"--enable={ENABLE}", f"-I{include}", "--xml", "-q"]
    # the headers' contents in the key: cppcheck's build dir re-analyses a .c file whose own tokens changed,
    # but kept the whole-program (CTU) records of a header as it was, and an edited header then counted
    # findings of both versions (typedef and tag names "not unique", declarations that were split)
    headers = hashlib.sha256()
    for h in sorted(p for d in {*folders, include} for p in (root / d).glob("*.h")):
        headers.update(h.name.encode() + b"\0" + h.read_bytes())
    key = hashlib.sha256(json.dumps([version, opts, texts, headers.hexdigest()]).encode()).hexdigest()[:16]
    cache = root / "build" / "cppcheck" / key
    cache.mkdir(parents=True, exist_ok=True)
    (cache / "misra-rules.txt").write_text(texts)
    addon = cache / "misra.json"
    addon.write_text(json.dumps({"script": "misra.py", "args": [f"--rule-texts={cache / 'misra-rules.txt'}"]}))
    cmd = [exe, *opts, f"--addon={addon}", f"--cppcheck-build-dir={cache}", f"-j{jobs}", *files]
    proc = subprocess.run(cmd, cwd=root, capture_output=True, text=True)
    if proc.returncode != 0:
        raise Untrusted(f"cppcheck exited {proc.returncode} on {', '.join(folders)}: {proc.stderr.strip()[-400:]}")
    if "<results" not in proc.stderr:
        raise Untrusted(f"cppcheck wrote no XML results for {', '.join(folders)}: {proc.stderr.strip()[-400:]}")
    xml_text = proc.stderr[proc.stderr.index("<?xml"):] if "<?xml" in proc.stderr else proc.stderr
    found = parse_xml(xml_text, root)
    failed = [f for f in found if f.id in TOOL_FAILURES]
    if failed:
        f = failed[0]
        raise Untrusted(f"cppcheck could not analyse {f.file}:{f.line} ({f.id}: {f.msg})"
                        + (f" and {len(failed) - 1} more" if len(failed) > 1 else ""))
    unknown = sorted({f.rule for f in found if f.rule is not None and f.rule not in table})
    if unknown:
        raise Untrusted(f"the addon reported rules {', '.join(unknown)}, absent from {RULES_CSV.name}")
    return [f for f in found if any(f.file.startswith(d + "/") for d in folders)]


def parse_xml(text: str, root: Path = ROOT) -> list[Finding]:
    """cppcheck's XML (version 2) results: one Finding per <error>, located
    at its first <location> (cppcheck lists the primary one first)."""
    out = []
    for e in ET.fromstring(text).iter("error"):
        loc = e.find("location")
        path = loc.get("file", "") if loc is not None else ""
        p = Path(path)
        if p.is_absolute() and p.is_relative_to(root):
            path = str(p.relative_to(root))
        out.append(Finding(e.get("id", ""), e.get("severity", ""), path,
                           int(loc.get("line", "0")) if loc is not None else 0, e.get("msg", "")))
    return out


def analyse(exe: str = "cppcheck", jobs: int = 2) -> dict:
    """Both runs: {'cppcheck': version, run name: [Finding, ...]}."""
    if shutil.which(exe) is None:
        raise Untrusted(f"{exe} not found (apt-get install cppcheck; .ci/run installs it as root)")
    version = cppcheck_version(exe)
    res = {"cppcheck": version}
    for name, folders, include, platform in RUNS:
        res[name] = run_cppcheck(exe, version, folders, include, platform, jobs)
    return res


def counts(findings: list[Finding]) -> dict[str, int]:
    """Findings per id (MISRA rule or cppcheck check), ids sorted."""
    c = Counter(f.id for f in findings)
    return {k: c[k] for k in sorted(c, key=id_key)}


def id_key(i: str):
    """MISRA rules first in rule order, then cppcheck's checks by name."""
    if i.startswith(MISRA_PREFIX):
        return (0, rule_key(i[len(MISRA_PREFIX):]), "")
    return (1, (0, 0), i)


def held(findings: list[Finding], run: str) -> list[Finding]:
    """The findings the ratchet holds for a run: all of csrc/control's, and
    cppcheck's own (not the addon's) in plant and sim."""
    return findings if run == CONTROL else [f for f in findings if f.rule is None]


def ratchet(res: dict, baseline: dict) -> list[str]:
    """What broke the ratchet, one line each (empty: it holds)."""
    broken = []
    for name, *_ in RUNS:
        now = counts(held(res[name], name))
        base = baseline["counts"].get(name, {})
        for i, n in now.items():
            if n > base.get(i, 0):
                where = sorted({f"{f.file}:{f.line}" for f in res[name] if f.id == i})
                broken.append(f"{name}: {i} {base.get(i, 0)} -> {n} (at {', '.join(where[:8])}"
                              + (" ..." if len(where) > 8 else "") + ")")
        if name != CONTROL:
            for f in res[name]:
                if f.severity in ("error", "warning"):
                    broken.append(f"{name}: cppcheck {f.severity} {f.id} at {f.file}:{f.line}: {f.msg} "
                                  "(plant and sim are held clean of errors and warnings)")
    return broken


def slack(res: dict, baseline: dict) -> list[str]:
    """Baseline counts above today's: the ratchet can be tightened."""
    out = []
    for name, *_ in RUNS:
        now = counts(held(res[name], name))
        for i, n in baseline["counts"].get(name, {}).items():
            if now.get(i, 0) < n:
                out.append(f"{name}: {i} {n} -> {now.get(i, 0)}")
    return out


def load_baseline() -> dict:
    return json.loads(BASELINE.read_text())


def baseline_of(res: dict) -> dict:
    return {"cppcheck": res["cppcheck"],
            "counts": {name: counts(held(res[name], name)) for name, *_ in RUNS}}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write-doc", action="store_true", help=f"write {DOC.relative_to(ROOT)}")
    ap.add_argument("--write-baseline", action="store_true", help=f"record today's counts in {BASELINE.name}")
    ap.add_argument("--cppcheck", default="cppcheck", help="the cppcheck executable")
    ap.add_argument("-j", "--jobs", type=int, default=2, help="cppcheck's parallel jobs")
    a = ap.parse_args(argv)
    if a.jobs < 1:
        print(f"--jobs = {a.jobs}: must be at least 1", file=sys.stderr)
        return 2
    try:
        records = load_records()
    except BadRecord as exc:
        print(f"static check not run: {exc}", file=sys.stderr)
        return EXIT_BAD_RECORD
    try:
        res = analyse(a.cppcheck, a.jobs)
    except Untrusted as exc:
        print(f"static check not run: {exc}", file=sys.stderr)
        return EXIT_UNTRUSTED
    if a.write_baseline:
        write_atomic(BASELINE, json.dumps(baseline_of(res), indent=1) + "\n")
        print(f"wrote {BASELINE.relative_to(ROOT)}")
    baseline = load_baseline()
    if a.write_doc:
        sys.path.insert(0, str(HERE))   # the report is this folder's other module, which imports this one
        import report
        write_atomic(DOC, report.markdown(res, baseline, rule_table(), records))
        print(f"wrote {DOC.relative_to(ROOT)}")
    table = rule_table()
    for name, *_ in RUNS:
        own = Counter(f.severity for f in res[name] if f.rule is None)
        cats = Counter(table[f.rule][0] for f in res[name] if f.rule is not None)
        print(f"{name}: cppcheck {sum(own.values())} ({', '.join(f'{s} {n}' for s, n in sorted(own.items())) or 'clean'});"
              f" MISRA {sum(cats.values())} ({', '.join(f'{c.lower()} {cats[c]}' for c in CATEGORIES)})")
    if res["cppcheck"] != baseline["cppcheck"]:
        print(f"static check not comparable: cppcheck {res['cppcheck']}, baseline measured with "
              f"{baseline['cppcheck']} (counts move between versions; rerun with --write-baseline on purpose)",
              file=sys.stderr)
        return EXIT_UNTRUSTED
    broken = ratchet(res, baseline)
    for line in broken:
        print(f"ratchet: {line}", file=sys.stderr)
    for line in slack(res, baseline):
        print(f"below baseline (tighten with --write-baseline): {line}")
    print("ratchet holds" if not broken else f"ratchet broken: {len(broken)} count(s) grew")
    problems = record_problems(res[CONTROL], records)
    for line in problems:
        print(f"records: {line}", file=sys.stderr)
    n_cov = sum(len(v) for v in covered(res[CONTROL], records).values())
    n_open = len(open_findings(res[CONTROL], records, table))
    print(f"records ({DEVIATIONS.name}): {len(records)}, covering {n_cov} finding(s); "
          f"mandatory and required findings neither cleared nor recorded: {n_open}"
          + ("" if not problems else f"; {len(problems)} record problem(s)"))
    return EXIT_RATCHET if broken or problems else EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
