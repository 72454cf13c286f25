"""The machine's envelope (fullspeed.design.envelope): exact against the
closed-form MTPA, voltage ellipse and MTPV on linear machines, against a
brute-force search of the current disc on flux maps, against the plant's C
model on algebraic ones; the trial's two machines against the trial's own
numbers; the feasibility warnings it gives `run` and scenario loading; and
what `fullspeed design` prints and writes."""
import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fullspeed.design.envelope import (OVERMODULATION, Limits, envelope, plant_flux, plant_mag, table_speeds,
                                       torque_at)
from fullspeed.design.machine import load_machine, machine_from_dict, mtpa_torque
from fullspeed.design.report import envelope_report, scenario_envelope
from fullspeed.design.scenario import scenario_from_dict
from fullspeed.model import zoo
from fullspeed.model.fluxmap import interp
from fullspeed.model.units import rad_s_to_rpm, rpm_to_rad_s

ROOT = Path(__file__).resolve().parents[1]
BALDOR = Path("/work/shared/data/baldor/baldor_400rpm_map.npz")


# --- the trial's machines (new-user-trial-2026-11-28, sec. 1), their maps built as the trial built them ------------

def secant_map(i_d, i_q, psi_f, L_d, L_q):
    """A flux map from secant inductances of each axis's own current."""
    D, Q = np.meshgrid(i_d, i_q, indexing="ij")
    return {"model": "fluxmap", "i_d": list(i_d), "i_q": list(i_q),
            "psi_d": (psi_f + L_d(D) * D).tolist(), "psi_q": (L_q(Q) * Q).tolist()}


def prius(i_max=250.0):
    """2004 Prius MG2: secant L(i) = L0 / (1 + |i|/a) through the published
    points, L_q 6.15 -> 3 mH and L_d 2.26 -> 1.8 mH at 250 A."""
    a_q, b_d = 250.0 / (6.15 / 3.0 - 1.0), 250.0 / (2.26 / 1.8 - 1.0)
    mag = secant_map(np.linspace(-250.0, 125.0, 31), np.linspace(-250.0, 250.0, 41), 0.1607,
                     lambda i: 2.26e-3 / (1 + abs(i) / b_d), lambda i: 6.15e-3 / (1 + abs(i) / a_q))
    return machine_from_dict({
        "name": "prius2004", "kind": "ipmsm", "pole_pairs": 4, "magnetic": mag,
        "electrical": {"R_s": 0.077, "L_d": 2.26e-3, "L_q": 6.15e-3, "psi_f": 0.1607},
        "mechanical": {"J": 0.035}, "rated": {"torque": 400.0, "current": 250.0, "speed_rpm": 1200.0},
        "bench": {"u_dc": 500.0, "f_pwm": 10000.0, "i_max": i_max}})


H27_L_Q = (27.44, 27.77, 27.42, 26.46, 24.26, 23.29, 22.41)   # mH at 0..6 A (the drive's parameter sheet)


def h27():
    """Hefei H27: L_q table read as incremental inductance (the trial's
    second reading, which its envelope used), L_d linear."""
    i_q = np.linspace(-6.0, 6.0, 25)

    def psi_q(i):   # the incremental table integrated from zero current
        x = np.linspace(0.0, abs(i), 201)
        return math.copysign(np.trapezoid(np.interp(x, np.arange(7.0), np.array(H27_L_Q) * 1e-3), x), i)
    mag = secant_map(np.linspace(-6.0, 3.0, 19), i_q, 0.0845, lambda i: 21.17e-3 + 0 * i, lambda i: 0 * i)
    mag["psi_q"] = [[psi_q(q) for q in i_q] for _ in mag["i_d"]]
    return machine_from_dict({
        "name": "hefei-h27", "kind": "ipmsm", "pole_pairs": 4, "magnetic": mag,
        "electrical": {"R_s": 2.87, "L_d": 21.17e-3, "L_q": 27.44e-3, "psi_f": 0.0845},
        "mechanical": {"J": 3e-4}, "rated": {"torque": 3.0, "current": 6.0, "speed_rpm": 6000.0},
        "bench": {"u_dc": 325.0, "f_pwm": 8000.0, "i_max": 6.0}})


