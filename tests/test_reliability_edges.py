"""Reliability at the edges (issue 22; the cases of
../shared/reports/reliability-probe-2026-11-24.md, numbered as there):
bounded reads, names that stay inside out/, atomic outputs, interrupts,
dead workers and lost clusters, exit 2 for every bad input, the C API's
NULL checks, and the mutation campaign at the Python API."""
from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fullspeed.model import files
from fullspeed.cli import main
from fullspeed.model.errors import ConfigError, EngineError
from fullspeed.sim import CHANNELS
from fullspeed.workflows.journal import JOURNAL, TASKS, read_journal, run_tasks
from fullspeed.design.scenario import load_scenario

BASE = ('name = "bad"\nduration = 0.05\nmachine = "yang2022"\n[controller]\nmode = "current"\nangle = "encoder"\n'
        '[references]\ni_q = 5.0\n[load]\nkind = "speed_pi"\nspeed_rpm = 400.0\n')
HFI = BASE.replace('angle = "encoder"', 'angle = "hfi"')
BIG = "1" + "0" * 400   # a 401-digit TOML integer
# a sweep of short SMO points (about 0.05 s of wall each)
SWEEP = ('name = "{name}"\nbase = "yang2022-smo-steady-400rpm"\nmetrics = ["est_err_deg.mean"]\n'
         '[overrides]\nduration = {duration}\nobserver = {{ handover = 0.1 }}\nmetrics = {{ steady = [0.2, {duration}] }}\n'
         '{extra}[axes]\n{axes}\n')
AXES = '"references.i_q" = [5.0, 15.0]\n"load.speed_rpm" = [200.0, 400.0, 600.0]'
ENV = {**os.environ, "PYTHONWARNINGS": "ignore"}
FS = [sys.executable, "-m", "fullspeed"]


def run_cli(capsys, *argv) -> tuple[int, str]:
    rc = main(list(argv))
    return rc, capsys.readouterr().err


def one_line_exit_2(capsys, *argv, words=()) -> str:
    rc, err = run_cli(capsys, *argv)
    assert rc == 2, err
    lines = [line for line in err.strip().splitlines() if not line.startswith("sweep ")]   # a sweep's banner
    assert len(lines) == 1 and "Traceback" not in err, err
    for w in words:
        assert w in err, err
    return err


def sweep_file(path: Path, name="t-edges", duration=0.3, axes=AXES, extra="") -> Path:
    path.write_text(SWEEP.format(name=name, duration=duration, axes=axes, extra=extra))
    return path


def no_run(monkeypatch):
    """Fail the test if a simulation starts: the refusal must come first."""
    import fullspeed.sim

    def boom(*a, **k):
        raise AssertionError("the simulation ran before the input was refused")
    monkeypatch.setattr(fullspeed.sim, "simulate", boom)
    monkeypatch.setattr(fullspeed.sim.Simulation, "__init__", boom)


# --- 5, 6, 7, 8: bad input that used to end in exit 3 -------------------------

@pytest.mark.parametrize("what,text,field", [
    ("401-digit duration", BASE.replace("duration = 0.05", f"duration = {BIG}"), "duration"),
    ("401-digit profile value", BASE.replace("i_q = 5.0", f"i_q = [[0.0, {BIG}]]"), "references.i_q[0]"),
    ("401-digit profile time", BASE.replace("i_q = 5.0", f"i_q = [[{BIG}, 1.0]]"), "references.i_q[0]"),
    ("-401-digit float field", BASE + f"bandwidth = -{BIG}\n", "load.bandwidth"),
    ("5000-digit integer", BASE.replace("duration = 0.05", "duration = 1" + "0" * 5000), "toml"),
    ("machine file name of 5000 bytes", BASE.replace('machine = "yang2022"', f'machine = "{"m" * 5000}.toml"'), "machine"),
    ("5000-segment dotted key", BASE + ".".join(["a"] * 5000) + " = 1\n", "load.a"),
    ("5000-segment table header", BASE + "[" + ".".join(["t"] * 5000) + "]\n", "t"),
    ("tiny top speed (smo)", BASE.replace('"encoder"', '"smo"') + "[observer]\ntop_speed_rpm = 5e-324\n", "observer.top_speed_rpm"),
    ("tiny rated speed", BASE.replace('machine = "yang2022"', 'machine = { catalog = "yang2022", rated = '
                                      '{ torque = 2.0, current = 56.57, speed_rpm = 5e-324 } }'), "machine.rated.speed_rpm"),
    ("tiny rated speed (smo)", BASE.replace('"encoder"', '"smo"').replace(
        'machine = "yang2022"', 'machine = { catalog = "yang2022", rated = { torque = 2.0, current = 56.57, speed_rpm = 5e-324 } }'),
     "machine.rated.speed_rpm"),
    ("third_harmonic a string", BASE.replace('machine = "yang2022"', 'machine = { catalog = "yang2022", third_harmonic = "x" }'),
     "machine.third_harmonic"),
    ("third_harmonic unknown key", BASE.replace('machine = "yang2022"', 'machine = { catalog = "yang2022", third_harmonic = { bogus = 1 } }'),
     "machine.third_harmonic.bogus"),
    ("third_harmonic unknown key, five phases", BASE.replace(
        'machine = "yang2022"', 'machine = { catalog = "yu2022", third_harmonic = { L_d3 = 1e-3, L_q3 = 1e-3, psi_f3 = 0.0, bogus = 1 } }'),
     "machine.third_harmonic.bogus"),
])
def test_bad_input_is_exit_2_before_any_work(tmp_path, capsys, monkeypatch, what, text, field):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    no_run(monkeypatch)
    err = one_line_exit_2(capsys, "run", str(f), "--quiet", "--out", str(tmp_path / "o"))
    assert f"{field} = " in err, err
    assert len(err) < 600, err


