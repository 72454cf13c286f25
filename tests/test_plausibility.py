"""Plausibility that catches the classic datasheet mistakes (design/checks.py)
on the new-user trial's Prius MG2, quiet on the catalog, the zoo and the
repository's machines; the template's Ke -> psi_f; the speed loop against
the observer that feeds it."""
import copy
import math
from pathlib import Path

import pytest

from fullspeed.design.checks import emf_warnings, torque_warnings
from fullspeed.design.machine import load_machine, machine_from_dict
from fullspeed.design.rules import u_linear
from fullspeed.design.scenario import load_scenario, scenario_from_dict
from fullspeed.model.machines import catalog_data, catalog_names
from fullspeed.model.reference import machine_template
from fullspeed.model import zoo

ROOT = Path(__file__).resolve().parents[1]
# the trial's Prius MG2 (its section 1: jonelay/phase-sweep's values, ORNL's ratings), linear magnetics
PRIUS = {"name": "prius2004", "kind": "ipmsm", "pole_pairs": 4,
         "electrical": {"R_s": 0.077, "L_d": 2.26e-3, "L_q": 6.15e-3, "psi_f": 0.1607},
         "mechanical": {"J": 0.035}, "rated": {"torque": 400.0, "current": 250.0, "speed_rpm": 1200.0},
         "bench": {"u_dc": 500.0, "f_pwm": 10e3, "t_dead": 3e-6, "noise_i": 0.3}}


def plausibility(d: dict) -> list[str]:
    m = machine_from_dict(copy.deepcopy(d))
    return emf_warnings(m, u_linear(m.bench["u_dc"], m.phases)) + torque_warnings(m)


def prius(**changes) -> dict:
    d = copy.deepcopy(PRIUS)
    for path, v in changes.items():
        *tables, key = path.split("__")
        t = d
        for k in tables:
            t = t[k]
        t[key] = v
    return d


def test_the_trial_prius_passes_and_its_classic_mistakes_are_named():
    assert plausibility(prius()) == []
    assert plausibility(prius(rated__torque=398.0)) == []   # ORNL's 50 kW at 1200 rpm
    # pole pairs given as poles
    (w,) = plausibility(prius(pole_pairs=8))
    assert w.startswith("machine.pole_pairs:") and "pole_pairs given as poles (8 for 4 pairs)" in w and "4.52 x" in w
    # psi_f from a line-to-line Ke: x sqrt 3
    (w,) = plausibility(prius(electrical__psi_f=0.1607 * math.sqrt(3)))
    assert w.startswith("machine.electrical.psi_f:") and "line-to-line Ke" in w and "sqrt(2) / sqrt(3)" in w
    # the rated current given as rms (the trial's third mistake, caught before, still caught)
    (w,) = plausibility(prius(rated__current=176.8))
    assert w.startswith("machine.rated.current:") and "rms" in w and "250" in w
    # L in mH typed as H: named by the time constant and by the torque
    ws = plausibility(prius(electrical__L_d=2.26, electrical__L_q=6.15))
    assert ws and ws[0].startswith("machine.electrical.L_d:") and "mH typed as H" in ws[0]


def test_the_rated_voltage_catches_what_the_link_cannot():
    # with a rated voltage, the back-EMF at rated speed against it: motulator's machine
    # (0.85 of its rated voltage) with its pole pairs doubled or psi_f from a line-to-line Ke
    d = catalog_data("motulator-2kw-ipmsm")
    assert plausibility(d) == []
    # (its torque at rated current, 1.08 x rated, doubles to 2.16: inside what saturation explains)
    d2 = copy.deepcopy(d)
    d2["pole_pairs"] *= 2
    (w,) = plausibility(d2)   # 1.7 x: halved or over sqrt 3 both fit, and both are named
    assert "rated voltage" in w and "1.7 x" in w and "pole_pairs given as poles (6 for 3 pairs)" in w
    assert w.split(":")[0] in ("machine.pole_pairs", "machine.electrical.psi_f")
    d3 = copy.deepcopy(d)
    d3["electrical"]["psi_f"] *= math.sqrt(3)
    (w,) = plausibility(d3)
    assert w.startswith("machine.electrical.psi_f:") and "rated voltage" in w and "line-to-line Ke" in w


