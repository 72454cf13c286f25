"""A scenario's plant_machine: the simulation turns another machine than
the one the drive is designed from (an identified machine file against the
true machine), everything the drive knows unchanged."""
import numpy as np
import pytest

from fullspeed.design.scenario import scenario_from_dict
from fullspeed.model.errors import ConfigError
from fullspeed.sim import simulate

BASE = {"name": "pm", "duration": 0.1, "machine": "yang2022",
        "controller": {"mode": "current", "angle": "encoder"},
        "references": {"i_q": 5.0}, "load": {"kind": "speed", "speed_rpm": 300.0},
        "initial": {"speed_rpm": 300.0}, "converter": {"inverter": "averaged"}}


def run(**extra):
    sc = scenario_from_dict({**BASE, **extra})
    return sc, simulate(sc)


def test_the_same_machine_as_plant_changes_nothing():
    _, a = run()
    _, b = run(plant_machine="yang2022")
    for ch in ("i_d", "i_q", "T_e", "u_d", "u_q"):
        assert np.array_equal(np.asarray(a[ch]), np.asarray(b[ch])), ch


def test_the_plant_is_the_other_machine_and_the_drive_is_not():
    sc0, a = run()
    sc1, b = run(plant_machine={"catalog": "yang2022", "electrical": {"psi_f": 1.1 * sc0.machine.psi_f}})
    # the drive designed alike (its every designed value), the plant's magnet 10 % stronger
    assert {k: v.value for k, v in sc0.design.items()} == {k: v.value for k, v in sc1.design.items()}
    assert sc1.machine.psi_f == sc0.machine.psi_f and sc1.plant.psi_f == pytest.approx(1.1 * sc0.machine.psi_f)
    t = np.asarray(a["t"])
    w = t > 0.05
    # the torque per ampere of q current (the magnet's, most of this machine's) grows with the plant's psi_f
    k0, k1 = ((np.asarray(r["T_e"])[w] / np.asarray(r["i_q"])[w]).mean() for r in (a, b))
    assert 1.07 < k1 / k0 < 1.11


def test_a_plant_of_another_pole_count_is_refused():
    with pytest.raises(ConfigError) as e:
        scenario_from_dict({**BASE, "plant_machine": {"catalog": "yang2022", "pole_pairs": 2}})
    assert "plant_machine.pole_pairs" in str(e.value)