def baldor(tmp_path):
    """The measured Baldor PM-SyRM map as a machine file (R_s 0.63 ohm, 2
    pole pairs, 540 V: motulator's example; 8.8 A rms, 29.7 N m, 60 Hz:
    its nameplate)."""
    z = np.load(BALDOR)
    i, psi = z["i_s_dq"], z["psi_s_dq"]
    rows = [",".join(repr(float(x)) for x in (a.real, a.imag, b.real, b.imag)) for a, b in zip(i.ravel(), psi.ravel())]
    (tmp_path / "baldor.csv").write_text("i_d [A],i_q [A],psi_d [Wb],psi_q [Wb]\n" + "\n".join(rows) + "\n")
    (tmp_path / "baldor.toml").write_text(
        'name = "baldor"\nkind = "ipmsm"\npole_pairs = 2\n[magnetic]\nfile = "baldor.csv"\n'
        "[electrical]\nR_s = 0.63\nL_d = 0.026\nL_q = 0.14\npsi_f = 0.444\n[mechanical]\nJ = 0.05\n"
        "[rated]\ntorque = 29.7\ncurrent = 12.45\nspeed_rpm = 1800.0\n[bench]\nu_dc = 540.0\nf_pwm = 5000.0\n")
    return load_machine(tmp_path / "baldor.toml")


# --- linear machines: the closed forms ------------------------------------------------------------------------------

def mtpa_closed(m, I):
    """MTPA of a linear IPMSM at |i| = I: i_d from dT/d(angle) = 0."""
    dL = m.L_q - m.L_d
    i_d = (m.psi_f - math.sqrt(m.psi_f ** 2 + 8 * dL ** 2 * I ** 2)) / (4 * dL) if dL else 0.0
    i_q = math.sqrt(I * I - i_d * i_d)
    return i_d, i_q, 1.5 * m.pole_pairs * (m.psi_f * i_q + (m.L_d - m.L_q) * i_d * i_q)


def speed_closed(m, u, i_d, i_q):
    """The electrical speed where |R i + j w psi| = u (linear), a quadratic in w."""
    pd, pq = m.psi_f + m.L_d * i_d, m.L_q * i_q
    a, b, c = pd ** 2 + pq ** 2, m.R_s * (i_q * pd - i_d * pq), m.R_s ** 2 * (i_d ** 2 + i_q ** 2) - u ** 2
    return (-b + math.sqrt(b * b - a * c)) / a


def mtpv_closed(m, psi):
    """The most torque with |psi| = psi (R_s = 0): the flux angle from
    2 b psi c^2 + a c - b psi = 0, a = psi_f / L_d, b = 1/L_q - 1/L_d."""
    a, b = m.psi_f / m.L_d, 1 / m.L_q - 1 / m.L_d
    best = None
    for c in np.roots([2 * b * psi, a, -b * psi]).real:
        if abs(c) <= 1:
            s = math.sqrt(1 - c * c)
            T = 1.5 * m.pole_pairs * psi * s * (a + b * psi * c)
            if best is None or T > best[0]:
                best = (T, (psi * c - m.psi_f) / m.L_d, psi * s / m.L_q)
    return best


def test_a_linear_machine_without_resistance_is_the_closed_form_mtpa_ellipse_and_mtpv():
    """motulator-2kw-ipmsm with R_s = 0 and i_max 20 A (its characteristic
    current, 15.1 A, inside): MTPA below base speed, the circle meeting the
    ellipse (psi_f + L_d i_d)^2 + (L_q i_q)^2 = (u/w)^2 in flux weakening,
    the MTPV of the ellipse above: the torque to 1e-9; speeds and currents
    to 1e-7 (at a smooth maximum the torque fixes the current's angle only
    to about the square root of its own rounding)."""
    m = dataclasses.replace(load_machine("motulator-2kw-ipmsm"), R_s=0.0)
    I, u_dc = 20.0, 540.0
    u = u_dc / math.sqrt(3)
    env = envelope(m, u_dc, I)
    p = m.pole_pairs
    d0, q0, T0 = mtpa_closed(m, I)
    assert env.T_base == pytest.approx(T0, rel=1e-9)
    assert env.w_base * p == pytest.approx(u / math.hypot(m.psi_f + m.L_d * d0, m.L_q * q0), rel=1e-7)
    assert env.i_ch == pytest.approx(m.psi_f / m.L_d, rel=1e-12) and not env.top_finite
    # where MTPV takes over: its current reaches i_max
    lo, hi = 1e-6, m.psi_f
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if math.hypot(*mtpv_closed(m, mid)[1:]) < I else (lo, mid)
    assert env.w_mtpv * p == pytest.approx(u / lo, rel=1e-6)   # told by |i| < i_max (1 - 1e-9): |i| falls slowly there
    seen = set()
    for k in range(env.w_m.size):
        w = env.w_m[k] * p
        if env.region[k] == "MTPA":
            T, d = T0, d0
        elif env.region[k] == "FW":
            # (L_d^2 - L_q^2) i_d^2 + 2 psi_f L_d i_d + psi_f^2 + L_q^2 I^2 - (u/w)^2 = 0
            r = np.roots([m.L_d ** 2 - m.L_q ** 2, 2 * m.psi_f * m.L_d, m.psi_f ** 2 + m.L_q ** 2 * I * I - (u / w) ** 2]).real
            d = max(x for x in r if -I <= x <= 0)
            T = 1.5 * p * (m.psi_f * math.sqrt(I * I - d * d) + (m.L_d - m.L_q) * d * math.sqrt(I * I - d * d))
        else:
            T, d, _ = mtpv_closed(m, u / w)
        seen.add(env.region[k])
        assert env.T[k] == pytest.approx(T, rel=1e-9, abs=1e-12), (k, env.region[k])
        assert env.i_d[k] == pytest.approx(d, rel=1e-6, abs=1e-6), (k, env.region[k])
    assert seen == {"MTPA", "FW", "MTPV"}


