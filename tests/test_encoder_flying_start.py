"""A drive started on a rotor that already turns, on the encoder (a flying
start; each point of `fullspeed map` starts so). The encoder's PLL took its
speed from zero at its bandwidth, and the speed loop's first step read zero
speed: the README's 48 V example at 4500 rpm (its EMF near the link's
linear voltage) tripped on overcurrent in 1.8 ms (a new user's trial), and
`fullspeed map` marked every point from 4500 rpm up as not held."""
from pathlib import Path

import numpy as np

from fullspeed.design.scenario import scenario_from_dict
from fullspeed.model.units import rad_s_to_rpm
from fullspeed.sim.runner import simulate

MACHINE = Path(__file__).resolve().parents[1] / "examples" / "own-machine" / "my48v.toml"


def flying(rpm: float) -> dict:
    return {"name": "flying-start", "duration": 0.1, "machine": str(MACHINE),
            "controller": {"mode": "speed", "angle": "encoder", "flux_weakening": True},
            "initial": {"speed_rpm": rpm}, "references": {"speed_rpm": rpm}}


def test_a_turning_rotor_is_taken_over_at_its_speed_without_a_bump():
    sc = scenario_from_dict(flying(4500.0), "flying-start")
    i_max = sc.data["controller"]["i_max"]
    res = simulate(sc)
    assert res.stop_reason == "done"
    w_hat = rad_s_to_rpm(np.asarray(res["w_m_hat"]))
    assert w_hat[0] == 0.0 and abs(w_hat[1] - 4500.0) < 1.0   # the speed from the second reading on
    i_ph = np.abs(np.stack([res["i_a"], res["i_b"], res["i_c"]]))
    assert i_ph.max() < 0.3 * i_max          # the first sample's voltage without the EMF's feed-forward, no more
    w = rad_s_to_rpm(np.asarray(res["w_m"]))
    assert w.min() > 0.99 * 4500.0            # no braking torque from a speed loop that read zero speed


def test_a_rotor_at_rest_is_seeded_with_zero_speed():
    """At rest the second reading gives zero speed, exactly: the PLL and the
    speed loop then run as before the seeding (bench/trace_hashes.py: every
    catalog trace the same to the bit)."""
    res = simulate(scenario_from_dict({**flying(0.0), "references": {"speed_rpm": [[0.0, 0.0], [0.01, 0.0], [0.05, 1000.0]]}},
                                      "rest"))
    assert res.stop_reason == "done"
    assert np.asarray(res["w_m"])[1] == 0.0 and np.asarray(res["w_m_hat"])[1] == 0.0
