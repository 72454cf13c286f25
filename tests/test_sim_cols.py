"""The column-major trace (fs_sim_run_cols) and the runner's chunks.

What could be wrong: a channel written to the wrong column or row, a call
that runs on past its buffer or with a stride that would overlap channels,
a grown buffer that loses the rows before it, and chunks (the C calls a
run is cut into) that change the result or do not grow as promised. The
row-major fs_sim_run is the reference: both layouts must hold the same
bits.
"""
from __future__ import annotations

import numpy as np
import pytest

import fullspeed.sim.runner as runner
from fullspeed._core import ffi, lib
from fullspeed.design.scenario import load_scenario

SC = load_scenario("bench-motulator-2kw", {"duration": 0.05, "trace": {"decimation": 3}, "metrics": {"steady": None}})


def rows_major(sc, t_end, n):
    sim = runner.Simulation(sc)
    buf, rows = np.full((n, lib.FS_CH_N), np.nan), ffi.new("int *")
    rc = lib.fs_sim_run(sim._sim, t_end, ffi.cast("double *", buf.ctypes.data), n, rows)
    return rc, buf[: rows[0]]


def test_columns_hold_the_row_major_trace_bit_for_bit_across_calls():
    rc, ref = rows_major(SC, SC.duration, 200)
    assert rc == lib.FS_RUN_DONE and len(ref) > 100
    sim = runner.Simulation(SC)
    stride = len(ref) + 7                     # a stride beyond the rows: the tail stays untouched
    buf, rows, n = np.full((lib.FS_CH_N, stride), np.nan), ffi.new("int *"), 0
    for t_end in (0.011, 0.02, SC.duration):  # three calls, each writing after the last
        ptr = ffi.cast("double *", buf.ctypes.data) + n
        assert lib.fs_sim_run_cols(sim._sim, sim.steps(t_end), ptr, stride, stride - n, rows) == lib.FS_RUN_DONE
        n += rows[0]
    assert n == len(ref)
    assert buf[:, :n].tobytes() == np.ascontiguousarray(ref.T).tobytes()
    assert np.isnan(buf[:, n:]).all()


@pytest.mark.parametrize("name, over", [
    ("zou2021-region-a", {}),                                                   # the matrix converter, its meters
    ("yu2022-seq-dyn", {}),                                                     # five phases: i_d3, i_q3
    ("beyond-thermal", {}),                                                     # the thermal model: R_s, the magnet
    ("yang2022-encoder-speedstep", {"losses": {"devices": True, "iron": True}}),  # the loss meters
])
def test_channels_held_by_the_configuration_or_moving_are_the_row_major_bits(name, over):
    # the column-major trace fills the channels a configuration holds constant once a call (fs_sim.c's groups);
    # each of these runs moves a group (in its first 30 ms), which must then be written a row at a time as before
    sc = load_scenario(name, {**over, "duration": 0.03, "metrics": {"steady": None}})
    n = runner.Simulation(sc).steps(sc.duration) + 2
    rc, ref = rows_major(sc, sc.duration, n)
    sim = runner.Simulation(sc)
    buf, rows = np.full((lib.FS_CH_N, n), np.nan), ffi.new("int *")
    base = ffi.cast("double *", buf.ctypes.data)
    half = lib.fs_sim_run_cols(sim._sim, sim.steps(sc.duration / 2), base, n, n, rows)
    first = rows[0]
    assert half == lib.FS_RUN_DONE and 0 < first < len(ref)
    assert lib.fs_sim_run_cols(sim._sim, sim.steps(sc.duration), base + first, n, n - first, rows) == rc
    assert first + rows[0] == len(ref) and len(ref) >= 20
    assert buf[:, : len(ref)].tobytes() == np.ascontiguousarray(ref.T).tobytes()
    assert np.isnan(buf[:, len(ref):]).all()


def test_a_call_without_a_trace_is_refused_and_writes_nothing():
    # the held channels' fill runs after the loop: not on a call refused for a missing trace, whose row
    # count is the caller's own (here 5: a fill would write five rows through the null pointer)
    sim = runner.Simulation(SC)
    rows = ffi.new("int *", 5)
    assert lib.fs_sim_run_cols(sim._sim, sim.steps(SC.duration), ffi.NULL, 10, 10, rows) == lib.FS_RUN_ERR_NULL
    assert rows[0] == 5 and sim.step_count == 0


def test_a_full_buffer_stops_the_call_and_the_next_goes_on():
    _, ref = rows_major(SC, SC.duration, 200)
    sim = runner.Simulation(SC)
    stride = len(ref)
    buf, rows = np.full((lib.FS_CH_N, stride), np.nan), ffi.new("int *")
    base = ffi.cast("double *", buf.ctypes.data)
    assert lib.fs_sim_run_cols(sim._sim, sim.steps(SC.duration), base, stride, 10, rows) == lib.FS_RUN_BUFFER_FULL
    assert rows[0] == 10 and np.isnan(buf[:, 10:]).all()
    assert lib.fs_sim_run_cols(sim._sim, sim.steps(SC.duration), base + 10, stride, stride - 10, rows) == lib.FS_RUN_DONE
    assert buf.tobytes() == np.ascontiguousarray(ref.T).tobytes()


