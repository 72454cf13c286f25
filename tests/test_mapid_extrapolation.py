"""The identified map beyond what its q sweeps reached (workflows/mapid.py):
carried on from the readings' own saturation, not a straight line.

A free rotor's standstill q sweeps stop short of the disc where the rotor
would turn (syre-thor free: i_d = 0 only, to 11 A of 44). A straight line
through the last two readings carries the incremental L_q of 11 A to 44 A:
on syre-thor, whose L_q falls from 34 mH at zero current to 2.3 mH at
i_max, that gave psi_q twice the truth at the limit, a map 107 % of psi_f
off, and a drive designed from it tripped on overcurrent."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fullspeed.workflows import mapid

ND, NQ = mapid.ND, mapid.NQ
I_MAX, PSI_F = 40.0, 0.1


def _readings(psi_q_of, js, L_d=5e-3):
    """The d sweep over the whole axis (linear), the q sweep at i_d = 0
    read at j i_max / 8 for j in js, psi_q_of(i_q) the q flux there."""
    i_d = [0.25 * (k - ND // 2) * I_MAX for k in range(ND)]
    n_q = [[0] * NQ for _ in range(ND)]
    psi_q = [[0.0] * NQ for _ in range(ND)]
    zero = [[0.0] * NQ for _ in range(ND)]
    for j in js:
        n_q[ND // 2][j - 1] = 4
        psi_q[ND // 2][j - 1] = psi_q_of(j * I_MAX / NQ)
    return {"dpsi_d": [L_d * a for a in i_d], "n_d": [4] * ND, "psi_d_w": [0.0] * ND, "w_d_w": [0] * ND,
            "n_q": n_q, "psi_q": psi_q, "dpsi_dq": zero, "i_d_at": zero}


def _row(grid):
    return grid["psi_q"][1 + ND // 2, 1:-1]   # the row i_d = 0, the disc's i_q (grid has a step beyond each side)


def test_saturating_q_axis_is_carried_on_saturating():
    """psi_q = a tanh(i / b) read to i_max / 4: beyond it the map keeps the
    fall of the incremental L_q it read (a geometric fall, 0.75 a step
    here): at i_max 0.14 Wb above the truth's 0.40 Wb, where the straight
    line is 0.58 Wb above it (tanh falls faster than geometric: the map
    errs high, never below the truth)."""
    a, b = 0.4, 12.0
    true = lambda i: a * math.tanh(i / b)
    grid = mapid.assemble(_readings(true, [1, 2]), I_MAX, PSI_F, 5e-3)
    row = _row(grid)
    assert row[NQ + 2] == true(2 * I_MAX / NQ)   # read: as read
    s = true(2 * I_MAX / NQ) - true(I_MAX / NQ)
    line = true(2 * I_MAX / NQ) + 6 * s
    assert line > true(I_MAX) + 0.6 * PSI_F   # what a straight line would hold
    assert true(I_MAX) < row[-1] < true(I_MAX) + 0.3 * (line - true(I_MAX)), (row[-1], true(I_MAX), line)
    assert np.all(np.diff(row) > 0) and np.allclose(row, -row[::-1])   # still rising, odd in i_q


def test_linear_q_axis_is_carried_on_straight():
    """A q axis that did not saturate over what was read is carried on by
    its slope, exactly (the ratio of its steps is 1)."""
    L_q = 8e-3
    grid = mapid.assemble(_readings(lambda i: L_q * i, [1, 2, 3]), I_MAX, PSI_F, 5e-3)
    assert np.allclose(_row(grid), L_q * grid["i_q"][1:-1], rtol=1e-9, atol=1e-12)


def test_one_point_read_is_carried_on_by_its_slope():
    """One q reading shows no fall: its secant carried on (nothing invented)."""
    grid = mapid.assemble(_readings(lambda i: 0.02 * i, [1]), I_MAX, PSI_F, 5e-3)
    assert np.allclose(_row(grid), 0.02 * grid["i_q"][1:-1])


def test_free_thor_identified_then_run_does_not_trip(tmp_path):
    """syre-thor on a free shaft: its q sweeps reach 11 A of 44 at i_d = 0
    alone (the rotor would turn), the rest of the map carried on from
    them. The full-range run (B-REAL's scenario) on the machine file written,
    the true machine turning, completes: with the straight line carried on
    it tripped on overcurrent (psi_q twice the truth at the limit). The
    map says it is partial from the drive's own readings (before, only the
    truth a simulation knows said it was off: on a real machine, "ok")."""
    import copy

    from fullspeed.design.scenario import scenario_from_dict
    from fullspeed.reproduce.papers.real import real_scenario, sensorless_angle
    from fullspeed.sim.runner import simulate
    from fullspeed.workflows.identify import identify, write_identification

    angle, _ = sensorless_angle("syre-thor")
    data, _ = real_scenario("syre-thor", angle or "blend")
    sc = scenario_from_dict(copy.deepcopy(data), "thor", warn=False)
    res = identify(sc)
    # outside its goal, said from the drive's own readings (no truth on a real machine): the sweeps stopped, the
    # rotor turning, after the level i_d = 0
    assert res.map is not None and res.status["map"] == "outside goal"
    why = res.reason["map"]
    assert why.startswith("partial: the q sweeps stopped after the level i_d = +0 A") and "1 of 7 d levels" in why, why
    assert sum(1 for s in res.map["grid"]["source"].ravel() if s == "measured") < 20   # the free rotor's few points
    write_identification(res, sc, tmp_path)
    run = copy.deepcopy(data)
    run["machine"], run["plant_machine"] = str(tmp_path / "machine.toml"), data["machine"]
    out = simulate(scenario_from_dict(run, "thor identified", warn=False))
    assert out.stop_reason == "done", (out.stop_reason, out.metrics.get("lock_lost_at"))


def test_free_prius_partial_map_is_written_said_partial_and_runs(tmp_path):
    """The Prius MG2 on a free shaft: a d current below 0 A turns its magnet
    off the axis, so the d sweep stops at +-0.72 i_max and the map is not
    identified over the disc. What it read (the d axis to +-i_max/2, the q
    axis at i_d = 0 to 68 A, where L_q is already 26 % below its zero-current
    value) is written, marked partial with what was read, outside its goal
    (exit 1): on the constants alone (even the true ones) the full-range
    run lost its lock at the first load step (overspeed); on the partial
    map it completes."""
    import copy

    from fullspeed.design.scenario import scenario_from_dict
    from fullspeed.reproduce.papers.real import real_scenario, sensorless_angle
    from fullspeed.sim.runner import simulate
    from fullspeed.workflows.identify import OUTSIDE, identify, write_identification

    angle, _ = sensorless_angle("prius2004-mg2")
    data, _ = real_scenario("prius2004-mg2", angle or "blend")
    sc = scenario_from_dict(copy.deepcopy(data), "prius", warn=False)
    res = identify(sc)
    assert res.status["map"] == OUTSIDE and not res.ok
    why = res.reason["map"]
    assert why.startswith("partial: the d sweep") and "the q axis to 67.7 A at i_d = 0" in why and "locked = true" in why, why
    write_identification(res, sc, tmp_path)
    assert "[magnetic]" in (tmp_path / "machine.toml").read_text()
    run = copy.deepcopy(data)
    run["machine"], run["plant_machine"] = str(tmp_path / "machine.toml"), data["machine"]
    out = simulate(scenario_from_dict(run, "prius identified", warn=False))
    assert out.stop_reason == "done", (out.stop_reason, out.metrics.get("lock_lost_at"))


def test_lopsided_d_axis_read_at_a_carrier_it_is_straight_over():
    """syre-thor's d axis: the incremental L_d 5.0 mH below zero current,
    7.6 mH at +1..2 A, 16 mH at +4..9 A. The d carrier at 4.1 A read the
    swing's fundamental, 5.76 mH, +15 % against the value at zero current;
    its current's second harmonic (14 % of the fundamental) shows the
    lopsidedness, and the carrier is cut until the reading stops moving:
    L_d within its 5 % goal at 1.7 A. A symmetric axis (the Prius MG2's)
    keeps its carrier."""
    from fullspeed.design.scenario import scenario_from_dict
    from fullspeed.workflows.identify import GOALS_PCT, identify

    def run(name):
        return identify(scenario_from_dict({"name": name, "duration": 1.0, "machine": name, "controller": {"mode": "off"},
                                            "identify": {"locked": True}}, warn=False))
    thor = run("syre-thor")
    assert thor.status["L_d"] == "ok" and abs(thor.errors_pct()["L_d"]) <= GOALS_PCT["L_d"], thor.errors_pct()
    assert thor.details["ld_carrier_A"] < 2.5 and thor.details["ld_second_harmonic"] < 0.05, thor.details["ld_carrier_A"]
    prius = run("prius2004-mg2")
    assert prius.details["ld_carrier_A"] > 10.0 and prius.details["ld_second_harmonic"] < 0.05


def test_spread_says_what_the_readings_leave_open():
    """The spread (straight on against falling as read) is zero where the
    readings did not fall and grows with the fall; over the disc it is the
    drive's own measure of a partial map (no truth needed)."""
    lin = mapid.assemble(_readings(lambda i: 8e-3 * i, [1, 2, 3]), I_MAX, PSI_F, 5e-3)
    sat = mapid.assemble(_readings(lambda i: 0.4 * math.tanh(i / 12.0), [1, 2, 3]), I_MAX, PSI_F, 5e-3)
    assert np.all(lin["spread"] == 0.0) and mapid.spread_pct(lin, PSI_F, I_MAX) == 0.0
    assert mapid.spread_pct(sat, PSI_F, I_MAX) > 50.0   # tanh's fall over 15 A carried to 40 A: far apart
    assert np.all(sat["spread"][:, NQ - 3:NQ + 4] == 0.0)   # read (or copied from a read row) up to j = 3: nothing open


def test_linear_machine_whose_sweeps_stopped_keeps_its_map():
    """anaheim-bly171d free: its q sweeps stop when the rotor turns at a
    level's end, but its readings carry on straight (spread 0.01 % of
    psi_f): the map stands, "ok" (0.16 % off the truth), not partial."""
    from fullspeed.design.scenario import scenario_from_dict
    from fullspeed.workflows.identify import identify

    res = identify(scenario_from_dict({"name": "a", "duration": 1.0, "machine": "anaheim-bly171d",
                                       "controller": {"mode": "off"}}, warn=False))
    assert 4 in res.map["readings"]["limit"]   # FS_MAPID_LIM_MOVING: the sweeps stopped
    assert res.map["spread_pct"] < 0.5 and res.status["map"] == "ok", (res.map["spread_pct"], res.reason["map"])


def test_identified_grid_rises_with_its_currents():
    """A reading that falls against its neighbour (two points 0.4 % of
    psi_f the wrong way) is made the nearest rising row: the two pooled at
    their mean, everything else as read; a map that rose is left to the
    bit, and the grid is one the loader takes."""
    from fullspeed.model.machines import _check_fluxmap

    L_q = 8e-3
    rd = _readings(lambda i: L_q * i, [1, 2, 3, 4])
    clean = mapid.assemble(rd, I_MAX, PSI_F, 5e-3)
    assert clean["rise_moved"] == 0.0
    rd["psi_q"][ND // 2][2] = rd["psi_q"][ND // 2][1] - 0.004 * PSI_F   # psi_q at j = 3 read below j = 2
    grid = mapid.assemble(rd, I_MAX, PSI_F, 5e-3)
    row, row0 = _row(grid), _row(clean)
    assert np.all(np.diff(row) > 0)
    pooled = 0.5 * (L_q * 2 * I_MAX / NQ + L_q * 2 * I_MAX / NQ - 0.004 * PSI_F)
    assert row[NQ + 2] == pytest.approx(pooled, abs=1e-9) and row[NQ + 3] == pytest.approx(pooled, abs=1e-6)
    assert grid["rise_moved"] == pytest.approx(0.002 * PSI_F, rel=1e-3)   # each of the two by half the fall
    assert row[NQ + 1] == row0[NQ + 1] and np.array_equal(grid["psi_d"], clean["psi_d"])   # the rest as read
    mag = {"i_d": list(grid["i_d"]), "i_q": list(grid["i_q"]), "psi_d": grid["psi_d"].tolist(), "psi_q": grid["psi_q"].tolist()}
    _check_fluxmap(mag, "machine.magnetic", None)   # raises where a flux does not rise


def test_polarity_is_reported_with_its_sign_as_the_pulses_read_it():
    """The Baldor PM-SyRM's d axis on the identified map's grid (i_max/4 =
    4.7 A steps; here its true fluxes on that grid): the asymmetry at the
    pulses, +-9.3 A, is 20 % in size, but the carrier is the smaller where
    the d current adds to the magnet, so the pulses would read the south
    pole (the report said "decides" from the size alone while the design on
    the written file took the motion test). On the machine's own map, at its
    1.2 A carrier, the same pulse reads -2 %: the grid's cell, not the
    machine."""
    from fullspeed.design.machine import load_machine
    from fullspeed.design.start import carrier_asymmetry
    from fullspeed.workflows.identify import true_flux

    m = load_machine("baldor-ecs101m0h7ef4")
    i_max = 18.675
    rep = mapid.polarity_report(mapid.true_grid(true_flux(m), i_max), None, 0.5 * i_max)
    assert rep["asymmetry"] > 0.15 and rep["signed"] < -0.15
    assert rep["reversed"] and not rep["decides"]
    assert abs(carrier_asymmetry(m, 0.5 * i_max, 1.2)[0]) < 0.05
