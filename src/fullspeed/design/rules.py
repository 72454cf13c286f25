"""Designed defaults: every setting of a sensorless drive that can be
designed from what a datasheet gives (the machine's electrical, mechanical
and rated values), the converter (u_dc, f_pwm, sampling, dead time) and the
sensors (ADC bits and range, noise), each with its reason.

The machine file's [bench], [injection] and [blending] fields and the
scenario's [controller], [injection], [observer] and [blending] fields
override what is designed here; the catalog machines state theirs. The
gains themselves are designed in C from these bandwidths (fs_drive_init),
so the simulation and the firmware export get the same ones.

Rules, in the order they depend on each other (Ts the sampling period,
f_s = 1/Ts):

- i_max = 1.5 i_rated, i_trip = 1.25 i_max, adc_range = 1.2 i_trip;
- bw_current = 2 pi f_s / 20: one period of computation delay and the PWM
  hold (1.5 Ts) cost 27 deg of phase at crossover, leaving about 63 deg;
- the carrier f_h = f_s / 10: ten samples a period (the SRFFs need them),
  and twice the current loop's bandwidth, so the loop neither follows the
  carrier nor puts its own response into the carrier's band; higher where
  the current loop (a given bw_current) would act on the negative carrier's
  sidebands, which carry the angle (carrier_loop_action);
- the blending band from the voltage errors the back-EMF observer cannot
  tell from the EMF (the resistance known to 20 %, at rated current, and
  half the dead time's voltage left by its compensation near zero current):
  lower where the EMF is 1.5 times that, at least 5 % and at most 30 % of
  rated speed; upper 1.6 x lower (yang2022's band, 160..260 rpm, has that
  ratio); and the carrier at least 10 times the electrical frequency at the
  upper edge (its speed range);
- u_h: the smallest carrier whose negative-sequence current, eq. (24), is
  35 ADC steps (yang2022's 1.70 A on a 49 mA step), 10 noise deviations
  and 2 % of i_max, at most what leaves the fundamental its voltage at the
  upper blending speed and i_max (0.85 of the linear limit in all) and a
  carrier current peak of 20 % of i_max;
- the observer's PLL at 3 times the electrical speed of the lower band edge
  (it must follow the angle there), within the larger of 6 bw_speed and
  what holds an unknown step of the rated torque within 5 el.deg
  (pll_for_load_step) .. bw_current / 10;
- bw_speed = bw_current / 30, the encoder PLL at 2 pi x that (its double
  pole lags 18 deg at the speed loop's crossover);
- the overspeed stop at 1.2 x the fastest the drive is designed for (the
  observer's and flux weakening's top speed) or the scenario asks (its
  references, the load's speed, the initial speed).
"""
from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

from .._core import ffi, lib
from ..model.fluxmap import table_at
from ..model.units import rad_s_to_rpm