def test_a_stride_below_the_rows_is_refused_before_any_step():
    sim = runner.Simulation(SC)
    buf, rows = np.zeros((lib.FS_CH_N, 8)), ffi.new("int *")
    ptr = ffi.cast("double *", buf.ctypes.data)
    assert lib.fs_sim_run_cols(sim._sim, sim.steps(SC.duration), ptr, 4, 8, rows) == lib.FS_RUN_ERR_STRIDE
    assert lib.fs_sim_run_cols(sim._sim, sim.steps(SC.duration), ptr, 0, 0, rows) == lib.FS_RUN_ERR_STRIDE
    assert lib.fs_sim_time(sim._sim) == 0.0 and not buf.any()
    assert lib.fs_sim_run_cols(ffi.NULL, 100, ptr, 8, 8, rows) == lib.FS_RUN_ERR_NULL


def test_the_runner_grows_its_buffer_without_losing_rows():
    # its buffer is sized for SC.duration (134 rows, padded to 514: runner.padded_rows): 5 times that needs 668
    _, ref = rows_major(SC, 5 * SC.duration, 800)
    sim = runner.Simulation(SC)
    cap = sim._buf.shape[1]
    assert sim.advance(5 * SC.duration) == "running"
    assert sim._buf.shape[1] > cap
    tr = sim.traces()
    assert all(v.flags.c_contiguous for v in tr.values())
    assert np.stack([tr[c] for c in runner.CHANNELS]).tobytes() == np.ascontiguousarray(ref.T).tobytes()


class _Counting:
    def __init__(self):
        self.calls = 0

    def __getattr__(self, name):
        return getattr(lib, name)

    def fs_sim_run_cols(self, *args):
        self.calls += 1
        return lib.fs_sim_run_cols(*args)


@pytest.mark.parametrize("wall_s, calls", [(float("inf"), 2), (0.0, 100)])
def test_chunks_grow_while_fast_and_change_nothing(monkeypatch, wall_s, calls):
    sc = load_scenario("bench-motulator-2kw", {"duration": 0.2, "metrics": {"steady": None}})
    fixed = runner.simulate(sc, chunk=sc.duration / 100)
    counting = _Counting()
    monkeypatch.setattr(runner, "lib", counting)
    monkeypatch.setattr(runner, "CHUNK_WALL_S", wall_s)
    res = runner.simulate(sc)
    # T/100, then as many periods as the budget holds at its rate (all of them, in no time): two calls; never
    # faster than the budget: 100
    assert counting.calls == calls
    assert res.stop_reason == fixed.stop_reason == "done"
    for ch in runner.CHANNELS:
        assert res[ch].tobytes() == fixed[ch].tobytes(), ch


def test_a_whole_run_fits_the_buffer_it_started_with():
    """The buffer is sized by the periods the run takes (fs_sim_steps, by
    rounding), not by int(duration / Tc), which falls one short where the
    division lands just below a whole number: the run's last call then
    doubled the buffer and copied the whole trace."""
    sim0 = runner.Simulation(SC)
    Tc = sim0.period
    # a duration in whole milliseconds whose division by Tc falls just short of its periods
    T = next(m / 1000 for m in range(10, 500) if int((m / 1000) / Tc) < round((m / 1000) / Tc))
    sc = load_scenario("bench-motulator-2kw", {"duration": T, "metrics": {"steady": None}})
    sim = runner.Simulation(sc)
    n = sim.steps(sc.duration)
    assert int(sc.duration / Tc) == n - 1
    buf = sim._buf
    assert sim.advance(sc.duration) == "running" and sim.step_count == n   # simulate() calls it done
    assert sim._buf is buf
    tr = sim.traces()
    assert tr["t"].size == n and tr["t"].base is buf


def test_a_flat_profile_read_without_its_piece_gives_the_bits_of_the_piece():
    # a profile of one point is read as its one value (fs_sim.c's fixed profiles); the same value drawn as two
    # points goes through the profile's piece: both runs must hold the same bits, and a master's hold
    # (fs_sim_hold) still takes its place
    flat = {"duration": 0.03, "metrics": {"steady": None}, "load": {"torque": [[0.0, 3.7]]}}
    drawn = {**flat, "load": {"torque": [[0.0, 3.7], [0.5, 3.7]]}}
    a, b = (runner.simulate(load_scenario("bench-motulator-2kw", o)) for o in (flat, drawn))
    assert a["T_L"][-1] == 3.7 and np.all(a["T_L"] == 3.7)
    assert all(a[ch].tobytes() == b[ch].tobytes() for ch in runner.CHANNELS)
    sim = runner.Simulation(load_scenario("bench-motulator-2kw", flat))
    assert lib.fs_sim_hold(sim._sim, lib.FS_SIM_T_LOAD, -1.25, 0.0) == 0
    sim.advance(0.01)
    assert np.all(sim.traces()["T_L"] == -1.25)


def test_the_buffers_stride_never_puts_the_channels_on_one_page_offset():
    """What could be wrong: a stride of a whole number of 4 KiB pages (any
    run whose periods come to a multiple of 512, less the two rows spare)
    puts every channel's sample k at the same page offset, where the
    runner's loop took half as long again; the padding must hold for the
    first buffer and a grown one, and must not lose a row."""
    assert [runner.padded_rows(n) for n in (1, 2, 3, 512, 514, 1024, 12802)] == [2, 2, 514, 514, 514, 1026, 12802]
    for T in (0.064, 0.128):   # 512 and 1,024 periods of 125 us: the bare count, plus two, is 2 past a multiple
        sc = load_scenario("bench-motulator-2kw", {"duration": T - 2 * 125e-6, "metrics": {"steady": None}})
        sim = runner.Simulation(sc)
        assert sim._buf.shape[1] % 512 == 2 and sim._buf.shape[1] >= sim.steps(sc.duration) + 2
        assert sim.advance(2 * T) == "running"           # past its first buffer: grown, padded the same
        assert sim._buf.shape[1] % 512 == 2
        assert sim.traces()["t"].size == sim.step_count
