"""Offline calibration of the injection estimator's cross-saturation error.

A cross-saturated machine has its HF saliency axis away from the d axis by an
angle that grows with the q current; an injection estimator, rotating
(yang2022) or square-wave (yu2022), locks onto that axis. The calibration runs the drive in current control with the
encoder in the loop and the estimator alongside, steps i_q through the range,
and records the estimate's lead theta_hat - theta_r at each step: the table
the estimator then takes out online (fs_xcomp.h; claims B-XCOMP-3PH,
U-XCOUPLE). Run it where the speed is held low (the square wave's estimate
leads by 1.5 w_e Ts besides, which is not cross-saturation).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .errors import ConfigError
from .files import write_atomic
from .metrics import window_mask
from .scenario import Scenario, load_scenario
from .sim import simulate

T_START = 0.1      # s: the estimator settles at zero current first


def xsat_table(scenario: str | Path, i_q_max: float = 40.0, points: int = 17,
               t_hold: float = 0.15, t_avg: float = 0.1) -> tuple[dict, Scenario]:
    """Measure delta(i_q) on an even grid from -i_q_max to +i_q_max (A).

    Each current is held t_hold seconds and the error averaged over its last
    t_avg seconds. Returns the table {i_q, delta_deg, source} and the scenario
    that was run.
    """
    if not 2 <= points <= 33:
        raise ConfigError("points", points, "must be 2..33 (the estimator's table size)", None)
    if not i_q_max > 0:
        raise ConfigError("i_q_max", i_q_max, "must be > 0 A", None)
    if not 0 < t_avg < t_hold:
        raise ConfigError("t_avg", t_avg, f"must be > 0 and < t_hold ({t_hold:g} s)", None)
    grid = np.linspace(-i_q_max, i_q_max, points)
    edges = [round(T_START + t_hold * k, 9) for k in range(points + 1)]
    t_steps, duration = edges[:-1], edges[-1]
    profile = [[0.0, 0.0], [T_START, 0.0]]
    for k, i in enumerate(grid):
        profile += [[edges[k], float(i)], [edges[k + 1], float(i)]]
    angle = load_scenario(scenario).data["controller"]["angle"]
    sc = load_scenario(scenario, {
        "duration": duration,
        "controller": {"mode": "current", "angle": "swvi" if angle == "swvi" else "hfi"},
        "observer": {"handover": duration},          # the encoder all along
        "injection": {"xcomp": None},
        "references": {"i_q": profile, "i_d": 0.0},
        "metrics": {"steady": None},
    })
    if sc.data["controller"]["i_max"] < i_q_max:
        raise ConfigError("i_q_max", i_q_max, f"must be <= controller.i_max ({sc.data['controller']['i_max']:g} A)", sc.source)
    res = simulate(sc)
    if res.stop_reason != "done":
        raise ConfigError("scenario", sc.name, f"calibration run stopped: {res.stop_reason} at {res.stop_time}", sc.source)
    delta = []
    for t in t_steps:
        m = window_mask(res["t"], t + t_hold - t_avg, t + t_hold)
        delta.append(-float(np.degrees(np.mean(res["est_err"][m]))))
    table = {"i_q": [round(float(i), 6) for i in grid], "delta_deg": [round(d, 4) for d in delta],
             "source": f"fullspeed calibrate on {sc.name} ({sc.machine.name}): encoder in the loop, "
                       f"i_q held {t_hold:g} s per point, mean of theta_hat - theta over the last {t_avg:g} s"}
    return table, sc


def write_table(table: dict, path: Path) -> Path:
    """The table as TOML ([xcomp] with i_q, delta_deg and source), readable by
    injection.xcomp."""
    def arr(xs):
        return "[" + ", ".join(f"{x:g}" for x in xs) + "]"
    text = ("# Cross-saturation table of the HF injection estimator (fullspeed calibrate)\n"
            "[xcomp]\n"
            f"source = {json.dumps(table['source'])}\n"
            + f"i_q = {arr(table['i_q'])}              # A\n"
            f"delta_deg = {arr(table['delta_deg'])}    # el.deg, theta_hat - theta_r uncompensated\n")
    return write_atomic(path, text)
