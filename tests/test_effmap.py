"""`fullspeed map`: the analytic envelope against its closed form, the map's
powers closing on its losses, what a point not held reports, and the
refusals."""
import copy
import csv
import json
import math
import os
import subprocess
import sys

import pytest

from fullspeed.design.machine import machine_from_dict
from fullspeed.model.errors import ConfigError
from fullspeed.model.machines import catalog_data
from fullspeed.model.units import rpm_to_rad_s
from fullspeed.workflows.effmap import efficiency_map, envelope

from conftest import MACHINE
from test_losses import CONV, IRON
from tomlw import dumps

LOSS_KEYS = ("P_cu_W", "P_fe_W", "P_mech_W", "P_cond_W", "P_sw_W", "P_rect_W", "P_filter_W")


def test_envelope_is_the_current_circle_meeting_the_voltage_circle():
    """A surface-magnet machine without resistance: below base speed the
    current circle's torque, 3/2 p psi_f i_max; above it the intersection
    of |i| = i_max and |psi_f + j L i| = u / w, i_d = ((u/w)^2 - psi_f^2 -
    L^2 I^2) / (2 psi_f L)."""
    d = copy.deepcopy(catalog_data("zou2021"))
    d["electrical"]["R_s"] = 0.0
    m = machine_from_dict(d)
    I, u, L, psi, p = 15.0, 250.0, m.L_d, m.psi_f, m.pole_pairs
    n = [500.0, 1400.0]
    T = envelope(m, n, I, u)
    assert T[0] == pytest.approx(1.5 * p * psi * I, rel=1e-3)
    w = p * rpm_to_rad_s(n[1])
    i_d = ((u / w) ** 2 - psi ** 2 - (L * I) ** 2) / (2 * psi * L)
    assert -I < i_d < 0.0   # flux weakening, the current still on its circle
    assert T[1] == pytest.approx(1.5 * p * psi * math.sqrt(I * I - i_d * i_d), rel=5e-3)


def machine_file(tmp_path):
    m = copy.deepcopy(MACHINE)
    m.update(converter=CONV, losses=IRON, mechanical={"J": 1.87e-3, "B": 2e-4, "T_coulomb": 0.03})
    f = tmp_path / "m.toml"
    f.write_text(dumps(m))
    return f


def test_map_powers_close_on_the_losses_and_points_beyond_reach_say_so(tmp_path):
    """Each held point: the source's power = the shaft's + every loss (the
    window's stored energy is steady to 1 %), the efficiencies are the
    powers' ratios; the summary's peaks are the table's; a point the drive
    cannot hold (its torque limit below the load) has no efficiency."""
    em = efficiency_map(str(machine_file(tmp_path)), tmp_path / "map", speeds=2, torques=(0.3, 0.9),
                        top_rpm=2000.0, workers=1, overrides={"controller": {"T_max": 2.0}})
    rows = em.rows
    assert [r["speed_rpm"] for r in rows] == [1000.0, 1000.0, 2000.0, 2000.0]
    assert [r["torque_Nm"] < 2.0 for r in rows] == [True, False, True, False]
    held = [r for r in rows if r["held"]]
    assert [r["torque_Nm"] < 2.0 for r in held] == [True, True]
    for r in held:
        losses = sum(r[k] for k in LOSS_KEYS)
        assert r["P_source_W"] == pytest.approx(r["P_shaft_W"] + losses, rel=0.01)
        assert min(r["P_cu_W"], r["P_fe_W"], r["P_mech_W"], r["P_cond_W"], r["P_sw_W"]) > 0.0
        assert r["eta_drive"] == pytest.approx(r["eta_machine"] * r["eta_converter"], rel=1e-9)
        assert 0.3 < r["eta_drive"] < 1.0
        assert r["torque_Nm"] * rpm_to_rad_s(r["speed_rpm"]) == pytest.approx(r["P_shaft_W"], rel=0.01)
    assert all(r["eta_drive"] is None and r["speed_mean_rpm"] < 0.99 * r["speed_rpm"] for r in rows if not r["held"])
    best = max(held, key=lambda r: r["eta_drive"])
    assert em.summary["eta_drive_peak"]["eta"] == best["eta_drive"]
    table = list(csv.DictReader(open(tmp_path / "map" / "map.csv")))
    assert len(table) == 4 and float(table[0]["torque_Nm"]) == pytest.approx(rows[0]["torque_Nm"])
    assert json.loads((tmp_path / "map" / "map.json").read_text())["summary"]["held"] == 2
    assert (tmp_path / "map" / "map.png").stat().st_size > 20_000


