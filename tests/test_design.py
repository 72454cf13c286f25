"""Designed defaults (fullspeed.design.rules), the warnings a scenario says out
loud (fullspeed.design.checks), and polarity detection that refuses what it cannot
tell (issue 21)."""
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from fullspeed.design import rules as dz
from fullspeed.model import zoo
from fullspeed.design.machine import machine_from_dict
from fullspeed.design.scenario import UNWARNED, load_scenario, scenario_from_dict
from fullspeed.sim import simulate

# a 48 V machine given by its datasheet alone (the new user's trial)
DATASHEET = {
    "name": "my48", "kind": "ipmsm", "phases": 3, "pole_pairs": 4,
    "electrical": {"R_s": 0.05, "L_d": 0.3e-3, "L_q": 0.8e-3, "psi_f": 0.02},
    "mechanical": {"J": 5e-4},
    "rated": {"torque": 3.0, "current": 30.0, "speed_rpm": 3000.0},
    "bench": {"u_dc": 48.0, "f_pwm": 20000.0, "t_dead": 0.5e-6, "noise_i": 0.05},
}


def scenario(machine, **sections):
    d = {"name": "t", "duration": 0.5, "machine": machine,
         "controller": {"mode": "speed", "angle": "blend", "flux_weakening": True}}
    d.update(sections)
    return scenario_from_dict(d)


def test_a_datasheet_machine_gets_every_setting_designed_with_its_reason():
    sc = scenario(DATASHEET)
    m, d = sc.machine, sc.data
    Ts = 1 / 20e3
    assert m.bench["i_max"] == pytest.approx(45.0) and m.bench["i_trip"] == pytest.approx(56.25)
    assert m.bench["adc_range"] >= m.bench["i_trip"]
    assert d["controller"]["bw_current"] == pytest.approx(2 * math.pi / (20 * Ts))
    assert d["injection"]["f_h"] == pytest.approx(2000.0)   # f_s / 10: twice the current loop's bandwidth
    assert 2 * math.pi * d["injection"]["f_h"] >= 2 * d["controller"]["bw_current"] * 0.999
    # the carrier's negative-sequence current is 35 ADC steps, eq. (24)
    lsb = 2 * m.bench["adc_range"] / 2 ** 12
    _, i_n = dz.carrier_currents(d["injection"]["u_h"], 2 * math.pi * d["injection"]["f_h"], m.L_d, m.L_q)
    assert i_n == pytest.approx(35 * lsb, rel=1e-6)
    # the band within 5..30 % of rated speed, upper 1.6 x lower, under the carrier's speed range
    lo, hi = d["blending"]["lower_rpm"], d["blending"]["upper_rpm"]
    assert 0.05 * 3000 - 1e-9 <= lo <= 0.3 * 3000 and hi == pytest.approx(1.6 * lo)
    assert hi * 4 / 60 <= d["injection"]["f_h"] / 10 + 1e-9
    for key in ("controller.bw_current", "controller.i_max", "injection.u_h", "injection.f_h", "blending.lower_rpm",
                "observer.bw_pll", "observer.valid_rpm"):
        v = sc.design[key]
        assert not v.given and len(v.reason.split()) >= 4, key


def test_the_catalog_keeps_its_values():
    sc = load_scenario("yang2022-blend-accdec")
    d = sc.data
    assert (d["injection"]["u_h"], d["injection"]["f_h"]) == (5.0, 1000.0)
    assert (d["blending"]["lower_rpm"], d["blending"]["upper_rpm"]) == (160.0, 260.0)
    assert (d["controller"]["bw_current"], d["observer"]["bw_pll"]) == (3000.0, 250.0)
    assert (d["observer"]["valid_rpm"], d["observer"]["cutoff_min_rpm"]) == (100.0, 20.0)
    assert all(v.given for k, v in sc.machine.design.items())


def test_a_scenario_overrides_the_design():
    sc = scenario(DATASHEET, injection={"u_h": 5.0}, blending={"lower_rpm": 100.0, "upper_rpm": 200.0})
    assert sc.data["injection"]["u_h"] == 5.0 and sc.data["blending"]["lower_rpm"] == 100.0
    assert sc.design["blending.lower_rpm"].given


