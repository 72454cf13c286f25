"""Scenarios as data: a machine, its converter, timing, sensors, controller,
load and reference profiles, read from TOML (a catalog name or a file, with
`--set` merged in) and validated field by field. Nothing here designs or
runs: design.scenario fills in what a scenario leaves to the design and
checks what depends on it."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from .errors import ConfigError, MissingFields
from .files import package_names, path_kind
from .machines import MACHINE, Machine, catalog_data, catalog_names, parse_machine
from .schema import MISSING, B, C, F, I, N, NONNEG, POS, P, S, Spec, T, deep_merge, even_grid, finite_number, parse_toml, read_toml, validate
from .zoo import SEED as ZOO_SEED
from .zoo import machine as zoo_machine

SCENARIO = {
    "name": S(doc="the scenario's name (out/<name>/ by default)"), "description": S("", doc="one line for `fullspeed list`"),
    "paper": S("", doc="the paper it reproduces, if any"),
    "duration": POS(hi=1e4, doc="simulated time, s"),
    "machine": Spec("any", MISSING, doc="a catalog name, a machine file (.toml), or a table: the fields of [machine] below, or catalog = \"name\" and the fields to override"),
    "plant_machine": Spec("any", None, doc="the machine the simulation turns where it is not `machine`, the one the drive knows and is "
                          "designed from (an identified machine file there, the true machine here): given as `machine` is; "
                          "its phases and pole pairs must be the machine's. Its windings, magnetics and mechanics are the "
                          "plant's; the converter, the sensors, the losses, the heating and the harmonics stay `machine`'s"),
    "converter": T({
        "kind": C("inverter", "imc", default="inverter",
                  doc="imc: the indirect matrix converter of zou2021 (grid, LC filter, rectifier and inverter stages)"),
        "inverter": C("averaged", "switching", default=None, doc="default switching; the imc's is averaged per rectifier interval"),
        "u_dc": POS(None, hi=1e5, doc="V; default the machine's bench"), "f_pwm": F(None, lo=100.0, hi=1e6, doc="Hz, PWM carrier; default the machine's bench"),
        "t_dead": NONNEG(None, hi=1e-4, doc="s, dead time; default the machine's bench"), "u_on": NONNEG(0.0, hi=1e3, doc="V, device on-state drop"),
        "r_on": NONNEG(0.0, hi=1e3, doc="ohm, device on-state resistance: the drop is sign(i) u_on + r_on i"),
        # the matrix converter (defaults from the machine's bench)
        "modulation": C("linear", "om1", "om2", default="om2",
                        doc="imc: the highest region (zou2021 sec. 3.3): linear, over-modulation I (CASE 1) or II (CASE 1 and 2)"),
        "grid_ll_rms": POS(None, hi=1e5, doc="V, line-line rms"), "f_grid": POS(None, hi=1e4, doc="Hz"),
        "l_filter": POS(None, hi=10.0, doc="H"), "r_filter": POS(None, hi=1e6, doc="ohm, in parallel with l_filter"), "c_filter": POS(None, hi=10.0, doc="F"),
    }, default={}),
    "timing": T({
        "sampling": C("single", "double", default=None, doc="current sampling once or twice per PWM period; default the machine's bench"),
        "delay": B(True, doc="one control period of computation delay"),
        "h_max": F(None, lo=1e-9, hi=1e-3, doc="longest integration step, s; default from the machine's time constants; at least 1/1000 of the control period"),
    }, default={}),
    "sensors": T({
        "adc_bits": I(None, 0, 24, doc="current ADC resolution (0: ideal); default the machine's bench"),
        "adc_range": POS(None, hi=1e6, doc="A, the ADC's +- full scale; default the machine's bench"),
        "noise_i": NONNEG(None, hi=1e4, doc="A, rms current-sensor noise; default the machine's bench"),
        "encoder_bits": I(None, 0, 32, doc="encoder resolution (0: ideal); default the machine's bench"),
        "seed": I(1, 0, 2**63 - 1, doc="the noise generator's seed"),
    }, default={}),
    "controller": T({
        "mode": C("off", "voltage", "vf", "current", "speed", doc="what the drive controls: nothing, dq voltages, V/f, currents or speed (the references below)"),
        "angle": C("encoder", "true", "smo", "hfi", "blend", "swvi", default="encoder",
                   doc="the loops' angle: encoder, the true angle, the sliding-mode observer, rotating HF injection, their blend, or square-wave injection"),
        "gains": C("designed", "internal_model", "paper", default="designed",
                   doc="PI gains: designed from the bandwidths (the current PIs by pole placement, or internal_model: "
                       "k_p = bw_current L, k_i = bw_current R_s, zou2021's), or the machine's [paper_gains]"),
        "bw_current": POS(None, hi=1e6, doc="rad/s, current loop; default the machine's bench (designed)"),
        "bw_speed": POS(None, hi=1e6, doc="rad/s, speed loop; default the machine's bench (designed)"),
        "bw_pll": POS(None, hi=1e6, doc="rad/s, the encoder's speed PLL; default the machine's bench (designed)"),
        "i_max": POS(None, hi=1e5, doc="A, current limit; default the machine's bench (designed)"),
        "T_max": POS(None, hi=1e6, doc="N m, torque limit; default the MTPA torque at i_max"),
        "dead_time_comp": B(True, doc="compensate the converter's dead time"),
        "i_dead_band": NONNEG(None, hi=1e5, doc="A, below this the dead-time compensation ramps to zero; default 1 % of i_max"),
        "dead_time_predict": B(None, doc="the compensation takes each edge's sign from the current predicted there "
                                         "(fs_dtcomp.h); default true where the drive injects (angle hfi or blend): the "
                                         "carrier's current crosses zero within the period at standstill"),
        "xy_control": B(False, doc="five phases: PI control of the x-y current in the d3-q3 frame at bw_current (fs_xyctrl.h)"),
        "vf_gain": NONNEG(0.0, hi=1e3, doc="V per electrical rad/s"), "vf_boost": NONNEG(0.0, hi=1e5, doc="V, V/f boost at zero frequency"),
        # the controller's parameters relative to the true machine's
        "R_s_scale": F(1.0, lo=0.01, hi=100.0, doc="the controller's R_s over the machine's (a mismatch)"),
        "L_d_scale": F(1.0, lo=0.01, hi=100.0, doc="the controller's L_d over the machine's"),
        "L_q_scale": F(1.0, lo=0.01, hi=100.0, doc="the controller's L_q over the machine's"),
        "psi_f_scale": F(1.0, lo=0.01, hi=100.0, doc="the controller's psi_f over the machine's"),
        "J_scale": F(1.0, lo=0.01, hi=100.0, doc="the controller's J over the machine's"),
        "flux_weakening": B(False, doc="speed mode: flux weakening above the base speed (fw_method says how)"),
        "fw_method": C("planned", "feedback", default=None,
                       doc="default planned on a three-phase inverter, feedback with five phases or the matrix "
                           "converter (the plan's voltage limit is the three-phase VSI's); \"planned\": the current references within the voltage limit at each speed, planned on the "
                           "machine's flux map (fs_fwmap.h; a machine given by L_d, L_q, psi_f: the map those make), with "
                           "a trim on the voltage asked; \"feedback\": zou2021's PART_1, a d current from the voltage "
                           "error on top of MTPA (fs_fw.h; fw_top_speed_rpm, fw_gain, fw_cutoff and fw_excess are its), "
                           "on machines given by constants only"),
        # zou2021 PART_1 voltage-error-feedback flux weakening on top of MTPA (fw_method = "feedback")
        "fw_top_speed_rpm": POS(None, hi=1e6, doc="w_r,max of eq. (31); default the observer's top speed"),
        "fw_gain": POS(None, hi=1e6, doc="multiplies beta of eq. (31): the loop's dc gain at the top speed (the paper: 1); default designed in the drive's init (fs_drive.h: 50 wound back, 1/4 held)"),
        "fw_cutoff": POS(None, hi=1e6, doc="rad/s, the low-pass of eq. (30); default designed in the drive's init (fs_drive.h; the paper: bw_current)"),
        "fw_excess": C("wound_back", "held", default="wound_back",
                       doc="the over-modulation excess flux weakening feeds on: wound back by the current PIs' anti-windup "
                           "(eq. (30) then holds i_d on a standing current error), or held in their integrals as zou2021's "
                           "eq. (26) reads (with gains = \"internal_model\"; fs_fw.h)"),
        # zou2021 PART_2: the matrix converter's rectifier modulation-depth controller
        "depth_control": B(False, doc="imc, speed mode with flux weakening and modulation om2: alpha from eq. (33); else from the demanded VTR"),
        "i_lim": POS(None, hi=1e5, doc="A, I_lim of eq. (33); default the machine's bench i_lim"),
        # loss of lock of the estimator the loops use (fs_lock.h)
        "lock": C("off", "detect", "stop", "recover", default=None,
                  doc="what the drive does when it loses lock: recover: zero current, then at speed a flying restart "
                      "on the back-EMF observer, at low speed the start sequence again, else the stop with the PWM off "
                      "(fs_drive_protect.h), and the stop once lock_retries are spent; stop: the stop at once (stop reason "
                      "loss_of_lock); detect: traced only (lock_resid, lock_lost), the drive goes on; default recover, "
                      "stop with angle = \"swvi\" (no restart sequence)"),
        "lock_time": POS(0.02, hi=10.0, doc="s off track, net (each step weighted by how far over, up to twice: fs_lock.h), before lock counts as lost"),
        "recover_time": POS(0.05, hi=10.0, doc="s of zero current before a recovery re-acquires"),
        "lock_retries": I(3, 0, 1000, doc="recoveries before a loss of lock stops the run"),
        "overspeed_rpm": NONNEG(None, hi=1e6, doc="the drive stops with the PWM off above this speed (stop reason overspeed; "
                                "fs_drive_protect.h); default designed: 1.2 x the fastest the drive is designed for or asked "
                                "(fullspeed design); 0: no overspeed stop"),
        "torque_slew": NONNEG(None, hi=1e9, doc="N m/s: while the injection runs (speed mode, angle hfi or blend; refused "
                              "elsewhere), the speed loop's torque changes at most this fast; default designed: what the injection's observer follows within "
                              "5 el.deg if the shaft does not move with it (a load machine, a vehicle); 0: no limit"),
        "param_adapt": B(False, doc="online correction of R_s and psi_f while sensorless (fs_param_adapt.h)"),
        "adapt_time": POS(5.0, hi=1e4, doc="s, its least squares' forgetting time: long against the drive's cycle of operating points, short against the machine's heating"),
    }),
    # the estimator (yang2022 sec. 2); used from `handover` on, running from t = 0
    "observer": T({
        "handover": NONNEG(0.0, hi=1e4, doc="s: the loops switch from the encoder to the observer"),
        "k": NONNEG(0.0, hi=1e6, doc="V; 0: margin x the bound of eq. (18)"),
        "margin": F(1.5, lo=1.0, hi=100.0, lo_open=True, doc="the SMO gain over its bound of eq. (18) when k = 0"),
        "delta": NONNEG(0.0, hi=1e5, doc="A; floored at k Ts / L_d"),
        "cutoff_min_rpm": POS(None, hi=1e6, doc="floor of the adaptive filter's cutoff, as a mechanical speed; default 1/8 of the lower blending speed (yang2022: 20 rpm)"),
        "bw_pll": POS(None, hi=1e6, doc="rad/s; default from the machine's bench"),
        "valid_rpm": NONNEG(None, hi=1e6, doc="the observer's estimate is trusted above this speed; default 5/8 of the lower blending speed (yang2022: 100 rpm)"),
        "top_speed_rpm": POS(None, hi=1e6, doc="for the gain bound; default 1.5 x rated, or 1.1 x the fastest speed the scenario asks where that is more"),
        "lag": C("exact", "paper", default="exact", doc="form = \"paper\": the adaptive filter's phase lag compensated exactly, or by pi/4 as the paper writes it"),
        "form": C("paper", "tracking", default="tracking",
                  doc="tracking: fullspeed's, exact in discrete time, with a motion observer on the measured torque whose "
                      "bandwidth follows the EMF (fs_smo.h); paper: the SMO and PLL of yang2022 sec. 2 (its scenarios pin it)"),
        # how the sensorless drive starts: on the encoder until `handover`, or
        # sensorless from standstill with an I/f start
        "start": C("encoder", "if", default="encoder", doc="sensorless start: on the encoder until handover, or I/f from standstill (fs_if_start.h)"),
        "i_start": POS(None, hi=1e5, doc="A, the I/f frame's d current; default half of i_max, or what carries the load at 45 el.deg with a quarter to spare (at most 0.8 i_max)"),
        "start_accel_rpm_s": POS(None, hi=1e9, doc="frame acceleration; default the start current's torque left beside the load, at most a quarter of it, over J"),
        "start_handover_rpm": POS(None, hi=1e6, doc="the loops take the observer here; default twice valid_rpm"),
        "start_damping": NONNEG(0.7, hi=10.0, doc="the damping ratio of the rotor's swing about the I/f frame, by the EMF it makes (fs_if_start.h); 0: none"),
        "start_timeout": POS(None, hi=1e4, doc="s, the longest wait at the hand-over speed for the observer, then the run stops (start_failed); default 100 / bw_pll, at least 0.5 s"),
        "restart_rpm": NONNEG(None, hi=1e6, doc="below this, with the reference below it too, the loops return from the observer to the I/f frame (a reversal through zero); default 0.75 x start_handover_rpm; 0: never"),
    }, default={}),
    # the sensorless start from standstill with injection (hfi, blend) or
    # without (design.start): chosen by the machine unless named here
    "start": T({
        "method": C("designed", "pulses", "motion", "if", default="designed",
                    doc="designed: polarity pulses where the d axis saturates asymmetrically, else a bounded motion test "
                        "where the injection has saliency to use, else (angle blend) an I/f start into the back-EMF "
                        "observer; pulses, motion or if to name one"),
        "allow_motion": B(True, doc="false: no start that turns the rotor (the motion test, the I/f start): the polarity "
                                    "pulses, which refuse to start where they cannot decide (stop reason polarity_undetermined)"),
        "i_push": POS(None, hi=1e5, doc="A, the motion test's q-current push; default designed from J, psi_f and the load (fs_motion_test.h)"),
        "turn_deg": POS(None, hi=20.0, doc="el.deg, the injection estimate's turn that decides the motion test; default 4 (doubled where the estimate is noisier)"),
    }, default={}),
    # HF voltage injection: rotating (yang2022 sec. 3) for angle = "hfi" or
    # "blend", square-wave (yu2022 sec. 2) for angle = "swvi"
    "injection": T({
        "u_h": POS(None, hi=1e4, doc="V; default the machine's [injection]"),
        "f_h": POS(None, hi=1e5, doc="Hz; default the machine's [injection], else designed: f_s / 10, fewer samples a period where the current loop would act on the carrier's sidebands (fullspeed design); at most a quarter of the sampling rate"),
        "bw_filter_p": POS(None, hi=1e6, doc="rad/s, SRFF at +w_h; default w_h / 20 (fs_hfi.h)"),
        "bw_filter_n": POS(None, hi=1e6, doc="rad/s, SRFF at -w_h + 2 w_r; default w_h / 20"),
        "bw_observer": POS(None, hi=1e6, doc="rad/s, motion observer; default bw_filter_n (tracking = \"paper\": bw_filter_n / 5)"),
        "tracking": C("paper", "lag", default="lag",
                      doc="hfi/blend: lag designs the motion observer with the negative-sequence filter's lag in its loop "
                          "(fs_motion_obs.h: five times faster, less error under a load it does not know), the loops' "
                          "speed from a second observer at the paper's rule on its angle (fs_hfi.h); paper: Fig. 5 on "
                          "the error as it is (the yang2022 scenarios pin it)"),
        "leak": C("keep", "remove", default=None,
                  doc="hfi/blend: remove takes the fundamental's leak out of the negative carrier (fs_hfi_filter.h: no "
                      "load-proportional bias); keep: the paper's filter; default remove with tracking = \"lag\" (whose "
                      "observer is designed for the double lag it makes), keep with \"paper\" (whose observer, blind to "
                      "that lag, rings with it)"),
        "xcomp": Spec("any", None, doc="cross-saturation table {i_q = [A...], delta_deg = [...]} on an even grid, or a TOML file holding it, or (swvi) \"paper\": the machine's fitted error polynomial, or false: none; left out, the rotating injection's is designed from a flux map or an algebraic model (design.xcomp)"),
        "stop_rpm": POS(None, hi=1e6, doc="blend: the injection stops above this speed (resumes below 0.9 of it); default 1.2 x the upper blending speed"),
        "sequence": C("optimized", "conventional", default="optimized", doc="swvi: the time sequence of yu2022 sec. 3.2"),
        "bw_pll": POS(None, hi=1e6, doc="swvi: PLL bandwidth, rad/s (k_p = 2 w_b, k_i = w_b^2); default the machine's [injection]"),
        "carrier": B(True, doc="swvi: false keeps the loops' timing without the carrier (comparison runs, on the encoder)"),
    }, default={}),
    "polarity": T({
        "enabled": B(True, doc="detect the magnet polarity before starting sensorless on injection"),
        "i_pulse": POS(None, hi=1e5, doc="A, d-current pulses; default half of controller.i_max"),
        "t_lock": NONNEG(None, hi=10.0, doc="s, the estimator settles first: >= 6 / w_b_n + 2 / w_o (fade-in, filters, observer; w_o the slower observer's, with tracking = \"lag\" the speed's); default 0.06 s or that bound x 1.2, the longer"),
        "t_pulse": POS(None, hi=10.0, doc="s, each pulse: >= 6 / w_b_p (the carrier amplitude settles in the first half); default 0.02 s or that bound x 1.2, the longer"),
        "i_pulse_max": POS(None, hi=1e5, doc="A, the largest pulse of the retries when the first pair decides nothing; default controller.i_max less the carrier's peak"),
    }, default={}),
    "blending": T({
        "lower_rpm": NONNEG(None, hi=1e6, doc="eq. (28), the injection alone below; default the machine's [blending], else designed"),
        "upper_rpm": POS(None, hi=1e6, doc="eq. (28), the back-EMF observer alone above; default the machine's [blending], else designed"),
        "bw_observer": POS(None, hi=1e6, doc="rad/s, the motion observer after the blend (Fig. 6); default that of the injection's (with injection.tracking = \"lag\": the paper's rule, bw_filter_n / 5)"),
        "gate": B(True, doc="the SMO's weight only once it has converged, the injection stopped only then (fs_blend.h); false: eq. (28) alone (the paper's)"),
    }, default={}),
    "load": T({
        "kind": C("torque", "speed", "speed_pi", "brake", default="torque",
                  doc="brake: a passive brake (powder, eddy current), torque = its magnitude against the motion"),
        "torque": P(0.0, hi=1e6, doc="N m, kind torque or brake"), "speed_rpm": P(0.0, hi=1e6, doc="kind speed or speed_pi: the speed the load holds"),
        "torque_pu": P(None, hi=100.0, doc="the torque as a fraction of the machine's rated torque (instead of torque)"),
        "bandwidth": POS(100.0, hi=1e6, doc="load machine speed loop, rad/s"), "J_load": NONNEG(0.0, hi=1e5, doc="kg m^2, the load machine's inertia (speed_pi)"),
    }, default={}),
    "references": T({
        "speed_rpm": P(0.0, hi=1e6, doc="mode speed"), "i_d": P(0.0, hi=1e5, doc="A, mode current"), "i_q": P(0.0, hi=1e5, doc="A, mode current"),
        "speed_pu": P(None, hi=100.0, doc="the speed as a fraction of the machine's rated speed (instead of speed_rpm)"),
        "u_d": P(0.0, hi=1e5, doc="V, mode voltage"), "u_q": P(0.0, hi=1e5, doc="V, mode voltage"),
        "frame_rpm": P(0.0, hi=1e6, doc="modes voltage and vf: the frame's speed"),
    }, default={}),
    "initial": T({"theta_e_deg": F(0.0, -360.0, 360.0, doc="the rotor's angle at t = 0"), "speed_rpm": F(0.0, -1e6, 1e6, doc="the rotor's speed at t = 0")}, default={}),
    # faults of the drive's hardware, each from its time on (fs_sim.h); a load
    # impact is a [load] torque profile
    "faults": T({
        "t_sensor": NONNEG(0.0, hi=1e4, doc="s: the current-sensor errors act from here"),
        "i_offset": N([], doc="A added to each phase's sensed current (a, b, c, ...)"),
        "i_gain": N([], doc="each phase sensor's relative gain error (0.1 reads 10 % high)"),
        "open_phase": C("none", "a", "b", "c", default="none", doc="three phases on the inverter"),
        "t_open": NONNEG(0.0, hi=1e4, doc="s"),
        "t_encoder_stop": POS(None, hi=1e4, doc="s: the encoder's reading freezes here"),
        "u_dc_scale": P(1.0, hi=10.0, doc="the dc link relative to converter.u_dc: a sag or a step (inverter)"),
    }, default={}),
    # the machine's heating (its [thermal] table, csrc/plant/fs_thermal.h)
    "thermal": T({
        "enabled": B(False, doc="R_s and the magnet follow the winding's and magnets' temperatures"),
        "time_scale": F(1.0, lo=1.0, hi=1e6, doc="the heat capacities divided by this: minutes of heating in seconds"),
        "T_amb": F(None, lo=-50.0, hi=300.0, doc="degC; default the machine's"),
        "T_winding0": F(None, lo=-50.0, hi=300.0, doc="degC; default the ambient"),
        "T_magnet0": F(None, lo=-50.0, hi=300.0, doc="degC; default the ambient"),
    }, default={}),
    # where the power goes: the converter's devices and the machine's iron loss act on the plant, every loss metered
    # (csrc/plant/fs_losses.h; the trace's E_dc, E_cond, E_rect, E_sw, E_fe, E_mech, E_shaft)
    "losses": T({
        "devices": B(False, doc="the machine's [converter] module: its conduction drops act on the plant, its commutation "
                                "energies are drawn from the converter's source (false: ideal switches, or converter.u_on, r_on)"),
        "iron": B(False, doc="the machine's [losses] iron loss drawn from the shaft as a drag torque"),
        "trace": B(False, doc="run the loss meters also with neither (on with either)"),
    }, default={}),
    # the machine's spatial harmonics (its [harmonics] table, csrc/plant/fs_pmsm.h)
    "harmonics": T({"enabled": B(False, doc="the flux depends on the rotor angle: back-EMF and saliency harmonics, cogging")},
                   default={}),
    # `fullspeed identify`: the drive's self-commissioning (csrc/control/fs_ident.h) on this scenario's
    # machine and bench; the scenario's own controller, references and load are not used
    "identify": T({
        "may_turn": B(True, doc="the rotor may turn: after the standstill steps an I/f spin measures psi_f, the map's d axis "
                                "at speed, J and friction; false: standstill steps only (psi_f, J and friction from the "
                                "machine file, marked not identified), and a free rotor whose polarity they cannot see "
                                "(no saturation asymmetry) is refused: it needs locked = true"),
        "locked": B(False, doc="the rotor is locked (a brake, a fixture): standstill steps only, the map's q sweeps without "
                               "a motion bound; the simulation holds the shaft at zero speed"),
        "map": B(True, doc="identify the flux map psi_d(i_d, i_q), psi_q(i_d, i_q) over the current limit's disc: "
                           "fluxmap.csv beside machine.toml (the grid) and fluxmap-measured.csv (the points read)"),
        "i_test": POS(None, hi=1e5, doc="A, the standstill levels' top d current (R_s and the inverter's error); default 0.6 x "
                                        "the current limit; on a free rotor on its north pole only and at most half of "
                                        "psi_f / (L_q - L_d) (the magnet's pull then beats the reluctance torque's push); "
                                        "polarity unknown and locked, at +i and -i"),
        "t_level": POS(None, hi=10.0, doc="s, the top three levels' window per sign (the others half of it); default 0.1, "
                                          "at least 100 control periods"),
        "motion_max_deg": F(1.0, lo=0.0, hi=90.0, lo_open=True,
                            doc="el.deg, the swing the map's q sweeps may give a free rotor: their rise is sized from the "
                                "machine file's psi_f and J, their amplitude lowered where the voltage cannot rise faster"),
        "speed_frac": F(0.3, lo=0.0, hi=1.0, lo_open=True, doc="the running steps' speed, as a fraction of rated (lowered where the "
                                                               "back-EMF would pass half the linear voltage)"),
        "t_ramp": POS(1.0, hi=1e3, doc="s, the I/f ramp to that speed (at least 100 control periods)"),
        "t_limit": POS(30.0, hi=1e4, doc="s simulated before the identification counts as stuck (reported with its step)"),
    }, default={}),
    "trace": T({"decimation": I(1, 1, 10**6, doc="record every n-th control period")}, default={}),
    "metrics": T({"steady": Spec("any", None, doc="[t_start, t_end] s, the steady window; default the last flat stretch of the references and load after the loop settles, none where less than one time constant of the loop is left (fullspeed.sim.metrics)")}, default={}),
}


@dataclass(frozen=True)
class Scenario:
    name: str
    machine: Machine
    data: dict          # validated, with the bench's values filled in
    source: str | None = None
    # "section.key" -> design.Value for every setting that was designed or
    # given (where it came from, and why), and one-line warnings about what
    # the scenario asks (feasibility, plausibility, what polarity detection
    # cannot see)
    design: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    plant: Machine | None = None   # the machine the simulation turns where it is not `machine` (plant_machine)

    @property
    def duration(self) -> float:
        return self.data["duration"]

    def section(self, key: str) -> dict:
        return self.data[key]


def scenario_names() -> list[str]:
    return package_names("scenarios")


def _machine_file(raw: str, source) -> Path:
    """A machine file named by a scenario: beside the scenario first."""
    p = Path(raw)
    if not p.is_absolute() and source and path_kind(Path(source).parent / p) == "file":
        p = Path(source).parent / p
    return p


def _machine_of(raw, source) -> Machine:
    if isinstance(raw, str) and raw.endswith(".toml"):
        p = _machine_file(raw, source)
        return parse_machine(read_toml(p, "machine"), str(p))
    if isinstance(raw, str):
        raw = {"catalog": raw}
    if not isinstance(raw, dict):
        raise ConfigError("machine", raw, "must be a catalog name, a machine file (.toml) or a table", source)
    raw = dict(raw)
    if "zoo" in raw:   # a machine of the seeded zoo (model.zoo), its fields overridable
        k, seed = raw.pop("zoo"), raw.pop("zoo_seed", ZOO_SEED)
        for key, v in (("machine.zoo", k), ("machine.zoo_seed", seed)):
            whole = isinstance(v, int) or (isinstance(v, float) and v.is_integer())   # a sweep's range gives floats
            if isinstance(v, bool) or not whole or not 0 <= v < 2**31:
                raise ConfigError(key, v, "must be an integer in 0 .. 2^31 - 1", source)
        k, seed = int(k), int(seed)
        return parse_machine(deep_merge(zoo_machine(k, seed), raw), source)
    name = raw.pop("catalog", None)
    if name is not None:
        if not isinstance(name, str):
            raise ConfigError("machine.catalog", name, "must be a catalog name (string)", source)
        base = catalog_data(name, source)
        return parse_machine(deep_merge(base, raw), source)
    return parse_machine(raw, source)


def plant_machine(d: dict, m: Machine, source: str | None = None) -> Machine | None:
    """The scenario's plant_machine, parsed (None where it has none): the
    machine the simulation turns in place of m, with m's phases and pole
    pairs (a drive designed for another pole count is another drive)."""
    if d.get("plant_machine") is None:
        return None
    pm = _machine_of(d["plant_machine"], source)
    for key in ("phases", "pole_pairs"):
        if getattr(pm, key) != getattr(m, key):
            raise ConfigError(f"plant_machine.{key}", getattr(pm, key), f"must be the machine's ({getattr(m, key)}): "
                              "the drive is designed for that machine", source)
    return pm


def parse_scenario(data: dict, source: str | None = None) -> tuple[dict, Machine]:
    """A scenario table validated field by field, with its machine as given
    (parse_machine): every required field of both refused together, the
    profiles given per unit turned into SI, and the fields checked that
    need nothing designed (faults, heating, harmonics, the x-y control,
    the steady window)."""
    if not isinstance(data, dict):
        raise ConfigError("scenario", data, "must be a table", source)
    _refuse_machine_file(data, source)
    missing = []   # the scenario's required fields not given, and its machine's, refused together
    d = validate(data, SCENARIO, "", source, missing)
    if missing:
        if "machine" in d:
            try:
                _machine_of(d["machine"], source)
            except MissingFields as exc:
                missing += exc.entries
        raise MissingFields(missing)
    m = _machine_of(d["machine"], source)
    _per_unit(d, data, m, source)
    _fault_fields(d, m, source)
    _thermal_fields(d, m, source)
    _losses_fields(d, m, source)
    if d["controller"]["xy_control"] and m.phases != 5:
        raise ConfigError("controller.xy_control", True, "needs a five-phase machine (the x-y plane)", source)
    steady = d["metrics"]["steady"]
    if steady is not None:
        ok = (isinstance(steady, list) and len(steady) == 2
              and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in steady)
              and 0 <= steady[0] < steady[1] <= d["duration"])
        if not ok:
            raise ConfigError("metrics.steady", steady, f"must be [t_start, t_end] with 0 <= t_start < t_end <= duration ({d['duration']:g})", source)
    return d, m


def _refuse_machine_file(data: dict, source: str | None) -> None:
    """A machine file given where a scenario belongs (`fullspeed run
    my48v.toml`): refused as what it is, with the way a scenario takes it,
    not by the first of its keys a scenario does not know."""
    own = [k for k in data if k in MACHINE and k not in SCENARIO]
    if own and "machine" not in data:
        file = Path(source).name if source else "the machine's file"
        key = "pole_pairs" if "pole_pairs" in own else own[0]   # the field no scenario could mean
        raise ConfigError(key, data[key], f"a machine's field, not a scenario's: this is a machine file; a scenario "
                          f"names it (machine = \"{file}\", beside its duration and references; "
                          "examples/own-machine/my48v-full-range.toml is one)", source)


def _per_unit(d: dict, data: dict, m: Machine, source) -> None:
    """Profiles given per unit of the machine's rating, into SI/rpm ones."""
    for sec, pu, key, base in (("references", "speed_pu", "speed_rpm", m.w_m_rated * 60 / (2 * math.pi)),
                               ("load", "torque_pu", "torque", m.T_rated)):
        if d[sec][pu] is None:
            continue
        if key in data.get(sec, {}):
            raise ConfigError(f"{sec}.{pu}", "given", f"and {sec}.{key} are one setting: give one of them", source)
        t, y = d[sec][pu]
        d[sec][key] = (t, [v * base for v in y])