# The design targets, each with its reason (printed by `fullspeed design`).
I_MAX_PER_RATED = 1.5        # the usual short-time overload of an industrial drive; room for the carrier and acceleration under rated load
I_TRIP_PER_MAX = 1.25        # covers the carrier's current peak and the current loop's overshoot above i_max
ADC_RANGE_PER_TRIP = 1.2     # the trip level stays inside the converter's range
BW_CURRENT_PER_FS = 2 * math.pi / 20
CARRIER_PER_FS = 0.1
BW_SPEED_PER_CURRENT = 1 / 30
R_S_UNCERTAINTY = 0.2        # the resistance is known to 20 % (temperature: 0.4 %/K over 50 K)
DEAD_TIME_RESIDUE = 0.5      # the compensation leaves about half the dead time's voltage near zero current
EMF_PER_ERROR_LOWER = 1.5    # at the band's lower edge the EMF is 1.5 x the voltage error: angle error below about 40 deg where the observer's weight is still small
BAND_RATIO = 1.6             # upper / lower: yang2022's 260 / 160 rpm
BAND_MIN, BAND_MAX = 0.05, 0.30   # of rated speed
CARRIER_PER_W_E = 10         # the carrier stays 10 x the electrical frequency in the injection's speed range
I_N_LSB = 35                 # the negative-sequence current spans 35 ADC steps (yang2022: 1.70 A on 49 mA)
I_N_NOISE = 10               # and 10 noise deviations
I_N_PER_I_MAX = 0.02         # and 2 % of i_max (ideal sensors)
U_H_SHARE = 0.85             # carrier and fundamental within 85 % of the linear limit
I_HF_PER_I_MAX = 0.2         # the carrier current's peak, I_p + I_n, at most 20 % of i_max
# Where the fundamental at the band's top and i_max leaves no voltage (a machine whose base speed at i_max is
# below the band's top, as the 2004 Prius MG2 with its unsaturated L_q: 265 V of 245 V at 405 rpm and 250 A) the
# carrier takes its wanted amplitude from the fundamental there, at most half the shared voltage: the torque at
# the band's top while injecting is then the envelope's at the voltage left (the planned flux weakening keeps the
# carrier's room, fs_drive.c), and the fundamental keeps at least half the voltage
U_H_TAKEN_MAX = 0.5
PLL_PER_W_E_LOWER = 3
# The back-EMF tracker's bandwidth at least what holds an unknown step of the rated torque within this angle
# (pll_for_load_step): half the 10 el.deg B-REAL allows after a step. SyR-e's THOR (J = 0.0042 kg m^2) at
# 150.8 rad/s (6 bw_speed) lost the rotor at its load step at 1.5 x base speed at 5 of 6 initial angles
LOAD_STEP_ANGLE = math.radians(5.0)
# el.deg: the span of a cross-saturation table (twice its largest lead) up to which the blend's observer is still
# raised for a load ramp (design.scenario's _blend_for_load_ramp): the lag that raise is designed to leave
XCOMP_SPAN_FOR_RAMP = math.degrees(LOAD_STEP_ANGLE)


def xcomp_span_deg(table: dict | None) -> float:
    """A cross-saturation table's span, el.deg: twice its largest lead (the table is odd in i_q); 0 without one."""
    return 2.0 * max(abs(x) for x in table["delta_deg"]) if table else 0.0
# The current loop's action on the negative carrier's sidebands (carrier_loop_action) at most this: the
# designed point (bw_current 2 pi f_s / 20 against f_s / 10, 1.5 Ts of delay) gives 0.63..0.66 on the
# yang2022 machine, whose full range (B-FULLRANGE) keeps 5.9 el.deg there; at 0.85..0.93 (20 kHz with
# bw_current 3000 rad/s, or 10 kHz with 4000, both against its 1 kHz carrier) the error at standstill
# under rated load grows to 9..15 el.deg, and from 0.99 up the injection's loop cycles at 35 Hz
# (20 kHz with 3500 or 4000 rad/s, 40 kHz with 3000, 10 kHz with 5000: +-20..45 el.deg)
CARRIER_LOOP_ACTION_MAX = 0.8
# A load that changes over this long or longer is a ramp the estimate must follow as it rises
# (observer_for_load_ramp); a faster change is a step, which the runs' metrics forgive for the 50 ms after it
# (sim.metrics.sensorless_error_max) and pll_for_load_step bounds
LOAD_RAMP_MIN = 0.05
# The overspeed stop (csrc/control/fs_drive_protect.h) over the fastest the drive is designed for or asked: a
# speed loop's overshoot on a step (5-15 %) and a reversal's stay below it; a rotor 20 % past that is a runaway
# (an active load overhauling the drive, a loss the monitor has not flagged yet) whose back-EMF outgrows what
# the observer's gain, flux weakening's d current and the link were designed for
OVERSPEED_PER_TOP = 1.2