def test_a_linear_machine_with_resistance_meets_the_voltage_limit_exactly():
    """motulator-2kw-ipmsm as it is (R_s = 3.6 ohm, 9.1 A, characteristic
    current beyond i_max): the base speed where the MTPA current's voltage
    |R i + j w psi| reaches u_dc/sqrt3, the top speed at -i_max on the d
    axis, and in flux weakening the circle's point where the voltage
    reaches the limit (bisected here on the closed-form fluxes)."""
    m = load_machine("motulator-2kw-ipmsm")
    I, u = m.bench["i_max"], m.bench["u_dc"] / math.sqrt(3)
    env = envelope(m, m.bench["u_dc"], I)
    p = m.pole_pairs
    d0, q0, T0 = mtpa_closed(m, I)
    assert env.T_base == pytest.approx(T0, rel=1e-9)
    assert env.w_base * p == pytest.approx(speed_closed(m, u, d0, q0), rel=1e-7)
    assert env.top_finite and env.w_mtpv is None
    assert env.w_top * p == pytest.approx(math.sqrt(u * u - (m.R_s * I) ** 2) / (m.psi_f - m.L_d * I), rel=1e-9)
    fw = np.flatnonzero(env.region == "FW")
    assert fw.size > 50
    for k in fw[:-1]:
        w = env.w_m[k] * p

        def volts(g):
            d, q = I * math.cos(g), I * math.sin(g)
            return math.hypot(m.R_s * d - w * m.L_q * q, m.R_s * q + w * (m.psi_f + m.L_d * d)) - u
        a, b = math.atan2(q0, d0), math.pi
        for _ in range(100):
            mid = 0.5 * (a + b)
            a, b = (a, mid) if volts(mid) <= 0 else (mid, b)
        d, q = I * math.cos(b), I * math.sin(b)
        assert env.T[k] == pytest.approx(1.5 * p * (m.psi_f * q + (m.L_d - m.L_q) * d * q), rel=1e-9)
    # the MTPA locus the checks read: each point's speed is where its voltage reaches the limit
    a = env.mtpa
    for k in (10, 60, 128):
        d, q, T = mtpa_closed(m, math.hypot(a["i_d"][k], a["i_q"][k]))
        assert a["T"][k] == pytest.approx(T, rel=1e-9)
        assert a["w_m"][k] * p == pytest.approx(speed_closed(m, u, d, q), rel=1e-7)


def test_a_surface_magnet_machine_weakens_on_the_circle_to_its_top_speed():
    """zou2021's SPMSM: MTPA is i_d = 0, the characteristic current 51.9 A
    is beyond its 15 A, so the top speed is finite, at -i_max."""
    m = load_machine("zou2021")
    env = envelope(m, m.bench["u_dc"], m.bench["i_max"])
    assert env.i_d[0] == pytest.approx(0.0, abs=1e-6) and env.T_base == pytest.approx(1.5 * 2 * m.psi_f * 15.0, rel=1e-12)
    assert env.top_finite and set(env.region) == {"MTPA", "FW"} and env.i_d[-1] == pytest.approx(-15.0, rel=1e-9)
    assert np.all(np.diff(env.T) <= 1e-9)


# --- flux maps: brute force over the current disc ------------------------------------------------------------------------

