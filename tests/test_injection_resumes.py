"""The injection resuming at low speed (fs_drive.c, drive_injection_step):
its observer, reset with the filter's lag, reads its error only once the
filters have settled on the whole carrier, not when the carrier's fade-in
ends. Read at the fade's end, the negative sequence's filter still held the
positive carrier's image (the ramp leaves the filters behind by a third of
the carrier) and the first corrections turned the Baldor PM-SyRM's estimate
by 12 el.deg in B-REAL's reversal through 100 rpm: its largest error there
was 6.5 to 11.6 el.deg over six initial angles, four of them above B-REAL's
10."""
import numpy as np
import pytest

from fullspeed.design.scenario import scenario_from_dict
from fullspeed.reproduce.papers.real import real_scenario
from fullspeed.sim.runner import simulate


@pytest.mark.parametrize("theta_0", [0.0, 0.001])
def test_the_baldor_reverses_through_the_injection_band_within_6_el_deg(theta_0):
    d, _ = real_scenario("baldor-ecs101m0h7ef4", "blend")
    d.setdefault("initial", {})["theta_e_deg"] = d.get("initial", {}).get("theta_e_deg", 0.0) + theta_0
    ref = d["references"]["speed_rpm"]
    res = simulate(scenario_from_dict(d, "test", warn=False))
    assert res.stop_reason == "done"
    t, e = np.asarray(res["t"]), np.degrees(np.asarray(res["theta_err"]))
    rev = (t > ref[3][0]) & (t < ref[4][0])   # from the top speed down through zero
    w = np.asarray(res["w_m"])[rev]
    assert w.max() > 1000.0 * np.pi / 30.0 and w.min() < -100.0 * np.pi / 30.0   # it did pass the band
    assert np.asarray(res["inject"])[rev].max() > 0.5                              # ... and injected again
    assert np.abs(e[rev]).max() < 6.0