def test_config_error_repr_is_bounded():
    deep: dict = {}
    cur = deep
    for _ in range(100_000):
        cur["a"] = {}
        cur = cur["a"]
    for value in (deep, 10**5000 if sys.get_int_max_str_digits() == 0 else 10**4000, "x" * 10**6, list(range(10**5))):
        e = ConfigError("f", value, "allowed")
        assert len(str(e)) < 300 and "\n" not in str(e)


# --- 9, 10: reads that are bounded -------------------------------------------

def test_dev_zero_fifo_directory_and_huge_files_are_refused_without_reading(tmp_path, capsys, monkeypatch):
    fifo = tmp_path / "f.toml"
    os.mkfifo(fifo)
    big = tmp_path / "big.toml"
    with open(big, "wb") as f:   # sparse: 65 MiB on paper, nothing on disk
        f.truncate(files.MAX_TOML_BYTES + 2**20)
    no_run(monkeypatch)
    t0 = time.monotonic()
    for path, words in (("/dev/zero", "not a regular file"), (str(fifo), "not a regular file"),
                        (str(tmp_path), "directory"), (str(big), "at most")):
        one_line_exit_2(capsys, "run", path, "--quiet", words=(words,))
    xc = tmp_path / "s.toml"
    for target in ("/dev/zero", str(fifo)):
        xc.write_text(HFI + f'[injection]\nxcomp = "{target}"\n')
        one_line_exit_2(capsys, "run", str(xc), "--quiet", words=("injection.xcomp", "not a regular file"))
    assert time.monotonic() - t0 < 30   # no FIFO blocked, nothing read to the end


def test_bounded_reader_reads_a_file_that_grows_only_to_the_limit(tmp_path):
    f = tmp_path / "x.toml"
    f.write_bytes(b"a" * 100)
    assert files.read_bounded(f, "x", limit=100) == b"a" * 100
    with pytest.raises(ConfigError, match="at most 99"):
        files.read_bounded(f, "x", limit=99)


# --- 11, 12, 13, 14, 21: names that make paths ---------------------------------

@pytest.mark.parametrize("name", ["../../escape", "/tmp/fullspeed-abs-escape", "x/y/z", "", ".", "..", "a\u0000b",
                                  "a\nb", "n" * 201, "\u00e9" * 101])