def brute_force(m, u, i_max, w_e, n=700):
    """The largest torque of any current of a fine polar grid of the
    disc's second quadrant whose steady-state voltage meets u at w_e."""
    I = i_max * np.sqrt(np.linspace(0.0, 1.0, n))
    g = np.linspace(0.5 * math.pi, math.pi, n)
    I, g = np.meshgrid(I, g)
    d, q = I * np.cos(g), I * np.sin(g)
    pd, pq = interp(m.magnetic, "psi_d", d, q), interp(m.magnetic, "psi_q", d, q)
    T = 1.5 * m.pole_pairs * (pd * q - pq * d)
    return [float(T[np.hypot(m.R_s * d - w * pq, m.R_s * q + w * pd) <= u].max(initial=0.0)) for w in w_e]


MAPS = {"prius": lambda tmp: prius(), "h27": lambda tmp: h27(), "baldor": baldor,
        "own-machine": lambda tmp: load_machine(ROOT / "examples/own-machine/my48v.toml")}


@pytest.mark.parametrize("name", sorted(MAPS))
def test_on_a_flux_map_the_envelope_is_the_best_current_within_both_limits(name, tmp_path):
    """At speeds across MTPA, flux weakening and MTPV, the envelope's
    current is inside the disc and meets the voltage limit on the map, and
    its torque is at least the best of 490,000 such currents (and not 1 %
    above it: the grid's resolution on the circle's steep side)."""
    m = MAPS[name](tmp_path)
    i_max, u_dc = m.bench["i_max"], m.bench["u_dc"]
    u = u_dc / math.sqrt(3)
    env = envelope(m, u_dc, i_max)
    ks = sorted({int(np.argmin(np.abs(env.w_m - f * env.w_base))) for f in (0.5, 1.0, 1.2, 1.6, 2.5, 4.0)
                 if f * env.w_base <= env.w_m[-1]})
    w_e = env.w_m[ks] * m.pole_pairs
    T_bf = brute_force(m, u, i_max, w_e)
    for k, w, T in zip(ks, w_e, T_bf):
        d, q = env.i_d[k], env.i_q[k]
        pd, pq = interp(m.magnetic, "psi_d", d, q), interp(m.magnetic, "psi_q", d, q)
        assert math.hypot(d, q) <= i_max * (1 + 1e-12)
        assert math.hypot(m.R_s * d - w * pq, m.R_s * q + w * pd) <= u * (1 + 1e-9)
        assert env.T[k] == pytest.approx(1.5 * m.pole_pairs * (pd * q - pq * d), rel=1e-12)
        assert T - 1e-9 * env.T_base <= env.T[k] <= T * 1.01 + 1e-9 * env.T_base, (name, k, env.region[k])
    assert env.region[0] == "MTPA" and "FW" in set(env.region)


ALGEBRAIC = {"yang2022": lambda: load_machine("yang2022"), "zoo-0": lambda: machine_from_dict(zoo.machine(0)),
             "zoo-2": lambda: machine_from_dict(zoo.machine(2))}


@pytest.mark.parametrize("name", sorted(ALGEBRAIC))
def test_an_algebraic_machine_is_the_plant_model(name):
    """yang2022's and two saturating zoo machines' algebraic magnetics,
    tabulated from fs_mag_flux: the envelope's currents, with the plant's
    own fluxes at them, meet the voltage limit to 1e-5 and make the
    envelope's torque to 1e-5; and no current of a polar grid (the plant's
    fluxes) does better."""
    m = ALGEBRAIC[name]()
    assert m.magnetic["model"] == "algebraic"
    i_max, u_dc = m.bench["i_max"], m.bench["u_dc"]
    u, p = u_dc / math.sqrt(3), m.pole_pairs
    env = envelope(m, u_dc, i_max)
    st = plant_mag(m)
    ks = np.linspace(0, env.w_m.size - 2, 9).astype(int)
    pd, pq = plant_flux(st, env.i_d[ks], env.i_q[ks])
    w = env.w_m[ks] * p
    v = np.hypot(m.R_s * env.i_d[ks] - w * pq, m.R_s * env.i_q[ks] + w * pd)
    assert np.all(v <= u * (1 + 1e-5))
    T = 1.5 * p * (pd * env.i_q[ks] - pq * env.i_d[ks])
    assert np.allclose(T, env.T[ks], rtol=1e-5, atol=1e-9 * env.T_base)
    I, g = np.meshgrid(i_max * np.sqrt(np.linspace(0, 1, 160)), np.linspace(0.5 * math.pi, math.pi, 160))
    d, q = I * np.cos(g), I * np.sin(g)
    gd, gq = plant_flux(st, d, q)
    Tg = 1.5 * p * (gd * q - gq * d)
    for k, wk in zip(ks, w):
        ok = np.hypot(m.R_s * d - wk * gq, m.R_s * q + wk * gd) <= u
        assert env.T[k] >= Tg[ok].max(initial=0.0) * (1 - 1e-5), k


