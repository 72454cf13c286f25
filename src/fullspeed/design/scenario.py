"""A scenario designed: what it leaves to the design formed from its machine
(designed as design.machine forms the bench), its converter and sensors,
each with its reason, and what depends on the design checked: the
bandwidths, the blending band, the observers, the I/f start, the rotating
carrier and its amplitude, the polarity pulses, the square wave, the torque
limit, the integration step and the trace's size. `load_scenario` is the
whole path from a name or a file to a Scenario a run takes."""
from __future__ import annotations

import math
from pathlib import Path

from .._core import ffi, lib
from ..model.errors import ConfigError
from ..model.machines import Machine
from ..model.scenario import Scenario, parse_scenario, plant_machine, scenario_data, xcomp_table
from ..model.units import rad_s_to_rpm, rpm_to_rad_s
from .checks import plausibility_warnings, warnings_of
from .envelope import envelope, torque_at
from .controller import controller_model, hfi_design, injection_inductances
from .machine import design_machine, mtpa_torque
from .magnetics import controller_values
from .start import (POLARITY_ASYMMETRY, RESOLUTION_MIN, design_if, design_motion, design_pulses, injection_resolution,
                    polarity_blind, polarity_reversed)
from .rules import (LOAD_STEP_ANGLE, XCOMP_SPAN_FOR_RAMP, Value, control_period, design_band, design_carrier,
                    design_injection, design_observer_pll, design_overspeed, load_ramp_for_observer, load_ramp_lag,
                    load_ramp_max, machine_values, observer_for_load_ramp, u_linear, xcomp_span_deg)
from .xcomp import check_table_settings, designed_table

# The trace is held in memory: one row of doubles per recorded sample.
TRACE_ROW_BYTES = 8 * lib.FS_CH_N
TRACE_MAX_BYTES = 2e9


# Scenario.warnings of a scenario loaded with warn=False: its caller reads none of them
UNWARNED = ("warnings: not formed (loaded with warn=False: its caller reads none; `fullspeed design` or a run "
            "loaded otherwise gives them)")


def scenario_from_dict(data: dict, source: str | None = None, warn: bool = True) -> Scenario:
    """A scenario table, validated (model.scenario.parse_scenario) and
    designed: every setting it leaves to the design formed (each with its
    reason in Scenario.design), what depends on the design checked, and the
    warnings of what it asks (design.checks). warn=False leaves the
    warnings out (UNWARNED in their place), for a caller that reads none:
    an envelope's bisection runs past the envelope on purpose, and the
    warning's search of the torque there was most of such a run's CPU.
    A refusal of the design carries the machine data's likeliest mistake
    where its plausibility finds one (a unit typed wrong is often what
    makes a design impossible: L in H, not mH, leaves no voltage for a
    carrier)."""
    try:
        return _designed(data, source, warn)
    except ConfigError as exc:
        hint = _data_mistake(data, source)
        if hint is None or type(exc) is not ConfigError:
            raise
        raise ConfigError(exc.field, exc.value, f"{exc.allowed}; the machine's data: {hint}", exc.source) from None


def _data_mistake(data: dict, source: str | None) -> str | None:
    """The first plausibility line of the scenario's machine (None where the
    data does not parse, or nothing is implausible)."""
    try:
        d, m = parse_scenario(data, source)
        m = design_machine(m)
        if d["converter"]["u_dc"] is None:
            d["converter"]["u_dc"] = m.bench["u_dc"]
        if d["controller"]["i_max"] is None:
            d["controller"]["i_max"] = m.bench["i_max"]
        lines = plausibility_warnings(d, m)
    except (ConfigError, ValueError, KeyError, TypeError):
        return None
    return lines[0] if lines else None


