"""What tests/test_sanitizers.py runs on the sanitized core (started by
tests/sanitize_core.py, which has already made fullspeed._core the sanitized
build): every catalog scenario to its end, then the C runner's error paths
and the extremes that once reached undefined behaviour.

One JSON object a line on stdout, for the test to check:
  {"kind": "core", "file"}                                   the extension loaded as fullspeed._core
  {"kind": "scenario", "name", "status", "rows", "t_last"}   one per catalog scenario
  {"kind": "check", "name", "ok", "detail"}                  one per check below
  {"kind": "end", "failed": [...]}                           last, if nothing aborted

--only NAME,...     just those checks, no scenarios
--canary asan|ubsan break the API's contract on purpose instead, so that
                    the test sees the sanitizers are live in the loaded core
"""
from __future__ import annotations

import json
import math
import sys
import traceback

import numpy as np

import fullspeed._core as core
from fullspeed._core import ffi, lib
from fullspeed.design.scenario import load_scenario, scenario_from_dict
from fullspeed.model.scenario import scenario_names
from fullspeed.sim import build_config, simulate

FAILED: list[str] = []
CHECKS: list = []


def emit(**row) -> None:
    print(json.dumps(row), flush=True)


def check(fn):
    """Register a check (they run after the scenarios, in this order)."""
    CHECKS.append(fn)
    return fn


def run_check(fn) -> None:
    """Run a check; a failure is reported, and the others still run."""
    try:
        detail = fn()
        emit(kind="check", name=fn.__name__, ok=True, detail=detail)
    except Exception:   # reported to the test, which fails
        FAILED.append(fn.__name__)
        emit(kind="check", name=fn.__name__, ok=False, detail=traceback.format_exc())


def config(name: str):
    """The C configuration of a catalog scenario, and what keeps it alive."""
    return build_config(load_scenario(name))


def create(cfg, err_len: int = 512):
    err = ffi.new("char[]", max(err_len, 1))
    ptr = lib.fs_sim_create(cfg, err, err_len)
    return ptr, ffi.string(err).decode()


def run_to(sim, t_end: float, max_rows: int):
    """fs_sim_run into a buffer of exactly max_rows rows (malloc'd by NumPy,
    so a write past it is ASan's to see)."""
    buf = np.full((max(max_rows, 0), lib.FS_CH_N), np.nan)
    rows = ffi.new("int *")
    ptr = ffi.cast("double *", buf.ctypes.data) if max_rows > 0 else ffi.NULL
    rc = lib.fs_sim_run(sim, t_end, ptr, max_rows, rows)
    return rc, buf[: rows[0]].copy()


def run_cols_to(sim, t_end: float, max_rows: int):
    """fs_sim_run_cols into a column-major buffer of exactly max_rows rows a
    channel (stride max_rows); the rows returned row-major, as run_to's."""
    buf = np.full((lib.FS_CH_N, max(max_rows, 1)), np.nan)
    rows = ffi.new("int *")
    rc = lib.fs_sim_run_cols(sim, lib.fs_sim_steps(sim, t_end), ffi.cast("double *", buf.ctypes.data),
                             max(max_rows, 1), max_rows, rows)
    return rc, buf[:, : rows[0]].T.copy()


def run_scenarios() -> None:
    for name in scenario_names():
        r = simulate(load_scenario(name))
        t = r["t"]
        emit(kind="scenario", name=name, status=r.stop_reason, rows=int(t.size),
             t_last=float(t[-1]) if t.size else None)


# --- fs_sim_create refusing bad configurations -------------------------------

def _refusals(name: str, cases) -> list[str]:
    cfg0, keep = config(name)
    out = []
    for field, expect, mutate in cases:
        cfg = ffi.new("fs_sim_config *", cfg0[0])   # pointers shared with cfg0, kept alive by keep
        mutate(cfg)
        ptr, err = create(cfg)
        if ptr != ffi.NULL:
            lib.fs_sim_destroy(ptr)
            raise AssertionError(f"{name}: {field} accepted")
        assert expect in err, f"{name}: {field}: message {err!r} does not name {expect!r}"
        out.append(field)
    return out


