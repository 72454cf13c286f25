"""Tests of the static check, tools/static_check/static_check.py (cppcheck
and its MISRA addon over the C core, against a ratchet).

What could be wrong with it: a rule table that misses a rule the addon
reports (its findings then fall in no category) or files one under the
wrong category; a parser that loses findings or puts them on the wrong
line; a ratchet that lets a count grow, or lets a warning into the
simulator; a run that failed and reads as clean; a deviation record that
does not say which rule, where or why, or one that stays in force after
its findings are gone. And on the tree itself: a count held by the
ratchet that grew, a required finding neither cleared nor recorded, a
record no longer true. Tests needing cppcheck skip, with the reason, where
it is absent (.ci/run installs it as root).
"""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "static_check"
sc = load_script(TOOL / "static_check.py", "static_check")
HAVE = shutil.which("cppcheck") is not None
needs_cppcheck = pytest.mark.skipif(not HAVE, reason="cppcheck not found (apt-get install cppcheck; .ci/run does as root)")


def _addon() -> Path | None:
    """The installed misra.py, beside cppcheck's other addons."""
    for d in (Path("/usr/lib/x86_64-linux-gnu/cppcheck/addons"), Path("/usr/lib/aarch64-linux-gnu/cppcheck/addons"),
              Path("/usr/share/cppcheck/addons"), Path("/usr/lib/cppcheck/addons")):
        if (d / "misra.py").is_file():
            return d / "misra.py"
    return None


def test_rule_table_is_misra_c2012_with_its_amendments():
    """158 rules (143 of 2012, 14 of Amendment 1, 1 of Amendment 2), each
    in one of the three categories, numbered without gaps per section."""
    table = sc.rule_table()
    assert len(table) == 158
    assert {c for c, _ in table.values()} == set(sc.CATEGORIES)
    for sec in {sc.rule_key(r)[0] for r in table}:
        nums = sorted(sc.rule_key(r)[1] for r in table if sc.rule_key(r)[0] == sec)
        assert nums == list(range(1, len(nums) + 1)), sec
    # the mandatory rules are few and named: none of the form-only pass's required ones among them
    mandatory = {r for r, (c, _) in table.items() if c == "Mandatory"}
    assert mandatory == {"9.1", "12.5", "13.6", "17.3", "17.4", "17.6", "19.1", "21.13", "21.17", "21.18",
                         "21.19", "21.20", "22.2", "22.4", "22.5", "22.6"}


@pytest.mark.skipif(_addon() is None, reason="cppcheck's misra.py addon not found")
def test_rule_table_covers_every_rule_the_addon_reports():
    src = _addon().read_text()
    reported = {f"{a}.{b}" for a, b in re.findall(r"reportError\([^()]*(?:\([^()]*\)[^()]*)*,\s*(\d+),\s*(\d+)\)", src)}
    reported |= {f"{int(n) // 100}.{int(n) % 100}" for n in re.findall(r"executeCheck\((\d+),", src)}
    assert len(reported) > 100, "the addon's rule numbers were not read"
    assert reported <= set(sc.rule_table())


def test_rule_texts_read_as_the_addon_reads_them():
    """Every rule's line carries its category last and its text starts with a
    capital or a # (the addon skips a text that does not)."""
    text = sc.rule_texts(sc.rule_table())
    lines = text.splitlines()
    assert any("Appendix A" in ln and ln.find("Summary of guidelines") >= 10 for ln in lines)
    heads = [i for i, ln in enumerate(lines) if ln.startswith("Rule ")]
    assert len(heads) == 158
    for i in heads:
        assert re.match(r"^Rule \d+\.\d+ (Mandatory|Required|Advisory)$", lines[i])
        assert re.match(r"^[#A-Z]", lines[i + 1])


def _f(i, sev="style", file="csrc/control/a.c", line=1):
    return sc.Finding(i, sev, file, line, "m")


