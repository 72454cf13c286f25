"""examples/own-machine: a machine defined from `fullspeed new-machine`'s
template and an FEA-like flux-map CSV runs sensorless, as written, from
standstill under load to rated speed in flux weakening, through a load step
and back through zero (issue 24's done-when)."""
import tomllib
import warnings
from pathlib import Path

import numpy as np

from fullspeed.model.fluxmap import FluxMapWarning
from fullspeed.design.machine import load_machine
from fullspeed.model.reference import machine_template
from fullspeed.sim import simulate
from script_loader import load_script

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "own-machine"
RPM = 60.0 / (2.0 * np.pi)


def test_the_csv_is_what_its_script_writes(tmp_path):
    gen = load_script(EXAMPLE / "make_fluxmap.py", "make_fluxmap")
    gen.main(tmp_path / "map.csv")
    assert (tmp_path / "map.csv").read_bytes() == (EXAMPLE / "my48v-fluxmap.csv").read_bytes()
    # reciprocal, as a lossless magnetic circuit's map is: d psi_d / d i_q = d psi_q / d i_d
    h = 1e-3
    for i_d, i_q in ((-20.0, 15.0), (5.0, 30.0), (-40.0, 45.0)):
        dpd_dq = (gen.psi_dq(i_d, i_q + h)[0] - gen.psi_dq(i_d, i_q - h)[0]) / (2 * h)
        dpq_dd = (gen.psi_dq(i_d + h, i_q)[1] - gen.psi_dq(i_d - h, i_q)[1]) / (2 * h)
        assert abs(dpd_dq - dpq_dd) < 1e-6 * 0.6e-3 and dpd_dq < 0.0   # cross-saturation lowers psi_d


def test_the_machine_is_the_template_filled_in_and_agrees_with_its_map():
    asked = tomllib.loads(machine_template("my48v"))
    given = tomllib.loads((EXAMPLE / "my48v.toml").read_text(encoding="utf-8"))
    for key, value in asked.items():
        fields = value.keys() if isinstance(value, dict) else [None]
        for f in fields:
            v = given[key] if f is None else given[key][f]
            assert v != "?", (key, f)
    with warnings.catch_warnings():
        warnings.simplefilter("error", FluxMapWarning)   # [electrical] within the map's tolerances
        m = load_machine(EXAMPLE / "my48v.toml")
    assert m.magnetic["model"] == "fluxmap" and m.magnetic["source"].startswith("my48v-fluxmap.csv (sha256 ")
    assert "negative i_q by symmetry" in m.magnetic["source"] and "resampled" in m.magnetic["source"]


def test_the_example_runs_sensorless_with_the_drive_in_control():
    """The whole scenario as shipped (6 s simulated, a few s of wall time).

    The bound on the largest angle error while sensorless, 15 el.deg: on
    this map the injection's axis turns with load (cross-saturation; the
    incremental inductances give 0.5 atan2(2 L_dq, L_qq - L_dd) = 8.3 el.deg
    at 2 N m and 11.3 at rated torque on the MTPA locus), which a run
    without a calibrated xcomp table carries; the back-EMF observer's
    transient at the 1 N m load step in 20 ms at 4000 rpm is of that size
    too (11.7 measured). 15 el.deg costs 1 - cos 15 = 3.4 % of torque per
    ampere; a loss of lock is 90 and more."""
    res = simulate(str(EXAMPLE / "my48v-full-range.toml"))
    m = res.metrics
    assert m["stop_reason"] == "done" and m["lock_lost_at"] is None and m["true_loss_at"] is None
    assert not m["silent_failure"] and m["recoveries"] == 0
    assert m["polarity"]["stage"] == "done"
    assert {"injection", "blend", "backemf", "flux_weakening"} <= set(m["stages"])
    assert m["sensorless_err_deg_max"] < 15.0
    w = res["w_m"] * RPM
    assert w.max() > 0.97 * 4000.0 and w.min() < -0.97 * 500.0   # rated speed, and back through zero
    assert abs(m["speed_rpm"] - m["speed_ref_rpm"]) < 5.0        # generating at -500 rpm under 2 N m