@pytest.mark.parametrize("name", catalog_names())
def test_quiet_on_every_catalog_machine(name):
    assert plausibility(catalog_data(name)) == []


def test_quiet_on_the_zoo_and_the_repository_machines():
    from conftest import MACHINE
    from test_design import DATASHEET as MY48
    from test_identify import SERVO
    for k in range(zoo.SIZE):
        assert plausibility(zoo.machine(k)) == [], k
    for d in (MACHINE, MY48, SERVO):
        assert plausibility(d) == [], d["name"]
    own = load_machine(str(ROOT / "examples" / "own-machine" / "my48v.toml"))   # with its flux map's torque
    assert emf_warnings(own, u_linear(own.bench["u_dc"], own.phases)) + torque_warnings(own) == []


def test_the_template_turns_a_line_to_line_ke_into_psi_f():
    text = machine_template("m")
    assert "Ke" in text and "line-to-line rms" in text
    assert "psi_f = Ke * sqrt(2) / sqrt(3) / (pole_pairs * 2 * pi * 1000 / 60)" in text
    # its worked example is right: 50 V/krpm, 4 pole pairs
    assert "0.0975 Wb" in text and 50 * math.sqrt(2) / math.sqrt(3) / (4 * 2 * math.pi * 1000 / 60) == pytest.approx(0.0975, abs=5e-5)
    assert "poles / 2" in text


def test_a_speed_loop_faster_than_its_observer_is_warned():
    d = {"name": "p", "duration": 1.0, "machine": copy.deepcopy(PRIUS), "injection": {"u_h": 50.0},
         "controller": {"mode": "speed", "angle": "blend", "flux_weakening": True}}
    designed = scenario_from_dict(copy.deepcopy(d))
    assert not any(w.startswith("controller.bw_speed") for w in designed.warnings)
    bw = designed.data["controller"]["bw_speed"]
    d["controller"]["bw_speed"] = 100.0   # the trial's --set controller.bw_speed=100
    (w,) = [w for w in scenario_from_dict(copy.deepcopy(d)).warnings if w.startswith("controller.bw_speed")]
    assert f"at most {bw:.4g} rad/s" in w and "half the bandwidth of the observer" in w
    d["controller"]["bw_speed"] = 0.9 * bw
    assert not any(w.startswith("controller.bw_speed") for w in scenario_from_dict(copy.deepcopy(d)).warnings)
    smo = load_scenario("yang2022-smo-ramp", {"controller": {"bw_speed": 200.0}})
    assert any(w.startswith("controller.bw_speed") and "a sixth of the back-EMF observer's PLL" in w for w in smo.warnings)


def test_a_flux_map_machine_is_judged_by_its_own_torque():
    # SyR-e's THOR makes half its torque from saliency: the magnet alone (0.46 x rated) is no sign of an rms
    # current on a map, but the map's total at an rms current (0.64 x, below 0.7) is, and says so
    d = catalog_data("syre-thor")
    assert plausibility(d) == []
    d["rated"]["current"] /= math.sqrt(2)
    (w,) = plausibility(d)
    assert w.startswith("machine.rated.current:") and "rms" in w and "0.642 x" in w


@pytest.mark.parametrize("name, ratio", [("baldor-ecs101m0h7ef4", "2.1 x"), ("syre-thor", "1.99 x")])
def test_pole_pairs_given_as_poles_on_a_reluctance_machine_are_named(name, ratio):
    """A PM-SyRM's magnet flux is small: twice its pole pairs leaves the
    back-EMF at rated speed within the rated voltage, and only the torque
    its map makes at rated current (twice the rating) shows it."""
    d = catalog_data(name)
    d["pole_pairs"] *= 2
    m = machine_from_dict(copy.deepcopy(d))
    assert emf_warnings(m, u_linear(m.bench["u_dc"], m.phases)) == []
    (w,) = plausibility(d)
    assert w.startswith("machine.pole_pairs:") and "on its flux map" in w and ratio in w
    assert f"pole_pairs given as poles ({d['pole_pairs']} for {d['pole_pairs'] // 2} pairs)" in w