@dataclass(frozen=True)
class Value:
    """One designed (or given) setting."""
    value: float
    unit: str
    reason: str
    given: bool = False      # taken from the machine file or the scenario, not designed


def sampling_period(f_pwm: float, sampling: str) -> float:
    return (0.5 if sampling == "double" else 1.0) / f_pwm


def control_period(d: dict) -> float:
    """A scenario's control period: the PWM period, or half of it with double sampling."""
    return sampling_period(d["converter"]["f_pwm"], d["timing"]["sampling"])


def u_linear(u_dc: float, phases: int) -> float:
    """The modulator's linear limit (peak phase voltage)."""
    return u_dc / (2 * math.cos(math.pi / 10)) if phases == 5 else u_dc / math.sqrt(3)


def design_bench(m, b: dict, i_max_map: float | None = None) -> dict[str, Value]:
    """The bench's limits and bandwidths from the machine and its converter
    (b: the machine's [bench] as given; None where left out). i_max_map: the
    largest current limit the machine's flux map covers (fluxmap.coverage_limit);
    a designed i_max is held to it (beyond, the plant would extrapolate the map)."""
    out: dict[str, Value] = {}

    def put(key, value, unit, reason):
        given = b.get(key) is not None
        out[key] = Value(float(b[key]) if given else value, unit, "given in the machine file" if given else reason, given)
        return out[key].value

    Ts = sampling_period(b["f_pwm"], b["sampling"])
    i_rule = I_MAX_PER_RATED * m["i_rated"]
    if i_max_map is not None and i_rule > i_max_map:
        i_max = put("i_max", i_max_map, "A", f"held to the {i_max_map:g} A its flux map covers (i_q over +-i_max, i_d from -i_max "
                    f"to i_max/2), below {I_MAX_PER_RATED:g} x the rated current ({i_rule:g} A): beyond it the plant would extrapolate the map")
    else:
        i_max = put("i_max", i_rule, "A",
                    f"{I_MAX_PER_RATED:g} x the rated current: the usual short-time overload, room for the carrier and for accelerating under rated load")
    i_trip = put("i_trip", I_TRIP_PER_MAX * i_max, "A",
                 f"{I_TRIP_PER_MAX:g} x i_max: above the carrier's peak and the current loop's overshoot")
    put("adc_range", ADC_RANGE_PER_TRIP * i_trip, "A", f"{ADC_RANGE_PER_TRIP:g} x i_trip: the trip level inside the converter's range")
    bw_c = put("bw_current", BW_CURRENT_PER_FS / Ts, "rad/s",
               f"2 pi f_s / 20 at f_s = {1 / Ts:g} Hz: 1.5 Ts of delay (computation and PWM hold) costs 27 deg at crossover, about 63 deg of phase margin left")
    bw_s = put("bw_speed", BW_SPEED_PER_CURRENT * bw_c, "rad/s", "bw_current / 30: the speed loop well inside the current loop")
    put("bw_pll", 2 * math.pi * bw_s, "rad/s", "2 pi bw_speed: the encoder PLL's double pole lags 18 deg at the speed loop's crossover")
    return out


def design_overspeed(speeds: dict[str, float]) -> Value:
    """The overspeed stop, rpm: OVERSPEED_PER_TOP x the fastest of the speeds
    (name: rpm) the drive is designed for or asked."""
    name, top = max(speeds.items(), key=lambda kv: abs(kv[1]))
    return Value(OVERSPEED_PER_TOP * abs(top), "rpm",
                 f"{OVERSPEED_PER_TOP:g} x the fastest the drive is designed for or asked ({name}, {abs(top):.5g} rpm): "
                 "a step's overshoot stays below it; a rotor beyond it is a runaway (an active load overhauling the "
                 "drive, a loss not yet flagged), whose back-EMF outgrows what the observer, flux weakening and the "
                 "link were designed for")


