"""What a scenario asks, said out loud when it is loaded: one warning line
per finding, each naming the field. Not errors: the run may be what the
user wants (a machine at its limit, a test of a refusal); the command line
prints them before it runs, and the run's summary names the idealised
hardware.

- feasibility: a speed reference, with the load it turns against, outside
  the machine's envelope (design.envelope: MTPA, flux weakening and MTPV
  within the current limit and the converter's voltage), or beyond where
  the MTPA current meets the voltage limit without flux weakening; a
  current reference whose voltage at the load's speed exceeds the limit;
- plausibility: parameters far outside what machines have (time constants,
  the back-EMF at rated speed against the rated voltage or the link, the
  torque at rated current with its reluctance part against the rated
  torque, the rated speed against the rated power or the voltage limit,
  copper losses), which are unit and definition mistakes more often than
  machines (H for mH, kg m^2 for g m^2, poles for pole pairs, psi_f from a
  line-to-line Ke, the rated current as rms, the rated speed in rad/s, the
  power in kW), each line naming the field and the likely mistake;
- the speed loop against the observer whose speed it takes (a given
  controller.bw_speed above what design.scenario allows it);
- polarity pulses on a machine without the d-axis saturation asymmetry
  they measure (linear magnetics), pulses larger than the rotor and the
  current loop tolerate (design.start), or a load that turns the rotor while
  the pulses make no torque (fs_polarity.h): the drive will refuse to start
  sensorless, or trip; an injection start on a saliency below the
  injection's resolution (design.start).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._core import lib
from ..model.errors import ConfigError
from ..model.units import rad_s_to_rpm, rpm_to_rad_s
from .controller import controller_model, hfi_design, injection_inductances
from .envelope import I_MAX_FIELD, OVERMODULATION, Limits, limits
from .machine import mtpa_torque
from .magnetics import mtpa_locus, saliency_warnings
from .rules import (CARRIER_LOOP_ACTION_MAX, LOAD_STEP_ANGLE, XCOMP_SPAN_FOR_RAMP, carrier_loop_action, control_period,
                    load_ramp_lag, load_ramp_max, u_linear, xcomp_span_deg)
from .start import POLARITY_LOAD, RESOLUTION_MIN, largest_on, polarity_blind

# The bands of plausibility, each with its reason.
TAU_E = (1e-5, 1.0)      # s, L_d / R_s: 10 us (a few-mH machine with a large R) .. 1 s (large machines reach 0.1 s)
TAU_M = (1e-3, 20.0)     # s, J w_rated / T_rated: the time to rated speed at rated torque
EMF_PER_LINK = 2.0       # the back-EMF at rated speed may exceed the link (flux weakening), not by 2x
# The back-EMF at rated speed against the rated (terminal) voltage, where the machine gives it: the terminal
# voltage carries the EMF and the current's drops (catalog: 0.69..1.04); above 1.3 the magnet flux alone would
# need flux weakening cancelling a quarter of it at rated speed: twice the pole pairs or a line-to-line Ke's
# psi_f (x sqrt 3) put a machine from 0.65 or 0.75 there
EMF_PER_RATED_VOLTAGE = 1.3
K_T_MAGNET = 0.5         # 1.5 p psi_f i_rated / T_rated: the magnet alone below half the rated torque is a current given as rms or a small psi_f
# The torque at rated current on MTPA, 1.5 p (psi_f i_q + (L_d - L_q) i_d i_q) (a flux map's own), against the
# rated torque. Below 0.7 the machine cannot make its rating (the zoo's, which draws the magnet's share at
# 0.8..1, reaches 0.81). Above 2.4 it makes far more than its rating, beyond what saturation explains with the
# small-signal inductances a datasheet gives: zou2021's 1.92, the Prius MG2's published 2.26 / 6.15 mH at its
# 250 A (2.26 x its 400 N m; its flux map 1.21 x); twice the pole pairs doubles it (Prius 4.52), a line-to-line
# Ke's psi_f (x sqrt 3) raises it to 2.60 there
K_T_TOTAL = (0.7, 2.4)
# The same on a flux map, whose torque is the machine's own, saturation in it: the published maps give 0.76
# (hefei-h27) .. 1.22 (prius2004-mg2). Above 1.6 the rated current is not the rated torque's: a short-time
# current given as the rated one, or twice the pole pairs (the Baldor PM-SyRM's map: 1.05, with 4 pairs for its
# 2: 2.10; SyR-e's THOR 1.00 -> 1.99), which on a reluctance machine the back-EMF check cannot see (its magnet
# flux is small)
K_T_MAP = (0.7, 1.6)
# The rated speed over the speed at which the rated current on MTPA meets the voltage limit (its base speed):
# the catalog's 0.58 (grin-all-axle-5t) .. 2.04 (hefei-h27, rated deep in flux weakening); a machine whose
# rated speed leaves it more than three quarters of its voltage unused is a speed given in rad/s (the catalog's
# then at 0.06..0.21) or krpm more often than a machine
RATED_SPEED_MIN = 0.25
# The rated power over T_rated w_rated, where the machine gives it: the catalog's 0.99..1.27 (the power at
# base speed, or above it in flux weakening); a speed in rad/s puts it at x 9.55, a power in kW at / 1000
POWER_PER_TW = (0.3, 3.0)
PEAK_PER_RATED = 3.0     # the current limit over the rated current: machines' peak ratings seldom pass 3 (the windings'
                         # heating, the magnets' demagnetisation; the catalog 1..2, the zoo 1.5)
COPPER = 0.5             # copper losses at rated current, of rated power: small low-voltage machines reach 0.4 (yang2022: 0.41 at its 40 A rms)
# psi_f (Wb, peak phase flux linkage) from a datasheet's Ke (V per 1000 rpm, line-to-line rms), as the
# machine template says it (model.reference.machine_template)
KE_TO_PSI_F = "psi_f = Ke sqrt(2) / sqrt(3) / (p 2 pi 1000 / 60)"


def top_speed(m, u: float, T: float, i_d: float = 0.0) -> float:
    """The mechanical speed (rad/s) at which the voltage reaches u with the
    q current for torque T and a given i_d, in steady state (linear
    magnetics): zou2021's analytic limits, whose i_d is fixed by the
    strategy (0, or on a current circle). What a machine can reach at its
    best current is its envelope (design.envelope)."""
    k = 0.5 * m.phases * m.pole_pairs
    i_q = abs(T) / (k * (m.psi_f + (m.L_d - m.L_q) * i_d)) if m.psi_f + (m.L_d - m.L_q) * i_d > 0 else math.inf
    if not math.isfinite(i_q):
        return 0.0
    # (R i_q + w psi_d)^2 + (w L_q i_q - R i_d)^2 = u^2, psi_d = psi_f + L_d i_d: a quadratic in w
    psi_d = m.psi_f + m.L_d * i_d
    a = psi_d ** 2 + (m.L_q * i_q) ** 2
    b = 2 * (m.R_s * i_q * psi_d - m.L_q * i_q * m.R_s * i_d)
    c = (m.R_s * i_q) ** 2 + (m.R_s * i_d) ** 2 - u ** 2
    disc = b * b - 4 * a * c
    if a <= 0 or disc < 0:
        return 0.0
    return max((-b + math.sqrt(disc)) / (2 * a), 0.0) / m.pole_pairs


def inertia_implausible(m) -> str | None:
    """Where the machine's J gives an implausible time to rated speed at
    rated torque (TAU_M): what it gives, for a line that names J as a
    cause; None where it is plausible or cannot be judged."""
    if not (m.T_rated > 0 and m.w_m_rated > 0):
        return None
    tau_m = m.J * m.w_m_rated / m.T_rated
    if TAU_M[0] <= tau_m <= TAU_M[1]:
        return None
    return (f"J = {m.J:.3g} kg m^2 gives J w_rated / T_rated = {tau_m:.3g} s to rated speed at rated torque, outside "
            f"{TAU_M[0]:g}..{TAU_M[1]:g} s: check J's unit (kg m^2)")


def plausibility_warnings(d: dict, m) -> list[str]:
    """The machine's data against what machines have (time constants, the
    back-EMF, the torque and the rated speed against their ratings, the
    copper losses), each line naming the field and the likely mistake; d is
    a scenario's data whose converter's u_dc is known."""
    out = []
    u_lin = u_linear(d["converter"]["u_dc"], m.phases)
    if m.R_s > 0 and not TAU_E[0] <= m.L_d / m.R_s <= TAU_E[1]:
        out.append(f"machine.electrical.L_d: L_d / R_s = {m.L_d / m.R_s:.3g} s is outside {TAU_E[0]:g}..{TAU_E[1]:g} s, "
                   "unusual for a PMSM: check the units (H, not mH) of L_d, L_q and R_s (ohm)")
    j = inertia_implausible(m)
    if j:
        out.append(f"machine.mechanical.J: {j}")
    out += emf_warnings(m, u_lin)
    out += torque_warnings(m)
    speed = rated_speed_warnings(d, m)
    out += speed
    i_max = d["controller"]["i_max"]
    if m.i_rated > 0 and i_max > PEAK_PER_RATED * m.i_rated:
        out.append(f"{I_MAX_FIELD}: the current limit, {i_max:.4g} A, "
                   f"is {i_max / m.i_rated:.3g} x the rated current ({m.i_rated:.4g} A), where machines' peak ratings "
                   f"seldom pass {PEAK_PER_RATED:g} x: the design takes it as the machine's (its envelope, carrier and "
                   "loops are sized on it): check the value and the "
                   "machine's and converter's peak ratings")
    p_rated = m.T_rated * m.w_m_rated
    loss = 0.5 * m.phases * m.R_s * m.i_rated ** 2
    if loss > COPPER * p_rated and not speed:   # a wrong rated speed is the wrong rated power too
        out.append(f"machine.electrical.R_s: the copper losses at rated current, {loss:.4g} W, are {loss / p_rated:.0%} "
                   f"of the rated power: check R_s (ohm, per phase)")
    return out


def warnings_of(d: dict, m, bw_speed_given: bool = False, bw_observer_given: bool = False) -> list[str]:
    """The warning lines of a validated scenario (data d, machine m;
    bw_speed_given, bw_observer_given: the scenario sets controller.bw_speed,
    blending.bw_observer)."""
    out = plausibility_warnings(d, m)
    ctl = d["controller"]

    # feasibility of the references and the load against the machine's envelope
    out += envelope_warnings(d, m)

    # the speed loop against the observer whose speed it takes
    if bw_speed_given:
        out += speed_loop_warning(d, m)
    out += load_ramp_warning(d, m, bw_observer_given)

    # the start (design.start)
    pol, inj, st = d.get("polarity", {}), d.get("injection", {}), d.get("start", {})
    out += start_warnings(d, m)
    # a first doublet the load outweighs is refused (design.start.design_motion); one its retries meet is warned
    if st.get("kind") == "motion" and "T_load_all" in st["c"] and not st["c"]["T_push_max"] > 2 * st["c"]["T_load_all"]:
        c = st["c"]
        out.append(f"load.torque: {c['T_load_all'] - m.T_coulomb:.3g} N m acts before the motion test's doublets can all have "
                   f"run (until {c['t_all']:.3g} s): its largest push, {c['i_push_max']:.4g} A, makes {c['T_push_max']:.3g} N m, "
                   f"not above twice the load and friction ({2 * c['T_load_all']:.3g} N m); should the first doublet not decide, "
                   "the load turns the rotor in the waits between them and the start fails; let the load act after the start")
    if st.get("kind") == "pulses" and m.psi_f > 0:
        safe = st["c"].get("pulse_safe", {})
        i_safe = min(safe.get("still", math.inf), safe.get("reach", math.inf))
        # judged as the design judged the pulses (scenario._polarity_start): up to the retries' largest,
        # over the carrier's span; a second judgement on other terms contradicted the start it chose
        span = st["c"].get("pulse_span")
        blind = (polarity_blind(m, span["i_top"], pol["i_pulse"], span["h"]) if span else polarity_blind(m, pol["i_pulse"]))
        if blind:
            out.append(f"polarity.enabled: polarity detection measures the d axis's saturation asymmetry, and {m.name}'s "
                       f"{blind}: the drive will refuse to start sensorless (stop reason polarity_undetermined); "
                       "give [magnetic] its saturation, start at a known angle (polarity.enabled = false), or let the start "
                       "turn the rotor (start.method = \"designed\" or \"motion\", start.allow_motion = true)")
        elif pol["i_pulse"] > 1.0001 * i_safe:
            why = ("the rotor's inertia: its torque on an estimate a few degrees off the axis spins the rotor within a "
                   "pulse, and the detection will refuse (stop reason polarity_undetermined)"
                   if safe["still"] <= safe["reach"] else
                   "the current loop's reach: the step from +i to -i on the d axis's saturated incremental inductance, "
                   "with the carrier, passes 0.9 of the trip level (stop reason overcurrent)")
            out.append(f"polarity.i_pulse: {pol['i_pulse']:.4g} A is beyond what {m.name} tolerates, {why}; "
                       f"polarity.i_pulse = {i_safe:.3g} A would not (or leave it to the design)")
        if not blind and d["load"]["kind"] == "torque" and pol.get("t_lock") is not None and pol.get("t_pulse"):
            # the pulses make no torque: a load acting before the first pair
            # ends accelerates the rotor, and a pair whose half-pulse mean
            # speeds differ by more than w_max (a tenth of the positive
            # carrier's filter band, fs_polarity.h) decides nothing
            t_pol = pol["t_lock"] + 2 * pol["t_pulse"]
            T_pol = largest_on(d["load"]["torque"], t_pol)
            dw = m.pole_pairs * max(T_pol - m.T_coulomb, 0.0) / m.J * 0.5 * pol["t_pulse"]
            w_max = 0.1 * _w_b_p(d, m)   # FS_POLARITY_W_MAX_PER_FILTER of the filter's band
            if w_max > 0 and dw > POLARITY_LOAD * w_max:
                out.append(f"load.torque: {T_pol:.3g} N m acts during polarity detection (until t = {t_pol:.3g} s at the "
                           f"earliest), while the drive makes no torque: it changes the rotor's speed by {dw:.3g} el. rad/s "
                           f"in half a pulse, {dw / w_max:.2g} x the {w_max:.3g} the detection tolerates, so it may refuse "
                           "(the pulses spun the rotor); let the load act after that, or hold the rotor (kind = \"speed\")")

    # the injection's observer against its filter (fs_hfi.h)
    if ctl["angle"] in ("hfi", "blend") and inj.get("tracking") == "paper" and inj.get("leak") == "remove":
        out.append("injection.leak: \"remove\" with tracking = \"paper\": the leak's removal makes the negative carrier's "
                   "filter a double lag, which the paper's observer does not model (its response to the angle peaks at 2.7 "
                   "times near twice its bandwidth): it rings, and on the yang2022 machine blended at rated load it cycles at +-12 el.deg; "
                   "use tracking = \"lag\" (designed for it) or leak = \"keep\"")

    # the current loop against the injection's carrier (rules.carrier_loop_action)
    if ctl["angle"] in ("hfi", "blend") and ctl["gains"] == "designed" and inj.get("f_h"):
        out += carrier_loop_warning(d, m)

    # the saliency an injection estimator locks on, where a flux map gives it
    if ctl["angle"] in ("hfi", "blend") and m.magnetic["model"] == "fluxmap":
        out += saliency_warnings(m.magnetic, ctl["i_max"], m.phases, m.pole_pairs, m.T_rated, m.name)
    return out


# the matrix converter's voltage per modulation region: the largest voltage transfer ratio of each
# (zou2021 sec. 3.3, eqs. (20)-(21): CASE 1; CASE 2 at alpha = pi/6), as the modulator has them
IMC_VTR = {"linear": ("FS_IMC_LINEAR", 0.0), "om1": ("FS_IMC_OM1", 0.0), "om2": ("FS_IMC_OM2", math.pi / 6)}
ENVELOPE_TOL = 1e-6      # of the torque: the envelope's own accuracy; a point at the limit is inside


def voltage_limit(d: dict, m) -> tuple[float, str]:
    """The voltage (V peak phase) the scenario's converter gives the
    machine in steady state, and how it says so: the modulator's linear
    limit u_dc/sqrt3 (the drive's over-modulation gives up to 4.9 % more),
    or a matrix converter's largest VTR in its modulation times the grid's
    phase amplitude (the over-modulation regions are its own setting)."""
    conv = d["converter"]
    if conv["kind"] == "imc":
        name, alpha = IMC_VTR[conv["modulation"]]
        v_im = conv["grid_ll_rms"] * math.sqrt(2.0 / 3.0)
        return (float(lib.fs_imc_vtr_max(getattr(lib, name), alpha)) * v_im,
                f"the matrix converter's {conv['modulation']} modulation on a {conv['grid_ll_rms']:g} V grid")
    return (u_linear(conv["u_dc"], m.phases),
            f"the {conv['u_dc']:g} V link at linear modulation, over-modulation giving up to "
            f"{100 * (OVERMODULATION - 1):.1f} % more voltage")


def _points(profiles: list, extra: tuple = ()) -> list[tuple[float, list]]:
    """The corners of piecewise-linear profiles (times, values), together:
    each time any of them has a corner (and the extra times), with each
    profile's values there (both sides of a step)."""
    times = sorted({t for p in profiles for t in p[0]} | set(extra)) or [0.0]
    out = []
    for t in times:
        vals = []
        for tp, yp in profiles:
            at = [y for tk, y in zip(tp, yp) if tk == t]
            vals.append(at or [float(np.interp(t, tp, yp)) if len(tp) else 0.0])
        out.append((t, vals))
    return out


def envelope_warnings(d: dict, m) -> list[str]:
    """A line per field whose profile asks, at one of its corners, for more
    than the machine's envelope gives there (the worst corner): in speed
    mode the speed reference with the load and friction it turns against
    (with flux weakening, against the torque the envelope gives at that
    speed; without, against where the MTPA current meets the voltage
    limit); in current mode with a speed-holding load, the current
    reference's voltage at the load's speed."""
    ctl, load, ref = d["controller"], d["load"], d["references"]
    if ctl["mode"] == "speed" and load["kind"] in ("torque", "brake"):
        cases = []
        for t, (speeds, loads) in _points([ref["speed_rpm"], load["torque"]]):
            for n in speeds:
                w_m = rpm_to_rad_s(abs(n))
                for T_l in loads:
                    cases.append((t, abs(n), w_m, abs(T_l), abs(T_l) + m.B * w_m + m.T_coulomb))
        cases = [c for c in cases if c[1] > 0]
        if not cases:
            return []
        try:
            quick, how = _limits(d, m, coarse=True)
            if _inside(quick, cases, ctl["flux_weakening"]):   # the usual case, in a few ms
                return []
            lim, how = _limits(d, m)
        except ConfigError as exc:   # a flux map short of the scenario's i_max: said, not refused here
            return [f"controller.i_max: {exc.allowed}: the references are not checked against the envelope"]
        return _speed_warnings(lim, cases, ctl["flux_weakening"], how, m)
    if ctl["mode"] == "current" and load["kind"] in ("speed", "speed_pi"):
        try:
            return _current_warnings(d, m)
        except ConfigError as exc:
            return [f"controller.i_max: {exc.allowed}: the references are not checked against the envelope"]
    return []


def _limits(d: dict, m, coarse: bool = False) -> tuple[Limits, str]:
    """The machine within the scenario's current limit and its converter's voltage."""
    u, how = voltage_limit(d, m)
    return limits(m, d["converter"]["u_dc"], d["controller"]["i_max"], u, coarse), how


QUICK_MARGIN = 1e-3      # the coarse MTPA locus's interpolation is within this of the fine one's


def _inside(quick: Limits, cases: list, weakening: bool) -> bool:
    """Whether every case is inside by a coarse scan alone: with flux
    weakening a scanned current within both limits makes its torque (a
    lower bound of the envelope's); without, the MTPA locus's speed with a
    margin for its coarser interpolation."""
    p = quick.p
    if weakening:
        T_low = quick.scan_torque(np.array([c[2] * p for c in cases]))
        return all(c[4] <= T for c, T in zip(cases, T_low))
    return all(c[2] * p <= (1 - QUICK_MARGIN) * quick.mtpa_speed(c[4]) for c in cases)


def _speed_warnings(lim: Limits, cases: list, weakening: bool, how: str, m) -> list[str]:
    """The speed mode's lines, the worst case of each field (cases: t,
    rpm, w_m, load torque, torque needed with friction): load.torque where
    a load asks for the torque, references.speed_rpm where friction alone
    does (the speed is beyond the top speed)."""
    p, i_max = lim.p, lim.i_max
    T_mtpa = lim.mtpa_locus()["T"][-1]
    where = f"{i_max:g} A and {how}"
    if weakening:   # nan: no current within the limits reaches the speed (beyond the top speed)
        T_max = lim.best(np.array([c[2] * p for c in cases]))[0]
        short = [(c[4] - T if np.isfinite(T) else math.inf, c, T) for c, T in zip(cases, T_max)]
    else:   # the MTPA current for the torque must meet the voltage limit at the speed
        w_top = {T: lim.mtpa_speed(T) / p for T in {c[4] for c in cases}}
        short = [((c[2] - w_top[c[4]]) / max(c[2], 1e-300), c, w_top[c[4]]) for c in cases]
    worst = {}
    for excess, c, limit in short:
        field = "load.torque" if c[3] > 0 else "references.speed_rpm"
        if excess > (ENVELOPE_TOL * max(c[4], 1e-12) if weakening else ENVELOPE_TOL) and excess > worst.get(field, (0.0,))[0]:
            worst[field] = (excess, c, limit)
    out = []
    for field, (_, (t, n, w_m, T_l, T), limit) in worst.items():
        what = f"{T_l:.4g} N m at {n:.5g} rpm" if T_l > 0 else f"{n:.5g} rpm"
        at = f"t = {t:g} s" + (f", {T:.4g} N m with friction" if T > T_l * (1 + 1e-9) else "")
        if T > T_mtpa * (1 + ENVELOPE_TOL):
            # at speed the envelope gives less than MTPA's torque: the smaller bound is the one the speed meets
            there = ("" if not weakening or (np.isfinite(limit) and limit >= T_mtpa * (1 - ENVELOPE_TOL)) else
                     f", and at that speed it makes at most {limit:.4g} N m with flux weakening" if np.isfinite(limit)
                     else f", and that speed is beyond its top speed, {rad_s_to_rpm(lim.w_top()[0] / p):.5g} rpm")
            out.append(f"{field}: {what} ({at}) is beyond the {T_mtpa:.4g} N m {m.name} makes at i_max on MTPA{there} "
                       f"(within {where}; `fullspeed design` prints the envelope)")
        elif weakening:
            most = (f"it makes at most {limit:.4g} N m at that speed" if np.isfinite(limit) else
                    f"that speed is beyond its top speed, {rad_s_to_rpm(lim.w_top()[0] / p):.5g} rpm")
            out.append(f"{field}: {what} ({at}) lies outside {m.name}'s envelope: {most} with flux weakening (MTPA, "
                       f"flux weakening and MTPV within {where}; `fullspeed design` prints the envelope): the speed "
                       "will not be held")
        else:
            T_fw = lim.best(np.array([w_m * p]))[0][0]
            fw = (f"with flux weakening the envelope gives {T_fw:.4g} N m there" if np.isfinite(T_fw) and T_fw > 0
                  else "beyond the top speed even with flux weakening")
            out.append(f"references.speed_rpm: {n:.5g} rpm is beyond the {rad_s_to_rpm(limit):.5g} rpm "
                       f"{how.split(',')[0]} allows at {T:.3g} N m ({at}) without flux weakening "
                       f"(controller.flux_weakening = false: the MTPA current meets the voltage limit there; {fw}): "
                       "the speed will not be reached")
    return out


def _current_warnings(d: dict, m) -> list[str]:
    """The current mode's line: the reference's voltage at the load's
    speed above the converter's (the currents will not be reached)."""
    ref, load, ctl = d["references"], d["load"], d["controller"]
    lim, how = _limits(d, m, coarse=True)   # its fluxes anywhere are the plant's own, exact
    u = lim.u
    worst = None
    for t, (ds, qs, ns) in _points([ref["i_d"], ref["i_q"], load["speed_rpm"]]):
        for i_d in ds:
            for i_q in qs:
                for n in ns:
                    if math.hypot(i_d, i_q) > ctl["i_max"]:
                        continue   # the drive limits the current: not the voltage's question
                    v = _voltage(lim, i_d, i_q, m.pole_pairs * rpm_to_rad_s(n))
                    if worst is None or v > worst[0]:
                        worst = (v, t, i_d, i_q, n)
    if worst is None or worst[0] <= u * (1 + ENVELOPE_TOL):
        return []
    v, t, i_d, i_q, n = worst
    T_max = _limits(d, m)[0].best(np.array([m.pole_pairs * rpm_to_rad_s(abs(n))]))[0][0]
    return [f"references.i_q: i_d = {i_d:.4g} A, i_q = {i_q:.4g} A at {n:.5g} rpm (load.speed_rpm, t = {t:g} s) needs "
            f"{v:.4g} V of the {u:.4g} V {how.split(',')[0]} gives: the currents will not be reached (the envelope "
            f"gives at most {T_max:.4g} N m at that speed)"]


def _voltage(lim: Limits, i_d: float, i_q: float, w_e: float) -> float:
    """|R_s i + j w_e psi(i)| at any current (the flux as the plant has it)."""
    psi_d, psi_q = lim.flux_anywhere(i_d, i_q)
    return math.hypot(lim.R * i_d - w_e * psi_q, lim.R * i_q + w_e * psi_d)

def _mistakes(m, psi_ok: bool, p_ok: bool, henry_ok: bool = False) -> list[tuple[str, str]]:
    """The likely mistakes behind too much EMF or torque, (field, what),
    the commonest first: psi_f from a line-to-line Ke, pole pairs given as
    poles, inductances in mH typed as H."""
    out = []
    if psi_ok:
        out.append(("machine.electrical.psi_f", f"psi_f from a line-to-line Ke ({m.psi_f:.4g} Wb is sqrt 3 x "
                    f"{m.psi_f / math.sqrt(3):.4g}: {KE_TO_PSI_F}, Ke in V/krpm line-to-line rms)"))
    if p_ok:
        out.append(("machine.pole_pairs", f"pole_pairs given as poles ({m.pole_pairs} for {m.pole_pairs // 2} pairs)"))
    if henry_ok:
        out.append(("machine.electrical.L_d", f"L_d and L_q in mH typed as H ({m.L_d:g} and {m.L_q:g})"))
    return out


def rated_speed_warnings(d: dict, m) -> list[str]:
    """The rated speed against the rated power where the machine gives it
    (POWER_PER_TW), else against the speed at which the rated current on
    MTPA meets the scenario's voltage limit (RATED_SPEED_MIN), naming a
    speed given in rad/s where rpm would fit."""
    rpm = rad_s_to_rpm(m.w_m_rated)
    as_rad_s = f"likely the rated speed given in rad/s ({rpm:g} rad/s is {rad_s_to_rpm(rpm):.5g} rpm)"
    if m.P_rated:
        r = m.P_rated / (m.T_rated * m.w_m_rated)
        if POWER_PER_TW[0] <= r <= POWER_PER_TW[1]:
            return []
        head = (f"the rated power, {m.P_rated:.4g} W, is {r:.3g} x the rated torque at the rated speed "
                f"({m.T_rated:g} N m at {rpm:g} rpm), outside {POWER_PER_TW[0]:g}..{POWER_PER_TW[1]:g}")
        if POWER_PER_TW[0] <= r / (60.0 / (2.0 * math.pi)) <= POWER_PER_TW[1]:
            return [f"machine.rated.speed_rpm: {head}: {as_rad_s}"]
        if POWER_PER_TW[0] <= r * 1e3 <= POWER_PER_TW[1]:
            return [f"machine.rated.power: {head}: likely the power given in kW (W)"]
        return [f"machine.rated.power: {head}: check the rated power (W), torque (N m) and speed_rpm"]
    try:
        lim, how = _limits(d, m, coarse=True)
    except ConfigError:   # a flux map short of the scenario's i_max: said by envelope_warnings
        return []
    _, i_d, i_q = lim.mtpa(np.array([min(m.i_rated, lim.i_max)]))
    w_base = float(lim.w_limit(i_d, i_q)[0]) / m.pole_pairs
    r = m.w_m_rated / w_base if w_base > 0 else math.inf
    if r >= RATED_SPEED_MIN:
        return []
    why = as_rad_s if r * 60.0 / (2.0 * math.pi) >= RATED_SPEED_MIN else "check speed_rpm, psi_f (Wb) and converter.u_dc"
    return [f"machine.rated.speed_rpm: {rpm:g} rpm is {r:.3g} x the speed at which the rated current on MTPA "
            f"({min(m.i_rated, lim.i_max):g} A) meets the voltage limit ({rad_s_to_rpm(w_base):.5g} rpm, {how}), "
            f"below {RATED_SPEED_MIN:g}: {why}"]


def _likely(found: list[tuple[str, str]], first: str, otherwise: str) -> str:
    """A warning's field (the likeliest mistake's, else `first`) and its text."""
    if not found:
        return f"{first}: {{}}: {otherwise}"
    return f"{found[0][0]}: {{}}: likely " + " or ".join(what for _, what in found)


def emf_warnings(m, u_lin: float) -> list[str]:
    """The back-EMF at rated speed against the rated voltage where the
    machine gives it (EMF_PER_RATED_VOLTAGE), else against the link
    (EMF_PER_LINK)."""
    emf = m.pole_pairs * m.w_m_rated * m.psi_f
    ref, what, band = ((m.u_rated, "rated voltage (machine.rated.voltage, peak phase: line-to-line rms x sqrt(2/3))",
                        EMF_PER_RATED_VOLTAGE) if m.u_rated else (u_lin, "link gives", EMF_PER_LINK))
    if not emf > band * ref:
        return []
    found = _mistakes(m, emf / math.sqrt(3) <= band * ref, m.pole_pairs % 2 == 0 and emf / 2 <= band * ref)
    line = _likely(found, "machine.electrical.psi_f", "check psi_f (Wb, peak phase flux linkage), pole_pairs and converter.u_dc")
    return [line.format(f"the back-EMF at rated speed, p w_rated psi_f = {emf:.4g} V, is {emf / ref:.3g} x the {ref:.4g} V "
                        f"the {what}, above {band:g}")]


def rated_torque_ratio(m, i: float | None = None, **fields) -> float | None:
    """The torque at current i (the rated current) on the MTPA locus, with
    its reluctance part, over the rated torque: the linear model's
    (1.5 p (psi_f i_q + (L_d - L_q) i_d i_q)), a flux map's own where the
    machine has one; with other fields (pole_pairs, psi_f, L_d, L_q) for the
    linear model. None where the model makes no torque."""
    i = m.i_rated if i is None else i
    mm = dataclasses.replace(m, **fields) if fields else m
    if set(fields) <= {"pole_pairs"} and m.magnetic.get("model") == "fluxmap":   # a map's torque goes as p
        T, d, q = mtpa_locus(m.magnetic, max(i, 1e-9) * 1.0, m.phases, mm.pole_pairs)
        return float(T[-1]) / m.T_rated
    try:
        return mtpa_torque(mm, i) / m.T_rated
    except ValueError:
        return None


def torque_warnings(m) -> list[str]:
    """The torque at rated current with its reluctance part against the rated
    torque (K_T_TOTAL; K_T_MAP on a flux map), and the magnet's alone (K_T_MAGNET), each naming the
    likely mistake."""
    out = []
    r = rated_torque_ratio(m)
    fluxmap = m.magnetic.get("model") == "fluxmap"
    band = K_T_MAP if fluxmap else K_T_TOTAL
    head = (f"the torque at rated current on MTPA with its reluctance part (1.5 p (psi_f i_q + (L_d - L_q) i_d i_q) at "
            f"{m.i_rated:g} A{', on its flux map' if fluxmap else ''}) is {r:.3g} x the rated torque ({m.T_rated:g} N m)"
            if r is not None else "")
    if r is not None and r > band[1]:
        def fits(**fields):
            return band[0] <= (rated_torque_ratio(m, **fields) or 0.0) <= band[1]
        # a map's fluxes are given as they are: the psi_f and henry mistakes are a datasheet's linear model's
        found = _mistakes(m, not fluxmap and fits(psi_f=m.psi_f / math.sqrt(3)),
                          m.pole_pairs % 2 == 0 and fits(pole_pairs=m.pole_pairs // 2),
                          not fluxmap and m.R_s > 0 and m.L_d / m.R_s > TAU_E[1] and fits(L_d=1e-3 * m.L_d, L_q=1e-3 * m.L_q))
        line = _likely(found, "machine.rated.current" if fluxmap else "machine.electrical.psi_f",
                       "check pole_pairs, the rated current (A peak, the continuous one) and torque (N m)" if fluxmap else
                       "check pole_pairs, psi_f (Wb), L_d, L_q (H) and the rated torque (N m)")
        out.append(line.format(f"{head}, above {band[1]:g}, " + ("more than a rating at one operating point explains" if fluxmap
                                                                   else "more than saturation explains")))
    elif r is not None and r < band[0]:
        rms = band[0] <= (rated_torque_ratio(m, math.sqrt(2) * m.i_rated) or 0)
        out.append(f"machine.rated.current: {head}, below {band[0]:g}: the machine cannot make its rating; "
                   + (f"likely the rated current given as rms (peak {math.sqrt(2) * m.i_rated:.4g} A)" if rms
                      else "check psi_f (Wb), the rated current (A peak) and torque (N m)"))
    k_t = 0.5 * m.phases * m.pole_pairs * m.psi_f * m.i_rated / m.T_rated
    # the magnet alone stands in for the total where linear inductances (unsaturated, small-signal) overstate the
    # reluctance torque: the trial's Prius at an rms current still makes 1.22 x on them. A flux map's torque is
    # the machine's own, saturation in it, and the total decides: a PM-assisted synchronous reluctance machine
    # makes most of its torque from saliency (SyR-e's THOR: magnet 0.46 of 1.0 x rated)
    linear = m.magnetic.get("model") != "fluxmap"
    if linear and m.psi_f > 0 and k_t < K_T_MAGNET and not (r is not None and r < K_T_TOTAL[0]):
        out.append(f"machine.rated.current: the magnet's torque at rated current, (phases/2) p psi_f i_rated = {k_t:.3g} x the "
                   f"rated torque, below {K_T_MAGNET:g}: likely the rated current given as rms (peak = rms x sqrt 2 = "
                   f"{math.sqrt(2) * m.i_rated:.4g} A), or check psi_f (Wb) and the torque (N m)")
    return out


def injection_loop_observer(d: dict, m) -> float:
    """The bandwidth (rad/s) of the motion observer whose angle and speed
    the loops take with the injection (controller.angle hfi or blend): the
    blend's, or the injection's speed observer (design.scenario's rule)."""
    cm = controller_model(d["controller"], m)
    h = hfi_design(d["injection"], control_period(d), cm["L_d"], cm["L_q"])
    return (d["blending"]["bw_observer"] if d["controller"]["angle"] == "blend" else None) or h.w_o_blend


def speed_loop_bound(d: dict, m) -> tuple[float, str] | None:
    """The fastest speed loop the observer feeding it allows (design.scenario's
    rule) and why; None where the loop takes the encoder's speed or a
    paper's gains."""
    ctl, inj, obs = d["controller"], d["injection"], d["observer"]
    if ctl["gains"] == "paper":
        return None
    if ctl["angle"] in ("hfi", "blend"):
        w_o = injection_loop_observer(d, m)
        return 0.5 * w_o, f"half the bandwidth of the observer whose speed it takes ({w_o:.4g} rad/s)"
    if ctl["angle"] == "smo":
        return obs["bw_pll"] / 6.0, f"a sixth of the back-EMF observer's PLL (observer.bw_pll = {obs['bw_pll']:.4g} rad/s)"
    if ctl["angle"] == "swvi":
        return inj["bw_pll"] / 2.0, f"half the square wave's PLL (injection.bw_pll = {inj['bw_pll']:.4g} rad/s)"
    return None


def load_ramp_warning(d: dict, m, given: bool = False) -> list[str]:
    """A line when the blend's motion observer, whose angle and speed the
    loops take, lags the scenario's steepest load ramp by more than
    LOAD_STEP_ANGLE (design.rules.observer_for_load_ramp), with the cause:
    given too slow (`given`), designed at its cap (the injection's own
    observer), or left at the injection's default because the map's
    cross-saturation table spans more than XCOMP_SPAN_FOR_RAMP
    (design.scenario's _blend_for_load_ramp: the advice to leave it to the
    design would then be no advice)."""
    ctl, load = d["controller"], d["load"]
    if ctl["angle"] != "blend" or load["kind"] != "torque" or ctl["gains"] == "paper":
        return []
    ramp = load_ramp_max(load["torque"])
    if not ramp > 0.0:
        return []
    w_o = injection_loop_observer(d, m)
    lag = load_ramp_lag(m.pole_pairs, m.J, ramp, w_o)
    if not lag > LOAD_STEP_ANGLE * (1 + 1e-6):
        return []
    if given:
        cause = ("; let the load rise more slowly, or leave blending.bw_observer to the design (up to the injection's "
                 "own observer, injection.bw_filter_n)")
    elif d["blending"]["bw_observer"] is None:
        cause = (f"; the design left it at the injection's default: the map's cross-saturation table spans "
                 f"{xcomp_span_deg(d['injection']['xcomp']):.4g} el.deg, more than {XCOMP_SPAN_FOR_RAMP:g}, and a "
                 "faster observer would pass the carrier angle's moves with the current to the loops; let the load "
                 "rise more slowly")
    else:
        cause = "; designed at its cap, the injection's own observer: let the load rise more slowly"
    return [f"blending.bw_observer: the blend's observer ({w_o:.4g} rad/s) lags the load's steepest ramp "
            f"({ramp:.4g} N m/s on J = {m.J:.4g} kg m^2) by {math.degrees(lag):.3g} el.deg, more than "
            f"{math.degrees(LOAD_STEP_ANGLE):g}: the loops take that lag, and the speed loop at half the observer lets the "
            "rotor roll back under it" + cause]


def speed_loop_warning(d: dict, m) -> list[str]:
    """A line when a speed loop the scenario sets (controller.bw_speed; a
    machine file's bench.bw_speed is its bench's, as the catalog's papers
    ran it) outruns the observer that feeds it: its lag then sits inside the
    loop (the Prius MG2 rolled back further at standstill under 200 N m with
    bw_speed 60 and 100 rad/s)."""
    ctl = d["controller"]
    b = speed_loop_bound(d, m) if ctl["mode"] == "speed" else None
    if b is None or not ctl["bw_speed"] > b[0] * (1 + 1e-6):
        return []
    return [f"controller.bw_speed: {ctl['bw_speed']:.4g} rad/s outruns the observer that feeds the speed loop: at most "
            f"{b[0]:.4g} rad/s, {b[1]}; its lag in the loop makes the rotor roll back further under a load at standstill "
            "and can cost lock: leave bw_speed to the design or raise the observer's bandwidth"]


def _w_b_p(d: dict, m) -> float:
    """The positive carrier's filter band, rad/s, as fs_hfi_init designs it."""
    L_d, L_q = injection_inductances(controller_model(d["controller"], m))
    h = hfi_design(d["injection"], control_period(d), L_d, L_q)
    return h.cfg.w_b_p


def carrier_loop_warning(d: dict, m) -> list[str]:
    """A line when the current loop acts on the rotating carrier's sidebands
    beyond rules.CARRIER_LOOP_ACTION_MAX (a given f_h or bw_current; the
    designed carrier keeps within it), with the largest bw_current that does not."""
    ctl, inj = d["controller"], d["injection"]
    Ts, delay = control_period(d), d["timing"]["delay"]
    w_h = 2 * math.pi * inj["f_h"]
    cm = controller_model(ctl, m)
    Ls, R = (cm["L_d"], cm["L_q"]), cm["R_s"]

    def action(bw):
        return max(carrier_loop_action(Ts, delay, bw, w_h, L, R, inj.get("bw_filter_n")) for L in Ls)
    a = action(ctl["bw_current"])
    if a <= CARRIER_LOOP_ACTION_MAX:
        return []
    lo, hi = 0.0, ctl["bw_current"]
    for _ in range(30):   # the largest bandwidth within the bound
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if action(mid) <= CARRIER_LOOP_ACTION_MAX else (lo, mid)
    return [f"controller.bw_current: {ctl['bw_current']:.4g} rad/s acts on the sidebands of the {inj['f_h']:.4g} Hz carrier that "
            f"carry the angle ({a:.2f} of them, at most {CARRIER_LOOP_ACTION_MAX:g}; {1 / (Ts * inj['f_h']):.3g} "
            "samples a carrier period: rules.carrier_loop_action): the injection's estimate may grow or cycle under load at "
            f"standstill; keep bw_current <= {lo:.4g} rad/s, or leave injection.f_h to the design (it rises with bw_current)"]


def start_warnings(d: dict, m) -> list[str]:
    """The start the design kept where the machine asked for another: an
    injection start on a saliency below the injection's resolution."""
    st = d.get("start", {})
    res = st.get("c", {}).get("resolution")
    if st.get("kind") in ("pulses", "motion", "known") and res is not None and res < RESOLUTION_MIN:
        return [f"start.method: the injection's resolution on {m.name} is {res:.2f} of what its carrier's design wants "
                f"(below {RESOLUTION_MIN:g}: too little saliency); its angle at standstill will be noisy or lost: "
                "start.method = \"designed\" with start.allow_motion = true starts I/f into the back-EMF observer instead"]
    return []


def ideal_hardware(d: dict) -> list[str]:
    """What the scenario's hardware leaves out, named in the run's summary."""
    conv, sen, ctl = d["converter"], d["sensors"], d["controller"]
    out = []
    if conv["kind"] == "inverter" and conv["t_dead"] == 0:
        out.append("no dead time")
    if conv["inverter"] == "averaged":
        out.append("averaged inverter (no switching ripple)")
    if sen["noise_i"] == 0:
        out.append("no current-sensor noise")
    if sen["adc_bits"] == 0:
        out.append("no ADC quantization")
    if ctl["angle"] == "encoder" and sen["encoder_bits"] == 0:
        out.append("an ideal encoder")
    return out
