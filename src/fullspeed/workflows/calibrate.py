"""Offline calibration of the injection estimator's cross-saturation error.

A cross-saturated machine has its HF saliency axis away from the d axis by an
angle that grows with the q current; an injection estimator, rotating
(yang2022) or square-wave (yu2022), locks onto that axis. The calibration runs the drive in current control with the
encoder in the loop and the estimator alongside, steps i_q through the range,
and records the estimate's lead theta_hat - theta_r at each step: the table
the estimator then takes out online (fs_xcomp.h; claims B-XCOMP-3PH,
U-XCOUPLE).

The speed is held by the load machine whatever the scenario's load was (the
square wave's estimate leads by 1.5 w_e Ts besides, which is not
cross-saturation, and a torque load lets the rotor run away under the q
current). A table that cannot be trusted is refused with the reason
(CalibrationError), never written: the estimate had not locked at zero
current, slipped (the injection sees the saliency axis modulo 180 el.deg, so
a lead of 90 el.deg or more is a slip, not cross-saturation) or wandered
within a point's averaging window, or the speed left its band there. The
angles are averaged on the circle; each point's scatter (circular standard
deviation) is reported with the table, and the table is checked by running
the same steps again with it in the estimator: the compensated estimate's
mean error at each point (`residual_deg`).

A table holds the estimator's own bias at the settings it was measured with
as well as the machine's cross-saturation (the rotating injection's leak,
issue 27: about 3 el.deg at 40 A on yang2022, of either sign; the square
wave's lead of its sequence at the held speed), so it records them
(`settings`) and a scenario that uses it with others is refused (the
estimator, the leak, the sequence: a known bias) or warned, one line naming
the field (the machine, the carrier, the filters): design.xcomp.check_table_settings.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..design.scenario import load_scenario
from ..design.xcomp import table_settings
from ..model.errors import ConfigError
from ..model.files import write_atomic
from ..model.scenario import Scenario
from ..model.schema import toml_string
from ..model.units import rad_s_to_rpm
from ..sim.metrics import window_mask
from ..sim.runner import simulate

T_START = 0.1          # s: the estimator settles at zero current first
DEFAULT_SPEED_RPM = 100.0   # held when the scenario's load does not hold a speed: low, where injection is used
# Where the scenario's load holds no speed: a load machine with inertia, not
# an ideal speed source. The rotating injection's motion observer feeds the
# torque forward through J + J_load (fs_hfi.h); against an ideal source (no
# acceleration at all) it lost the yang2022 machine at -40 A, with 1, 2, 5
# and 10 times J it held (residual 0.93, 0.80, 0.67, 0.60 el.deg). Five: a
# bench's load machine, and the speed sags less.
J_LOAD_PER_J = 5.0
LOCK_DEG = 30.0        # at zero current the estimate is within this of the rotor's angle, or it has not locked
SLIP_DEG = 90.0        # a lead this large is a slip (the saliency axis repeats every 180 el.deg), not cross-saturation
WANDER_DEG = 20.0      # within a point's averaging window no sample strays further from the window's mean
SPEED_BAND = 0.25      # the true speed within 25 % of the held speed in every averaging window (a speed-PI load sags
                       # 10 % under a 40 A step on yang2022; the lead that moves with speed, 1.5 w_e Ts of the
                       # square wave, moves 0.1 el.deg over the band at 100 rpm) ...
SPEED_FLOOR_RPM = 2.0  # ... and never a band narrower than 2 rpm (a held standstill)


class CalibrationError(ConfigError):
    """A calibration whose table cannot be trusted: the reason, no table."""


def circular_mean_deg(a_rad: np.ndarray) -> float:
    """The mean direction of angles (rad), el.deg: wrapped angles near +-180
    average to 180, not to 0."""
    return float(np.degrees(np.angle(np.mean(np.exp(1j * a_rad)))))


def circular_std_deg(a_rad: np.ndarray) -> float:
    """The circular standard deviation sqrt(-2 ln R), el.deg."""
    r = min(1.0, float(np.abs(np.mean(np.exp(1j * a_rad)))))
    return float(np.degrees(np.sqrt(-2.0 * np.log(r)))) if r > 0 else float("inf")


def _wrap(a_rad: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * a_rad))


def _held_speed(sc_raw: Scenario, speed_rpm: float | None) -> tuple[float, dict]:
    """The speed to hold and the [load] that holds it: the scenario's own
    speed load (ideal or a speed-controlled machine, with its bandwidth and
    inertia) at that speed, else a speed-controlled load machine of
    J_LOAD_PER_J times the motor's inertia."""
    load = sc_raw.data["load"]
    if load["kind"] in ("speed", "speed_pi"):
        speed_rpm = load["speed_rpm"][1][-1] if speed_rpm is None else speed_rpm
        return speed_rpm, {"kind": load["kind"], "speed_rpm": speed_rpm, "torque": 0.0}
    speed_rpm = DEFAULT_SPEED_RPM if speed_rpm is None else speed_rpm
    return speed_rpm, {"kind": "speed_pi", "speed_rpm": speed_rpm, "torque": 0.0, "J_load": J_LOAD_PER_J * sc_raw.machine.J}


