"""The rotating carrier's limit, one rule for the scenario check and
fs_hfi_init (fs_hfi_w_h_max): more than 4 samples per carrier period,
w_h Ts < pi/2 as float32 computes it.

What could be wrong: the two sides disagreeing (issue 27: f_h = fs/4 passed
the scenario and fs_hfi_init refused it with a message about a bandwidth),
a limit off by more than float rounding, or a message that does not say
what the limit is.
"""
import math

import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.model.errors import ConfigError
from fullspeed.design.scenario import load_scenario


def hfi_init(w_h: float, Ts: float) -> int:
    cfg = ffi.new("fs_hfi_config *", {"Ts": Ts, "delay": 1.0, "u_h": 10.0, "w_h": w_h, "L_d": 0.036, "L_q": 0.051})
    cfg.obs.J, cfg.obs.pole_pairs = 0.015, 3
    return lib.fs_hfi_init(ffi.new("fs_hfi *"), cfg)


@pytest.mark.parametrize("Ts", [1e-4, 125e-6, 62.5e-6, 1.0 / 12000.0, 1.0 / 30000.0])
def test_the_largest_accepted_carrier_is_just_below_a_quarter_of_fs(Ts):
    w_max = lib.fs_hfi_w_h_max(Ts)
    Ts32 = float(np.float32(Ts))
    # within float rounding of pi / (2 Ts), and below it as float computes
    assert w_max == pytest.approx(0.5 * math.pi / Ts32, rel=1e-6)
    assert float(np.float32(w_max) * np.float32(Ts32)) < float(np.float32(0.5 * math.pi))
    assert hfi_init(w_max, Ts) == lib.FS_OK
    assert hfi_init(float(np.nextafter(np.float32(w_max), np.float32(np.inf))), Ts) == lib.FS_ERR_BANDWIDTH
    # f_h = fs / 4 itself: as float rounds w_h Ts, accepted exactly where it is at most w_max
    w_q = 0.5 * math.pi / Ts
    assert (hfi_init(w_q, Ts) == lib.FS_OK) == (float(np.float32(w_q)) <= w_max)


def test_scenario_check_is_the_same_rule_and_names_the_limit():
    Ts = 125e-6   # bench-motulator-2kw-hfi: 4 kHz PWM, double sampling
    with pytest.raises(ConfigError) as e:
        load_scenario("bench-motulator-2kw-hfi", {"injection": {"f_h": 0.25 / Ts, "u_h": 100.0}})
    msg = str(e.value)
    f_max = lib.fs_hfi_w_h_max(Ts) / (2 * math.pi)
    assert "injection.f_h" in msg and f"must be at most {f_max:.10g} Hz" in msg
    assert "more than 4 samples per carrier period" in msg and "2000 Hz" in msg
    # the largest accepted frequency loads (fs_hfi_init runs inside the check)
    sc = load_scenario("bench-motulator-2kw-hfi", {"injection": {"f_h": f_max * (1 - 1e-9), "u_h": 100.0}})
    assert sc.data["injection"]["f_h"] < 0.25 / Ts


def test_a_period_beyond_the_search_is_refused_not_hung():
    """(pi / 2) / Ts 2^-24 is subnormal for Ts past about 8e30 s: the
    search's next-down step rounds back to the same value, and
    fs_hfi_w_h_max(6.52e34) never returned. Beyond FS_HFI_TS_MAX it gives
    0, and fs_hfi_init names the period; at the bound it still searches."""
    assert lib.fs_hfi_w_h_max(6.52e34) == 0.0 and lib.fs_hfi_w_h_max(float("inf")) == 0.0
    assert hfi_init(1e-30, 6.52e34) == lib.FS_ERR_TS
    w = lib.fs_hfi_w_h_max(1e30)
    assert 0.0 < w and float(np.float32(w) * np.float32(1e30)) < float(np.float32(0.5 * math.pi))
