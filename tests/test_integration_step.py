"""The default integration step (a fifth of the shortest electrical time
constant and of a radian of rotation at the top speed) is converged: the
bench scenario run with it matches a run with a 50x finer step to well
below what any metric resolves, for both inverter models."""
import numpy as np
import pytest

import fullspeed.sim as fs
from fullspeed.design.scenario import load_scenario


@pytest.mark.parametrize("inverter", ["averaged", "switching"])
def test_default_step_matches_a_fine_step(inverter):
    name = "bench-motulator-2kw"
    sc = load_scenario(name, {"converter": {"inverter": inverter}})
    h = sc.data["timing"]["h_max"]
    assert 5e-5 < h < 2e-4, f"default h_max {h:g} s from the machine's time constants"
    coarse = fs.simulate(sc)
    fine = fs.simulate(name, overrides={"converter": {"inverter": inverter}, "timing": {"h_max": h / 50}})
    for ch in ("i_d", "i_q", "w_m"):
        scale = np.max(np.abs(fine[ch]))
        err = np.max(np.abs(coarse[ch] - fine[ch])) / scale
        assert err < 1e-4, f"{ch}: max deviation {err:.2e} of its range"
