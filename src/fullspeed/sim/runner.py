"""Running a scenario on the C core: the chunked advance with a progress
bar, the traces, and the Result (the configuration: sim.config)."""
from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass, field

import numpy as np

from .._core import ffi, lib
from ..design.scenario import load_scenario
from ..model.errors import SimulationError
from ..model.files import json_safe
from ..model.scenario import Scenario
from .config import build_config, check_smo_gain
from .metrics import STAGES, compute_metrics

CHANNELS = [
    "t", "theta_e", "w_m", "psi_d", "psi_q", "i_d", "i_q", "i_a", "i_b", "i_c",
    "T_e", "T_L", "u_d", "u_q", "duty_a", "duty_b", "duty_c",
    "w_m_ref", "i_d_ref", "i_q_ref", "T_ref", "i_d_hat", "i_q_hat", "u_d_ref", "u_q_ref",
    "theta_hat", "w_m_hat", "theta_err", "overmod", "E_in", "E_cu", "E_airgap", "W_mag",
    "theta_est", "w_m_est", "est_valid", "est_err", "phase", "i_d_fw",
    "g_w", "inject", "i_d3", "i_q3", "i_hf_d", "i_hf_q",
    "i_grid_a", "v_pn", "u_ab", "alpha", "E_grid", "E_rf", "W_filter",
    "lock_resid", "lock_lost", "stage", "recoveries", "u_dc",
    "T_winding", "T_magnet", "R_s_true", "psi_f_true", "R_s_hat", "psi_f_hat",
    "E_dc", "E_cond", "E_rect", "E_sw", "E_fe", "E_mech", "E_shaft",
]
assert len(CHANNELS) == lib.FS_CH_N, "channel names out of step with fs_sim.h"

# Each channel's unit (SI; angles in electrical rad, speeds mechanical rad/s;
# "1" for ratios and flags; stage is a name from metrics.STAGES).
UNITS = {
    "t": "s", "theta_e": "rad", "w_m": "rad/s", "psi_d": "Wb", "psi_q": "Wb",
    **dict.fromkeys(("i_d", "i_q", "i_a", "i_b", "i_c", "i_d_ref", "i_q_ref", "i_d_hat", "i_q_hat", "i_d_fw",
                     "i_d3", "i_q3", "i_hf_d", "i_hf_q", "i_grid_a"), "A"),
    **dict.fromkeys(("T_e", "T_L", "T_ref"), "N m"),
    **dict.fromkeys(("u_d", "u_q", "u_d_ref", "u_q_ref", "v_pn", "u_ab", "u_dc"), "V"),
    **dict.fromkeys(("duty_a", "duty_b", "duty_c", "overmod", "est_valid", "phase", "g_w", "inject", "alpha",
                     "lock_resid", "lock_lost", "recoveries"), "1"),
    **dict.fromkeys(("w_m_ref", "w_m_hat", "w_m_est"), "rad/s"),
    **dict.fromkeys(("theta_hat", "theta_err", "theta_est", "est_err"), "rad"),
    **dict.fromkeys(("E_in", "E_cu", "E_airgap", "W_mag", "E_grid", "E_rf", "W_filter",
                     "E_dc", "E_cond", "E_rect", "E_sw", "E_fe", "E_mech", "E_shaft"), "J"),
    "stage": "name",
    "T_winding": "degC", "T_magnet": "degC", "R_s_true": "ohm", "R_s_hat": "ohm", "psi_f_true": "Wb", "psi_f_hat": "Wb",
}
assert set(UNITS) == set(CHANNELS), "a channel without a unit"

STOP_REASONS = {
    lib.FS_RUN_DONE: "done",
    lib.FS_STOP_NAN: "nan",
    lib.FS_STOP_OVERCURRENT: "overcurrent",
    lib.FS_STOP_LOSS_OF_LOCK: "loss_of_lock",
    lib.FS_STOP_POLARITY: "polarity_undetermined",
    lib.FS_STOP_OVERSPEED: "overspeed",
    lib.FS_STOP_START: "start_failed",
}

