"""What a scenario asks, said out loud when it is loaded: one warning line
per finding, each naming the field. Not errors: the run may be what the
user wants (a machine at its limit, a test of a refusal); the command line
prints them before it runs, and the run's summary names the idealised
hardware.

- feasibility: a speed reference beyond what the link allows at the load
  (without flux weakening, or beyond what flux weakening can reach);
- plausibility: parameters far outside what machines have (time constants,
  the back-EMF against the link and the rated voltage, the torque constant
  against the rated torque, copper losses), which are unit mistakes more
  often than machines (H for mH, kg m^2 for g m^2);
- polarity pulses on a machine without the d-axis saturation asymmetry
  they measure (linear magnetics), pulses larger than the rotor and the
  current loop tolerate (design.start), or a load that turns the rotor while
  the pulses make no torque (fs_polarity.h): the drive will refuse to start
  sensorless, or trip; an injection start on a saliency below the
  injection's resolution (design.start).
"""
from __future__ import annotations

import math

import numpy as np

from ..model.units import rad_s_to_rpm
from .controller import controller_model, hfi_design
from .magnetics import saliency_warnings
from .rules import CARRIER_LOOP_ACTION_MAX, carrier_loop_action, control_period, u_linear
from .start import POLARITY_LOAD, RESOLUTION_MIN, largest_on, polarity_blind

# The bands of plausibility, each with its reason.
TAU_E = (1e-5, 1.0)      # s, L_d / R_s: 10 us (a few-mH machine with a large R) .. 1 s (large machines reach 0.1 s)
TAU_M = (1e-3, 20.0)     # s, J w_rated / T_rated: the time to rated speed at rated torque
EMF_PER_LINK = 2.0       # the back-EMF at rated speed may exceed the link (flux weakening), not by 2x
K_T = (0.5, 3.0)         # 1.5 p psi_f i_rated / T_rated: reluctance torque and saturation move it, not by 2x
COPPER = 0.5             # copper losses at rated current, of rated power: small low-voltage machines reach 0.4 (yang2022: 0.41 at its 40 A rms)


def top_speed(m, u: float, T: float, i_d: float = 0.0) -> float:
    """The mechanical speed (rad/s) at which the voltage reaches u with the
    q current for torque T (and i_d), in steady state."""
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


def warnings_of(d: dict, m) -> list[str]:
    """The warning lines of a validated scenario (data d, machine m)."""
    out = []
    ctl = d["controller"]
    u_lin = u_linear(d["converter"]["u_dc"], m.phases)
    w_e_rated = m.pole_pairs * m.w_m_rated

    # plausibility
    if m.R_s > 0 and not TAU_E[0] <= m.L_d / m.R_s <= TAU_E[1]:
        out.append(f"machine.electrical.L_d: L_d / R_s = {m.L_d / m.R_s:.3g} s is outside {TAU_E[0]:g}..{TAU_E[1]:g} s, "
                   "unusual for a PMSM: check the units (H, not mH) of L_d, L_q and R_s (ohm)")
    tau_m = m.J * m.w_m_rated / m.T_rated
    if not TAU_M[0] <= tau_m <= TAU_M[1]:
        out.append(f"machine.mechanical.J: J w_rated / T_rated = {tau_m:.3g} s to rated speed at rated torque is outside "
                   f"{TAU_M[0]:g}..{TAU_M[1]:g} s: check J's unit (kg m^2)")
    emf = w_e_rated * m.psi_f
    if emf > EMF_PER_LINK * u_lin:
        out.append(f"machine.electrical.psi_f: the back-EMF at rated speed, {emf:.4g} V, is {emf / u_lin:.3g} x the "
                   f"{u_lin:.4g} V the link gives: check psi_f (Wb, peak phase flux linkage) and converter.u_dc")
    k_t = 0.5 * m.phases * m.pole_pairs * m.psi_f * m.i_rated / m.T_rated
    if m.psi_f > 0 and not K_T[0] <= k_t <= K_T[1]:
        out.append(f"machine.rated.current: (phases/2) p psi_f i_rated = {k_t:.3g} x the rated torque, outside "
                   f"{K_T[0]:g}..{K_T[1]:g}: check psi_f (Wb), the rated current (A peak) and torque (N m)")
    p_rated = m.T_rated * m.w_m_rated
    loss = 0.5 * m.phases * m.R_s * m.i_rated ** 2
    if loss > COPPER * p_rated:
        out.append(f"machine.electrical.R_s: the copper losses at rated current, {loss:.4g} W, are {loss / p_rated:.0%} "
                   f"of the rated power: check R_s (ohm, per phase)")

    # feasibility of the speed reference
    if ctl["mode"] == "speed":
        w_ref = max((abs(v) for v in d["references"]["speed_rpm"][1]), default=0.0)
        T_load = max((abs(v) for v in d["load"]["torque"][1]), default=0.0) if d["load"]["kind"] in ("torque", "brake") else 0.0
        T = T_load + m.B * w_ref * 2 * math.pi / 60 + m.T_coulomb
        w_top = rad_s_to_rpm(top_speed(m, u_lin, T))
        if not ctl["flux_weakening"] and w_ref > 1.02 * w_top:
            out.append(f"references.speed_rpm: {w_ref:.5g} rpm is beyond the {w_top:.5g} rpm the {d['converter']['u_dc']:g} V link "
                       f"allows at {T:.3g} N m without flux weakening (controller.flux_weakening = false): the speed will not be reached")
        elif ctl["flux_weakening"]:
            w_fw = rad_s_to_rpm(top_speed(m, u_lin, T, -ctl["i_max"] * 0.9)) if m.psi_f > m.L_d * ctl["i_max"] * 0.9 else math.inf
            if w_ref > 1.02 * max(w_fw, w_top):
                out.append(f"references.speed_rpm: {w_ref:.5g} rpm is beyond the {max(w_fw, w_top):.5g} rpm flux weakening reaches "
                           f"at {T:.3g} N m with {0.9 * ctl['i_max']:.4g} A of d current: the speed will not be reached")

    # the start (design.start)
    pol, inj, st = d.get("polarity", {}), d.get("injection", {}), d.get("start", {})
    out += start_warnings(d, m)
    if st.get("kind") == "motion" and not st["c"]["T_push"] > 2 * st["c"]["T_load"]:
        out.append(f"start.i_push: the motion test's push, {st['i_push']:.4g} A, makes {st['c']['T_push']:.3g} N m, not above "
                   f"twice the load and friction acting while it runs ({st['c']['T_load']:.3g} N m): the load would turn the "
                   "rotor its own way and the test will refuse (stop reason polarity_undetermined); let the load act after "
                   f"the start, or raise start.i_push towards {2.2 * st['c']['T_load'] / st['c']['T_push'] * st['i_push']:.3g} A")
    if st.get("kind") == "pulses" and m.psi_f > 0:
        safe = st["c"].get("pulse_safe", {})
        i_safe = min(safe.get("still", math.inf), safe.get("reach", math.inf))
        blind = polarity_blind(m, pol["i_pulse"])
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


def _w_b_p(d: dict, m) -> float:
    """The positive carrier's filter band, rad/s, as fs_hfi_init designs it."""
    cm = controller_model(d["controller"], m)
    h = hfi_design(d["injection"], control_period(d), cm["L_d"], cm["L_q"])
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
