"""Tests of bench/breakdown.py's logic: a simulate() call's instructions per
sample split into the control step, the plant, the runner, the tracing, the
metrics and the front.

What could be wrong: an annotation line misread (a function's inclusive
count taken from a caller's line, the lines callgrind_annotate prints
without the object in brackets), a part counted twice or the base driver's
warm-up not cancelled, the switching model's phase currents left in the
runner, nanoseconds that do not add up to the measured time, and a missing
valgrind turning into a crash. No callgrind runs here: the annotations are
written out by hand in callgrind_annotate's format.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]
bd = load_script(ROOT / "bench" / "breakdown.py", "bench_breakdown")

SO = "[/x/_core.abi3.so]"


def annotation(total, fns, calls=()):
    """callgrind_annotate --inclusive=yes --tree=caller text: fns {name:
    inclusive}, calls [(caller, callee, cost, count)]."""
    lines = [f"{total:,} (100.0%)  PROGRAM TOTALS", ""]
    for fn, cost in fns.items():
        for caller, callee, c, k in calls:
            if callee == fn:
                lines.append(f"  {c:,} ( 1.00%)  < /x/csrc/sim/fs_sim.c:{caller} ({k:,}x) {SO}")
        # the function's own line, once with and once without the object
        lines.append(f"  {cost:,} ( 2.00%)  *  /x/csrc/f.c:{fn}")
        lines.append(f"  {cost // 2:,} ( 1.00%)  *  csrc/f.c:{fn} {SO}")
        lines.append("")
    return "\n".join(lines)


def test_the_annotation_gives_totals_inclusive_counts_and_calls():
    a = bd.parse_annotation(annotation(1_000_000, {"fs_drive_step": 28_406_579, "phase_currents": 600},
                                       [("advance", "phase_currents", 500, 3), ("sample", "phase_currents", 100, 1)]))
    assert a["total"] == 1_000_000
    assert a["incl"]["fs_drive_step"] == 28_406_579          # the larger of its two lines: the whole function
    assert a["calls"][("advance", "phase_currents")] == (500, 3)
    assert a["calls"][("sample", "phase_currents")] == (100, 1)


def test_a_functions_copies_under_link_time_optimisation_count_as_the_function():
    # the core is built with -flto: fs_sim_run_cols is a wrapper around its clone, fs_drive_step has an alias
    # called from elsewhere, phase_currents_at is called from the integration's own function
    a = bd.parse_annotation(annotation(
        1_000_000, {"fs_sim_run_cols": 5_010, "fs_sim_run_cols.part.0.constprop.0": 5_000, "fs_drive_step": 300,
                    "fs_drive_step.localalias.lto_priv.0": 200, "phase_currents_at.lto_priv.0": 90},
        [("fs_sim_run_cols", "fs_sim_run_cols.part.0.constprop.0", 5_000, 1),
         ("integrate_period.lto_priv.0", "phase_currents_at.lto_priv.0", 60, 2),
         ("advance.lto_priv.0", "phase_currents_at.lto_priv.0", 30, 1)]))
    assert a["incl"]["fs_sim_run_cols"] == 5_010            # the wrapper holds its clone: not 10,010
    assert a["incl"]["fs_drive_step"] == 500                # two entries into the same code: both
    assert a["calls"][("integrate_period", "phase_currents_at")] == (60, 2)


def test_the_plant_is_the_integrations_function_whatever_the_inliner_took_into_it():
    # integrate_period under its LTO name holds the RK4 steps, the segments' currents and, inlined, the
    # inverter's model; the stop check's currents (advance's) are the runner's
    a = bd.parse_annotation(annotation(
        1_000_000, {"integrate_period.lto_priv.0": 1_350, "fs_pmsm_rk4_at": 1_000, "advance.lto_priv.0": 2_000,
                    "phase_currents_at.lto_priv.0": 90},
        [("integrate_period.lto_priv.0", "phase_currents_at.lto_priv.0", 60, 2),
         ("advance.lto_priv.0", "phase_currents_at.lto_priv.0", 30, 1)]))
    assert bd.plant_ir(a) == 1_350                           # not the rk4 and currents again, not advance's
    assert bd.plant_ir({"incl": {"integrate_period_imc": 900}, "calls": {}}) == 900   # the matrix converter's


def test_an_integration_inlined_out_of_sight_fails_rather_than_counting_it_as_the_runner():
    a = {"total": 2_000, "incl": {"fs_sim_run_cols": 900, "fs_drive_step": 300}, "calls": {}}
    with pytest.raises(RuntimeError, match="integrate_period"):
        bd.split(a, a, a, a, 1, 10)


def test_parts_are_differences_to_the_base_and_add_up_to_the_run():
    samples, n = 10, 2

    def ann(total, run, drive, rk4, runs=bd.WARM_RUNS):
        # the stop check's phase currents, 7 instructions, once a sample of every run
        return {"total": total, "incl": {"fs_sim_run_cols": run, "fs_drive_step": drive, "integrate_period": rk4},
                "calls": {("advance", "phase_currents"): (7 * samples * runs, samples * runs)}}
    base = ann(1_000_000, 7_000, 3_000, 1_000)            # imports, warm-up: cancel
    sim = ann(1_000_000 + 2 * 9_000, 7_000 + 2 * 6_000, 3_000 + 2 * 2_500, 1_000 + 2 * 1_500, bd.WARM_RUNS + n)
    met = ann(1_000_000 + 2 * 1_200, 7_000, 3_000, 1_000)
    one = ann(1_000_000, 7_000 + 2 * 5_400, 3_000, 1_000)  # the run tracing one row: 600 a run less
    rep = bd.split(base, sim, met, one, n, samples)
    ps = rep["per_sample"]
    assert rep["per_run"] == 9_000 and rep["c_loop_per_run"] == 6_000
    assert ps == pytest.approx({"control": 250.0, "plant": 150.0, "tracing": 60.0, "runner": 140.0,
                                "metrics": 120.0, "front": 180.0})
    assert sum(ps.values()) == pytest.approx(rep["total_per_sample"])


def test_nanoseconds_share_the_measured_times():
    ps = {"control": 200.0, "plant": 100.0, "tracing": 50.0, "runner": 50.0, "metrics": 80.0, "front": 20.0}
    wall = {"c_loop_s": 0.004, "metrics_s": 0.001, "simulate_s": 0.0055}
    ns = bd.nanoseconds(ps, wall, samples=10_000)
    assert ns["control"] == pytest.approx(200.0) and ns["plant"] == pytest.approx(100.0)   # 400 ns loop by 400 instr.
    assert ns["metrics"] == pytest.approx(100.0) and ns["front"] == pytest.approx(50.0)
    assert sum(ns.values()) == pytest.approx(550.0)


def test_without_valgrind_it_skips_and_says_why(monkeypatch):
    monkeypatch.setattr(bd.shutil, "which", lambda name: None)
    rep = bd.breakdown_report(runs=1, timing_runs=1)
    assert rep["status"] == "skipped" and "valgrind" in rep["reason"]
    assert bd.format_report(rep).startswith("per-sample breakdown: skipped")
    assert bd.main(["--runs", "0"]) == 2
