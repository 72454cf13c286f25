"""The Prius MG2's map beside ORNL's measured one (ORNL/TM-2006/423).

    python compare_ornl.py MAP_FOLDER

MAP_FOLDER holds `fullspeed map prius-mg2.toml` output (map.csv). Prints the
map's peak machine efficiency and where it sits beside ORNL's, the map's
nearest held points to ORNL's peak, and the plant's own efficiency at
ORNL's peak point: the machine in current control at the least current
that makes the torque (its friction and iron drag included) within the
modulator's linear voltage, the speed held by the load machine (what the
plant's losses give there, whatever the drive's speed loop holds).
"""
from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

import numpy as np

from fullspeed.design.scenario import scenario_from_dict
from fullspeed.model.units import rpm_to_rad_s
from fullspeed.sim import simulate
from fullspeed.workflows.effmap import fluxes, voltage_limit

HERE = Path(__file__).resolve().parent
ORNL_PEAK = {"eta": 0.950, "speed_rpm": 2303.0, "torque_Nm": 110.8}   # the transcription of ORNL's table


def least_current_point(sc, rpm: float, T_e: float) -> tuple[float, float]:
    """(i_d, i_q) of least magnitude that makes T_e within the linear voltage at rpm."""
    m = sc.machine
    w = m.pole_pairs * rpm_to_rad_s(rpm)
    I = np.linspace(1.0, sc.data["controller"]["i_max"], 500)
    g = np.linspace(0.5 * np.pi, np.pi, 1801)
    i_d, i_q = np.outer(I, np.cos(g)), np.outer(I, np.sin(g))
    psi_d, psi_q = fluxes(m, i_d, i_q)
    T = 1.5 * m.pole_pairs * (psi_d * i_q - psi_q * i_d)
    u = np.hypot(m.R_s * i_d - w * psi_q, m.R_s * i_q + w * psi_d)
    ok = (T >= T_e) & (u <= voltage_limit(sc))
    k = np.argwhere(ok)
    if not k.size:
        raise SystemExit(f"{T_e:.1f} N m is beyond the envelope at {rpm:g} rpm")
    a, b = k[np.argmin(k[:, 0])]   # the smallest magnitude, then its first angle
    return float(i_d[a, b]), float(i_q[a, b])


def plant_at(rpm: float, torque: float) -> dict:
    """The plant's efficiency at a shaft torque and speed, with the drive in current control."""
    base = {"name": "ornl-point", "duration": 0.3, "machine": str(HERE / "prius-mg2.toml"), "metrics": {"steady": [0.15, 0.3]},
            "controller": {"mode": "current", "angle": "encoder"},
            "losses": {"devices": True, "iron": True}, "load": {"kind": "speed", "speed_rpm": rpm},
            "initial": {"speed_rpm": rpm}}
    sc = scenario_from_dict(base)
    T_e = torque
    for _ in range(3):   # the drag depends on the flux the currents make
        i_d, i_q = least_current_point(sc, rpm, T_e)
        res = simulate(scenario_from_dict({**base, "references": {"i_d": i_d, "i_q": i_q}}))
        P = res.metrics["power"]   # over the steady window: the load machine takes what the shaft gives
        w = rpm_to_rad_s(rpm)
        T_e = torque + (P["P_fe_W"] + P["P_mech_W"]) / w
    return {"i_d_A": i_d, "i_q_A": i_q, "shaft_Nm": P["P_shaft_W"] / w, **P}


def main(folder: str) -> None:
    rows = [r for r in csv.DictReader(open(Path(folder) / "map.csv")) if r["held"] == "True"]
    best = max(rows, key=lambda r: float(r["eta_machine"]))
    print(f"map's peak machine efficiency: {100 * float(best['eta_machine']):.1f} % at {float(best['speed_rpm']):.0f} rpm, "
          f"{float(best['torque_Nm']):.1f} N m")
    print(f"ORNL's measured peak:          {100 * ORNL_PEAK['eta']:.1f} % at {ORNL_PEAK['speed_rpm']:.0f} rpm, "
          f"{ORNL_PEAK['torque_Nm']:.1f} N m")
    near = sorted(rows, key=lambda r: math.hypot(float(r["speed_rpm"]) / ORNL_PEAK["speed_rpm"] - 1.0,
                                                 float(r["torque_Nm"]) / ORNL_PEAK["torque_Nm"] - 1.0))[:3]
    for r in near:
        print(f"  held near it: {float(r['speed_rpm']):.0f} rpm, {float(r['torque_Nm']):.1f} N m: machine "
              f"{100 * float(r['eta_machine']):.1f} %, drive {100 * float(r['eta_drive']):.1f} %")
    p = plant_at(ORNL_PEAK["speed_rpm"], ORNL_PEAK["torque_Nm"])
    print(f"the plant at ORNL's point in current control (i_d {p['i_d_A']:.1f} A, i_q {p['i_q_A']:.1f} A, "
          f"{p['shaft_Nm']:.1f} N m on the shaft): machine {100 * p['eta_machine']:.1f} %, drive {100 * p['eta_drive']:.1f} % "
          f"(copper {p['P_cu_W']:.0f} W, iron {p['P_fe_W']:.0f} W, friction {p['P_mech_W']:.0f} W)")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "out/maps/prius-mg2")
