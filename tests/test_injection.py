"""Rotating HF injection in the closed loop (yang2022 sec. 3-4): the
scenario checks, polarity detection, the cross-saturation calibration and the
blend's hand-over."""

import numpy as np
import pytest

from fullspeed.workflows.calibrate import xsat_table
from fullspeed.model.errors import ConfigError
from fullspeed.design.scenario import load_scenario
from fullspeed.model.scenario import xcomp_table
from fullspeed.sim import simulate

from test_cli import bad, fullspeed, write_scenario


def test_injection_on_a_machine_without_saliency_is_refused(tmp_path):
    """zou2021's SPMSM has L_d = L_q: nothing for an injection to see."""
    with pytest.raises(ConfigError) as exc:
        load_scenario("yang2022-hfi-steady-100rpm", {"machine": "zou2021"})
    msg = str(exc.value)
    assert "controller.angle" in msg and "salient" in msg and "zou2021" in msg
    f = write_scenario(tmp_path, bad('machine = "zou2021"\n', 'angle = "hfi"\n'))
    p = fullspeed("run", str(f), "--out", str(tmp_path / "o"), "--quiet")
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1
    assert "controller.angle" in p.stderr and "Traceback" not in p.stderr


@pytest.mark.parametrize("over, field, words", [
    ({"injection": {"f_h": 3000.0}}, "injection.f_h", "4 samples"),           # Ts = 100 us: limit 2500 Hz
    ({"injection": {"u_h": 20.0}}, "injection.u_h", "linear modulation"),      # u_dc / sqrt3 = 13.9 V
    ({"injection": {"xcomp": {"i_q": [0.0, 1.0, 3.0], "delta_deg": [0, 1, 2]}}}, "injection.xcomp.i_q", "even steps"),
    ({"injection": {"xcomp": {"i_q": [0.0, 1.0], "delta_deg": [0.0, 95.0]}}}, "injection.xcomp.delta_deg", "90"),
    ({"injection": {"xcomp": "no-such-table"}}, "injection.xcomp", "not found"),
    ({"polarity": {"i_pulse": 80.0}}, "polarity.i_pulse", "i_max"),
])
def test_injection_fields_are_checked(over, field, words):
    with pytest.raises(ConfigError) as exc:
        load_scenario("yang2022-hfi-steady-100rpm", over)
    assert field in str(exc.value) and words in str(exc.value)


def test_blend_needs_the_injection_to_resume_inside_its_band():
    with pytest.raises(ConfigError) as exc:
        load_scenario("yang2022-blend-iqstep", {"injection": {"stop_rpm": 270.0}})
    assert "injection.stop_rpm" in str(exc.value)


def _final_error_deg(res):
    return float(np.degrees(res["est_err"][-1]))


def test_polarity_found_at_36_angles_and_needed_at_some():
    """With the detection every start ends on the north pole; without it the
    estimator ends on the south pole from some angles (the pi ambiguity of
    eq. (26)), so the detection is what gets them right."""
    right, wrong_without = 0, 0
    for a in range(0, 360, 10):
        res = simulate(load_scenario("yang2022-polarity", {"initial": {"theta_e_deg": float(a)}}))
        assert res.stop_reason == "done"
        assert res["phase"][-1] == 0                   # detection finished, running
        right += abs(_final_error_deg(res)) < 10.0
        res = simulate(load_scenario("yang2022-polarity", {"initial": {"theta_e_deg": float(a)},
                                                           "polarity": {"enabled": False}}))
        wrong_without += abs(_final_error_deg(res)) > 170.0
    assert right == 36
    assert wrong_without >= 6


def test_shipped_cross_saturation_table_is_what_the_calibration_measures():
    """fullspeed/calibration/yang2022-xsat.toml must be regenerated
    (fullspeed calibrate beyond-xcomp-3ph --out ...) when the plant or the
    estimator changes: this test fails when they drift apart. With the
    fundamental's leak removed (the default) the estimator adds no bias of
    its own: the table is the machine's HF saliency axis, which
    machines/yang2022.toml's reason gives as 0.87 and 22.0 el.deg at 5 and
    25 A (the paper's filter adds a load-proportional bias: 15 at 25 A)."""
    fresh, _ = xsat_table("beyond-xcomp-3ph")
    shipped = xcomp_table("yang2022-xsat", None)
    assert fresh["i_q"] == shipped["i_q"]
    assert np.max(np.abs(np.subtract(fresh["delta_deg"], shipped["delta_deg"]))) < 0.5
    d = dict(zip(fresh["i_q"], fresh["delta_deg"]))
    assert abs(d[25.0] - 22.0) < 1.0 and abs(d[5.0] - 0.87) < 0.5


def test_compensation_removes_the_cross_saturation_error():
    plain = simulate(load_scenario("beyond-xcomp-3ph", {"injection": {"xcomp": False}}))
    comp = simulate(load_scenario("beyond-xcomp-3ph"))
    m = (plain["t"] >= 0.5)
    e_plain = np.degrees(np.mean(plain["est_err"][m]))
    e_comp = np.degrees(np.mean(comp["est_err"][m]))
    assert e_plain < -8.0            # the estimate leads by the saliency shift
    assert abs(e_comp) < 3.0


def test_blend_hands_over_to_the_smo_and_back_without_a_current_step():
    """Above the injection's stop speed the HF voltage fades out, below 0.9 of
    it fades in: no jump of the measured q current at either instant, the
    weight at 1 while the injection is off, and the estimate kept."""
    res = simulate(load_scenario("yang2022-blend-accdec"))
    t, inj = res["t"], res["inject"]
    off = np.flatnonzero(np.diff(inj) < 0)
    on = np.flatnonzero(np.diff(inj) > 0)
    assert len(off) == 1 and len(on) == 1 and t[off[0]] < 1.5 < 3.4 < t[on[0]]
    assert np.all(res["g_w"][inj == 0] == 1.0)
    for k in (off[0], on[0]):
        w = slice(k - 50, k + 50)   # +-5 ms
        assert np.ptp(res["i_q_hat"][w]) < 4.0
    assert np.max(np.abs(np.degrees(res["est_err"][t > 0.2]))) < 10.0


def test_blend_reverses_through_zero_speed():
    """+400 -> -400 rpm: through the band, the injection at standstill and
    back out the other way; the SMO must follow the negative direction (its
    PLL error changes sign with the speed) and the blend keeps lock."""
    res = simulate(load_scenario("yang2022-blend-accdec", {
        "references": {"speed_rpm": [[0.0, 0.0], [0.2, 0.0], [0.6, 100.0], [1.1, 100.0], [1.4, 400.0],
                                     [2.4, 400.0], [3.2, -400.0]]},
        "load": {"torque": 0.0}}))
    t = res["t"]
    assert res.stop_reason == "done"
    assert np.max(np.abs(np.degrees(res["est_err"][t > 0.2]))) < 10.0
    assert res["w_m"][-1] * 60 / (2 * np.pi) == pytest.approx(-400.0, abs=5.0)
    assert res["g_w"][-1] == 1.0 and res["inject"][-1] == 0.0     # the SMO alone at -400 rpm
