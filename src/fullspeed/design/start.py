"""The sensorless start, chosen by the machine and designed (issue 34).

Which start a machine gets, in order:
- injection with polarity pulses (fs_polarity.h) where the injection can
  use its saliency and its d axis saturates asymmetrically at a pulse the
  rotor and the current loop tolerate;
- injection with a bounded motion test (fs_motion_test.h) where the
  saliency is there but the asymmetry is not (linear magnetics, or too
  little of it at a safe pulse);
- an I/f start into the back-EMF observer (fs_if_start.h) where the
  injection cannot use the saliency (a surface-PM machine): its
  negative-sequence carrier, at the carrier current the design allows,
  would not reach half of what its design wants (the angle's resolution at
  least twice worse than designed);
each with its reason. A scenario forbids the starts that turn the rotor
with `start.allow_motion = false` (then the pulses, and the refusal when
they cannot decide, as before), or names one with `start.method`.

The pulses' current (item 2 of the issue) is the largest of half the
current limit that both
- leaves the rotor still: on an estimate POLARITY_ERROR_DEG off the axis a
  d pulse makes torque (phases/2) p i (psi_f + (L_q - L_d) i) sin(err)
  (magnet and reluctance; a negative pulse on an interior-magnet machine
  doubles it), which with the load must change the rotor's speed by no more
  than POLARITY_LOAD of the detection's tolerance over half a pulse (the
  Prius MG2's 125 A designed pulses spun its 0.035 kg m^2 rotor, 60 A did
  not: 1.8 and 0.5 of it);
- stays within the current loop's reach: the loop, designed on the
  controller's L_d, stepped from +i to -i on the smallest incremental L_d
  the plant has between them (a saturating d axis lowers it: the loop's gain
  rises with L_d / L_inc and beyond its gain margin it oscillates), with the
  carrier's peak on top, keeps below TRIP_MARGIN of the trip level.
"""
from __future__ import annotations

import math

import numpy as np

from .._core import ffi, lib
from ..model.errors import ConfigError
from ..model.units import rad_s_to_rpm
from .envelope import plant_flux
from .magnetics import incremental_inductances, map_flux
from .rules import I_HF_PER_I_MAX, I_N_LSB, I_N_NOISE, I_N_PER_I_MAX, Value, carrier_currents

# The injection's resolution: usable when its negative-sequence current, with the carrier's current at
# its cap (I_HF_PER_I_MAX of i_max), reaches this share of what the carrier's design wants (I_N_LSB ADC
# steps, I_N_NOISE noise deviations, I_N_PER_I_MAX of i_max): the angle's quantum and noise at most twice
# the designed ones. On the zoo's 12-bit benches that is L_q/L_d >= 1.15.
RESOLUTION_MIN = 0.5
# the incremental L_d asymmetry below which the pulses cannot decide: their 5 % floor on the carrier
# amplitude (fs_polarity.h) needs about that much
POLARITY_ASYMMETRY = 0.05
# the injection estimate's static error at standstill that a d pulse's torque acts on: cross-saturation,
# the inverter's voltage error, the leak (yang2022's machine: about 1 el.deg unloaded; the zoo: up to 4)
POLARITY_ERROR_DEG = 8.0
# the share of the detection's speed tolerance (a tenth of the positive carrier's filter band,
# fs_polarity.h) that the pulses' torque and a load's may use over half a pulse: the estimate's own lag
# and noise take the rest (yang2022's machine refused from 0.94 of it under 1 N m of load)
POLARITY_LOAD = 0.8
# the pulses' peak current, the carrier's peak on top, within this share of the trip level (noise, and
# the loop's model of a plant whose L changes along the step)
TRIP_MARGIN = 0.9
# the current loop's gain margin kept beyond the linear loop's (the plant at the incremental L_d over
# this): on a saturated d axis the carrier's current is larger and distorted by the saturation itself, and
# its harmonics reach the loop past the SRFFs; a 30 kW, 700 V machine (L_d 0.45 mH) whose incremental L_d
# fell to 0.42 of it at 105 A pulses oscillated at the carrier and tripped (0.46 at 90 A; 75 A held), where the
# linear loop, SRFFs included, holds down to 0.33: 1.5 keeps the loop that tripped out
REACH_GAIN_MARGIN = 1.5
# the motion test: the turn that decides (above the injection estimate's spread at standstill, 1..3
# el.deg peak to peak on the catalog's and the zoo's machines; the test doubles a larger measured spread),
# reached after this many time constants of the estimator's observer (its lag behind the rotor then 2 %),
# and the largest threshold it accepts (the rotor then turns by about twice that)
MOTION_TURN_DEG = 4.0
MOTION_TURN_FACTOR = 2.0      # the doublet is designed to turn the rotor by twice that (friction; the estimate's wander)
MOTION_OBSERVER_TAUS = 4.0
MOTION_MAX_DEG = 12.0
# the coast the doublet may leave, as a share of its turn over the settling: half the design's margin over the
# threshold (the turn is MOTION_TURN_FACTOR x the threshold; friction and the estimate's wander take the other half).
# A doublet leaves the rotor at rest only where its two halves' torques match; the injection's estimate sits on the
# carrier's saliency axis, which cross-saturation turns with the push's q current, and on a frame that far off the
# axis the q current has a d part whose reluctance torque changes the push's torque; the estimate lags the current, so
# the halves differ by up to that change, and the rotor coasts at up to its share of the first half's speed through
# the settling: a share r of the turn times t_settle / t_push (sine doublet: the turn p T (2 t)^2 / (2 pi J), the
# half's speed p T 2 t / (pi J)). The Baldor PM-SyRM's 16.2 A push in 2 x 15.9 ms: the axis 27 el.deg off, the torque
# there 2 x its own (r ~ 1), the halves' impulses 13 % apart; the rotor coasted back 3.5 el.deg of its 9.4 over the
# 44 ms settling and the test read 5.7 against its threshold of 4, then, with a map a little different, under it.
MOTION_COAST_SHARE = 0.5 * (1.0 - 1.0 / MOTION_TURN_FACTOR)
# the longest doublet the coast's rule may ask, as a multiple of MOTION_OBSERVER_TAUS time constants: its current
# then still outweighs the load by a margin (at the current that only balances it the doublet lasts for ever:
# 2 x 40,558 s was designed for the Baldor with 15 N m acting through its test, which fs_drive_init refused)
MOTION_STRETCH_MAX = 4.0
# the I/f start: the load angle the current is designed to carry the load and the acceleration at, the
# share of its torque that accelerates, the damping ratio of the rotor's swing about the frame, the
# return from the observer to the frame at this share of the hand-over speed (the observer still trusted
# there: the hand-over is at twice its valid speed)
IF_LOAD_ANGLE_DEG = 45.0
IF_ACCEL_SHARE = 0.25
IF_ACCEL_SHARE_MIN = 0.05
IF_DAMPING = 0.7
IF_SELF_LOOP = 0.5    # the damping's loop through the controller's L error: at most this gain (zoo machine 100, a
                      # saturating 16.9 kW one, limit-cycled its damping current against i_max at 0.9 of it)