# --- the trial's numbers ---------------------------------------------------------------------------------------------------

def test_the_trials_prius_envelope():
    """The trial's own envelope from its map (sec. 5; 250 A, 500 V, linear
    modulation): 486 N m on MTPA at 250 A, 470 at 1200 rpm, 241 at 2000,
    134 at 3000, 69 at 5000; within 3 % (its map was a grid of its own,
    with an assumed +i_d saturation that the motoring quadrant does not
    reach); and psi_f / L_d = 71 A with the unsaturated L_d, 77 A with the
    map's."""
    env = envelope(prius(), 500.0, 250.0)
    assert env.T_base == pytest.approx(486.0, rel=0.01)
    for rpm, T in ((1200, 470.0), (2000, 241.0), (3000, 134.0), (5000, 69.0)):
        assert torque_at(env, rpm_to_rad_s(rpm)) == pytest.approx(T, rel=0.03), rpm
    assert 71.0 < env.i_ch < 80.0 and not env.top_finite and env.w_mtpv is not None
    assert rad_s_to_rpm(env.w_base) == pytest.approx(1096.2, rel=1e-3)   # the trial's "about 1200 rpm" base


def test_the_trials_h27_envelope():
    """The trial's H27 envelope (6 A, 325 V, linear modulation): 3.19 N m
    to 2000 rpm, 1.70 at 6000, 1.26 at 8000, 1.13 at 9000, 0.84 at 12000;
    the characteristic current psi_f / L_d = 3.99 A (L_d is linear) is
    within the 6 A, so flux weakening goes on along MTPV."""
    m = h27()
    env = envelope(m, 325.0, 6.0)
    assert torque_at(env, rpm_to_rad_s(2000)) == pytest.approx(3.19, rel=0.005)
    for rpm, T in ((6000, 1.70), (8000, 1.26), (9000, 1.13), (12000, 0.84)):
        assert torque_at(env, rpm_to_rad_s(rpm)) == pytest.approx(T, rel=0.015), rpm
    assert env.i_ch == pytest.approx(0.0845 / 21.17e-3, rel=1e-9) and not env.top_finite
    assert env.region[np.argmin(np.abs(env.w_m - rpm_to_rad_s(8000)))] == "MTPV"


def test_the_baldor_map_is_in_the_pmsm_convention():
    """The measured map has the magnet on +d already (psi_d(0, 0) = 0.44
    Wb, psi_q(0, 0) = 0) and the small incremental inductance on d: no turn
    is needed (SyR-e's .mat files are turned on reading). Its characteristic
    current lies beyond the map's -20 A: the envelope says so, and its top
    speed is finite."""
    z = np.load(BALDOR)
    i, psi = z["i_s_dq"], z["psi_s_dq"]
    k, n = np.unravel_index(np.argmin(np.abs(i)), i.shape)
    assert abs(i[k, n]) == 0 and psi[k, n].real > 0.4 and abs(psi[k, n].imag) < 1e-12
    L_d = (psi[k + 1, n].real - psi[k - 1, n].real) / 4.0
    L_q = (psi[k, n + 1].imag - psi[k, n - 1].imag) / 4.0
    assert 0 < L_d < L_q / 2


def test_the_baldor_envelope(tmp_path):
    m = baldor(tmp_path)
    env = envelope(m, 540.0, m.bench["i_max"])
    assert env.i_ch > 20.0 and "beyond the map's -20 A" in env.i_ch_note and env.top_finite
    assert env.T_base > m.T_rated   # 29.7 N m at 8.8 A rms; i_max is 1.5 x that
    assert env.T[-1] == 0.0 and env.i_d[-1] == pytest.approx(-m.bench["i_max"], rel=1e-6)


def test_the_zoo_linear_machines_reach_the_controllers_mtpa_torque():
    """The linear zoo machines: the envelope's MTPA torque at i_max is the
    controller's own MTPA table's (csrc/control/fs_mtpa.c, float32), and the
    envelope falls with speed."""
    for k in (1, 3, 5, 7):
        m = machine_from_dict(zoo.machine(k))
        lim = Limits(m, m.bench["u_dc"], m.bench["i_max"])
        T = lim.mtpa(np.array([m.bench["i_max"]]))[0][0]
        assert T == pytest.approx(mtpa_torque(m, m.bench["i_max"]), rel=1e-5), k
        w = np.linspace(0, 3, 7) * m.pole_pairs * m.w_m_rated
        T_w = lim.best(w)[0]
        assert T_w[0] == pytest.approx(T, rel=1e-12) and np.all(np.diff(T_w[np.isfinite(T_w)]) <= 1e-9), k