def _thermal_fields(d: dict, m: Machine, source) -> None:
    if d["harmonics"]["enabled"]:
        if m.harmonics is None:
            raise ConfigError("harmonics.enabled", True, f"needs a [harmonics] table in the machine {m.name}", source)
        if m.phases != 3:
            raise ConfigError("harmonics.enabled", True, "spatial harmonics are modelled on three-phase machines", source)
        if d["faults"]["open_phase"] != "none":
            raise ConfigError("harmonics.enabled", True, "not modelled with an open phase (faults.open_phase)", source)
    th = d["thermal"]
    if not th["enabled"]:
        return
    if m.thermal is None:
        raise ConfigError("thermal.enabled", True, f"needs a [thermal] table in the machine {m.name}", source)
    if m.magnetic["model"] == "fluxmap":
        raise ConfigError("thermal.enabled", True, "a flux map's magnet temperature is not modelled: "
                          "the machine's magnetic model must be linear or algebraic", source)
    if th["T_amb"] is None:
        th["T_amb"] = m.thermal["T_amb"]
    for key in ("T_winding0", "T_magnet0"):
        if th[key] is None:
            th[key] = th["T_amb"]


def _losses_fields(d: dict, m: Machine, source) -> None:
    los, conv = d["losses"], d["converter"]
    if los["devices"]:
        if m.converter is None:
            raise ConfigError("losses.devices", True, f"needs a [converter] table in the machine {m.name}: the module's "
                              "datasheet values (fullspeed schema machine.converter)", source)
        for key in ("u_on", "r_on"):
            if conv[key]:
                raise ConfigError(f"converter.{key}", conv[key], "must be 0 with losses.devices (the drops are the "
                                  "module's, machine [converter]: one setting in one place)", source)
    if los["iron"] and m.losses is None:
        raise ConfigError("losses.iron", True, f"needs a [losses] table in the machine {m.name}: its iron loss "
                          "coefficients (fullspeed schema machine.losses)", source)