IF_RESTART = 0.75
# the longest wait at the hand-over speed for the observer: this many of its PLL's time constants, and
# at least IF_WAIT_MIN s (the zoo's converge within 10..20 of them)
IF_WAIT_TAUS = 100.0
IF_WAIT_MIN = 0.5
# the hand-over: the observer's tracker (SMO_BW_PER_W x the electrical speed at low speed, fs_smo.h's
# FS_SMO_BW_PER_W) at least this many times the speed loop's bandwidth at the return speed (the usual
# rule for an observer feeding a loop, fs_motion_obs.h), the hand-over at most this share of rated speed
SMO_BW_PER_W = 2.0
IF_TRACKER_PER_SPEED_LOOP = 8.0
IF_HANDOVER_MAX = 0.12


def largest_on(profile, t_end: float) -> float:
    """The largest magnitude of a piecewise-linear profile (times, values;
    held beyond its ends) over [0, t_end]."""
    t, y = profile
    ts = [0.0, t_end, *(tk for tk in t if 0.0 < tk < t_end)]
    return max(abs(float(np.interp(tk, t, y))) for tk in ts) if len(t) else 0.0


def load_torque(d: dict, t_end: float) -> float:
    """The largest torque the scenario's load (an active one or a brake)
    puts on the shaft until t_end, N m."""
    load = d["load"]
    return largest_on(load["torque"], t_end) if load["kind"] in ("torque", "brake") else 0.0


# -- what the injection and the pulses can use ---------------------------------

def injection_resolution(L_d: float, L_q: float, f_h: float, bench: dict, i_max: float) -> tuple[float, str]:
    """The injection's negative-sequence current at the carrier current's
    cap (I_p + I_n = I_HF_PER_I_MAX i_max) over the one its design wants,
    and that want's reason."""
    i_p, i_n = carrier_currents(1.0, 2 * math.pi * f_h, L_d, L_q)
    lsb = 2 * bench["adc_range"] / 2 ** bench["adc_bits"] if bench["adc_bits"] else 0.0
    want = max((I_N_LSB * lsb, f"{I_N_LSB} ADC steps"), (I_N_NOISE * bench["noise_i"], f"{I_N_NOISE} noise deviations"),
               (I_N_PER_I_MAX * i_max, f"{I_N_PER_I_MAX:.0%} of i_max"))
    reach = I_HF_PER_I_MAX * i_max * i_n / (i_p + i_n)
    return reach / want[0], f"I_n = {reach:.3g} A at a carrier peak of {I_HF_PER_I_MAX:.0%} of i_max, against {want[0]:.3g} A ({want[1]})"


def _plant_mag(m):
    """The plant's magnetic model for a machine whose model is algebraic."""
    cfg = ffi.new("fs_mag_config *")
    cfg.kind = lib.FS_MAG_ALGEBRAIC
    cfg.L_d, cfg.L_q, cfg.psi_f = m.L_d, m.L_q, m.psi_f
    for k in ("a_dd", "a_qq", "a_dq", "S", "T", "U", "V"):
        setattr(cfg, k, m.magnetic[k])
    st = ffi.new("fs_mag *")
    return st if lib.fs_mag_init(st, cfg) == lib.FS_OK else None


def incremental_L_d(m, i_d, h: float) -> np.ndarray:
    """The plant's incremental d inductance at i_q = 0 (central differences
    of +-h), H, at each of i_d."""
    i = np.atleast_1d(np.asarray(i_d, float))
    model = m.magnetic["model"]
    if model == "fluxmap":
        mag = m.magnetic
        i_grid, i_q = np.asarray(mag["i_d"], float), np.asarray(mag["i_q"], float)
        col = np.array([np.interp(0.0, i_q, row) for row in np.asarray(mag["psi_d"], float)])   # psi_d(i_d) at i_q = 0
        return (np.interp(i + h, i_grid, col) - np.interp(i - h, i_grid, col)) / (2 * h)
    st = _plant_mag(m) if model == "algebraic" else None
    if st is None:
        return np.full(i.shape, m.L_d)
    return (plant_flux(st, i + h, 0.0)[0] - plant_flux(st, i - h, 0.0)[0]) / (2 * h)