def _set(path: str, value):
    def mutate(cfg):
        *parents, leaf = path.split(".")
        obj = cfg
        for p in parents:
            obj = getattr(obj, p)
        setattr(obj, leaf, value)
    return mutate


def _profile(name: str, t, y):
    """Set a profile; t = None gives three points and no arrays (NULL)."""
    def mutate(cfg):
        prof = getattr(cfg, name)
        if t is None:
            prof.n, prof.t, prof.y = 3, ffi.NULL, ffi.NULL
            return
        _KEEP.extend((ffi.new("double[]", t), ffi.new("double[]", y)))
        prof.n, prof.t, prof.y = len(t), _KEEP[-2], _KEEP[-1]
    return mutate


_KEEP: list = []
NAN, INF = math.nan, math.inf


@check
def create_refuses_bad_inverter_configs():
    c = [("inverter.T_pwm", "inverter.T_pwm", _set("inverter.T_pwm", 0.0)),
         ("inverter.T_pwm nan", "inverter.T_pwm", _set("inverter.T_pwm", NAN)),
         ("inverter.t_dead", "inverter.t_dead", _set("inverter.t_dead", 1.0)),
         ("inverter.t_dead nan", "inverter.t_dead", _set("inverter.t_dead", NAN)),
         ("inverter.u_dc", "inverter.u_dc", _set("inverter.u_dc", -24.0)),
         ("sampling", "timing.sampling", _set("sampling", 7)),
         ("h_max 0", "timing.h_max", _set("h_max", 0.0)),
         ("h_max nan", "timing.h_max", _set("h_max", NAN)),
         ("h_max -1", "timing.h_max", _set("h_max", -1.0)),
         ("h_max 1e-300", "timing.h_max", _set("h_max", 1e-300)),   # the RK4 step count must fit an int
         ("decimation", "trace.decimation", _set("decimation", 0)),
         ("plant.phases", "plant.phases", _set("plant.phases", 4)),
         ("inverter.phases", "inverter.phases", _set("inverter.phases", 5)),
         ("drive.phases", "controller.phases", _set("drive.phases", 5)),
         ("converter", "converter.kind", _set("converter", 9)),
         ("drive.converter", "controller.converter", _set("drive.converter", 1)),
         ("drive.Ts", "controller.Ts", _set("drive.Ts", 3e-4)),
         ("plant.pole_pairs", "machine: pole", _set("plant.pole_pairs", 0)),
         ("plant.mag.L_d", "machine", _set("plant.mag.L_d", 0.0)),
         ("drive.i_max", "controller.i_max:", _set("drive.i_max", 0.0)),
         ("drive.mode", "controller.mode:", _set("drive.mode", 42)),
         ("inverter.kind", "inverter: kind = 7", _set("inverter.kind", 7)),
         ("inverter.u_on", "inverter: kind", _set("inverter.u_on", NAN)),
         ("inverter.u_dc inf", "inverter.u_dc", _set("inverter.u_dc", INF)),
         ("adc_range", "sensors.adc_range", _set("adc_range", 0.0)),
         ("fault.open_phase", "faults.open_phase", _set("fault.open_phase", 4)),
         ("fault.i_gain", "faults", lambda cfg: cfg.fault.i_gain.__setitem__(2, -2.0)),
         ("fault.i_offset", "faults", lambda cfg: cfg.fault.i_offset.__setitem__(4, NAN)),
         ("profile decreasing", "profile w_m_ref", _profile("w_m_ref", [0.0, 1.0, 0.5], [0.0, 1.0, 2.0])),
         ("profile null", "profile T_load", _profile("T_load", None, None))]
    return _refusals("yang2022-encoder-speedstep", c)


