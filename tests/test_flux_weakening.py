"""Sensorless start (I/f, then the SMO) and flux weakening, on the bench's
2.2 kW IPMSM scenario (motulator's example): the drive starts without a
sensor, hands over once, reaches 2 p.u. under load only with flux
weakening, keeps the current inside its circle and the voltage on its limit."""
import numpy as np
import pytest

import fullspeed.sim as fs
from fullspeed.model.units import rad_s_to_rpm

NAME = "bench-motulator-2kw"


@pytest.fixture(scope="module")
def fw_run():
    return fs.simulate(NAME, overrides={"converter": {"inverter": "averaged"}})


def test_if_start_hands_over_once_to_a_locked_observer(fw_run):
    r = fw_run
    phase = r["phase"]
    assert phase[0] == 1, "starts in the I/f phase"
    changes = np.flatnonzero(np.diff(phase))
    assert len(changes) == 1 and phase[-1] == 0, "exactly one hand-over, to the observer"
    t_h = r["t"][changes[0] + 1]
    assert 0.2 < t_h < 0.5, f"hand-over at {t_h:.3f} s: after the speed step, within the start ramp"
    after = r["t"] > t_h + 0.05
    assert np.max(np.abs(np.degrees(r["est_err"][after]))) < 10.0, "the observer stays locked after the hand-over"


def test_flux_weakening_holds_top_speed_under_load_inside_the_limits(fw_run):
    r, sc = fw_run, fw_run.scenario
    late = r["t"] > 1.3
    w = rad_s_to_rpm(r["w_m"][late])
    assert abs(np.mean(w) - 3000.0) < 30.0, f"mean speed {np.mean(w):.0f} rpm at 2 p.u. with 9.8 N m"
    i_max = sc.data["controller"]["i_max"]
    assert np.max(np.hypot(r["i_d"][late], r["i_q"][late])) <= 1.03 * i_max, "current inside its circle"
    assert np.mean(r["i_d_fw"][late]) < -0.5 * i_max, "deep in flux weakening"
    u = np.hypot(r["u_d_ref"][late], r["u_q_ref"][late])
    u_lin = sc.data["converter"]["u_dc"] / np.sqrt(3.0)
    assert np.mean(u) > 0.98 * u_lin, f"voltage {np.mean(u):.0f} V on the limit ({u_lin:.0f} V linear)"


def test_without_flux_weakening_top_speed_is_not_reached():
    # the current loops saturate at the voltage limit and the monitor flags it: detect alone lets the run
    # go on to show where the speed stops (the default would stop the drive after its retries)
    r = fs.simulate(NAME, overrides={"converter": {"inverter": "averaged"},
                                     "controller": {"flux_weakening": False, "lock": "detect"}})
    late = r["t"] > 1.3
    assert np.mean(rad_s_to_rpm(r["w_m"][late])) < 2500.0


def test_a_flux_weakening_cutoff_above_the_sampling_limit_is_a_field_error():
    from fullspeed.model.errors import ConfigError
    from fullspeed.design.scenario import load_scenario
    with pytest.raises(ConfigError, match="controller.fw_cutoff"):
        load_scenario(NAME, {"controller": {"fw_cutoff": 1e5}})