def d_asymmetry(m, i_pulse: float) -> float | None:
    """The incremental L_d at -i_pulse against +i_pulse (i_q = 0), relative:
    what polarity detection decides on; None with linear magnetics."""
    if m.magnetic["model"] == "linear":
        return None
    lo, hi = incremental_L_d(m, [-i_pulse, i_pulse], 0.25 * i_pulse)
    return abs(lo - hi) / max(lo, hi) if max(lo, hi) > 0 else 0.0


def pulse_amplitudes(i_pulse: float, i_top: float) -> list[float]:
    """The pulses fs_polarity may run (and the doublets fs_motion_test may):
    i_pulse, then 1.5 times larger per retry up to i_top."""
    out = [i_pulse]
    while out[-1] < i_top * (1 - 1e-9):
        out.append(min(1.5 * out[-1], i_top))
    return out


def _fluxes(m):
    """The plant's (psi_d, psi_q) at currents, Wb, for a machine with a flux
    map or an algebraic model; None with linear magnetics."""
    model = m.magnetic["model"]
    if model == "fluxmap":
        return map_flux(m.magnetic)
    st = _plant_mag(m) if model == "algebraic" else None
    return None if st is None else (lambda i_d, i_q: plant_flux(st, i_d, i_q))


def carrier_asymmetry(m, i_pulse: float, h: float | None = None) -> tuple[float, np.ndarray, np.ndarray] | None:
    """What polarity detection measures, as the plant's magnetics give it:
    the positive-sequence carrier current goes as the mean of the incremental
    admittances, tr(L_inc^-1) / 2 (eq. (24): (L_d + L_q) / (2 L_d L_q) on the
    axes; the d pulse moves L_q too, by cross-saturation), so D = that at
    +i_pulse less that at -i_pulse over their mean (i_q = 0; central
    differences of +-h: the carrier current's peak, the span it sweeps
    about the pulse; without it i_pulse / 4, as d_asymmetry); with the incremental
    inductance matrices at +i_pulse and -i_pulse, H; None with linear
    magnetics."""
    flux = _fluxes(m)
    if flux is None:
        return None
    h = h or 0.25 * i_pulse

    def L_inc(i_d):
        L_dd, L_dq, L_qd, L_qq = (float(x) for x in incremental_inductances(flux, i_d, 0.0, h))
        return np.array([[L_dd, L_dq], [L_qd, L_qq]])
    L_pos, L_neg = L_inc(i_pulse), L_inc(-i_pulse)
    y_pos, y_neg = (0.5 * float(np.trace(np.linalg.inv(L))) for L in (L_pos, L_neg))
    return (y_pos - y_neg) / (0.5 * (y_pos + y_neg)), L_pos, L_neg


def polarity_reversed(m, i_pulse: float, i_top: float | None = None, h: float | None = None) -> str | None:
    """Why polarity detection would decide the wrong way on machine m (as
    "<m.name>'s ..." completes it), or None: fs_polarity.h reads the common
    sign of the d axis's saturation, a current that adds to the magnet
    saturates the iron and raises the carrier's amplitude (D > 0 on the north
    pole); where at a pulse it may run (i_pulse, then its retries up to
    i_top; h: carrier_asymmetry's) the magnetics give D <= -POLARITY_ASYMMETRY, the pulses decide,
    with their margin, for the south pole. SyR-e's THOR PM-SyRM map: D = -31 %
    at 13.7 A with its 2.9 A carrier (incremental L_d 4.6 mH at +13.7 A against
    3.2 mH at -13.7 A: its magnet holds the ribs saturated, a d current along
    it relieves them); the drive measured D = -21 % and turned a right
    estimate by pi. The Baldor PM-SyRM's map: -2 % at its first 9.3 A pulse
    with its 1.2 A carrier (the drive: no decision there), +9 % at the 14 A
    retry (the drive: +8 %)."""
    for i in pulse_amplitudes(i_pulse, i_top if i_top is not None else i_pulse):
        got = carrier_asymmetry(m, i, h)
        if got is not None and got[0] <= -POLARITY_ASYMMETRY:
            D, L_pos, L_neg = got
            what = "flux map" if m.magnetic["model"] == "fluxmap" else "magnetic model"
            return (f"{what} gives the carrier a {-D:.0%} smaller amplitude where the d current adds to the magnet (incremental "
                    f"L_d {L_pos[0, 0] * 1e3:.3g} mH, L_q {L_pos[1, 1] * 1e3:.3g} mH at +{i:.3g} A; {L_neg[0, 0] * 1e3:.3g} mH, "
                    f"{L_neg[1, 1] * 1e3:.3g} mH at -{i:.3g} A), the opposite of the saturation the pulses read: they "
                    "would decide for the south pole")
    return None


def polarity_blind(m, i_pulse: float, i_first: float | None = None, h: float | None = None) -> str | None:
    """Why polarity detection cannot decide on machine m at pulses of i_pulse
    (what its magnetics lack, as "<m.name>'s ..." completes it), or None;
    with i_first, the pulses from i_first up to i_pulse are checked for the
    reversed sign (polarity_reversed, with h)."""
    if m.magnetic["model"] == "linear":
        return "magnetics are linear"
    rev = polarity_reversed(m, i_first if i_first is not None else i_pulse, i_pulse, h)
    if rev:
        return rev
    asym = d_asymmetry(m, i_pulse)
    if asym is not None and asym < POLARITY_ASYMMETRY:
        what = "flux map's" if m.magnetic["model"] == "fluxmap" else "magnetic model's"
        return f"{what} incremental L_d differs by only {asym:.1%} between -i_pulse and +i_pulse"
    return None


