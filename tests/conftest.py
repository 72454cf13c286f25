import copy

import pytest

# A machine of the yang2022 size, inline so that physics tests do not move
# when the catalog's chosen values do.
MACHINE = {
    "name": "test-ipmsm", "kind": "ipmsm", "pole_pairs": 5,
    "electrical": {"R_s": 0.036, "L_d": 0.065e-3, "L_q": 0.09e-3, "psi_f": 0.007},
    "mechanical": {"J": 1.87e-3, "B": 0.0, "T_coulomb": 0.0},
    "rated": {"torque": 2.0, "current": 56.6, "speed_rpm": 2000.0},
    "bench": {"u_dc": 24.0, "f_pwm": 10e3, "t_dead": 1e-6, "i_max": 60.0, "i_trip": 90.0,
              "adc_bits": 12, "adc_range": 100.0, "encoder_bits": 10,
              "bw_current": 2500.0, "bw_speed": 100.0, "bw_pll": 300.0},
}


def scenario(**sections):
    """A scenario dict on the test machine; sections override the defaults."""
    d = {"name": "test", "duration": 0.2, "machine": copy.deepcopy(MACHINE),
         "controller": {"mode": "current"}}
    for k, v in sections.items():
        if isinstance(v, dict) and isinstance(d.get(k), dict):
            d[k] = {**d[k], **v}
        else:
            d[k] = v
    return d


@pytest.fixture
def make_scenario():
    return scenario