@check
def create_refuses_bad_five_phase_configs():
    c = [("plant.L_d3", "plant.L_d3", _set("plant.L_d3", 0.0)),
         ("plant.L_q3", "plant.L_q3", _set("plant.L_q3", NAN)),
         ("plant.psi_f3", "plant.psi_f3", _set("plant.psi_f3", -1.0)),
         ("plant.L_d3 inf", "plant.L_d3", _set("plant.L_d3", INF)),
         ("fault.open_phase", "faults.open_phase", _set("fault.open_phase", 1))]
    return _refusals("yu2022-seq-ss-300rpm", c)


@check
def create_refuses_bad_matrix_converter_configs():
    c = [("inverter.kind", "converter.inverter", _set("inverter.kind", lib.FS_INV_SWITCHING)),
         # the scenario has the module's devices on: the simple drops are refused without them too
         ("inverter.u_on", "converter.u_on", lambda cfg: (setattr(cfg.inverter.dev, "enabled", 0),
                                                          setattr(cfg.inverter, "u_on", 1.0))),
         ("inverter.r_on", "converter.u_on", lambda cfg: (setattr(cfg.inverter.dev, "enabled", 0),
                                                          setattr(cfg.inverter, "r_on", 0.01))),
         ("inverter.dev.I_ref", "inverter: kind", _set("inverter.dev.I_ref", 0.0)),
         ("sampling", "timing.sampling", lambda cfg: (setattr(cfg, "sampling", lib.FS_SAMPLING_DOUBLE),
                                                      setattr(cfg.drive, "Ts", cfg.drive.Ts / 2))),
         ("grid.C_f", "converter.grid", _set("grid.C_f", 0.0)),
         ("grid.V_im", "converter.grid", _set("grid.V_im", NAN)),
         ("fault.open_phase", "faults.open_phase", _set("fault.open_phase", 2))]
    return _refusals("zou2021-region-a", c)


@check
def create_writes_no_more_of_the_message_than_it_is_given():
    cfg, keep = config("yang2022-encoder-speedstep")
    cfg.h_max = -1.0
    out = []
    for n in (1, 2, 8, 16):
        err = ffi.new("char[]", n)   # exactly n bytes: snprintf must truncate
        assert lib.fs_sim_create(cfg, err, n) == ffi.NULL
        s = ffi.string(err, n)
        assert len(s) <= n - 1, s
        out.append(s.decode())
    return out


# --- fs_sim_run's stops -----------------------------------------------------

def _stop_then_again(cfg, t_end: float, expect: int):
    ptr, err = create(cfg)
    assert ptr != ffi.NULL, err
    sim = ffi.gc(ptr, lib.fs_sim_destroy)
    Ts = cfg.drive.Ts
    n = int(round(t_end / Ts)) + 2
    rc, tr = run_to(sim, t_end, n)
    assert rc == expect, (rc, expect)
    t_stop = lib.fs_sim_stop_time(sim)
    assert math.isfinite(t_stop) and t_stop <= t_end, t_stop
    assert tr.shape[0] >= 1 and np.all(np.isfinite(tr[:, lib.FS_CH_T]))
    rc2, tr2 = run_to(sim, t_end, n)   # a stopped run stays stopped and writes nothing
    assert rc2 == expect and tr2.shape[0] == 0, (rc2, tr2.shape)
    return {"stop_time": t_stop, "rows": tr.shape[0]}


@check
def run_stops_on_overcurrent():
    cfg, keep = config("yang2022-encoder-speedstep")
    cfg.i_trip = 1.0      # the load step needs far more
    return _stop_then_again(cfg, 0.5, lib.FS_STOP_OVERCURRENT)


@check
def run_stops_on_overcurrent_five_phase():
    cfg, keep = config("yu2022-seq-dyn")
    cfg.i_trip = 0.05
    return _stop_then_again(cfg, 0.5, lib.FS_STOP_OVERCURRENT)


