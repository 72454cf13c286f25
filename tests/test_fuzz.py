"""Fuzzing `fullspeed run` (issue 10): hypothesis writes scenario files,
valid and invalid (huge and tiny numbers, NaN, wrong types, deep nesting,
unknown keys, text that is not TOML), and every outcome must be a completed
run (exit 0, or 1 with the stop and its time) or one clean line (exit 2):
never an internal error, a traceback or a hang (each case has a time limit).

The cases mutate the catalog scenarios, so most of them reach deep into the
validation and many of them run. A duration the schema accepts is cut to
50 ms, so a case is bounded by its work and not by the wall clock, and in
half the cases drawn anew below that: any remainder after the last whole
control period (issue 40's hang H1 was on such durations, which a fuzzer
rounding them to 50 ms never tried).
"""
from __future__ import annotations

import collections
import contextlib
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import tomllib
from importlib import resources
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fullspeed.model import zoo
from fullspeed.cli import main
from fullspeed.model.machines import catalog_data
from fullspeed.model.schema import deep_merge
from fullspeed.model.scenario import scenario_names
from fullspeed.sim import STOP_REASONS

from tomlw import dumps

TIME_LIMIT = 60          # s per case: a hang fails the test
MAX_DURATION = 0.05      # s

OUTCOMES: collections.Counter = collections.Counter()


def _raw(name: str) -> dict:
    return tomllib.loads((resources.files("fullspeed") / "scenarios" / f"{name}.toml").read_text())


BASES = {n: _raw(n) for n in scenario_names()}


def _leaves(d, path=()):
    for k, v in d.items():
        if isinstance(v, dict) and v:
            yield from _leaves(v, path + (k,))
        else:
            yield path + (k,)


def _nest(depth: int, leaf, kind: str):
    for _ in range(depth):
        leaf = [leaf] if kind == "list" else {"k": leaf}
    return leaf


scalars = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 5e-324, 1e-300, 1e300, -1e300, 1.7976931348623157e308, 1e-12, 1e12]),
    st.integers(min_value=-2**63, max_value=2**63 - 1),
    st.booleans(),
    st.text(max_size=12),
)
values = st.one_of(
    scalars,
    st.lists(scalars, max_size=4),
    st.lists(st.lists(st.floats(allow_nan=True), max_size=3), max_size=4),
    st.dictionaries(st.text(max_size=6), scalars, max_size=3),
    st.builds(_nest, st.integers(1, 60), scalars, st.sampled_from(["list", "dict"])),
)


@st.composite
def scenario_texts(draw) -> str:
    name = draw(st.sampled_from(sorted(BASES)))
    d = json.loads(json.dumps(BASES[name]))          # a deep copy
    if draw(st.integers(0, 19)) == 0:                  # now and then: text that is not a scenario at all
        return draw(st.text(max_size=200))
    if draw(st.booleans()):                            # the machine inline, so its fields are fuzzed too
        m = d["machine"] if isinstance(d["machine"], dict) else {"catalog": d["machine"]}
        base = zoo.machine(m["zoo"]) if "zoo" in m else catalog_data(m["catalog"])
        d["machine"] = deep_merge(base, {k: v for k, v in m.items() if k not in ("catalog", "zoo")})
    paths = list(_leaves(d))
    for _ in range(draw(st.integers(0, 4))):
        if draw(st.integers(0, 4)) == 0:               # a new key, perhaps in a new table
            path = tuple(draw(st.lists(st.sampled_from(["controller", "x", "faults", "machine", "timing", "i_max", "mode"]),
                                       min_size=1, max_size=3)))
        else:
            path = draw(st.sampled_from(paths))
        cur = d
        for k in path[:-1]:
            if not isinstance(cur.get(k), dict):
                cur[k] = {}
            cur = cur[k]
        cur[path[-1]] = draw(values)
    dur = d.get("duration")
    if isinstance(dur, (int, float)) and not isinstance(dur, bool) and 0 < dur <= 1e4:
        d["duration"] = min(dur, MAX_DURATION)
        if draw(st.booleans()):   # not a multiple of anything: a whole number of periods and a remainder, or tiny
            d["duration"] = draw(st.one_of(st.floats(1e-7, MAX_DURATION),
                                           st.builds(lambda k, r: (k + r) * 1e-4, st.integers(0, 499), st.floats(0.0, 1.0))))
    steady = d.get("metrics", {}).get("steady") if isinstance(d.get("metrics"), dict) else None
    if isinstance(steady, list) and isinstance(d.get("duration"), float) and steady == BASES[name].get("metrics", {}).get("steady"):
        d["metrics"]["steady"] = [0.0, d["duration"]]
    if isinstance(d.get("observer"), dict) and d["observer"].get("handover") == BASES[name].get("observer", {}).get("handover"):
        d["observer"].pop("handover", None)
    return dumps(d)