def _fault_fields(d: dict, m: Machine, source) -> None:
    f = d["faults"]
    for key, lo, hi in (("i_offset", -1e5, 1e5), ("i_gain", -0.99, 10.0)):
        v = f[key]
        if len(v) > m.phases or not all(lo <= x <= hi for x in v):
            raise ConfigError(f"faults.{key}", v, f"must list at most {m.phases} values (phases a, b, ...), each in [{lo:g}, {hi:g}]", source)
    if f["open_phase"] != "none" and (m.phases != 3 or d["converter"]["kind"] != "inverter"):
        raise ConfigError("faults.open_phase", f["open_phase"], "is modelled on a three-phase machine fed by the inverter", source)
    scale = f["u_dc_scale"][1]
    if min(scale) < 0.01:
        raise ConfigError("faults.u_dc_scale", min(scale), "must stay >= 0.01 (a dc link that collapses to zero is a stop, not a sag)", source)
    if d["converter"]["kind"] != "inverter" and any(x != 1.0 for x in scale):
        raise ConfigError("faults.u_dc_scale", scale, "applies to the inverter's dc link (the matrix converter's follows the grid)", source)


def _xcomp_path(raw: str, source) -> Path:
    """A table's file: a relative path against the scenario's own folder
    first, then the working directory; else a table shipped with the
    package, by name."""
    p = Path(raw)
    here = [Path(source).parent / p] if source and path_kind(source) == "file" and not p.is_absolute() else []
    for t in here + [p, Path(str(resources.files("fullspeed") / "calibration" / f"{raw}.toml"))]:
        if path_kind(t) is not None:
            return t
    raise ConfigError("injection.xcomp", raw, "file not found (nor a table in fullspeed/calibration)", source)