def pulse_speed_change(m, i_pulse: float, t_pulse: float, T_load: float, L_d: float, L_q: float) -> float:
    """The rotor's speed change over half a pulse, el. rad/s, from the pulse's
    torque on an estimate POLARITY_ERROR_DEG off the axis (magnet and
    reluctance: the negative pulse's) and the load's."""
    k_T = 0.5 * m.phases * m.pole_pairs
    T = k_T * i_pulse * (m.psi_f + max(L_q - L_d, 0.0) * i_pulse) * math.sin(math.radians(POLARITY_ERROR_DEG))
    return m.pole_pairs * (T + max(T_load - m.T_coulomb, 0.0)) / m.J * 0.5 * t_pulse


def pulse_peak(Ts: float, delay: bool, bw: float, R: float, L_ctrl: float, L_plant: float, i_pulse: float,
               n: int, u_max: float, hfi=None) -> float:
    """The largest |i_d| of a pulse pair 0 -> +i -> -i -> 0 (n samples each)
    through the current loop as fs_drive_init designs it on L_ctrl, the
    plant's d axis at L_plant (R, the voltage held within u_max), the loop
    reading the injection's fundamental (hfi: its fs_hfi_filter config; the
    SRFFs' stop bands add their lag to the loop): inf where the loop
    diverges (beyond its gain margin)."""
    cc = ffi.new("fs_current_ctrl_config *", {"Ts": Ts, "R_s": R, "L_d": L_ctrl, "L_q": L_ctrl, "psi_f": 0.0,
                                                "bandwidth": bw, "predict": int(delay)})
    cfg = ffi.new("fs_pulse_peak_config *", {"Ts": Ts, "delay": int(delay), "R": R, "L_plant": L_plant,
                                              "u_max": u_max, "filt": hfi[0] if hfi else ffi.NULL,
                                              "w_h": hfi[1] if hfi else 0.0})
    # in C (csrc/sim/fs_pulse_peak.c): the design's bisections run it ~60 times a scenario
    return float(lib.fs_pulse_peak(cfg, cc, i_pulse, n))


def _largest(ok, lo: float, hi: float) -> float:
    """The largest x in [lo, hi] with ok(x) (ok monotone: true below some
    point); lo if none."""
    if ok(hi):
        return hi
    if not ok(lo):
        return lo
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def design_pulses(d: dict, m, cm: dict, i_hf: float, h, u_lin: float) -> dict[str, Value]:
    """The polarity pulses' current and its retries' largest (item 2): half
    the current limit, or less where the rotor's inertia or the current
    loop's reach asks it; each with its reason and numbers."""
    ctl, pol = d["controller"], d["polarity"]
    i_max, t_p, Ts = ctl["i_max"], pol["t_pulse"], _Ts(d)
    L_ctrl, L_d, L_q = cm["L_d"], m.L_d, m.L_q   # the loop on the controller's model; the torque the machine's
    t_pol = pol["t_lock"] + 2 * t_p
    T_L = load_torque(d, t_pol)
    w_max = 0.1 * h.cfg.w_b_p   # FS_POLARITY_W_MAX_PER_FILTER of the filter's band
    filt = (ffi.new("fs_hfi_filter_config *", {"Ts": Ts, "w_b_p": h.cfg.w_b_p, "w_b_n": h.cfg.w_b_n}), h.cfg.w_h)

    def still(i):   # the pulses' own torque (a load's is the scenario's, warned: design.checks)
        return pulse_speed_change(m, i, t_p, 0.0, L_d, L_q) <= POLARITY_LOAD * w_max
    n = max(int(round(t_p / Ts)), 4)
    i_trip = m.bench["i_trip"]

    def within(i):   # the smallest incremental L_d between -i and +i, and the carrier's peak there
        L_inc = float(np.min(incremental_L_d(m, np.linspace(-i, i, 41), 0.01 * max(i, 1e-6))))
        L_inc = min(max(L_inc, 1e-3 * L_ctrl), L_ctrl) if L_inc > 0 else 1e-3 * L_ctrl
        peak = pulse_peak(Ts, d["timing"]["delay"], ctl["bw_current"], cm["R_s"], L_ctrl, L_inc / REACH_GAIN_MARGIN, i, n,
                          u_lin, filt)
        return peak + i_hf * L_ctrl / L_inc <= TRIP_MARGIN * i_trip
    i_lim = max(i_max - i_hf, 1e-9)
    half = 0.5 * i_max
    i_still, i_reach = _largest(still, 1e-3 * i_max, i_lim), _largest(within, 1e-3 * i_max, i_lim)
    i_safe = min(i_still, i_reach)
    out = {}
    if pol["i_pulse"] is None:
        i_p = min(half, i_safe)
        if i_p == half:
            why = "half of controller.i_max: the d axis saturates there on common machines"
        else:
            why = _pulse_limit_reason(i_p, i_still, i_reach, half)
        pol["i_pulse"] = i_p
        out["polarity.i_pulse"] = Value(i_p, "A", why)
    if pol["i_pulse_max"] is None and i_safe < i_lim:
        pol["i_pulse_max"] = max(i_safe, pol["i_pulse"])
        out["polarity.i_pulse_max"] = Value(pol["i_pulse_max"], "A", "the retries' largest: " + _pulse_limit_reason(
            i_safe, i_still, i_reach, i_lim, "controller.i_max less the carrier's peak"))
    d["start"]["c"]["pulse_safe"] = {"still": i_still, "reach": i_reach, "T_load": T_L}
    # the rotor's largest turn: its speed may change by POLARITY_LOAD w_max every half pulse (4 a pair, the
    # pairs one for each 1.5 x step up to the retries' largest), its turn the sum of those speeds' halves
    i_top = pol["i_pulse_max"] or i_lim
    pairs = len(pulse_amplitudes(pol["i_pulse"], i_top))
    halves = 4 * pairs
    d["start"]["c"]["bound_deg"] = math.degrees(POLARITY_LOAD * w_max * 0.5 * t_p * halves * (halves + 1) / 2)
    return out


