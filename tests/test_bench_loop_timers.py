"""Tests of bench/loop_timers.py's patch: the counters must stand where the
runner's parts are, each anchor once.

What could be wrong: a runner changed so that an anchor no longer stands
(a part left untimed, or timed twice where it stands twice) without the
tool saying so. Nothing is built or timed here.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]
lt = load_script(ROOT / "bench" / "loop_timers.py", "bench_loop_timers")

SIM = (ROOT / "csrc" / "sim" / "fs_sim.c").read_text()


def test_every_part_of_the_runner_is_timed_once():
    text = lt.patched(SIM)
    # the loop 5 (its four parts), the plant 2, each of the three RK4 sites 2 (the switching inverter's, the
    # averaged one's with dead time or drops, and the ideal averaged one's, the wall bench's example)
    assert text.count("__rdtsc()") == 13
    for k in (0, 1, 2, 3, 4, 5, 7):        # the parts, the plant, the RK4 steps and the samples counted
        assert f"fs_tm[{k}] +=" in text
    assert text.endswith(lt.READER)


def test_an_anchor_gone_or_doubled_is_refused():
    anchor = lt.PATCHES[3][0]
    with pytest.raises(ValueError, match="0 times"):
        lt.patched(SIM.replace(anchor, ""))
    with pytest.raises(ValueError, match="2 times"):
        lt.patched(SIM.replace(anchor, anchor + anchor))


def test_the_ideal_averaged_steps_are_timed_and_an_older_runner_without_them_is_not_refused():
    anchor = lt.OPTIONAL[0][0]
    assert SIM.count(anchor) == 1          # this runner's fast path stands where the tool times it
    older = lt.patched(SIM.replace(anchor, ""))   # a checkout from before it (bench/loop_timers.py --src)
    assert older.count("__rdtsc()") == 11
    with pytest.raises(ValueError, match="2 times"):
        lt.patched(SIM.replace(anchor, anchor + anchor))