def rated_speed(d: dict) -> list[str]:
    """The rated-speed lines of a speed scenario on machine table d (its link, its current limit)."""
    sc = scenario_from_dict({"name": "p", "duration": 0.1, "machine": copy.deepcopy(d),
                             "controller": {"mode": "speed"}, "references": {"speed_rpm": 100.0}})
    return [w for w in sc.warnings if w.startswith(("machine.rated.speed_rpm", "machine.rated.power", "machine.electrical.R_s"))]


def test_a_rated_speed_given_in_rad_s_is_named_not_r_s():
    """The trial's Prius MG2 with its 1200 rpm typed as 125.7 (rad/s): the
    copper loss against T_rated w_rated (137 % of a power ten times too
    small) had named R_s; the rated power, where given, or the voltage the
    rated current leaves unused at rated speed now name the speed."""
    assert rated_speed(prius()) == []
    assert rated_speed(prius(rated__power=50e3)) == []   # ORNL's 50 kW: 0.995 x 400 N m at 1200 rpm
    w_rad_s = 1200.0 * 2.0 * math.pi / 60.0
    (w,) = rated_speed(prius(rated__speed_rpm=round(w_rad_s, 1), rated__power=50e3))
    assert w.startswith("machine.rated.speed_rpm:") and "9.5 x" in w and "rad/s" in w and "1200.3 rpm" in w
    # without the power: the rated current on MTPA meets the link's voltage at 570 rpm on this linear copy,
    # 4.5 x the 125.7 rpm given
    (w,) = rated_speed(prius(rated__speed_rpm=round(w_rad_s, 1)))
    assert w.startswith("machine.rated.speed_rpm:") and "0.221 x" in w and "569.8" in w and "rad/s" in w
    # a power in kW is the power's mistake
    (w,) = rated_speed(prius(rated__power=50.0))
    assert w.startswith("machine.rated.power:") and "kW" in w


def test_the_rated_speed_check_is_quiet_on_the_catalog_and_the_zoo():
    for name in catalog_names():
        assert rated_speed(catalog_data(name)) == [], name
    for k in range(0, zoo.SIZE, 3):
        assert rated_speed(zoo.machine(k)) == [], k


def test_a_design_refused_on_implausible_data_names_the_datas_likely_mistake():
    """The trial's first mistake, L_d and L_q in mH typed as H: the design
    refuses (no voltage left for a carrier: 2.6e5 V needed), and the
    refusal now also names the field the data's plausibility finds wrong,
    which the warnings printed after a successful design never reached."""
    from fullspeed.model.errors import ConfigError
    from fullspeed.reproduce.papers.real import real_scenario
    d = {"name": "p", "duration": 1.0, "machine": prius(electrical__L_d=2.26, electrical__L_q=6.15),
         "controller": {"mode": "speed", "angle": "blend"}, "references": {"speed_rpm": 1000.0}}
    with pytest.raises(ConfigError) as exc:
        scenario_from_dict(d)
    text = str(exc.value)
    assert exc.value.field == "injection.u_h" and "no voltage left for a carrier" in text
    assert "the machine's data: machine.electrical.L_d:" in text and "H, not mH" in text
    # a refusal on plausible data is left as it was: the H27's I/f start against B-REAL's load
    data, _ = real_scenario("hefei-h27", "smo")
    with pytest.raises(ConfigError) as exc:
        scenario_from_dict(data)
    assert "the machine's data" not in str(exc.value) and "cannot carry" in str(exc.value)
