"""B-REAL's measurement (reproduce.papers.real) on the machines that start
by I/f: the estimator's error counts from the hand-over on, the start's
turn within its bound; their held runs turn the shaft with the I/f frame."""
import numpy as np
import pytest

from fullspeed.design.scenario import scenario_from_dict
from fullspeed.reproduce.papers.real import IF_WAIT, START, _machine_ok, held_scenario
from fullspeed.sim.metrics import SENSORLESS_STAGES, sensorless_error_max

IF, BACKEMF = 3, 6   # the I/f start's stage and the back-EMF observer's (metrics.STAGES)


def test_the_if_frame_is_no_estimate_but_the_observer_after_it_is():
    t = np.arange(0.0, 1.0, 1e-3)
    stage = np.where(t < 0.3, IF, BACKEMF)
    err = np.radians(np.where(t < 0.3, 50.0, np.where(t < 0.32, 20.0, 3.0)))
    err[800] = np.radians(12.0)   # a spike well after the hand-over: it counts
    tr = {"t": t, "stage": stage, "theta_err": err, "w_m_ref": np.full_like(t, 100.0)}
    assert sensorless_error_max(tr) == pytest.approx(50.0)   # the I/f's load angle, as every run counts it
    assert sensorless_error_max(tr, stages=SENSORLESS_STAGES) == pytest.approx(12.0)   # 50 ms after the hand-over forgiven


def test_an_if_machine_passes_only_with_its_start_within_bound():
    row = {"refused": None, "stop_reason": "done", "lock_lost_at": None, "err_max": 2.0, "steady_mean": 0.1,
           "start": "if", "turn_deg": 400.0, "bound_deg": 5000.0}
    assert _machine_ok(row)
    assert not _machine_ok({**row, "turn_deg": 6000.0})
    assert not _machine_ok({**row, "turn_deg": None})
    assert not _machine_ok({**row, "err_max": 12.0})


def test_each_machine_also_runs_from_its_rotor_turned_a_quarter():
    """B-REAL runs each machine's full range twice, the second from the rotor
    turned by TURNED (90 el.deg: the injection's worst start); the scenario
    built once is not changed by the turn."""
    from fullspeed.reproduce.papers.real import TURNED, _turned, real_scenario
    built = real_scenario("syre-thor", "blend")
    theta0 = built[0].get("initial", {}).get("theta_e_deg", 0.0)
    data, info = _turned(built)
    assert TURNED == 90.0 and data["initial"]["theta_e_deg"] == theta0 + TURNED
    assert built[0].get("initial", {}).get("theta_e_deg", 0.0) == theta0 and info is built[1]
    assert {k: v for k, v in data.items() if k != "initial"} == {k: v for k, v in built[0].items() if k != "initial"}


def test_the_held_run_asks_no_torque_against_a_shaft_held_at_standstill():
    """No speed is asked while the load machine holds the shaft at
    standstill: asked for 1.2 x the speed from the start, the drive stalled
    against it at its full torque (a locked-rotor test), and SyR-e's THOR
    lost its rotor there from 1,037 rpm up; asked once the shaft turns, it
    holds the encoder's torque at 1,037 rpm."""
    from fullspeed.reproduce.papers.real import HELD_TOL, held_torque
    d = held_scenario("syre-thor", 1036.8, "blend")
    shaft, ref = d["load"]["speed_rpm"], d["references"]["speed_rpm"]
    held = [p[0] for p in shaft if p[1] == 0.0]
    assert max(held) == START and all(v == 0.0 for t, v in ref if t <= START)
    assert all(v >= 1.2 * 1036.8 - 1e-9 for t, v in ref if t > START + 1e-3)
    enc = held_torque({"machine": "syre-thor", "rpm": 1036.8, "angle": "encoder"})
    sl = held_torque({"machine": "syre-thor", "rpm": 1036.8, "angle": "blend"})
    assert enc["stop_reason"] == sl["stop_reason"] == "done", (enc, sl)
    assert sl["T"] >= (1.0 - HELD_TOL) * enc["T"], (sl, enc)


def test_held_runs_turn_the_shaft_with_the_if_frame_until_the_hand_over():
    name = "odrive-d6374"   # no saliency the injection can use: an I/f start
    enc = held_scenario(name, 3000.0, "encoder")
    assert enc["load"]["speed_rpm"][:2] == [[0.0, 0.0], [START, 0.0]]   # the shaft held while the drive starts
    d = held_scenario(name, 3000.0, "blend")
    ob = scenario_from_dict(d).data["observer"]
    assert ob["start"] == "if"
    (t0, n0), (t_h, n_h), (t_w, n_w), (t1, n1) = d["load"]["speed_rpm"][:4]
    assert (t0, n0) == (0.0, 0.0) and n_h == n_w == ob["start_handover_rpm"] and n1 == 3000.0
    assert n_h / t_h == pytest.approx(ob["start_accel_rpm_s"])   # as fast as the frame turns
    assert t_w - t_h == pytest.approx(IF_WAIT * ob["start_timeout"])
    assert d["metrics"]["steady"][1] == d["duration"] and d["metrics"]["steady"][0] > t1


def test_no_machine_runs_b_real_on_the_encoders_start():
    """The back-EMF observer alone starts by I/f (its default start is the
    encoder's angle, which is no sensorless start): the H27 washer motor,
    whose I/f start cannot carry half its rated torque, is refused naming
    that, not run from the encoder's angle."""
    from fullspeed.reproduce.papers.real import real_scenario, sensorless_angle
    assert real_scenario("hefei-h27", "smo")[0]["observer"]["start"] == "if"
    angle, why = sensorless_angle("hefei-h27")
    assert angle is None and "the I/f start cannot carry this load" in why


