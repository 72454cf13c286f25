"""The rotating injection's leak removal (fs_hfi_filter_step_nl, injection.leak
= "remove") and the blend's gate (fs_blend_step_gated, blending.gate), issue 27.

What could be wrong: a leak removal that takes the carrier out with the
fundamental (then the angle is lost) or leaves the leak in; a gate that
never opens (the SMO never blended in) or lets an unconverged SMO in; and
the closed-loop claims of the issue: on motulator's 2.2 kW IPMSM at rated
load, the injection (its observer designed with the filters' lag,
injection.tracking = "lag") within 5 el.deg and unbiased through the load
steps, and the blend holding the rotor for every band between 5 % and 25 %
of rated speed. The closed-loop runs are 4 s simulated, ~0.04 s each.
"""
import math

import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.design.scenario import load_scenario
from fullspeed.sim import simulate

TS, W_H = 125e-6, 2 * math.pi * 1000.0


def _filter(w_b):
    f = ffi.new("fs_hfi_filter *")
    assert lib.fs_hfi_filter_init(f, ffi.new("fs_hfi_filter_config *", [TS, w_b, w_b])) == lib.FS_OK
    return f


def test_leak_removal_keeps_the_carrier_and_drops_the_fundamental():
    """Standstill: a 5 A fundamental (dc) and a 0.16 A negative carrier at
    2 theta_r = 1 rad. The paper's filter passes about w_b / w_h of the
    fundamental into i_hn; step_nl (w_b / w_h)^2 of it; the carrier comes
    through both the same."""
    w_b = W_H / 20
    f_cs, f_nl = _filter(w_b), _filter(w_b)
    i_fund, i_n, th2 = 5.0 + 0j, 0.16, 1.0
    n = int(0.2 / TS)
    per = int(round(2 * math.pi / (W_H * TS)))          # 8 samples per carrier period
    hn_cs, hn_nl, ph = [], [], []
    for k in range(n):
        th_h = (W_H * k * TS + math.pi) % (2 * math.pi) - math.pi
        carrier = i_n * np.exp(1j * (-W_H * k * TS + th2))
        i = i_fund + carrier
        e_h = {"alpha": math.cos(th_h), "beta": math.sin(th_h)}
        th_n = (2 * 0.5 * th2 - th_h + math.pi) % (2 * math.pi) - math.pi   # theta_hat = theta_r
        e_n = {"alpha": math.cos(th_n), "beta": math.sin(th_n)}
        x = {"alpha": i.real, "beta": i.imag}
        a, b = ffi.new("fs_ab *"), ffi.new("fs_ab *")
        lib.fs_hfi_filter_step_cs(f_cs, x, e_h, e_n, a, b)
        hn_cs.append(b.alpha + 1j * b.beta)
        lib.fs_hfi_filter_step_nl(f_nl, x, e_h, e_n, a, b)
        hn_nl.append(b.alpha + 1j * b.beta)
        ph.append(np.exp(1j * (-W_H * k * TS + th2)))
    win = slice(n - 100 * per, n)                          # the last 100 carrier periods
    hn_cs, hn_nl, ph = np.array(hn_cs)[win], np.array(hn_nl)[win], np.array(ph)[win]
    leak_cs, leak_nl = abs(hn_cs.mean()), abs(hn_nl.mean())   # the dc part: the fundamental's
    assert leak_cs == pytest.approx(abs(i_fund) * w_b / W_H, rel=0.2)
    assert leak_nl < 0.1 * leak_cs
    car_cs, car_nl = (hn_cs * np.conj(ph)).mean(), (hn_nl * np.conj(ph)).mean()
    assert abs(car_nl) == pytest.approx(abs(car_cs), rel=0.01)
    assert abs(np.angle(car_nl / car_cs)) < math.radians(0.2)


def _blend(gate=1):
    b = ffi.new("fs_blend *")
    cfg = ffi.new("fs_blend_config *", {"w_lower": 50.0, "w_upper": 100.0, "gate": gate,
                                        "obs": {"Ts": TS, "J": 0.015, "B": 0.0, "pole_pairs": 3, "bandwidth": 250.0}})
    assert lib.fs_blend_init(b, cfg) == lib.FS_OK
    return b


def test_gate_holds_an_unconverged_smo_out_and_lets_it_in_slowly():
    b = _blend()
    lib.fs_blend_reset(b, 0.0, 200.0)          # above w_upper: eq. (28) says 1
    lib.fs_blend_step_gated(b, 0.1, 0.0, 0.0, False, True)
    assert b.g_w == 0.0                         # the injection's angle only
    n_rise = math.ceil(4.0 / (250.0 * TS))
    steps = 0
    while b.trust < 1.0 and steps < 10 * n_rise:
        w_before = b.obs.w_hat                  # the weight uses the speed of the step before
        lib.fs_blend_step_gated(b, 0.0, 0.0, 0.0, True, True)
        assert b.g_w == pytest.approx(b.trust * lib.fs_blend_weight(w_before, 50.0, 100.0), rel=1e-5)
        steps += 1
    assert n_rise - 2 <= steps <= n_rise + 2    # back over 4 / w_o
    lib.fs_blend_step_gated(b, 0.0, 0.0, 0.0, False, True)
    assert b.g_w == 0.0                         # and out at once
    lib.fs_blend_reset(b, 0.0, 200.0)
    lib.fs_blend_step_gated(b, 0.0, 0.0, 0.0, False, False)
    assert b.trust == 1.0 and b.g_w == 1.0      # no injection: eq. (28) alone
    bad = ffi.new("fs_blend *")
    cfg = ffi.new("fs_blend_config *", {"w_lower": 50.0, "w_upper": 100.0, "gate": 2,
                                        "obs": {"Ts": TS, "J": 0.015, "pole_pairs": 3, "bandwidth": 250.0}})
    assert lib.fs_blend_init(bad, cfg) == lib.FS_ERR_PARAM