def _designed(data: dict, source: str | None, warn: bool) -> Scenario:
    """scenario_from_dict's work."""
    d, m = parse_scenario(data, source)
    m = design_machine(m)
    b = m.bench
    conv, tim, sen, ctl = d["converter"], d["timing"], d["sensors"], d["controller"]
    if conv["kind"] == "imc":
        _imc_fields(d, m, source)
    if conv["inverter"] is None:
        conv["inverter"] = "switching"
    for key in ("u_dc", "f_pwm", "t_dead"):
        if conv[key] is None:
            conv[key] = b[key]
    if tim["sampling"] is None:
        tim["sampling"] = b["sampling"]
    for key in ("adc_bits", "adc_range", "encoder_bits", "noise_i"):
        if sen[key] is None:
            sen[key] = b[key]
    notes: dict = {}
    for key in ("bw_current", "bw_speed", "bw_pll", "i_max"):
        if ctl[key] is None:
            ctl[key] = b[key]
            notes[f"controller.{key}"] = m.design[key]
        else:
            notes[f"controller.{key}"] = Value(ctl[key], m.design[key].unit, "given in the scenario", True)
    notes.update(_choose_start(d, m, source))
    obs = d["observer"]
    band = _band(d, m)
    if obs["bw_pll"] is None:
        if b.get("bw_pll_smo") is not None:
            notes["observer.bw_pll"] = Value(b["bw_pll_smo"], "rad/s", "given in the machine file (bench.bw_pll_smo)", True)
        else:
            notes["observer.bw_pll"] = design_observer_pll(machine_values(m), rpm_to_rad_s(band["lower_rpm"].value),
                                                              ctl["bw_speed"], ctl["bw_current"])
        obs["bw_pll"] = notes["observer.bw_pll"].value
    for key, share in (("valid_rpm", 0.625), ("cutoff_min_rpm", 0.125)):
        if obs[key] is None:   # where the observer is trusted, and its filter's floor, against the band it blends in
            obs[key] = share * band["lower_rpm"].value
            notes[f"observer.{key}"] = Value(obs[key], "rpm", f"{share:g} x the lower blending speed (yang2022: "
                                                f"{share * 160:g} rpm of 160): trusted inside the band, filtering below it")
    if ctl["angle"] in ("smo", "blend") and not obs["cutoff_min_rpm"] > 0:   # the SMO's filter needs a floor
        raise ConfigError("observer.cutoff_min_rpm", obs["cutoff_min_rpm"], "must be > 0 (the default, 1/8 of the "
                          f"lower blending speed {band['lower_rpm'].value:g} rpm, is 0): set it", source)
    if ctl["angle"] == "smo" and "bw_speed" not in data.get("controller", {}):
        # the speed comes from the observer's PLL: keep its lag (a double pole)
        # small at the speed loop's crossover, as the bench's encoder PLL does
        ctl["bw_speed"] = min(ctl["bw_speed"], obs["bw_pll"] / 6.0)
    if obs["top_speed_rpm"] is None:
        # the back-EMF observer's gain bound holds up to its top speed (fs_smo.h, eq. (18)): at least the
        # fastest the scenario turns the rotor, with 10 % to spare (the 2004 Prius MG2 driven to 5000 rpm
        # with its default of 1.5 x its rated 1200 rpm lost its sliding mode there and the rotor with it)
        n_rated = 1.5 * m.w_m_rated * 60 / (2 * math.pi)
        n_run = 1.1 * _largest_speed_rpm(d)
        obs["top_speed_rpm"] = max(n_rated, n_run)
        notes["observer.top_speed_rpm"] = Value(obs["top_speed_rpm"], "rpm", (
            "1.5 x the rated speed" if n_rated >= n_run else
            "1.1 x the fastest speed the scenario asks (references, a speed load, the initial speed), above 1.5 x rated")
            + ": the observer's gain bound, eq. (18), holds up to it")
        if not obs["top_speed_rpm"] >= 1e-3:
            raise ConfigError("machine.rated.speed_rpm", m.w_m_rated * 60 / (2 * math.pi), "must be >= 1e-3 rpm "
                              "(1.5 x it is the observer's top speed; a denormal one divides by zero)", source)
    if not obs["top_speed_rpm"] >= 1e-3:   # the SMO's gain bound and h_max divide by it
        raise ConfigError("observer.top_speed_rpm", obs["top_speed_rpm"], "must be >= 1e-3 rpm", source)
    if tim["h_max"] is None:
        # RK4 within a PWM segment: a fifth of the shortest electrical time
        # constant and of the time the rotor turns a radian (el.) at the top
        # speed keeps the local error near (h / tau)^5 / 120 < 3e-6
        tau = min(m.L_d, m.L_q) / m.R_s if m.R_s > 0 else math.inf
        w_top = m.pole_pairs * rpm_to_rad_s(obs["top_speed_rpm"])
        tim["h_max"] = min(0.2 * tau, 0.2 / w_top if w_top > 0 else math.inf, 1e-3)   # w_top underflows to 0 at 5e-324 rpm
        if conv["kind"] == "imc":   # and a fifth of a radian of the input filter's resonance
            tim["h_max"] = min(tim["h_max"], 0.2 * math.sqrt(conv["l_filter"] * conv["c_filter"]))
    vsi3 = m.phases == 3 and conv["kind"] != "imc"   # the plan's voltage limit is the three-phase VSI's (fs_fwmap.h)
    if ctl["flux_weakening"] and m.magnetic["model"] == "fluxmap" and not vsi3:
        raise ConfigError("controller.flux_weakening", True, "needs a three-phase inverter on a machine with a flux "
                          "map: its flux weakening is planned on the map within that inverter's voltage limit "
                          "(fs_fwmap.h)", source)
    if ctl["fw_method"] is None:
        ctl["fw_method"] = "planned" if vsi3 else "feedback"
    if ctl["flux_weakening"] and ctl["fw_method"] == "planned" and not vsi3:
        raise ConfigError("controller.fw_method", "planned", "must be \"feedback\" with five phases or the matrix "
                          "converter: the plan's voltage limit is a three-phase inverter's (fs_fwmap.h)", source)
    if ctl["flux_weakening"] and m.magnetic["model"] == "fluxmap" and ctl["fw_method"] == "feedback":
        raise ConfigError("controller.fw_method", "feedback", "must be \"planned\" on a machine with a flux map: the "
                          "drive plans its flux weakening on the map within the voltage limit (fs_fwmap.h)", source)
    if ctl["flux_weakening"] and ctl["fw_method"] == "planned" and ctl["fw_excess"] == "held":
        raise ConfigError("controller.fw_excess", "held", "must be \"wound_back\" with fw_method = \"planned\": the "
                          "references come from the map within the voltage limit (fs_fwmap.h), with no voltage-error "
                          "loop for a held excess to feed (\"held\" is fw_method = \"feedback\"'s, zou2021's)", source)
    if ctl["flux_weakening"] and ctl["fw_method"] == "planned":
        for key in ("fw_top_speed_rpm", "fw_gain", "fw_cutoff"):
            if ctl[key] is not None:
                raise ConfigError(f"controller.{key}", ctl[key], "is fw_method = \"feedback\"'s (zou2021's PART_1), "
                                  "which the planned flux weakening (the default) does not use: leave it out or set "
                                  "fw_method = \"feedback\"", source)
    if ctl["fw_top_speed_rpm"] is None:
        ctl["fw_top_speed_rpm"] = obs["top_speed_rpm"]
    if ctl["overspeed_rpm"] is None:
        notes["controller.overspeed_rpm"] = design_overspeed(_speeds_asked(d))
        ctl["overspeed_rpm"] = notes["controller.overspeed_rpm"].value
    else:
        notes["controller.overspeed_rpm"] = Value(ctl["overspeed_rpm"], "rpm", "given in the scenario", True)
    if ctl["torque_slew"] is not None and not (ctl["mode"] == "speed" and ctl["angle"] in ("hfi", "blend")):
        raise ConfigError("controller.torque_slew", ctl["torque_slew"], "limits the speed loop's torque while the "
                          "rotating injection runs: it needs controller.mode = \"speed\" and angle \"hfi\" or "
                          f"\"blend\" (here {ctl['mode']!r}, {ctl['angle']!r}); leave it out", source)
    if ctl["lock"] is None:   # the drive acts on a loss (fs_drive_protect.h); the square wave has no restart sequence
        ctl["lock"] = "stop" if ctl["angle"] == "swvi" else "recover"
    if obs["start"] == "if":
        if ctl["angle"] != "smo" or ctl["mode"] != "speed":
            raise ConfigError("observer.start", "if", "needs controller.mode = \"speed\" and controller.angle = \"smo\"", source)
        if obs["handover"] != 0.0:
            raise ConfigError("observer.handover", obs["handover"], "must be 0 with start = \"if\" (sensorless from t = 0)", source)
        if obs["i_start"] is not None and obs["i_start"] > ctl["i_max"]:
            raise ConfigError("observer.i_start", obs["i_start"], f"must be <= controller.i_max ({ctl['i_max']:g} A)", source)
        notes.update(design_if(d, m, source, bw_speed_given="bw_speed" in data.get("controller", {}) or m.design["bw_speed"].given))
    if d["injection"]["leak"] is None:   # the filter the observer is designed for (fs_hfi.h)
        d["injection"]["leak"] = "remove" if d["injection"]["tracking"] == "lag" else "keep"
    if ctl["angle"] in ("hfi", "blend"):
        pll_given = "bw_pll" in data.get("observer", {}) or b.get("bw_pll_smo") is not None
        _injection_fields(d, m, source, bw_speed_given="bw_speed" in data.get("controller", {}) or m.design["bw_speed"].given,
                          designed_pll=None if pll_given else lambda bw_speed: design_observer_pll(
                              machine_values(m), rpm_to_rad_s(band["lower_rpm"].value), bw_speed, ctl["bw_current"]))
    if ctl["angle"] == "swvi":
        _swvi_fields(d, m, source, bw_speed_given="bw_speed" in data.get("controller", {}))
    if ctl["gains"] == "paper":
        _paper_gains(d, m, source)
    if obs["handover"] > d["duration"]:
        raise ConfigError("observer.handover", obs["handover"], f"must be <= duration ({d['duration']:g} s)", source)
    if ctl["T_max"] is None:
        try:
            ctl["T_max"] = mtpa_torque(m, ctl["i_max"])
        except ValueError:   # a machine that makes no torque (a passive load): only the speed mode needs it
            if ctl["mode"] == "speed":
                raise ConfigError("controller.T_max", "missing", f"is required: {m.name} makes no torque by MTPA at {ctl['i_max']:g} A", source) from None
            ctl["T_max"] = 1.0
    if ctl["i_dead_band"] is None:
        ctl["i_dead_band"] = 0.01 * ctl["i_max"]
    if ctl["dead_time_predict"] is None:   # the carrier's current crosses zero within the period (fs_dtcomp.h)
        ctl["dead_time_predict"] = ctl["angle"] in ("hfi", "blend")
    # consistency between fields
    T_pwm, Ts = 1.0 / conv["f_pwm"], control_period(d)
    if conv["t_dead"] >= 0.5 * T_pwm:
        raise ConfigError("converter.t_dead", conv["t_dead"], f"must be shorter than half the PWM period ({0.5 * T_pwm:g} s)"
                          + (", the control period with double sampling" if tim["sampling"] == "double" else ""), source)
    if tim["h_max"] < 1e-3 * Ts:   # a run of finite steps: at most a thousand RK4 steps per control period
        given = "h_max" in data.get("timing", {})
        raise ConfigError("timing.h_max", tim["h_max"], f"must be >= {1e-3 * Ts:g} s, a thousandth of the control period"
                          + ("" if given else f" (the default, a fifth of {m.name}'s shortest time constant L/R or "
                             "of a radian at the top speed, is shorter: check R_s, L_d, L_q and observer.top_speed_rpm)"), source)
    if ctl["i_max"] >= m.bench["i_trip"]:
        raise ConfigError("controller.i_max", ctl["i_max"], f"must be below the trip level bench.i_trip ({m.bench['i_trip']:g} A)", source)
    if d["duration"] < Ts:   # the run counts whole periods (fs_sim_steps): a shorter one would run none
        raise ConfigError("duration", d["duration"], f"must be at least one control period ({Ts:g} s)", source)
    rows = d["duration"] / (Ts * d["trace"]["decimation"])
    if rows * TRACE_ROW_BYTES > TRACE_MAX_BYTES:
        need = math.ceil(d["duration"] / Ts * TRACE_ROW_BYTES / TRACE_MAX_BYTES)
        raise ConfigError("trace.decimation", d["trace"]["decimation"], f"must be >= {need}: {d['duration']:g} s at Ts = {Ts:g} s "
                          f"would trace {rows * TRACE_ROW_BYTES / 1e9:.3g} GB, above the {TRACE_MAX_BYTES / 1e9:g} GB limit", source)
    for sec, key, limit in (("controller", "bw_current", 1.0), ("controller", "fw_cutoff", 1.0), ("controller", "bw_speed", 0.5),
                            ("controller", "bw_pll", 0.5), ("observer", "bw_pll", 0.5)):
        if d[sec][key] is not None and d[sec][key] * Ts > limit:   # None: designed in C
            raise ConfigError(f"{sec}.{key}", d[sec][key], f"must be <= {limit / Ts:g} rad/s for the control period {Ts:g} s", source)
    for key in ("u_h", "f_h"):
        if f"injection.{key}" not in notes and d["injection"][key] is not None and ctl["angle"] in ("hfi", "blend", "swvi"):
            notes[f"injection.{key}"] = Value(d["injection"][key], "", "given in the machine file or the scenario", True)
    notes.update(d.pop("_notes", {}))
    warnings = ((warnings_of(d, m, bw_speed_given="bw_speed" in data.get("controller", {}),
                             bw_observer_given="bw_observer" in (data.get("blending") or {})) if warn else [UNWARNED])
                + check_table_settings(d, m.name, source))
    pm = plant_machine(d, m, source)
    return Scenario(name=d["name"], machine=m, data=d, source=source, design=notes, warnings=warnings,
                    plant=design_machine(pm) if pm is not None else None)


