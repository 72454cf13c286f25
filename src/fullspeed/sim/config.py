"""A scenario as the C core's configuration (fs_sim_config: the plant, the
converter, the timing, the sensors, the faults and fs_drive_config), and
the buffers it points into."""
from __future__ import annotations

import math

import numpy as np

from .._core import ffi, lib
from ..design.controller import controller_model
from ..design.magnetics import controller_map, linear_controller_map
from ..model.errors import ConfigError
from ..model.scenario import Scenario
from ..model.units import hz_to_rad_s, rpm_to_rad_s

MODES = {"off": lib.FS_MODE_OFF, "voltage": lib.FS_MODE_VOLTAGE_DQ, "vf": lib.FS_MODE_VF,
         "current": lib.FS_MODE_CURRENT, "speed": lib.FS_MODE_SPEED}

ANGLES = {"encoder": lib.FS_ANGLE_ENCODER, "true": lib.FS_ANGLE_EXTERNAL, "smo": lib.FS_ANGLE_SMO,
          "hfi": lib.FS_ANGLE_HFI, "blend": lib.FS_ANGLE_BLEND, "swvi": lib.FS_ANGLE_SWVI}

SEQUENCES = {"conventional": lib.FS_SWVI_CONVENTIONAL, "optimized": lib.FS_SWVI_OPTIMIZED}

LAGS = {"exact": lib.FS_SMO_LAG_EXACT, "paper": lib.FS_SMO_LAG_PAPER}

SMO_FORMS = {"paper": lib.FS_SMO_FORM_PAPER, "tracking": lib.FS_SMO_FORM_TRACKING}

REGIONS = {"linear": lib.FS_IMC_LINEAR, "om1": lib.FS_IMC_OM1, "om2": lib.FS_IMC_OM2}

MAGNETIC = {"linear": lib.FS_MAG_LINEAR, "algebraic": lib.FS_MAG_ALGEBRAIC, "fluxmap": lib.FS_MAG_FLUXMAP}


class _Keep:
    """Keeps the cffi buffers alive as long as the config that points at them."""

    def __init__(self):
        self.items = []

    def __call__(self, x):
        self.items.append(x)
        return x


def _set_profile(prof, t, y, keep):
    prof.n = len(t)
    prof.t = keep(ffi.new("double[]", list(t)))
    prof.y = keep(ffi.new("double[]", list(y)))


def set_fluxmap(cfg_mag, mag: dict, keep):
    """The flux map (checked by model.machines) into the plant's config."""
    i_d, i_q, psi_d, psi_q = (np.asarray(mag[k], dtype=float) for k in ("i_d", "i_q", "psi_d", "psi_q"))
    cfg_mag.map_n_d, cfg_mag.map_n_q = i_d.size, i_q.size
    cfg_mag.map_i_d0, cfg_mag.map_di_d = i_d[0], i_d[1] - i_d[0]
    cfg_mag.map_i_q0, cfg_mag.map_di_q = i_q[0], i_q[1] - i_q[0]
    cfg_mag.map_psi_d = keep(ffi.new("double[]", psi_d.ravel().tolist()))
    cfg_mag.map_psi_q = keep(ffi.new("double[]", psi_q.ravel().tolist()))


def _controller_map(dc, cm: dict) -> None:
    """A flux map on the controller's grid (design.magnetics: fs_drive.h, map)."""
    mp = dc.map
    mp.di_d, mp.i_d0, mp.di_q, mp.psi_scale = cm["di_d"], cm["i_d0"], cm["di_q"], cm["psi_scale"]
    for k, (d, q) in enumerate(zip(cm["psi_d"], cm["psi_q"])):
        mp.psi_d[k], mp.psi_q[k] = d, q