def voltage_error(m, b: dict) -> float:
    """The voltage the back-EMF observer cannot tell from the EMF, V: the
    resistance's uncertainty at rated current and the dead time's residue."""
    return R_S_UNCERTAINTY * m["R_s"] * m["i_rated"] + DEAD_TIME_RESIDUE * b["t_dead"] * b["f_pwm"] * b["u_dc"]


def design_band(m, b: dict, f_h: float) -> dict[str, Value]:
    """The blending band, mechanical rpm (yang2022 eq. (28))."""
    p, w_rated = m["pole_pairs"], m["w_m_rated"]
    e_err = voltage_error(m, b)
    w_m_emf = EMF_PER_ERROR_LOWER * e_err / m["psi_f"] / p if m["psi_f"] > 0 else math.inf
    lo = min(max(w_m_emf, BAND_MIN * w_rated), BAND_MAX * w_rated)
    why = (f"the EMF is {EMF_PER_ERROR_LOWER:g} x the voltage error ({e_err:.3g} V: R_s known to {R_S_UNCERTAINTY:.0%} at rated current, "
           f"and half the dead time's voltage)")
    if lo > w_m_emf:
        why = f"{BAND_MIN:.0%} of rated speed (where {why.replace('the EMF is', 'the EMF would be')} is lower)"
    elif lo < w_m_emf:
        why = f"{BAND_MAX:.0%} of rated speed, capped ({why} only at {rad_s_to_rpm(w_m_emf):.4g} rpm)"
    # the carrier follows the rotor up to the band's upper edge
    w_m_carrier = 2 * math.pi * f_h / CARRIER_PER_W_E / p
    hi = BAND_RATIO * lo
    why_hi = f"{BAND_RATIO:g} x lower (yang2022's 260 / 160 rpm)"
    if hi > w_m_carrier:
        hi = w_m_carrier
        why_hi = f"the carrier's speed range: f_h / {CARRIER_PER_W_E} electrical ({BAND_RATIO:g} x lower would be above it)"
        lo = min(lo, hi / BAND_RATIO)
    return {"lower_rpm": Value(rad_s_to_rpm(lo), "rpm", why), "upper_rpm": Value(rad_s_to_rpm(hi), "rpm", why_hi)}


def carrier_currents(u_h: float, w_h: float, L_d: float, L_q: float) -> tuple[float, float]:
    """The positive- and negative-sequence carrier currents I_p, I_n of a
    rotating carrier u_h at w_h (yang2022 eq. (24)), A."""
    S, D = 0.5 * (L_d + L_q), 0.5 * (L_q - L_d)
    den = w_h * (S * S - D * D)
    return u_h * S / den, u_h * abs(D) / den


def fundamental_voltage(m, w_m: float, i: float) -> float:
    """The fundamental's voltage at a mechanical speed and a q current, V
    peak: a flux map's fluxes at that current where the machine has one (a
    saturated L_q: the 2004 Prius MG2 needs 150 V at 405 rpm and 250 A on
    its map, 265 V with its unsaturated L_q)."""
    w_e = m["pole_pairs"] * w_m
    if m.get("flux") is not None:
        psi_d, psi_q = m["flux"](0.0, i)
        return math.hypot(m["R_s"] * i + w_e * psi_d, w_e * psi_q)
    return math.hypot(m["R_s"] * i + w_e * m["psi_f"], w_e * m["L_q"] * i)


