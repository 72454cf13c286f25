"""Self-commissioning end to end (issue 25): `fullspeed identify` on a
catalog machine and on one from outside the catalog, each quantity within
its goal and with its status; a failure names its step and reason and
exits 1 with no number left without a status; bad input exits 2."""
from __future__ import annotations

import tomllib

import numpy as np

import pytest

from fullspeed.cli import main
from fullspeed.model.errors import ConfigError
from fullspeed.workflows.identify import GOALS_PCT, QUANTITIES, identify
from fullspeed.design.machine import load_machine
from fullspeed.design.scenario import scenario_from_dict

from tomlw import dumps

# A 1 kW servo motor that is not in the catalog, with its own bench: dead
# time, quantization and noise on, the switching inverter, a saturating d
# axis and cross-saturation.
SERVO = {
    "name": "servo-1kw", "kind": "ipmsm", "phases": 3, "pole_pairs": 4,
    "electrical": {"R_s": 0.9, "L_d": 3.2e-3, "L_q": 6.5e-3, "psi_f": 0.075},
    "mechanical": {"J": 4e-4, "B": 2e-5, "T_coulomb": 0.02},
    "rated": {"torque": 3.2, "current": 8.0, "speed_rpm": 3000.0},
    "magnetic": {"model": "algebraic", "a_dd": 2e4, "S": 4.0, "a_dq": 5e3, "U": 2.0, "V": 1.0},
    "bench": {"u_dc": 320.0, "f_pwm": 16000.0, "t_dead": 1.0e-6, "i_max": 12.0, "i_trip": 15.0, "adc_bits": 12,
              "adc_range": 18.0, "noise_i": 0.015, "bw_current": 5000.0, "bw_speed": 150.0, "bw_pll": 900.0},
}


def _scenario(machine=SERVO, **extra):
    return scenario_from_dict({"name": "identify-servo", "duration": 1.0, "machine": machine,
                               "controller": {"mode": "off"}, "initial": {"theta_e_deg": 137.0}, **extra})


def _within_goals(res):
    assert res.ok, res.failures()
    err = res.errors_pct()
    assert set(err) == set(GOALS_PCT)
    for q, e in err.items():
        assert abs(e) <= GOALS_PCT[q], f"{res.machine} {q}: {e:+.2f} % (goal {GOALS_PCT[q]} %)"


def test_catalog_machine_cli(tmp_path):
    out = tmp_path / "yang"
    assert main(["identify", "yang2022-encoder-speedstep", "--out", str(out)]) == 0
    tab = tomllib.loads((out / "identification.toml").read_text())
    for q in QUANTITIES:
        assert tab[q]["status"] == "ok"
    for q, goal in GOALS_PCT.items():
        assert abs(tab[q]["error_pct"]) <= goal, (q, tab[q])
    # the identified machine file is a machine fullspeed takes
    m = load_machine(out / "machine.toml")
    assert m.R_s == pytest.approx(tab["R_s"]["identified"]) and m.J == pytest.approx(tab["J"]["identified"])
    assert not list(out.glob(".*tmp")), "temporary files left behind"


def test_machine_outside_the_catalog():
    res = identify(_scenario())
    _within_goals(res)
    # the truth of L is the plant's incremental inductance at zero current,
    # which saturation puts below the nominal L_d
    assert res.truth["L_d"] < SERVO["electrical"]["L_d"]
    assert res.values["u_e"] == pytest.approx(res.truth["u_e"], rel=0.1)


