"""Sweeps: the description, the points and their draws, durability under
SIGKILL, failing points, the local pool against Dask, the table."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fullspeed.cli import main
from fullspeed.design.scenario import scenario_from_dict
from fullspeed.model.errors import ConfigError
from fullspeed.workflows.journal import JOURNAL
from fullspeed.workflows.sweep import load_sweep, load_sweep_file, run_sweep, sweep_from_dict

pd = pytest.importorskip("pandas")

# short runs of the SMO at a held speed: about 0.05 s of wall time each
BASE = {"base": "yang2022-smo-steady-400rpm",
        "overrides": {"duration": 0.3, "observer": {"handover": 0.1}, "metrics": {"steady": [0.2, 0.3]}},
        "metrics": ["est_err_deg.mean", "est_err_deg.pp", "i_q_error_rms"]}


def grid_spec(**kw) -> dict:
    return {"name": "t-grid", **BASE,
            "axes": {"references.i_q": [5.0, 15.0, 25.0], "load.speed_rpm": {"range": [200.0, 800.0, 200.0]}}, **kw}


def mc_spec(seed=7, samples=6) -> dict:
    return {"name": "t-mc", **BASE, "seed": seed, "samples": samples,
            "axes": {"controller.psi_f_scale": {"uniform": [0.8, 1.2]}, "sensors.seed": {"integers": [1, 10**6]}}}


def write_toml(path: Path, d: dict) -> Path:
    def val(v):
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{json.dumps(k)} = {val(x)}" for k, x in v.items()) + " }"
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(v)
    path.write_text("\n".join(f"{json.dumps(k)} = {val(v)}" for k, v in d.items()) + "\n")
    return path


def table(folder: Path):
    """The table without the wall times, which no two runs share."""
    return load_sweep(folder).drop(columns=["wall_s"])


# --- the description ------------------------------------------------------

def test_grid_is_the_product_in_order_with_ranges_expanded():
    sw = sweep_from_dict(grid_spec(), "t")
    pts = sw.points()
    assert sw.shape == (3, 4) and len(pts) == 12
    assert [p["load.speed_rpm"] for p in pts[:4]] == [200.0, 400.0, 600.0, 800.0]
    assert [p["references.i_q"] for p in pts[::4]] == [5.0, 15.0, 25.0]
    task = sw.tasks()[5]
    assert task["scenario"]["references"]["i_q"] == 15.0 and task["scenario"]["load"]["speed_rpm"] == 400.0
    assert task["scenario"]["duration"] == 0.3          # the overrides reach every point


def test_linked_fields_and_machine_fields_reach_the_scenario():
    sw = sweep_from_dict({"name": "l", **BASE, "axes": {
        "load.speed_rpm,initial.speed_rpm": [300.0], "machine.electrical.R_s": {"linspace": [0.1, 0.2, 2]}}}, "t")
    data = sw.tasks()[1]["scenario"]
    assert data["load"]["speed_rpm"] == data["initial"]["speed_rpm"] == 300.0
    assert data["machine"] == {"catalog": "yang2022", "electrical": {"R_s": 0.2}}


SERVO = """name = "servo400"
kind = "ipmsm"
pole_pairs = 4
[electrical]
R_s = 0.3
L_d = 0.6e-3
L_q = 0.7e-3
psi_f = 0.011
[mechanical]
J = 5e-5
[rated]
torque = 1.27
current = 8.0
speed_rpm = 3000.0
[bench]
u_dc = 48.0
f_pwm = 16000.0
"""


def own_machine_base(folder: Path) -> Path:
    """A scenario whose machine is a file beside it (as new-machine and the README's own machine)."""
    folder.mkdir()
    (folder / "servo400.toml").write_text(SERVO)
    return write_toml(folder / "servo-run.toml", {"name": "servo-run", "duration": 0.01, "machine": "servo400.toml",
                                                  "controller": {"mode": "current"}})


@pytest.mark.parametrize("here", [".", "scen"])
def test_a_machine_file_beside_the_base_takes_machine_axes_and_overrides(tmp_path, here):
    # the sweep in another folder than its base or beside it: the machine file is found beside the
    # base, and the axis and the override go into the file's machine (they were refused: the file
    # not found, or 'machine.catalog = servo400.toml: unknown machine')
    base = own_machine_base(tmp_path / "scen")
    sw = sweep_from_dict({"name": "own", "base": str(base), "overrides": {"machine": {"bench": {"f_pwm": 10000.0}}},
                          "axes": {"machine.electrical.R_s": [0.3, 0.4]}}, str(tmp_path / here / "sw.toml"), tmp_path / here)
    data = sw.tasks()[1]["scenario"]
    assert data["machine"]["name"] == "servo400" and data["machine"]["electrical"]["R_s"] == 0.4
    assert data["machine"]["electrical"]["L_q"] == 0.7e-3 and data["machine"]["bench"]["f_pwm"] == 10000.0
    sc = scenario_from_dict(data, sw.base_source, warn=False)
    assert sc.machine.name == "servo400" and sc.machine.R_s == 0.4


def test_the_own_machine_example_sweeps_its_machine_from_another_folder(tmp_path):
    base = Path(__file__).resolve().parents[1] / "examples" / "own-machine" / "my48v-full-range.toml"
    sw = sweep_from_dict({"name": "own", "base": str(base), "overrides": {"duration": 1.0},
                          "axes": {"machine.mechanical.J": [4e-4, 8e-4]}}, str(tmp_path / "sw.toml"), tmp_path)
    sc = scenario_from_dict(sw.tasks()[1]["scenario"], sw.base_source, warn=False)
    assert sc.machine.name == "my48v" and sc.machine.J == 8e-4


def test_sweep_set_merges_a_machine_field_into_the_machine_file(tmp_path, capsys):
    base = own_machine_base(tmp_path / "scen")
    sw = write_toml(base.parent / "sw.toml", {"name": "own-set", "base": base.name, "metrics": ["i_q_error_rms"],
                                           "axes": {"references.i_q": [0.5, 1.0]}})
    # was refused: 'missing required fields: machine.name, kind, ...' (the file replaced by the one field)
    assert main(["sweep", str(sw), "--set", "machine.mechanical.J=1e-4", "--out", str(tmp_path / "o"),
                 "--workers", "1", "--quiet"]) == 0, capsys.readouterr().err
    assert list(load_sweep(tmp_path / "o")["stop_reason"]) == ["done", "done"]
    capsys.readouterr()
    # the value reaches the file's machine: one it refuses is its refusal
    assert main(["sweep", str(sw), "--set", "machine.mechanical.J=-1.0", "--out", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "J = -1.0" in err[0] and "missing required" not in err[0], err


def test_same_seed_same_draws_other_seed_other_draws():
    a, b, c = (sweep_from_dict(mc_spec(seed=s), "t").points() for s in (7, 7, 8))
    assert a == b and a != c
    assert all(0.8 <= p["controller.psi_f_scale"] <= 1.2 for p in a)
    assert len({p["controller.psi_f_scale"] for p in a}) == len(a)       # fresh draws per sample


@pytest.mark.parametrize("change, field", [
    ({"axes": {"references.i_qq": [1.0]}}, "axes.references.i_qq"),
    ({"axes": {"controller": [1.0]}}, "axes.controller"),
    ({"axes": {"references.i_q": {"uniform": [2.0, 1.0]}}}, "axes.references.i_q.uniform"),
    ({"axes": {"references.i_q": {"linspace": [0.0, 1.0, 0]}}}, "axes.references.i_q.linspace"),
    ({"axes": {"references.i_q": {"range": [0.0, 1.0, -0.5]}}}, "axes.references.i_q.range"),
    ({"axes": {"references.i_q": {"gamma": [1.0, 2.0]}}}, "axes.references.i_q.gamma"),
    ({"samples": 3}, "samples"),
    ({"metrics": ["speed_error"]}, "metrics"),
    ({"base": "no-such-scenario"}, "base"),
    ({"colour": "red"}, "colour"),
])
def test_bad_descriptions_are_refused_naming_the_field(change, field):
    with pytest.raises(ConfigError) as err:
        sweep_from_dict({**grid_spec(), **change}, "my.toml")
    assert str(err.value).startswith(f"my.toml: {field} = ")


def test_cli_refuses_a_bad_sweep_with_one_line_and_status_2(tmp_path, capsys):
    path = write_toml(tmp_path / "bad.toml", {**grid_spec(), "samples": 0})
    assert main(["sweep", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "samples = 0" in err[0]


# --- running ----------------------------------------------------------------

def test_failing_points_are_recorded_and_the_sweep_goes_on(tmp_path):
    """A random draw the scenario refuses is a row with its error (a Monte
    Carlo counts it); a bad grid value is refused before anything runs."""
    sw = sweep_from_dict({"name": "f", **BASE, "seed": 3, "samples": 4,
                          "axes": {"controller.bw_current": {"uniform": [-3000.0, 3000.0]}}}, "t")
    _, rows = run_sweep(sw, tmp_path, workers=1, plot=False)
    bad = [r for r in rows if r["controller.bw_current"] <= 0]
    good = [r for r in rows if r["controller.bw_current"] > 0]
    assert bad and good, rows
    assert all(r["stop_reason"] == "error" and "controller.bw_current = -" in r["error"] for r in bad)
    assert all(r["stop_reason"] == "done" and r["error"] is None and r["est_err_deg.pp"] is not None for r in good)
    with pytest.raises(ConfigError, match=r"controller.bw_current = -1.0: .*axes.controller.bw_current = -1.0"):
        sweep_from_dict({"name": "f", **BASE, "axes": {"controller.bw_current": [-1.0, 2000.0]}}, "t")


def test_identical_seeds_give_identical_results(tmp_path):
    for d in ("a", "b"):
        run_sweep(sweep_from_dict(mc_spec(), "t"), tmp_path / d, workers=1, plot=False)
    a, b = table(tmp_path / "a"), table(tmp_path / "b")
    pd.testing.assert_frame_equal(a, b)
    assert a["est_err_deg.mean"].nunique() == len(a)      # the draws did change the runs


def test_another_sweep_in_the_same_folder_is_refused(tmp_path):
    run_sweep(sweep_from_dict(mc_spec(samples=2), "t"), tmp_path, workers=1, plot=False)
    with pytest.raises(ConfigError, match="different sweep"):
        run_sweep(sweep_from_dict(mc_spec(seed=9, samples=2), "t"), tmp_path, workers=1, plot=False)


def test_a_sweep_into_a_folder_in_use_says_only_that(tmp_path, capsys):
    """A second sweep into the folder a running one holds is refused in one
    line (a new user's trial: it first printed "sweep ...: 300 points in 2
    worker process(es)", as if it ran); with the folder free it says so, once."""
    from fullspeed.model.files import claim

    path = write_toml(tmp_path / "s.toml", {**grid_spec(), "axes": {"references.i_q": [5.0, 15.0]}})
    out = tmp_path / "o"
    argv = ["sweep", str(path), "--out", str(out), "--workers", "1", "--quiet"]
    with claim(out):   # the running sweep's lock (flock: another open of the folder conflicts, in this process too)
        assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("fullspeed: error: --out = ") and "in use by another" in err[0], err
    assert not (out / JOURNAL).exists()
    assert main(argv) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert [e for e in err if e.startswith("sweep ")] == [f"sweep t-grid: 2 points in 1 worker process(es) -> {out}"]


def test_killed_sweep_resumes_to_the_uninterrupted_table(tmp_path):
    spec = write_toml(tmp_path / "s.toml", {**grid_spec(), "axes": {
        "references.i_q": [5.0, 10.0, 15.0, 20.0, 25.0], "load.speed_rpm": {"range": [200.0, 1400.0, 200.0]}}})
    n = 35
    run_sweep(load_sweep_file(spec), tmp_path / "whole", workers=1, plot=False)
    cmd = [sys.executable, "-m", "fullspeed", "sweep", str(spec), "--workers", "2", "--out", str(tmp_path / "cut"),
           "--quiet"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    journal = tmp_path / "cut" / JOURNAL
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if journal.exists() and journal.read_bytes().count(b"\n") >= 5:
            break
        time.sleep(0.01)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    before = journal.read_bytes().count(b"\n")
    assert 5 <= before < n, "the kill must land part-way"
    partial = load_sweep(tmp_path / "cut")                  # what the journal holds, as a table
    assert len(partial) == before and partial["references.i_q"].notna().all()

    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    lines = [json.loads(x) for x in journal.read_text().splitlines()]
    assert len(lines) == n and len({x["task"] for x in lines}) == n    # only the missing points ran
    pd.testing.assert_frame_equal(table(tmp_path / "cut"), table(tmp_path / "whole"))


def test_local_pool_and_dask_give_identical_tables(tmp_path):
    distributed = pytest.importorskip("distributed")
    sw = sweep_from_dict(mc_spec(samples=8), "t")
    run_sweep(sw, tmp_path / "pool", workers=2, plot=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        run_sweep(sw, tmp_path / "dask", dask=cluster.scheduler_address, plot=False)
    pd.testing.assert_frame_equal(table(tmp_path / "pool"), table(tmp_path / "dask"))


def test_csv_without_pyarrow_holds_the_same_values(tmp_path, monkeypatch):
    sw = sweep_from_dict(grid_spec(), "t")
    run_sweep(sw, tmp_path / "pq", workers=1, plot=False)
    a = table(tmp_path / "pq")
    monkeypatch.setattr("fullspeed.workflows.sweep._pyarrow", lambda: None)    # as without pyarrow
    path, _ = run_sweep(sw, tmp_path / "csv", workers=1, plot=False)
    assert path.name == "results.csv"
    b = table(tmp_path / "csv")
    num = [c for c in a.columns if a[c].dtype.kind == "f"]
    pd.testing.assert_frame_equal(a[num], b[num])


def test_a_rerun_in_the_other_format_leaves_one_table(tmp_path, monkeypatch):
    """A new user's trial: a finished sweep run again after installing the
    [sweep] extra wrote results.parquet beside the earlier results.csv, two
    tables that may disagree (and the other way round load_sweep read the
    stale parquet before the new csv). The earlier format's table goes; the
    journal's rows are all in the new one."""
    pytest.importorskip("pyarrow")
    sw = sweep_from_dict({**grid_spec(), "axes": {"references.i_q": [5.0, 15.0]}}, "t")
    out = tmp_path / "o"
    monkeypatch.setattr("fullspeed.workflows.sweep._pyarrow", lambda: None)   # as without pyarrow
    path, _ = run_sweep(sw, out, workers=1, plot=False)
    assert path.name == "results.csv"
    csv_table = table(out)
    monkeypatch.undo()   # pyarrow installed since
    path, _ = run_sweep(sw, out, workers=1, plot=False)
    assert path.name == "results.parquet" and sorted(p.name for p in out.glob("results*")) == ["results.parquet"]
    assert len(table(out)) == 2 and table(out)["i_q_error_rms"].tolist() == csv_table["i_q_error_rms"].tolist()
    (out / "results.parquet").write_bytes(b"stale")   # a table that no longer holds the rows: removed the other way too
    monkeypatch.setattr("fullspeed.workflows.sweep._pyarrow", lambda: None)
    path, _ = run_sweep(sw, out, workers=1, plot=False)
    assert sorted(p.name for p in out.glob("results*")) == ["results.csv"] and len(table(out)) == 2
    assert not [p for p in out.iterdir() if p.name.startswith(".")]
    # killed as the new table is written: no stale table is read, the journal's rows are
    monkeypatch.undo()
    def killed(path, write):
        raise KeyboardInterrupt
    monkeypatch.setattr("fullspeed.workflows.sweep.write_with", killed)
    with pytest.raises(KeyboardInterrupt):
        run_sweep(sw, out, workers=1, plot=False)
    assert not list(out.glob("results*"))
    assert table(out)["i_q_error_rms"].tolist() == csv_table["i_q_error_rms"].tolist()


def test_maps_are_drawn_for_one_and_two_grid_axes_only(tmp_path):
    from fullspeed.sim.plots import plot_sweep

    sw2 = sweep_from_dict(grid_spec(), "t")
    _, rows = run_sweep(sw2, tmp_path / "two", workers=1)
    assert (tmp_path / "two" / "sweep.png").stat().st_size > 10_000
    three = sweep_from_dict({**grid_spec(), "axes": {**grid_spec()["axes"], "controller.bw_speed": [50.0]}}, "t")
    assert plot_sweep(three, rows, tmp_path / "three.png") is None
