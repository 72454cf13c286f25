"""Dead-time compensation on the current predicted at each edge
(fs_dtcomp.h): the usual compensation for a steady current, and each
edge's own sign when an injected carrier takes the current through zero."""
import pytest

from fullspeed._core import ffi, lib

T_PWM, T_DEAD, L = 1e-4, 1e-6, 1e-3


def unit(Ts=T_PWM, delay=1.0, band=0.0, phases=3):
    d = ffi.new("fs_dtcomp *")
    cfg = ffi.new("fs_dtcomp_config *", {"phases": phases, "T_pwm": T_PWM, "Ts": Ts, "delay": delay,
                                         "t_dead": T_DEAD, "i_band": band, "L_d": L, "L_q": L})
    assert lib.fs_dtcomp_init(d, cfg) == lib.FS_OK
    return d


def step(d, i_ph, u_inj=(0.0, 0.0), duty=(0.5, 0.5, 0.5)):
    i = ffi.new("float[5]", list(i_ph) + [0.0] * (5 - len(i_ph)))
    dt = ffi.new("float[5]", list(duty) + [0.0] * (5 - len(duty)))
    lib.fs_dtcomp_step(d, i, {"alpha": u_inj[0], "beta": u_inj[1]}, dt)
    return [dt[k] for k in range(len(duty))]


def test_steady_current_is_the_usual_compensation():
    dd = T_DEAD / T_PWM
    assert step(unit(), (5.0, -2.0, -3.0)) == pytest.approx([0.5 + dd, 0.5 - dd, 0.5 - dd], abs=1e-7)
    # double update: each half compensates its own edge, twice as much, and the two halves average to it
    d = unit(Ts=T_PWM / 2)
    first, second = step(d, (5.0, -2.0, -3.0)), step(d, (5.0, -2.0, -3.0))
    assert sorted([first[0], second[0]]) == pytest.approx([0.5, 0.5 + 2 * dd], abs=1e-7)
    assert sorted([first[1], second[1]]) == pytest.approx([0.5 - 2 * dd, 0.5], abs=1e-7)


def test_carrier_through_zero_takes_each_edges_sign():
    """Phase a at +0.1 A sampled, a carrier of -100 V on alpha (10 A per
    period through 1 mH): at its rising edge, a quarter period into the
    interval after a period of the same carrier, the current is -12.4 A: no
    loss there; at the falling edge negative: the gain is compensated. The
    sampled sign says the opposite."""
    dd = T_DEAD / T_PWM
    d = unit()
    step(d, (0.1, -0.05, -0.05), u_inj=(-100.0, 0.0))          # the carrier acting until the interval
    duty = step(d, (0.1, -0.05, -0.05), u_inj=(-100.0, 0.0))
    assert duty[0] == pytest.approx(0.5 - dd, abs=1e-7)
    # without the carrier the sampled sign holds at both edges
    assert step(unit(), (0.1, -0.05, -0.05))[0] == pytest.approx(0.5 + dd, abs=1e-7)


def test_no_edge_no_compensation_and_refusals():
    assert step(unit(), (5.0, -2.0, -3.0), duty=(1.0, 0.0, 0.5))[:2] == [1.0, 0.0]
    d = ffi.new("fs_dtcomp *")
    base = {"phases": 3, "T_pwm": T_PWM, "Ts": T_PWM, "delay": 1.0, "t_dead": T_DEAD, "i_band": 0.0, "L_d": L, "L_q": L}
    for field, value, st in (("Ts", 0.3 * T_PWM, lib.FS_ERR_TS), ("t_dead", 0.0, lib.FS_ERR_PARAM),
                             ("phases", 4, lib.FS_ERR_PARAM), ("L_q", 0.0, lib.FS_ERR_LQ), ("delay", 0.5, lib.FS_ERR_PARAM)):
        assert lib.fs_dtcomp_init(d, ffi.new("fs_dtcomp_config *", {**base, field: value})) == st, field


def test_a_carrier_that_stopped_acts_until_the_update_then_the_usual():
    """Without a carrier (none acting, none coming) the step is the usual
    compensation, computed as such (the ramp within +-i_band included); the
    step right after the carrier stops still predicts from the carrier that
    acts until the interval: phase a sampled at +0.1 A, -10 A of carrier
    current added by then, both edges negative."""
    dd = T_DEAD / T_PWM
    d = unit(band=0.4)
    step(d, (0.1, -0.05, -0.05), u_inj=(-100.0, 0.0))
    assert step(d, (0.1, -0.05, -0.05))[0] == pytest.approx(0.5 - dd, abs=1e-7)     # the carrier acting until then
    assert step(d, (0.1, -0.05, -0.05))[0] == pytest.approx(0.5 + 0.25 * dd, abs=1e-7)   # 0.1 / 0.4 of the ramp