def build_config(sc: Scenario):
    """The C configuration of a scenario, and the buffers it points into."""
    keep = _Keep()
    m, d = sc.machine, sc.data
    conv, tim, sen, ctl, load, ref = (d[k] for k in ("converter", "timing", "sensors", "controller", "load", "references"))
    cfg = keep(ffi.new("fs_sim_config *"))
    pl = cfg.plant
    pm = sc.plant or m   # the machine the simulation turns: the scenario's plant_machine, else the drive's
    pl.pole_pairs = pm.pole_pairs
    pl.R_s = pm.R_s
    pmag = pm.magnetic
    pl.mag.kind = MAGNETIC[pmag["model"]]
    pl.mag.L_d, pl.mag.L_q, pl.mag.psi_f = pm.L_d, pm.L_q, pm.psi_f
    for k in ("a_dd", "a_qq", "a_dq", "S", "T", "U", "V"):
        setattr(pl.mag, k, pmag[k])
    if pmag["model"] == "fluxmap":
        set_fluxmap(pl.mag, pmag, keep)
    pl.J, pl.B, pl.T_coulomb = pm.J, pm.B, pm.T_coulomb
    mag = m.magnetic
    pl.w_coulomb = 1e-2
    pl.load_kind = {"torque": lib.FS_LOAD_TORQUE, "speed": lib.FS_LOAD_SPEED_IDEAL, "speed_pi": lib.FS_LOAD_SPEED_PI,
                    "brake": lib.FS_LOAD_BRAKE}[load["kind"]]
    pl.J_load = load["J_load"]
    pl.load_bandwidth = load["bandwidth"]
    pl.phases = m.phases
    if m.phases == 5:   # the third-harmonic plane (model.machines checked the [third_harmonic] table)
        pl.L_d3, pl.L_q3, pl.psi_f3 = m.L_d3, m.L_q3, m.psi_f3

    _set_thermal(cfg.thermal, m, d["thermal"])
    _set_losses(cfg, m, d["losses"])
    if d["harmonics"]["enabled"]:
        _set_harmonics(pl, m)

    inv = cfg.inverter
    inv.kind = lib.FS_INV_SWITCHING if conv["inverter"] == "switching" else lib.FS_INV_AVERAGED
    inv.u_dc, inv.T_pwm, inv.t_dead, inv.u_on = conv["u_dc"], 1.0 / conv["f_pwm"], conv["t_dead"], conv["u_on"]
    inv.r_on = conv["r_on"]
    inv.phases = m.phases
    imc = conv["kind"] == "imc"
    cfg.converter = lib.FS_CONV_IMC if imc else lib.FS_CONV_VSI
    if imc:
        g = cfg.grid
        g.V_im = conv["grid_ll_rms"] * math.sqrt(2.0 / 3.0)
        g.f_grid, g.L_f, g.R_f, g.C_f = conv["f_grid"], conv["l_filter"], conv["r_filter"], conv["c_filter"]
    double = tim["sampling"] == "double"
    cfg.sampling = lib.FS_SAMPLING_DOUBLE if double else lib.FS_SAMPLING_SINGLE
    cfg.delay = 1 if tim["delay"] else 0
    cfg.h_max = tim["h_max"]
    Ts = inv.T_pwm / 2 if double else inv.T_pwm

    cfg.adc_bits, cfg.adc_range, cfg.noise_i = sen["adc_bits"], sen["adc_range"], sen["noise_i"]
    cfg.encoder_bits, cfg.seed = sen["encoder_bits"], sen["seed"]
    cfg.i_trip = m.bench["i_trip"]
    flt = d["faults"]
    fc = cfg.fault
    fc.t_sensor = flt["t_sensor"]
    for k, v in enumerate(flt["i_offset"]):
        fc.i_offset[k] = v
    for k, v in enumerate(flt["i_gain"]):
        fc.i_gain[k] = v
    fc.open_phase = {"none": 0, "a": 1, "b": 2, "c": 3}[flt["open_phase"]]
    fc.t_open = flt["t_open"]
    fc.t_encoder_stop = flt["t_encoder_stop"] or 0.0
    cfg.theta_m0 = math.radians(d["initial"]["theta_e_deg"]) / m.pole_pairs
    cfg.w_m0 = rpm_to_rad_s(d["initial"]["speed_rpm"])

    dc = cfg.drive
    dc.config_size = ffi.sizeof("fs_drive_config")   # fs_drive_init checks it against the library's
    dc.phases = m.phases
    dc.mode, dc.angle_source = MODES[ctl["mode"]], ANGLES[ctl["angle"]]
    dc.Ts, dc.T_pwm, dc.delay = Ts, inv.T_pwm, float(cfg.delay)
    cm = controller_model(ctl, m)
    dc.R_s, dc.L_d, dc.L_q, dc.psi_f = cm["R_s"], cm["L_d"], cm["L_q"], cm["psi_f"]
    dc.pole_pairs = m.pole_pairs
    if mag["model"] == "fluxmap":   # the machine's map, with the scenario's mismatch scales
        dc.L_d_hf, dc.L_q_hf = cm["L_d_hf"], cm["L_q_hf"]
        _controller_map(dc, controller_map(m.magnetic, ctl["i_max"], ctl["psi_f_scale"], ctl["L_d_scale"],
                                           ctl["L_q_scale"]))
    elif ctl["flux_weakening"] and ctl["fw_method"] == "planned":   # the map of the controller's constants
        _controller_map(dc, linear_controller_map(cm["psi_f"], cm["L_d"], cm["L_q"], ctl["i_max"]))
        dc.map_fw_only = 1   # the rest of the drive stays on the constants
    dc.J, dc.B = (m.J + (load["J_load"] if load["kind"] == "speed_pi" else 0.0)) * ctl["J_scale"], m.B
    dc.i_max, dc.T_max = ctl["i_max"], ctl["T_max"]
    dc.bw_current, dc.bw_speed, dc.bw_pll = ctl["bw_current"], ctl["bw_speed"], ctl["bw_pll"]
    dc.cc_internal_model = 1 if ctl["gains"] == "internal_model" else 0
    # the matrix converter's stage loses its dead time in each of the period's two intervals (fs_sim.h): the
    # compensation's one offset per period is twice the dead time (exact when the intervals' volt-seconds are equal)
    dc.t_dead_comp = (2.0 if imc else 1.0) * conv["t_dead"] if ctl["dead_time_comp"] else 0.0
    dc.i_dead_band = ctl["i_dead_band"]
    dc.dt_predict = 1 if ctl["dead_time_predict"] else 0
    if ctl["xy_control"]:   # the same bandwidth as the fundamental's loops
        dc.bw_xy, dc.L_d3, dc.L_q3, dc.psi_f3 = ctl["bw_current"], m.L_d3, m.L_q3, m.psi_f3
    dc.vf_gain, dc.vf_boost = ctl["vf_gain"], ctl["vf_boost"]
    if ctl["flux_weakening"]:   # fw_w_e_max > 0: on (fs_drive.h); the rest is fs_fw.h's, fw_method = "feedback"
        dc.fw_w_e_max = m.pole_pairs * rpm_to_rad_s(ctl["fw_top_speed_rpm"])
        dc.fw_gain = ctl["fw_gain"] or 0.0       # 0: designed in fs_drive_init
        dc.fw_cutoff = ctl["fw_cutoff"] or 0.0   # 0: designed in fs_drive_init
        dc.fw_hold = 1 if ctl["fw_excess"] == "held" else 0
    if ctl["param_adapt"]:
        dc.adapt.T_f = ctl["adapt_time"]
    dc.lock_time = ctl["lock_time"] if ctl["lock"] != "off" else 0.0
    dc.lock_recover = int(ctl["lock"] == "recover")
    dc.t_recover, dc.lock_retries = ctl["recover_time"], ctl["lock_retries"]
    cfg.lock_stop = ctl["lock"] in ("stop", "recover")   # with recovery: once the retries are spent
    dc.w_over = m.pole_pairs * rpm_to_rad_s(ctl["overspeed_rpm"])
    dc.T_slew = ctl["torque_slew"] or 0.0

    p = m.pole_pairs
    obs = d["observer"]
    oc = dc.smo
    oc.w_e_max = p * rpm_to_rad_s(obs["top_speed_rpm"])
    oc.i_max = ctl["i_max"]
    oc.k, oc.margin, oc.delta = obs["k"], obs["margin"], obs["delta"]
    oc.w_c_min = p * rpm_to_rad_s(obs["cutoff_min_rpm"])
    oc.bw_pll = obs["bw_pll"]
    oc.w_valid = p * rpm_to_rad_s(obs["valid_rpm"])
    oc.lag = LAGS[obs["lag"]]
    oc.form = SMO_FORMS[obs["form"]]
    if obs["start"] == "if":
        dc.i_start = obs["i_start"]
        dc.a_start = p * rpm_to_rad_s(obs["start_accel_rpm_s"])
        dc.w_handover = p * rpm_to_rad_s(obs["start_handover_rpm"])
        c = d["start"]["c"]
        dc.r_damp, dc.w_swing = c.get("r_damp", 0.0), c.get("w_swing", 0.0)
        dc.t_handover = obs["start_timeout"]
        dc.w_restart = p * rpm_to_rad_s(obs["restart_rpm"])
    if ctl["angle"] in ("hfi", "blend"):
        _set_injection(dc, d, p)
    if ctl["angle"] == "swvi":
        _set_swvi(dc.swvi, d["injection"])
    dc.converter = cfg.converter
    if imc:
        dc.imc_region = REGIONS[conv["modulation"]]
        dc.imc_w_grid = hz_to_rad_s(conv["f_grid"])
        dc.imc_depth = 1 if ctl["depth_control"] else 0
        dc.imc_i_lim = ctl["i_lim"]
        dc.imc_V_im = cfg.grid.V_im
    for key, value in ctl.get("paper_gains", {}).items():
        setattr(dc, key, value)
    if ctl["angle"] not in ("smo", "hfi", "blend", "swvi"):
        sensorless = ([0.0], [0.0])
    elif obs["handover"] > 0.0:
        sensorless = ([0.0, obs["handover"], obs["handover"]], [0.0, 0.0, 1.0])
    else:
        sensorless = ([0.0], [1.0])
    profiles = {
        "w_m_ref": (ref["speed_rpm"], rpm_to_rad_s(1.0)),
        "i_d_ref": (ref["i_d"], 1.0), "i_q_ref": (ref["i_q"], 1.0),
        "u_d_ref": (ref["u_d"], 1.0), "u_q_ref": (ref["u_q"], 1.0),
        "w_e_ref": (ref["frame_rpm"], p * rpm_to_rad_s(1.0)),
        "T_load": (load["torque"], 1.0), "w_load": (load["speed_rpm"], rpm_to_rad_s(1.0)),
        "sensorless": (sensorless, 1.0),
    }
    if flt["u_dc_scale"] != ([0.0], [1.0]):   # left empty, the runner skips it per sample
        profiles["u_dc_scale"] = (flt["u_dc_scale"], 1.0)
    for name, ((t, y), scale) in profiles.items():
        _set_profile(getattr(cfg, name), t, [v * scale for v in y], keep)
    cfg.decimation = d["trace"]["decimation"]
    return cfg, keep