def test_map_refuses_what_is_not_a_speed_drive(tmp_path):
    with pytest.raises(ConfigError, match="controller.mode"):
        efficiency_map("yang2022-hfi-iqstep", tmp_path / "m", speeds=2)
    with pytest.raises(ConfigError, match="--speeds"):
        efficiency_map("yang2022", tmp_path / "m", speeds=1)


def test_map_command_prints_the_peaks(tmp_path):
    p = subprocess.run([sys.executable, "-m", "fullspeed", "map", str(machine_file(tmp_path)), "--speeds", "2",
                        "--torques", "0.5", "--top-rpm", "2000", "--workers", "1", "--out", str(tmp_path / "o"),
                        "--quiet"], capture_output=True, text=True, timeout=300,
                       env={**os.environ, "PYTHONWARNINGS": "ignore"})
    assert p.returncode == 0, p.stderr
    assert "peak drive efficiency" in p.stdout and "module: test module" in p.stdout
    assert (tmp_path / "o" / "map.csv").exists()


def test_the_map_gives_the_machine_files_reason_for_its_iron_loss(tmp_path, capsys):
    """A new user's trial: `fullspeed map yang2022` printed "iron loss: assumed:
    a share of the rating usual for small machines (reasons below); no
    measurement ..." and no reason followed (it is the machine file's [losses]
    reasons). The map gives the file's reason for the iron loss's size in one
    line after the summary, and no dangling "(reasons below)"."""
    from fullspeed.cli import main

    why = catalog_data("yang2022")["losses"]["reasons"]["P_fe_ref"]
    assert "(reasons below)" in catalog_data("yang2022")["losses"]["source"]
    assert main(["map", "yang2022", "--speeds", "2", "--torques", "0.5", "--workers", "1", "--quiet",
                 "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out.splitlines()
    summary = next(k for k, line in enumerate(out) if "iron loss: " in line)
    assert "iron loss: assumed: a share of the rating usual for small machines; no measurement" in out[summary]
    assert out[summary + 1] == f"iron loss, the machine file's reason: {why}"
    assert not any("reasons" in line and "reason:" not in line for line in out), out
    s = json.loads((tmp_path / "o" / "map.json").read_text())["summary"]
    assert s["iron_reason"] == why and "reasons" not in s["iron_source"]
    # a file's multi-line reason is one line; a file without reasons prints none
    from fullspeed.workflows.effmap import iron_loss_note
    assert iron_loss_note({**IRON, "source": "assumed (reasons)", "reasons": {"k_hyst": "a\nb", "P_fe_ref": "5 %\n of it"}}) == (
        "assumed", "5 % of it")
    assert iron_loss_note(IRON) == ("assumed: a test's", None) and iron_loss_note(None) == (None, None)


@pytest.mark.parametrize("argv, says", [(["yang2022", "--torques", "2"], "--torques = [2.0]"),
                                        (["yang2022", "--speeds", "1"], "--speeds = 1"),
                                        (["yang2022", "--workers", "0"], "--workers = 0"),
                                        (["beyond-full-range"], "controller.angle = 'blend'")])
def test_a_refused_map_says_only_why(tmp_path, capsys, argv, says):
    """Found beside a new user's trial: the map printed "map TARGET -> OUT" and
    then its refusal, as if it ran; --workers 0 was no refusal and ran the map
    on every core. One line, exit 2, nothing written; the banner once it runs."""
    from fullspeed.cli import main

    assert main(["map", *argv, "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("fullspeed: error: ") and says in err[0], err
    assert not (tmp_path / "o").exists()
    assert main(["map", "yang2022", "--speeds", "2", "--torques", "0.5", "--workers", "1", "--quiet",
                 "--out", str(tmp_path / "o")]) == 0
    assert capsys.readouterr().err.strip().splitlines() == [f"map yang2022 -> {tmp_path / 'o'}"]


def test_the_maps_envelope_is_designs_on_a_saturating_machine(tmp_path):
    """yang2022's machine saturates (an algebraic model): the map's torques
    are fractions of the envelope `fullspeed design` prints, not of the
    unsaturated L_d, L_q and psi_f's (3.22 N m at 60 A against design's
    2.99, where every 0.97 point could not be held)."""
    from fullspeed.design.envelope import envelope as design_envelope
    from fullspeed.design.envelope import torque_at
    from fullspeed.design.rules import u_linear

    m = machine_from_dict(catalog_data("yang2022"))
    assert m.magnetic["model"] == "algebraic"
    u_dc, i_max = m.bench["u_dc"], m.bench["i_max"]
    n = [750.0, 3000.0, 4000.0]
    T = envelope(m, n, i_max, u_linear(u_dc, m.phases))
    assert T == pytest.approx(torque_at(design_envelope(m, u_dc, i_max), rpm_to_rad_s(n)), rel=2e-3)
    g = [0.5 * math.pi + 0.5 * math.pi * k / 2000 for k in range(2001)]   # the current circle, unsaturated
    T_lin = max(1.5 * m.pole_pairs * (m.psi_f + (m.L_d - m.L_q) * i_max * math.cos(a)) * i_max * math.sin(a) for a in g)
    assert T[0] < 0.95 * T_lin   # saturation takes 7 % of it


def test_a_sensorless_scenario_is_refused_before_the_map(tmp_path):
    """Each point starts at its speed; the sensorless drive starts only from
    standstill (every point of beyond-full-range stopped, overcurrent or
    polarity undetermined, and the map said '0 held' with exit 0)."""
    with pytest.raises(ConfigError, match="controller.angle.*encoder"):
        efficiency_map("beyond-full-range", tmp_path / "m", speeds=2)
    assert not (tmp_path / "m").exists()


def test_a_map_whose_points_stop_fails_and_counts_the_stops(tmp_path):
    """A point whose drive stopped (here the overspeed stop, set below the
    map's top speed) is a failed map: exit 1, the stops counted by reason in
    the summary; a point that only sags at the envelope's edge is not."""
    p = subprocess.run([sys.executable, "-m", "fullspeed", "map", "yang2022", "--speeds", "2", "--torques", "0.3",
                        "--top-rpm", "2000", "--set", "controller.overspeed_rpm=1500", "--workers", "1",
                        "--out", str(tmp_path / "o"), "--quiet"], capture_output=True, text=True, timeout=300,
                       env={**os.environ, "PYTHONWARNINGS": "ignore"})
    assert p.returncode == 1, p.stderr
    assert "2 points, 1 held (1 stopped: 1 overspeed)" in p.stdout
    assert "map failed: 1 of 2 points stopped (1 overspeed)" in p.stderr
    rows = list(csv.DictReader(open(tmp_path / "o" / "map.csv")))
    assert [r["stop_reason"] for r in rows] == ["done", "overspeed"]
    assert json.loads((tmp_path / "o" / "map.json").read_text())["summary"]["stops"] == {"overspeed": 1}


def test_a_second_map_into_a_folder_in_use_is_refused(tmp_path, capsys):
    """Two maps into one folder would write one journal: the second is refused
    in one line while the first holds the folder (as a sweep's), and runs once
    it is free."""
    from fullspeed.cli import main
    from fullspeed.model.files import claim

    out = tmp_path / "o"
    argv = ["map", "yang2022", "--speeds", "2", "--torques", "0.3", "--top-rpm", "2000", "--workers", "1",
            "--out", str(out), "--quiet"]
    with claim(out):   # the running map's lock (flock: another open of the folder conflicts, in this process too)
        assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "in use by another fullspeed command" in err[0], err
    assert not (out / "map.csv").exists()
    assert main(argv) == 0 and (out / "map.csv").exists()


def test_the_map_prints_the_machines_implausible_data_before_it_runs(tmp_path, capsys):
    """A new user's trial typed J as 150 kg m^2 (for 1.5e-3): `run` and
    `design` warned of it, `map` ran its points and said nothing. The map
    prints its base scenario's warnings, the machine's data among them,
    before its banner; the same file with a plausible J prints none."""
    from fullspeed.cli import main

    f = machine_file(tmp_path)
    argv = ["--speeds", "2", "--torques", "0.5", "--top-rpm", "2000", "--workers", "1", "--quiet"]
    assert main(["map", str(f), *argv, "--out", str(tmp_path / "ok")]) == 0
    assert capsys.readouterr().err.strip().splitlines() == [f"map {f} -> {tmp_path / 'ok'}"]
    m = copy.deepcopy(MACHINE)
    m.update(converter=CONV, losses=IRON, mechanical={"J": 150.0, "B": 2e-4, "T_coulomb": 0.03})
    heavy = tmp_path / "heavy.toml"
    heavy.write_text(dumps(m))
    main(["map", str(heavy), *argv, "--out", str(tmp_path / "heavy")])
    err = capsys.readouterr().err.strip().splitlines()
    banner = err.index(f"map {heavy} -> {tmp_path / 'heavy'}")
    warned = [line for line in err[:banner] if line.startswith("fullspeed: warning: machine.mechanical.J: J = 150")]
    assert len(warned) == 1 and "check J's unit (kg m^2)" in warned[0], err
