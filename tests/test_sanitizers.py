"""The whole C core (control, plant, sim) under AddressSanitizer and
UndefinedBehaviorSanitizer, as Python drives it (issue 10, item 6).

tests/sanitize_core.py builds fullspeed._core with
-fsanitize=address,undefined,float-cast-overflow -fno-sanitize-recover=all
into a temporary directory, once for this module; tests/sanitized_workload.py
then runs in one subprocess on that build, with the ASan runtime preloaded:
every catalog scenario to its end, and the runner's error paths (refused
configurations, the overcurrent, NaN and loss-of-lock stops, a run advanced
in small chunks into a tiny trace buffer). Any sanitizer report aborts the
subprocess; the test fails on it, on a non-zero exit, on a scenario that is
missing or short of samples, and on a failed check. Two canaries break the
API's contract on purpose and must be caught, so a build or a load that
lost its instrumentation cannot pass silently.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

import sanitize_core
import sanitized_workload
from fullspeed.design.scenario import load_scenario
from fullspeed.model.scenario import scenario_names

WORKLOAD = Path(sanitized_workload.__file__).resolve()
REPORTS = ("ERROR: AddressSanitizer", "ERROR: LeakSanitizer", "runtime error:")


@pytest.fixture(scope="module")
def sanitized_core(tmp_path_factory) -> Path:
    why = sanitize_core.missing_toolchain()
    if why is not None:
        pytest.skip(why)
    return sanitize_core.build(tmp_path_factory.mktemp("sanitized_core"))


def _run(core: Path, *args: str):
    return sanitize_core.run(core, WORKLOAD, args, timeout=600)


def _tail(text: str, n: int = 6000) -> str:
    return text if len(text) <= n else "...\n" + text[-n:]


def expected_rows(name: str) -> int:
    """Recorded samples of a catalog scenario run to its end: sample k is
    taken while k < fs_sim_steps(T) = ceil(T / Ts - 1/2) (fs_sim_run), every decimation-th kept."""
    d = load_scenario(name).data
    Ts = 1.0 / d["converter"]["f_pwm"]
    if d["timing"]["sampling"] == "double":
        Ts /= 2
    n = math.ceil(d["duration"] / Ts - 0.5)
    dec = d["trace"]["decimation"]
    return -(-n // dec)


@pytest.mark.parametrize("which, report", [
    ("asan", "ERROR: AddressSanitizer: heap-buffer-overflow"),
    ("ubsan", "runtime error: "),
], ids=["asan", "ubsan"])
def test_the_sanitizers_are_live_in_the_loaded_core(sanitized_core, which, report):
    r = _run(sanitized_core, "--canary", which)
    assert r.returncode != 0 and report in r.stderr, (
        f"the {which} canary was not caught (exit {r.returncode}):\n{_tail(r.stdout)}\n{_tail(r.stderr)}")
    assert "not caught" not in r.stdout


def test_scenarios_and_error_paths_run_clean_under_the_sanitizers(sanitized_core):
    r = _run(sanitized_core)
    found = [s for s in REPORTS if s in r.stderr]
    assert not found and r.returncode == 0, (
        f"exit {r.returncode}, sanitizer reports {found}; the last lines:\n{_tail(r.stdout, 2000)}\n{_tail(r.stderr)}")
    rows = [json.loads(line) for line in r.stdout.splitlines() if line.startswith("{")]
    by_kind: dict[str, list] = {}
    for row in rows:
        by_kind.setdefault(row["kind"], []).append(row)

    # the sanitized build is what ran
    assert [c["file"] for c in by_kind.get("core", [])] == [str(sanitized_core)]

    # every catalog scenario, to its end
    ran = {s["name"]: s for s in by_kind.get("scenario", [])}
    names = scenario_names()
    assert sorted(ran) == names, f"scenarios missing: {sorted(set(names) - set(ran))}"
    wrong = {n: (s["status"], s["rows"], expected_rows(n)) for n, s in ran.items()
             if s["status"] != "done" or s["rows"] != expected_rows(n)}
    assert not wrong, f"(status, samples, expected samples): {wrong}"

    # every check, passed
    checks = {c["name"]: c for c in by_kind.get("check", [])}
    expected = [fn.__name__ for fn in sanitized_workload.CHECKS]
    assert sorted(checks) == sorted(expected), f"checks missing: {sorted(set(expected) - set(checks))}"
    failed = {n: c["detail"] for n, c in checks.items() if not c["ok"]}
    assert not failed, "\n".join(f"{n}:\n{d}" for n, d in failed.items())
    assert by_kind.get("end") == [{"kind": "end", "failed": []}]