def _set_harmonics(pl, m) -> None:
    """The machine's [harmonics] (checked by model.scenario) into
    the plant: back-EMF harmonic E_n / E_1 of order n is n psi_n / psi_f."""
    h = m.harmonics
    for k, n in enumerate((5, 7, 11, 13)):
        pl.psi_h[k] = h[f"emf{n}"] * m.psi_f / n
    for k, ax in enumerate(("dd", "qq", "dq")):
        pl.sal6[k], pl.sal12[k] = h[f"sal6_{ax}"], h[f"sal12_{ax}"]
    pl.T_cog, pl.cog_order = h["cogging_Nm"], h["cogging_order"]


def _set_thermal(tc, m, th: dict) -> None:
    """The machine's [thermal] table and the scenario's [thermal] run
    settings (checked by model.scenario) into the plant's config."""
    tc.enabled = 1 if th["enabled"] else 0
    if not th["enabled"]:
        return
    mt = m.thermal
    tc.T_amb, tc.T_ref, tc.T_w0, tc.T_m0 = th["T_amb"], mt["T_ref"], th["T_winding0"], th["T_magnet0"]
    tc.R_wa, tc.R_wm, tc.R_ma, tc.C_w, tc.C_m = (mt[k] for k in ("R_wa", "R_wm", "R_ma", "C_w", "C_m"))
    tc.alpha_cu, tc.alpha_br = mt["alpha_cu"], mt["alpha_br"]
    _set_iron(tc.iron, m)
    tc.k_rotor, tc.time_scale = mt["k_rotor"], th["time_scale"]