def design_injection(m, b: dict, i_max: float, w_m_upper: float, carrier: Value) -> dict[str, Value]:
    """The rotating carrier: frequency (design_carrier's) and amplitude."""
    Ts = sampling_period(b["f_pwm"], b["sampling"])
    f_h = carrier.value
    w_h = 2 * math.pi * f_h
    L_d, L_q = m.get("L_d_hf", m["L_d"]), m.get("L_q_hf", m["L_q"])   # what the carrier sees
    _, i_n_per_v = carrier_currents(1.0, w_h, L_d, L_q)
    i_p_per_v = sum(carrier_currents(1.0, w_h, L_d, L_q))
    lsb = 2 * b["adc_range"] / 2 ** b["adc_bits"] if b["adc_bits"] else 0.0
    targets = {f"{I_N_LSB} ADC steps": I_N_LSB * lsb, f"{I_N_NOISE} noise deviations": I_N_NOISE * b["noise_i"],
               f"{I_N_PER_I_MAX:.0%} of i_max": I_N_PER_I_MAX * i_max}
    what, i_n = max(targets.items(), key=lambda kv: kv[1])
    u_want = i_n / i_n_per_v if i_n_per_v > 0 else math.inf
    # the held carrier (zero-order hold: / sinc) beside the fundamental at the band's top, and its current
    sinc = math.sin(math.pi * f_h * Ts) / (math.pi * f_h * Ts)
    u_share, u_f = U_H_SHARE * u_linear(b["u_dc"], m["phases"]), fundamental_voltage(m, w_m_upper, i_max)
    u_room = (u_share - u_f) * sinc
    u_cur = I_HF_PER_I_MAX * i_max / i_p_per_v
    u_h = min(u_want, u_room, u_cur)
    if u_room <= 0.0:   # no room at i_max: the carrier takes its voltage from the fundamental's torque there
        u_h = min(u_want, u_cur, U_H_TAKEN_MAX * u_share * sinc)
        held = "its negative-sequence current I_n = {:.3g} A, {}".format(u_h * i_n_per_v, what if u_h == u_want else
                                                                         f"below the wanted {what} ({i_n:.3g} A)")
        short = (f"the fundamental at the upper blending speed ({rad_s_to_rpm(w_m_upper):.4g} rpm) and i_max needs "
                 f"{u_f:.4g} V of the {u_share:.4g} V the link leaves carrier and fundamental")
        return {"f_h": carrier, "u_h": Value(u_h, "V", f"taken from the fundamental: {short}; {held}"),
                "u_taken": Value(u_h / sinc, "V", short)}
    if u_h == u_want:
        why = f"its negative-sequence current I_n = {i_n:.3g} A is {what}, eq. (24)"
    else:
        limit = "the voltage left beside the fundamental at the upper blending speed and i_max" if u_h == u_room \
            else f"the carrier current's peak at {I_HF_PER_I_MAX:.0%} of i_max"
        why = (f"held by {limit}; I_n = {u_h * i_n_per_v:.3g} A, below the wanted {what} ({i_n:.3g} A): "
               "the injection's angle will be noisier than designed")
    return {"f_h": carrier, "u_h": Value(max(u_h, 0.0), "V", why)}