def _pulse_limit_reason(i: float, i_still: float, i_reach: float, bound: float, what: str = "half of controller.i_max") -> str:
    if i_still <= i_reach:
        return (f"{i:.4g} A, not {what} ({bound:.4g} A): on an estimate {POLARITY_ERROR_DEG:g} el.deg off the axis a "
                f"larger pulse's torque (magnet and reluctance) and the load's would change the rotor's speed by more "
                f"than {POLARITY_LOAD:g} of the detection's tolerance in half a pulse: the rotor's inertia")
    return (f"{i:.4g} A, not {what} ({bound:.4g} A): a larger step from +i to -i on the incremental L_d the d axis "
            f"saturates to there, through the current loop designed on L_d, with the carrier's peak, would pass "
            f"{TRIP_MARGIN:g} of the trip level: the current loop's reach")


def _Ts(d: dict) -> float:
    return (0.5 if d["timing"]["sampling"] == "double" else 1.0) / d["converter"]["f_pwm"]


# -- the motion test ------------------------------------------------------------

def push_torque_change(m, i: float) -> tuple[float, float] | None:
    """What a q-current push of i on the injection's estimate does on machine
    m's magnetics: the carrier's saliency axis at (0, i), where the estimate
    sits while the current flows (the principal axis of the incremental
    inductance matrix, as fs_hfi reads it; el. rad off the d axis), and the
    push's torque on a frame that far off the axis (either way) against its
    torque on the axis, |T / T(0, i) - 1| (the q current's d part adds
    reluctance torque); None with linear magnetics (the axis stays put)."""
    flux = _fluxes(m)
    if flux is None or not i > 0:
        return None
    h = 0.01 * i
    L_dd, L_dq, L_qd, L_qq = (float(x) for x in incremental_inductances(flux, 0.0, i, h))
    delta = 0.5 * math.atan2(L_dq + L_qd, L_qq - L_dd)   # the axis of the symmetric part

    def torque(i_d, i_q):   # over (phases/2) p: psi_d i_q - psi_q i_d
        psi_d, psi_q = (float(x) for x in flux(i_d, i_q))
        return psi_d * i_q - psi_q * i_d
    T0 = torque(0.0, i)
    if not T0 > 0:
        return delta, math.inf
    r = max(abs(torque(-s * i * math.sin(delta), i * math.cos(delta)) / T0 - 1.0) for s in (1.0, -1.0))
    return delta, r