def test_held_runs_give_the_polarity_where_the_start_is_a_motion_test():
    """The 2004 Prius MG2's designed start turns the rotor (a motion test);
    the held run's load machine holds the shaft, so the polarity is given
    there (and only there: the encoder's run and the I/f machines' keep
    theirs)."""
    d = held_scenario("prius2004-mg2", 600.0, "blend")
    assert d["polarity"] == {"enabled": False}
    assert "polarity" not in held_scenario("prius2004-mg2", 600.0, "encoder")
    assert "polarity" not in held_scenario("odrive-d6374", 3000.0, "blend")
    assert scenario_from_dict(held_scenario("prius2004-mg2", 600.0, "blend")).data["start"]["kind"] == "known"


def test_the_encoder_drive_in_flux_weakening_holds_within_the_envelopes_band():
    """The drive's flux weakening enters over-modulation: at twice base speed
    the encoder's torque lies above the linear-limit envelope and below the
    over-modulated one (siemens-1ft6084 held 9 % above the linear one)."""
    import math
    from fullspeed.design.envelope import OVERMODULATION, envelope, torque_at
    from fullspeed.design.machine import load_machine
    from fullspeed.design.rules import u_linear
    from fullspeed.reproduce.papers.real import HELD_TOL, held_speeds, held_torque, held_within
    n = "siemens-1ft6084"
    m = load_machine(n)
    env = envelope(m, m.bench["u_dc"], m.bench["i_max"], w_end=4.0 * m.w_m_rated)
    env_om = envelope(m, m.bench["u_dc"], m.bench["i_max"], w_end=4.0 * m.w_m_rated,
                      u_max=OVERMODULATION * u_linear(m.bench["u_dc"], m.phases))
    w = held_speeds(env)[-1]
    T_lin, T_om = torque_at(env, w), torque_at(env_om, w)
    assert T_om > (1.0 + 2 * HELD_TOL) * T_lin          # the band matters up there
    T = held_torque({"machine": n, "rpm": w * 30 / math.pi, "angle": "encoder"})["T"]
    assert (1.0 + HELD_TOL) * T_lin < T < T_om          # beyond the linear envelope's tolerance, within the band
    assert held_within(T, T_lin, T_om) and not held_within(T, T_lin, T_lin)
    below = held_speeds(env)[0]
    assert torque_at(env_om, below) == pytest.approx(torque_at(env, below), rel=1e-6)   # the current limit alone


def test_the_held_torque_is_the_drives_not_its_speed_loops_wind_up():
    """A speed reference only 20 % above the held speed winds a slow speed
    loop up at k_i dw: the grin hub motor's sensorless drive (speed loop at
    a fraction of the encoder's bandwidth) held 19.2 of its 31.05 N m at 127
    rpm when the hold ended. After SETTLE the reference steps to where the
    loop asks its most torque at once; the observer and the overspeed stop
    stay designed for the speeds 1.2 x the held one reaches."""
    from fullspeed.reproduce.papers.real import HELD_TOL, held_torque, sensorless_angle
    name, rpm = "grin-all-axle-5t", 127.0
    angle = sensorless_angle(name)[0]
    d = held_scenario(name, rpm, angle)
    ref = d["references"]["speed_rpm"]
    assert ref[0][1] == ref[1][1] == pytest.approx(1.2 * rpm) and ref[-1][1] > 2.0 * rpm   # the I/f frame turns the shaft
    designed = scenario_from_dict(d).data
    as_asked = scenario_from_dict({**d, "references": {"speed_rpm": 1.2 * rpm}}).data
    assert designed["observer"]["top_speed_rpm"] == pytest.approx(as_asked["observer"]["top_speed_rpm"])
    enc = held_torque({"machine": name, "rpm": rpm, "angle": "encoder"})
    sl = held_torque({"machine": name, "rpm": rpm, "angle": angle})
    assert enc["stop_reason"] == sl["stop_reason"] == "done"
    assert sl["T"] >= (1.0 - HELD_TOL) * enc["T"], (sl, enc)


def test_a_machine_whose_held_runs_did_not_run_has_held_nothing():
    """held_rows: the B-REAL run that lost its worker processes counted all
    eight machines as holding their torque, with no held run made."""
    from fullspeed.design.envelope import envelope
    from fullspeed.design.machine import load_machine
    from fullspeed.reproduce.papers.real import held_rows
    m = load_machine("siemens-1ft6084")
    env = envelope(m, m.bench["u_dc"], m.bench["i_max"])
    T = float(env.T[0])
    enc = {"rpm": 100.0, "angle": "encoder"}
    sl = {"rpm": 100.0, "angle": "blend"}
    assert held_rows([], env, env, True) == ([], False)
    assert held_rows([(enc, None), (sl, None)], env, env, True)[1] is False
    assert held_rows([(enc, {"T": T}), (sl, None)], env, env, True)[1] is False            # sensorless did not run
    assert held_rows([(enc, {"T": T}), (sl, {"T": T})], env, env, True)[1] is True
    assert held_rows([(enc, {"T": T})], env, env, False)[1] is True                        # refused sensorless
    assert held_rows([(enc, {"T": 0.5 * T}), (sl, {"T": 0.5 * T})], env, env, True)[1] is False   # half the torque