# --- the envelope as data -----------------------------------------------------------------------------------------------

def test_torque_at_interpolates_within_its_accuracy():
    """torque_at between the envelope's speeds against the search at those
    speeds: within 2e-4; the braking side mirrors; zero beyond a finite top."""
    m = prius()
    env = envelope(m, 500.0, 250.0)
    lim = Limits(m, 500.0, 250.0)
    mid = 0.5 * (env.w_m[1:] + env.w_m[:-1])[::7]
    exact = lim.best(mid * m.pole_pairs)[0]
    assert np.allclose(torque_at(env, mid), exact, rtol=2e-4)
    assert torque_at(env, -mid[3]) == torque_at(env, mid[3])
    with pytest.raises(ValueError, match="beyond prius2004's envelope"):   # not known beyond an infinite one's end
        torque_at(env, 1.01 * env.w_m[-1])
    mot = load_machine("motulator-2kw-ipmsm")
    e2 = envelope(mot, 540.0, mot.bench["i_max"])
    assert torque_at(e2, 1.01 * e2.w_top) == 0.0


def test_the_optimum_current_for_a_torque_and_a_speed():
    """Below the envelope: the MTPA current where it meets the voltage
    limit, else the least current on the voltage limit (larger than MTPA's,
    within i_max); at the envelope's torque, its current; above, none."""
    m = prius()
    lim = Limits(m, 500.0, 250.0)
    p = m.pole_pairs
    d, q, region = lim.optimum_current(200.0, p * rpm_to_rad_s(500))
    assert region == "MTPA" and lim.torque(d, q) == pytest.approx(200.0, rel=1e-9)
    T_a, d_a, q_a = lim.mtpa(np.array([math.hypot(d, q)]))
    assert T_a[0] == pytest.approx(200.0, rel=1e-9) and d == pytest.approx(d_a[0], abs=1e-6)
    w = p * rpm_to_rad_s(3000)
    T_max, d_max, q_max = (x[0] for x in lim.best(np.array([w])))
    d, q, region = lim.optimum_current(0.8 * T_max, w)
    assert region == "FW" and lim.torque(d, q) == pytest.approx(0.8 * T_max, rel=1e-9)
    assert lim.excess(d, q, w) == pytest.approx(0.0, abs=1e-9 * lim.u) and math.hypot(d, q) < 250.0
    assert math.hypot(d, q) > math.hypot(*lim.mtpa_current(0.8 * T_max))
    for share in (1 - 1e-4, 1 - 1e-12):   # the second within the angle scan's resolution of the maximum
        d, q, _ = lim.optimum_current(T_max * share, w)
        assert math.hypot(d - d_max, q - q_max) < 1e-2 * 250.0 and lim.excess(d, q, w) <= 1e-9 * lim.u
    assert lim.optimum_current(T_max * 1.001, w) is None
    assert lim.optimum_current(600.0, 0.0) is None   # beyond MTPA at i_max


def test_table_speeds_are_round_and_reach_the_end():
    for rpm, step in ((6906.0, 800.0), (4556.0, 500.0), (1842.4, 200.0), (31591.0, 3000.0)):
        s = rad_s_to_rpm(table_speeds(rpm_to_rad_s(rpm)))
        assert s[0] == 0.0 and s[-1] == pytest.approx(rpm) and np.allclose(np.diff(s[:-1]), step) and s.size <= 13


def test_the_overmodulation_margin():
    """Minimum-phase-error over-modulation at its limit: the hexagon's
    boundary traced at the reference's angle, its fundamental (6/pi) ln sqrt3
    of the inscribed circle's radius: measured here on the hexagon itself."""
    th = np.linspace(0, math.pi / 3, 200001)[:-1]
    r = 1.0 / np.cos(th - math.pi / 6)   # the boundary's radius, the inscribed circle's 1
    assert OVERMODULATION == pytest.approx(r.mean(), rel=1e-6) and 1.04 < OVERMODULATION < 1.05


def test_an_envelope_outside_the_map_is_refused_with_its_range(tmp_path):
    from fullspeed.model.errors import ConfigError
    m = baldor(tmp_path)
    with pytest.raises(ConfigError, match="within baldor's flux map"):
        envelope(m, 540.0, 24.9)


# --- feasibility warnings ---------------------------------------------------------------------------------------------

def speed_scenario(m, rpm, T, fw=True):
    return scenario_from_dict({"name": "t", "duration": 1.0, "machine": m,
                               "controller": {"mode": "speed", "flux_weakening": fw},
                               "references": {"speed_rpm": [[0.0, 0.0], [0.5, rpm]]},
                               "load": {"torque": [[0.0, 0.0], [0.6, T]]}})