def design_motion(d: dict, m, i_hf: float, w_o: float, w_b_n: float) -> dict[str, Value]:
    """The motion test's doublet (fs_motion_test.h): the q current that
    turns the rotor by MOTION_TURN_FACTOR x the deciding turn, against twice
    the load and friction, in two halves of MOTION_OBSERVER_TAUS time
    constants of the injection's observer each; the retries, the rotor's
    largest turn; each with its reason."""
    ctl, st, pol = d["controller"], d["start"], d["polarity"]
    p, J = m.pole_pairs, m.J
    k_T = 0.5 * m.phases * p
    turn = math.radians(st["turn_deg"] if st["turn_deg"] is not None else MOTION_TURN_DEG)
    want = MOTION_TURN_FACTOR * turn
    t_half = MOTION_OBSERVER_TAUS / w_o
    t_settle = 3.0 / w_b_n + 8.0 / w_o   # as fs_drive_init sets it: the filters settle, the observer catches up
    T_L = load_torque(d, pol["t_lock"] + 2 * t_half + t_settle) + m.T_coulomb
    i_lim = 0.999 * (ctl["i_max"] - i_hf)   # below fs_drive's float32 bound
    out = {}

    def half(x):   # each half of the doublet that turns the rotor by `want` at x A against twice the load
        return 0.5 * math.sqrt(2 * math.pi * want * J / (p * max(k_T * m.psi_f * x - 2 * T_L, 1e-12)))
    if st["i_push"] is None:
        # a sine period over 2 t_half turns the rotor by p T (2 t_half)^2 / (2 pi J); the load at most half its peak
        T = 2 * math.pi * want * J / (p * (2 * t_half) ** 2) + 2 * T_L
        i = T / (k_T * m.psi_f)
        why = (f"turns the rotor by {math.degrees(want):.3g} el.deg (J = {J:.3g} kg m^2) in a doublet of 2 x "
               f"{t_half * 1e3:.3g} ms ({MOTION_OBSERVER_TAUS:g} time constants of the injection's observer each, "
               f"{w_o:.4g} rad/s), against twice the load and friction ({T_L:.3g} N m)")
        # the coast the halves' mismatch may leave (MOTION_COAST_SHARE): a longer doublet turns the rotor as far with
        # less current, whose axis the carrier's saliency keeps closer to the d axis
        def coasts(x):
            got = push_torque_change(m, x)
            return 0.0 if got is None else got[1] * t_settle / half(x)
        if coasts(i) > MOTION_COAST_SHARE:
            i0, t0, T_L0, stretched = i, t_half, T_L, True
            for _ in range(4):   # a longer doublet may meet more of the load: sized again on the load in its window
                # the least current whose doublet is at most MOTION_STRETCH_MAX x the observer's: near the current
                # that only balances the load the doublet's length diverges (a load acting through the test)
                lo = (2 * T_L + 2 * math.pi * want * J / (p * (2 * MOTION_STRETCH_MAX * t0) ** 2)) / (k_T * m.psi_f)
                if not (lo < i0 and coasts(lo) <= MOTION_COAST_SHARE):
                    stretched = False
                    break
                i = _largest(lambda x: coasts(x) <= MOTION_COAST_SHARE, lo, i0)
                t_half = half(i)
                T_in = load_torque(d, pol["t_lock"] + 2 * t_half + t_settle) + m.T_coulomb
                if T_in <= T_L:
                    break
                T_L = T_in
            _, r0 = push_torque_change(m, i0)
            if stretched:
                delta, r = push_torque_change(m, i)
                why = (f"turns the rotor by {math.degrees(want):.3g} el.deg (J = {J:.3g} kg m^2) in a doublet of 2 x "
                       f"{t_half * 1e3:.3g} ms against twice the load and friction ({T_L:.3g} N m), longer than "
                       f"{MOTION_OBSERVER_TAUS:g} time constants of the injection's observer ({t0 * 1e3:.3g} ms, {i0:.4g} A): "
                       f"there the carrier's saliency axis, where the estimate sits, would turn so far with the current that "
                       f"the push's torque on it changes by {r0:.0%}, and the halves' mismatch could leave the rotor coasting "
                       f"by more than {MOTION_COAST_SHARE:.0%} of the turn over the {t_settle * 1e3:.3g} ms settling; at "
                       f"{i:.4g} A the axis is {math.degrees(delta):+.2g} el.deg off, the torque {r:.1%}")
            else:   # as designed: the coast may take more of the turn, which the test's threshold and retries meet
                i, t_half, T_L = i0, t0, T_L0
                why += (f"; the push's torque on the carrier's axis there changes by {r0:.0%}, and no doublet up to "
                        f"{MOTION_STRETCH_MAX:g} x longer keeps the halves' coast within {MOTION_COAST_SHARE:.0%} of the turn "
                        "against this load")
        if i > i_lim:
            i = i_lim
            if not k_T * m.psi_f * i > 2 * T_L:   # no doublet within the limit outweighs the load: the test cannot decide
                load = T_L - m.T_coulomb
                raise ConfigError("load.torque", load, (
                    f"at most {0.5 * k_T * m.psi_f * i - m.T_coulomb:.3g} N m may act while the motion test runs (until "
                    f"{pol['t_lock'] + 2 * t_half + t_settle:.3g} s, its first doublet): its push at the current limit "
                    f"less the carrier's peak, {i:.4g} A, makes {k_T * m.psi_f * i:.3g} N m, which must outweigh twice the "
                    f"load and friction ({2 * T_L:.3g} N m) to turn the rotor its own way; let the load act after the start"),
                    None)
            t_half = half(i)
            why = (f"controller.i_max less the carrier's peak: the turn of {math.degrees(want):.3g} el.deg then takes "
                   f"2 x {t_half * 1e3:.3g} ms")
        st["i_push"] = i
        out["start.i_push"] = Value(i, "A", why)
    else:
        if not k_T * m.psi_f * st["i_push"] > 2 * T_L:   # given: a push the load outweighs turns nothing its own way
            raise ConfigError("start.i_push", st["i_push"], (
                f"makes {k_T * m.psi_f * st['i_push']:.3g} N m, which must outweigh twice the load and friction acting "
                f"while the motion test runs ({2 * T_L:.3g} N m): at least {2 * T_L / (k_T * m.psi_f):.4g} A, or let the "
                "load act after the start"), None)
        t_half = half(st["i_push"])
    if st["i_push"] > i_lim:
        raise ConfigError("start.i_push", st["i_push"], f"must be <= {i_lim:.4g} A: controller.i_max less the carrier's peak", None)
    st["c"]["T_push"], st["c"]["T_load"] = k_T * m.psi_f * st["i_push"], T_L   # the first doublet against the load (refused above)
    st["turn_deg"] = math.degrees(turn)
    i_top = min(i_lim, 2.25 * st["i_push"])   # two retries
    # the doublets up to i_top, each 1.5 times the last (fs_motion_test.h), and the load while all of them run:
    # a retry is the start taking longer, and a load that comes meanwhile turns the rotor in the waits between
    t_all = pol["t_lock"] + len(pulse_amplitudes(st["i_push"], i_top)) * (2 * t_half + t_settle)
    st["c"].update(T_push_max=k_T * m.psi_f * i_top, T_load_all=load_torque(d, t_all) + m.T_coulomb, t_all=t_all)
    # the lock: the pulses' settling, and the observer's pull-in from as far as 90 el.deg off the axis (its triple
    # pole within 1.4 % in 8 / w_o), over which the pulses do not wait: they read the carrier's amplitude, not the angle
    t_lock = pol["t_lock"] + 8.0 / w_o
    st["c"].update(t_lock=t_lock, t_push=max(t_half, _Ts(d)), i_push_max=i_top, theta_max_deg=MOTION_MAX_DEG,
                   bound_deg=1.1 * (MOTION_MAX_DEG + math.degrees(want) * i_top / st["i_push"]))
    out["start.t_lock"] = Value(t_lock, "s", f"polarity.t_lock and 8 time constants of the injection's observer: its estimate "
                                "pulls in from as far as 90 el.deg off the axis before the turn is read from it")
    out["start.t_push"] = Value(st["c"]["t_push"], "s", (
        f"each half of the doublet; the turn is read {t_settle * 1e3:.3g} ms after it with no current flowing (the estimate "
        f"moves with the current by itself); a doublet 1.5 times larger where it did not reach the threshold, up to "
        f"{i_top:.4g} A"))
    return out


# -- the I/f start ----------------------------------------------------------------