class _Hang(Exception):
    pass


def _alarm(signum, frame):
    raise _Hang()


def run_case(text: str) -> tuple[int, str, Path]:
    tmp = Path(tempfile.mkdtemp(prefix="fuzz-"))
    f = tmp / "case.toml"
    f.write_text(text, encoding="utf-8", errors="surrogatepass")
    err = io.StringIO()
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(TIME_LIMIT)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            rc = main(["run", str(f), "--out", str(tmp / "out"), "--quiet"])
    except _Hang:
        raise AssertionError(f"hang: no outcome within {TIME_LIMIT} s for\n{text}") from None
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    return rc, err.getvalue(), tmp / "out"


def check_outcome(rc: int, err: str, out: Path, text: str) -> str:
    assert "Traceback" not in err and "internal error" not in err, f"{err}\n--- for ---\n{text}"
    assert rc in (0, 1, 2), (rc, err, text)
    if rc == 2:   # one line of refusal (the warnings a loaded scenario prints before it are not errors)
        lines = [ln for ln in err.strip().splitlines() if not ln.startswith("fullspeed: warning: ")]
        assert len(lines) == 1 and lines[0].startswith("fullspeed: error: "), (err, text)
        assert not out.exists()
        return "refused"
    m = json.loads((out / "metrics.json").read_text())      # a completed run, its metrics written
    assert (out / "traces.npz").stat().st_size > 0
    if rc == 0:
        assert m["stop_reason"] == "done"
        return "ran"
    # a failed run (exit 1): stopped, or a loss of lock flagged or seen by the truth, and said so
    assert "fullspeed: run failed: " in err, err
    if m["stop_reason"] == "done":   # a loss, or the job not done (a start stage at the end, the speed far off)
        assert (m["lock_lost_at"] is not None or m["true_loss_at"] is not None or m["start_unfinished"]
                or (m["speed_end"] or {}).get("far") or (m["speed_end"] or {}).get("unheld") or m.get("speed_steady")
                or any(r.get("unheld") for r in m.get("steps", []))), m
        return "lost"
    assert m["stop_reason"] in set(STOP_REASONS.values()) - {"done"} and m["stop_time"] is not None, m
    return "stopped"


@settings(max_examples=400, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(scenario_texts())
def test_fuzzed_scenarios_run_or_are_refused_cleanly(text):
    rc, err, out = run_case(text)
    try:
        OUTCOMES[check_outcome(rc, err, out, text)] += 1
    finally:   # 400 cases a run: the failing one's text is in the assertion
        shutil.rmtree(out.parent, ignore_errors=True)


def test_fuzzing_reached_both_runs_and_refusals():
    """The fuzzer is not degenerate: its cases (the test above, run first)
    both ran and were refused."""
    print("fuzz outcomes:", dict(OUTCOMES))
    assert OUTCOMES["refused"] >= 20 and OUTCOMES["ran"] + OUTCOMES["stopped"] >= 10, OUTCOMES


@settings(max_examples=8, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(scenario_texts())
def test_fuzzed_scenarios_through_the_console_script(text):
    """The same, as a process: the exit status and stderr a user sees."""
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "case.toml"
        f.write_text(text, encoding="utf-8", errors="surrogatepass")
        p = subprocess.run([sys.executable, "-m", "fullspeed", "run", str(f), "--out", str(Path(tmp) / "out"), "--quiet"],
                           capture_output=True, text=True, timeout=TIME_LIMIT + 30,
                           env={**os.environ, "PYTHONWARNINGS": "ignore"})
        check_outcome(p.returncode, p.stderr, Path(tmp) / "out", text)