def _set_iron(fe, m) -> None:
    """The machine's [losses] iron loss (fs_losses.h; none without one)."""
    if m.losses is None:
        return
    lo = m.losses
    fe.P_ref, fe.k_hyst, fe.beta = lo["P_fe_ref"], lo["k_hyst"], lo["beta"]
    fe.w_ref = m.pole_pairs * rpm_to_rad_s(lo["speed_fe_rpm"])
    fe.psi_ref = m.psi_f if m.psi_f > 0 else 1.0   # a machine without magnet: its loss at any flux
    # the hysteresis drag's linear band around standstill: 1 % of the loss's speed, far below any operating point
    fe.w_band = 0.01 * rpm_to_rad_s(lo["speed_fe_rpm"])


def _set_losses(cfg, m, los: dict) -> None:
    """The scenario's [losses] (checked by model.scenario): the module's
    devices into the converter, the iron loss into the plant, the meters."""
    cfg.plant.losses = 1 if los["devices"] or los["iron"] or los["trace"] else 0
    if los["iron"]:
        _set_iron(cfg.plant.iron, m)
    if los["devices"]:
        cv, dev = m.converter, cfg.inverter.dev
        dev.enabled = 1
        dev.kind = lib.FS_DEV_MOSFET if cv["kind"] == "mosfet" else lib.FS_DEV_IGBT
        for key in ("u_t", "r_t", "u_d", "r_d", "E_on", "E_off", "E_rr", "I_ref", "V_ref", "k_i_t", "k_v_t", "k_i_d", "k_v_d"):
            setattr(dev, key, cv[key])