def xcomp_table(raw, source) -> dict:
    """The cross-saturation table: inline, or the path of a TOML file holding it."""
    where = "injection.xcomp"
    if isinstance(raw, str):
        p = _xcomp_path(raw, source)
        try:
            raw = read_toml(p, where, source)
        except ConfigError as exc:   # name the field, and the file in it
            raise ConfigError(where, raw, f"{p}: {exc.allowed}", source) from None
        raw = raw.get("xcomp", raw)
    # what `fullspeed calibrate` writes beside the table (its provenance and quality) is accepted and not used;
    # the settings it was measured with are kept for design.xcomp.check_table_settings
    if not isinstance(raw, dict) or set(raw) - {"i_q", "delta_deg", "source", "spread_deg", "speed_rpm", "residual_deg", "settings"} \
            or not {"i_q", "delta_deg"} <= set(raw):
        raise ConfigError(where, raw if not isinstance(raw, dict) else sorted(raw), "must be a table with i_q = [A...] and delta_deg = [el.deg...]", source)
    i_q, delta = raw["i_q"], raw["delta_deg"]
    ok = (isinstance(i_q, list) and isinstance(delta, list) and 2 <= len(i_q) == len(delta) <= 33
          and all(finite_number(x) for x in i_q + delta))
    if not ok:
        raise ConfigError(where, "table", "i_q and delta_deg must be lists of 2..33 finite numbers of the same length", source)
    if not even_grid(i_q):
        raise ConfigError(f"{where}.i_q", i_q, "must rise in even steps", source)
    if not all(abs(x) < 90.0 for x in delta):
        raise ConfigError(f"{where}.delta_deg", delta, "must lie within +-90 el.deg", source)
    out = {"i_q": [float(x) for x in i_q], "delta_deg": [float(x) for x in delta]}
    if "settings" in raw:
        st = raw["settings"]
        if not isinstance(st, dict) or not all(isinstance(v, (str, int, float)) and not isinstance(v, bool) for v in st.values()):
            raise ConfigError(f"{where}.settings", st, "must be a table of the settings it was measured with (names and numbers)", source)
        out["settings"] = {k: float(v) if isinstance(v, int) else v for k, v in st.items()}
    return out


