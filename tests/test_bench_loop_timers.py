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
    assert text.count("__rdtsc()") == 11   # the loop 5 (its four parts), the plant 2, each of the two RK4 sites 2
    for k in (0, 1, 2, 3, 4, 5, 7):        # the parts, the plant, the RK4 steps and the samples counted
        assert f"fs_tm[{k}] +=" in text
    assert text.endswith(lt.READER)


def test_an_anchor_gone_or_doubled_is_refused():
    anchor = lt.PATCHES[3][0]
    with pytest.raises(ValueError, match="0 times"):
        lt.patched(SIM.replace(anchor, ""))
    with pytest.raises(ValueError, match="2 times"):
        lt.patched(SIM.replace(anchor, anchor + anchor))
