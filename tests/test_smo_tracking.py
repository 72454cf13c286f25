"""The SMO's tracking form (fs_smo.h) and the I/f start's hand-over, on
motulator's 2.2 kW IPMSM example (bench-motulator-2kw: 0 -> 3000 rpm at
0.2 s, 9.8 N m at 0.8 s, linear plant, exact parameters, no noise).

What could be wrong: a tracking form that is no better than the paper's
(the -0.94 el.deg bias under load at 3000 rpm and the acceleration lag still
there), a paper form that changed with it (the yang2022 claims run on it),
and a hand-over taken on an observer that has not converged (the 109 el.deg
burst of issue 27). Each run is 1.6 s simulated, about 0.01 s of wall time.
"""
import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.design.scenario import load_scenario
from fullspeed.sim import simulate

AVG = {"converter": {"inverter": "averaged"}}


def run(form: str, **extra):
    ov = {**AVG, "observer": {"form": form, **extra.pop("observer", {})}, **extra}
    return simulate(load_scenario("bench-motulator-2kw", ov))


def deg(x):
    return np.degrees(np.asarray(x))


@pytest.fixture(scope="module")
def tracking():
    return run("tracking")


@pytest.fixture(scope="module")
def paper():
    return run("paper")


def test_tracking_form_meets_the_issue_goals(tracking):
    """issue 27 (a): max error after start-up <= 2.2 el.deg (motulator's flux
    observer: 2.19), steady |mean| <= 0.2 under load at 3000 rpm."""
    t, e = tracking["t"], deg(tracking["theta_err"])
    assert tracking.stop_reason == "done"
    after = t >= 0.35
    assert np.abs(e[after]).max() <= 2.2
    steady = (t >= 1.2) & (t < 1.6)
    assert abs(e[steady].mean()) <= 0.2
    assert tracking["w_m"][steady].mean() * 30 / np.pi == pytest.approx(3000.0, abs=2.0)


def test_paper_form_keeps_its_bias(paper):
    """The paper's form is unchanged by the tracking form: its forward-Euler
    model and PLL keep the bias the issue measured (-0.94 el.deg), so the
    tracking form's result above is its own, not the plant's."""
    t, e = paper["t"], deg(paper["theta_err"])
    steady = (t >= 1.2) & (t < 1.6)
    assert e[steady].mean() == pytest.approx(-0.94, abs=0.05)


@pytest.mark.parametrize("form", ["tracking", "paper"])
def test_hand_over_waits_for_a_converged_observer(form, tracking, paper):
    """The loops take the observer only once it has converged: its own error
    at that instant is small, and the angle the loops use stays within
    10 el.deg from the next sample on (issue 27: 109 el.deg before)."""
    res = tracking if form == "tracking" else paper
    t, phase = res["t"], res["phase"]
    k = int(np.nonzero((phase == lib.FS_PHASE_RUN) & (t > 0.01))[0][0])
    assert 0.2 < t[k] < 0.35
    assert abs(deg(res["est_err"][k])) < 5.0
    assert np.abs(deg(res["theta_err"][k + 1:])).max() < 10.0


def _smo(form, **kw):
    c = dict(Ts=125e-6, R_s=3.6, L_d=0.036, L_q=0.051, psi_f=0.545, w_e_max=1036.0, i_max=9.12, k=0.0,
             margin=1.5, delta=0.0, w_c_min=6.28, bw_pll=300.0, w_valid=31.4, lag=lib.FS_SMO_LAG_EXACT,
             form=form, J=0.015, B=0.0, pole_pairs=3, phases=3)
    c.update(kw)
    o = ffi.new("fs_smo *")
    return o, lib.fs_smo_init(o, ffi.new("fs_smo_config *", c))