def _largest_speed_rpm(d: dict) -> float:
    """The fastest the scenario turns the rotor, rpm: its speed references,
    a load that holds a speed, its initial speed."""
    speeds = [abs(v) for v in d["references"]["speed_rpm"][1]] + [abs(d["initial"]["speed_rpm"])]
    if d["load"]["kind"] in ("speed", "speed_pi"):
        speeds += [abs(v) for v in d["load"]["speed_rpm"][1]]
    return max(speeds)


def load_scenario(name_or_path: str | Path, overrides: dict | None = None, warn: bool = True) -> Scenario:
    """A catalog scenario by name, or a TOML file by path, designed; overrides
    are merged into the raw data before validation (warn: scenario_from_dict's)."""
    data, source = scenario_data(name_or_path, overrides)
    return scenario_from_dict(data, source, warn)


def _speeds_asked(d: dict) -> dict[str, float]:
    """The speeds (rpm) the drive is designed for or the scenario asks, by
    the field that gives each: what the overspeed stop is designed over."""
    ctl, ref, load = d["controller"], d["references"], d["load"]
    out = {"observer.top_speed_rpm": d["observer"]["top_speed_rpm"], "initial.speed_rpm": d["initial"]["speed_rpm"]}
    if ctl["flux_weakening"]:
        out["controller.fw_top_speed_rpm"] = ctl["fw_top_speed_rpm"]
    profiles = {"speed": "speed_rpm", "voltage": "frame_rpm", "vf": "frame_rpm"}
    if ctl["mode"] in profiles:
        key = profiles[ctl["mode"]]
        out[f"references.{key}"] = max((abs(v) for v in ref[key][1]), default=0.0)
    if load["kind"] in ("speed", "speed_pi"):
        out["load.speed_rpm"] = max((abs(v) for v in load["speed_rpm"][1]), default=0.0)
    return out


