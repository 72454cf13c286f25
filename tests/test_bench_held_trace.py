"""Tests of bench/held_trace.py, the estimators inside a held run.

What could be wrong: the rows read at another instant than the simulator's
last sample (the angle errors then compare the estimate with a stale
rotor angle), an error's sign or wrap, the speeds left electrical, the
window not around the step (held_scenario's reference), a machine whose
held run is not blended traced anyway. One held run of the 2004 Prius MG2
is simulated from 1 ms before its step to 4 ms after (its step at full
torque, the back-EMF observer's tracker and the injection's still on).
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
import held_trace as ht  # noqa: E402

from fullspeed.model.errors import ConfigError  # noqa: E402
from fullspeed.reproduce.papers.real import held_scenario  # noqa: E402


def test_the_rows_are_the_simulators_own_samples_around_the_step():
    rpm = 293.7
    t_s = ht.step_time(held_scenario("prius2004-mg2", rpm, "blend"))
    rows = ht.trace("prius2004-mg2", rpm, before=1e-3, after=4e-3, every=5e-4)
    assert len(rows) == 10
    assert rows[0]["t"] == pytest.approx(t_s - 0.5e-3, abs=1e-6) and rows[-1]["t"] == pytest.approx(t_s + 4e-3, abs=1e-6)
    for r in rows:
        assert r["w_m_rpm"] == pytest.approx(rpm, rel=1e-6)   # the load machine holds the shaft
        # the blend's error as the simulator's own channel says (its estimate, theta_est, is the blend's)
        assert r["blend"]["err_deg"] == pytest.approx(r["est_err_deg"], abs=1e-3)
        for e in ("smo", "hfi", "blend"):
            assert -180.0 < r[e]["err_deg"] <= 180.0
    # before the step the estimators sit at the shaft's speed in mechanical rpm (p = 4: electrical would be 4x)
    assert rows[0]["smo"]["w_rpm"] == pytest.approx(rpm, rel=0.05) and rows[0]["blend"]["w_rpm"] == pytest.approx(rpm, rel=0.05)
    # the speed loop asks its most torque at the step: the torque fed forward rises from tens to hundreds of N m
    assert rows[0]["T_ff"] < 100.0 and max(r["T_ff"] for r in rows) > 350.0


def test_a_machine_not_blended_is_refused():
    with pytest.raises(ConfigError, match="blended"):
        ht.trace("siemens-1ft6084", 1000.0)