def test_ratchet_catches_growth_a_new_rule_and_a_simulator_warning():
    sim = sc.RUNS[1][0]
    base = {"cppcheck": "x", "counts": {sc.CONTROL: {"misra-c2012-15.6": 2}, sim: {}}}
    ok = {sc.CONTROL: [_f("misra-c2012-15.6"), _f("misra-c2012-15.6", line=2)],
          sim: [_f("misra-c2012-10.4", file="csrc/sim/b.c")]}   # the simulator's MISRA findings are not held
    assert sc.ratchet(ok, base) == []
    grown = {**ok, sc.CONTROL: ok[sc.CONTROL] + [_f("misra-c2012-15.6", line=3)]}
    assert [b for b in sc.ratchet(grown, base) if "15.6 2 -> 3" in b and "a.c:3" in b]
    new = {**ok, sc.CONTROL: ok[sc.CONTROL] + [_f("misra-c2012-14.4", line=4)]}
    assert [b for b in sc.ratchet(new, base) if "14.4 0 -> 1" in b]
    base_w = {**base, "counts": {**base["counts"], sim: {"uninitvar": 1}}}   # a baseline cannot admit one
    warned = {**ok, sim: [_f("uninitvar", "warning", "csrc/sim/b.c", 7)]}
    assert [b for b in sc.ratchet(warned, base_w) if "warning uninitvar at csrc/sim/b.c:7" in b]
    fewer = {**ok, sc.CONTROL: ok[sc.CONTROL][:1]}
    assert sc.ratchet(fewer, base) == [] and sc.slack(fewer, base) == [f"{sc.CONTROL}: misra-c2012-15.6 2 -> 1"]


PLANTED = """\
int f(int x)
{
    int y;
    if (x > 0) y = 1;
    return y;
}
"""


@needs_cppcheck
def test_planted_findings_are_counted_at_their_lines_and_categories(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "planted.c").write_text(PLANTED)
    version = sc.cppcheck_version("cppcheck")
    found = sc.run_cppcheck("cppcheck", version, ("src",), "src", "unix64", 1, root=tmp_path)
    at = {(f.id, f.line) for f in found}
    assert ("misra-c2012-15.6", 4) in at          # the if's body without braces
    assert ("misra-c2012-14.4", 4) not in at      # x > 0 is boolean
    assert any(f.id == "uninitvar" and f.line == 5 and f.severity in ("error", "warning") for f in found)
    table = sc.rule_table()
    assert table["15.6"][0] == "Required" and table["9.1"][0] == "Mandatory"
    assert all(f.file == "src/planted.c" for f in found)


@needs_cppcheck
def test_the_cache_sees_a_changed_header(tmp_path):
    """Results are cached per file (cppcheck's build dir): a finding a
    header gains must still be counted though the .c file is unchanged."""
    src = tmp_path / "src"
    src.mkdir()
    (src / "h.h").write_text("static inline int g(int x) { return x; }\n")
    (src / "a.c").write_text('#include "h.h"\nint f(int x);\nint f(int x) { return g(x); }\n')
    version = sc.cppcheck_version("cppcheck")
    def run():
        return sc.run_cppcheck("cppcheck", version, ("src",), "src", "unix64", 1, root=tmp_path)
    assert not [f for f in run() if f.id == "misra-c2012-17.8"]
    (src / "h.h").write_text("static inline int g(int x) { x = x + 1; return x; }\n")   # a parameter assigned
    assert [f for f in run() if f.id == "misra-c2012-17.8" and f.file == "src/h.h"]


@needs_cppcheck
def test_a_file_cppcheck_cannot_parse_is_no_result(tmp_path):
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "broken.c").write_text("int f(void) { return (1; }\n")
    with pytest.raises(sc.Untrusted, match="could not analyse src/broken.c"):
        sc.run_cppcheck("cppcheck", sc.cppcheck_version("cppcheck"), ("src",), "src", "unix64", 1, root=tmp_path)


@pytest.fixture(scope="module")
def tree():
    """Both runs on the tree, once for the tests that read them, with the
    cppcheck version the baseline was measured with (counts move between
    versions)."""
    if not HAVE:
        pytest.skip("cppcheck not found (apt-get install cppcheck; .ci/run does as root)")
    base = sc.load_baseline()
    version = sc.cppcheck_version("cppcheck")
    if version != base["cppcheck"]:
        pytest.skip(f"cppcheck {version}, baseline measured with {base['cppcheck']}: counts not comparable")
    return sc.analyse(), base


@needs_cppcheck
def test_the_tree_holds_the_ratchet(tree):
    """csrc/control gains no finding of any rule or check; csrc/plant and
    csrc/sim stay clean under cppcheck's own analysis."""
    res, base = tree
    assert sc.ratchet(res, base) == []
    sim = sc.RUNS[1][0]
    assert not [f for f in res[sim] if f.rule is None]


@needs_cppcheck
def test_every_required_finding_left_is_recorded_and_every_record_in_force(tree):
    """Issue 39: no mandatory or required finding in csrc/control without a
    record, and no record that is stale or covers another number of
    findings than it was written for."""
    res, _ = tree
    records = sc.load_records()
    control = res[sc.CONTROL]
    assert sc.record_problems(control, records) == []
    left = sc.open_findings(control, records, sc.rule_table())
    assert left == [], [f"{f.file}:{f.line} {f.id}" for f in left]