def test_the_old_blending_names_are_refused_with_the_new_one():
    from fullspeed.model.errors import ConfigError
    with pytest.raises(ConfigError, match="blending.lower_rpm"):
        machine_from_dict({**DATASHEET, "blending": {"omega_lower_rpm": 100.0}})


def test_design_command_prints_each_value_and_its_reason(tmp_path):
    f = tmp_path / "my48.toml"
    f.write_text(json_to_toml(DATASHEET))
    p = subprocess.run([sys.executable, "-m", "fullspeed", "design", str(f)], capture_output=True, text=True, timeout=120,
                       cwd=tmp_path)   # envelope.png goes to out/<name> there
    assert p.returncode == 0, p.stderr
    for key in ("bench.i_max", "injection.u_h", "injection.f_h", "blending.lower_rpm", "observer.bw_pll"):
        line = next(ln for ln in p.stdout.splitlines() if key in ln)
        assert "designed:" in line
    assert "45 A" in next(ln for ln in p.stdout.splitlines() if "bench.i_max" in ln)
    # linear magnetics: the pulses cannot tell the poles, the start the machine gets is a motion test, and why
    assert "bounded motion test" in p.stdout and "magnetics are linear" in p.stdout, p.stdout
    assert "start.i_push" in p.stdout and not p.stderr
    # with the rotor not to be turned: the pulses, and the warning that they will refuse
    p = subprocess.run([sys.executable, "-m", "fullspeed", "design", str(f), "--set", "start.allow_motion=false"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and "polarity.enabled" in p.stderr and "linear" in p.stderr, p.stderr


def test_design_of_a_machine_with_a_square_wave_injection_designs_it(tmp_path):
    """yu2022's machine file gives a square-wave injection (f_h a quarter of
    the sampling rate): `design yu2022` designs that drive, not the blend's
    rotating carrier, which cannot take its f_h (exit 2 on float32 rounding)."""
    p = subprocess.run([sys.executable, "-m", "fullspeed", "design", "yu2022", "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "estimators (controller.angle = swvi;" in p.stdout and "the square wave has no polarity detection" in p.stdout


def test_design_command_shows_the_estimators_forms_and_takes_set(tmp_path):
    """The forms the estimators run with (the defaults a user would not see
    in the scenario) are printed with their values; --set changes them, and
    the leak's default follows the tracking it is designed for."""
    def forms(*sets):
        args = [a for kv in sets for a in ("--set", kv)]
        p = subprocess.run([sys.executable, "-m", "fullspeed", "design", "yang2022", *args], cwd=tmp_path,
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 0, p.stderr
        return {ln.split()[0]: ln.split()[1] for ln in p.stdout.splitlines() if ln.startswith("  ") and len(ln.split()) > 1}
    d = forms()
    assert (d["observer.form"], d["injection.tracking"], d["injection.leak"], d["blending.gate"],
            d["controller.dead_time_predict"]) == ("tracking", "lag", "remove", "true", "true")
    d = forms("injection.tracking=paper", "blending.gate=false")
    assert (d["injection.tracking"], d["injection.leak"], d["blending.gate"]) == ("paper", "keep", "false")
    d = forms("controller.angle=smo")
    assert "observer.form" in d and "injection.leak" not in d and "controller.dead_time_predict" not in d
    p = subprocess.run([sys.executable, "-m", "fullspeed", "design", "yang2022", "--set", "injection.tracking=fast"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and "injection.tracking" in p.stderr


def json_to_toml(d: dict) -> str:
    top = [f"{k} = {json.dumps(v)}" for k, v in d.items() if not isinstance(v, dict)]
    tables = [f"[{k}]\n" + "\n".join(f"{kk} = {json.dumps(vv)}" for kk, vv in v.items()) for k, v in d.items() if isinstance(v, dict)]
    return "\n".join(top) + "\n" + "\n".join(tables) + "\n"


# --- warnings ------------------------------------------------------------------

@pytest.mark.parametrize("change, field", [
    ({"electrical": {"R_s": 0.05, "L_d": 0.3, "L_q": 0.8, "psi_f": 0.02}}, "machine.electrical.L_d"),   # H for mH
    ({"mechanical": {"J": 50.0}}, "machine.mechanical.J"),
    ({"electrical": {"R_s": 0.05, "L_d": 0.3e-3, "L_q": 0.8e-3, "psi_f": 2.0}}, "machine.electrical.psi_f"),
    ({"electrical": {"R_s": 50.0, "L_d": 0.3e-3, "L_q": 0.8e-3, "psi_f": 0.02}}, "machine.electrical.R_s"),
])
def test_implausible_parameters_are_named(change, field):
    m = {**DATASHEET, **change}
    sc = scenario_from_dict({"name": "t", "duration": 0.1, "machine": m, "controller": {"mode": "current"}})
    assert any(w.startswith(field + ":") for w in sc.warnings), sc.warnings
    clean = scenario_from_dict({"name": "t", "duration": 0.1, "machine": DATASHEET, "controller": {"mode": "current"}})
    assert not clean.warnings


def test_an_unreachable_speed_is_named():
    refs = {"speed_rpm": 10000.0}
    no_fw = scenario_from_dict({"name": "t", "duration": 0.1, "machine": DATASHEET, "controller": {"mode": "speed"},
                                "references": refs})
    assert any(w.startswith("references.speed_rpm:") and "without flux weakening" in w for w in no_fw.warnings)
    ok = scenario_from_dict({"name": "t", "duration": 0.1, "machine": DATASHEET, "controller": {"mode": "speed"},
                             "references": {"speed_rpm": 3000.0}})
    assert not any(w.startswith("references.") for w in ok.warnings)


# --- polarity ----------------------------------------------------------------------

LINEAR_YANG = {"machine": {"catalog": "yang2022", "magnetic": {"model": "linear"}}, "duration": 0.5}


def test_polarity_pulses_on_a_linear_machine_refuse_at_every_angle():
    """Linear magnetics, the rotor not to be turned (start.allow_motion =
    false): the pulses have nothing to measure; the drive refuses to start
    sensorless, and never starts pi off (yang2022's machine made linear)."""
    for th in range(0, 360, 45):
        r = simulate("yang2022-polarity", overrides={**LINEAR_YANG, "start": {"allow_motion": False},
                                                     "initial": {"theta_e_deg": th}})
        assert r.stop_reason == "polarity_undetermined", (th, r.polarity)
        assert r.polarity["method"] == "pulses"
        assert r.polarity["stage"] == "undetermined" and r.polarity["margin"] < 1.0


def test_the_motion_test_finds_the_pole_on_a_linear_machine_at_every_angle():
    """Linear magnetics, the start left to the machine: the motion test
    (fs_motion_test.h) turns the rotor by a few degrees and tells north from
    south at every angle, the estimate ending on the rotor; the turn stays
    within the design's bound and is reported. (The scenario's paper observer
    is slow: the test takes about 0.7 s.)"""
    flips = set()
    for th in range(0, 360, 45):
        r = simulate("yang2022-polarity", overrides={**LINEAR_YANG, "duration": 1.2, "initial": {"theta_e_deg": th}})
        assert r.stop_reason == "done" and r.polarity["method"] == "motion", (th, r.polarity)
        assert r.polarity["stage"] == "done" and abs(r.polarity["turn_deg"]) >= r.polarity["threshold_deg"]
        assert abs(np.degrees(r["theta_err"][-1])) < 20.0, th   # on the right pole
        sm = r.metrics["start_motion"]
        assert sm["kind"] == "motion" and 1.0 < sm["turn_deg"] <= sm["bound_deg"], sm
        flips.add(r.polarity["flip"])
    assert flips == {True, False}   # both poles were found at some angle


def test_polarity_on_the_saturating_machine_decides_with_margin():
    for th in (0, 135, 180, 315):
        r = simulate("yang2022-polarity", overrides={"initial": {"theta_e_deg": th}})
        assert r.stop_reason == "done" and r.polarity["margin"] > 2.0, (th, r.polarity)
        assert abs(np.degrees(r["theta_err"][-1])) < 20.0   # ended on the right pole


@pytest.mark.parametrize("allow_motion, why", [
    (False, "magnetics are linear, so the pulses have no saturation asymmetry"),
    (True, "polarity undetermined by the motion test (the rotor turned"),
])
def test_a_run_that_failed_exits_1_and_says_why(tmp_path, allow_motion, why):
    """A linear machine whose rotor the load machine holds: the pulses have
    nothing to decide on (the cause beneath named, as the load-time warning
    gives it, whatever the pulses did first), and the motion test cannot turn
    the rotor (its largest push named)."""
    out = tmp_path / "o"
    p = subprocess.run([sys.executable, "-c",
                        "import sys; from fullspeed.cli import main; sys.exit(main(['run', sys.argv[1], '--quiet', '--out', sys.argv[2], "
                        "'--set', sys.argv[3]]))",
                        str(_linear_polarity(tmp_path)), str(out), f"start.allow_motion={str(allow_motion).lower()}"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 1, p.stderr
    assert "fullspeed: run failed: " in p.stderr and "polarity undetermined" in p.stderr
    assert why in p.stderr, p.stderr
    m = json.loads((out / "metrics.json").read_text())
    assert m["stop_reason"] == "polarity_undetermined" and m["polarity"]["stage"] == "undetermined"


def test_a_load_during_polarity_detection_is_warned_of_where_it_makes_the_detection_refuse():
    """The pulses make no torque: an active load turns the rotor while they
    run. Warned where its acceleration uses most of the detection's speed
    tolerance; the simulation refuses there and decides below."""
    def run(T):
        ov = {"load": {"kind": "torque", "torque": T}, "duration": 0.3, "metrics": {"steady": [0.2, 0.3]}}
        warned = any(w.startswith("load.torque") for w in load_scenario("beyond-full-range", ov).warnings)
        return warned, simulate("beyond-full-range", overrides=ov).stop_reason
    assert run(2.0) == (True, "polarity_undetermined")
    assert run(1.0) == (True, "polarity_undetermined")
    assert run(0.6) == (False, "done")
    # the catalog scenario takes its load on after the detection
    assert not [w for w in load_scenario("beyond-full-range").warnings if w.startswith("load.")]


def _linear_polarity(tmp_path):
    f = tmp_path / "lin.toml"
    f.write_text('name = "lin"\nduration = 0.4\nmachine = { catalog = "yang2022", magnetic = { model = "linear" } }\n'
                 '[controller]\nmode = "current"\nangle = "hfi"\n[load]\nkind = "speed"\n')
    return f


# --- the zoo ---------------------------------------------------------------------

def test_the_zoo_is_seeded_and_plausible():
    a, b = zoo.machine(7), zoo.machine(7)
    assert a == b and zoo.machine(7, seed=1) != a
    for k in range(20):
        d = zoo.machine(k)
        m = machine_from_dict(d)
        assert 2 <= m.pole_pairs <= 12 and 1.2 <= m.L_q / m.L_d <= 3.5
        assert 24.0 <= m.bench["u_dc"] <= 700.0 and 8e3 <= m.bench["f_pwm"] <= 20e3
        assert 100.0 <= d["rated"]["power"] <= 50e3
        assert (d.get("magnetic") is not None) == (k % 2 == 0)
        sc = scenario_from_dict({"name": "z", "duration": 0.1, "machine": {"zoo": k},
                                 "controller": {"mode": "speed", "angle": "blend"}})
        assert not [w for w in sc.warnings if not w.startswith("polarity.")], sc.warnings


@pytest.mark.parametrize("k, start", [(1, "motion"), (4, "pulses"), (92, "pulses"), (24, "pulses")])
def test_zoo_sample(k, start):
    """Some of the zoo's runs (the whole zoo is claim B-ZOO), each through the
    whole profile within 15 el.deg: a linear machine starts by the motion
    test; saturating ones by the pulses: 4; 92 (12 pole pairs, 8 kHz: the
    start under half rated load tripped on the paper's injection observer,
    which lagged the load ramp); 24 (the dead time's voltage 0.8 of the
    carrier's: with the usual compensation the estimate wandered 25 el.deg
    at standstill)."""
    from fullspeed.reproduce.papers.zoo import classify
    r = simulate("beyond-zoo", overrides={"machine": {"zoo": k}})
    assert r.scenario.data["start"]["kind"] == start
    row = {**r.metrics, "stop_reason": r.stop_reason}
    assert classify(row) == "success", r.metrics
    assert r["w_m"].max() > 1.25 * r.scenario.machine.w_m_rated and r["w_m"][-1] < 0


def _fluxmap(asym: float) -> dict:
    """A flux map of the test machine whose incremental L_d falls by `asym`
    from negative to positive d current (none with asym = 0)."""
    i = [-60.0 + 10.0 * k for k in range(13)]
    L_d, L_q, psi_f = 0.3e-3, 0.8e-3, 0.02
    psi_d = [[psi_f + L_d * (x - asym * max(x, 0.0) ** 2 / 120.0) for _ in i] for x in i]
    psi_q = [[L_q * y for y in i] for _ in i]
    return {"model": "fluxmap", "i_d": i, "i_q": i, "psi_d": psi_d, "psi_q": psi_q}


@pytest.mark.parametrize("asym, start", [(0.0, "motion"), (0.6, "pulses")])
def test_a_flux_map_without_d_asymmetry_is_named(asym, start):
    """The map's asymmetry decides the start; where the pulses are kept
    anyway (the rotor not to be turned), the warning names the map."""
    m = {**DATASHEET, "magnetic": _fluxmap(asym)}
    sc = scenario(m)
    assert sc.data["start"]["kind"] == start
    assert not [w for w in sc.warnings if w.startswith("polarity.")], sc.warnings
    if start == "motion":
        assert "flux map's incremental L_d differs by only" in sc.data["start"]["reason"]
    kept = scenario(m, start={"allow_motion": False})
    assert kept.data["start"]["kind"] == "pulses"
    assert any(w.startswith("polarity.enabled:") and "flux map" in w for w in kept.warnings) == (start == "motion"), kept.warnings


@pytest.mark.parametrize("asym", [-0.6, 0.6])
def test_a_d_axis_that_saturates_the_other_way_does_not_get_the_pulses(asym):
    """A map whose incremental L_d rises where the d current adds to the
    magnet (a PM-SyRM's ribs, held saturated by the magnet, relieved by it)
    gives the pulses a carrier amplitude smaller on the north pole: they
    would decide for the south pole. The design starts it by the motion test
    instead, naming why, and refuses the pulses where the rotor may not turn;
    the common sign keeps them."""
    from fullspeed.model.errors import ConfigError
    m = {**DATASHEET, "magnetic": _fluxmap(asym)}
    sc = scenario(m)
    if asym > 0:
        assert sc.data["start"]["kind"] == "pulses"
        assert scenario(m, start={"allow_motion": False}).data["start"]["kind"] == "pulses"
        return
    assert sc.data["start"]["kind"] == "motion"
    assert "would decide for the south pole" in sc.data["start"]["reason"], sc.data["start"]["reason"]
    with pytest.raises(ConfigError) as e:
        scenario(m, start={"allow_motion": False})
    assert "start.allow_motion" in str(e.value) and "smaller amplitude where the d current adds to the magnet" in str(e.value)


def test_syre_thor_is_started_by_the_motion_test():
    """SyR-e's THOR: its FEA map's carrier amplitude is about 30 % smaller at
    +13.7 A than at -13.7 A (the drive measured D = -21 % and turned a right
    estimate by pi); its designed start is the motion test."""
    from fullspeed.design.machine import load_machine
    from fullspeed.design.start import carrier_asymmetry
    D = carrier_asymmetry(load_machine("syre-thor"), 13.7, 2.9)[0]
    assert -0.4 < D < -0.2, D
    sc = scenario("syre-thor")
    assert sc.data["start"]["kind"] == "motion" and "south pole" in sc.data["start"]["reason"]


def test_no_voltage_for_a_carrier_is_named_with_its_cause():
    """L in H for mH under a blended drive: the fundamental alone needs more
    than the link, the designed carrier comes out at nothing, and the
    refusal names the carrier's amplitude and why (not its frequency, which
    is what the estimator's own check would blame)."""
    from fullspeed.model.errors import ConfigError
    m = {**DATASHEET, "electrical": {"R_s": 0.05, "L_d": 0.3, "L_q": 0.8, "psi_f": 0.02}}
    with pytest.raises(ConfigError) as e:
        scenario(m)
    msg = str(e.value)
    assert "injection.u_h" in msg and "no voltage left for a carrier" in msg and "below the machine's rated" in msg, msg
    assert "f_h" not in msg, msg
    assert scenario(DATASHEET).data["injection"]["u_h"] > 0.0


def test_a_carrier_taken_from_the_fundamental_where_the_band_passes_base_speed():
    """The new-user trial's 2004 Prius MG2 with its unsaturated L_q: at the
    band's top and i_max the fundamental alone needs more than the link
    (its base speed at i_max lies below the band), yet the machine makes
    its rated torque there with a carrier beside it. The carrier is taken
    from the fundamental (at most half the shared voltage), the design says
    what it costs, and the refusal comes only where the rated torque cannot
    be made while injecting."""
    from fullspeed.design.envelope import envelope, torque_at
    from fullspeed.design.rules import U_H_SHARE, U_H_TAKEN_MAX, u_linear
    prius = {"name": "prius2004", "kind": "ipmsm", "pole_pairs": 4,
             "electrical": {"R_s": 0.077, "L_d": 2.26e-3, "L_q": 6.15e-3, "psi_f": 0.1607},
             "mechanical": {"J": 0.035}, "rated": {"torque": 400.0, "current": 250.0, "speed_rpm": 1200.0},
             "bench": {"u_dc": 500.0, "f_pwm": 10e3, "t_dead": 3e-6, "noise_i": 0.3}}
    sc = scenario(prius)
    u_h = sc.data["injection"]["u_h"]
    u_share = U_H_SHARE * u_linear(500.0, 3)
    assert 0.0 < u_h <= U_H_TAKEN_MAX * u_share
    why = sc.design["injection.u_h"].reason
    assert why.startswith("taken from the fundamental") and "the drive makes at most" in why, why
    # the torque it names is the envelope's at the voltage the carrier leaves, at the band's top
    T_named = float(why.split("makes at most ")[1].split(" N m")[0])
    w_top = sc.data["blending"]["upper_rpm"] * math.pi / 30
    T_all = torque_at(envelope(sc.machine, 500.0, sc.data["controller"]["i_max"], w_end=2 * w_top), w_top)
    assert 400.0 <= T_named < T_all
    # the same machine on a link that leaves less than its rated torque while injecting: refused, naming it
    from fullspeed.model.errors import ConfigError
    with pytest.raises(ConfigError) as e:
        scenario({**prius, "bench": {**prius["bench"], "u_dc": 150.0}})
    assert "below the machine's rated 400 N m" in str(e.value), str(e.value)


def test_a_scenario_loaded_without_warnings_is_the_same_design_and_says_it_was_not_warned():
    ov = {"references": {"speed_rpm": [[0.0, 0.0], [0.4, 2500.0], [0.8, 2500.0]]}, "load": {"torque": 10.0}}
    warned = load_scenario("zou2021-speed-range", ov)
    quiet = load_scenario("zou2021-speed-range", ov, warn=False)
    assert any(w.startswith(("load.torque:", "references.speed_rpm:")) for w in warned.warnings), warned.warnings
    assert quiet.warnings == [UNWARNED]
    assert quiet.data == warned.data and quiet.design.keys() == warned.design.keys()


def test_a_load_no_motion_test_can_outweigh_is_refused_with_its_numbers():
    """The new-user trial's hoist: 15 N m on the Baldor from standstill asked a
    push above the current limit; the design clamped it, the doublet's time
    came out unbounded and the C core refused with 'controller.motion:
    parameter out of range'. Refused before any work, naming the load, what
    may act and what the push at the limit makes."""
    from fullspeed.model.errors import ConfigError
    st = scenario("syre-thor").data["start"]
    T_top = st["c"]["T_push_max"]            # the largest doublet's push unloaded, at most the limit's
    with pytest.raises(ConfigError) as e:
        scenario("syre-thor", load={"kind": "torque", "torque": 5.0 * T_top})
    msg = str(e.value)
    assert msg.startswith("load.torque = ") and "may act while the motion test runs" in msg and "let the load act after" in msg
    ok = scenario("syre-thor", load={"kind": "torque", "torque": 0.3 * T_top})   # outweighed twice: designed, no refusal
    assert ok.data["start"]["c"]["T_push"] > 2 * ok.data["start"]["c"]["T_load"]
    i_push = ok.data["start"]["i_push"]   # given, and too small for that load: refused on start.i_push with what it needs
    with pytest.raises(ConfigError) as e:
        scenario("syre-thor", load={"kind": "torque", "torque": 0.3 * T_top}, start={"i_push": 0.25 * i_push})
    assert str(e.value).startswith("start.i_push = ") and "must outweigh twice the load" in str(e.value)


def test_a_load_that_comes_while_the_motion_tests_retries_run_is_warned():
    """The trial's load ramped in at 0.1..0.4 s: the first doublet's window
    saw little of it and nothing was said; the retries ran into it, the load
    spun the rotor to 2,590 rpm and the run stopped on overcurrent. Warned
    now, naming the load, until when the doublets run and their largest push."""
    sc = scenario("syre-thor")
    c = sc.data["start"]["c"]
    t1 = c["t_lock"]   # the first doublet starts after the lock: a load from then on is the retries'
    T = 0.8 * c["T_push_max"]
    late = scenario("syre-thor", load={"kind": "torque", "torque": [[0.0, 0.0], [c["t_all"] - 0.02, 0.0], [c["t_all"] - 0.01, T]]})
    lines = [w for w in late.warnings if w.startswith("load.torque:")]
    assert late.data["start"]["c"]["T_push"] > 2 * late.data["start"]["c"]["T_load"]   # the first doublet is clear of it
    assert lines and "before the motion test's doublets can all have run" in lines[0] and "largest push" in lines[0]
    after = scenario("syre-thor", load={"kind": "torque", "torque": [[0.0, 0.0], [c["t_all"] + 0.05, 0.0], [c["t_all"] + 0.06, T]]})
    assert not [w for w in after.warnings if "motion test" in w] and t1 < c["t_all"]


def test_a_current_limit_far_above_the_rating_is_warned():
    """The new-user trial set bench.i_max = 50 A on a 12.4 A machine: no word,
    an envelope of 16 x rated torque, a carrier the link could not give, and a
    run stuck at 170 rpm. Above 3 x the rated current: one line naming the
    limit, the factor and the rated current; at 2 x, nothing."""
    def lines(i_max):
        sc = scenario({**DATASHEET, "bench": {**DATASHEET["bench"], "i_max": i_max}})
        return [w for w in sc.warnings if "peak ratings" in w]
    high = lines(120.0)
    assert len(high) == 1 and "120 A, is 4 x the rated current (30 A)" in high[0]
    assert lines(60.0) == []


@pytest.mark.parametrize("field, value, hint", [("L_d", 26.0, "0.026 H if the value is in mH"),
                                                ("psi_f", 444.0, "0.444 Wb if the value is in mWb"),
                                                ("L_q", 1e5, None)])
def test_a_value_in_the_units_thousandth_is_read_as_it(field, value, hint):
    """The new-user trial typed L_d = 26 for 26 mH: refused with the range
    alone. A value above the range that fits it read as the unit's thousandth
    gets that reading beside the refusal; one that does not, the range alone."""
    from fullspeed.model.errors import ConfigError
    m = {**DATASHEET, "electrical": {**DATASHEET["electrical"], field: value}}
    with pytest.raises(ConfigError) as e:
        machine_from_dict(m)
    msg = str(e.value)
    assert f"machine.electrical.{field} = " in msg and "must be a number" in msg
    assert (hint in msg) if hint else ("if the value is in" not in msg)
