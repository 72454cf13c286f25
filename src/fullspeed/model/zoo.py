"""The machine zoo: a seeded generator of plausible PMSMs across the range
people build, given only what a datasheet gives; every other setting is
designed (fullspeed.design).

Machine k of seed s is always the same machine. The ranges: 2..12 pole
pairs, 100 W..50 kW, saliency L_q/L_d 1.2..3.5, 24..700 V links, 8..20 kHz
PWM, half of them with magnetic saturation (self-saturation of the d axis,
which polarity detection needs, and cross-saturation), dead time, current
sensor noise and 12-bit quantization. A scenario names one as
`machine = { zoo = k }` (and `zoo_seed`); the catalog sweep `beyond-zoo`
runs the first SIZE (claim B-ZOO). From SIZE on the machines are the
low-saliency family, L_q/L_d 1.0..1.2 (surface magnets, hub motors: what
an injection cannot use), drawn otherwise alike: the draws of the first
SIZE are not changed by it (claim B-START runs some of them).

How each quantity is drawn, and why:
- power P log-uniform 100 W..50 kW; rated speed log-uniform 1000..6000 rpm
  (smaller machines run faster: the range narrows to 1000..3000 rpm at
  50 kW); T_rated = P / w_rated;
- the link from the power, as products are built: u_dc about 30 V (P /
  100 W)^0.45, times 0.8..1.4, within 24..700 V (100 W: 24-48 V; 10 kW:
  about 240 V; 50 kW: 500-700 V);
- the back-EMF at rated speed 0.5..0.8 of the linear limit u_dc/sqrt3
  (psi_f), the q reactance at rated current 0.2..0.5 of it (L_q), so the
  rated point fits the link with id = 0 or a little flux weakening;
- i_rated from the torque with the magnet's share 0.8..1 of it;
- R_s from copper losses of 1..5 % of P (larger machines lower);
- J from the mechanical time constant J w_rated / T_rated, 0.05..0.4 s
  (a motor with its coupling and some load inertia);
- friction 1 % of rated torque at rated speed, Coulomb 0.5..1.5 %;
- saturation: the incremental L_d at +i_rated 15..30 % below L_d (the
  magnet's flux and the current's add), cross-saturation lowering the
  incremental L_q by 3..10 % at rated q current (fs_magnetic.h's model);
- dead time 0.3 us at 24 V to 2 us at 700 V; noise 1..3 ADC steps.
"""
from __future__ import annotations

import math

import numpy as np

from .units import rpm_to_rad_s

SEED = 2026
SIZE = 100


def _loguniform(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def machine(k: int, seed: int = SEED) -> dict:
    """Machine k of the zoo with this seed: a machine table (datasheet
    fields only) that fullspeed.model.machines.parse_machine accepts."""
    rng = np.random.default_rng([seed, k])
    p = int(rng.integers(2, 13))
    P = _loguniform(rng, 100.0, 50e3)
    n_hi = 6000.0 - 3000.0 * math.log10(P / 100.0) / math.log10(500.0)   # 6000 rpm at 100 W .. 3000 at 50 kW
    n_rated = _loguniform(rng, 1000.0, n_hi)
    w_m = rpm_to_rad_s(n_rated)
    w_e = p * w_m
    T = P / w_m
    u_dc = min(max(30.0 * (P / 100.0) ** 0.45 * rng.uniform(0.8, 1.4), 24.0), 700.0)
    u_lin = u_dc / math.sqrt(3)
    psi_f = rng.uniform(0.5, 0.8) * u_lin / w_e
    i_rated = T / (1.5 * p * psi_f) * rng.uniform(0.8, 1.0)
    L_q = rng.uniform(0.2, 0.5) * u_lin / (w_e * i_rated)
    xi = rng.uniform(1.2, 3.5) if k < SIZE else rng.uniform(1.0, 1.2)   # the same draw: the first SIZE unchanged
    L_d = L_q / xi
    R_s = rng.uniform(0.01, 0.05) * (1.0 - 0.5 * math.log10(P / 100.0) / math.log10(500.0)) * P / (1.5 * i_rated ** 2)
    J = rng.uniform(0.05, 0.4) * T / w_m
    f_pwm = float(rng.integers(8, 21)) * 1e3
    t_dead = 0.3e-6 + (2.0e-6 - 0.3e-6) * (u_dc - 24.0) / (700.0 - 24.0)
    saturates = bool(k % 2 == 0)
    i_max = 1.5 * i_rated   # the designed limit (fullspeed.design.rules): the noise's scale
    lsb = 2 * 1.2 * 1.25 * i_max / 4096
    m = {
        "name": f"zoo-{seed}-{k}", "kind": "spmsm" if xi < 1.05 else "ipmsm", "phases": 3, "pole_pairs": p,
        "description": f"zoo machine {k} (seed {seed}): {P / 1e3:.3g} kW, {n_rated:.0f} rpm, {u_dc:.0f} V, "
                       f"L_q/L_d {xi:.2f}, {'saturating' if saturates else 'linear magnetics'}",
        "source": f"fullspeed.model.zoo.machine({k}, seed={seed})",
        "electrical": {"R_s": R_s, "L_d": L_d, "L_q": L_q, "psi_f": psi_f},
        "mechanical": {"J": J, "B": 0.01 * T / w_m, "T_coulomb": rng.uniform(0.005, 0.015) * T},
        "rated": {"torque": T, "current": i_rated, "speed_rpm": n_rated, "power": P},
        "bench": {"u_dc": u_dc, "f_pwm": f_pwm, "t_dead": t_dead, "adc_bits": 12,
                  "noise_i": rng.uniform(1.0, 3.0) * lsb},
    }
    s_d, c_q = rng.uniform(0.15, 0.30), rng.uniform(0.03, 0.10)
    if saturates:
        m["magnetic"] = saturation(L_d, L_q, psi_f, i_rated, s_d, c_q)
    return m


def saturation(L_d: float, L_q: float, psi_f: float, i_rated: float, s_d: float, c_q: float,
               S: int = 8, U: int = 2, V: int = 1) -> dict:
    """The algebraic model's coefficients (fs_magnetic.h) for a machine whose
    incremental L_d is s_d below L_d at +i_rated on the d axis, and whose
    incremental L_q falls by c_q at rated q current (at the magnet's flux)."""
    psi_d1 = psi_f + L_d * i_rated
    # d(i_d)/d(psi_d) = 1/L_d + (S + 1) a_dd psi_d^S = 1 / ((1 - s_d) L_d) at psi_d1
    a_dd = (1.0 / (1.0 - s_d) - 1.0) / L_d / ((S + 1) * psi_d1 ** S)
    # the cross term's d(i_q)/d(psi_q) = a_dq/(U+2) (V+1) psi_d^(U+2) psi_q^V = c_q / L_q at (psi_f, L_q i_rated)
    psi_q1 = L_q * i_rated
    a_dq = c_q / L_q * (U + 2) / ((V + 1) * psi_f ** (U + 2) * psi_q1 ** V)
    return {"model": "algebraic", "a_dd": a_dd, "S": float(S), "a_qq": 0.0, "T": 0.0, "a_dq": a_dq,
            "U": float(U), "V": float(V),
            "source": "fullspeed.model.zoo: drawn",
            "reason": f"incremental L_d {s_d:.0%} lower at +i_rated than L_d; incremental L_q {c_q:.0%} lower at rated q current"}


def machines(n: int = SIZE, seed: int = SEED) -> list[dict]:
    """The first n machines of the zoo with this seed."""
    return [machine(k, seed) for k in range(n)]