def _if_handover(d: dict, m, source, bw_speed_given: bool) -> dict[str, Value]:
    """The speed the observer takes over at: where it is trusted (twice
    valid_rpm: its EMF about twice the voltage error it cannot tell from it,
    design.rules.design_band), and where its tracker (FS_SMO_BW_PER_W x the
    electrical speed, fs_smo.h) is IF_TRACKER_PER_SPEED_LOOP times the speed
    loop's bandwidth at the return speed (IF_RESTART of it: the lowest speed
    the loops run on it), at most IF_HANDOVER_MAX of rated speed; the speed
    loop slower where that cap holds the hand-over below it (on the zoo a
    tracker at 0.7 x the speed loop handed over under load through a
    reversal swung the speed +-80 rpm and ran off with the load)."""
    ctl, obs = d["controller"], d["observer"]
    p = m.pole_pairs
    out: dict[str, Value] = {}
    to_e = p * 2 * math.pi / 60   # rpm -> el. rad/s
    w_bw = IF_TRACKER_PER_SPEED_LOOP * ctl["bw_speed"] / (SMO_BW_PER_W * IF_RESTART)   # el. rad/s
    w_cap = IF_HANDOVER_MAX * m.w_m_rated * p
    if obs["start_handover_rpm"] is None:
        w_h, why = 2.0 * obs["valid_rpm"] * to_e, "twice valid_rpm: the observer is trusted from there (its EMF about twice the voltage error it cannot tell from it)"
        if w_bw > w_h:
            tracker = (f"where the observer's tracker, {SMO_BW_PER_W:g} x the electrical speed at {IF_RESTART:g} of it, is "
                       f"{IF_TRACKER_PER_SPEED_LOOP:g} x the speed loop's bandwidth ({ctl['bw_speed']:.4g} rad/s)")
            if w_bw <= w_cap:
                w_h, why = w_bw, tracker + ", above twice valid_rpm"
            elif w_cap > w_h:
                w_h, why = w_cap, f"{IF_HANDOVER_MAX:.0%} of rated speed, short of {tracker}"
            else:
                why += f" (short of {tracker}, above {IF_HANDOVER_MAX:.0%} of rated speed)"
        obs["start_handover_rpm"] = w_h / to_e
        out["observer.start_handover_rpm"] = Value(obs["start_handover_rpm"], "rpm", why)
    if not obs["start_handover_rpm"] > 0:   # a default that came out 0: the I/f start would never hand over
        raise ConfigError("observer.start_handover_rpm", obs["start_handover_rpm"], "must be > 0 (the default is twice valid_rpm): set it", source)
    bw_max = SMO_BW_PER_W * IF_RESTART * obs["start_handover_rpm"] * to_e / IF_TRACKER_PER_SPEED_LOOP
    if not bw_speed_given and ctl["bw_speed"] > bw_max:
        ctl["bw_speed"] = bw_max
        out["controller.bw_speed"] = Value(bw_max, "rad/s", (
            f"the observer's tracker at {IF_RESTART:g} x the hand-over speed over {IF_TRACKER_PER_SPEED_LOOP:g}: the lowest "
            "speed the loops run on it"))
    return out


def _load_at_low_speed(d: dict, w_rpm: float) -> float:
    """The largest load torque while the I/f frame may run: from the start
    until the reference has passed w_rpm, and wherever it comes back below
    (the return through zero), N m; on a grid of the run's breakpoints and
    1 ms."""
    load = d["load"]
    if load["kind"] not in ("torque", "brake"):
        return 0.0
    (t_w, w), (t_l, T) = d["references"]["speed_rpm"], load["torque"]
    t = np.union1d(np.union1d(t_w, t_l), np.arange(0.0, d["duration"], 1e-3))
    w_t, T_t = np.abs(np.interp(t, t_w, w)), np.abs(np.interp(t, t_l, T))
    low = w_t <= w_rpm
    first = int(np.argmax(~low)) if (~low).any() else t.size   # the start runs until the reference leaves the band
    low[:first] = True
    return float(np.max(T_t[low])) if low.any() else 0.0