def _bench_of(d: dict, m: Machine) -> dict:
    """The machine's bench with the scenario's converter and sensors: what
    the injection and the band are designed against."""
    conv, sen = d["converter"], d["sensors"]
    return {**m.bench, "u_dc": conv["u_dc"], "f_pwm": conv["f_pwm"], "t_dead": conv["t_dead"],
            "sampling": d["timing"]["sampling"], "adc_bits": sen["adc_bits"], "adc_range": sen["adc_range"],
            "noise_i": sen["noise_i"]}


def _band(d: dict, m: Machine) -> dict:
    """The blending band: the machine's [blending], else designed."""
    mb = m.extra.get("blending", {})
    bench = _bench_of(d, m)
    f_h = d["injection"]["f_h"] or m.extra.get("injection", {}).get("f_h") or _carrier(d, m).value
    band = design_band(machine_values(m), bench, f_h)
    return {k: Value(float(mb[k]), "rpm", "given in the machine file", True) if k in mb else band[k]
            for k in ("lower_rpm", "upper_rpm")}


def _carrier(d: dict, m: Machine) -> Value:
    """The rotating carrier's designed frequency, against the current loop
    as the controller designs it (its model of the machine, its timing)."""
    ctl = d["controller"]
    mv = {**machine_values(m), **controller_model(ctl, m)}
    return design_carrier(mv, _bench_of(d, m), ctl["bw_current"] if ctl["gains"] == "designed" else None,
                             d["timing"]["delay"])


def _imc_fields(d: dict, m: Machine, source) -> None:
    """The indirect matrix converter (zou2021): the grid and filter from the
    bench, and what the averaged model of fs_sim.h does not have."""
    conv, ctl, tim, b = d["converter"], d["controller"], d["timing"], m.bench
    if m.phases != 3:
        raise ConfigError("converter.kind", "imc", f"drives three phases; {m.name} has {m.phases}", source)
    for key, bkey in (("grid_ll_rms", "u_grid_ll_rms"), ("f_grid", "f_grid"), ("l_filter", "l_filter"),
                      ("r_filter", "r_filter"), ("c_filter", "c_filter")):
        if conv[key] is None:
            if b.get(bkey) is None:
                raise ConfigError(f"converter.{key}", "missing", f"is required: {m.name}'s bench has no {bkey}", source)
            conv[key] = b[bkey]
    if conv["inverter"] == "switching":
        raise ConfigError("converter.inverter", "switching", "must be \"averaged\" with kind = \"imc\" (the inverter stage is averaged per rectifier interval)", source)
    conv["inverter"] = "averaged"
    for key in ("u_on", "r_on"):
        if conv[key]:
            raise ConfigError(f"converter.{key}", conv[key], "must be 0 with kind = \"imc\" (its devices' drops are the "
                              "machine's [converter] module's, with losses.devices)", source)
    if conv["t_dead"] is None:   # the ideal converter of the paper's modulator (not the bench's inverter dead time)
        conv["t_dead"] = 0.0
    if tim["sampling"] == "double":
        raise ConfigError("timing.sampling", "double", "must be \"single\" with kind = \"imc\"", source)
    tim["sampling"] = "single"
    if ctl["angle"] == "swvi":
        raise ConfigError("controller.angle", "swvi", "square-wave injection is not available with kind = \"imc\"", source)
    if ctl["i_lim"] is None:
        ctl["i_lim"] = b.get("i_lim") or ctl["i_max"] or b["i_max"]
    i_max = ctl["i_max"] or b["i_max"]
    if ctl["depth_control"] and ctl["i_lim"] > i_max:
        raise ConfigError("controller.i_lim", ctl["i_lim"], f"must be <= controller.i_max ({i_max:g} A)", source)


def _injection_saliency(d: dict, m: Machine) -> tuple[float, float]:
    """The inductances an injection's carrier sees, as the datasheet gives
    them: a flux map's incremental ones at half the rated current on its
    MTPA locus, else the machine's. Not the scenario's *_scale: those are a
    controller's errors on purpose, which the design (as the carrier's, from
    the machine's values) does not know of (B-ROBUST's +-20 % on L_d and L_q
    put yang2022's L_q/L_d of 1.4 at 1.04 and chose an I/f start for it)."""
    if m.magnetic["model"] == "fluxmap":
        cv = controller_values(m.magnetic, d["controller"]["i_max"], m.i_rated, m.phases, m.pole_pairs)
        return cv["L_d_hf"], cv["L_q_hf"]
    return m.L_d, m.L_q


def _choose_start(d: dict, m: Machine, source) -> dict:
    """The start the machine gets (design.start): d["start"]["kind"] one of
    pulses, motion (settled in _injection_fields, which designs them), if,
    known (the angle taken as known: polarity detection off, the square
    wave), sensor (the encoder until the hand-over), none (no closed loop),
    with its reason; a blend on a machine whose saliency the injection cannot
    use becomes the back-EMF observer with an I/f start."""
    ctl, obs, st = d["controller"], d["observer"], d["start"]
    st["c"] = {}
    angle, closed = ctl["angle"], ctl["mode"] in ("current", "speed")
    method, motion = st["method"], st["allow_motion"]
    if angle == "smo" and method == "if" and obs["handover"] == 0.0:
        obs["start"] = "if"
    if not closed or angle in ("encoder", "true"):
        st["kind"], st["reason"] = ("sensor" if closed else "none"), "the loops do not start on an estimate"
        return {}
    if angle == "smo":
        if obs["start"] == "if" and not motion:
            raise ConfigError("start.allow_motion", False, "forbids the I/f start (observer.start = \"if\"): it turns the rotor", source)
        st["kind"] = "if" if obs["start"] == "if" else "sensor"
        st["reason"] = ("observer.start = \"if\": the back-EMF observer sees nothing at standstill" if st["kind"] == "if"
                        else f"the encoder until observer.handover ({obs['handover']:g} s)")
        return {}
    if angle == "swvi":
        st["kind"], st["reason"] = "known", "the square wave has no polarity detection: the rotor within 90 el.deg of the estimate"
        return {}
    L_d, L_q = _injection_saliency(d, m)
    inj = d["injection"]
    f_h = inj["f_h"] or m.extra.get("injection", {}).get("f_h") or _carrier(d, m).value
    ratio, what = injection_resolution(L_d, L_q, f_h, _bench_of(d, m), ctl["i_max"])
    # a carrier given (the scenario's injection.u_h, or the machine's) is the scenario's choice of the injection:
    # the design keeps it (its own checks then apply to it) and says how well it resolves
    carrier_given = inj["u_h"] is not None or "u_h" in m.extra.get("injection", {})
    usable = ratio >= RESOLUTION_MIN or carrier_given
    st["c"]["resolution"] = ratio
    sal = f"L_q/L_d = {L_q / L_d:.3g} ({what}: {ratio:.2f}, {'at least' if ratio >= RESOLUTION_MIN else 'below'} {RESOLUTION_MIN:g})"
    if method == "if" or (method == "designed" and motion and not usable):
        if not motion:
            raise ConfigError("start.allow_motion", False, "forbids the I/f start (start.method = \"if\"): it turns the rotor", source)
        if angle == "hfi":
            raise ConfigError("controller.angle", "hfi", f"{m.name} is not salient enough for the injection, {sal}: "
                              "use \"blend\" (it then starts I/f into the back-EMF observer) or \"smo\" with observer.start = \"if\"", source)
        if ctl["mode"] != "speed":
            raise ConfigError("controller.mode", ctl["mode"], f"must be \"speed\" for the I/f start the machine needs ({sal})", source)
        ctl["angle"], obs["start"] = "smo", "if"
        st["kind"] = "if"
        st["reason"] = ("start.method = \"if\"" if method == "if" else
                        f"no saliency the injection can use, {sal}: the back-EMF observer alone (controller.angle blend -> smo), "
                        "from standstill by an I/f start")
        return {}
    if not d["polarity"]["enabled"]:
        st["kind"], st["reason"] = "known", "polarity.enabled = false: the rotor's angle taken as the estimate's"
    elif method == "motion" and not motion:
        raise ConfigError("start.allow_motion", False, "forbids the motion test (start.method = \"motion\"): it turns the rotor", source)
    else:
        st["kind"] = "pulses" if not motion else {"pulses": "pulses", "motion": "motion"}.get(method, "designed")
        st["reason"] = f"the injection uses the saliency, {sal}" + (
            "" if ratio >= RESOLUTION_MIN else "; the carrier is given" if carrier_given and motion and method == "designed"
            else "; start.allow_motion = false or a named method keeps it")
    return {}