def _set_injection(dc, d: dict, p: int) -> None:
    """The injection estimator, the blend and the polarity detection (C
    defaults where a field is left out: 0)."""
    inj, pol, bl = d["injection"], d["polarity"], d["blending"]
    hc = dc.hfi
    hc.u_h, hc.w_h = inj["u_h"], hz_to_rad_s(inj["f_h"])
    hc.w_b_p = inj["bw_filter_p"] or 0.0
    hc.w_b_n = inj["bw_filter_n"] or 0.0
    hc.obs.bandwidth = inj["bw_observer"] or 0.0
    hc.leak = inj["leak"] == "remove"
    hc.lag = inj["tracking"] == "lag"
    xc = inj["xcomp"]
    if xc is not None:
        _set_xcomp(hc.xcomp, xc)
    if d["controller"]["angle"] == "blend":
        dc.blend.w_lower = p * rpm_to_rad_s(bl["lower_rpm"])
        dc.blend.w_upper = p * rpm_to_rad_s(bl["upper_rpm"])
        dc.blend.obs.bandwidth = bl["bw_observer"] or 0.0
        dc.blend.gate = bl["gate"]
        dc.w_inject_max = p * rpm_to_rad_s(inj["stop_rpm"])
    st = d["start"]
    if pol["enabled"] and st["kind"] == "motion":
        mc, c = dc.motion, st["c"]
        mc.i_push, mc.i_push_max, mc.t_lock, mc.t_push = st["i_push"], c["i_push_max"], c["t_lock"], c["t_push"]
        mc.theta_dec, mc.theta_max = math.radians(st["turn_deg"]), math.radians(c["theta_max_deg"])
    elif pol["enabled"]:
        dc.polarity.i_pulse, dc.polarity.t_lock, dc.polarity.t_pulse = pol["i_pulse"], pol["t_lock"], pol["t_pulse"]
        dc.polarity.i_pulse_max = pol["i_pulse_max"] or 0.0   # 0: up to i_max less the carrier's peak


def _set_swvi(sc, inj: dict) -> None:
    """The square-wave injection estimator (Ts, delay and inductances come from the drive)."""
    sc.u_h, sc.bandwidth = inj["u_h"], inj["bw_pll"]
    sc.sequence = SEQUENCES[inj["sequence"]]
    sc.carrier_off = not inj["carrier"]
    xc = inj["xcomp"]
    if xc is not None and "poly_error" in xc:
        for k, c in enumerate(xc["poly_error"]):   # the fit is of the error theta_r - theta_hat = -delta
            sc.xcomp.poly[k] = -c
    elif xc is not None:
        _set_xcomp(sc.xcomp, xc)


def _set_xcomp(xcfg, xc: dict) -> None:
    """A cross-saturation table {i_q, delta_deg} (even grid) into an fs_xcomp_config."""
    xcfg.n = len(xc["i_q"])
    xcfg.i_q0 = xc["i_q"][0]
    xcfg.di_q = (xc["i_q"][-1] - xc["i_q"][0]) / (len(xc["i_q"]) - 1)
    for k, v in enumerate(xc["delta_deg"]):
        xcfg.delta[k] = math.radians(v)


def check_smo_gain(cfg, sc: Scenario) -> None:
    """A configured SMO gain below eq. (18)'s bound, as a field error."""
    dc = cfg.drive
    oc = ffi.new("fs_smo_config *", dc.smo)
    oc.Ts, oc.R_s, oc.L_d, oc.L_q, oc.psi_f = dc.Ts, dc.R_s, dc.L_d, dc.L_q, dc.psi_f
    smo = ffi.new("fs_smo *")
    # FS_ERR_SMO_GAIN also covers a designed gain of 0 (no EMF); fs_sim_create names that one
    if lib.fs_smo_init(smo, oc) == lib.FS_ERR_SMO_GAIN and 0.0 < oc.k <= smo.k_bound:
        raise ConfigError("observer.k", sc.data["observer"]["k"],
                          f"must be above the Lyapunov bound of eq. (18), {smo.k_bound:.4g} V "
                          f"for the top speed {sc.data['observer']['top_speed_rpm']:g} rpm and i_max "
                          f"{sc.data['controller']['i_max']:g} A", sc.source)