def _mach(m):
    """A designed machine back as the table a scenario takes."""
    d = {"name": m.name, "kind": m.kind, "pole_pairs": m.pole_pairs,
         "magnetic": {k: v for k, v in m.magnetic.items() if v is not None},
         "electrical": {"R_s": m.R_s, "L_d": m.L_d, "L_q": m.L_q, "psi_f": m.psi_f},
         "mechanical": {"J": m.J}, "rated": {"torque": m.T_rated, "current": m.i_rated,
                                             "speed_rpm": rad_s_to_rpm(m.w_m_rated)},
         "bench": {k: m.bench[k] for k in ("u_dc", "f_pwm", "i_max")}}
    return d


def feasibility(sc):
    return [w for w in sc.warnings if w.startswith(("load.torque:", "references."))]


def test_the_trials_infeasible_points_are_warned_with_flux_weakening_on():
    """20000 rpm x 40 N m on the Prius and 9000 rpm x 1.5 N m on the H27
    (accepted before): one line naming the field, the point and the
    envelope's torque there; the points the trial held are not warned."""
    P, H = _mach(prius()), _mach(h27())
    w = feasibility(speed_scenario(P, 20000.0, 40.0))
    T = torque_at(envelope(prius(), 500.0, 250.0, w_end=rpm_to_rad_s(21000.0)), rpm_to_rad_s(20000.0))
    assert len(w) == 1 and w[0].startswith("load.torque: 40 N m at 20000 rpm") and f"at most {T:.4g} N m" in w[0]
    w = feasibility(speed_scenario(H, 9000.0, 1.5))
    assert len(w) == 1 and "1.5 N m at 9000 rpm" in w[0] and "at most 1.127 N m" in w[0]
    assert not feasibility(speed_scenario(P, 5000.0, 40.0)) and not feasibility(speed_scenario(H, 7000.0, 0.6))


def test_the_warning_sits_at_the_envelope():
    """Just inside the envelope's torque at a speed: no line; just outside: one."""
    m = prius()
    T = Limits(m, 500.0, 250.0).best(np.array([m.pole_pairs * rpm_to_rad_s(2500.0)]))[0][0]
    assert not feasibility(speed_scenario(_mach(m), 2500.0, T * (1 - 1e-4)))
    assert len(feasibility(speed_scenario(_mach(m), 2500.0, T * (1 + 1e-4)))) == 1


def test_a_load_beyond_mtpa_at_speed_names_the_envelope_there_too():
    """A load beyond the MTPA torque at i_max, at a speed where flux weakening
    gives far less: the line names both, the smaller being the one the speed
    meets (the new-user trial's Baldor, 60 N m at 3600 rpm, named only the
    51 N m of MTPA)."""
    m = prius()
    lim = Limits(m, 500.0, 250.0)
    T_mtpa = lim.mtpa_locus()["T"][-1]
    T_there = lim.best(np.array([m.pole_pairs * rpm_to_rad_s(4000.0)]))[0][0]
    assert T_there < 0.8 * T_mtpa
    w = feasibility(speed_scenario(_mach(m), 4000.0, 1.1 * T_mtpa))
    assert len(w) == 1 and f"beyond the {T_mtpa:.4g} N m" in w[0] and f"at most {T_there:.4g} N m" in w[0]
    w = feasibility(speed_scenario(_mach(m), 500.0, 1.1 * T_mtpa))   # on MTPA at that speed: MTPA's bound alone
    assert len(w) == 1 and "at most" not in w[0]


def test_a_speed_beyond_a_finite_top_speed_is_named_without_load():
    m = load_machine("motulator-2kw-ipmsm")
    env = envelope(m, 540.0, m.bench["i_max"])
    w = feasibility(speed_scenario("motulator-2kw-ipmsm", 1.05 * rad_s_to_rpm(env.w_top), 0.0))
    assert len(w) == 1 and w[0].startswith("references.speed_rpm:") and "beyond its top speed" in w[0]
    assert f"{rad_s_to_rpm(env.w_top):.5g} rpm" in w[0]
    assert not feasibility(speed_scenario("motulator-2kw-ipmsm", 0.9 * rad_s_to_rpm(env.w_top), 0.0))