def design_if(d: dict, m, source, bw_speed_given: bool = True) -> dict[str, Value]:
    """The I/f start into the back-EMF observer (fs_if_start.h): the speed
    the observer takes over at, the current, the frame's acceleration, the
    damping of the rotor's swing, the longest wait for the observer, the
    return to the frame at low speed; each with its reason."""
    ctl, obs = d["controller"], d["observer"]
    p, J = m.pole_pairs, m.J
    k_T = 0.5 * m.phases * p
    psi_f = m.psi_f   # the datasheet's (the scenario's *_scale are a controller's errors, unknown to the design)
    out: dict[str, Value] = {}
    if not psi_f > 0:
        raise ConfigError("observer.start", "if", f"needs a magnet flux: {m.name} has psi_f = {psi_f:g} Wb", source)
    out.update(_if_handover(d, m, source, bw_speed_given))
    T_L = _load_at_low_speed(d, obs["start_handover_rpm"]) + m.T_coulomb
    i_max = ctl["i_max"]
    c_load = math.cos(math.radians(IF_LOAD_ANGLE_DEG))
    s_load = math.sin(math.radians(IF_LOAD_ANGLE_DEG))
    dL = max(m.L_q - m.L_d, 0.0)

    def T_i(i):
        """The torque i makes at 90 el.deg of load angle, as it scales the one at IF_LOAD_ANGLE_DEG: the frame's d
        current lies at the load angle ahead of the rotor's d axis, and its part along that axis, i cos(delta),
        takes reluctance torque away where L_q > L_d: (phases/2) p i sin(delta) (psi_f - (L_q - L_d) i cos(delta))."""
        return k_T * i * (psi_f - dL * i * c_load)
    if obs["i_start"] is None:
        i_top = 0.8 * i_max   # the damping's current needs room within the limit
        need = T_L / (s_load - IF_ACCEL_SHARE)
        i_load = _largest(lambda x: T_i(x) <= need, 0.0, i_top) if T_i(i_top) >= need else i_top
        i = max(0.5 * i_max, i_load)
        why = "half of controller.i_max"
        if i > 0.5 * i_max:
            why = (f"carries the load and friction ({T_L:.3g} N m) with {IF_ACCEL_SHARE:g} of its torque to spare for "
                   f"accelerating, at a load angle of {IF_LOAD_ANGLE_DEG:g} el.deg (the reluctance torque of its d part "
                   "taken off)")
        if T_i(i_top) < need:
            why = f"0.8 x controller.i_max (room for the damping): carrying the load ({T_L:.3g} N m) with {IF_ACCEL_SHARE:g} to spare would need more"
        obs["i_start"] = i
        out["observer.i_start"] = Value(i, "A", why)
    Ti = T_i(obs["i_start"])
    share = min(IF_ACCEL_SHARE, s_load - T_L / Ti) if Ti > 0 else 0.0
    if obs["start_accel_rpm_s"] is None:
        if share < IF_ACCEL_SHARE_MIN:
            raise ConfigError("observer.i_start", obs["i_start"], f"makes {Ti:.3g} N m, which carries the load and friction "
                              f"({T_L:.3g} N m) at {IF_LOAD_ANGLE_DEG:g} el.deg with less than {IF_ACCEL_SHARE_MIN:g} of it to "
                              "accelerate: the I/f start cannot carry this load (a larger controller.i_max, or less load at "
                              "low speed)", source)
        obs["start_accel_rpm_s"] = rad_s_to_rpm(share * Ti / J)
        out["observer.start_accel_rpm_s"] = Value(obs["start_accel_rpm_s"], "rpm/s", (
            f"{share:.3g} of the start current's torque ({Ti:.3g} N m) accelerates J = {J:.3g} kg m^2"
            + (f"; the load ({T_L:.3g} N m) takes the rest at {IF_LOAD_ANGLE_DEG:g} el.deg" if T_L > 0 else "")))
    a_m = obs["start_accel_rpm_s"] * 2 * math.pi / 60
    # the swing about the frame: its stiffness at the load angle that carries the load and the acceleration,
    # d/d(delta) of k_T i sin(delta) (psi_f - dL i cos(delta))
    i0 = obs["i_start"]
    delta = math.asin(min((T_L + J * a_m) / max(Ti, 1e-12), 0.999))
    K = max(p * k_T * i0 * (psi_f * math.cos(delta) - dL * i0 * math.cos(2 * delta)), 1e-12)
    w_n = math.sqrt(K / J)
    Ts = _Ts(d)
    if obs["start_damping"] > 0:
        D = 2 * obs["start_damping"] * math.sqrt(K * J)
        r = k_T * p * psi_f ** 2 / D
        w_s = min(w_n, 0.1 / Ts)
        # the EMF's L di/dt with the controller's mean L where the plant's incremental one differs (saliency,
        # the d axis saturated by i_start) closes a loop of gain dL w / r_damp through the damping: at most
        # IF_SELF_LOOP at the band's top (4 w_swing)
        cm = {"L_d": m.L_d * ctl["L_d_scale"], "L_q": m.L_q * ctl["L_q_scale"]}   # the controller's, in the EMF
        L = 0.5 * (cm["L_d"] + cm["L_q"])
        L_inc = float(incremental_L_d(m, [obs["i_start"]], 0.01 * obs["i_start"])[0])
        dL_self = max(abs(L - L_inc), abs(L - cm["L_q"]), abs(L - cm["L_d"]))
        r_min = dL_self * 4 * w_s / IF_SELF_LOOP
        why = (f"damps the rotor's swing about the frame ({w_n:.3g} rad/s at {math.degrees(delta):.3g} el.deg of load angle) "
               f"at a ratio of {obs['start_damping']:g}: the current answers the EMF the swing makes as a stator "
               "resistance this small would")
        if r_min > r:
            why = (f"{r_min / r:.3g} x what damps the rotor's swing about the frame ({w_n:.3g} rad/s) at a ratio of "
                   f"{obs['start_damping']:g} ({r:.3g} ohm), so {obs['start_damping'] * r / r_min:.3g}: the controller's "
                   f"L ({L * 1e3:.3g} mH) is {dL_self * 1e3:.3g} mH off the plant's incremental ones at i_start, and the damping's "
                   f"loop through that error stays at {IF_SELF_LOOP:g} of unity at 4 w_swing")
            r = r_min
        d["start"]["c"].update(r_damp=r, w_swing=w_s)
        out["observer.start_r_damp"] = Value(r, "ohm", why)
    if obs["start_timeout"] is None:
        obs["start_timeout"] = max(IF_WAIT_MIN, IF_WAIT_TAUS / obs["bw_pll"])
        out["observer.start_timeout"] = Value(obs["start_timeout"], "s", (
            f"{IF_WAIT_TAUS:g} time constants of the observer's PLL ({obs['bw_pll']:.4g} rad/s), at least {IF_WAIT_MIN:g} s: "
            "the longest wait at the hand-over speed before the start counts as failed"))
    if obs["restart_rpm"] is None:
        obs["restart_rpm"] = IF_RESTART * obs["start_handover_rpm"]
        out["observer.restart_rpm"] = Value(obs["restart_rpm"], "rpm", (
            f"{IF_RESTART:g} x the hand-over speed, where the observer is still trusted: below it, with the "
            "reference below it too, the loops return to the I/f frame through the speeds the observer cannot see"))
    if not obs["restart_rpm"] < obs["start_handover_rpm"]:
        raise ConfigError("observer.restart_rpm", obs["restart_rpm"], f"must be below observer.start_handover_rpm "
                          f"({obs['start_handover_rpm']:g} rpm)", source)
    # the rotor's largest turn before the loops close: the alignment (up to pi), the ramp to the hand-over
    # speed and the longest wait there
    w_h = p * obs["start_handover_rpm"] * 2 * math.pi / 60
    a_e = p * a_m
    d["start"]["c"]["bound_deg"] = math.degrees(math.pi + w_h ** 2 / (2 * a_e) + w_h * obs["start_timeout"])
    return out
