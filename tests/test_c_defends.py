"""The C side defends itself (issue 10, item 2), by property tests through cffi.

Init refusal: every fs_<thing>_init (and the designs, fs_xcomp_check, the
plant's fs_mag_init, fs_pmsm_init, fs_inverter_check, fs_grid_check) refuses
a config with one field made bad -- NaN, an infinity, a double beyond the
float range (1e39, which cffi stores as an infinity), a negative or zero
where the header asks for > 0 -- with a status whose message is a real one;
fs_drive_init names the field in `fail`, and fs_sim_create shows it as
"controller.<field>: <message>".

Step finiteness: each step function, on random configs within the headers'
ranges (and accepted by its init) and random finite inputs within their
physical ranges (currents within +-4 i_max, angles within +-1e3 rad, speeds
within +-2 x the top speed, a dc link > 0), run for a few hundred samples,
keeps every output and every float of its instance finite. Inputs are drawn
by numpy from a seed hypothesis chooses, with extremes (the range's ends, 0)
mixed in; the configs are drawn by hypothesis.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from fullspeed._core import ffi, lib
from fullspeed.design.scenario import load_scenario
from fullspeed.sim import build_config

INIT_SETTINGS = settings(deadline=None, max_examples=100)
STEP_SETTINGS = settings(deadline=None, max_examples=150, suppress_health_check=[HealthCheck.filter_too_much])
DRIVE_SETTINGS = settings(deadline=None, max_examples=1000, suppress_health_check=[HealthCheck.filter_too_much])
N_STEPS = 300
NAN, INF = float("nan"), float("inf")


def f32(x: float) -> float:
    return float(np.float32(x))


def message(status: int) -> str:
    return ffi.string(lib.fs_status_str(status)).decode()


def logu(lo: float, hi: float) -> st.SearchStrategy[float]:
    """Log-uniform float32 in [lo, hi]."""
    return st.floats(math.log10(lo), math.log10(hi)).map(lambda e: f32(10.0 ** e))


def unit(lo: float = 0.0, hi: float = 1.0) -> st.SearchStrategy[float]:
    """Uniform float32 in [lo, hi] (the ends rounded to float32)."""
    return st.floats(f32(lo), f32(hi), width=32)


# --- bad values, by the range a field documents -----------------------------

P, N, F = "P", "N", "F"          # > 0, >= 0, finite
NONFINITE = [NAN, INF, -INF, 1e39, -1e39]
BAD = {F: NONFINITE, N: NONFINITE + [-1.0, -1e-30], P: NONFINITE + [-1.0, 0.0, -1e-30]}
# doubles (the plant): 1e39 is a double like any other
BAD_D = {F: [NAN, INF, -INF], N: [NAN, INF, -INF, -1.0], P: [NAN, INF, -INF, -1.0, 0.0]}


def set_field(obj, path: str, value) -> None:
    """obj.a.b[2] = value for path 'a.b[2]'."""
    *head, last = path.split(".")
    for h in head:
        obj = getattr(obj, h)
    if last.endswith("]"):
        name, k = last[:-1].split("[")
        getattr(obj, name)[int(k)] = value
    else:
        setattr(obj, last, value)


def assert_refused(status: int, what: str) -> None:
    assert status != lib.FS_OK, f"{what}: accepted"
    assert 0 < status < lib.FS_ERR__COUNT, f"{what}: status {status} out of the enum"
    msg = message(status)
    assert msg != "unknown status" and msg, f"{what}: status {status} has no message"


# --- every init, with a valid base config and the range of each field --------

def _hfi_base():
    return {"Ts": 1e-4, "delay": 1.0, "u_h": 10.0, "w_h": 2 * math.pi * 1000, "R_s": 0.036, "L_d": 65e-6,
            "L_q": 90e-6, "w_b_p": 0.0, "w_b_n": 0.0, "obs": {"Ts": 1e-4, "J": 1.87e-3, "B": 0.0, "pole_pairs": 5}}


def xcomp_table():
    return {"n": 4, "i_q0": -2.0, "di_q": 1.5, "delta": [0.1, -0.2, 0.3, 0.05]}


# name: (instance type, config type, init, base config, {field: range})
INITS = {
    "pi": ("fs_pi *", "fs_pi_config *", lib.fs_pi_init,
           {"Ts": 1e-4, "k_t": 1.0, "k_p": 1.0, "k_i": 10.0, "u_max": 5.0},
           {"Ts": P, "k_t": N, "k_p": N, "k_i": N, "u_max": F}),
    "pll": ("fs_pll *", "fs_pll_config *", lib.fs_pll_init, {"Ts": 1e-4, "bandwidth": 100.0, "w_max": 0.0},
            {"Ts": P, "bandwidth": P, "w_max": F}),
    "lpf": ("fs_lpf *", "fs_lpf_config *", lib.fs_lpf_init, {"Ts": 1e-4, "w_c_min": 10.0}, {"Ts": P, "w_c_min": P}),
    "smo": ("fs_smo *", "fs_smo_config *", lib.fs_smo_init,
            {"Ts": 1e-4, "R_s": 0.036, "L_d": 65e-6, "L_q": 90e-6, "psi_f": 7.2e-3, "w_e_max": 2000.0, "i_max": 50.0,
             "k": 0.0, "margin": 1.5, "delta": 0.0, "w_c_min": 50.0, "bw_pll": 300.0, "w_valid": 100.0},
            {"Ts": P, "R_s": N, "L_d": P, "L_q": P, "psi_f": N, "w_e_max": P, "i_max": P, "k": N, "margin": P,
             "delta": N, "w_c_min": P, "bw_pll": P, "w_valid": N}),
    "current_ctrl": ("fs_current_ctrl *", "fs_current_ctrl_config *", lib.fs_current_ctrl_init,
                     {"Ts": 1e-4, "R_s": 0.036, "L_d": 65e-6, "L_q": 90e-6, "psi_f": 7.2e-3, "bandwidth": 2000.0,
                      "predict": 1},
                     {"Ts": P, "R_s": N, "L_d": P, "L_q": P, "psi_f": N, "bandwidth": P, "k_p_d": N, "k_i_d": N,
                      "k_p_q": N, "k_i_q": N}),
    "speed_ctrl": ("fs_speed_ctrl *", "fs_speed_ctrl_config *", lib.fs_speed_ctrl_init,
                   {"Ts": 1e-4, "J": 1.87e-3, "B": 1e-4, "bandwidth": 100.0, "T_max": 2.0},
                   {"Ts": P, "J": P, "B": N, "bandwidth": P, "T_max": P, "k_p": N, "k_i": N}),
    "mtpa": ("fs_mtpa *", "fs_mtpa_config *", lib.fs_mtpa_init,
             {"L_d": 65e-6, "L_q": 90e-6, "psi_f": 7.2e-3, "pole_pairs": 5, "i_max": 50.0, "phases": 3},
             {"L_d": P, "L_q": P, "psi_f": N, "i_max": P}),
    "fw": ("fs_fw *", "fs_fw_config *", lib.fs_fw_init,
           {"Ts": 1e-4, "L": 65e-6, "w_e_max": 2000.0, "gain": 1.0, "bandwidth": 500.0, "i_max": 50.0},
           {"Ts": P, "L": P, "w_e_max": P, "gain": P, "bandwidth": P, "i_max": P}),
    "srff": ("fs_srff *", "fs_srff_config *", lib.fs_srff_init, {"Ts": 1e-4, "w_b": 300.0}, {"Ts": P, "w_b": P}),
    "hfi_filter": ("fs_hfi_filter *", "fs_hfi_filter_config *", lib.fs_hfi_filter_init,
                   {"Ts": 1e-4, "w_b_p": 300.0, "w_b_n": 300.0}, {"Ts": P, "w_b_p": P, "w_b_n": P}),
    "motion_obs": ("fs_motion_obs *", "fs_motion_obs_config *", lib.fs_motion_obs_init,
                   {"Ts": 1e-4, "J": 1.87e-3, "B": 1e-4, "pole_pairs": 5, "bandwidth": 60.0},
                   {"Ts": P, "J": P, "B": N, "bandwidth": P}),
    "blend": ("fs_blend *", "fs_blend_config *", lib.fs_blend_init,
              {"w_lower": 100.0, "w_upper": 200.0,
               "obs": {"Ts": 1e-4, "J": 1.87e-3, "B": 0.0, "pole_pairs": 5, "bandwidth": 60.0}},
              {"w_lower": N, "w_upper": P, "obs.Ts": P, "obs.J": P, "obs.B": N, "obs.bandwidth": P}),
    "hfi": ("fs_hfi *", "fs_hfi_config *", lib.fs_hfi_init, _hfi_base(),
            {"Ts": P, "delay": F, "u_h": P, "w_h": P, "R_s": N, "L_d": P, "L_q": P, "w_b_p": N, "w_b_n": N,
             "obs.J": P, "obs.B": N, "obs.bandwidth": N, "xcomp.poly[0]": F, "xcomp.poly[3]": F}),
    "swvi": ("fs_swvi *", "fs_swvi_config *", lib.fs_swvi_init,
             {"Ts": 1e-4, "delay": 1, "u_h": 20.0, "L_d": 1e-3, "L_q": 2e-3, "bandwidth": 57.5, "w_max": 0.0,
              "sequence": 1},
             {"Ts": P, "u_h": P, "L_d": P, "L_q": P, "bandwidth": P, "w_max": N, "xcomp.poly[1]": F}),
    "polarity": ("fs_polarity *", "fs_polarity_config *", lib.fs_polarity_init,
                 {"Ts": 1e-4, "i_pulse": 10.0, "t_lock": 0.01, "t_pulse": 0.02},
                 {"Ts": P, "i_pulse": P, "t_lock": N, "t_pulse": P, "i_pulse_max": N, "d_min": N, "w_filter": N,
                  "w_max": N}),
    "lock": ("fs_lock *", "fs_lock_config *", lib.fs_lock_init, {"Ts": 1e-4, "t_lost": 0.02},
             {"Ts": P, "t_lost": P}),
    "imc_depth": ("fs_imc_depth *", "fs_imc_depth_config *", lib.fs_imc_depth_init,
                  {"Ts": 1e-4, "k_p": 0.1, "k_i": 10.0, "i_lim": 5.0},
                  {"Ts": P, "k_p": N, "k_i": N, "i_lim": P}),
}


def _init(name: str, cfg):
    inst_t, _, init, _, _ = INITS[name]
    return init(ffi.new(inst_t), cfg)


@pytest.mark.parametrize("name", sorted(INITS))
def test_base_configs_are_accepted(name):
    """The base configs the refusals start from are valid (so a refusal is the bad field's)."""
    _, cfg_t, _, base, _ = INITS[name]
    assert _init(name, ffi.new(cfg_t, base)) == lib.FS_OK


@INIT_SETTINGS
@given(data=st.data())
def test_every_control_init_refuses_a_bad_field(data):
    name = data.draw(st.sampled_from(sorted(INITS)), label="init")
    _, cfg_t, _, base, ranges = INITS[name]
    field = data.draw(st.sampled_from(sorted(ranges)), label="field")
    value = data.draw(st.sampled_from(BAD[ranges[field]]), label="value")
    cfg = ffi.new(cfg_t, base)
    set_field(cfg, field, value)
    assert_refused(_init(name, cfg), f"fs_{name}_init with {field} = {value}")


@INIT_SETTINGS
@given(which=st.sampled_from(["pi", "imc"]), arg=st.integers(0, 5), data=st.data())
def test_designs_refuse_a_bad_argument(which, arg, data):
    if which == "pi":   # Ts, L, R, alpha, u_max
        args, kinds = [1e-4, 1e-3, 0.1, 100.0, 0.0], [P, P, N, P, F]
        fn = lambda a: lib.fs_pi_design(ffi.new("fs_pi_config *"), *a)   # noqa: E731
    else:               # Ts, i_lim, V_im, w_e_max, L, bw
        args, kinds = [1e-4, 5.0, 100.0, 2000.0, 1e-3, 50.0], [P, P, P, P, P, P]
        fn = lambda a: lib.fs_imc_depth_design(ffi.new("fs_imc_depth_config *"), *a)   # noqa: E731
    assert fn(args) == lib.FS_OK
    k = arg % len(args)
    args[k] = data.draw(st.sampled_from(BAD[kinds[k]]))
    assert_refused(fn(args), f"{which} design with argument {k} = {args[k]}")


def test_designs_refuse_gains_beyond_the_float_range():
    """Every argument finite, the gains not: L / Ts beyond the float range."""
    assert_refused(lib.fs_pi_design(ffi.new("fs_pi_config *"), 1e-30, 1e30, 0.0, 1e29, 0.0), "pi design, L / Ts = 1e60")
    assert_refused(lib.fs_motion_obs_init(ffi.new("fs_motion_obs *"), ffi.new("fs_motion_obs_config *", {
        "Ts": 1e-30, "J": 1.0, "B": 0.0, "pole_pairs": 1, "bandwidth": 1e28})), "motion observer, Ts = 1e-30")
    assert_refused(lib.fs_fw_init(ffi.new("fs_fw *"), ffi.new("fs_fw_config *", {
        "Ts": 1e-4, "L": 1e-30, "w_e_max": 1e-20, "gain": 1.0, "bandwidth": 500.0, "i_max": 5.0})), "fw, w_e,max L = 1e-50")
    smo = dict(INITS["smo"][3], psi_f=0.0, L_q=INITS["smo"][3]["L_d"])   # no EMF: a designed gain of 0
    assert_refused(_init("smo", ffi.new("fs_smo_config *", smo)), "smo without EMF")
    mt = dict(INITS["mtpa"][3], i_max=1e30)   # torque beyond the float range
    assert_refused(_init("mtpa", ffi.new("fs_mtpa_config *", mt)), "mtpa, i_max = 1e30")


@INIT_SETTINGS
@given(data=st.data())
def test_xcomp_check_refuses_a_bad_table_or_polynomial(data):
    cfg = ffi.new("fs_xcomp_config *", xcomp_table())
    assert lib.fs_xcomp_check(cfg) == lib.FS_OK
    field = data.draw(st.sampled_from(["i_q0", "di_q", "delta[0]", "delta[3]", "poly[0]", "poly[2]", "n"]))
    if field == "n":
        value = data.draw(st.sampled_from([1, -1, 34]))
    elif field.startswith("delta"):
        value = data.draw(st.sampled_from(NONFINITE + [2.0, -1.6]))
    else:
        value = data.draw(st.sampled_from(BAD[P if field == "di_q" else F]))
    set_field(cfg, field, value)
    assert_refused(lib.fs_xcomp_check(cfg), f"xcomp with {field} = {value}")


# --- the plant (double) -----------------------------------------------------------

def _mag_linear():
    return {"kind": lib.FS_MAG_LINEAR, "L_d": 65e-6, "L_q": 90e-6, "psi_f": 7.2e-3}


def _mag_algebraic():
    return dict(_mag_linear(), kind=lib.FS_MAG_ALGEBRAIC, a_dd=10.0, a_qq=20.0, a_dq=5.0, S=4.0, T=2.0, U=1.0, V=0.0)


_MAP = ffi.new("double[9]", [0.0] * 9)


def _mag_fluxmap():
    return {"kind": lib.FS_MAG_FLUXMAP, "map_n_d": 3, "map_n_q": 3, "map_i_d0": -1.0, "map_di_d": 1.0, "map_i_q0": -1.0,
            "map_di_q": 1.0, "map_psi_d": _MAP, "map_psi_q": _MAP}


def _pmsm(mag: dict, phases: int = 3) -> dict:
    c = {"pole_pairs": 5, "R_s": 0.036, "mag": mag, "J": 1.87e-3, "B": 1e-4, "T_coulomb": 0.01, "w_coulomb": 0.01,
         "load_kind": lib.FS_LOAD_SPEED_PI, "J_load": 1e-3, "load_bandwidth": 50.0, "phases": phases}
    if phases == 5:
        c.update(L_d3=1e-4, L_q3=1e-4, psi_f3=1e-3)
    return c


PLANT = {
    "mag_linear": ("fs_mag *", "fs_mag_config *", lib.fs_mag_init, _mag_linear, {"L_d": P, "L_q": P, "psi_f": N}),
    "mag_algebraic": ("fs_mag *", "fs_mag_config *", lib.fs_mag_init, _mag_algebraic,
                      {"L_d": P, "L_q": P, "psi_f": N, "a_dd": N, "a_qq": N, "a_dq": N, "S": N, "T": N, "U": N, "V": N}),
    "mag_fluxmap": ("fs_mag *", "fs_mag_config *", lib.fs_mag_init, _mag_fluxmap,
                    {"L_d": F, "map_i_d0": F, "map_di_d": P, "map_i_q0": F, "map_di_q": P}),
    "pmsm": ("fs_pmsm *", "fs_pmsm_config *", lib.fs_pmsm_init, lambda: _pmsm(_mag_linear()),
             {"R_s": N, "J": P, "B": N, "T_coulomb": N, "w_coulomb": P, "J_load": N, "load_bandwidth": P,
              "mag.L_d": P, "mag.psi_f": N}),
    "pmsm5": ("fs_pmsm *", "fs_pmsm_config *", lib.fs_pmsm_init, lambda: _pmsm(_mag_linear(), 5),
              {"L_d3": P, "L_q3": P, "psi_f3": N}),
    "inverter": (None, "fs_inverter_config *", lib.fs_inverter_check,
                 lambda: {"kind": lib.FS_INV_SWITCHING, "u_dc": 48.0, "T_pwm": 1e-4, "t_dead": 1e-6, "u_on": 0.5,
                          "phases": 3},
                 {"u_dc": P, "T_pwm": P, "t_dead": N, "u_on": N}),
    "grid": (None, "fs_grid_config *", lib.fs_grid_check,
             lambda: {"V_im": 100.0, "f_grid": 50.0, "L_f": 1e-3, "R_f": 10.0, "C_f": 1e-5},
             {"V_im": P, "f_grid": P, "L_f": P, "R_f": P, "C_f": P}),
}


def _plant_init(name: str, cfg):
    inst_t, _, init, _, _ = PLANT[name]
    return init(cfg) if inst_t is None else init(ffi.new(inst_t), cfg)


@INIT_SETTINGS
@given(data=st.data())
def test_every_plant_init_refuses_a_bad_field(data):
    name = data.draw(st.sampled_from(sorted(PLANT)), label="init")
    _, cfg_t, _, base, ranges = PLANT[name]
    assert _plant_init(name, ffi.new(cfg_t, base())) == lib.FS_OK
    field = data.draw(st.sampled_from(sorted(ranges)), label="field")
    value = data.draw(st.sampled_from(BAD_D[ranges[field]]), label="value")
    cfg = ffi.new(cfg_t, base())
    set_field(cfg, field, value)
    assert_refused(_plant_init(name, cfg), f"{name} with {field} = {value}")


def test_plant_refuses_bad_enums_and_map_values():
    assert_refused(lib.fs_mag_init(ffi.new("fs_mag *"), ffi.new("fs_mag_config *", dict(_mag_linear(), kind=7))), "kind 7")
    bad_map = ffi.new("double[9]", [0.0, 1.0, NAN, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert_refused(lib.fs_mag_init(ffi.new("fs_mag *"), ffi.new("fs_mag_config *", dict(_mag_fluxmap(), map_psi_q=bad_map))),
                   "NaN in the flux map")
    assert_refused(lib.fs_pmsm_init(ffi.new("fs_pmsm *"), ffi.new("fs_pmsm_config *", dict(_pmsm(_mag_linear()), load_kind=9))),
                   "load kind 9")
    inv = {"kind": 0, "u_dc": 48.0, "T_pwm": 1e-4, "t_dead": 6e-5, "u_on": 0.0, "phases": 3}
    assert_refused(lib.fs_inverter_check(ffi.new("fs_inverter_config *", inv)), "t_dead above T_pwm / 2")


# --- the drive: fs_drive_init names the field, fs_sim_create shows it --------------

# The drive's table (fs_drive.c): checked in every mode, F finite, N >= 0, P > 0.
DRIVE_FIELDS = {
    "Ts": P, "T_pwm": P, "delay": F, "R_s": N, "L_d": P, "L_q": P, "psi_f": N, "J": F, "B": N, "i_max": P,
    "T_max": F, "bw_current": F, "bw_speed": F, "bw_pll": F, "t_dead_comp": N, "i_dead_band": N, "vf_gain": F,
    "vf_boost": F, "smo.w_e_max": F, "smo.i_max": F, "smo.k": F, "smo.margin": F, "smo.delta": F,
    "smo.w_c_min": F, "smo.bw_pll": F, "smo.w_valid": F, "fw_w_e_max": N, "fw_gain": N, "fw_cutoff": N,
    "lock_time": N, "t_recover": F, "i_start": N, "a_start": F, "w_handover": F, "hfi.u_h": F, "hfi.w_h": F,
    "hfi.w_b_p": F, "hfi.w_b_n": F, "hfi.obs.bandwidth": F, "blend.w_lower": F, "blend.w_upper": F,
    "blend.obs.bandwidth": F, "w_inject_max": N, "polarity.i_pulse": F, "polarity.t_lock": F,
    "polarity.t_pulse": F, "polarity.i_pulse_max": N, "polarity.d_min": N, "polarity.w_filter": N, "polarity.w_max": N, "swvi.u_h": F, "swvi.bandwidth": F, "swvi.w_max": F, "k_p_d": N, "k_i_d": N,
    "k_p_q": N, "k_i_q": N, "k_p_w": N, "k_i_w": N, "imc_w_grid": N, "imc_i_lim": F, "imc_V_im": F,
}
# Refused by a sub-block's init in the scenario below (current mode, SMO), with where it is named.
SUBBLOCK_FIELDS = {"bw_current": (P, "bw_current"), "bw_pll": (P, "bw_pll"), "smo.w_e_max": (P, "smo"),
                   "smo.i_max": (P, "smo"), "smo.margin": (P, "smo"), "smo.w_c_min": (P, "smo"),
                   "smo.bw_pll": (P, "smo"), "smo.k": (N, "smo"), "smo.delta": (N, "smo"), "smo.w_valid": (N, "smo")}
SCENARIO = "yang2022-smo-steady-400rpm"


@lru_cache(maxsize=1)
def _scenario_config():
    cfg, keep = build_config(load_scenario(SCENARIO))
    return cfg, keep


def _sim_config():
    cfg, _ = _scenario_config()
    return ffi.new("fs_sim_config *", cfg[0])


def test_the_scenario_drive_is_accepted():
    cfg = _sim_config()
    drv = ffi.new("fs_drive *")
    assert lib.fs_drive_init(drv, ffi.addressof(cfg, "drive")) == lib.FS_OK
    assert drv.fail == ffi.NULL
    err = ffi.new("char[512]")
    sim = lib.fs_sim_create(cfg, err, 512)
    assert sim != ffi.NULL, ffi.string(err).decode()
    lib.fs_sim_destroy(sim)


def _bad_drive_case(data):
    if data.draw(st.booleans(), label="range, not finiteness"):
        field = data.draw(st.sampled_from(sorted([f for f, k in DRIVE_FIELDS.items() if k != F] + list(SUBBLOCK_FIELDS))))
        kind, where = SUBBLOCK_FIELDS.get(field, (DRIVE_FIELDS[field], field))
        value = data.draw(st.sampled_from([v for v in BAD[kind] if math.isfinite(v) and abs(v) < 1e38]))
    else:
        field = data.draw(st.sampled_from(sorted(DRIVE_FIELDS)))
        value = data.draw(st.sampled_from(NONFINITE))
        where = field
    return field, value, where


@INIT_SETTINGS
@given(data=st.data())
def test_drive_init_names_the_field_it_refuses(data):
    field, value, where = _bad_drive_case(data)
    cfg = _sim_config()
    set_field(cfg.drive, field, value)
    drv = ffi.new("fs_drive *")
    status = lib.fs_drive_init(drv, ffi.addressof(cfg, "drive"))
    assert_refused(status, f"drive {field} = {value}")
    assert ffi.string(drv.fail).decode() == where


@INIT_SETTINGS
@given(data=st.data())
def test_sim_create_shows_the_refused_field_and_why(data):
    field, value, where = _bad_drive_case(data)
    cfg = _sim_config()
    set_field(cfg.drive, field, value)
    err = ffi.new("char[512]")
    assert lib.fs_sim_create(cfg, err, 512) == ffi.NULL
    text = ffi.string(err).decode()
    if field == "Ts" and not math.isnan(value):   # fs_sim_create's own check: Ts is the carrier's
        assert text.startswith("controller.Ts = ")
        return
    drv = ffi.new("fs_drive *")
    status = lib.fs_drive_init(drv, ffi.addressof(cfg, "drive"))
    assert text == f"controller.{where}: {message(status)}"


@pytest.mark.parametrize("field, value, where", [
    ("mode", 9, "mode"), ("angle_source", -1, "angle_source"), ("pole_pairs", 0, "pole_pairs"),
    ("phases", 4, "phases"), ("converter", 2, "converter"), ("lock_recover", 2, "lock_recover"),
    ("T_pwm", 1e-5, "T_pwm"), ("delay", 3.0, "delay"), ("i_start", 1e3, "i_start"),
    ("t_dead_comp", 1e-3, "t_dead_comp"), ("smo.lag", 7, "smo"),
])
def test_drive_init_names_ints_and_relations(field, value, where):
    cfg = _sim_config()
    set_field(cfg.drive, field, value)
    drv = ffi.new("fs_drive *")
    assert_refused(lib.fs_drive_init(drv, ffi.addressof(cfg, "drive")), f"{field} = {value}")
    assert ffi.string(drv.fail).decode() == where


def test_drive_refuses_a_carrier_above_half_the_current_limit():
    cfg = _sim_config()
    d = cfg.drive
    d.angle_source = lib.FS_ANGLE_HFI
    d.hfi.u_h, d.hfi.w_h = 10.0, 2 * math.pi * 1000
    i_hf = 10.0 / (2 * math.pi * 1000 * min(d.L_d, d.L_q))
    d.i_max = 1.9 * i_hf
    drv = ffi.new("fs_drive *")
    status = lib.fs_drive_init(drv, ffi.addressof(cfg, "drive"))
    assert status == lib.FS_ERR_ABOVE_I_MAX and ffi.string(drv.fail) == b"hfi.u_h"
    d.i_max = 2.1 * i_hf
    assert lib.fs_drive_init(drv, ffi.addressof(cfg, "drive")) == lib.FS_OK


# --- step finiteness ------------------------------------------------------------------

@lru_cache(maxsize=None)
def _float_fields(ctype) -> tuple[np.ndarray, tuple[str, ...]]:
    """Indices (in floats) and names of every float of a struct, nested structs and arrays included."""
    idx, names = [], []

    def walk(t, base, name):
        if t.kind == "struct":
            for fname, f in t.fields:
                walk(f.type, base + f.offset, f"{name}.{fname}" if name else fname)
        elif t.kind == "array":
            for k in range(t.length):
                walk(t.item, base + k * ffi.sizeof(t.item), f"{name}[{k}]")
        elif t.kind == "primitive" and t.cname == "float":
            assert base % 4 == 0
            idx.append(base // 4)
            names.append(name)
    walk(ctype, 0, "")
    return np.array(idx, dtype=np.intp), tuple(names)


class Finite:
    """Watches every float of a struct (through a live numpy view of its memory)."""

    def __init__(self, ptr):
        self.idx, self.names = _float_fields(ffi.typeof(ptr).item)
        self.view = np.frombuffer(ffi.buffer(ptr), dtype=np.float32)

    def check(self, what: str, k: int) -> None:
        ok = np.isfinite(self.view[self.idx])
        if not ok.all():
            bad = [f"{self.names[j]} = {self.view[self.idx[j]]}" for j in np.flatnonzero(~ok)[:6]]
            raise AssertionError(f"{what}: not finite after step {k}: {', '.join(bad)}")


def draws(rng: np.random.Generator, shape, lo: float, hi: float) -> np.ndarray:
    """float32 inputs uniform in [lo, hi], with the ends and 0 (if inside) mixed in."""
    x = rng.uniform(lo, hi, size=shape)
    pick = rng.random(size=shape)
    x = np.where(pick < 0.04, lo, x)
    x = np.where((pick >= 0.04) & (pick < 0.08), hi, x)
    if lo <= 0.0 <= hi:
        x = np.where((pick >= 0.08) & (pick < 0.1), 0.0, x)
    return x.astype(np.float32)


def sym(rng, shape, bound: float) -> np.ndarray:
    return draws(rng, shape, -bound, bound)


seeds = st.integers(0, 2**32 - 1)
ANGLE = 1e3


def run_steps(what: str, watched, step, n: int = N_STEPS) -> None:
    """Call step(k) n times; after each, every watched struct is finite."""
    checks = [Finite(p) for p in watched]
    for k in range(n):
        step(k)
        for c in checks:
            c.check(what, k)


def _init_or_skip(init, inst, cfg) -> None:
    status = init(inst, cfg)
    assume(status == lib.FS_OK)


# machine-like parameters shared by the step tests
Ts_s = logu(1e-6, 1e-2)
L_s = logu(1e-6, 1.0)
R_s_s = st.one_of(st.just(0.0), logu(1e-3, 100.0))
psi_s = st.one_of(st.just(0.0), logu(1e-4, 5.0))
i_max_s = logu(0.1, 2000.0)
J_s = logu(1e-7, 100.0)
p_s = st.integers(1, 50)
T_s = logu(1e-3, 1e4)


@STEP_SETTINGS
@given(Ts=Ts_s, k_t=unit(0, 1e3), k_p=unit(0, 1e3), k_i=logu(1e-3, 1e6), u_max=unit(-1.0, 1e3), seed=seeds)
def test_pi_step_stays_finite(Ts, k_t, k_p, k_i, u_max, seed):
    pi = ffi.new("fs_pi *")
    _init_or_skip(lib.fs_pi_init, pi, ffi.new("fs_pi_config *", [Ts, k_t, k_p, k_i, u_max]))
    rng = np.random.default_rng(seed)
    r, y = sym(rng, N_STEPS, 1e3), sym(rng, N_STEPS, 1e3)
    out = ffi.new("float[1]")

    def step(k):
        out[0] = lib.fs_pi_step(pi, r[k], y[k])
    run_steps("pi", [pi, out], step)


@STEP_SETTINGS
@given(Ts=Ts_s, bw=unit(1e-3, 0.5), w_max=unit(-1.0, 1e5), seed=seeds)
def test_pll_step_stays_finite(Ts, bw, w_max, seed):
    pll = ffi.new("fs_pll *")
    _init_or_skip(lib.fs_pll_init, pll, ffi.new("fs_pll_config *", [Ts, f32(bw / Ts), w_max]))
    err = sym(np.random.default_rng(seed), N_STEPS, math.pi)
    run_steps("pll", [pll], lambda k: lib.fs_pll_step(pll, err[k]))


@STEP_SETTINGS
@given(Ts=Ts_s, w_c_min=logu(1e-3, 1e5), w_top=logu(1.0, 1e5), seed=seeds)
def test_lpf_step_stays_finite(Ts, w_c_min, w_top, seed):
    f = ffi.new("fs_lpf *")
    _init_or_skip(lib.fs_lpf_init, f, ffi.new("fs_lpf_config *", [Ts, w_c_min]))
    rng = np.random.default_rng(seed)
    x, w = sym(rng, (N_STEPS, 2), 1e4), sym(rng, N_STEPS, 2 * w_top)
    run_steps("lpf", [f], lambda k: lib.fs_lpf_step(f, {"alpha": x[k, 0], "beta": x[k, 1]}, w[k]))


@st.composite
def smo_configs(draw):
    Ts, L_d = draw(Ts_s), draw(L_s)
    psi_f = draw(psi_s)
    L_q = draw(st.one_of(st.just(L_d), unit(0.3, 3.0).map(lambda r: f32(r * L_d))))
    w_e_max = f32(draw(unit(0.01, 1.0)) / Ts)
    c = {"Ts": Ts, "R_s": draw(R_s_s), "L_d": L_d, "L_q": L_q, "psi_f": psi_f, "w_e_max": w_e_max,
         "i_max": draw(i_max_s), "k": 0.0, "margin": draw(unit(1.0, 3.0)), "delta": draw(unit(0.0, 1.0)),
         "w_c_min": f32(draw(unit(1e-3, 0.5)) * w_e_max), "bw_pll": f32(draw(unit(1e-3, 0.5)) / Ts),
         "w_valid": f32(draw(unit(0.0, 0.3)) * w_e_max), "lag": draw(st.sampled_from([0, 1])),
         "dir_external": draw(st.sampled_from([0, 1]))}
    return c


@STEP_SETTINGS
@given(cfg=smo_configs(), seed=seeds)
def test_smo_step_stays_finite(cfg, seed):
    o = ffi.new("fs_smo *")
    _init_or_skip(lib.fs_smo_init, o, ffi.new("fs_smo_config *", cfg))
    rng = np.random.default_rng(seed)
    i = sym(rng, (N_STEPS, 2), 4 * cfg["i_max"])
    u = sym(rng, (N_STEPS, 2), 2 * o.k + 2 * cfg["R_s"] * cfg["i_max"] + 1.0)   # what a drive can apply
    w_dir = sym(rng, N_STEPS, 2 * cfg["w_e_max"])

    def step(k):
        if cfg["dir_external"]:
            lib.fs_smo_set_dir(o, w_dir[k])
        lib.fs_smo_step(o, {"alpha": i[k, 0], "beta": i[k, 1]}, {"alpha": u[k, 0], "beta": u[k, 1]})
    run_steps("smo", [o], step)


@STEP_SETTINGS
@given(Ts=Ts_s, L_d=L_s, ratio=unit(0.3, 3.0), R=R_s_s, psi_f=psi_s, bw=unit(0.01, 1.0), predict=st.booleans(),
       explicit=st.booleans(), k_p=logu(1e-3, 1e3), k_i=logu(1e-3, 1e6), i_max=i_max_s, im=st.booleans(),
       seed=seeds)
def test_current_ctrl_step_stays_finite(Ts, L_d, ratio, R, psi_f, bw, predict, explicit, k_p, k_i, i_max, im, seed):
    cc = ffi.new("fs_current_ctrl *")
    gains = [k_p, k_i, k_p, k_i] if explicit else [0.0] * 4
    cfg = ffi.new("fs_current_ctrl_config *", [Ts, R, L_d, f32(ratio * L_d), psi_f, f32(bw / Ts), predict, *gains])
    if im and not explicit:
        lib.fs_current_ctrl_internal_model(cfg)
    _init_or_skip(lib.fs_current_ctrl_init, cc, cfg)
    rng = np.random.default_rng(seed)
    w_top = 1.0 / Ts
    ref, i, w = sym(rng, (N_STEPS, 2), 2 * i_max), sym(rng, (N_STEPS, 2), 4 * i_max), sym(rng, N_STEPS, 2 * w_top)
    u_lim = draws(rng, N_STEPS, 1e-3, 1e3)   # the modulator's limit this step
    out = ffi.new("fs_dq *")

    def step(k):
        u = lib.fs_current_ctrl_step(cc, {"d": ref[k, 0], "q": ref[k, 1]}, {"d": i[k, 0], "q": i[k, 1]}, w[k])
        out.d, out.q = u.d, u.q
        m = math.hypot(u.d, u.q)
        s = min(1.0, u_lim[k] / m) if m > 0 else 1.0
        u_real = {"d": f32(u.d * s), "q": f32(u.q * s)}
        if k % 2:   # an outer loop keeps half the excess (fs_fw_hold)
            lib.fs_current_ctrl_update_held(cc, u_real, {"d": f32(u.d * (1 + s) / 2), "q": f32(u.q * (1 + s) / 2)})
        else:
            lib.fs_current_ctrl_update(cc, u_real)
    run_steps("current_ctrl", [cc, out], step)


@STEP_SETTINGS
@given(Ts=Ts_s, J=J_s, B=unit(0.0, 0.1), bw=unit(1e-3, 0.5), T_max=T_s,
       explicit=st.booleans(), k_p=logu(1e-4, 1e2), k_i=logu(1e-4, 1e4), w_top=logu(1.0, 3e3), seed=seeds)
def test_speed_ctrl_step_stays_finite(Ts, J, B, bw, T_max, explicit, k_p, k_i, w_top, seed):
    sc = ffi.new("fs_speed_ctrl *")
    cfg = ffi.new("fs_speed_ctrl_config *", [Ts, J, B, f32(bw / Ts), T_max, *((k_p, k_i) if explicit else (0.0, 0.0))])
    _init_or_skip(lib.fs_speed_ctrl_init, sc, cfg)
    rng = np.random.default_rng(seed)
    r, w, T_real = sym(rng, N_STEPS, 2 * w_top), sym(rng, N_STEPS, 2 * w_top), sym(rng, N_STEPS, T_max)
    out = ffi.new("float[1]")

    def step(k):
        out[0] = T = lib.fs_speed_ctrl_step(sc, r[k], w[k])
        lib.fs_speed_ctrl_realised(sc, T, T_real[k] if abs(T_real[k]) < abs(T) else T)
    run_steps("speed_ctrl", [sc, out], step)


@STEP_SETTINGS
@given(L_d=L_s, ratio=unit(1.0, 5.0), psi_f=psi_s, p=p_s, i_max=i_max_s, phases=st.sampled_from([3, 5]),
       seed=seeds)
def test_mtpa_step_stays_finite_and_within_the_limit(L_d, ratio, psi_f, p, i_max, phases, seed):
    m = ffi.new("fs_mtpa *")
    _init_or_skip(lib.fs_mtpa_init, m, ffi.new("fs_mtpa_config *", [L_d, f32(ratio * L_d), psi_f, p, i_max, phases]))
    T = sym(np.random.default_rng(seed), N_STEPS, 2 * m.T[lib.FS_MTPA_N - 1])
    out = ffi.new("fs_dq *")

    def step(k):
        r = lib.fs_mtpa_step(m, T[k])
        out.d, out.q = r.d, r.q
        assert math.hypot(r.d, r.q) <= i_max * (1 + 1e-4)
    run_steps("mtpa", [m, out], step)


@STEP_SETTINGS
@given(Ts=Ts_s, L=L_s, w_top=logu(1.0, 1e5), gain=logu(0.1, 100.0), bw=unit(1e-3, 1.0), i_max=i_max_s, seed=seeds)
def test_fw_step_stays_finite(Ts, L, w_top, gain, bw, i_max, seed):
    fw = ffi.new("fs_fw *")
    _init_or_skip(lib.fs_fw_init, fw, ffi.new("fs_fw_config *", [Ts, L, w_top, gain, f32(bw / Ts), i_max]))
    rng = np.random.default_rng(seed)
    dv, w = sym(rng, N_STEPS, 1e3), sym(rng, N_STEPS, 2 * w_top)
    u_real = sym(rng, (N_STEPS, 2), 1e3)
    out = ffi.new("fs_dq *")

    def step(k):
        lib.fs_fw_step(fw, dv[k], w[k])
        real = {"d": f32(u_real[k, 0]), "q": f32(u_real[k, 1])}
        ref = {"d": f32(real["d"] + 0.3 * dv[k]), "q": f32(real["q"] + dv[k])}
        h = lib.fs_fw_hold(fw, ref, real, w[k])
        out.d, out.q = h.d, h.q
        for ax in ("d", "q"):   # between the realised voltage and the reference: a share of the excess
            lo, hi = sorted((real[ax], ref[ax]))
            tol = 1e-6 * max(abs(lo), abs(hi), 1.0)
            assert lo - tol <= getattr(h, ax) <= hi + tol
    run_steps("fw", [fw, out], step)


@STEP_SETTINGS
@given(Ts=Ts_s, b_p=unit(1e-3, 0.5), b_n=unit(1e-3, 0.5), seed=seeds)
def test_srff_and_hfi_filter_steps_stay_finite(Ts, b_p, b_n, seed):
    sr = ffi.new("fs_srff *")
    hf = ffi.new("fs_hfi_filter *")
    _init_or_skip(lib.fs_srff_init, sr, ffi.new("fs_srff_config *", [Ts, f32(b_p / Ts)]))
    _init_or_skip(lib.fs_hfi_filter_init, hf, ffi.new("fs_hfi_filter_config *", [Ts, f32(b_p / Ts), f32(b_n / Ts)]))
    rng = np.random.default_rng(seed)
    x, th = sym(rng, (N_STEPS, 2), 1e4), sym(rng, (N_STEPS, 2), ANGLE)
    i_f, i_hn, y = ffi.new("fs_ab *"), ffi.new("fs_ab *"), ffi.new("fs_ab *")

    def step(k):
        xk = {"alpha": x[k, 0], "beta": x[k, 1]}
        r = lib.fs_srff_step(sr, xk, th[k, 0])
        y.alpha, y.beta = r.alpha, r.beta
        lib.fs_hfi_filter_step(hf, xk, th[k, 0], th[k, 1], i_f, i_hn)
    run_steps("srff, hfi_filter", [sr, hf, i_f, i_hn, y], step)


obs_configs = st.builds(lambda Ts, J, B, p, bw: [Ts, J, B, p, f32(bw / Ts)],
                        Ts_s, J_s, unit(0.0, 1.0), p_s, unit(1e-3, 0.5))


@STEP_SETTINGS
@given(cfg=obs_configs, T_max=T_s, seed=seeds)
def test_motion_obs_step_stays_finite(cfg, T_max, seed):
    o = ffi.new("fs_motion_obs *")
    _init_or_skip(lib.fs_motion_obs_init, o, ffi.new("fs_motion_obs_config *", cfg))
    rng = np.random.default_rng(seed)
    eps, T = sym(rng, N_STEPS, ANGLE), sym(rng, N_STEPS, 2 * T_max)
    run_steps("motion_obs", [o], lambda k: lib.fs_motion_obs_step(o, eps[k], T[k]))


@STEP_SETTINGS
@given(obs=obs_configs, lo=unit(0.0, 0.3), width=unit(0.01, 0.5), T_max=T_s, seed=seeds)
def test_blend_step_stays_finite(obs, lo, width, T_max, seed):
    b = ffi.new("fs_blend *")
    w_top = 0.5 / obs[0]
    cfg = ffi.new("fs_blend_config *", {"w_lower": f32(lo * w_top), "w_upper": f32((lo + width) * w_top), "obs": obs})
    _init_or_skip(lib.fs_blend_init, b, cfg)
    rng = np.random.default_rng(seed)
    th, T = sym(rng, (N_STEPS, 2), ANGLE), sym(rng, N_STEPS, 2 * T_max)
    run_steps("blend", [b], lambda k: lib.fs_blend_step(b, th[k, 0], th[k, 1], T[k]))


xcomps = st.one_of(
    st.just({}),
    st.builds(lambda p: {"poly": p}, st.lists(unit(-1.0, 1.0), min_size=4, max_size=4)),
    st.builds(lambda n, i0, di, d: {"n": n, "i_q0": i0, "di_q": di, "delta": d[:n]},
              st.integers(2, 33), unit(-100.0, 0.0), logu(1e-2, 10.0),
              st.lists(unit(-1.5, 1.5), min_size=33, max_size=33)))


@st.composite
def hfi_configs(draw):
    Ts, L_d = draw(Ts_s), draw(L_s)
    L_q = f32(L_d * draw(st.one_of(unit(0.3, 0.95), unit(1.05, 4.0))))
    w_h = f32(draw(unit(0.05, 0.5 * math.pi)) / Ts)
    i_max = draw(i_max_s)
    u_h = f32(draw(unit(0.01, 0.9)) * 0.5 * i_max * w_h * min(L_d, L_q))
    opt = lambda lo, hi: st.one_of(st.just(0.0), unit(lo, hi).map(lambda x: f32(x / Ts)))   # noqa: E731
    return {"Ts": Ts, "delay": draw(st.sampled_from([0.0, 0.5, 1.0, 2.0])), "u_h": u_h, "w_h": w_h,
            "R_s": draw(R_s_s), "L_d": L_d, "L_q": L_q, "w_b_p": draw(opt(1e-3, 0.5)), "w_b_n": draw(opt(1e-2, 0.5)),
            "obs": {"Ts": Ts, "J": draw(J_s), "B": draw(unit(0.0, 0.1)),
                    "pole_pairs": draw(p_s), "bandwidth": draw(opt(1e-3, 0.5))},
            "xcomp": draw(xcomps)}, i_max


@STEP_SETTINGS
@given(cfg_i=hfi_configs(), T_max=T_s, seed=seeds)
def test_hfi_step_stays_finite(cfg_i, T_max, seed):
    cfg, i_max = cfg_i
    h = ffi.new("fs_hfi *")
    _init_or_skip(lib.fs_hfi_init, h, ffi.new("fs_hfi_config *", cfg))
    rng = np.random.default_rng(seed)
    i, T = sym(rng, (N_STEPS, 2), 4 * i_max), sym(rng, N_STEPS, 2 * T_max)
    # the caller's scale, 0..1: mostly 1, sometimes anywhere, near 0 or 0
    gain = np.select([rng.random(N_STEPS) < 0.8, rng.random(N_STEPS) < 0.5], [1.0, rng.random(N_STEPS)],
                     rng.choice([0.0, 1e-45, 1e-38, 1e-20, 1e-8], N_STEPS)).astype(np.float32)

    def step(k):
        h.gain = gain[k]
        lib.fs_hfi_step(h, {"alpha": i[k, 0], "beta": i[k, 1]}, T[k])
    run_steps("hfi", [h], step)


@STEP_SETTINGS
@given(Ts=Ts_s, L_d=L_s, ratio=st.one_of(unit(0.3, 0.95), unit(1.05, 4.0)), u_h=logu(0.1, 100.0), bw=unit(1e-3, 0.5),
       w_max=st.one_of(st.just(0.0), logu(1.0, 1e5)), delay=st.sampled_from([0, 1]), seq=st.sampled_from([0, 1]),
       off=st.booleans(), xcomp=xcomps, i_max=i_max_s, seed=seeds)
def test_swvi_step_stays_finite(Ts, L_d, ratio, u_h, bw, w_max, delay, seq, off, xcomp, i_max, seed):
    s = ffi.new("fs_swvi *")
    cfg = {"Ts": Ts, "delay": delay, "u_h": u_h, "L_d": L_d, "L_q": f32(ratio * L_d), "bandwidth": f32(bw / Ts),
           "w_max": w_max, "sequence": seq, "xcomp": xcomp, "carrier_off": off}
    _init_or_skip(lib.fs_swvi_init, s, ffi.new("fs_swvi_config *", cfg))
    i = sym(np.random.default_rng(seed), (N_STEPS, 2), 4 * i_max)
    run_steps("swvi", [s], lambda k: lib.fs_swvi_step(s, {"alpha": i[k, 0], "beta": i[k, 1]}))


@STEP_SETTINGS
@given(Ts=Ts_s, i_max=i_max_s, pulse=unit(0.01, 1.0), n_lock=st.integers(0, 50), n_pulse=st.integers(4, 100),
       t_lost=st.integers(1, 100), seed=seeds)
def test_polarity_lock_and_imc_depth_steps_stay_finite(Ts, i_max, pulse, n_lock, n_pulse, t_lost, seed):
    p, lk, dc = ffi.new("fs_polarity *"), ffi.new("fs_lock *"), ffi.new("fs_imc_depth *")
    _init_or_skip(lib.fs_polarity_init, p, ffi.new("fs_polarity_config *", [Ts, f32(pulse * i_max), f32(n_lock * Ts),
                                                                             f32(n_pulse * Ts)]))
    _init_or_skip(lib.fs_lock_init, lk, ffi.new("fs_lock_config *", [Ts, f32(t_lost * Ts)]))
    dcfg = ffi.new("fs_imc_depth_config *")
    assume(lib.fs_imc_depth_design(dcfg, Ts, f32(pulse * i_max), 100.0, 0.3 / Ts, 1e-3, 0.05 / Ts) == lib.FS_OK)
    _init_or_skip(lib.fs_imc_depth_init, dc, dcfg)
    rng = np.random.default_rng(seed)
    i_p, r, i_ref = draws(rng, N_STEPS, 0.0, 4 * i_max), sym(rng, N_STEPS, 1e6), draws(rng, N_STEPS, 0.0, 4 * i_max)
    weak = rng.random(N_STEPS) < 0.8
    w = sym(rng, N_STEPS, 1e4)
    out = ffi.new("float[2]")

    def step(k):
        out[0] = lib.fs_polarity_step(p, i_p[k], w[k])
        lib.fs_lock_step(lk, r[k])
        out[1] = lib.fs_imc_depth_step(dc, i_ref[k], bool(weak[k]))
        assert abs(out[0]) <= p.cfg.i_pulse_max and 0.0 <= out[1] <= math.pi / 6 + 1e-6
    run_steps("polarity, lock, imc depth", [p, lk, dc, out], step)


# --- the drive, in every mode and angle source ------------------------------------------

MODES = [lib.FS_MODE_OFF, lib.FS_MODE_VOLTAGE_DQ, lib.FS_MODE_VF, lib.FS_MODE_CURRENT, lib.FS_MODE_SPEED]
SOURCES = [lib.FS_ANGLE_ENCODER, lib.FS_ANGLE_EXTERNAL, lib.FS_ANGLE_SMO, lib.FS_ANGLE_HFI, lib.FS_ANGLE_BLEND,
           lib.FS_ANGLE_SWVI]


@st.composite
def drive_configs(draw):
    """A random drive config within the headers' ranges: the machine, the mode
    and source, and the options each uses (flux weakening, I/f start, lock
    monitor and recovery, polarity detection, dead-time compensation,
    explicit gains, the matrix converter)."""
    mode, src = draw(st.sampled_from(MODES)), draw(st.sampled_from(SOURCES))
    if src == lib.FS_ANGLE_SWVI and mode in (lib.FS_MODE_VOLTAGE_DQ, lib.FS_MODE_VF):
        mode = lib.FS_MODE_CURRENT
    phases = draw(st.sampled_from([3, 5]))
    Ts = draw(Ts_s)
    Tl = 2 * Ts if src == lib.FS_ANGLE_SWVI else Ts
    L_d = draw(L_s)
    salient = src in (lib.FS_ANGLE_HFI, lib.FS_ANGLE_BLEND, lib.FS_ANGLE_SWVI)
    lo_ratio = 1.05 if salient else 1.0
    L_q = f32(L_d * draw(unit(lo_ratio, 4.0)))
    psi_f = draw(psi_s)
    if src in (lib.FS_ANGLE_SMO, lib.FS_ANGLE_BLEND) and psi_f == 0.0 and L_q == L_d:
        psi_f = 0.01
    p = draw(p_s)
    i_max = draw(i_max_s)
    w_top = f32(draw(unit(0.01, 0.5)) / Ts)   # top electrical speed: at least 12 samples a turn
    opt = lambda lo, hi: st.one_of(st.just(0.0), unit(lo, hi))   # noqa: E731
    c = {
        "phases": phases, "mode": mode, "angle_source": src, "Ts": Ts,
        "T_pwm": f32(Ts * draw(st.sampled_from([1.0, 2.0]))), "delay": draw(st.sampled_from([0.0, 1.0])),
        "R_s": draw(R_s_s), "L_d": L_d, "L_q": L_q, "psi_f": psi_f, "pole_pairs": p,
        "J": draw(J_s), "B": draw(unit(0.0, 0.1)), "i_max": i_max, "T_max": draw(T_s),
        "bw_current": f32(draw(unit(0.02, 1.0)) / Tl), "bw_speed": f32(draw(unit(1e-3, 0.5)) / Tl),
        "bw_pll": f32(draw(unit(1e-3, 0.5)) / Ts),
        "vf_gain": f32(draw(unit(0.0, 2.0)) * psi_f), "vf_boost": draw(unit(0.0, 10.0)),
        "smo": {"w_e_max": w_top, "i_max": i_max, "k": 0.0, "margin": draw(unit(1.0, 3.0)),
                "delta": f32(draw(unit(0.0, 0.1)) * i_max), "w_c_min": f32(draw(unit(1e-3, 0.5)) * w_top),
                "bw_pll": f32(draw(unit(1e-3, 0.5)) / Ts), "w_valid": f32(draw(unit(0.0, 0.3)) * w_top),
                "lag": draw(st.sampled_from([0, 1]))},
    }
    c["t_dead_comp"] = f32(draw(opt(0.0, 0.1)) * c["T_pwm"])
    c["i_dead_band"] = f32(draw(opt(0.0, 0.1)) * i_max)
    if mode == lib.FS_MODE_SPEED and draw(st.booleans()):   # flux weakening
        c.update(fw_w_e_max=w_top, fw_gain=draw(logu(0.1, 100.0)),
                 fw_cutoff=f32(draw(opt(1e-3, 1.0)) / Ts))
    if draw(st.booleans()):   # loss-of-lock monitor, and recovery
        c.update(lock_time=f32(Tl * draw(st.integers(1, 100))), lock_recover=int(draw(st.booleans())),
                 t_recover=f32(Ts * draw(st.integers(1, 50))), lock_retries=draw(st.integers(0, 3)))
    if src == lib.FS_ANGLE_SMO and draw(st.booleans()):   # I/f start
        c.update(i_start=f32(draw(unit(0.05, 1.0)) * i_max), a_start=f32(draw(logu(1.0, 1e3)) * w_top),
                 w_handover=f32(draw(unit(0.01, 0.5)) * w_top))
    if src in (lib.FS_ANGLE_HFI, lib.FS_ANGLE_BLEND):
        w_h = f32(draw(unit(0.1, 0.5 * math.pi)) / Ts)
        c["hfi"] = {"u_h": f32(draw(unit(0.01, 0.9)) * 0.5 * i_max * w_h * min(L_d, L_q)), "w_h": w_h,
                    "w_b_p": f32(draw(opt(1e-2, 0.5)) / Ts), "w_b_n": f32(draw(opt(1e-2, 0.5)) / Ts),
                    "obs": {"bandwidth": f32(draw(opt(1e-3, 0.5)) / Ts)}, "xcomp": draw(xcomps)}
        lo_w = f32(draw(unit(0.0, 0.2)) * w_top)
        c["blend"] = {"w_lower": lo_w, "w_upper": f32(lo_w + draw(unit(0.01, 0.3)) * w_top),
                      "obs": {"bandwidth": f32(draw(opt(1e-3, 0.5)) / Ts)}}
        if draw(st.booleans()):
            c["w_inject_max"] = f32(c["blend"]["w_upper"] / 0.9 * draw(unit(1.0, 2.0)))
        if draw(st.booleans()):
            c["polarity"] = {"i_pulse": f32(draw(unit(0.05, 1.0)) * i_max), "t_lock": f32(Ts * draw(st.integers(0, 30))),
                             "t_pulse": f32(Ts * draw(st.integers(4, 40)))}
    if src == lib.FS_ANGLE_SWVI:
        c["swvi"] = {"u_h": draw(logu(0.1, 100.0)), "bandwidth": f32(draw(unit(1e-3, 0.5)) / Ts),
                     "w_max": draw(opt(1.0, 2.0)) * w_top, "sequence": draw(st.sampled_from([0, 1])),
                     "xcomp": draw(xcomps), "carrier_off": draw(st.booleans())}
    if draw(st.integers(0, 3)) == 0:   # a paper's explicit gains
        kp, ki = draw(logu(1e-3, 1e3)), draw(logu(1e-3, 1e6))
        c.update(k_p_d=kp, k_i_d=ki, k_p_q=kp, k_i_q=ki, k_p_w=draw(logu(1e-4, 1e2)), k_i_w=draw(logu(1e-4, 1e4)))
    if phases == 3 and src != lib.FS_ANGLE_SWVI and draw(st.booleans()):   # the matrix converter
        c.update(converter=lib.FS_CONV_IMC, imc_region=draw(st.sampled_from([0, 1, 2])),
                 imc_w_grid=draw(unit(0.0, 400.0)), imc_depth=int(draw(st.booleans())),
                 imc_i_lim=f32(draw(unit(0.1, 1.0)) * i_max), imc_V_im=draw(logu(1.0, 1e3)))
    return c, w_top


def _held(rng, x: np.ndarray) -> np.ndarray:
    """x held over segments of random length (1 to n/4 samples)."""
    n = len(x)
    starts = np.flatnonzero(np.r_[True, rng.random(n - 1) < 8.0 / n])
    return x[np.repeat(starts, np.diff(np.r_[starts, n]))]


def _drive_inputs(rng, c, w_top, n, style):
    """The drive's inputs: white noise within the ranges, or each held over
    random segments, or a machine turning: currents of a rotating vector
    (fundamental and a carrier-like ripple) and the encoder following it at a
    speed that ramps within +-2 w_top."""
    i_max, p = c["i_max"], c["pole_pairs"]
    x = {
        "i_ph": sym(rng, (n, 5), 4 * i_max),
        "u_dc": np.exp(rng.uniform(math.log(1e-3), math.log(1e4), n)).astype(np.float32),
        "u_in": sym(rng, (n, 3), 1e3),
        "theta_m_enc": sym(rng, n, ANGLE), "theta_e_ext": sym(rng, n, ANGLE), "w_e_ext": sym(rng, n, 2 * w_top),
        "w_m_ref": sym(rng, n, 2 * w_top / p), "i_d_ref": sym(rng, n, 2 * i_max), "i_q_ref": sym(rng, n, 2 * i_max),
        "u_d_ref": sym(rng, n, 1e3), "u_q_ref": sym(rng, n, 1e3), "w_e_ref": sym(rng, n, 2 * w_top),
    }
    if style == "held":
        x = {k: _held(rng, v) for k, v in x.items()}
    elif style == "turning":
        w = np.linspace(*rng.uniform(-2 * w_top, 2 * w_top, 2), n)
        th = np.cumsum(w) * c["Ts"] + rng.uniform(-ANGLE, ANGLE)
        amp, ripple = rng.uniform(0, 2 * i_max), rng.uniform(0, 0.5 * i_max)
        ph = np.arange(5)[None, :] * (2 * np.pi / c["phases"])
        carrier = np.cumsum(np.full(n, rng.uniform(0.1, 1.5)))[:, None]
        i = amp * np.cos(th[:, None] + rng.uniform(-1, 1) - ph) + ripple * np.cos(carrier - ph)
        x["i_ph"] = np.clip(i, -4 * i_max, 4 * i_max).astype(np.float32)
        x["theta_m_enc"] = np.clip(th / p, -ANGLE, ANGLE).astype(np.float32)
        x["theta_e_ext"] = np.clip(th, -ANGLE, ANGLE).astype(np.float32)
        x["w_e_ext"] = w.astype(np.float32)
        x["u_dc"] = np.full(n, np.float32(np.exp(rng.uniform(math.log(1.0), math.log(1e3)))))
        x = {k: (v if k in ("i_ph", "theta_m_enc", "theta_e_ext", "w_e_ext", "u_dc") else _held(rng, v))
             for k, v in x.items()}
    return x


@DRIVE_SETTINGS
@given(cw=drive_configs(), seed=seeds, sensorless=st.sampled_from(["on", "off", "switching"]),
       style=st.sampled_from(["noise", "held", "turning"]))
def test_drive_step_stays_finite_in_every_mode_and_source(cw, seed, sensorless, style):
    c, w_top = cw
    drv = ffi.new("fs_drive *")
    cfg = ffi.new("fs_drive_config *", c)
    status = lib.fs_drive_init(drv, cfg)
    assume(status == lib.FS_OK)
    rng = np.random.default_rng(seed)
    x = _drive_inputs(rng, c, w_top, N_STEPS, style)
    sl = {"on": np.ones(N_STEPS, bool), "off": np.zeros(N_STEPS, bool),
          "switching": rng.random(N_STEPS) < 0.5}[sensorless]
    inp, out = ffi.new("fs_drive_in *"), ffi.new("fs_drive_out *")

    def step(k):
        inp.i_ph = x["i_ph"][k].tolist()
        inp.u_in = x["u_in"][k].tolist()
        for name in ("u_dc", "theta_m_enc", "theta_e_ext", "w_e_ext", "w_m_ref", "i_d_ref", "i_q_ref", "u_d_ref",
                     "u_q_ref", "w_e_ref"):
            setattr(inp, name, x[name][k])
        inp.sensorless = int(sl[k])
        lib.fs_drive_step(drv, inp, out)
        duty = list(out.duty)[:c["phases"]]
        assert all(0.0 <= d <= 1.0 for d in duty), duty
    run_steps(f"drive mode {c['mode']} source {c['angle_source']}", [drv, out], step)