def _profile(grid: np.ndarray, t_hold: float) -> tuple[list, list, float]:
    edges = [round(T_START + t_hold * k, 9) for k in range(len(grid) + 1)]
    profile = [[0.0, 0.0], [T_START, 0.0]]
    for k, i in enumerate(grid):
        profile += [[edges[k], float(i)], [edges[k + 1], float(i)]]
    return profile, edges[:-1], edges[-1]


def _points(res, t_steps, t_hold, t_avg) -> tuple[list, list, list]:
    """Per point: the circular mean of theta_hat - theta (el.deg), its
    scatter and the largest stray from it in the averaging window, and the
    true speed's extremes there (rpm)."""
    lead, spread, speed = [], [], []
    for t in t_steps:
        m = window_mask(res["t"], t + t_hold - t_avg, t + t_hold)
        e = -np.asarray(res["est_err"])[m]   # est_err is true minus estimate
        mu = circular_mean_deg(e)
        lead.append(mu)
        spread.append((circular_std_deg(e), float(np.max(np.abs(np.degrees(_wrap(e - np.radians(mu))))))))
        w = rad_s_to_rpm(np.asarray(res["w_m"])[m])
        speed.append((float(np.min(w)), float(np.max(w))))
    return lead, spread, speed


def xsat_table(scenario: str | Path, i_q_max: float = 40.0, points: int = 17,
               t_hold: float = 0.15, t_avg: float = 0.1, speed_rpm: float | None = None,
               verify: bool = True) -> tuple[dict, Scenario]:
    """Measure delta(i_q) on an even grid from -i_q_max to +i_q_max (A).

    Each current is held t_hold seconds at speed_rpm (default: the speed the
    scenario's load holds, else DEFAULT_SPEED_RPM) and the lead averaged
    over its last t_avg seconds. Returns the table {i_q, delta_deg, source,
    spread_deg, speed_rpm, residual_deg} and the scenario that was run;
    raises CalibrationError with the reason when the table cannot be trusted.
    With verify, the steps are run again with the table in the estimator and
    residual_deg is the compensated estimate's mean error at each point.
    """
    if not 2 <= points <= 33:
        raise ConfigError("points", points, "must be 2..33 (the estimator's table size)", None)
    if not i_q_max > 0:
        raise ConfigError("i_q_max", i_q_max, "must be > 0 A", None)
    if not 0 < t_avg < t_hold:
        raise ConfigError("t_avg", t_avg, f"must be > 0 and < t_hold ({t_hold:g} s)", None)
    grid = np.linspace(-i_q_max, i_q_max, points)
    profile, t_steps, duration = _profile(grid, t_hold)
    raw = load_scenario(scenario)
    held, load = _held_speed(raw, speed_rpm)
    angle = raw.data["controller"]["angle"]
    over = {
        "duration": duration,
        "controller": {"mode": "current", "angle": "swvi" if angle == "swvi" else "hfi"},
        "observer": {"handover": duration},          # the encoder all along
        "references": {"i_q": profile, "i_d": 0.0},
        "load": load,
        "initial": {"speed_rpm": held},
        "metrics": {"steady": None},
    }
    sc = load_scenario(scenario, {**over, "injection": {"xcomp": False}})   # uncompensated: not the designed table
    if sc.data["controller"]["i_max"] < i_q_max:
        raise ConfigError("i_q_max", i_q_max, f"must be <= controller.i_max ({sc.data['controller']['i_max']:g} A)", sc.source)
    res = simulate(sc)
    if res.stop_reason != "done":
        raise CalibrationError("scenario", sc.name, f"calibration run stopped: {res.stop_reason} at {res.stop_time}; no table written", sc.source)
    _check_lock_at_zero(res, sc)
    lead, spread, speed = _points(res, t_steps, t_hold, t_avg)
    band = max(SPEED_BAND * abs(held), SPEED_FLOOR_RPM)
    for i, d, (s_circ, stray), (w_lo, w_hi) in zip(grid, lead, spread, speed):
        where = f"at i_q = {i:g} A"
        if abs(d) >= SLIP_DEG:
            raise CalibrationError("scenario", sc.name, f"the estimate slipped {where}: it leads the encoder by {d:+.1f} el.deg "
                                   f"(|lead| >= {SLIP_DEG:g} is a slip, not cross-saturation); lower --i-q-max or use a "
                                   "larger carrier; no table written", sc.source)
        if stray > WANDER_DEG:
            raise CalibrationError("scenario", sc.name, f"the estimate did not settle {where}: it strays {stray:.1f} el.deg "
                                   f"from its mean within the averaging window (> {WANDER_DEG:g}); no table written", sc.source)
        if w_lo < held - band or w_hi > held + band:
            raise CalibrationError("scenario", sc.name, f"the speed left its band {where}: {w_lo:.1f}..{w_hi:.1f} rpm against "
                                   f"{held:g} +- {band:.3g} rpm held by the load machine; a stiffer load.bandwidth or a "
                                   "smaller --i-q-max; no table written", sc.source)
    table = {"i_q": [round(float(i), 6) for i in grid], "delta_deg": [round(d, 4) for d in lead],
             "source": f"fullspeed calibrate on {sc.name} ({sc.machine.name}): encoder in the loop, {held:g} rpm held by "
                       f"the load machine, i_q held {t_hold:g} s per point, circular mean of theta_hat - theta over the "
                       f"last {t_avg:g} s",
             "spread_deg": [round(s, 4) for s, _ in spread], "speed_rpm": held,
             "settings": table_settings(sc.data, sc.machine.name)}
    if verify:
        again = simulate(load_scenario(scenario, {**over, "injection": {"xcomp": {k: table[k] for k in ("i_q", "delta_deg", "settings")}}}))
        if again.stop_reason != "done":
            raise CalibrationError("scenario", sc.name, f"the check with the table stopped: {again.stop_reason}; no table written", sc.source)
        table["residual_deg"] = [round(d, 4) for d in _points(again, t_steps, t_hold, t_avg)[0]]
    return table, sc