# a record as deviations.toml holds it (its file must exist under csrc/control)
RECORD = {"id": "DEV-T", "rule": "17.2", "kind": "deviation", "files": ["csrc/control/fs_transforms.c"], "findings": 2,
          "where": "fs_cis -> cis_far -> fs_cis", "why": "the common path keeps no stack frame",
          "guard": "the second call's argument is wrapped to (-pi, pi]", "by": "a test", "date": "2026-11-29"}


def _toml(rows) -> str:
    out = []
    for row in rows:
        out.append("[[record]]")
        for k, v in row.items():
            val = "[" + ", ".join(f'"{x}"' for x in v) + "]" if isinstance(v, list) else (str(v) if isinstance(v, int) else f'"{v}"')
            out.append(f"{k} = {val}")
        out.append("")
    return "\n".join(out)


def _load(tmp_path, rows):
    p = tmp_path / "deviations.toml"
    p.write_text(_toml(rows))
    return sc.load_records(p)


def test_the_repositorys_records_name_a_rule_a_place_and_a_reason():
    """Each record of tools/static_check/deviations.toml: a MISRA C:2012 rule
    of the table, existing files under csrc/control, and where, why, the guard,
    who and when in words."""
    records = sc.load_records()
    table = sc.rule_table()
    assert records, "no record: issue 39 keeps 5.7, 14.1, 17.2 and 20.7 findings, each needs one"
    assert len({r.id for r in records}) == len(records)
    for r in records:
        assert r.rule in table and r.kind in sc.KINDS
        assert r.files and all((ROOT / f).is_file() and f.startswith("csrc/control/") for f in r.files)
        assert r.where and r.why and r.guard and r.by and r.date
    # the rules the form-only pass keeps are the ones recorded
    assert {r.rule for r in records} >= {"5.7", "14.1", "17.2", "20.7"}


@pytest.mark.parametrize("field, value, says", [
    ("rule", None, "rule = None: must be given"),          # no rule
    ("rule", "99.1", "must be a MISRA C:2012 rule"),
    ("where", "  ", "where = '  ': must be given, in words"),   # no place
    ("files", [], "must list the files"),
    ("files", ["csrc/control/no_such_file.c"], "must be an existing file under csrc/control/"),
    ("files", ["csrc/sim/fs_sim.c"], "must be an existing file under csrc/control/"),
    ("why", None, "why = None: must be given"),             # no reason
    ("guard", "", "guard = '': must be given"),
    ("kind", "waiver", "must be one of deviation, false positive"),
    ("findings", 0, "at least 1"),
    ("date", "yesterday", "YYYY-MM-DD"),
    ("reason", "a field of another name", "not a field of a record"),
])
def test_a_record_without_a_rule_a_place_or_a_reason_is_refused(tmp_path, field, value, says):
    row = dict(RECORD)
    if value is None:
        del row[field]
    else:
        row[field] = value
    with pytest.raises(sc.BadRecord, match=re.escape(says)) as exc:
        _load(tmp_path, [row])
    assert "record 1 (DEV-T)" in str(exc.value)
    assert _load(tmp_path, [RECORD])[0].rule == "17.2"   # the same record, whole, is read


def test_a_mandatory_rule_cannot_be_deviated_and_ids_are_unique(tmp_path):
    with pytest.raises(sc.BadRecord, match="a mandatory rule permits no deviation"):
        _load(tmp_path, [{**RECORD, "rule": "9.1"}])
    assert _load(tmp_path, [{**RECORD, "rule": "9.1", "kind": "false positive"}])[0].kind == "false positive"
    with pytest.raises(sc.BadRecord, match="must be unique"):
        _load(tmp_path, [RECORD, dict(RECORD)])