def scenario_data(name_or_path: str | Path, overrides: dict | None = None) -> tuple[dict, str]:
    """A catalog scenario by name, or a TOML file by path, as its table and
    where it came from; overrides (--set) are merged into it."""
    p = Path(name_or_path)
    names = scenario_names()
    # a file by that name wins; a folder by a catalog name (an earlier run's
    # --out) does not shadow the catalog
    kind = path_kind(p)
    if p.suffix == ".toml" or kind == "file" or (str(name_or_path) not in names and kind is not None):
        source = str(p)
        data = read_toml(p, "scenario")
    else:
        if str(name_or_path) not in names:
            raise ConfigError("scenario", str(name_or_path), "unknown scenario; `fullspeed list` shows the catalog", None)
        source = f"scenarios/{name_or_path}.toml"
        data = parse_toml((resources.files("fullspeed") / "scenarios" / f"{name_or_path}.toml").read_text(), "toml", source)
    if overrides:
        data = with_overrides(data, overrides, source)
    return data, source


def with_overrides(data: dict, overrides: dict, source) -> dict:
    """overrides (--set, a sweep's [overrides] and axes) merged into a
    scenario's table read from source. A field of a machine given by name
    (machine.bench.f_pwm = 20000) is merged into that machine, a catalog one
    or a file beside the scenario, not replacing the name with a table of
    the one field; a catalog or zoo machine the overrides name replaces it."""
    base = data.get("machine")
    if isinstance(base, str) and isinstance(overrides.get("machine"), dict) \
            and not {"catalog", "zoo"} & set(overrides["machine"]):
        data = {**data, "machine": _machine_table(base, source)}
    return deep_merge(data, overrides)


def check_target(target: str) -> None:
    """A command's target that may be a machine or a scenario (design, map):
    a name that is neither, nor a file, is refused as that, not as an
    unknown scenario."""
    if target.endswith(".toml") and path_kind(target) is None:   # a file, as design's read_toml would name it 'machine'
        raise ConfigError("target", target, "file not found", None)
    if not target.endswith(".toml") and path_kind(target) is None and target not in scenario_names() \
            and target not in catalog_names():
        raise ConfigError("target", target, "unknown machine or scenario; `fullspeed list` shows the catalog", None)


def _machine_table(raw: str, source) -> dict:
    """A scenario's machine given by name (a catalog machine, or a machine
    file beside the scenario) as the table that names it, for merging fields
    into: {"catalog": name}, or the file's fields."""
    if not raw.endswith(".toml"):
        return {"catalog": raw}
    p = _machine_file(raw, source)
    table = read_toml(p, "machine")
    mag = table.get("magnetic")
    if isinstance(mag, dict) and isinstance(mag.get("file"), str) and not Path(mag["file"]).is_absolute():
        # the flux map lies beside the machine file, which the merged table no longer is
        table["magnetic"] = {**mag, "file": str(p.parent / mag["file"])}
    return table

