"""What the back-EMF observer's angle shows of an angle error, along each
catalog flux map's MTPA locus.

The tracking observer (csrc/control/fs_smo.h, saturation) models the
extended EMF with the map's q secant inductance L_q = psi_q / i_q and reads
the map at the current as its own frame sees it. An angle error d turns
that current by d, so the model's L_q moves with the error, and the EMF's
angle shows only g d of it (first order, steady state):

    g = 1 + (L_qd i_q - (L_qq - L_q) i_d) / psi_a,   psi_a = psi_d - L_q i_d,

L_qq = d psi_q / d i_q and L_qd = d psi_q / d i_d at the operating point:
1 where the machine does not saturate, less where its q axis saturates
along a negative i_d. The tracker's gains assume g = 1; where g is small
its correction works at a fraction of its bandwidth there, and the EMF's
model errors hold an angle error 1 / g times larger than on a linear
machine.

This prints g at fractions of the current limit on each map's MTPA locus,
from the formula and, as its check, from the angle the model's EMF points
at when the frame is turned by +-1 mrad (the two agree to the map's
interpolation). A diagnostic, not a claim: see docs/held-runs.md.

    .venv/bin/python bench/emf_sensitivity.py [--machines prius2004-mg2,syre-thor]
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

SHARES = (0.25, 0.5, 0.75, 1.0)   # of the current limit, on MTPA
H_ANGLE = 1e-3                     # rad: the frame's turn for the check


def emf_sensitivity(psi, i_d: float, i_q: float, h: float) -> float:
    """g from the map psi(i_d, i_q) -> (psi_d, psi_q) at a point (module
    docstring), the derivatives by central differences of step h (A)."""
    psi_d, psi_q = psi(i_d, i_q)
    L_q = psi_q / i_q
    L_qq = (psi(i_d, i_q + h)[1] - psi(i_d, i_q - h)[1]) / (2 * h)
    L_qd = (psi(i_d + h, i_q)[1] - psi(i_d - h, i_q)[1]) / (2 * h)
    return 1.0 + (L_qd * i_q - (L_qq - L_q) * i_d) / (psi_d - L_q * i_d)


def emf_angle_error(psi, i_d: float, i_q: float, d: float) -> float:
    """The angle (rad) the model's steady EMF shows when the tracker's frame
    lags the rotor's by d: the model takes L_q at the current as that frame
    sees it, the machine's flux is the map's at the true current."""
    c, s = np.cos(d), np.sin(d)
    e_d, e_q = i_d * c - i_q * s, i_q * c + i_d * s   # the current in the lagging frame
    L_q = psi(e_d, e_q)[1] / e_q
    psi_d, psi_q = psi(i_d, i_q)
    return d + float(np.arctan2(psi_q - L_q * i_q, psi_d - L_q * i_d))


def rows(name: str) -> list[dict]:
    from fullspeed.design.machine import load_machine
    from fullspeed.design.magnetics import mtpa_locus
    from fullspeed.model.fluxmap import interp
    m = load_machine(name)
    mag = m.magnetic
    if mag is None or mag.get("model") != "fluxmap":
        return []   # a linear machine: g = 1
    i_max = m.bench["i_max"]
    T, d, q = mtpa_locus(mag, i_max, m.phases, m.pole_pairs)
    I = np.hypot(d, q)
    h = 1e-2 * (mag["i_d"][1] - mag["i_d"][0])

    def psi(i_d, i_q):
        return float(interp(mag, "psi_d", i_d, i_q)), float(interp(mag, "psi_q", i_d, i_q))

    out = []
    for share in SHARES:
        k = int(np.argmin(np.abs(I - share * i_max)))
        i_d, i_q = float(d[k]), float(q[k])
        g = emf_sensitivity(psi, i_d, i_q, h)
        g_check = (emf_angle_error(psi, i_d, i_q, H_ANGLE) - emf_angle_error(psi, i_d, i_q, -H_ANGLE)) / (2 * H_ANGLE)
        out.append({"machine": name, "share": share, "i_d": i_d, "i_q": i_q, "T": float(T[k]), "g": g, "g_check": g_check})
    return out


def main(argv: list[str] | None = None) -> int:
    from fullspeed.model.machines import published_machines
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--machines", default=",".join(published_machines()))
    a = ap.parse_args(argv)
    print("machine                 |i|/i_max    i_d A    i_q A    T N m      g   (check)")
    for n in a.machines.split(","):
        for r in rows(n):
            print(f"{r['machine']:22s} {r['share']:8.2f} {r['i_d']:8.1f} {r['i_q']:8.1f} {r['T']:8.1f} {r['g']:6.2f}   ({r['g_check']:.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