def test_tracking_form_needs_its_mechanics():
    assert _smo(lib.FS_SMO_FORM_TRACKING)[1] == lib.FS_OK
    assert _smo(lib.FS_SMO_FORM_TRACKING, J=0.0)[1] == lib.FS_ERR_J
    assert _smo(lib.FS_SMO_FORM_TRACKING, pole_pairs=0)[1] == lib.FS_ERR_POLE_PAIRS
    assert _smo(lib.FS_SMO_FORM_TRACKING, phases=4)[1] == lib.FS_ERR_PARAM
    assert _smo(2)[1] == lib.FS_ERR_MODE
    # the paper's form does not need them (the yang2022 configs leave them 0)
    assert _smo(lib.FS_SMO_FORM_PAPER, J=0.0, pole_pairs=0, phases=0)[1] == lib.FS_OK


def test_converged_needs_a_settled_error():
    """`converged` comes after 4 / bw_pll of small error, and goes with the
    first large one."""
    o, st = _smo(lib.FS_SMO_FORM_PAPER)
    assert st == lib.FS_OK and o.n_settle == int(np.ceil(4.0 / (300.0 * 125e-6)))
    assert not o.converged
    # no current, no voltage: nothing to measure, the error stays 0
    for _ in range(o.n_settle - 1):
        lib.fs_smo_step(o, {"alpha": 0.0, "beta": 0.0}, {"alpha": 0.0, "beta": 0.0})
    assert not o.converged
    lib.fs_smo_step(o, {"alpha": 0.0, "beta": 0.0}, {"alpha": 0.0, "beta": 0.0})
    assert o.converged
    # a current the model did not predict: out of the boundary layer
    lib.fs_smo_step(o, {"alpha": 50.0, "beta": 0.0}, {"alpha": 0.0, "beta": 0.0})
    assert o.r_i > 1.0 and not o.converged


def _spin(o, theta0: float, w: float, n: int):
    """n steps of a rotor at w (rad/s el.) from theta0 with no current: the
    voltage that acted in each period is its EMF's mean over it,
    psi_f (cos, sin) difference over Ts. Returns the estimate's largest
    |error| over the last half (rad) and whether `converged` was set at any
    step of it."""
    Ts, psi = o.cfg.Ts, o.cfg.psi_f
    err, conv = 0.0, False
    for k in range(1, n + 1):
        th0, th1 = theta0 + w * Ts * (k - 1), theta0 + w * Ts * k
        u = {"alpha": psi * (np.cos(th1) - np.cos(th0)) / Ts, "beta": psi * (np.sin(th1) - np.sin(th0)) / Ts}
        lib.fs_smo_step(o, {"alpha": 0.0, "beta": 0.0}, u)
        if k > n // 2:
            err = max(err, abs(np.remainder(th1 - o.theta + np.pi, 2 * np.pi) - np.pi))
            conv |= bool(o.converged)
    return err, conv


def test_converged_is_not_set_on_an_estimate_pi_off():
    """A tracker pi off with the direction the wrong way (the caller's, as
    the blend hands it over) is self-consistent: the EMF's angle read with
    the wrong direction is the rotor's plus pi, turning at the rotor's speed,
    so the innovation is nil and the current error slides. Only the EMF's
    own speed, -w against the estimate's +w, tells: `converged` stays unset
    for the whole 0.2 s while the estimate stays pi off. The same tracker
    started right converges (fs_smo.h, convergence)."""
    w = 300.0   # rad/s el., about 1000 rpm on the motulator machine
    o, st = _smo(lib.FS_SMO_FORM_TRACKING, dir_external=1)
    assert st == lib.FS_OK
    lib.fs_smo_reset(o, np.pi, w)
    lib.fs_smo_set_dir(o, -w)
    err, conv = _spin(o, 0.0, w, int(0.2 / o.cfg.Ts))
    assert err > np.radians(170.0) and not conv
    o, _ = _smo(lib.FS_SMO_FORM_TRACKING, dir_external=1)
    lib.fs_smo_reset(o, 0.0, w)
    lib.fs_smo_set_dir(o, w)
    err, conv = _spin(o, 0.0, w, int(0.2 / o.cfg.Ts))
    assert err < np.radians(2.0) and conv
