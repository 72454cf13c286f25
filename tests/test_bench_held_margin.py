"""Tests of bench/held_margin.py, the margin of B-REAL's held torques.

What could be wrong: the neighbours' speeds not k x STEP beside the
claim's; a machine B-REAL refuses sensorless given runs anyway; the table
counting a run that stopped early, or one below the encoder's torque less
HELD_TOL, as held; the claim's own run (k = 0) read from another; and the
stops not named by their k. Two short held runs are simulated (one speed,
k = 0 and the encoder), the rest is the table's logic on rows.
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
import held_margin as hm  # noqa: E402

from fullspeed.reproduce.papers.real import HELD_TOL  # noqa: E402


def test_the_neighbours_sit_k_steps_beside_the_claims_speeds():
    ts = hm.tasks(["odrive-d6374"], 2)
    enc = [t for t in ts if t["angle"] == "encoder"]
    sl = [t for t in ts if t["angle"] != "encoder"]
    assert len(enc) == 6 and len(sl) == 6 * 5   # B-REAL's six speeds, k = -2..2
    for t in sl:
        assert t["rpm"] == pytest.approx(t["rpm0"] * (1.0 + t["k"] * hm.STEP), rel=1e-12)
    assert {t["rpm0"] for t in enc} == {t["rpm0"] for t in sl}
    assert hm.tasks(["hefei-h27"], 2) == []   # refused sensorless by B-REAL: nothing to hold


def _rows(T_enc, Ts):
    rows = [{"machine": "m", "rpm0": 100.0, "rpm": 100.0, "angle": "encoder", "k": 0, "T": T_enc, "stop_reason": "done"}]
    for k, T in zip(range(-(len(Ts) // 2), len(Ts) // 2 + 1), Ts):
        rows.append({"machine": "m", "rpm0": 100.0, "rpm": 100.0 * (1 + k * hm.STEP), "angle": "blend", "k": k,
                     "T": T, "stop_reason": "done" if T is not None else "overspeed"})
    return rows


def test_the_table_counts_what_held_and_names_the_rest():
    low = (1.0 - HELD_TOL) * 100.0
    (r,) = hm.summarise(_rows(100.0, [None, low - 0.01, 99.0, low + 0.01, None]))
    assert r["held"] == 2 and r["runs"] == 5 and r["claim_run_held"]
    assert r["stops"] == {-2: "overspeed", 2: "overspeed"}
    assert r["T_min"] == pytest.approx(low - 0.01) and r["T_max"] == pytest.approx(99.0)
    (r,) = hm.summarise(_rows(100.0, [99.0, None, 99.0]))
    assert r["held"] == 2 and not r["claim_run_held"] and r["stops"] == {0: "overspeed"}