def test_without_flux_weakening_the_mtpa_current_meets_the_voltage_limit():
    """Flux weakening off: the drive stays on MTPA; the speed where the MTPA
    current for the load meets the voltage limit bounds the reference."""
    m = prius()
    lim = Limits(m, 500.0, 250.0)
    n = rad_s_to_rpm(lim.mtpa_speed(100.0) / m.pole_pairs)
    assert n == pytest.approx(rad_s_to_rpm(lim.w_limit(*lim.mtpa_current(100.0)) / 4), rel=2e-4)
    w = feasibility(speed_scenario(_mach(m), 1.01 * n, 100.0, fw=False))
    assert len(w) == 1 and w[0].startswith("references.speed_rpm:") and "without flux weakening" in w[0]
    assert f"{n:.5g} rpm" in w[0] and "with flux weakening the envelope gives" in w[0]
    assert not feasibility(speed_scenario(_mach(m), 0.99 * n, 100.0, fw=False))


def test_a_current_reference_beyond_the_voltage_is_named():
    """Current mode against a speed-holding load: the voltage the current
    reference needs at the load's speed."""
    d = {"name": "t", "duration": 0.3, "machine": "motulator-2kw-ipmsm", "controller": {"mode": "current"},
         "references": {"i_q": 8.0}, "load": {"kind": "speed", "speed_rpm": 3000.0}}
    w = [x for x in scenario_from_dict(d).warnings if x.startswith("references.i_q:")]
    assert len(w) == 1 and "needs" in w[0] and "3000 rpm" in w[0]
    d["load"]["speed_rpm"] = 1000.0
    assert not [x for x in scenario_from_dict(d).warnings if x.startswith("references.i_q:")]


def test_a_matrix_converter_is_held_to_its_modulations_voltage():
    """zou2021's scenarios run on the IMC's over-modulation regions: each
    is checked against the VTR its modulation reaches, and none is warned;
    in the linear region Region C's 1750 rpm at 10 N m is outside."""
    from fullspeed.design.scenario import load_scenario
    for name in ("zou2021-region-a", "zou2021-region-b", "zou2021-region-c", "zou2021-speed-range"):
        assert not feasibility(load_scenario(name)), name
    w = feasibility(load_scenario("zou2021-region-c", {"converter": {"modulation": "linear"}}))
    assert len(w) == 1 and "linear modulation" in w[0]


# --- the command line ------------------------------------------------------------------------------------------------------

def test_design_prints_the_envelope_and_writes_its_figure(tmp_path):
    out = tmp_path / "o"
    p = subprocess.run([sys.executable, "-m", "fullspeed", "design", "motulator-2kw-ipmsm", "--out", str(out)],
                       capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    text = p.stdout
    for what in ("base speed", "characteristic current", "top speed", "T_max N m", "P_max kW"):
        assert what in text, what
    def numbers(ln):   # the envelope table's rows: five numbers and the limit (not prose that wraps onto a number)
        try:
            return [float(x) for x in ln.split()[:5]] if len(ln.split()) >= 6 else None
        except ValueError:
            return None
    rows = [ln.split() for ln in text.splitlines() if ln.startswith("  ") and numbers(ln)]
    assert len(rows) >= 11 and float(rows[0][0]) == 0.0 and float(rows[-1][1]) == 0.0
    assert {r[5] for r in rows} == {"current", "current+voltage"}
    assert (out / "envelope.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the default folder: out/<name> where it runs
    p = subprocess.run([sys.executable, "-m", "fullspeed", "design", "zou2021-region-c"],
                       capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert p.returncode == 0 and (tmp_path / "out" / "zou2021-region-c" / "envelope.png").is_file(), p.stderr
    assert "matrix converter's om2 modulation" in p.stdout
    (tmp_path / "afile").write_text("")
    p = subprocess.run([sys.executable, "-m", "fullspeed", "design", "yang2022", "--out", str(tmp_path / "afile")],
                       capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert p.returncode == 2 and "--out" in p.stderr


def test_the_report_says_where_mtpv_lies_beyond_the_table():
    """SyR-e's THOR: its characteristic current lies within i_max (top speed
    infinite), and its MTPV onset beyond the table's last speed, where the
    report read w_mtpv (None) and `fullspeed design syre-thor` stopped with
    an internal error after printing its settings."""
    d = {"name": "thor-envelope", "machine": "syre-thor", "duration": 1.0,
         "controller": {"mode": "speed", "angle": "encoder", "flux_weakening": True}}
    env, how = scenario_envelope(scenario_from_dict(d, "thor", warn=False))
    assert not env.top_finite and env.w_mtpv is None
    text = envelope_report(env, how)
    assert f"beyond the table's last speed, {rad_s_to_rpm(env.w_m[-1]):.0f} rpm, MTPV" in text