def carrier_loop_action(Ts: float, delay: bool, bw_current: float, w_h: float, L: float, R: float,
                        w_b: float | None = None) -> float:
    """How much the current loop changes the negative carrier's sidebands, the
    largest |i_closed / i_open - 1| within w_b of -w_h (standstill).

    The angle reaches the estimator as the negative carrier's modulation: its
    sidebands at -w_h +- Delta, Delta up to the filters' band w_b (w_h / 20,
    fs_hfi.h), which the injection's observer (as fast as w_b with tracking =
    "lag") follows. The current loop works on the fundamental the two SRFFs
    leave (fs_hfi_filter.h), whose stop bands are only w_b wide: at the
    carrier itself it sees nothing, at Delta = w_b already 0.7 of the
    sideband, and it answers with its loop gain there, about 2 bw_current /
    w_h turned by the computation delay. The closed loop's sidebands are the
    open loop's / (1 + L F); what that changes (gain and phase) enters the
    injection's loop beside its own filter lag. It grows with bw_current / w_h
    and with less delay per carrier period (more samples a period: 20 kHz
    leaves the loop a 1 kHz carrier's sidebands less turned by its delay than
    10 kHz, and it damps them instead). The sampled loop as fs_drive builds
    it: the 2DOF PI of fs_pi_design on L di/dt = u - R i, the one-step
    predictor with the computation delay (fs_current_ctrl.h), the SRFFs'
    discretisation (fs_srff.h)."""
    pi = ffi.new("fs_pi_config *")   # the current PI's gains as fs_drive_init designs them (fs_pi_design)
    if lib.fs_pi_design(pi, Ts, L, R, bw_current, 0.0) != lib.FS_OK:
        return math.inf   # no such loop (bandwidth beyond 2 / Ts): as far from acceptable as it gets
    k_p, k_i = pi.k_p, pi.k_i
    a = math.exp(-R * Ts / L)
    b = (1.0 - a) / R if R > 0 and a < 1.0 else Ts / L   # the plant's sampled step response
    w_b = w_h / 20.0 if w_b is None else w_b
    a_f = math.exp(-w_b * Ts)
    g = 0.5 * (1.0 + a_f)
    worst = 0.0
    for k in range(-20, 21):
        z = cmath.exp(1j * (-w_h + w_b * k / 20.0) * Ts)
        F = 1.0
        for c in (cmath.exp(1j * w_h * Ts), cmath.exp(-1j * w_h * Ts)):   # the SRFFs at +w_h and -w_h
            F *= g * (z - c) / (z - a_f * c)
        K = k_p + k_i * Ts / (z - 1.0)
        # with the delay the voltage acts from the next sample and the PI works on the predicted current
        loop = K * a * F * b / (z * (1.0 + K * b / z) * (z - a)) if delay else K * F * b / (z - a)
        worst = max(worst, abs(1.0 / (1.0 + loop) - 1.0))
    return worst


def design_carrier(m, b: dict, bw_current: float | None, delay: bool = True) -> Value:
    """The rotating carrier's frequency: f_s / 10, or f_s / n with fewer
    samples a period, n down to 5, where the current loop would act on its
    sidebands (carrier_loop_action); a whole number of samples a period, as
    the i_q average over one (fs_hfi.h) takes. bw_current None: gains not
    designed from it (the paper's, the internal model's), f_s / 10."""
    f_s = 1.0 / sampling_period(b["f_pwm"], b["sampling"])
    n0 = round(1 / CARRIER_PER_FS)
    why = f"f_s / {n0}: ten samples a carrier period, twice the current loop's bandwidth"
    if bw_current is None:
        return Value(f_s / n0, "Hz", why)

    def action(n):
        return max(carrier_loop_action(1 / f_s, delay, bw_current, 2 * math.pi * f_s / n, L, m["R_s"])
                   for L in (m["L_d"], m["L_q"]))
    n = n0
    while n > 5 and action(n) > CARRIER_LOOP_ACTION_MAX:
        n -= 1
    if n == n0:
        return Value(f_s / n0, "Hz", why)
    return Value(f_s / n, "Hz", f"f_s / {n}: at f_s / {n0} bw_current = {bw_current:.4g} rad/s would act on the carrier's "
                 f"sidebands by {action(n0):.2f} (at most {CARRIER_LOOP_ACTION_MAX:g}, carrier_loop_action), here {action(n):.2f}")


def machine_values(m) -> dict:
    """The datasheet quantities the rules use, from a Machine; with a flux
    map also its fluxes (flux(i_d, i_q) -> (psi_d, psi_q), Wb) and the
    incremental inductances a carrier sees (L_d_hf, L_q_hf:
    design.machine.map_model)."""
    out = {"pole_pairs": m.pole_pairs, "phases": m.phases, "R_s": m.R_s, "L_d": m.L_d, "L_q": m.L_q,
           "psi_f": m.psi_f, "J": m.J, "i_rated": m.i_rated, "w_m_rated": m.w_m_rated, "T_rated": m.T_rated}
    if m.magnetic["model"] == "fluxmap" and "map.L_d_hf" in m.design:
        mag = m.magnetic
        out.update(psi_f=m.design["map.psi_f"].value, L_d_hf=m.design["map.L_d_hf"].value, L_q_hf=m.design["map.L_q_hf"].value,
                   flux=lambda i_d, i_q: (table_at(mag, "psi_d", i_d, i_q), table_at(mag, "psi_q", i_d, i_q)))
    return out


