"""Tests of the static check, tools/static_check/static_check.py (cppcheck
and its MISRA addon over the C core, against a ratchet).

What could be wrong with it: a rule table that misses a rule the addon
reports (its findings then fall in no category) or files one under the
wrong category; a parser that loses findings or puts them on the wrong
line; a ratchet that lets a count grow, or lets a warning into the
simulator; a run that failed and reads as clean. And on the tree itself:
a count held by the ratchet that grew. Tests needing cppcheck skip, with
the reason, where it is absent (.ci/run installs it as root).
"""
from __future__ import annotations

import importlib.util
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "static_check"


def _load():
    spec = importlib.util.spec_from_file_location("static_check", TOOL / "static_check.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


sc = _load()
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


@needs_cppcheck
def test_the_tree_holds_the_ratchet():
    """csrc/control gains no finding of any rule or check; csrc/plant and
    csrc/sim stay clean under cppcheck's own analysis. Counted with the
    cppcheck version the baseline was measured with (counts move between
    versions)."""
    base = sc.load_baseline()
    version = sc.cppcheck_version("cppcheck")
    if version != base["cppcheck"]:
        pytest.skip(f"cppcheck {version}, baseline measured with {base['cppcheck']}: counts not comparable")
    res = sc.analyse()
    assert sc.ratchet(res, base) == []
    sim = sc.RUNS[1][0]
    assert not [f for f in res[sim] if f.rule is None]


def test_the_command_says_when_it_cannot_be_trusted():
    proc = subprocess.run([sys.executable, str(TOOL / "static_check.py"), "--cppcheck", "no-such-cppcheck"],
                          capture_output=True, text=True, cwd=ROOT)
    assert proc.returncode == sc.EXIT_UNTRUSTED and "no-such-cppcheck not found" in proc.stderr