@dataclass
class Result:
    """Traces (NumPy arrays by channel name, SI units) and metrics of a run."""
    scenario: Scenario
    traces: dict[str, np.ndarray]
    stop_reason: str                 # "done", "nan", "overcurrent", "loss_of_lock", "polarity_undetermined", "overspeed", "interrupted"
    stop_time: float | None
    wall_time: float                 # s
    sim_time: float                  # s simulated
    adc_saturated_at: float | None = None   # s, the first current reading at +-adc_range
    polarity: dict | None = None     # the polarity detection's outcome (Simulation.polarity)
    halt: dict | None = None         # why the drive halted (Simulation.halt)
    _metrics: dict | None = field(default=None, repr=False, compare=False)

    @property
    def metrics(self) -> dict:
        """compute_metrics of the run, formed at the first read and kept: a
        caller that reads only the traces (a campaign's checks, a bench)
        does not pay for them (about 0.7 ms a call on the wall bench's
        12,800 samples, some 10 % of the call). They are the metrics of the
        traces as they are at that read, as the run left them unless the
        caller changed the arrays in place before."""
        if self._metrics is None:
            self._metrics = compute_metrics(self)
        return self._metrics

    @metrics.setter
    def metrics(self, value: dict) -> None:
        self._metrics = value

    @property
    def speed_ratio(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.sim_time / self.wall_time if self.wall_time > 0 else math.inf

    def __getitem__(self, name: str) -> np.ndarray:
        return self.traces[name]

    def to_dataframe(self):
        """The traces as a pandas DataFrame indexed by time (s): one column
        per channel, `stage` as a categorical of names (metrics.STAGES), and
        each column's unit in df.attrs["units"] (the scenario's name in
        df.attrs["scenario"])."""
        import pandas as pd

        cols = {k: v for k, v in self.traces.items() if k != "t"}
        cols["stage"] = pd.Categorical.from_codes(np.asarray(cols["stage"]).astype(int), categories=list(STAGES))
        df = pd.DataFrame(cols, index=pd.Index(self.traces["t"], name="t"))
        df.attrs["units"] = dict(UNITS)
        df.attrs["scenario"] = self.scenario.name
        return df

    def to_mat(self, path) -> None:
        """The traces and metrics as a MATLAB .mat file (v5, compressed; scipy
        needed): `traces` (a struct of the channels, SI), `units` (each
        channel's unit), `metrics`, `stage_names` (the names of stage's codes,
        from 0), `scenario`, `stop_reason`, `stop_time` ([] if none). Readable
        by MATLAB's load and scipy.io.loadmat."""
        from scipy.io import savemat

        data = {"traces": {k: np.ascontiguousarray(v) for k, v in self.traces.items()},
                "units": dict(UNITS), "metrics": mat_value(json_safe(self.metrics)),
                "stage_names": mat_value(list(STAGES)), "scenario": self.scenario.name,
                "stop_reason": self.stop_reason, "stop_time": mat_value(self.stop_time)}
        with open(path, "wb") as f:
            savemat(f, data, do_compression=True, long_field_names=True, oned_as="column")


def mat_value(x):
    """A JSON-like value as scipy.io.savemat takes it: dicts as structs (keys
    made MATLAB names), lists as arrays or cells, None as [] (MATLAB's empty)."""
    if isinstance(x, dict):
        return {mat_name(str(k)): mat_value(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        items = [mat_value(v) for v in x]
        if items and all(isinstance(v, (int, float, bool, np.number)) for v in items):
            return np.asarray(items, dtype=float)
        cell = np.empty(len(items), dtype=object)
        cell[:] = items
        return cell
    return np.zeros((0, 0)) if x is None else x


def mat_name(key: str) -> str:
    """A MATLAB field name: letters, digits and _, starting with a letter."""
    name = re.sub(r"\W", "_", key, flags=re.ASCII)
    return name if name[:1].isalpha() else "x" + name


# The buffer's row count (the stride between its channels) is padded to 2 more than a multiple of 512: each
# channel then starts 16 B further into a 4 KiB page than the one before it. The C runner writes some 50
# channels at each sample, one double into each; where the stride is a multiple of 512 rows (4 KiB), all of
# them fall on the same page offset, the same few lines of each L1 set, and the loop took 6.86 against 4.59
# ms on the wall bench's averaged example (the least of 20 runs in 6 alternated processes); an offset of 8 B
# 4.95 ms, of 64 B 4.81, of 16 B (its own: 12,802 rows) the least of the offsets tried (8 .. 320 B, 2064,
# 4080). At most 511 rows more a channel; no value changes (the channels' samples are the same, in views).
STRIDE_BLOCK, STRIDE_ROW = 512, 2


def padded_rows(rows: int) -> int:
    """rows, or the least count above it that is STRIDE_ROW more than a multiple of STRIDE_BLOCK."""
    return rows + (STRIDE_ROW - rows) % STRIDE_BLOCK


class Simulation:
    """A simulation object that is advanced in chunks and keeps what it computed."""

    def __init__(self, scenario: Scenario):
        self.scenario = scenario
        self._cfg, self._keep = build_config(scenario)
        if scenario.data["controller"]["angle"] in ("smo", "blend"):
            check_smo_gain(self._cfg, scenario)
        err = ffi.new("char[]", 512)
        ptr = lib.fs_sim_create(self._cfg, err, 512)
        if ptr == ffi.NULL:
            raise SimulationError(f"{scenario.source or scenario.name}: {ffi.string(err).decode()}")
        self._sim = ffi.gc(ptr, lib.fs_sim_destroy)
        # one buffer the C runner writes into, a row per channel (each
        # channel's samples contiguous: the metrics read them so), grown by doubling; sized by the
        # periods the run takes (fs_sim_steps, the count advance_steps asks room for: int(duration / Ts)
        # could fall one short of it and double the buffer with a copy at the run's last chunk)
        rows = lib.fs_sim_steps(ptr, scenario.duration) // self._cfg.decimation + 2
        self._buf = np.empty((lib.FS_CH_N, padded_rows(rows)))
        self._n = 0
        # rows the C runner wrote in its last call and that are not in _n yet:
        # a Ctrl-C raised as fs_sim_run returns leaves them here, not lost
        self._rows = ffi.new("int *")
        self.status = "running"
        self.stop_time: float | None = None

    @property
    def time(self) -> float:
        return lib.fs_sim_time(self._sim)

    @property
    def period(self) -> float:
        """The control period Tc (s): a step of the drive."""
        return self._cfg.drive.Ts

    @property
    def step_count(self) -> int:
        """Control periods run so far."""
        return lib.fs_sim_step_count(self._sim)

    def steps(self, t: float) -> int:
        """The control periods a run to t takes (fs_sim_steps: the nearest
        whole number, |n Tc - t| <= Tc / 2), the count advance(t) stops at."""
        return lib.fs_sim_steps(self._sim, t)

    def advance(self, t_end: float) -> str:
        """Run to t_end (or a stop): to steps(t_end) periods. Returns the status: running, done or a stop reason."""
        return self.advance_steps(self.steps(t_end))

    def advance_steps(self, k_end: int) -> str:
        """Run until k_end control periods have run in all (or a stop). Returns the status."""
        rows = self._rows
        dec = self._cfg.decimation
        while True:
            self._n += rows[0]; rows[0] = 0   # noqa: E702 (no call or jump between the two: no signal handler runs there)
            cap = self._buf.shape[1]
            need = self._n + max(0, k_end - self.step_count) // dec + 2
            if need > cap:
                grown = np.empty((lib.FS_CH_N, padded_rows(max(need, 2 * cap))))
                grown[:, : self._n] = self._buf[:, : self._n]
                self._buf, cap = grown, grown.shape[1]
            ptr = ffi.cast("double *", self._buf.ctypes.data) + self._n
            rc = lib.fs_sim_run_cols(self._sim, k_end, ptr, cap, cap - self._n, rows)
            self._n += rows[0]; rows[0] = 0   # noqa: E702
            if rc == lib.FS_RUN_BUFFER_FULL:
                continue
            if rc != lib.FS_RUN_DONE:
                self.status = STOP_REASONS.get(rc, f"stop {rc}")
                self.stop_time = lib.fs_sim_stop_time(self._sim)
            return self.status

    @property
    def adc_saturated_at(self) -> float | None:
        t = lib.fs_sim_adc_saturated_at(self._sim)
        return None if math.isnan(t) else t

    def polarity(self) -> dict | None:
        """The polarity detection's outcome: by pulses (fs_polarity.h) its
        stage, the relative difference D of the last pulse pair and its
        margin (>= 1 decides), the pairs run, the last pulse; by the motion
        test (fs_motion_test.h, method "motion") its stage, the estimate's
        turn and the threshold it had to reach (el.deg), the pushes run, the
        last push; None without detection."""
        drv = lib.fs_sim_drive(self._sim)
        if drv.cfg.angle_source not in (lib.FS_ANGLE_HFI, lib.FS_ANGLE_BLEND):
            return None
        if drv.cfg.motion.i_push > 0.0:
            mt = drv.mt
            stages = {lib.FS_MOTION_LOCK: "lock", lib.FS_MOTION_PUSH: "doublet", lib.FS_MOTION_SETTLE: "settle",
                      lib.FS_MOTION_DONE: "done", lib.FS_MOTION_UNDETERMINED: "undetermined"}
            return {"method": "motion", "stage": stages.get(mt.stage, str(mt.stage)), "turn_deg": math.degrees(mt.turn),
                    "threshold_deg": math.degrees(mt.threshold), "attempts": int(mt.attempts), "i_push": float(mt.i_now),
                    "flip": bool(mt.flip), "moved": bool(mt.moved)}
        if drv.cfg.polarity.i_pulse <= 0.0:
            return None
        p = drv.pol
        stages = {lib.FS_POLARITY_LOCK: "lock", lib.FS_POLARITY_POS: "pulse", lib.FS_POLARITY_NEG: "pulse",
                  lib.FS_POLARITY_DONE: "done", lib.FS_POLARITY_UNDETERMINED: "undetermined"}
        return {"method": "pulses", "stage": stages.get(p.stage, str(p.stage)), "d": float(p.d), "margin": float(p.margin),
                "attempts": int(p.attempts), "i_pulse": float(p.i_now), "flip": bool(p.flip), "moved": bool(p.moved)}

    def halt(self) -> dict | None:
        """Why the drive halted (fs_drive_protect.h), None if it did not: the
        fault, and for a loss of lock the back-EMF its zero-current wait last
        measured, V, and the speed that says by the controller's magnet flux."""
        drv = lib.fs_sim_drive(self._sim)
        faults = {lib.FS_FAULT_POLARITY: "polarity", lib.FS_FAULT_LOCK: "lock", lib.FS_FAULT_OVERSPEED: "overspeed",
                  lib.FS_FAULT_START: "start"}
        if drv.phase != lib.FS_PHASE_HALT:
            return None
        c = drv.cfg
        w = float(drv.e_rec) / (c.psi_f * c.pole_pairs) if c.psi_f > 0 else math.nan
        return {"fault": faults.get(drv.fault, str(drv.fault)), "emf_V": float(drv.e_rec), "emf_rpm": w * 60.0 / (2.0 * math.pi)}

    def traces(self) -> dict[str, np.ndarray]:
        """Each channel as a view into the buffer (contiguous, no copy)."""
        self._n += self._rows[0]; self._rows[0] = 0   # noqa: E702 (rows of a call a Ctrl-C cut off)
        return dict(zip(CHANNELS, self._buf[:, : self._n]))


# Without a progress bar or a chunk asked for, the chunks of simulated time
# grow while one takes less wall time than this: each at least doubles, and
# takes as many periods as half of it holds at the last call's rate, so that
# a short run is two C calls (the first, T / 100, measures the rate) and
# Ctrl-C still lands within about this.
CHUNK_WALL_S = 0.05


def simulate(scenario: Scenario | str, progress: bool = False, chunk: float | None = None,
             overrides: dict | None = None) -> Result:
    """Run a scenario (object, catalog name or TOML path) to its end or to a stop.

    An interrupt (Ctrl-C) ends the run early and keeps what was computed.
    The chunks (simulated seconds a C call) change nothing in the result.
    The result's metrics are computed at their first read (Result.metrics).
    """
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario, overrides)
    sim = Simulation(sc)
    T = sc.duration
    # periods, counted once by the C core's rule (fs_sim_steps): the loop ends
    # whatever the remainder of T after its last whole period
    n_end = sim.steps(T)
    grow = chunk is None and not progress
    n_chunk = max(1, sim.steps(chunk or max(T / 100.0, 1e-3)))
    bar = None
    if progress:
        from tqdm import tqdm
        # counted in periods, shown in seconds: the bar's total is the periods the run takes (its
        # end n_end Tc may pass T by up to Tc / 2; a total of T was passed, and tqdm warned)
        bar = tqdm(total=n_end, unit="s sim", unit_scale=sim.period, desc=sc.name, leave=False,
                   bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.3f}/{total:.3f} s [{elapsed}<{remaining}]")
    t0 = time.perf_counter()
    status = "running"
    try:
        while sim.step_count < n_end and status == "running":
            before, w0 = sim.step_count, time.perf_counter()
            status = sim.advance_steps(min(sim.step_count + n_chunk, n_end))
            dt = time.perf_counter() - w0
            if bar is not None:
                bar.update(sim.step_count - before)
            elif grow and dt < CHUNK_WALL_S:
                # doubling alone took seven calls for the bench's 12,800 periods, each its Python and its C entry
                fit = (sim.step_count - before) * (0.5 * CHUNK_WALL_S / dt) if dt > 0 else math.inf
                n_chunk = max(2 * n_chunk, int(min(fit, n_end)))
    except KeyboardInterrupt:
        status = "interrupted"
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - t0
    if status == "running":
        status = "done"
    # the metrics are formed when first read (Result.metrics)
    return Result(sc, sim.traces(), status, sim.stop_time, wall, sim.time, adc_saturated_at=sim.adc_saturated_at,
                  polarity=sim.polarity(), halt=sim.halt())