def _blend_for_load_ramp(d: dict, m: Machine, h, source) -> None:
    """The blend's motion observer, whose angle and speed the loops take,
    fast enough for the scenario's steepest load ramp (rules.
    observer_for_load_ramp), where the injection's default (the paper's
    rule, w_b_n / 5) is not: up to the injection's own observer (h.cfg.obs,
    w_b_n with its filter's lag), beyond which it would pass the carrier's
    ripple and noise. The speed loop follows it (half of it, below). On the
    2004 Prius MG2, 200 N m rising over 0.15 s at standstill on its 0.035
    kg m^2 rotor: at the default 62.8 rad/s the blend's estimate lagged 35
    el.deg and the rotor, its speed loop at half that, rolled back to -660
    rpm and was lost; at 120 rad/s the lag is 5 el.deg.

    Not on magnetics that cross-saturate (a designed or given
    injection.xcomp table): there the carrier's angle moves with the
    current faster than the table says (fs_hfi.h), and an observer faster
    than the paper's rule passes those moves to the loops' angle and speed
    (B-MAPID's zoo machine 0 reversing under load, from three initial
    angles 1e-3 el.deg apart: 10.3, 17.3 and 6.4 el.deg with the blend
    raised to 91 rad/s and the speed loop at the default's half; 3.6, 3.6
    and 4.0 at the default). The lag the ramp then leaves is
    checks.load_ramp_warning's line. Those moves stay within the table's
    span, twice its largest lead (the table is odd in i_q): a table whose
    span is within LOAD_STEP_ANGLE, the lag this observer is designed to
    leave, moves the angle by less than the raise takes off it, and does
    not keep it (XCOMP_SPAN_FOR_RAMP). Zoo machine 0's lead is 6.9 el.deg
    (a span of 13.9); a flux map identified on an own-axis machine carries
    a lead of its readings' noise: 0.13 el.deg on the 2004 Prius MG2
    identified locked (its truth none), whose table kept the default here
    and let the rotor roll back to -650 rpm under B-REAL's 200 N m ramp and
    be lost (tools/ident_catalog.py)."""
    ramp = load_ramp_max(d["load"]["torque"])
    if not ramp > 0.0:
        return
    w_need = observer_for_load_ramp(m.pole_pairs, m.J, ramp)
    if not w_need > h.w_o_blend:
        return
    xc = d["injection"]["xcomp"]
    table = xcomp_table(xc, source) if xc not in (None, False) else designed_table(m, d["controller"]["i_max"])[0]
    if xcomp_span_deg(table) > XCOMP_SPAN_FOR_RAMP:
        return
    w_cap = h.cfg.obs.bandwidth
    w = min(w_need, w_cap)
    d["blending"]["bw_observer"] = w
    def lag(w_o: float) -> float:
        return math.degrees(load_ramp_lag(m.pole_pairs, m.J, ramp, w_o))

    d.setdefault("_notes", {})["blending.bw_observer"] = Value(w, "rad/s", (
        f"follows the scenario's steepest load ramp, {ramp:.4g} N m/s on J = {m.J:.4g} kg m^2, "
        f"within {lag(w):.3g} el.deg (p (dT/dt) / (J w^3))"
        + ("" if w_need <= w_cap else f"; capped at the injection's own observer ({w_cap:.4g} rad/s), "
           f"{w_need:.4g} rad/s would keep it within {math.degrees(LOAD_STEP_ANGLE):g}")
        + f"; the injection's default {h.w_o_blend:.4g} rad/s would lag {lag(h.w_o_blend):.3g} el.deg"))


def _torque_slew(d: dict, m: Machine, w_o: float) -> None:
    """The speed loop's torque slew while the injection runs: its observers
    feed the torque forward on the rotor's own inertia, so a torque the
    shaft does not follow (held by a load machine, or coupled to a vehicle's
    inertia) is an unknown load of the whole change to them. Limited to the
    ramp whose lag at the injection's observer (w_o) is LOAD_STEP_ANGLE
    (rules.load_ramp_for_observer), the estimate stays within it whatever
    the shaft does. On the 2004 Prius MG2 held by a load machine that takes
    it from standstill to 1,958 rpm in 0.1 s, the speed loop's 260 N m step
    in 1 ms left the injection's estimate 30 el.deg behind and the lock was
    lost; limited to 2.4e4 N m/s (260 N m in 11 ms), within 5.5 el.deg."""
    ctl = d["controller"]
    if ctl["mode"] != "speed":
        return
    notes = d.setdefault("_notes", {})
    if ctl["torque_slew"] is not None:
        notes["controller.torque_slew"] = Value(ctl["torque_slew"], "N m/s", "given in the scenario", True)
        return
    ctl["torque_slew"] = load_ramp_for_observer(m.pole_pairs, m.J, w_o)
    notes["controller.torque_slew"] = Value(ctl["torque_slew"], "N m/s", (
        f"while injecting: a torque the shaft does not follow stays within {math.degrees(LOAD_STEP_ANGLE):g} el.deg "
        f"of the injection's observer ({w_o:.4g} rad/s): {math.degrees(LOAD_STEP_ANGLE):g} el.deg J w^3 / p "
        f"on J = {m.J:.4g} kg m^2"))