def test_failure_names_step_and_reason(tmp_path, capsys):
    # phase a open: no alpha current answers the probe
    path = tmp_path / "open.toml"
    path.write_text(dumps({"name": "open-phase", "duration": 1.0, "machine": SERVO, "controller": {"mode": "off"},
                           "faults": {"open_phase": "a", "t_open": 0.0}}))
    out = tmp_path / "out"
    assert main(["identify", str(path), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "verr (levels): the current did not answer the largest voltage pulse" in err
    tab = tomllib.loads((out / "identification.toml").read_text())
    for q in QUANTITIES:
        assert tab[q]["status"] == "failed" and tab[q]["reason"]
        assert not any(k.startswith(("identified", "error_pct")) for k in tab[q]), f"a number without a status in {q}"
    assert not (out / "machine.toml").exists()


def test_bad_input_exits_2(tmp_path, capsys):
    assert main(["identify", "yu2022-seq-dyn", "--out", str(tmp_path)]) == 2   # five phases
    assert "machine.phases" in capsys.readouterr().err
    assert main(["identify", "yang2022-encoder-speedstep", "--speed-frac", "0", "--out", str(tmp_path)]) == 2
    assert "speed_frac" in capsys.readouterr().err
    assert not (tmp_path / "identification.toml").exists()


def test_zoo_campaign_row(tmp_path):
    from fullspeed.workflows.identify import campaign_summary, zoo_campaign

    rows = zoo_campaign([3], tmp_path, workers=1)
    (row,) = rows
    assert row["ended_in"] == "done" and all(s == "ok" for s in row["status"].values()), row["failures"]
    s = campaign_summary(rows)
    assert s["failed_pct"] == 0.0 and s["R_s"]["identified"] == 1
    for q, goal in GOALS_PCT.items():
        assert s[q]["p95"] == pytest.approx(abs(row["errors_pct"][q])) and s[q]["p95"] <= goal


def test_campaign_summary_counts_failures():
    from fullspeed.workflows.identify import campaign_summary

    ok = {"machine": "a", "status": {q: "ok" for q in QUANTITIES}, "reason": {q: "" for q in QUANTITIES},
          "errors_pct": {q: 1.0 for q in GOALS_PCT}, "failures": []}
    bad = {"machine": "b", "status": {**ok["status"], "J": "failed", "friction": "failed"},
           "reason": {**ok["reason"], "J": "the speed changed too fast to fit", "friction": "an earlier quantity failed"},
           "errors_pct": {q: 2.0 for q in GOALS_PCT if q != "J"}, "failures": ["J (coast): ..."]}
    s = campaign_summary([ok, bad, dict(bad, machine="c", reason={**bad["reason"], "J": ""})])
    assert s["failed_pct"] == pytest.approx(200.0 / 3)
    assert s["failed_with_reason"] == 1          # machine c failed J without saying why
    assert s["J"]["identified"] == 1 and s["R_s"]["identified"] == 3
    assert s["R_s"]["max"] == 2.0 and set(s["failures"]) == {"b", "c"}


def test_identified_scales_put_the_identified_values_in_the_controller():
    """identify, then run sensorless: the controller's scales make its model
    the identified one (identified = truth x (1 + error); the inductances'
    truth is the small-signal one, against the machine file's nominal)."""
    from fullspeed.model import zoo
    from fullspeed.workflows.identify import identified_scales, small_signal_inductances
    from fullspeed.design.machine import machine_from_dict

    errs = {"R_s": 1.0, "L_d": -2.0, "L_q": 0.5, "psi_f": -1.0, "J": 4.0}
    row = {"status": {q: "ok" for q in errs}, "errors_pct": errs}
    for k in (2, 3):   # saturating (small-signal L below nominal), linear (equal)
        m = machine_from_dict(zoo.machine(k))
        L_d, L_q = small_signal_inductances(m)
        s = identified_scales(row, k)
        assert s["R_s_scale"] == pytest.approx(1.01) and s["psi_f_scale"] == pytest.approx(0.99)
        assert s["J_scale"] == pytest.approx(1.04)
        assert m.L_d * s["L_d_scale"] == pytest.approx(0.98 * L_d) and m.L_q * s["L_q_scale"] == pytest.approx(1.005 * L_q)
        assert (L_d < 0.999 * m.L_d) == (k % 2 == 0)
    assert identified_scales({**row, "status": {**row["status"], "J": "failed"}}, 2) is None


# ---- issue 35: the flux map, the machine file, the goals, the [identify] table ----

def _fake(values, truth=None, status=None):
    """An Identification as the sequence would return it (for what is done with it)."""
    from fullspeed.workflows.identify import Identification

    truth = truth or {"R_s": 0.9, "L_d": 3e-3, "L_q": 6e-3, "psi_f": 0.075, "J": 4e-4, "B": 0.0, "T_c": 0.0,
                      "u_e": 1.0, "L_d_nominal": 3e-3, "L_q_nominal": 6e-3}
    st = {q: "ok" for q in QUANTITIES}
    st["map"] = "skipped"
    st.update(status or {})
    return Identification("servo-1kw", st, {q: "" for q in QUANTITIES}, values, truth, "done", 5.0, 0.5)


GOOD = {"u_e": 1.0, "i_e": 0.1, "R_s": 0.9, "L_d": 3e-3, "L_q": 6e-3, "psi_f": 0.075, "J": 4e-4, "B": 1e-5, "T_c": 0.01}


def test_own_flux_map_machine_identifies_and_its_files_load(tmp_path):
    """The README's own flux-map machine (the trial's TypeError): identified,
    its map written as the loader's CSV, the machine file pointing at it and
    loadable, the map's reported error that of the file written."""
    from fullspeed.model.fluxmap import interp, load_map
    from fullspeed.workflows import mapid
    from fullspeed.workflows.identify import true_flux

    out = tmp_path / "own"
    rc = main(["identify", "examples/own-machine/my48v-full-range.toml", "--out", str(out)])
    tab = tomllib.loads((out / "identification.toml").read_text())
    assert rc == (0 if all(tab[q]["status"] in ("ok", "skipped") for q in QUANTITIES) else 1)
    # identified (on this frictionless rotor the sweeps leave it turning: within or outside its goal), and
    # nearer the truth than the constant L_d, L_q, psi_f the map replaces
    assert tab["map"]["status"] in ("ok", "outside goal")
    assert tab["map"]["rms_error_pct_of_psi_f"] < 0.5 * tab["map"]["constant_model_rms_error_pct"]
    m = load_machine(out / "machine.toml")
    assert m.magnetic["model"] == "fluxmap" and m.T_coulomb >= 0.0 and m.B >= 0.0
    # the file written is the map assessed: its RMS error over the disc recomputed from it
    mag = load_map(out / "fluxmap.csv", "magnetic.file")
    truth = load_machine("examples/own-machine/my48v.toml")
    flux = true_flux(truth)
    a, b = mapid.disc_points(48.0)   # the bench's current limit
    td, tq = flux(a, b)
    e = np.r_[interp(mag, "psi_d", a, b) - td, interp(mag, "psi_q", a, b) - tq] / truth.psi_f
    assert 100.0 * np.sqrt(np.mean(e ** 2)) == pytest.approx(tab["map"]["rms_error_pct_of_psi_f"], rel=0.02)
    # psi_d(0, 0) is the identified psi_f; the d-axis asymmetry polarity detection needs is reported
    assert interp(mag, "psi_d", np.array([0.0]), np.array([0.0]))[0] == pytest.approx(tab["psi_f"]["identified"], rel=1e-6)
    assert abs(tab["map"]["d_asymmetry_at_i_pulse"] - tab["map"]["d_asymmetry_truth"]) < 0.05
    assert (out / "fluxmap-measured.csv").read_text().count("standstill q sweep") > 10


def test_outside_goal_is_reported_and_exits_1(tmp_path, monkeypatch, capsys):
    """J 15.8 % off against its 10 % goal (the trial's H27) is not "ok"."""
    from fullspeed.workflows import identify as ident

    res = _fake(dict(GOOD, J=4e-4 * 1.158))
    ident._goals(res)
    assert res.status["J"] == ident.OUTSIDE and "+15.80 %" in res.reason["J"] and "10 % goal" in res.reason["J"]
    assert not res.ok and res.failures() == [f"J (coast): {res.reason['J']}"]
    assert res.status["R_s"] == "ok"
    monkeypatch.setattr(ident, "identify", lambda *a, **k: res)
    assert main(["identify", "yang2022-encoder-speedstep", "--out", str(tmp_path)]) == 1
    assert "J (coast): +15.80 %" in capsys.readouterr().err
    tab = tomllib.loads((tmp_path / "identification.toml").read_text())
    assert tab["J"]["status"] == "outside goal" and tab["J"]["error_pct"] == pytest.approx(15.8)


def test_machine_file_fits_the_schema_or_is_not_left(tmp_path):
    """A friction fitted below zero (the trial's T_coulomb = -0.00026) is
    written as zero with a note; a value the loader refuses leaves no
    machine.toml, the refusal reported."""
    from fullspeed.workflows.identify import write_identification

    sc = _scenario()
    res = _fake(dict(GOOD, T_c=-2.6e-4, B=-1e-6))
    write_identification(res, sc, tmp_path / "a")
    m = load_machine(tmp_path / "a" / "machine.toml")
    assert m.T_coulomb == 0.0 and m.B == 0.0
    notes = res.details["machine_file"]["notes"]
    assert any("T_coulomb fitted -0.00026 set to 0" in n for n in notes)
    assert "T_coulomb fitted" in tomllib.loads((tmp_path / "a" / "machine.toml").read_text())["source"]
    bad = _fake(dict(GOOD, R_s=-0.1))
    write_identification(bad, sc, tmp_path / "b")
    assert not (tmp_path / "b" / "machine.toml").exists()
    assert "R_s" in bad.details["machine_file"]["refused"]
    assert "R_s" in tomllib.loads((tmp_path / "b" / "identification.toml").read_text())["machine_file"]["refused"]


def test_refused_machine_file_is_no_success(tmp_path, monkeypatch, capsys):
    """Every quantity within its goal but the machine file refused by the
    loader (an identified map whose flux fell with its current, on the grin
    hub motor in an experiment): nothing to run on, so exit 1 with the
    refusal, not 0."""
    from fullspeed.workflows import identify as ident

    res = _fake(dict(GOOD))
    monkeypatch.setattr(ident, "identify", lambda *a, **k: res)
    assert main(["identify", "yang2022-encoder-speedstep", "--out", str(tmp_path / "a")]) == 0   # the same, written
    assert (tmp_path / "a" / "machine.toml").exists()

    def refuse(path):
        raise ConfigError("machine.magnetic.psi_q[8][6]", -0.00278553739, "must be above psi_q[8][5] = -0.00241193")
    monkeypatch.setattr(ident, "load_machine", refuse)
    assert main(["identify", "yang2022-encoder-speedstep", "--out", str(tmp_path / "b")]) == 1
    err = capsys.readouterr().err
    assert "machine.toml not written, the loader refuses it: machine.magnetic.psi_q[8][6]" in err, err
    assert not (tmp_path / "b" / "machine.toml").exists()


def test_locked_rotor_standstill_only(tmp_path):
    """[identify] locked: the standstill steps (and the map, unbounded by
    motion) on a held shaft; psi_f, J and friction skipped, saying why."""
    from fullspeed.workflows.identify import machine_table, write_identification

    # the speed loop's and the PLL's bandwidths left to the design: the written file must leave them out too
    servo = dict(SERVO, bench={k: v for k, v in SERVO["bench"].items() if k not in ("bw_speed", "bw_pll")})
    sc = _scenario(machine=servo, identify={"locked": True})
    res = identify(sc)
    assert res.step == "done" and res.ok, res.failures()
    for q in ("psi_f", "J", "friction"):
        assert res.status[q] == "skipped" and res.reason[q] == "skipped: the rotor is locked"
    err = res.errors_pct()
    assert set(err) == {"R_s", "L_d", "L_q"} and all(abs(e) <= GOALS_PCT[q] for q, e in err.items())
    assert res.map["errors"]["rms_pct"] <= 3.0
    assert res.motion["max_deg"] < 0.01     # the shaft held
    assert "map" not in res.times["quantities"] or res.times["quantities"]["psi_f"] == 0.0
    tab, notes = machine_table(res, sc)
    assert tab["electrical"]["psi_f"] == SERVO["electrical"]["psi_f"] and "not identified" in notes[0]
    # the bench as the file gave it: a designed bandwidth written would read as given, and a sensorless
    # drive on the identified file would keep the identification's speed loop instead of the one its
    # observer allows (B-MAPID's zoo 6: 125.7 rad/s where the true file designs 37.7, and lost lock)
    assert set(tab["bench"]) == set(servo["bench"]) | {"sampling", "encoder_bits"} - {"bw_speed", "bw_pll"}
    blended = {"name": "b", "duration": 1.0, "controller": {"mode": "speed", "angle": "blend"}}
    write_identification(res, sc, tmp_path)
    given, written = (scenario_from_dict({**blended, "machine": mach}) for mach in (servo, str(tmp_path / "machine.toml")))
    assert written.data["controller"]["bw_speed"] == given.data["controller"]["bw_speed"] < servo["bench"]["bw_current"] / 30


def test_may_not_turn_without_polarity_is_refused_before_it_turns():
    """[identify] may_turn = false on a free rotor whose polarity does not
    show standing (the servo's d-axis asymmetry at i_max/2 is 2 %): the
    levels would turn it (-I pushes the magnet away); refused, naming the
    cure, with the rotor left where it was."""
    res = identify(_scenario(identify={"may_turn": False}))
    assert res.step == "failed" and res.status["verr"] == "failed"
    assert "lock it" in res.reason["verr"] and "polarity" in res.reason["verr"]
    assert res.motion["max_deg"] < 2.0 and "levels" not in res.motion["steps"]
    for q in ("psi_f", "J", "friction"):
        assert res.status[q] == "skipped"


def test_identify_settings_are_checked(tmp_path, capsys):
    scen = tmp_path / "s.toml"
    for table, field in (({"i_test": 13.0}, "identify.i_test"), ({"t_level": 1e-3}, "identify.t_level")):
        scen.write_text(dumps({"name": "s", "duration": 1.0, "machine": SERVO, "controller": {"mode": "off"},
                               "identify": table}))
        assert main(["identify", str(scen), "--out", str(tmp_path / "o")]) == 2
        assert field in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_motion_and_time_are_reported():
    """Every standstill step's motion (el.deg, with its current) and every
    step's time; the standstill steps other than ALIGN (which turns the
    rotor on purpose: the servo's polarity does not show) keep the servo
    within 5 el.deg."""
    res = identify(_scenario())
    steps = res.motion["steps"]
    assert {"probe", "axis", "polarity", "levels", "ldq", "check_premap", "map", "check"} <= set(steps)
    for st, v in steps.items():
        assert v["i_peak"] > 0.0
        if st != "align":
            assert v["max_deg"] < 5.0, (st, v)
    assert steps["align"]["max_deg"] > 5.0   # ALIGN ran and turned it (a polarity that does not show)
    tm = res.times
    assert sum(tm["steps"].values()) == pytest.approx(tm["total"]) and tm["total"] <= res.sim_time
    assert all(tm["quantities"][q] > 0.0 for q in QUANTITIES)
    assert tm["standstill"] < tm["total"]


# The trial's Prius-like machine (linear copy, no friction): p = 4, R_s 0.077 ohm,
# L_d 2.26 mH, L_q 6.15 mH, psi_f 0.1607 Wb, J 0.035 kg m^2, 500 V, 10 kHz, 250 A.
PRIUS = {
    "name": "prius-lin", "kind": "ipmsm", "pole_pairs": 4,
    "electrical": {"R_s": 0.077, "L_d": 2.26e-3, "L_q": 6.15e-3, "psi_f": 0.1607},
    "mechanical": {"J": 0.035}, "rated": {"torque": 400.0, "current": 250.0, "speed_rpm": 1200.0},
    "bench": {"u_dc": 500.0, "f_pwm": 10000.0, "t_dead": 3e-6, "noise_i": 0.3, "i_max": 250.0},
}


def test_prius_like_standstill_steps_keep_the_rotor():
    """The trial's "verr (levels): the rotor moved at standstill": the levels
    stay below half of psi_f / (L_q - L_d) (20.7 A; 24.5 A by AXIS's L), where the magnet holds
    the aligned rotor against the reluctance torque (at the old 150 A the
    rotor's rest is 74 el.deg off the current); R_s, L_d, L_q within goals."""
    res = identify(_scenario(PRIUS))
    for q in ("verr", "R_s", "L_d", "L_q"):
        assert res.status[q] == "ok", (q, res.reason[q])
    d = res.details   # the bound from AXIS's inductances (its carrier's L_q - L_d, 16 % below the truth's here)
    assert d["i_level_top"] == pytest.approx(0.5 * 0.1607 / (d["L_q_axis"] - d["L_d_axis"]), rel=1e-4)
    assert d["i_level_top"] < 0.6 * 0.1607 / (6.15e-3 - 2.26e-3)
    assert res.motion["steps"]["levels"]["max_deg"] < 15.0   # ALIGN's last swing on a frictionless rotor (was 762)
    locked = identify(_scenario(PRIUS, identify={"locked": True}))
    assert locked.ok and locked.map["errors"]["rms_pct"] <= 3.0, locked.failures()


def test_map_summary_counts_the_saturating_machines():
    from fullspeed.workflows.identify import map_summary

    rows = [{"machine": f"m{k}", "saturates": k % 2 == 0, "status": {"map": "ok"}, "reason": {"map": ""},
             "map": {"rms_pct": float(k), "constant_rms_pct": 2.0 * k}} for k in range(6)]
    rows[4] = {"machine": "m4", "saturates": True, "status": {"map": "failed"}, "reason": {"map": "the sweeps did not read the grid"}}
    s = map_summary(rows)
    assert s["machines"] == 3 and s["identified"] == 2 and s["max"] == 2.0
    assert s["not_identified"] == {"m4": "failed: the sweeps did not read the grid"}
    assert map_summary(rows, saturating_only=False)["identified"] == 5


def test_catalog_flux_map_machine_identified_locked_or_refused_naming_the_motion():
    # the Prius MG2 free: its standstill steps hold the rotor now (the probe's pulses bipolar on both axes,
    # tests/test_ident_standstill.py), its constants identified; its map's d sweep to the current limit
    # would push the magnet off the axis (i_d beyond psi_f / (L_q - L_d)): not identified, naming the cure; what
    # its sweeps read is kept as a partial map, outside its goal (tests/test_mapid_extrapolation.py)
    free = identify(_scenario("prius2004-mg2"))
    assert not free.ok
    for q in ("verr", "R_s", "L_d", "L_q", "psi_f", "J"):
        assert free.status[q] == "ok", (q, free.reason[q])
    assert free.status["map"] == "outside goal" and free.reason["map"].startswith("partial: ")
    assert "lock it" in free.reason["map"] and "psi_f / (L_q - L_d)" in free.reason["map"]
    # locked, as the reason says: the map within its goal
    held = identify(_scenario("prius2004-mg2", identify={"locked": True}))
    assert held.status["map"] == "ok" and held.map["errors"]["rms_pct"] <= 3.0
    assert all(held.status[q] == "ok" for q in ("verr", "R_s", "L_d", "L_q"))


def test_sensorless_on_identified_runs_only_the_true_parameter_runs_not_given(tmp_path, monkeypatch):
    """The true-parameter runs made already (B-ZOO's) are taken as they are,
    each beside its own machine's run on the identified parameters."""
    from fullspeed.workflows import identify as idf

    rows = [{"k": k, "status": {q: "ok" for q in QUANTITIES}, "errors_pct": {q: 1.0 for q in QUANTITIES}}
            for k in (0, 1, 2)]   # 1: a linear machine, not run
    kept = {"stop_reason": "done", "lock_lost_at": None, "true_loss_at": None}
    lost = dict(kept, lock_lost_at=1.0)
    ran = []

    def fake_run_tasks(fn, tasks, out, **kw):
        ran.extend(tasks)
        return [lost if t["k"] == 2 and not t["scales"] else kept for t in tasks]
    monkeypatch.setattr(idf, "run_tasks", fake_run_tasks)
    s = idf.sensorless_on_identified(rows, tmp_path, true_runs={0: kept})
    assert [(t["k"], bool(t["scales"])) for t in ran] == [(0, True), (2, False), (2, True)]
    assert s == {"machines": 2, "kept_true": 1, "kept_identified": 2, "differ": [2]}
    ran.clear()
    s0 = idf.sensorless_on_identified(rows, tmp_path, true_runs={0: lost})
    assert len(ran) == 3 and s0["kept_true"] == 0 and s0["differ"] == [0, 2]


def test_free_rotors_swing_is_not_read_into_the_map():
    """The q sweeps swing a free rotor by up to motion_max (1 el.deg), whose
    speed voltage w psi_d integrates to psi_d theta in the q flux read, 1.7 %
    of psi_f an el.deg: the sweeps take it out (fs_mapid.h). Zoo machine 10
    free (seed 2026): its q flux within 0.3 % of psi_f RMS over the disc
    (0.87 % with the swing left in, 0.03 % locked)."""
    from fullspeed.workflows.identify import zoo_identification

    row = zoo_identification(10)
    assert row["status"]["map"] == "ok", row["failures"]
    assert row["motion"]["steps"]["map"] > 0.5   # the rotor did swing in the sweeps
    assert row["map"]["rms_q_pct"] <= 0.3, row["map"]


def test_J_from_the_measured_torque_is_not_biased_high(tmp_path):
    """J = p T / (a_acc - a_coast) with T the measured current's torque, as
    the acceleration's fit weighs it: the reference's torque left the
    current loop's error under the rising back-EMF in J (100 of the zoo's
    100 above the truth, by 1.9 % on average, machine 0 by 3.0 %). Over zoo
    machines 0..7 the errors are centred on zero and each within 1.5 %."""
    from fullspeed.workflows.identify import zoo_campaign

    rows = zoo_campaign(range(8), tmp_path, workers=1)
    e = np.array([r["errors_pct"]["J"] for r in rows])
    assert abs(e.mean()) <= 0.5 and np.abs(e).max() <= 1.5, e


def test_inverter_error_knee_follows_the_ripple():
    """siemens-1ft6084's bench (2.5 us dead time at 5 kHz: 7 V a leg, 2.2 mH)
    on its free, rubbing shaft: with the leg error's knee LEVELS fitted at dc
    (29 mA), the 25 mA the current loop lags the coast's falling EMF by at
    zero current took the whole 7 V for its sign, psi_f came out 3.9 % low,
    and the map's d sweeps read a 20 % d-axis asymmetry into this linear
    machine, so the drive designed from the identified file chose polarity
    detection, which the true machine refused (polarity_undetermined). The
    knee is the ripple's displacement at the leg's edges too (fs_ident.c):
    psi_f within its goal, no asymmetry polarity detection would take for
    one, and the identified file's start the true file's."""
    from fullspeed.design.start import POLARITY_ASYMMETRY

    res = identify(_scenario("siemens-1ft6084"))
    assert res.status["psi_f"] == "ok" and abs(res.errors_pct()["psi_f"]) <= 1.0, res.errors_pct()
    assert res.status["map"] == "ok", res.reason["map"]
    pol = res.map["polarity"]
    assert pol["asymmetry_truth"] == pytest.approx(0.0, abs=1e-6)
    assert pol["asymmetry"] < POLARITY_ASYMMETRY and not pol["decides"], pol


def test_identified_linear_machine_starts_as_the_true_one(tmp_path):
    """identify, then run: the sensorless start the design chooses from the
    identified siemens-1ft6084 file is the true file's (an I/f start: no
    saliency), not a polarity detection its flux map would ask for."""
    from fullspeed.workflows.identify import write_identification

    sc = _scenario("siemens-1ft6084")
    res = identify(sc)
    write_identification(res, sc, tmp_path)
    run = {"name": "r", "duration": 1.0, "controller": {"mode": "speed", "angle": "blend"}}
    true = scenario_from_dict({**run, "machine": "siemens-1ft6084"}, warn=False)
    ident = scenario_from_dict({**run, "machine": str(tmp_path / "machine.toml"), "plant_machine": "siemens-1ft6084"},
                               warn=False)
    assert true.data["start"]["kind"] == "if"
    assert ident.data["start"]["kind"] == true.data["start"]["kind"]
    assert ident.data["controller"]["angle"] == true.data["controller"]["angle"]


@pytest.mark.parametrize("name, rms_max", [("baldor-ecs101m0h7ef4", 3.0), ("syre-thor", 5.0)])
def test_pm_syrm_locked_map_not_mirrored(name, rms_max):
    """The catalog's PM-SyRMs locked (their free rotors turn through LEVELS):
    their incremental L_d peaks at a positive d current (the ribs the magnet
    saturates relieved) and is still higher at +i_max/2 than at -i_max/2, so
    a polarity read there took the north for the south and mirrored the map
    (Baldor 13.4 %, THOR 38.6 % of psi_f RMS from this angle). Read at
    +-3/4 i_max, where the main path's saturation decides (fs_mapid.c), and
    on a locked rotor left to MAP's full d sweep where the polarity sweep
    could not step there: the d axis read within 1 % of psi_f of the truth.
    The Baldor's map is within B-MAPID's 3 %; THOR's is not from every
    angle (2.6 % from 0 el.deg, 4.8 % from this one, where MAP turns the
    frame and the q sweeps at +i_max/4 let the held d current drift to 17 A;
    the map's own grid, the truth at its points, is 2.1 % off over the
    disc), so it is held to 5 % here, the 3 % reported as not met. From
    this angle the right polarity also took THOR's q sweep at +i_max/4 past
    the sequence's 1.1 i_max (its L_q falls 15-fold towards i_max, and the
    reversal was predicted on the last step): the steps' growth is taken on
    now (fs_mapid.c, leg_next)."""
    from fullspeed.workflows.identify import true_flux

    res = identify(_scenario(name, identify={"locked": True}))
    assert res.status["map"] in ("ok", "outside goal"), res.reason["map"]
    if name.startswith("baldor"):
        # L_q at zero current from biases +-I_b on a locked rotor: through I_b and 2 I_b on the north (its
        # polarity now read) it extrapolated across the bend of its L_q near zero: +12 %
        assert res.status["L_q"] == "ok" and abs(res.errors_pct()["L_q"]) <= GOALS_PCT["L_q"], res.errors_pct()
    assert res.map["errors"]["rms_pct"] <= rms_max, res.map["errors"]
    g = res.map["grid"]
    flux = true_flux(load_machine(name))
    psi_f = load_machine(name).psi_f
    nq = len(g["i_q"]) // 2
    i_max = res.map["i_max"]
    for k, i_d in enumerate(g["i_d"]):   # the d axis, both sides of the magnet, within the current limit
        if abs(i_d) > i_max * (1 + 1e-9):
            continue
        assert abs(g["psi_d"][k, nq] - float(flux(i_d, 0.0)[0])) <= 0.01 * psi_f, (i_d, g["psi_d"][k, nq])


def test_light_rotors_acceleration_is_sized_from_what_it_showed():
    """The Prius MG2 free (0.035 kg m^2, 271 A, no friction): its first
    acceleration rose 40 % in 49 ms, and a quarter of the current a retry
    left it at 5 A, whose rise took 0.19 s against the 0.25 s its fit needs:
    J failed "too fast". The retry's current now comes from the acceleration
    the try showed (fs_ident.c, step_accel): J within its goal. From 0
    el.deg, B-REAL's angle (from 137 el.deg the standstill steps do not hold
    this rotor: test_catalog_flux_map_machine_identified_locked_or_refused_naming_the_motion)."""
    res = identify(_scenario("prius2004-mg2", initial={"theta_e_deg": 0.0}))
    assert res.status["J"] == "ok", res.reason["J"]
    assert abs(res.errors_pct()["J"]) <= GOALS_PCT["J"]


def test_speed_lost_at_speed_stops_the_d_levels():
    """anaheim-bly171d free (J 2.4e-6 kg m^2, J/B = 0.21 s): the rotor halved
    its speed in FLUX and turned backwards in DCURVE's first d level (a frame
    a little off the axis makes torque of the d current, which turns it
    further off); ACCEL then held its current on a frame off the rotor for
    the whole 20 s allowed and J failed "too fast". The levels stop below
    half of FLUX's speed and when a level moves the speed by a fifth, and a
    level whose d current turns a misaligned rotor away is run only where
    that loop's rate sqrt(p |K| / J) is a third of the PLL's bandwidth
    (322 rad/s at -i_max / 2 here against 250): the sequence ends, J
    within its goal."""
    res = identify(_scenario("anaheim-bly171d"))
    assert res.step == "done", res.failures()
    assert res.status["J"] == "ok" and res.status["friction"] == "ok", res.failures()
    assert abs(res.errors_pct()["J"]) <= GOALS_PCT["J"]
    assert res.times["steps"]["accel"] < 2.0   # not the 20 s of a frame off the rotor


def test_refusals_carry_their_numbers():
    """A refusal says the physical cause with its numbers, not its kind
    alone: the free Prius MG2's map (the d currents that push its magnet
    off the axis against the sweep's)."""
    prius = identify(_scenario("prius2004-mg2", initial={"theta_e_deg": 0.0}))
    assert prius.status["map"] == "outside goal" and prius.reason["map"].startswith("partial: ")
    why = prius.reason["map"]
    assert "lock it" in why and "psi_f / (L_q - L_d)" in why and "0.1607 Wb" in why, why
    dL = prius.values["L_q"] - prius.values["L_d"]
    assert f"= {0.1607 / dL:.3g} A" in why and "+-270.7 A" in why, why


def test_pm_syrm_spins_on_isotropic_loops():
    """The Baldor PM-SyRM free (L_q 5.5 L_d): with the polarity read right its
    standstill steps hold it, and the I/f spin follows. On the loops of the
    aligned frame the spin's q loop, on the rotor's d axis while the rotor
    lagged the ramp by up to a quarter turn, saw 5.5 times its designed gain,
    rang at the voltage limit and stalled the spin at a fifth of its speed:
    J failed "too fast". On the smaller inductance on both axes until FLUX
    has locked the frame on the EMF (fs_ident.c): psi_f and J within their
    goals."""
    res = identify(_scenario("baldor-ecs101m0h7ef4", initial={"theta_e_deg": 0.0}))
    for q in ("verr", "R_s", "L_d", "L_q", "psi_f", "J", "friction"):
        assert res.status[q] == "ok", (q, res.reason[q])
    assert res.details["w_flux"] > 0.8 * 0.3 * 2 * 1800 * 2 * np.pi / 60   # the spin reached its speed
    assert res.motion["steps"]["levels"]["max_deg"] < 5.0


def test_check_holds_a_light_salient_rotor_before_the_spin():
    """The free H27 (J 4e-4 kg m^2, no friction): the CHECK after MAP, a d
    carrier at zero current, pushed its d axis away from itself (the
    carrier's mean reluctance torque, an inverted pendulum) from 5 to 148
    el.deg, and the I/f spin started on the axis CHECK read: "the rotor did
    not follow the I/f frame", psi_f and J failed. A small d bias on the
    north holds it (fs_ident.c): the spin follows, psi_f and J within their
    goals."""
    res = identify(_scenario("hefei-h27", initial={"theta_e_deg": 0.0}))
    for q in ("psi_f", "J", "friction"):
        assert res.status[q] == "ok", (q, res.reason[q])
    assert abs(res.errors_pct()["psi_f"]) <= GOALS_PCT["psi_f"] and abs(res.errors_pct()["J"]) <= GOALS_PCT["J"]
    assert res.motion["steps"]["check"]["max_deg"] < 90.0


def test_map_says_which_q_sweeps_fell_short(capsys):
    """The Baldor free: its q sweeps stopped at i_d = 0 when the rotor was
    still turning at the level's end, and the other levels were never
    swept, so 134 of the grid's 153 points are extrapolated (10 % of psi_f
    off). The summary names each level that fell short and why, where the
    drive alone (no truth) would otherwise show only the counts."""
    from fullspeed.workflows.identify import print_identification

    res = identify(_scenario("baldor-ecs101m0h7ef4", initial={"theta_e_deg": 0.0}))
    print_identification(res)
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if "q sweeps short of the disc" in x)
    assert "i_d +0 A: the sweeps stopped: the rotor turning" in line, line
    assert line.count("not reached") == 6, line


def test_identified_map_reaches_past_the_current_limit(tmp_path):
    """The map written reaches a step past +-i_max on both axes (marked
    extrapolated), so that the design has slopes at the limit: ending at
    it, the cross-saturation table designed from zoo machine 2's identified
    map led by 78 el.deg at the limit against the truth's 19 (the loader's
    clamp read as a zero slope). Within 25 el.deg of the truth's there now."""
    from fullspeed.design.machine import machine_from_dict
    from fullspeed.design.xcomp import designed_table
    from fullspeed.model.zoo import machine as zoo_machine
    from fullspeed.workflows.identify import zoo_identification

    row = zoo_identification(2, folder=str(tmp_path))
    m = load_machine(row["machine_file"])
    i_max = m.bench["i_max"]
    assert min(m.magnetic["i_d"]) < -1.2 * i_max and max(m.magnetic["i_q"]) > 1.1 * i_max
    ident, _ = designed_table(m, i_max)
    true, _ = designed_table(machine_from_dict(zoo_machine(2)), i_max)
    assert abs(ident["delta_deg"][-1] - true["delta_deg"][-1]) < 25.0, (ident["delta_deg"][-1], true["delta_deg"][-1])
    rows = [x[2:] for x in (tmp_path / "fluxmap.csv").read_text().splitlines()[5:] if x.startswith("# ")]
    assert len(rows) == 11 and rows[0] == rows[-1] == "e" * 19   # the rows past +-i_max, all extrapolated
    assert all(r[0] == r[-1] == "e" for r in rows)


def test_the_truth_is_the_plant_the_simulation_turns():
    """The new-user trial identified with a guessed nameplate as `machine` and
    the real machine as `plant_machine`: the values found were the plant's
    (psi_f within 0.1 %, J 0.7 %), but they were judged against the nameplate
    and reported failed (+10.9 %, +48.9 %), exit 1. Judged against the plant,
    the nameplate's own errors do not enter."""
    guess = {**SERVO, "electrical": {**SERVO["electrical"], "psi_f": 0.85 * SERVO["electrical"]["psi_f"]},
             "mechanical": {**SERVO["mechanical"], "J": 0.6 * SERVO["mechanical"]["J"]}}
    res = identify(_scenario(guess, plant_machine=SERVO, identify={"map": False}))
    assert res.truth["psi_f"] == SERVO["electrical"]["psi_f"] and res.truth["J"] == SERVO["mechanical"]["J"]
    err = res.errors_pct()
    assert abs(err["psi_f"]) <= GOALS_PCT["psi_f"] and abs(err["J"]) <= GOALS_PCT["J"], err


def test_a_load_the_identification_does_not_apply_is_said():
    """The scenario's load is its own run's: identification turns a free shaft
    without it. The trial's 25 N m hoist load was dropped unsaid and the
    identification exited 0; it is now a note in the summary and the report,
    with the cure. A locked rotor, or no load, has none."""
    loaded = identify(_scenario(load={"kind": "torque", "torque": 1.5}, identify={"map": False}))
    assert len(loaded.details["notes"]) == 1 and "up to 1.5 N m" in loaded.details["notes"][0]
    assert "locked = true" in loaded.details["notes"][0]
    assert identify(_scenario(identify={"map": False})).details["notes"] == []


def test_a_spin_the_rotor_ran_ahead_of_is_named_a_swing_with_its_cure():
    """The new-user trial's Baldor from its datasheet alone (no dead time, no
    friction: nothing damps the I/f frame's rotor): psi_f failed 'the rotor
    did not follow the I/f frame' with the rotor at twice the frame's speed,
    no cause and no cure. Ahead of the frame is a swing about it, not a
    pull-out: said, with the ramp's time; the slower ramp it names
    identifies the machine."""
    import copy
    from fullspeed.model.machines import catalog_data
    d = copy.deepcopy(catalog_data("baldor-ecs101m0h7ef4"))
    d.update(bench={"u_dc": 650.0, "f_pwm": 5000.0}, mechanical={"J": 0.015},
             electrical={**d["electrical"], "R_s": 3.6}, rated={"torque": 29.7, "current": 12.4, "speed_rpm": 1800.0})

    def run(t_ramp):
        return identify(scenario_from_dict({"name": "x", "duration": 1.0, "machine": d, "controller": {"mode": "off"},
                                            "identify": {"map": False, "t_ramp": t_ramp}}))
    fast = run(1.0)
    assert fast.status["psi_f"] == "failed" and "ahead of the frame, a swing" in fast.reason["psi_f"]
    assert "[identify] t_ramp, 1 s now" in fast.reason["psi_f"]
    assert run(3.0).status["psi_f"] == "ok"


def test_a_test_current_the_drive_holds_lower_is_said():
    """The new-user trial asked i_test = 5 A of a free PM-SyRM: the levels ran
    to 1.9 A (half of psi_f / (L_q - L_d), the magnet's pull against the
    reluctance torque's push) and nothing said so. Now a note with both
    currents and the bound; none where the asked current is used."""
    low = identify(_scenario(identify={"map": False, "i_test": 12.0}))
    top = low.details["i_level_top"]
    assert 0.0 < top < 12.0
    lines = [n for n in low.details["notes"] if n.startswith("identify.i_test")]
    assert len(lines) == 1 and "12 A asked" in lines[0] and "psi_f / (L_q - L_d)" in lines[0]
    kept = identify(_scenario(identify={"map": False, "i_test": 0.5 * top}))
    assert not [n for n in kept.details["notes"] if n.startswith("identify.i_test")]


def test_an_align_that_turned_the_rotor_says_why(capsys):
    """The new-user trial's free Baldor: ALIGN turned the 'standstill' rotor
    161 el.deg and the summary never said why. Now one line with the turn
    and the cause from the drive's readings: no axis to find standing (a
    surface-magnet machine) or a polarity its d sweep did not decide."""
    import copy
    from fullspeed.model.machines import catalog_data
    from fullspeed.workflows.identify import print_identification
    d = copy.deepcopy(catalog_data("baldor-ecs101m0h7ef4"))
    d.update(bench={"u_dc": 650.0, "f_pwm": 5000.0, "t_dead": 2e-6, "noise_i": 0.05}, mechanical={"J": 0.015},
             electrical={**d["electrical"], "R_s": 3.6}, rated={"torque": 29.7, "current": 12.4, "speed_rpm": 1800.0})
    cases = ((d, "did not decide the polarity standing"), ("anaheim-bly171d", "no axis to find standing"))
    for machine, why in cases:
        res = identify(scenario_from_dict({"name": "x", "duration": 1.0, "machine": machine, "controller": {"mode": "off"},
                                           "identify": {"map": False}}))
        assert "align" in res.motion["steps"]
        print_identification(res)
        line = [ln for ln in capsys.readouterr().out.splitlines() if "align turned the rotor" in ln]
        assert len(line) == 1 and why in line[0]
    res = identify(scenario_from_dict({"name": "z", "duration": 1.0, "machine": "baldor-ecs101m0h7ef4",   # its catalog
                                       "controller": {"mode": "off"}, "identify": {"map": False}}))      # file: decided
    print_identification(res)
    assert "align" not in res.motion["steps"] and "align turned" not in capsys.readouterr().out


def test_a_scenario_that_names_only_its_machine_is_identified(tmp_path):
    """The new-user trial's identify scenario named its machine only and was
    refused for duration and controller.mode, which identify does not use:
    defaulted now for identify (1 s, off), given ones kept."""
    scen = tmp_path / "s.toml"
    scen.write_text('name = "only-machine"\nmachine = "anaheim-bly171d"\n[identify]\nmap = false\n')
    assert main(["identify", str(scen), "--out", str(tmp_path / "out")]) == 0
    rep = tomllib.loads((tmp_path / "out" / "identification.toml").read_text())
    assert rep["R_s"]["status"] == "ok" and (tmp_path / "out" / "machine.toml").is_file()


def test_locked_thor_reads_l_q_at_zero_d_current_through_its_asymmetric_curve():
    """SyR-e's THOR locked: L_q is 30.0 mH at -17.6 A of d current, 33.9 at
    zero and 33.4 at +17.6 A (the ribs its magnet saturates), and its
    inverter's error asks biases of +-17.6 A; their mean read L_q -6.5 %,
    outside the 5 % goal. Four biases (+-I_b, +-2 I_b) and Richardson's
    (4 m1 - m2) / 3 take the curve's second order out: within the goal,
    the biases as the C reads them."""
    from fullspeed.reproduce.papers.real import real_scenario

    data, _ = real_scenario("syre-thor", "blend")
    data["identify"] = {"locked": True}
    res = identify(scenario_from_dict(data, "thor locked", warn=False))
    assert res.status["L_q"] == "ok", (res.status["L_q"], res.errors_pct().get("L_q"))
    assert abs(res.errors_pct()["L_q"]) < 4.0, res.errors_pct()   # -2.99 % (-6.55 % from the two biases)