@check
def run_stops_on_nan_from_a_runaway_load():
    # the rotor's speed overflows to inf, then the states become NaN: on the
    # inverter and on the matrix converter (its filter integrated alongside)
    out = {}
    for name in ("yang2022-encoder-speedstep", "zou2021-region-a"):
        cfg, keep = config(name)
        cfg.i_trip = 0.0
        _profile("T_load", [0.0, 0.01], [0.0, 1e306])(cfg)
        out[name] = _stop_then_again(cfg, 0.2, lib.FS_STOP_NAN)
    return out


@check
def run_stops_on_nan_from_a_nan_initial_state():
    # the drive samples NaN currents and angles before the runner sees the state
    out = {}
    for name in ("yang2022-blend-iqstep", "yu2022-startup"):
        cfg, keep = config(name)
        cfg.i_trip = 0.0
        cfg.w_m0 = NAN
        out[name] = _stop_then_again(cfg, 0.05, lib.FS_STOP_NAN)
    return out


@check
def run_stops_on_nan_duties():
    # with the computation delay off, a NaN initial angle makes the first
    # samples, the drive's duties and so the switching instants
    # (fs_inverter_segments) NaN in the period they act, before the runner
    # sees a non-finite state; and a NaN dc link (the u_dc_scale profile)
    out = {}
    for name, kind in (("yang2022-blend-iqstep", lib.FS_INV_SWITCHING), ("yang2022-encoder-speedstep", lib.FS_INV_AVERAGED),
                       ("yu2022-seq-dyn", lib.FS_INV_SWITCHING), ("yu2022-startup", lib.FS_INV_AVERAGED)):
        inverter = "switching" if kind == lib.FS_INV_SWITCHING else "averaged"
        cfg, keep = config(name)
        cfg.i_trip, cfg.inverter.kind = 0.0, kind
        cfg.delay, cfg.drive.delay = 0, 0.0
        cfg.theta_m0 = NAN
        out[f"{name} {inverter} nan angle"] = _stop_then_again(cfg, 0.05, lib.FS_STOP_NAN)
        cfg, keep = config(name)
        cfg.i_trip, cfg.inverter.kind = 0.0, kind
        _profile("u_dc_scale", [0.0, 0.005, 0.005], [1.0, 1.0, NAN])(cfg)
        out[f"{name} {inverter} nan dc link"] = _stop_then_again(cfg, 0.05, lib.FS_STOP_NAN)
    return out


@check
def hardware_faults_run():
    # tests/test_reliability.py's faults, on the encoder and on the blend
    faults = {"sensor offset": {"faults": {"t_sensor": 0.3, "i_offset": [2.0, -1.0]}},
              "sensor gain": {"faults": {"t_sensor": 0.3, "i_gain": [0.1, -0.05]}},
              "adc saturation": {"sensors": {"adc_range": 20.0}},
              "dc-link sag": {"faults": {"u_dc_scale": [[0.3, 1.0], [0.35, 0.5]]}},
              "dc-link step": {"faults": {"u_dc_scale": [[0.3, 1.0], [0.3, 0.6]]}},
              "open phase": {"faults": {"open_phase": "b", "t_open": 0.3}},
              "encoder stop": {"faults": {"t_encoder_stop": 0.3}}}
    out = {}
    for name in ("yang2022-encoder-speedstep", "yang2022-blend-iqstep"):
        for fault, ov in faults.items():
            r = simulate(name, overrides=ov)
            # (polarity_undetermined: a lost lock's restart whose pulses the fault leaves undecided)
            assert r.stop_reason in ("done", "overcurrent", "nan", "loss_of_lock", "polarity_undetermined", "overspeed"), r.stop_reason
            out[f"{name} {fault}"] = r.stop_reason
    return out