def _injection_fields(d: dict, m: Machine, source, bw_speed_given: bool = True, designed_pll=None) -> None:
    """Fill in and check the injection, polarity and blending tables."""
    ctl, inj, pol, bl = d["controller"], d["injection"], d["polarity"], d["blending"]
    L_d, L_q = injection_inductances(controller_model(ctl, m))
    _check_saliency(ctl, m, source)
    band = _band(d, m)
    designed = design_injection(machine_values(m), _bench_of(d, m), ctl["i_max"], rpm_to_rad_s(band["upper_rpm"].value),
                                   _carrier(d, m))
    _machine_injection(inj, m, ("u_h", "f_h"), source, designed)
    if "u_taken" in designed and inj.get("_notes", {}).get("injection.u_h") is designed["u_h"]:
        inj["_notes"]["injection.u_h"] = _carrier_cost(d, m, band["upper_rpm"].value, designed, source)
    if not inj["u_h"] > 0.0:   # designed as nothing (fs_hfi_init would refuse it, blaming the carrier's frequency)
        raise ConfigError("injection.u_h", inj["u_h"], f"must be > 0 V: {designed['u_h'].reason}", source)
    d.setdefault("_notes", {}).update(inj.pop("_notes", {}))
    Ts = control_period(d)
    _check_carrier(inj["f_h"], Ts, source)
    for key in ("bw_filter_p", "bw_filter_n", "bw_observer"):
        if inj[key] is not None and inj[key] * Ts > 0.5:
            raise ConfigError(f"injection.{key}", inj[key], f"must be <= {0.5 / Ts:g} rad/s for the control period {Ts:g} s", source)
    h = hfi_design(inj, Ts, L_d, L_q, source)   # the bandwidths and the held amplitude as the estimator designs them
    # the observer whose speed the loops take: the blend's, or the injection's speed observer (fs_hfi.h: with
    # tracking = "lag" not the fast one, whose speed carries the angle's response to the loop's own current)
    if ctl["angle"] == "blend" and bl["bw_observer"] is None and d["load"]["kind"] == "torque":
        _blend_for_load_ramp(d, m, h, source)
    w_o = (bl["bw_observer"] if ctl["angle"] == "blend" else None) or h.w_o_blend
    if not bw_speed_given and ctl["bw_speed"] > 0.5 * w_o:
        # the speed loop at half its bandwidth keeps the observer's lag small (on the machine zoo: 28 of 50
        # saturating machines within 15 el.deg instead of 18 at bw_current / 30)
        ctl["bw_speed"] = 0.5 * w_o
        notes = d.setdefault("_notes", {})
        notes["controller.bw_speed"] = Value(ctl["bw_speed"], "rad/s", (
            f"half the observer whose speed the loop uses ({w_o:.4g} rad/s): its lag stays small "
            "(bw_current / 30 would be faster than the observer)"))
        if designed_pll is not None:   # the back-EMF observer's PLL, designed against the speed loop, follows it
            d["observer"]["bw_pll"] = designed_pll(ctl["bw_speed"]).value
            notes["observer.bw_pll"] = designed_pll(ctl["bw_speed"])
    w_b_p, w_b_n, w_o, w_o_speed = h.cfg.w_b_p, h.cfg.w_b_n, h.cfg.obs.bandwidth, min(h.cfg.obs.bandwidth, h.w_o_blend)
    _torque_slew(d, m, w_o)
    for key, w in (("bw_filter_p", w_b_p), ("bw_filter_n", w_b_n), ("bw_observer", w_o)):
        if w * Ts > 0.5:   # a default derived from the carrier
            raise ConfigError(f"injection.{key}", w, f"must be <= {0.5 / Ts:g} rad/s for the control period {Ts:g} s (default from f_h; set it)", source)
    u_lin = u_linear(d["converter"]["u_dc"], m.phases)
    if h.u_amp >= u_lin:
        raise ConfigError("injection.u_h", inj["u_h"], f"must be below {u_lin * inj['u_h'] / h.u_amp:.3g} V: the held carrier, u_h / sinc(pi f_h Ts) = {h.u_amp:.3g} V, inside the linear modulation limit u_dc/sqrt3", source)
    i_hf = inj["u_h"] / (2 * math.pi * inj["f_h"] * min(L_d, L_q))   # the carrier current's peak (fs_drive.c)
    if not i_hf < 0.5 * ctl["i_max"]:
        raise ConfigError("injection.u_h", inj["u_h"], f"must be below {inj['u_h'] * 0.5 * ctl['i_max'] / i_hf:.3g} V: the carrier current's peak, u_h / (2 pi f_h min(L_d, L_q)) = {i_hf:.3g} A, must stay below half of controller.i_max ({ctl['i_max']:g} A)", source)
    if bl["bw_observer"] is not None and bl["bw_observer"] * Ts > 0.5:
        raise ConfigError("blending.bw_observer", bl["bw_observer"], f"must be <= {0.5 / Ts:g} rad/s for the control period {Ts:g} s", source)
    if pol["enabled"]:
        t_lock_min, t_pulse_min = 6.0 / w_b_n + 2.0 / w_o_speed, 6.0 / w_b_p   # the slower observer settles too
        for key, t_min, t_default in (("t_lock", t_lock_min, 0.06), ("t_pulse", t_pulse_min, 0.02)):
            if pol[key] is None:   # 20 % above the settling bound: noise and the rounding to samples
                pol[key] = max(t_default, 1.2 * t_min)
                d.setdefault("_notes", {})[f"polarity.{key}"] = Value(
                    pol[key], "s", f"{t_default:g} s (yang2022's bench) or 1.2 x the settling bound {t_min:.3g} s, the longer")
        if pol["t_lock"] < t_lock_min:
            raise ConfigError("polarity.t_lock", pol["t_lock"], f"must be >= {t_lock_min:.3g} s: 6 / w_b_n + 2 / w_o, the fade-in, the filters and the observers settle first", source)
        if pol["t_pulse"] < t_pulse_min:
            raise ConfigError("polarity.t_pulse", pol["t_pulse"], f"must be >= {t_pulse_min:.3g} s: 6 / w_b_p, the carrier amplitude settles in each pulse's first half", source)
    if inj["xcomp"] is None:
        _designed_xcomp(d, m)
    elif inj["xcomp"] is False:   # none, on purpose (a paper's estimator, an uncompensated measurement)
        inj["xcomp"] = None
    else:
        inj["xcomp"] = xcomp_table(inj["xcomp"], source)
    if pol["enabled"] and d["start"]["kind"] in ("designed", "pulses", "motion"):
        d["_notes"].update(_polarity_start(d, m, i_hf, h, u_lin, source))
    if pol["i_pulse"] is None:
        pol["i_pulse"] = 0.5 * ctl["i_max"]
    if pol["i_pulse"] > ctl["i_max"]:
        raise ConfigError("polarity.i_pulse", pol["i_pulse"], f"must be <= controller.i_max ({ctl['i_max']:g} A)", source)
    if pol["i_pulse_max"] is not None and not pol["i_pulse"] <= pol["i_pulse_max"] <= ctl["i_max"]:
        raise ConfigError("polarity.i_pulse_max", pol["i_pulse_max"], f"must be within polarity.i_pulse ({pol['i_pulse']:g} A) .. controller.i_max ({ctl['i_max']:g} A)", source)
    if ctl["angle"] == "blend":
        for key in ("lower_rpm", "upper_rpm"):
            if bl[key] is None:
                bl[key] = band[key].value
                d["_notes"][f"blending.{key}"] = band[key]
            else:
                d["_notes"][f"blending.{key}"] = Value(bl[key], "rpm", "given in the scenario", True)
        if not bl["upper_rpm"] > bl["lower_rpm"]:
            raise ConfigError("blending.upper_rpm", bl["upper_rpm"], f"must be > blending.lower_rpm ({bl['lower_rpm']:g})", source)
        if inj["stop_rpm"] is None:
            inj["stop_rpm"] = 1.2 * bl["upper_rpm"]
        if not 0.9 * inj["stop_rpm"] >= bl["upper_rpm"]:
            raise ConfigError("injection.stop_rpm", inj["stop_rpm"], f"must be >= upper_rpm / 0.9 = {bl['upper_rpm'] / 0.9:g} (the injection resumes at 0.9 x stop_rpm)", source)