def _run(name, **ov):
    res = simulate(load_scenario(name, ov))
    t, e = res["t"], np.degrees(res["theta_err"])
    return res, t, e


def test_injection_holds_the_rated_load_steps_within_issue_27s_goal():
    """bench-motulator-2kw-hfi (1.6 kHz, w_h / 20 filters, leak removed, the
    motion observer designed with the filters' lag in its loop at their
    bandwidth): issue 27's item 3, max <= 5 el.deg over the run (the load
    release is the worst) and |mean| <= 1 el.deg at standstill under rated
    load. The paper's observer on the same filters (w_b_n / 5) lags the
    release by more than twice that (1.5 and 5.9 el.deg), and by more than
    its own design without the filters' lag in its loop allows,
    0.27 p dT / (J w_o^2) (fs_motion_obs.h: 4.3 el.deg); the fast observer
    with the paper's filter (the fundamental's leak kept) loses the rotor."""
    res, t, e = _run("bench-motulator-2kw-hfi")
    assert res.stop_reason == "done" and res.metrics["lock_lost_at"] is None
    assert np.abs(e[t >= 0.2]).max() <= 5.0
    assert abs(e[(t >= 0.8) & (t < 1.0)].mean()) <= 1.0
    lag_release = np.abs(e[t >= 3.5]).max()
    _, t, e = _run("bench-motulator-2kw-hfi", injection={"tracking": "paper"})
    w_o = 0.2 * 2 * math.pi * 1600.0 / 20   # the paper's rule, w_b_n / 5, at the scenario's carrier
    assert np.abs(e[t >= 3.5]).max() > max(2.0 * lag_release, math.degrees(0.27 * 3 * 14.0 / (0.015 * w_o ** 2)))
    res, t, e = _run("bench-motulator-2kw-hfi", injection={"leak": "keep"})
    assert res.stop_reason != "done" or np.abs(e[t >= 0.2]).max() > 90.0


@pytest.mark.parametrize("band", [(60.0, 120.0), (75.0, 150.0), (120.0, 195.0), (200.0, 375.0), (75.0, 375.0)])
def test_blend_keeps_the_rotor_for_bands_between_5_and_25_percent(band):
    """Rated speed 1500 rpm: bands within 75..375 rpm, and 60..120, which
    the test below shows needs the gate. The load steps at standstill and
    the release push the rotor to about +-250 rpm, into them."""
    res, t, e = _run("bench-motulator-2kw-blend", blending={"lower_rpm": band[0], "upper_rpm": band[1]})
    assert res.stop_reason == "done"
    assert np.abs(e[t >= 0.2]).max() <= 10.0


def test_blend_without_the_gate_holds_the_band_above_120_rpm():
    """Without the gate the blend used to hunt in the low bands (its speed
    estimate swinging 110..240 rpm about a rotor at 130..170 rpm, the weight
    flipping 0 <-> 1 between the two angles) and lost the rotor (180 el.deg
    on main before fs_smo.h's change 4). The back-EMF tracker keeps its
    acceleration continuous on becoming valid (T_d starts at -T) and takes
    the EMF's speed in the cross-coupling while generating; either alone
    ends that hunt, and the ungated blend holds 120..195 rpm as the gated
    one does (10 el.deg, the test above)."""
    res, t, e = _run("bench-motulator-2kw-blend", blending={"lower_rpm": 120.0, "upper_rpm": 195.0, "gate": False})
    assert res.stop_reason == "done"
    assert np.abs(e[t >= 0.2]).max() <= 10.0


def test_the_band_from_60_rpm_needs_the_gate():
    """With the injection's observer at its designed gain (fs_hfi.c: the
    carrier's amplitude without the fundamental's leak) the rotor the
    release throws back (to -165 rpm) enters 60..120 rpm while the back-EMF
    observer is valid but has not converged (it reads -40 to -90 rpm): the
    ungated weight takes it and the rotor is lost, where the gate keeps it
    out and the gated blend holds the band within 10 el.deg (2.4; the test
    above holds this band and those from 75 rpm, gated).

    This was the band from 75 rpm until the injection's error was first read
    once its filters had settled (fs_drive_reset): read earlier, its first
    corrections kicked the back-EMF observer at standstill into a spin it
    held, valid and unconverged, at +18 el.rad/s through the 0.5 s before the
    release (116 el.deg off at -78 rpm); started clean, it is still invalid
    at the release, valid on the rotor's direction by the band and the
    ungated blend holds 75..150 within 7.5 el.deg. The counterfactual needs
    the release to find the observer valid and not converged, which 60..120
    (and 50..100, 40..80) still does."""
    res, t, e = _run("bench-motulator-2kw-blend", blending={"lower_rpm": 60.0, "upper_rpm": 120.0, "gate": False})
    assert res.stop_reason != "done" or np.abs(e[t >= 0.2]).max() > 45.0