@check
def nan_references_run_without_undefined_behaviour():
    # what the drive makes of a NaN reference is its business (it may hold
    # the loops or the states may go NaN); here it must only be defined
    out = {}
    for name, prof in (("yang2022-encoder-speedstep", "w_m_ref"), ("yang2022-smo-iqstep", "i_q_ref"),
                       ("yang2022-hfi-iqstep", "i_d_ref"), ("yu2022-seq-dyn", "w_m_ref"),
                       ("zou2021-speed-range", "w_m_ref"), ("zou2021-modulator-vtr", "w_e_ref")):
        cfg, keep = config(name)
        cfg.i_trip = 0.0
        _profile(prof, [0.0, 0.005], [0.0, NAN])(cfg)
        ptr, err = create(cfg)
        assert ptr != ffi.NULL, err
        sim = ffi.gc(ptr, lib.fs_sim_destroy)
        rc, tr = run_to(sim, 0.02, 400)
        assert rc in (lib.FS_RUN_DONE, lib.FS_STOP_NAN), rc
        out[f"{name} {prof}"] = {lib.FS_RUN_DONE: "done", lib.FS_STOP_NAN: "nan"}[rc]
    return out


@check
def run_stops_on_loss_of_lock():
    # an SMO whose gain is designed for 500 rpm cannot hold the EMF at 2000 rpm (tests/test_lock.py)
    out = {}
    for lock in ("stop", "recover"):
        r = simulate("yang2022-smo-steady-400rpm", overrides={
            "observer": {"top_speed_rpm": 500.0}, "load": {"speed_rpm": 2000.0}, "controller": {"lock": lock}})
        assert r.stop_reason == "loss_of_lock", (lock, r.stop_reason)
        out[lock] = {"stop_time": r.stop_time, "recoveries": float(r["recoveries"][-1])}
    return out


# --- control inits: step counts from times and rates ------------------------

def _hfi_init(**fields) -> int:
    cfg = ffi.new("fs_hfi_config *", {"Ts": 1e-4, "delay": 1.0, "u_h": 1.0, "w_h": 2 * math.pi * 1000.0,
                                      "L_d": 65e-6, "L_q": 90e-6, **fields})
    cfg.obs.J, cfg.obs.pole_pairs = 1.0, 1
    return lib.fs_hfi_init(ffi.new("fs_hfi *"), cfg)


def _polarity_init(**fields) -> int:
    cfg = ffi.new("fs_polarity_config *", {"Ts": 1e-4, "i_pulse": 10.0, "t_lock": 0.06, "t_pulse": 0.02, **fields})
    return lib.fs_polarity_init(ffi.new("fs_polarity *"), cfg)


@check
def hfi_init_refuses_a_settling_count_beyond_int():
    # n_settle = ceil(3 / (w_b_n Ts)), w_b_n given or w_h / 20 by default
    assert _hfi_init() == lib.FS_OK
    for fields in ({"w_h": 1e-20}, {"w_b_n": NAN}, {"w_b_n": 1e-9}):
        st = _hfi_init(**fields)
        assert st == lib.FS_ERR_BANDWIDTH, (fields, st)
    # and the scenario whose carrier is that slow is refused with the field
    try:
        load_scenario("yang2022-hfi-iqstep", {"injection": {"f_h": 1e-20}})
    except Exception as exc:   # ConfigError
        assert "injection" in str(exc), exc
        return str(exc)
    raise AssertionError("f_h = 1e-20 Hz accepted")


@check
def polarity_init_refuses_step_counts_beyond_int():
    assert _polarity_init() == lib.FS_OK
    for fields in ({"Ts": 1e-30, "t_pulse": 0.02}, {"Ts": 1e-12, "t_lock": 900.0}):
        st = _polarity_init(**fields)
        assert st == lib.FS_ERR_PARAM, (fields, st)
    # through the runner: 100 GHz sampling, the injection's filters raised to pass fs_hfi_init
    cfg, keep = config("yang2022-polarity")
    for obj in (cfg.inverter, cfg.drive):
        obj.T_pwm = 1e-11
    cfg.drive.Ts, cfg.h_max, cfg.inverter.t_dead = 1e-11, 1e-11, 0.0
    hc = cfg.drive.hfi
    hc.w_h, hc.w_b_p, hc.w_b_n, hc.obs.bandwidth = 1e9, 1e8, 1e8, 1e7
    ptr, err = create(cfg)
    assert ptr == ffi.NULL, "accepted"
    return err