def _check_lock_at_zero(res, sc: Scenario) -> None:
    """The estimate must be on the rotor's angle at zero current before the
    steps: else every lead measured after is against a wrong start."""
    m = window_mask(res["t"], 0.5 * T_START, T_START)
    d = circular_mean_deg(-np.asarray(res["est_err"])[m])
    if abs(d) > LOCK_DEG:
        raise CalibrationError("scenario", sc.name, f"the estimate had not locked at zero current: {d:+.1f} el.deg from the "
                               f"encoder at {T_START:g} s (> {LOCK_DEG:g}); no table written", sc.source)


def _toml_value(v) -> str:
    return toml_string(v) if isinstance(v, str) else f"{v:.9g}"


def write_table(table: dict, path: Path) -> Path:
    """The table as TOML ([xcomp] with i_q, delta_deg and source, readable
    by injection.xcomp; [calibration] with the scatter, the held speed and
    the check), written to a temporary name and renamed into place."""
    def arr(xs):
        return "[" + ", ".join(f"{x:g}" for x in xs) + "]"
    text = ("# Cross-saturation table of the HF injection estimator (fullspeed calibrate)\n"
            "[xcomp]\n"
            f"source = {toml_string(table['source'])}\n"
            + f"i_q = {arr(table['i_q'])}              # A\n"
            f"delta_deg = {arr(table['delta_deg'])}    # el.deg, theta_hat - theta_r uncompensated\n")
    if table.get("settings"):
        text += ("\n# what it was measured with: a scenario that differs is refused (estimator, leak, sequence) or warned\n"
                 "[xcomp.settings]\n"
                 + "".join(f"{k} = {_toml_value(v)}\n" for k, v in table["settings"].items()))
    if "spread_deg" in table:
        text += ("\n# how far the table can be trusted (not read by the estimator)\n[calibration]\n"
                 f"speed_rpm = {table['speed_rpm']:g}            # held by the load machine\n"
                 f"spread_deg = {arr(table['spread_deg'])}    # el.deg, circular std of the lead in each averaging window\n")
        if "residual_deg" in table:
            text += f"residual_deg = {arr(table['residual_deg'])}    # el.deg, the compensated estimate's mean lead, same steps\n"
    return write_atomic(path, text)