def _designed_xcomp(d: dict, m: Machine) -> None:
    """The rotating injection's cross-saturation table, left out, designed
    from a flux map or an algebraic model (design.xcomp.designed_table): on
    the MTPA locus, or in current control at the scenario's i_d where it
    holds one value; none where the magnetics have no cross term."""
    if m.magnetic["model"] not in ("fluxmap", "algebraic"):
        return
    ctl = d["controller"]
    i_d = _held_reference(d["references"]["i_d"]) if ctl["mode"] == "current" else None
    table, note = designed_table(m, ctl["i_max"], i_d)
    if table is not None:
        d["injection"]["xcomp"] = table
        d.setdefault("_notes", {})["injection.xcomp"] = note


def _held_reference(ref) -> float | None:
    """A reference schedule's (times, values) one value, else None."""
    values = {float(v) for v in ref[1]}
    return values.pop() if len(values) == 1 else None


def _polarity_start(d: dict, m: Machine, i_hf: float, h, u_lin: float, source) -> dict:
    """The polarity detection the machine gets (design.start): the pulses,
    designed safe for the rotor and the current loop, where the d axis
    saturates asymmetrically at the largest of them; else the motion test."""
    ctl, pol, st = d["controller"], d["polarity"], d["start"]
    notes: dict = {}
    if st["kind"] in ("designed", "pulses"):
        given = {k: pol[k] for k in ("i_pulse", "i_pulse_max")}
        notes = design_pulses(d, m, controller_model(ctl, m), i_hf, h, u_lin)
        i_top = pol["i_pulse_max"] or max(ctl["i_max"] - i_hf, pol["i_pulse"])
        st["c"]["pulse_span"] = {"i_top": i_top, "h": i_hf}   # what the pulses were judged on: checks reads the same
        blind = polarity_blind(m, i_top, pol["i_pulse"], i_hf) if st["kind"] == "designed" else None
        wrong = polarity_reversed(m, pol["i_pulse"], i_top, i_hf) if st["kind"] == "pulses" else None
        if wrong:   # the pulses kept (named, or the rotor not to be turned) would start on the south pole
            raise ConfigError("start.method" if st["method"] == "pulses" else "start.allow_motion",
                              st["method"] if st["method"] == "pulses" else False,
                              f"leaves polarity to the pulses, and {m.name}'s {wrong}: let the start turn the rotor "
                              "(start.allow_motion = true, the motion test) or start at a known angle (polarity.enabled = false)",
                              source)
        if blind:   # nothing for the pulses to decide on (or the wrong way) at any pulse the rotor and the loop tolerate
            pol.update(given)
            notes = {}
            st["kind"] = "motion"
            st["reason"] += f"; {m.name}'s {blind} (at {i_top:.4g} A): the pulses cannot be used, a bounded motion test"
        else:
            st["kind"] = "pulses"
            if st["method"] == "designed":
                st["reason"] += f"; the d axis saturates asymmetrically at the pulses (design.start: {POLARITY_ASYMMETRY:.0%} needed)"
    if st["kind"] == "motion":
        notes.update(design_motion(d, m, i_hf, h.cfg.obs.bandwidth, h.cfg.w_b_n))
    return notes


def _check_carrier(f_h: float, Ts: float, source) -> None:
    """The rotating carrier's limit, fs_hfi_w_h_max's rule (the one C applies):
    more than 4 samples per carrier period, w_h Ts < pi/2 in float32."""
    w_max = lib.fs_hfi_w_h_max(Ts)
    if not float(ffi.cast("float", 2 * math.pi * f_h)) <= w_max:   # w_h as the C config holds it
        raise ConfigError("injection.f_h", f_h, f"must be at most {w_max / (2 * math.pi):.10g} Hz: more than 4 samples per carrier "
                          f"period at Ts = {Ts:g} s, w_h Ts below pi/2 in float32 (a quarter of the sampling rate, {0.25 / Ts:g} Hz, "
                          "is not below it there)", source)