def load_ramp_lag(pole_pairs: int, J: float, dT_dt: float, w_o: float) -> float:
    """The steady lag (el. rad) of a motion observer at w_o behind an unknown
    load ramp dT/dt (N m/s). Its triple pole (fs_motion_obs) takes a ramp of
    unmodelled acceleration, r = p (dT/dt) / J a second, as
    e(s) = r / (s (s + w_o)^3): r / w_o^3. The rotor's own inertia only, as
    pll_for_load_step."""
    return pole_pairs * dT_dt / (J * w_o ** 3)


def observer_for_load_ramp(pole_pairs: int, J: float, dT_dt: float) -> float:
    """The motion observer's bandwidth (rad/s) whose load_ramp_lag is
    LOAD_STEP_ANGLE."""
    return (pole_pairs * dT_dt / (J * LOAD_STEP_ANGLE)) ** (1.0 / 3.0)


def load_ramp_for_observer(pole_pairs: int, J: float, w_o: float) -> float:
    """The steepest unknown load ramp (N m/s) whose load_ramp_lag at w_o is
    LOAD_STEP_ANGLE."""
    return LOAD_STEP_ANGLE * J * w_o ** 3 / pole_pairs


def load_ramp_max(profile) -> float:
    """The steepest ramp (N m/s) of a load torque profile, a constant or
    (times, values) as parsed, over its segments that last LOAD_RAMP_MIN or
    longer; 0 for a constant or steps only."""
    if not isinstance(profile, tuple):
        return 0.0
    t, y = profile
    return max((abs(y1 - y0) / (t1 - t0) for t0, t1, y0, y1 in zip(t, t[1:], y, y[1:]) if t1 - t0 >= LOAD_RAMP_MIN),
               default=0.0)


def pll_for_load_step(m) -> float:
    """The tracker's bandwidth that holds an unknown step of the rated
    torque within LOAD_STEP_ANGLE, rad/s. Its triple pole at w_o (fs_motion_obs)
    takes a step a = p T / J of unmodelled acceleration as e(s) = a / (s + w_o)^3:
    e(t) = a t^2 exp(-w_o t) / 2, largest at t = 2 / w_o, 2 exp(-2) a / w_o^2.
    The rotor's own inertia only: a load's adds to J and shrinks the error."""
    a = m["pole_pairs"] * m["T_rated"] / m["J"]
    return math.sqrt(2.0 * math.exp(-2.0) * a / LOAD_STEP_ANGLE)


def design_observer_pll(m, w_m_lower: float, bw_speed: float, bw_current: float) -> Value:
    """The back-EMF observer's PLL double pole (yang2022 eq. (13))."""
    w = PLL_PER_W_E_LOWER * m["pole_pairs"] * w_m_lower
    w_load = pll_for_load_step(m)
    lo, hi = max(6 * bw_speed, w_load), bw_current / 10
    v = min(max(w, lo), hi)
    why = f"{PLL_PER_W_E_LOWER} x the electrical speed at the lower blending edge: it follows the angle there"
    if v > w and w_load > 6 * bw_speed:
        why = (f"an unknown step of the rated torque ({m['T_rated']:.4g} N m on J = {m['J']:.4g} kg m^2) "
               f"costs at most {math.degrees(LOAD_STEP_ANGLE):g} el.deg")
    elif v > w:
        why = "6 bw_speed: its lag stays small at the speed loop's crossover"
    if v < max(w, lo):
        why = "bw_current / 10: well inside the current loop"
    return Value(v, "rad/s", why)