# --- advancing in small chunks into a tiny trace buffer ---------------------

def _chunked(cfg, T: float, dt: float, max_rows: int, run=run_to):
    ptr, err = create(cfg)
    assert ptr != ffi.NULL, err
    sim = ffi.gc(ptr, lib.fs_sim_destroy)
    parts, full, t_end = [], 0, 0.0
    while lib.fs_sim_step_count(sim) < lib.fs_sim_steps(sim, T):   # periods, as fs_sim_run counts them
        t_end = min(t_end + dt, T)
        while True:
            rc, tr = run(sim, t_end, max_rows)
            parts.append(tr)
            if rc != lib.FS_RUN_BUFFER_FULL:
                break
            full += 1
        assert rc == lib.FS_RUN_DONE, rc
    return np.concatenate(parts), full


@check
def run_in_small_chunks_into_a_tiny_buffer_matches_one_run():
    out = {}
    for name, dec in (("yang2022-polarity", 1), ("yang2022-blend-iqstep", 7), ("zou2021-region-a", 3),
                      ("yu2022-startup", 2)):
        cfg, keep = config(name)
        cfg.decimation = dec
        T = 0.05
        Ts = cfg.drive.Ts
        n = math.ceil(round(T / Ts, 6) - 0.5)
        expect = -(-n // dec)
        one, _ = _chunked(cfg, T, T, expect)              # one call, the buffer just large enough
        assert one.shape[0] == expect, (name, one.shape[0], expect)
        fulls = []
        for dt, max_rows in ((0.37 * Ts, 1),              # steps shorter than a period
                             (5.3 * dec * Ts, 1),          # several rows a call into a one-row buffer
                             (11.7 * dec * Ts, 2)):
            chunked, full = _chunked(cfg, T, dt, max_rows)
            assert np.array_equal(one, chunked), (name, dt / Ts, max_rows)
            fulls.append(full)
        assert fulls[1] >= expect // 2 and fulls[2] >= expect // 4, (name, fulls)   # BUFFER_FULL was hit
        # a zero-row buffer: no progress at a recorded sample, and nothing written
        ptr, err = create(cfg)
        sim = ffi.gc(ptr, lib.fs_sim_destroy)
        rc, tr = run_to(sim, T, 0)
        assert rc == lib.FS_RUN_BUFFER_FULL and tr.shape[0] == 0 and lib.fs_sim_time(sim) == 0.0
        out[name] = {"rows": expect, "buffer_full": fulls}
    return out


@check
def columns_in_small_chunks_into_exact_buffers_match_the_rows():
    out = {}
    for name, dec in (("yang2022-blend-iqstep", 7), ("zou2021-region-a", 3), ("yu2022-startup", 2)):
        cfg, keep = config(name)
        cfg.decimation = dec
        T = 0.05
        n = -(-math.ceil(round(T / cfg.drive.Ts, 6) - 0.5) // dec)
        rows, _ = _chunked(cfg, T, T, n)
        for dt, max_rows in ((T, n), (0.37 * cfg.drive.Ts, 1), (5.3 * dec * cfg.drive.Ts, 2)):
            cols, _ = _chunked(cfg, T, dt, max_rows, run=run_cols_to)
            assert cols.tobytes() == rows.tobytes(), (name, dt, max_rows)
        out[name] = {"rows": n}
    return out


@check
def run_with_odd_end_times():
    cfg, keep = config("yang2022-encoder-speedstep")
    ptr, err = create(cfg)
    sim = ffi.gc(ptr, lib.fs_sim_destroy)
    for t_end in (NAN, -1.0, 0.0, -INF):
        rc, tr = run_to(sim, t_end, 4)
        assert rc == lib.FS_RUN_DONE and tr.shape[0] == 0 and lib.fs_sim_time(sim) == 0.0, t_end
    rc, tr = run_to(sim, INF, 16)
    assert rc == lib.FS_RUN_BUFFER_FULL and tr.shape[0] == 16
    return "ok"


# --- the flux-map plant (no catalog machine uses it) ------------------------

def _fluxmap_scenario(duration: float, **sections) -> dict:
    """The yang2022 machine with its magnetics as a flux map: the linear
    model's fluxes with some saturation of q, on a 9 x 9 grid."""
    L_d, L_q, psi_f = 0.065e-3, 0.09e-3, 0.007
    i_d = np.linspace(-80.0, 80.0, 9)
    i_q = np.linspace(-80.0, 80.0, 9)
    D, Q = np.meshgrid(i_d, i_q, indexing="ij")
    psi_d = psi_f + L_d * D
    psi_q = L_q * 60.0 * np.tanh(Q / 60.0)
    d = {"name": "fluxmap", "duration": duration,
         "machine": {"catalog": "yang2022", "magnetic": {
             "model": "fluxmap", "i_d": i_d.tolist(), "i_q": i_q.tolist(),
             "psi_d": psi_d.tolist(), "psi_q": psi_q.tolist()}},
         "controller": {"mode": "speed", "angle": "encoder"},
         "references": {"speed_rpm": [[0.0, 0.05], [0.0, 1500.0]]},
         "load": {"torque": [[0.0, 0.1], [0.0, 1.5]]}}
    d.update(sections)
    return d


@check
def fluxmap_plant_runs():
    r = simulate(scenario_from_dict(_fluxmap_scenario(0.3)))
    assert r.stop_reason == "done", r.stop_reason
    assert r["t"].size == 3000, r["t"].size
    return {"w_m_end_rpm": float(r["w_m"][-1] * 60 / (2 * math.pi))}


@check
def fluxmap_plant_stops_on_nan():
    sc = scenario_from_dict(_fluxmap_scenario(0.2))
    cfg, keep = build_config(sc)
    cfg.i_trip = 0.0
    _profile("T_load", [0.0, 0.01], [0.0, 1e306])(cfg)
    return _stop_then_again(cfg, 0.2, lib.FS_STOP_NAN)


# --- canaries: a broken contract the sanitizers must catch -------------------

def canary(which: str) -> None:
    if which == "asan":
        # a trace buffer one row shorter than the max_rows it is announced with
        cfg, keep = config("yang2022-polarity")
        ptr, err = create(cfg)
        buf = np.zeros((3, lib.FS_CH_N))
        rows = ffi.new("int *")
        lib.fs_sim_run(ptr, 0.01, ffi.cast("double *", buf.ctypes.data), 4, rows)
    elif which == "ubsan":
        # an instance at a misaligned address (the contract: a valid fs_pll object; fs_xcomp_eval, the canary
        # before, now defends itself against the table its check refuses)
        raw = ffi.new("char[]", 2 * ffi.sizeof("fs_pll"))
        pll = ffi.cast("fs_pll *", int(ffi.cast("uintptr_t", raw)) + 1)
        lib.fs_pll_reset(pll, 0.0, 0.0)
    print(f"canary {which}: not caught", flush=True)


def main(argv: list[str]) -> int:
    if argv[:1] == ["--canary"]:
        canary(argv[1])
        return 0
    emit(kind="core", file=core.__file__)
    only = argv[1].split(",") if argv[:1] == ["--only"] else None   # checks by name, no scenarios
    if only is None:
        run_scenarios()
    for fn in CHECKS:
        if only is None or fn.__name__ in only:
            run_check(fn)
    emit(kind="end", failed=FAILED)
    return 1 if FAILED else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