def _check_saliency(ctl: dict, m: Machine, source) -> None:
    L_d, L_q = injection_inductances(controller_model(ctl, m))
    if not abs(L_q - L_d) > 0.01 * 0.5 * (L_d + L_q):
        scaled = ctl["L_d_scale"] != 1.0 or ctl["L_q_scale"] != 1.0
        whose = (f"the controller's model of {m.name} (L_d x {ctl['L_d_scale']:g}, L_q x {ctl['L_q_scale']:g}) has"
                 if scaled else f"{m.name} has")
        if "map.L_d_hf" in m.design:   # the saliency a carrier sees, where it runs
            sal = (L_q - L_d) / (L_q + L_d)
            why = (f"{whose} an incremental saliency (L_q - L_d)/(L_q + L_d) of {sal:.1%} on its flux map at half the rated "
                   f"current on MTPA ({0.5 * m.i_rated:.3g} A: L_d = {L_d * 1e3:.4g} mH, L_q = {L_q * 1e3:.4g} mH), below "
                   "the 0.5 % an injection estimator can lock on")
        else:
            why = f"{whose} L_d = {L_d:g} H within 1 % of L_q = {L_q:g} H (no saliency to design the estimator for)"
        raise ConfigError("controller.angle", ctl["angle"], f"injection needs a salient machine: {why}", source)


def _carrier_cost(d: dict, m: Machine, upper_rpm: float, designed: dict, source) -> Value:
    """The designed carrier's note with what it costs where it was taken
    from the fundamental: the envelope's torque at the band's top with and
    without the carrier's voltage."""
    b, i_max = _bench_of(d, m), d["controller"]["i_max"]
    u_lin = u_linear(b["u_dc"], m.phases)
    w_m = rpm_to_rad_s(upper_rpm)
    T_all = torque_at(envelope(m, b["u_dc"], i_max, w_end=2 * w_m), w_m)
    T_inj = torque_at(envelope(m, b["u_dc"], i_max, u_max=u_lin - designed["u_taken"].value, w_end=2 * w_m), w_m)
    v = designed["u_h"]
    if T_inj < m.T_rated:   # the machine makes its rated torque up to its rated speed; the band lies well below it
        raise ConfigError("injection.u_h", "designed", (
            f"no voltage left for a carrier: {designed['u_taken'].reason}; with the carrier's "
            f"{designed['u_taken'].value:.4g} V taken from it the drive makes at most {T_inj:.4g} N m there, below the "
            f"machine's rated {m.T_rated:.4g} N m (made up to its rated {rad_s_to_rpm(m.w_m_rated):.4g} rpm)"), source)
    return Value(v.value, v.unit, f"{v.reason}; while injecting there the drive makes at most {T_inj:.4g} N m of the "
                                  f"envelope's {T_all:.4g} N m at i_max (the planned flux weakening keeps the carrier's room)")


def _machine_injection(inj: dict, m: Machine, keys, source, designed: dict | None = None) -> None:
    """Fields left out of [injection] from the machine's [injection], else
    from the design (the rotating carrier's), else required."""
    mi = m.extra.get("injection", {})
    for key in keys:
        if inj[key] is None:
            if key in mi:
                inj[key] = float(mi[key])
            elif designed is not None and key in designed:
                inj[key] = designed[key].value
                inj.setdefault("_notes", {})[f"injection.{key}"] = designed[key]
            else:
                raise ConfigError(f"injection.{key}", "missing", f"is required: {m.name} has no [injection].{key}", source)


def _swvi_fields(d: dict, m: Machine, source, bw_speed_given: bool) -> None:
    """The square-wave injection (yu2022): carrier at a quarter of the sampling
    rate, the PLL, the sequence and the cross-saturation compensation."""
    ctl, inj = d["controller"], d["injection"]
    _check_saliency(ctl, m, source)
    if ctl["mode"] not in ("current", "speed"):
        raise ConfigError("controller.mode", ctl["mode"], "must be \"current\" or \"speed\" with angle = \"swvi\"", source)
    if ctl["lock"] == "recover":
        raise ConfigError("controller.lock", "recover", "must be \"off\", \"detect\" or \"stop\" with angle = \"swvi\": "
                          "the square wave has no restart sequence (no polarity detection)", source)
    _machine_injection(inj, m, ("u_h", "f_h", "bw_pll"), source)
    Ts = control_period(d)
    if not math.isclose(inj["f_h"], 0.25 / Ts, rel_tol=1e-6):
        raise ConfigError("injection.f_h", inj["f_h"], f"must be 1 / (4 Ts) = {0.25 / Ts:g} Hz: the filterless processing takes four samples per carrier period (yu2022 sec. 2.2)", source)
    if inj["bw_pll"] * Ts > 0.5:
        raise ConfigError("injection.bw_pll", inj["bw_pll"], f"must be <= {0.5 / Ts:g} rad/s for the control period {Ts:g} s", source)
    if not bw_speed_given and ctl["gains"] != "paper":
        # the speed is the PLL's PI output (fs_swvi.h), whose zero keeps its lag
        # small up to about half the PLL's bandwidth (yu2022: 31 against 57.5 rad/s)
        ctl["bw_speed"] = min(ctl["bw_speed"], inj["bw_pll"] / 2.0)
    u_lin = u_linear(d["converter"]["u_dc"], m.phases)
    if inj["u_h"] >= u_lin:
        raise ConfigError("injection.u_h", inj["u_h"], f"must be below the linear modulation limit {u_lin:.4g} V", source)
    xc = inj["xcomp"]
    if xc == "paper":
        poly = m.extra.get("injection", {}).get("xcomp_paper")
        if poly is None:
            raise ConfigError("injection.xcomp", xc, f"{m.name} has no [injection].xcomp_paper (a fitted error polynomial)", source)
        inj["xcomp"] = {"poly_error": [float(x) for x in poly]}
    elif xc is False:   # none, on purpose
        inj["xcomp"] = None
    elif xc is not None:
        inj["xcomp"] = xcomp_table(xc, source)


def _paper_gains(d: dict, m: Machine, source) -> None:
    """The machine's [paper_gains]: current PIs in V/A and V/(A s) per axis,
    the speed PI in A per mechanical rad/s (and per rad), turned into torque
    with the torque constant (phases / 2) p psi_f."""
    g = m.extra.get("paper_gains")
    keys = ("current_kp_d", "current_ki_d", "current_kp_q", "current_ki_q", "speed_kp", "speed_ki")
    if not g or any(k not in g for k in keys):
        raise ConfigError("controller.gains", "paper", f"{m.name} has no complete [paper_gains] ({', '.join(keys)})", source)
    k_T = 0.5 * m.phases * m.pole_pairs * m.psi_f
    d["controller"]["paper_gains"] = {
        "k_p_d": g["current_kp_d"], "k_i_d": g["current_ki_d"], "k_p_q": g["current_kp_q"], "k_i_q": g["current_ki_q"],
        "k_p_w": g["speed_kp"] * k_T, "k_i_w": g["speed_ki"] * k_T,
    }