def test_a_name_that_is_not_one_path_component_is_refused_before_the_run(tmp_path, capsys, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    f = tmp_path / "s.toml"
    f.write_text(BASE.replace('name = "bad"', f"name = {json.dumps(name)}"))
    no_run(monkeypatch)
    one_line_exit_2(capsys, "run", str(f), "--quiet", words=("name = ", "cannot name an output"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]   # nothing written anywhere
    assert not Path("/tmp/fullspeed-abs-escape").exists()


def test_a_long_name_is_refused_by_the_schema_and_a_valid_unusual_one_runs_inside_out(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    f = tmp_path / "s.toml"
    f.write_text(BASE.replace('name = "bad"', f'name = "{"n" * 100_000}"'))
    t0 = time.monotonic()
    one_line_exit_2(capsys, "run", str(f), "--quiet", "--out", "o", words=("at most 4096 characters",))
    assert time.monotonic() - t0 < 10
    f.write_text(BASE.replace('name = "bad"', 'name = "run \u00e9t\u00e9 1"').replace("0.05", "0.005"))
    rc, err = run_cli(capsys, "run", str(f), "--quiet")
    assert rc == 0, err
    assert (tmp_path / "out" / "run \u00e9t\u00e9 1" / "metrics.json").is_file()


def test_calibrate_refuses_a_machine_name_that_leaves_out_before_it_runs(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    f = tmp_path / "s.toml"
    f.write_text(HFI.replace('machine = "yang2022"', 'machine = { catalog = "yang2022", name = "../../cal_escape" }'))
    no_run(monkeypatch)
    one_line_exit_2(capsys, "calibrate", str(f), "--points", "2", "--i-q-max", "5", words=("machine.name",))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def test_sweep_name_that_leaves_out_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    f = sweep_file(tmp_path / "s.toml", name="../../sw_escape")
    one_line_exit_2(capsys, "sweep", str(f), "--quiet", words=("name = ", "path separator"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


@pytest.mark.parametrize("name,ok", [("a", True), ("yang2022 run #3", True), ("\u6e2c\u8a66", True),
                                     ("a/b", False), ("a\\b", False), ("..", False), ("", False), ("x" * 200, True),
                                     ("x" * 201, False), ("a\x7fb", False), (3, False)])
def test_safe_name(name, ok, tmp_path):
    if ok:
        p = files.out_path(tmp_path, name, "name")
        assert p.parent == tmp_path and p.name == name
    else:
        with pytest.raises(ConfigError, match="cannot name an output"):
            files.out_path(tmp_path, name, "name")


# --- 19, 34: sweep axes and addresses -------------------------------------------

@pytest.mark.parametrize("axes,field", [
    ('"sensors.seed" = { integers = [0, 1180591620717411303424] }', "integers"),
    ('"controller.R_s_scale" = { uniform = [-1e308, 1e308] }', "uniform"),
    ('"controller.R_s_scale" = { normal = [1e308, 1e308] }', "normal"),
    (f'"references.i_q" = [5.0, {BIG}]', "references.i_q"),
    (f'"references.i_q" = {{ linspace = [0.0, {BIG}, 3] }}', "linspace"),
    (f'"references.i_q" = {{ linspace = [0.0, 1.0, {BIG}] }}', "linspace"),
    (f'"references.i_q" = {{ range = [0.0, {BIG}, 1.0] }}', "range"),
    ('"references.i_q" = { range = [-1e308, 1e308, 1e300] }', "range"),
])
def test_sweep_axes_with_huge_values_are_exit_2(tmp_path, capsys, axes, field):
    f = sweep_file(tmp_path / "s.toml", axes=axes)
    one_line_exit_2(capsys, "sweep", str(f), "--quiet", "--out", str(tmp_path / "o"), words=(field,))


@pytest.mark.parametrize("address", ["not-an-address", "tcp://127.0.0.1", "tcp://host:99999", "tcp://:8786 x"])
def test_dask_address_without_a_port_is_exit_2_at_once(tmp_path, capsys, address):
    f = sweep_file(tmp_path / "s.toml")
    t0 = time.monotonic()
    one_line_exit_2(capsys, "sweep", str(f), "--quiet", "--dask", address, "--out", str(tmp_path / "o"), words=("--dask",))
    assert time.monotonic() - t0 < 5
    assert not (tmp_path / "o").exists()


# --- 20: a long axis starts quickly, an absurd one is refused --------------------------

def test_a_long_axis_is_checked_at_a_bounded_spread_and_a_huge_one_refused(tmp_path, capsys, monkeypatch):
    import fullspeed.workflows.sweep
    from fullspeed.workflows.sweep import CHECKED_VALUES, MAX_POINTS, load_sweep_file

    calls = []
    real = fullspeed.workflows.sweep.scenario_from_dict

    def counted(d, source=None, **kw):   # kw: warn (the checks form no warning)
        calls.append(d["references"]["i_q"])
        return real(d, source, **kw)
    monkeypatch.setattr(fullspeed.workflows.sweep, "scenario_from_dict", counted)
    sw = load_sweep_file(sweep_file(tmp_path / "s.toml", axes='"references.i_q" = { linspace = [0.0, 20.0, 100000] }'))
    assert len(sw.points()) == 100_000
    checked = calls[1:]   # the first is the base
    assert len(checked) <= CHECKED_VALUES + 2 and 0.0 in checked and 20.0 in checked
    f = sweep_file(tmp_path / "s.toml", axes=f'"references.i_q" = {{ linspace = [0.0, 20.0, {MAX_POINTS + 1}] }}')
    one_line_exit_2(capsys, "sweep", str(f), "--quiet", "--out", str(tmp_path / "o"), words=("linspace",))
    f.write_text(f"samples = {MAX_POINTS}\n" + SWEEP.format(name="mc", duration=0.3, extra="", axes='"references.i_q" = [1.0, 2.0]\n'
                                                        '"controller.R_s_scale" = { uniform = [0.8, 1.2] }'))
    one_line_exit_2(capsys, "sweep", str(f), "--quiet", "--out", str(tmp_path / "o"), words=("at most",))


# --- 44, 45: which file a name means ----------------------------------------------

def test_a_folder_named_like_a_catalog_entry_does_not_shadow_it(tmp_path, monkeypatch):
    from fullspeed.workflows.sweep import load_sweep_file

    monkeypatch.chdir(tmp_path)
    (tmp_path / "yang2022-polarity").mkdir()         # an earlier `--out yang2022-polarity`
    (tmp_path / "yang2022-smo-map").mkdir()
    assert load_scenario("yang2022-polarity").source == "scenarios/yang2022-polarity.toml"
    assert load_sweep_file("yang2022-smo-map").name == "yang2022-smo-map"
    (tmp_path / "x").mkdir()                          # not in the catalog: the folder is named in the error
    with pytest.raises(ConfigError, match="is a directory"):
        load_scenario("x")
    (tmp_path / "yang2022-encoder-speedstep").write_text(BASE)   # a file by that name wins
    assert load_scenario("yang2022-encoder-speedstep").name == "bad"


def test_relative_xcomp_is_the_scenario_folder_first(tmp_path, monkeypatch, capsys):
    from importlib import resources

    scn, cwd = tmp_path / "scn", tmp_path / "cwd"
    scn.mkdir(), cwd.mkdir()
    (scn / "t.toml").write_text((resources.files("fullspeed") / "calibration" / "yang2022-xsat.toml").read_text())
    (scn / "s.toml").write_text(HFI + '[injection]\nxcomp = "t.toml"\n')
    (cwd / "t.toml").write_text("this is not TOML")
    monkeypatch.chdir(cwd)
    xc = load_scenario(str(scn / "s.toml")).data["injection"]["xcomp"]
    assert len(xc["i_q"]) == len(xc["delta_deg"]) >= 2
    (cwd / "s.toml").write_text(HFI + '[injection]\nxcomp = "t.toml"\n')   # its own folder is the working one
    err = one_line_exit_2(capsys, "run", "s.toml", "--quiet", words=("injection.xcomp = 't.toml'", "not valid TOML"))
    assert "toml = " not in err


# --- 23, 24, 26: the sweep's files --------------------------------------------------

def _journal_tasks(folder: Path) -> list[int]:
    return [json.loads(line)["task"] for line in (folder / JOURNAL).read_text().splitlines()]


def test_a_torn_results_table_is_read_from_the_journal(tmp_path):
    from fullspeed.workflows.sweep import load_sweep, load_sweep_file, run_sweep

    pytest.importorskip("pyarrow")
    sw = load_sweep_file(sweep_file(tmp_path / "s.toml"))
    run_sweep(sw, tmp_path / "o", workers=1, plot=False)
    whole = load_sweep(tmp_path / "o")
    table = tmp_path / "o" / "results.parquet"
    table.write_bytes(table.read_bytes()[:1626])   # as a kill in an in-place write left it
    torn = load_sweep(tmp_path / "o")
    assert list(torn["point"]) == list(whole["point"]) == list(range(6))
    assert list(torn["est_err_deg.mean"]) == list(whole["est_err_deg.mean"])


def test_hostile_journal_lines_are_rerun_and_a_folder_journal_is_exit_2(tmp_path, capsys):
    out = tmp_path / "o"
    out.mkdir()
    good = {"task": 1, "result": {"x": 1}}
    (out / JOURNAL).write_text("\n".join([
        "[1, 2]", '{"task": 3}', '{"task": 4, "result": "oops"}', '{"task": true, "result": {}}',
        '{"task": 2.0, "result": {}}', "[" * 100_000, "\u0000" * 5, json.dumps(good),
        json.dumps({"task": 3, "result": {"x": 3}})]) + "\n")
    done = read_journal(out / JOURNAL, 6)
    assert done == {1: {"x": 1}, 3: {"x": 3}}   # 0, 2, 4, 5 run again
    shutil.rmtree(out)
    (out / JOURNAL).mkdir(parents=True)
    f = sweep_file(tmp_path / "s.toml")
    one_line_exit_2(capsys, "sweep", str(f), "--quiet", "--out", str(out), words=("journal", "not a regular file"))


def test_an_unreadable_tasks_stamp_does_not_stop_the_resume(tmp_path):
    out = tmp_path / "o"
    tasks = [{"k": k} for k in range(3)]
    assert run_tasks(_double, tasks, out, workers=1) == [{"y": 0}, {"y": 2}, {"y": 4}]
    stamp = (out / TASKS).read_text()
    (out / TASKS).write_text("")   # torn by an older version's in-place write
    assert run_tasks(_double, tasks, out, workers=1) == [{"y": 0}, {"y": 2}, {"y": 4}]
    assert (out / TASKS).read_text() == stamp
    with pytest.raises(ConfigError, match="different sweep"):
        run_tasks(_double, tasks[:2], out, workers=1)


def _double(task: dict) -> dict:
    return {"y": 2 * task["k"]}


def _strace_sweep(cwd: Path, inject: str) -> tuple[subprocess.CompletedProcess, str]:
    trace = cwd / "strace.txt"
    r = subprocess.run(["strace", "-f", "-qq", "-o", str(trace), *inject.split(), *FS, "sweep", "s.toml",
                        "--workers", "1", "--quiet", "--out", "o"],
                       cwd=cwd, capture_output=True, text=True, env=ENV, timeout=300)
    return r, trace.read_text()


RENAMES = "rename,renameat,renameat2"


def _killed_at(trace: str, name: str) -> bool:
    """The last rename strace saw put o/name in place and did not return."""
    last = [line for line in trace.splitlines() if "rename" in line and "(" in line][-1]
    return f'"o/{name}"' in last and "= 0" not in last


@pytest.mark.skipif(shutil.which("strace") is None, reason="strace is not installed")
def test_sigkill_at_the_writes_of_tasks_json_and_the_table_leaves_a_resumable_sweep(tmp_path):
    """The probe's strace kills (cases 23, 24): SIGKILL as tasks.json and
    results.parquet are renamed into place, and at writes while the table
    and figure are written, each followed by a load and a resume."""
    from fullspeed.workflows.sweep import load_sweep

    pytest.importorskip("pyarrow")
    sweep_file(tmp_path / "s.toml", axes='"references.i_q" = [5.0, 15.0]')
    out = tmp_path / "o"
    # the first start writes sweep.json, tasks.json, (the points,) results.parquet, sweep.png, in that order
    r, trace = _strace_sweep(tmp_path, f"-e trace={RENAMES} -e inject={RENAMES}:signal=KILL:when=2")
    assert r.returncode in (-signal.SIGKILL, 137) and _killed_at(trace, "tasks.json"), trace
    assert not (out / TASKS).exists() and not (out / JOURNAL).exists()
    r, trace = _strace_sweep(tmp_path, f"-e trace={RENAMES} -e inject={RENAMES}:signal=KILL:when=3")
    assert r.returncode in (-signal.SIGKILL, 137) and _killed_at(trace, "results.parquet"), trace
    assert sorted(_journal_tasks(out)) == [0, 1] and not (out / "results.parquet").exists()
    assert list(load_sweep(out)["point"]) == [0, 1]   # from the journal
    stamp = (out / TASKS).read_text()
    # resumes killed at writes after the points (sweep.json, the table, the figure)
    for n in (2, 8):
        _strace_sweep(tmp_path, f"-e trace=write -e inject=write:signal=KILL:when={n}")
        assert (out / TASKS).read_text() == stamp   # not rewritten on a resume
        assert list(load_sweep(out)["point"]) == [0, 1]
    r = subprocess.run([*FS, "sweep", "s.toml", "--quiet", "--out", "o"], cwd=tmp_path, capture_output=True, text=True,
                       env=ENV, timeout=300)
    assert r.returncode == 0, r.stderr
    assert sorted(_journal_tasks(out)) == [0, 1]   # nothing ran twice
    assert list(load_sweep(out)["point"]) == [0, 1]


# --- 27, 28, 29: Ctrl-C and dead workers on sweeps -------------------------------

def _default_sigint() -> None:
    """Ctrl-C as a terminal delivers it: a process started with SIGINT
    ignored (the test runner's may be, by then) keeps it ignored across exec,
    and Python then installs no KeyboardInterrupt handler (a blocked one stays
    blocked too)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _start_sweep(tmp_path: Path, workers: int, duration=40.0) -> tuple[subprocess.Popen, Path]:
    # points of about a second and a half of wall time on an idle machine (40 s simulated, traced sparsely):
    # the interrupt must find the sweep in the middle
    f = sweep_file(tmp_path / "s.toml", duration=duration, axes='"references.i_q" = [5.0, 10.0, 15.0, 20.0, 25.0, 30.0]',
                   extra="trace = { decimation = 100 }\n")
    p = subprocess.Popen([*FS, "sweep", str(f), "--workers", str(workers), "--quiet", "--out", str(tmp_path / "o")],
                         start_new_session=True, preexec_fn=_default_sigint, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    return p, tmp_path / "o"


def _group_gone(pgid: int, limit=10.0) -> bool:
    t0 = time.monotonic()
    while time.monotonic() - t0 < limit:
        if subprocess.run(["pgrep", "-g", str(pgid)], capture_output=True).returncode == 1:
            return True
        time.sleep(0.1)
    return False


def _wait_for_lines(journal: Path, n: int, p: subprocess.Popen, limit=120.0) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < limit and p.poll() is None:
        if journal.exists() and len(journal.read_text().splitlines()) >= n:
            return
        time.sleep(0.05)
    raise AssertionError(f"no {n} journal lines within {limit} s")


@pytest.mark.parametrize("workers", [1, 2])
def test_ctrl_c_stops_a_sweep_at_once_keeps_what_finished_and_says_how_to_resume(tmp_path, workers):
    p, out = _start_sweep(tmp_path, workers)
    _wait_for_lines(out / JOURNAL, 1, p)
    time.sleep(0.3)   # into the next point(s)
    before = len((out / JOURNAL).read_text().splitlines())
    os.killpg(p.pid, signal.SIGINT)
    t0 = time.monotonic()
    _, err = p.communicate(timeout=60)
    stopped = time.monotonic() - t0
    assert p.returncode == 130, err
    assert stopped < 5.0, stopped   # a point takes about 1 s; the rest of the sweep about 5
    assert "resume with: fullspeed sweep" in err
    lines = (out / JOURNAL).read_text().splitlines()
    assert len(lines) <= before + workers and len(lines) < 6   # at most the points finishing as it stopped
    assert all(json.loads(line)["result"]["stop_reason"] == "done" for line in lines)   # none journaled as interrupted
    assert _group_gone(p.pid)   # no worker left (the forkserver and resource tracker end as the parent's pipes close)
    r = subprocess.run([*FS, "sweep", str(tmp_path / "s.toml"), "--quiet", "--out", str(out)], capture_output=True,
                       text=True, env=ENV, timeout=300)
    assert r.returncode == 0, r.stderr
    assert sorted(_journal_tasks(out)) == list(range(6))


def test_a_killed_worker_s_points_run_again_with_the_reason_printed(tmp_path):
    psutil = pytest.importorskip("psutil")
    p, out = _start_sweep(tmp_path, 2)
    _wait_for_lines(out / JOURNAL, 1, p)
    parent = psutil.Process(p.pid)
    workers = [c for c in parent.children(recursive=True) if c.ppid() != p.pid]   # the forkserver's children
    assert workers
    os.kill(workers[0].pid, signal.SIGKILL)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 0, err
    assert f"pid {workers[0].pid} by SIGKILL" in err and "run again" in err
    assert sorted(_journal_tasks(out)) == list(range(6))   # every point, once


# --- 32, 33: Dask clusters that go away ----------------------------------------------

def test_dask_with_no_worker_is_an_error_after_the_stated_timeout(tmp_path):
    distributed = pytest.importorskip("distributed")
    from fullspeed.workflows.sweep import load_sweep_file, run_sweep

    sw = load_sweep_file(sweep_file(tmp_path / "s.toml"))
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        t0 = time.monotonic()
        with pytest.raises(EngineError, match="no worker for 2 s"):
            run_sweep(sw, tmp_path / "o", dask=cluster.scheduler_address, plot=False, dask_timeout=2.0)
        assert time.monotonic() - t0 < 20


def test_dask_scheduler_lost_is_one_line_and_exit_1(tmp_path):
    pytest.importorskip("distributed")
    dask = Path(sys.executable).parent / "dask"
    if not dask.exists():
        pytest.skip("no dask command")
    sched = subprocess.Popen([str(dask), "scheduler", "--host", "127.0.0.1", "--port", "0", "--dashboard-address",
                              "127.0.0.1:0", "--scheduler-file", str(tmp_path / "sched.json")],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        t0, address = time.monotonic(), None
        while address is None and time.monotonic() - t0 < 60:
            time.sleep(0.2)
            try:
                address = json.loads((tmp_path / "sched.json").read_text())["address"]
            except (OSError, ValueError, KeyError):
                pass
        f = sweep_file(tmp_path / "s.toml")
        p = subprocess.Popen([*FS, "sweep", str(f), "--dask", address, "--quiet", "--out", str(tmp_path / "o")],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV, start_new_session=True)
        time.sleep(4)   # connected, waiting for a worker
        os.killpg(sched.pid, signal.SIGKILL)
        sched.wait()
        _, err = p.communicate(timeout=120)
    finally:
        if sched.poll() is None:
            os.killpg(sched.pid, signal.SIGKILL)
    assert p.returncode == 1, err
    lines = [line for line in err.strip().splitlines() if not line.startswith("sweep ")]
    assert "Traceback" not in err and len(lines) <= 2, err
    assert "lost the Dask scheduler" in err or "no worker" in err, err
    assert "resume with" in err


# --- 37, 39: the C API ----------------------------------------------------------------

def test_c_entry_points_refuse_null():
    from fullspeed._core import ffi, lib

    NULL = ffi.NULL
    assert lib.fs_pmsm_init(NULL, NULL) == lib.FS_ERR_NULL
    assert lib.fs_pmsm_init(ffi.new("fs_pmsm *"), NULL) == lib.FS_ERR_NULL
    assert lib.fs_pmsm_init(NULL, ffi.new("fs_pmsm_config *")) == lib.FS_ERR_NULL
    assert lib.fs_mag_init(NULL, NULL) == lib.FS_ERR_NULL
    assert lib.fs_mag_init(ffi.new("fs_mag *"), NULL) == lib.FS_ERR_NULL
    assert lib.fs_inverter_check(NULL) == lib.FS_ERR_NULL
    assert lib.fs_grid_check(NULL) == lib.FS_ERR_NULL
    assert lib.fs_sim_create(NULL, NULL, 0) == NULL
    err = ffi.new("char[]", 64)
    assert lib.fs_sim_create(NULL, err, 64) == NULL and b"NULL" in ffi.string(err)
    rows = ffi.new("int *", 7)
    assert lib.fs_sim_run(NULL, 1.0, NULL, 0, rows) == lib.FS_RUN_ERR_NULL
    assert math.isnan(lib.fs_sim_time(NULL)) and math.isnan(lib.fs_sim_stop_time(NULL))
    # a real simulation with no rows pointer, or no trace buffer for its rows
    from fullspeed.sim import Simulation

    sim = Simulation(load_scenario("yang2022-encoder-speedstep"))
    assert lib.fs_sim_run(sim._sim, 0.01, NULL, 10, rows) == lib.FS_RUN_ERR_NULL
    assert lib.fs_sim_run(sim._sim, 0.01, ffi.new("double[]", 10 * lib.FS_CH_N), 10, NULL) == lib.FS_RUN_ERR_NULL
    assert sim.time == 0.0   # nothing ran


def test_xcomp_eval_does_not_read_a_table_its_check_refuses():
    from fullspeed._core import ffi, lib

    c = ffi.new("fs_xcomp_config *")
    for k in range(lib.FS_XCOMP_MAX):
        c.delta[k] = 0.01 * (k + 1)
    c.n, c.i_q0, c.di_q = 1000, 0.0, 1.0
    assert lib.fs_xcomp_check(c) == lib.FS_ERR_PARAM and lib.fs_xcomp_eval(c, 500.0) == 0.0
    for n, di in ((5, 0.0), (5, -1.0), (5, math.nan), (-3, 1.0)):
        c.n, c.di_q = n, di
        assert lib.fs_xcomp_eval(c, 2.5) == 0.0 or c.n < 2   # n < 2: the (zero) polynomial
    c.n, c.di_q = 5, 1.0   # a table it accepts is still interpolated
    assert lib.fs_xcomp_check(c) == lib.FS_OK
    assert lib.fs_xcomp_eval(c, 2.5) == pytest.approx(0.035, abs=1e-6)
    assert lib.fs_xcomp_eval(ffi.NULL, 1.0) == 0.0 and not lib.fs_xcomp_active(ffi.NULL)


# --- 42, 43: Ctrl-C during a run and during its writing ----------------------------

class _InterruptAfterRun:
    """fullspeed.sim's lib with fs_sim_run_cols (what the runner calls)
    raising KeyboardInterrupt as it returns on its n-th call: where a real
    Ctrl-C lands (the C call returns, the interpreter then runs the signal
    handler)."""

    def __init__(self, lib, n):
        self._lib, self._n, self.calls = lib, n, 0

    def __getattr__(self, name):
        return getattr(self._lib, name)

    def fs_sim_run_cols(self, *args):
        rc = self._lib.fs_sim_run_cols(*args)
        self.calls += 1
        if self.calls == self._n:
            raise KeyboardInterrupt
        return rc


def test_ctrl_c_as_a_chunk_returns_keeps_that_chunk(monkeypatch):
    import fullspeed.sim as fsim
    import fullspeed.sim.runner

    sc = load_scenario("yang2022-encoder-speedstep", {"duration": 0.2, "metrics": {"steady": None}})
    proxy = _InterruptAfterRun(fsim.lib, 5)
    monkeypatch.setattr(fullspeed.sim.runner, "lib", proxy)   # the runner's binding of the core
    res = fsim.simulate(sc, chunk=0.02)
    assert res.stop_reason == "interrupted"
    Ts = 1.0 / sc.data["converter"]["f_pwm"] / (2 if sc.data["timing"]["sampling"] == "double" else 1)
    dec = sc.data["trace"]["decimation"]
    assert res.sim_time == pytest.approx(0.1, abs=2 * Ts)   # five chunks of 0.02 s ran in C
    assert res["t"][-1] == pytest.approx(res.sim_time - Ts * dec, abs=1e-9)   # and all five are in the trace
    assert len(res["t"]) == math.ceil(round(res.sim_time / Ts) / dec)


@pytest.mark.parametrize("where", ["npz", "plot"])
def test_ctrl_c_while_writing_leaves_no_torn_file_that_looks_complete(tmp_path, capsys, monkeypatch, where):
    import fullspeed.sim.plots

    out = tmp_path / "o"
    out.mkdir()
    (out / "metrics.json").write_text('{"stop_reason": "done"}')   # an earlier run's
    if where == "npz":
        real = np.savez_compressed

        def torn(f, **arrays):   # 22 of the channels, then Ctrl-C (the probe's case)
            real(f, **dict(list(arrays.items())[:22]))
            raise KeyboardInterrupt
        monkeypatch.setattr(np, "savez_compressed", torn)
    else:
        def interrupted(*a, **k):
            raise KeyboardInterrupt
        monkeypatch.setattr(fullspeed.sim.plots, "plot_run", interrupted)
    rc, err = run_cli(capsys, "run", "yang2022-encoder-speedstep", "--quiet", "--out", str(out))
    assert rc == 130 and "interrupted" in err
    assert not (out / "metrics.json").exists()   # the mark of a complete folder: absent
    names = sorted(p.name for p in out.iterdir())
    assert names == ([] if where == "npz" else ["traces.npz"]), names   # no temporary file left either
    if where == "plot":
        with np.load(out / "traces.npz") as z:
            assert len(z.files) == len(CHANNELS)


def test_a_complete_run_folder_has_metrics_json_written_last(tmp_path, capsys):
    out = tmp_path / "o"
    rc, err = run_cli(capsys, "run", "yang2022-encoder-speedstep", "--quiet", "--out", str(out))
    assert rc == 0, err
    stamps = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    assert sorted(stamps) == ["metrics.json", "run.png", "traces.npz"]
    assert stamps["metrics.json"] >= max(stamps.values())
    assert oct((out / "traces.npz").stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m


# --- 17: the mutation campaign at the Python API ------------------------------------
# Every single-field mutation of every catalog scenario (its machine expanded
# into the scenario, so that the machine's fields are mutated too) ends in a
# ConfigError or a run: load and validate, build the C config, fs_sim_create,
# and 2 ms of simulation.

MUTATIONS = ["x", "", [1.0], {"x": 1}, True, math.nan, math.inf, -math.inf, -1, 0, 10**400, -10**400, 2**63,
             1e308, -1e308, 5e-324, -5e-324, [[1.0, 0.0], [0.0, 1.0]], [[0.0, math.nan]], [[[1.0]]], [], {}]


def _catalog_raw(name: str) -> dict:
    import tomllib
    from importlib import resources

    from fullspeed.model.machines import catalog_data

    d = tomllib.loads((resources.files("fullspeed") / "scenarios" / f"{name}.toml").read_text())
    m = d["machine"]
    if isinstance(m, str):
        d["machine"] = catalog_data(m)
    elif isinstance(m, dict) and "catalog" in m:
        from fullspeed.model.schema import deep_merge
        extra = {k: v for k, v in m.items() if k != "catalog"}
        d["machine"] = deep_merge(catalog_data(m["catalog"]), extra)
    return d


def _paths(d: dict, path=()):
    """Every leaf and every table (a table is replaced whole, or given an unknown key)."""
    for k, v in d.items():
        yield path + (k,)
        if isinstance(v, dict):
            yield from _paths(v, path + (k,))


def _mutated(d: dict, path, value) -> dict:
    import copy

    d = copy.deepcopy(d)
    cur = d
    for k in path[:-1]:
        cur = cur[k]
    if value == "__unknown_key__":
        cur[path[-1]]["bogus_key"] = 1
    else:
        cur[path[-1]] = value
    return d


def campaign_cases() -> list[tuple[str, tuple, object]]:
    from fullspeed.model.scenario import scenario_names

    cases = []
    for name in scenario_names():
        raw = _catalog_raw(name)
        for path in _paths(raw):
            values = list(range(len(MUTATIONS)))
            if isinstance(_mutated(raw, path, None) and _get(raw, path), dict):
                values.append("__unknown_key__")
            cases += [(name, path, v) for v in values]
    return cases


def _get(d, path):
    for k in path:
        d = d[k]
    return d


def run_mutation(name: str, path: tuple, which) -> str:
    """"refused", "ran", or the unexpected exception's one line."""
    from fullspeed.design.scenario import scenario_from_dict
    from fullspeed.sim import Simulation

    value = "__unknown_key__" if which == "__unknown_key__" else MUTATIONS[which]
    data = _mutated(_catalog_raw(name), path, value)
    try:
        sc = scenario_from_dict(data, f"scenarios/{name}.toml")
        sim = Simulation(sc)
        sim.advance(min(sc.duration, 2e-3))
        sim.traces()
    except ConfigError:
        return "refused"
    except Exception as exc:   # noqa: BLE001 - the campaign counts every other exception
        return f"{type(exc).__name__}: {' '.join(str(exc).split())[:160]}"
    return "ran"


def campaign(cases) -> dict:
    counts: dict = {"refused": 0, "ran": 0, "other": []}
    for name, path, which in cases:
        r = run_mutation(name, path, which)
        if r in ("refused", "ran"):
            counts[r] += 1
        else:
            counts["other"].append((name, ".".join(path), which, r))
    return counts


def test_every_single_field_mutation_is_a_config_error_or_a_run():
    """A seeded sample in the suite; FULLSPEED_FULL_CAMPAIGN=1 runs them all
    (python tests/test_reliability_edges.py prints the full counts)."""
    import random

    cases = campaign_cases()
    if not os.environ.get("FULLSPEED_FULL_CAMPAIGN"):
        cases = random.Random(22).sample(cases, 1500)
    counts = campaign(cases)
    assert counts["other"] == [], counts["other"][:10]
    assert counts["refused"] > counts["ran"] > 0   # most mutations are absurd; some are in range and run


if __name__ == "__main__":
    t0 = time.perf_counter()
    all_cases = campaign_cases()
    result = campaign(all_cases)
    print(f"{len(all_cases)} mutations: {result['refused']} ConfigError, {result['ran']} ran, "
          f"{len(result['other'])} other, in {time.perf_counter() - t0:.1f} s")
    for row in result["other"][:40]:
        print("  ", *row)
    if len(sys.argv) > 1:
        Path(sys.argv[1]).write_text(json.dumps(result["other"], indent=1))