def test_a_record_whose_findings_are_gone_is_stale(tmp_path):
    """A record for a rule with no findings left in its files is reported
    stale; one covering another number than it was written for is reported
    for review; one whose findings are all there is in force."""
    rec = _load(tmp_path, [RECORD, {**RECORD, "id": "FP-T", "rule": "5.7", "kind": "false positive",
                                    "files": ["csrc/control/fs_types.h"], "findings": 1}])
    f_cis = [_f("misra-c2012-17.2", file="csrc/control/fs_transforms.c", line=60),
             _f("misra-c2012-17.2", file="csrc/control/fs_transforms.c", line=83)]
    f_tag = [_f("misra-c2012-5.7", file="csrc/control/fs_types.h", line=44)]
    other = [_f("misra-c2012-17.2", file="csrc/control/fs_drive.c", line=9)]   # another file: not covered
    assert sc.record_problems(f_cis + f_tag, rec) == []
    table = sc.rule_table()
    assert sc.open_findings(f_cis + f_tag + other, rec, table) == other
    # the 5.7 findings gone (the enums tagged, or the checker mended): FP-T is stale
    stale = sc.record_problems(f_cis, rec)
    assert len(stale) == 1 and stale[0].startswith("stale record FP-T") and "rule 5.7" in stale[0]
    # every finding gone: both stale
    assert [p.split()[2] for p in sc.record_problems([], rec)] == ["DEV-T:", "FP-T:"]
    # one of the two recursion findings gone: DEV-T covers 1, written for 2
    moved = sc.record_problems(f_cis[:1] + f_tag, rec)
    assert len(moved) == 1 and "DEV-T" in moved[0] and "written for 2" in moved[0] and "covers 1" in moved[0]


def test_the_doc_lists_the_records_with_their_counts(tmp_path):
    sys.path.insert(0, str(TOOL))
    import report
    rec = _load(tmp_path, [RECORD])
    control = [_f("misra-c2012-17.2", "style", "csrc/control/fs_transforms.c", 60),
               _f("misra-c2012-17.2", "style", "csrc/control/fs_transforms.c", 83),
               _f("misra-c2012-15.6", "style", "csrc/control/fs_drive.c", 5)]
    res = {"cppcheck": "2.10", sc.CONTROL: control, sc.RUNS[1][0]: []}
    base = {"cppcheck": "2.10", "counts": {sc.CONTROL: {}, sc.RUNS[1][0]: {}}}
    md = report.markdown(res, base, sc.rule_table(), rec)
    assert "| DEV-T | 17.2 | Required | deviation | fs_transforms.c | 2 |" in md
    assert "### DEV-T: rule 17.2" in md and "- Guard: the second call's argument is wrapped" in md
    assert "covering 2 of csrc/control's mandatory and required findings; neither cleared nor recorded: 1." in md
    stale = report.markdown({**res, sc.CONTROL: control[2:]}, base, sc.rule_table(), rec)
    assert "| DEV-T | 17.2 | Required | deviation | fs_transforms.c | 0 (stale: none left) |" in stale
    assert "- stale record DEV-T" in stale


def test_the_command_refuses_a_malformed_record_file(tmp_path, monkeypatch, capsys):
    """Exit 2 before any analysis, naming the record and the field."""
    bad = tmp_path / "deviations.toml"
    bad.write_text(_toml([{k: v for k, v in RECORD.items() if k != "why"}]))
    monkeypatch.setattr(sc, "DEVIATIONS", bad)
    assert sc.main(["--cppcheck", "no-such-cppcheck"]) == sc.EXIT_BAD_RECORD
    err = capsys.readouterr().err
    assert "record 1 (DEV-T): why = None: must be given" in err and "not found" not in err


def test_the_command_fails_on_a_stale_record(tmp_path, monkeypatch, capsys):
    """The check's exit status: 0 with the record's findings there, 1 once
    they are gone (the record must go too), the ratchet holding both times."""
    recs = tmp_path / "deviations.toml"
    recs.write_text(_toml([RECORD]))
    monkeypatch.setattr(sc, "DEVIATIONS", recs)
    sim = sc.RUNS[1][0]
    cis = [_f("misra-c2012-17.2", file="csrc/control/fs_transforms.c", line=60),
           _f("misra-c2012-17.2", file="csrc/control/fs_transforms.c", line=83)]
    monkeypatch.setattr(sc, "load_baseline", lambda: {"cppcheck": "2.10", "counts": {sc.CONTROL: {"misra-c2012-17.2": 2}, sim: {}}})
    monkeypatch.setattr(sc, "analyse", lambda exe="cppcheck", jobs=2: {"cppcheck": "2.10", sc.CONTROL: cis, sim: []})
    assert sc.main([]) == sc.EXIT_OK
    assert "records (deviations.toml): 1, covering 2 finding(s)" in capsys.readouterr().out
    monkeypatch.setattr(sc, "analyse", lambda exe="cppcheck", jobs=2: {"cppcheck": "2.10", sc.CONTROL: [], sim: []})
    assert sc.main([]) == sc.EXIT_RATCHET
    out = capsys.readouterr()
    assert "records: stale record DEV-T: no finding of rule 17.2 left" in out.err and "ratchet holds" in out.out
