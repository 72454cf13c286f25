"""Reliability, third pass (issue 40): a test for each finding of section 7
of ../shared/reports/reliability-probe-2026-11-28.md, named by its id there
(F1-F4 files, S1-S5 hostile input, H1-H4 hangs and crashes, W1-W9 wrong
exits, C1-C3 cosmetic). A case that hung on main runs under an alarm, so
that it fails instead of hanging the suite.
"""
from __future__ import annotations

import math
import os
import re
import signal
import time
import tomllib

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from fullspeed.cli import main
from fullspeed.design.scenario import load_scenario, scenario_from_dict
from fullspeed.model import fluxmap
from fullspeed.model.errors import ConfigError
from fullspeed.sim import Simulation, simulate
from fullspeed.sim.metrics import step_metrics

from reliability_helpers import fake_identification, within

BASE = ('name = "bad"\nduration = 0.05\nmachine = "yang2022"\n[controller]\nmode = "current"\nangle = "encoder"\n'
        '[references]\ni_q = 5.0\n[load]\nkind = "speed_pi"\nspeed_rpm = 400.0\n')
BASE_DATA = tomllib.loads(BASE)


def one_line_exit_2(capsys, *argv, words=()) -> str:
    rc = main(list(argv))
    err = capsys.readouterr().err
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("fullspeed: warning: ")]
    assert rc == 2 and len(lines) == 1 and lines[0].startswith("fullspeed: error: "), (rc, err)
    for w in words:
        assert w in err, err
    return err


# --- H1: every duration ends, the C runner and the Python loop count the same periods ------

def test_h1_a_duration_with_a_remainder_under_half_a_period_ends(tmp_path, capsys):
    f = tmp_path / "d.toml"
    f.write_text(BASE.replace("duration = 0.05", "duration = 0.05005"))   # 500.5 periods of 0.1 ms
    with within(60, "run of 0.05005 s"):
        rc = main(["run", str(f), "--out", str(tmp_path / "o"), "--quiet"])
    assert rc == 0, capsys.readouterr().err
    res_t = np.load(tmp_path / "o" / "traces.npz")["t"]
    assert res_t[-1] == pytest.approx(0.0500 - 1e-4)   # periods 0..499: 500, the nearest whole number
    with within(60, "--set duration=0.00015"):
        rc = main(["run", str(f), "--out", str(tmp_path / "o2"), "--quiet", "--set", "duration=0.00015"])
    assert rc == 0, capsys.readouterr().err


def test_h1_a_duration_shorter_than_one_period_is_refused(tmp_path, capsys):
    f = tmp_path / "d.toml"
    f.write_text(BASE.replace("duration = 0.05", "duration = 1e-5"))
    with within(60, "run of 1e-5 s"):
        one_line_exit_2(capsys, "run", str(f), "--out", str(tmp_path / "o"), "--quiet", words=("duration", "control period"))
    assert not (tmp_path / "o").exists()


@settings(max_examples=100, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(periods=st.integers(1, 300), frac=st.one_of(st.floats(0.0, 1.0, exclude_max=True),
                                                   st.sampled_from([0.0, 1e-9, 0.5, 0.5 - 1e-9, 0.5 + 1e-9, 1 - 1e-9])),
       f_pwm=st.one_of(st.sampled_from([8e3, 10e3, 16e3, 20e3]), st.floats(5e3, 40e3)),
       double=st.booleans(), decimation=st.integers(1, 7), chunk=st.one_of(st.none(), st.floats(1e-6, 0.02)))
def test_h1_steps_are_counted_once_by_one_rule(periods, frac, f_pwm, double, decimation, chunk):
    """Random durations (any remainder), control periods and decimations: the
    run ends, after n = ceil(T / Tc - 1/2) periods (|n Tc - T| <= Tc / 2) in
    simulate, in Simulation.advance and in fs_sim_run alike, with one traced
    row every decimation periods."""
    Tc = (0.5 if double else 1.0) / f_pwm
    T = (periods + frac) * Tc
    d = {**BASE_DATA, "duration": T, "converter": {"f_pwm": f_pwm, "inverter": "averaged"},
         "timing": {"sampling": "double" if double else "single"}, "trace": {"decimation": decimation}}
    try:
        sc = scenario_from_dict(d)
    except ConfigError:
        assume(False)
    n = max(0, math.ceil(T / Tc - 0.5))
    with within(30, f"simulate T = {T!r} at Tc = {Tc!r}"):
        res = simulate(sc, chunk=chunk)
        sim = Simulation(sc)
        assert sim.steps(T) == n and sim.advance(T) == "running" and sim.step_count == n
    assert res.stop_reason == "done"
    assert res.sim_time == pytest.approx(n * Tc, rel=1e-12) and abs(res.sim_time - T) <= 0.5 * Tc * (1 + 1e-9)
    assert len(res["t"]) == -(-n // decimation) == len(sim.traces()["t"])


# --- H2: step metrics linear in a profile's changes ------------------------------------

def test_h2_step_metrics_of_a_profile_of_400000_changes_end():
    """The report's profile of tiny steps (each a change of i_q), 4e5 of
    them in 0.05 s: every change's window found by bisection, not by a scan
    of all the others (minutes on main; seconds here)."""
    res = simulate(load_scenario(str(_base_file())))
    n = 400_000
    ts = [k * 0.05 / n for k in range(n)]
    ys = [5.0 + (k % 7) * 0.1 for k in range(n)]
    res.scenario.data["references"]["i_q"] = (ts, ys)
    with within(120, f"step metrics of {n} changes"):
        steps = step_metrics(res)
    # the changes: a rise 5.0 -> 5.6 in six pieces (one change), then a drop to 5.0, each before the run's end
    t_end = float(res["t"][-1])
    starts = [ts[k] for k in range(n - 1) if ys[k] in (5.0, 5.6) and ts[k] < t_end]
    assert [s["t"] for s in steps] == starts
    assert steps[0]["from"] == 5.0 and steps[0]["to"] == pytest.approx(5.6) and steps[1]["to"] == 5.0


def _base_file():
    import tempfile
    from pathlib import Path
    p = Path(tempfile.mkdtemp(prefix="fs-third-")) / "base.toml"
    p.write_text(BASE)
    return p


# --- S4, W2, W3, S3, C3: flux-map files ---------------------------------------------------

GRID_CSV = "0,0,1,1\n1,0,2,1\n0,1,1,2\n1,1,2,2\n"


def test_s4_a_header_of_20000_spaces_is_read_at_once(tmp_path):
    f = tmp_path / "map.csv"
    f.write_text("i_d " + " " * 20000 + "[A],i_q [A],psi_d [mWb],psi_q [mWb]\n" + GRID_CSV)
    with within(20, "a header with 20,000 spaces"):
        cols = fluxmap.read_csv(f, "magnetic.file")
    assert sorted(cols) == ["i_d", "i_q", "psi_d", "psi_q"] and cols["psi_d"][1] == pytest.approx(2e-3)
    f.write_text("i_d" + " " * 20000 + "[A,i_q [A],psi_d [mWb],psi_q [mWb]\n" + GRID_CSV)   # no closing bracket
    with within(20, "an unclosed bracket after 20,000 spaces"), pytest.raises(ConfigError, match="no column i_d"):
        fluxmap.read_csv(f, "magnetic.file")


@pytest.mark.parametrize("header,col,factor", [
    ("psi_d [mWb]", "psi_d", 1e-3), (" Psi D ( Wb ) ", "psi_d", 1.0), ("id[kA]", "i_d", 1e3), ("T (N m)", "torque", 1.0),
    ("x [A]", "", 0.0), ("i_d [A] extra", "", 0.0), ("i_d [A)]", "", 0.0), ("(A)", "", 0.0), ("", "", 0.0),
])
def test_s4_the_header_parser_reads_what_the_regular_expression_did(header, col, factor):
    assert fluxmap._header(header, "f", None) == (col, factor)


def test_w2_a_csv_field_over_the_csv_limit_is_one_line(tmp_path, capsys):
    f = tmp_path / "map.csv"
    f.write_text("i_d [A],i_q [A],psi_d [mWb],psi_q [mWb]\n1" + "0" * 200_000 + ",0,1,1\n" + GRID_CSV)
    with pytest.raises(ConfigError, match="field larger than field limit") as e:
        fluxmap.read_csv(f, "magnetic.file")
    assert "\n" not in str(e.value)


def test_c3_a_utf8_byte_order_mark_is_read_and_a_folder_or_fifo_is_named_so(tmp_path):
    f = tmp_path / "map.csv"
    f.write_text("\ufeffi_d [A],i_q [A],psi_d [mWb],psi_q [mWb]\n" + GRID_CSV, encoding="utf-8")
    assert fluxmap.read_csv(f, "magnetic.file")["i_d"].tolist() == [0.0, 1.0, 0.0, 1.0]
    (tmp_path / "d.csv").mkdir()
    with pytest.raises(ConfigError, match="is a folder"):
        fluxmap.load_map(tmp_path / "d.csv", "magnetic.file")
    import os
    os.mkfifo(tmp_path / "p.csv")
    with pytest.raises(ConfigError, match="not a regular file"):
        fluxmap.load_map(tmp_path / "p.csv", "magnetic.file")


def _syre(i_sat=30.0):
    """A small SyR-e map (magnet on -q): Id, Iq, Fd, Fq, T as full matrices."""
    i_d, i_q = np.meshgrid([-45.0, -20.0, 0.0, 25.0], [0.0, 15.0, 45.0], indexing="ij")
    pd, pq = 0.0105 + 0.3e-3 * i_d, 0.55e-3 * i_sat * np.tanh(i_q / i_sat)
    return {"Id": i_q, "Iq": -i_d, "Fd": pq, "Fq": -pd, "T": 6.0 * (pd * i_q - pq * i_d)}


def test_s3_a_mat_file_s_other_variables_are_never_decompressed(tmp_path):
    """The report's bomb, smaller: a valid map beside a compressed 3000 x
    3000 array of zeros (72 MB unpacked) that the map does not use."""
    sio = pytest.importorskip("scipy.io")
    import tracemalloc

    f = tmp_path / "map.mat"
    sio.savemat(f, {**_syre(), "J0": np.zeros((3000, 3000))}, do_compression=True)
    tracemalloc.start()
    try:
        cols = fluxmap.read_mat(f, "magnetic.file")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert cols["i_d"].size == 12
    assert peak < 8e6, f"{peak / 1e6:.0f} MB to read a map of 12 points"


def test_s3_the_variables_a_map_is_read_from_are_bounded_once_decompressed(tmp_path, monkeypatch):
    sio = pytest.importorskip("scipy.io")
    f = tmp_path / "map.mat"
    sio.savemat(f, {"motorModel": {"FluxMap_dq": _syre(), "junk": np.zeros((1000, 1000))}}, do_compression=True)
    assert fluxmap.read_mat(f, "magnetic.file")["i_d"].size == 12   # 8 MB: within the 256 MiB
    monkeypatch.setattr(fluxmap, "MAX_MAT_UNPACKED", 2**20, raising=False)
    with pytest.raises(ConfigError, match="MiB of data once decompressed"):
        fluxmap.read_mat(f, "magnetic.file")


@pytest.mark.parametrize("what,data,words", [
    ("Fd of another shape", lambda m: {**m, "Fd": m["Fd"][:-1, :]}, "as many values"),
    ("T of another shape", lambda m: {**m, "T": m["T"][:, :1]}, "as many values"),
    ("FluxMap_dq a number", lambda m: {"motorModel": {"FluxMap_dq": 5.0}}, "without FluxMap_dq"),
    ("NaN torque", lambda m: {**m, "T": m["T"] * np.nan}, "finite"),
    ("complex flux", lambda m: {**m, "Fd": m["Fd"] + 1j}, "real matrix"),
    ("a cell of text", lambda m: {**m, "Fq": np.array([["a", "b"]], dtype=object)}, "real matrix"),
])
def test_w3_c3_mat_maps_of_wrong_shapes_and_types_are_one_line(tmp_path, what, data, words):
    sio = pytest.importorskip("scipy.io")
    f = tmp_path / "map.mat"
    sio.savemat(f, data(_syre()))
    with pytest.raises(ConfigError, match=words) as e:
        fluxmap.load_map(f, "magnetic.file")
    assert "\n" not in str(e.value)


# --- F1: outputs that are only files ------------------------------------------------------

def _nodes(tmp_path):
    """A FIFO, a socket and a folder at output paths (and a device node, as root)."""
    import os
    import socket

    nodes = {"fifo": tmp_path / "fifo.toml", "socket": tmp_path / "sock.toml", "folder": tmp_path / "dir.toml"}
    os.mkfifo(nodes["fifo"])
    s = socket.socket(socket.AF_UNIX)
    s.bind(str(nodes["socket"]))
    nodes["folder"].mkdir()
    if os.geteuid() == 0:
        nodes["device"] = tmp_path / "null.toml"
        os.mknod(nodes["device"], 0o666 | 0o020000, os.makedev(1, 3))   # a character device: /dev/null's numbers
    return nodes, s


def _kind(path) -> str:
    import os
    import stat

    m = os.lstat(path).st_mode
    return next(k for k, f in (("fifo", stat.S_ISFIFO), ("socket", stat.S_ISSOCK), ("folder", stat.S_ISDIR),
                               ("device", stat.S_ISCHR), ("file", stat.S_ISREG)) if f(m))


def test_f1_new_machine_and_calibrate_refuse_what_is_not_a_file_and_leave_it(tmp_path, capsys, monkeypatch):
    import fullspeed.workflows.calibrate as calibrate

    nodes, sock = _nodes(tmp_path)
    monkeypatch.setattr(calibrate, "xsat_table", lambda *a, **k: pytest.fail("calibrated before the refusal"))
    try:
        for kind, path in nodes.items():
            one_line_exit_2(capsys, "new-machine", "x", "--out", str(path), "--force", words=("--out",))
            one_line_exit_2(capsys, "calibrate", "beyond-xcomp-3ph", "--out", str(path), words=("--out",))
            assert _kind(path) == kind
    finally:
        sock.close()


def test_f1_every_writer_refuses_to_replace_what_is_not_a_file(tmp_path):
    from fullspeed.model import files

    nodes, sock = _nodes(tmp_path)
    try:
        for kind, path in nodes.items():
            for write in (lambda p: files.write_atomic(p, "x"), lambda p: files.write_json(p, {}),
                          lambda p: files.write_npz(p, {"a": np.zeros(2)})):
                with pytest.raises(ConfigError, match="not a regular file|is a folder"):
                    write(path)
                assert _kind(path) == kind
        link = tmp_path / "link.toml"   # a symbolic link is replaced itself, not what it points to
        link.symlink_to(nodes["fifo"])
        files.write_atomic(link, "x")
        assert _kind(link) == "file" and _kind(nodes["fifo"]) == "fifo"
    finally:
        sock.close()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], "a temporary file was left"


# --- F2: a run's folder is claimed for one run --------------------------------------------

def test_f2_a_second_run_into_a_folder_in_use_is_refused_and_the_first_completes(tmp_path, capsys):
    import json
    import os
    import subprocess
    import sys

    long = tmp_path / "long.toml"
    long.write_text(BASE.replace("duration = 0.05", "duration = 60.0").replace(
        "i_q = 5.0", "i_q = 5.0\n[trace]\ndecimation = 100\n[converter]\ninverter = \"averaged\""))
    short = tmp_path / "short.toml"
    short.write_text(BASE.replace("i_q = 5.0", "i_q = 15.0"))
    shared = tmp_path / "shared"
    a = subprocess.Popen([sys.executable, "-m", "fullspeed", "run", str(long), "--out", str(shared), "--quiet"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                         env={**os.environ, "PYTHONWARNINGS": "ignore"})
    try:
        t0 = time.monotonic()
        while not shared.exists() and a.poll() is None and time.monotonic() - t0 < 60:
            time.sleep(0.05)
        assert shared.exists() and a.poll() is None, "the long run did not claim its folder while it ran"
        one_line_exit_2(capsys, "run", str(short), "--out", str(shared), "--quiet", words=("in use by another",))
        assert a.wait(timeout=120) == 0, a.stderr.read()
    finally:
        a.kill()
    m = json.loads((shared / "metrics.json").read_text())
    assert m["sim_time"] == pytest.approx(60.0) and sorted(p.name for p in shared.iterdir()) == [
        "metrics.json", "run.png", "traces.npz"]
    assert np.load(shared / "traces.npz")["t"][-1] == pytest.approx(60.0 - 100 * 1e-4)   # the long run's, not the short


def test_f2_a_refused_run_leaves_no_folder_and_a_finished_one_leaves_it_free(tmp_path, capsys):
    out = tmp_path / "a" / "b"   # refused by fs_drive_init, after the claim: the folders made for it go again
    one_line_exit_2(capsys, "run", "zou2021-region-b", "--out", str(out), "--quiet", "--set", "controller.fw_gain=7591",
                    words=("controller.fw_cutoff",))
    assert not (tmp_path / "a").exists()
    good = tmp_path / "good.toml"
    good.write_text(BASE)
    assert main(["run", str(good), "--out", str(out), "--quiet"]) == 0
    assert main(["run", str(good), "--out", str(out), "--quiet"]) == 0   # the claim ended with the first


# --- F3, S2, W5, C1, C4: identify's folder ----------------------------------------------------

def _fake_identify(ok: bool):
    return lambda sc, **kw: fake_identification(sc, ok)


def test_f3_a_failed_identification_leaves_no_earlier_machine_file(tmp_path, capsys, monkeypatch):
    import fullspeed.workflows.identify as idf

    out = tmp_path / "id"
    monkeypatch.setattr(idf, "identify", _fake_identify(True))
    assert main(["identify", "yang2022-encoder-speedstep", "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["identification.toml", "machine.toml"]
    monkeypatch.setattr(idf, "identify", _fake_identify(False))
    assert main(["identify", "yang2022-encoder-speedstep", "--out", str(out)]) == 1
    assert sorted(p.name for p in out.iterdir()) == ["identification.toml"], "an earlier identification's machine.toml"
    assert tomllib.loads((out / "identification.toml").read_text())["ended_in"] == "failed"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert oct((out / "identification.toml").stat().st_mode & 0o777) != "0o600"   # C4: as every output


def test_f3_an_identification_cut_short_while_writing_leaves_the_earlier_pair(tmp_path, capsys, monkeypatch):
    import fullspeed.model.files as files
    import fullspeed.workflows.identify as idf

    out = tmp_path / "id"
    monkeypatch.setattr(idf, "identify", _fake_identify(True))
    assert main(["identify", "yang2022-encoder-speedstep", "--out", str(out)]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    real, calls = files.write_atomic, []

    def killed(path, data):   # the second file's write never ends (a kill, Ctrl-C)
        calls.append(path)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(path, data)
    monkeypatch.setattr(files, "write_atomic", killed)
    monkeypatch.setattr(idf, "identify", _fake_identify(True))
    # another identification's machine file, one the loader takes (identify loads it back before writing)
    monkeypatch.setattr(idf, "_machine_toml", lambda tab, real=idf._machine_toml: "# another identification\n" + real(tab))
    assert main(["identify", "yang2022-encoder-speedstep", "--out", str(out)]) == 130
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], "the half-written folder was left"


def test_f3_identify_does_not_replace_a_folder_of_other_files(tmp_path, capsys, monkeypatch):
    import fullspeed.workflows.identify as idf

    monkeypatch.setattr(idf, "identify", lambda *a, **k: pytest.fail("identified before the refusal"))
    (tmp_path / "notes.txt").write_text("mine")
    one_line_exit_2(capsys, "identify", "yang2022-encoder-speedstep", "--out", str(tmp_path), words=("notes.txt",))
    assert (tmp_path / "notes.txt").read_text() == "mine"


@pytest.mark.parametrize("name,words", [
    ("x/../../../id_escaped", "path separator"), ("x\u0000y", "control character"), ("m" * 4000, "bytes long")])
def test_s2_w5_identify_s_default_folder_keeps_the_machine_name_inside_out(tmp_path, capsys, monkeypatch, name, words):
    import json

    import fullspeed.workflows.identify as idf

    monkeypatch.setattr(idf, "identify", lambda *a, **k: pytest.fail("identified before the refusal"))
    work = tmp_path / "a" / "b" / "c"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    text = BASE.replace('machine = "yang2022"', f"machine = {{ catalog = \"yang2022\", name = {json.dumps(name)} }}")
    (work / "s.toml").write_text(text.replace('kind = "speed_pi"\nspeed_rpm = 400.0', 'kind = "torque"\ntorque = 0.0'))
    one_line_exit_2(capsys, "identify", "s.toml", words=("machine.name", words))
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["a", "b", "c", "s.toml"]


def test_c1_names_with_del_or_beyond_the_bmp_give_toml_that_reads_back(tmp_path, monkeypatch, capsys):
    import fullspeed.workflows.identify as idf
    from fullspeed.workflows.calibrate import write_table

    for name in ("cal\u007fdel", "id-\U0001F680", 'q"uote\\back\nline'):
        write_table({"source": name, "i_q": [0.0, 1.0], "delta_deg": [0.0, 1.0]}, tmp_path / "x.toml")
        assert tomllib.loads((tmp_path / "x.toml").read_text())["xcomp"]["source"] == name
    monkeypatch.setattr(idf, "identify", _fake_identify(True))
    f = tmp_path / "s.toml"
    f.write_text(BASE.replace('machine = "yang2022"', 'machine = { catalog = "yang2022", name = "id-\U0001F680" }')
                 .replace('kind = "speed_pi"\nspeed_rpm = 400.0', 'kind = "torque"\ntorque = 0.0'))
    assert main(["identify", str(f), "--out", str(tmp_path / "id")]) == 0
    assert tomllib.loads((tmp_path / "id" / "identification.toml").read_text())["machine"] == "id-\U0001F680"
    assert tomllib.loads((tmp_path / "id" / "machine.toml").read_text())["name"] == "id-\U0001F680-identified"


def test_c2_new_machine_s_name_cannot_add_keys_to_the_template(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    name = 'evil" R_s = 5 #'
    assert main(["new-machine", name]) == 0
    (f,) = tmp_path.glob("*.toml")
    d = tomllib.loads(f.read_text())
    assert d["name"] == name and d["electrical"]["R_s"] == "?" and "R_s" not in d
    # one with a line break is refused as a name holding a control character (run's, sweep's)
    one_line_exit_2(capsys, "new-machine", 'evil"\nR_s = 5 #', words=("control character",))
    assert len(list(tmp_path.glob("*.toml"))) == 1


# --- W4: new-machine's names and folders --------------------------------------------------

def test_w4_new_machine_s_bad_outputs_are_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "exists.toml").write_text("")
    (tmp_path / "adir").mkdir()
    one_line_exit_2(capsys, "new-machine", "n" * 300, words=("name", "bytes"))
    one_line_exit_2(capsys, "new-machine", "x", "--out", "adir", "--force", words=("is a folder",))
    one_line_exit_2(capsys, "new-machine", "x", "--out", "exists.toml/m.toml", words=("exists.toml",))
    one_line_exit_2(capsys, "new-machine", "x", "--out", "/proc/self/x.toml", words=("cannot be written",))
    one_line_exit_2(capsys, "new-machine", "x", "--out", "exists.toml", words=("--force",))
    assert main(["new-machine", "x", "--out", "exists.toml", "--force"]) == 0
    assert tomllib.loads((tmp_path / "exists.toml").read_text())["name"] == "x"


@pytest.mark.parametrize("name, stem", [("mach/motor", "motor"), ("/tmp/x/abs", "abs"), ("..", None)])
def test_new_machine_refuses_a_name_that_is_a_path_and_points_at_out(tmp_path, capsys, monkeypatch, name, stem):
    # was exit 0: ./mach_motor.toml, ./_tmp_x_abs.toml with name = "/tmp/x/abs", no notice
    monkeypatch.chdir(tmp_path)
    err = one_line_exit_2(capsys, "new-machine", name, words=(f"name = {name!r}", "one file name", "--out"))
    if stem:
        assert f"fullspeed new-machine {stem} --out {name}.toml" in err
    assert not list(tmp_path.iterdir())


def test_new_machine_s_existing_file_names_it_and_force_not_an_out_never_given(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["new-machine", "servo400"]) == 0
    err = one_line_exit_2(capsys, "new-machine", "servo400", words=("name = 'servo400'", "servo400.toml exists", "--force"))
    assert "--out" not in err   # was "--out = 'servo400.toml': exists; --force to overwrite"
    one_line_exit_2(capsys, "new-machine", "servo400", "--out", "servo400.toml", words=("--out = 'servo400.toml'",))


# --- W1: --set within the limits of a file --------------------------------------------------

@pytest.mark.parametrize("command", ["run", "design", "export", "sweep"])
@pytest.mark.parametrize("value,words", [("9" * 5000, "digit"), ("[" * 3000 + "]" * 3000, "nested")])
def test_w1_set_values_beyond_the_parser_s_limits_are_one_line(tmp_path, capsys, command, value, words):
    target = {"run": "yang2022-encoder-speedstep", "design": "yang2022", "export": "yang2022-encoder-speedstep",
              "sweep": "yang2022-smo-map"}[command]
    extra = ["--out", str(tmp_path / "o")] if command != "design" else []
    one_line_exit_2(capsys, command, target, *extra, "--set", f"controller.bw_speed={value}", words=("--set", words))
    assert not (tmp_path / "o").exists()


# --- S1, W7, W8, F3: export ----------------------------------------------------------------

HOSTILE = [
    "demo */\n#ifndef PWN_ONCE\n#define PWN_ONCE\nint pwned_by_scenario_name(void) { return 1337; }\n#endif\n/* end",
    "a */ int pwned_inline = 1; /*", "x *\\\n/ int pwned_spliced = 2; /*", "t ??/\n*/ int pwned_trigraph = 3; /*",
    "*/\n#include \"/etc/hostname\"\n/*", "bidi \u202e*/ int pwned_bidi; /*\u202c", "nul \u0000 del \u007f */",
]


def _compile(folder, name="fs_config"):
    import shutil
    import subprocess
    from pathlib import Path

    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no host C compiler")
    control = Path(__file__).resolve().parents[1] / "csrc" / "control"
    obj = folder / f"{name}.o"
    r = subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-Werror", f"-I{control}", f"-I{folder}", "-c",
                        str(folder / f"{name}.c"), "-o", str(obj)], capture_output=True, text=True)
    if r.returncode:
        return r.stderr, None
    nm = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout
    return r.stderr, sorted(ln.split()[-2:] for ln in nm.splitlines() if ln.strip())


def _directives(text: str) -> list[str]:
    """The preprocessor lines of C text, without the export id (a hash of the text)."""
    return sorted(re.sub(r"0x[0-9a-f]{8}u", "ID", ln) for ln in text.splitlines() if ln.lstrip().startswith("#"))


@pytest.mark.parametrize("where", ["name", "machine", "folder", "set"])
def test_s1_hostile_names_and_paths_stay_comments_in_the_export(tmp_path, capsys, where):
    """Each hostile text as the scenario's name, the machine's, a folder of
    the scenario's path or a --set name: the export compiles (-Wall
    -Wextra -Werror, C99 with its trigraphs) to one object holding the one
    constant and nothing else."""
    import json

    (tmp_path / "clean.toml").write_text(BASE)
    assert main(["export", str(tmp_path / "clean.toml"), "--out", str(tmp_path / "clean")]) == 0
    clean = _directives((tmp_path / "clean" / "fs_config.c").read_text() + (tmp_path / "clean" / "fs_config.h").read_text())
    for k, text in enumerate(HOSTILE):
        folder = tmp_path / f"{where}{k}"
        folder.mkdir()
        scen = BASE
        argv = []
        if where == "name":
            scen = BASE.replace('name = "bad"', f"name = {json.dumps(text)}")
        elif where == "machine":
            scen = BASE.replace('machine = "yang2022"', f'machine = {{ catalog = "yang2022", name = {json.dumps(text)} }}')
        elif where == "set":
            argv = ["--set", f"name={json.dumps(text)}"]
        src = folder / "s.toml"
        if where == "folder":
            if "\u0000" in text:
                continue   # no file system takes a NUL
            src = folder / text.replace("/", "_slash_")[:80] / "s.toml"
            src.parent.mkdir()
        src.write_text(scen)
        out = folder / "x"
        assert main(["export", str(src), "--out", str(out), *argv]) == 0, capsys.readouterr().err
        text_c = (out / "fs_config.c").read_text() + (out / "fs_config.h").read_text()
        assert text_c.isascii() and _directives(text_c) == clean, f"{text!r} added a line to the preprocessor"
        err, symbols = _compile(out)
        assert symbols == [["R", "fs_config"]], (err, symbols)


@pytest.mark.parametrize("name", ["int", "return", "struct", "_Bool", "_Static_assert", "NULL", "NAN", "INFINITY",
                                  "main", "size_t", "fs_drive", "fs_drive_config", "fs_drive_init", "FS_OK", "fs_types",
                                  "stddef", "FS_DRIVE", "Fs_Drive", "math", "y1", "uint8_t", "_cfg", "FS_TYPES_H",
                                  "sqrtf", "FP_ZERO", "bool"])
def test_w8_export_refuses_a_name_that_cannot_be_the_constant_s(tmp_path, capsys, name):
    one_line_exit_2(capsys, "export", "yang2022-hfi-iqstep", "--out", str(tmp_path / "o"), "--name", name, words=("--name",))
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("name", ["fs_config", "bench_cfg", "drive_2", "Cfg", "my_fs_drive_config"])
def test_w8_ordinary_names_export_and_compile_to_their_one_symbol(tmp_path, name):
    assert main(["export", "yang2022-hfi-iqstep", "--out", str(tmp_path), "--name", name]) == 0
    err, symbols = _compile(tmp_path, name)
    assert symbols == [["R", name]], err


@pytest.mark.parametrize("scenario,setting,field", [
    ("zou2021-region-b", "controller.fw_gain=7591", "controller.fw_cutoff"),
    ("bench-motulator-2kw-blend", "controller.L_d_scale=3", "controller.L_q")])
def test_w7_export_refuses_what_fs_drive_init_refuses_in_run_s_words(tmp_path, capsys, scenario, setting, field):
    err = one_line_exit_2(capsys, "export", scenario, "--out", str(tmp_path / "x"), "--set", setting, words=(field,))
    assert not (tmp_path / "x").exists()
    err_run = one_line_exit_2(capsys, "run", scenario, "--out", str(tmp_path / "r"), "--set", setting, "--quiet")
    assert err == err_run


def test_f3_a_header_and_source_of_different_exports_do_not_compile(tmp_path, monkeypatch):
    import shutil

    import fullspeed.workflows.export as ex

    a, b = tmp_path / "a", tmp_path / "b"
    assert main(["export", "yang2022-encoder-speedstep", "--out", str(a)]) == 0
    assert main(["export", "yang2022-hfi-iqstep", "--out", str(b)]) == 0
    assert _compile(a)[1] == [["R", "fs_config"]]
    shutil.copy(b / "fs_config.h", a / "fs_config.h")   # the header of one, the source of the other
    err, symbols = _compile(a)
    assert symbols is None and "fs_config.h is not the header exported with fs_config.c" in err
    # a kill between the two renames: the new header beside the old source
    calls = []
    real = ex.write_atomic

    def killed(path, text):
        calls.append(path)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(path, text)
    monkeypatch.setattr(ex, "write_atomic", killed)
    with pytest.raises(KeyboardInterrupt):
        ex.export("yang2022-smo-ramp", b, "fs_config")
    err, symbols = _compile(b)
    assert symbols is None and "is not the header exported with" in err


# --- W9, F4: journal lines of wrong types --------------------------------------------------

def test_w9_f4_journal_results_of_wrong_types_or_empty_are_run_again(tmp_path, capsys):
    import json

    from fullspeed.workflows.journal import JOURNAL

    sweep = tmp_path / "s.toml"
    sweep.write_text('name = "t-third"\nbase = "yang2022-encoder-speedstep"\nmetrics = ["T_e_mean"]\n'
                     '[overrides]\nduration = 0.02\nmetrics = { steady = [0.01, 0.02] }\n'
                     '[axes]\n"references.speed_rpm" = [100.0, 200.0, 300.0]\n')
    out = tmp_path / "o"
    assert main(["sweep", str(sweep), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    lines = [json.loads(x) for x in (out / JOURNAL).read_text().splitlines()]
    good = {r["task"]: r["result"] for r in lines}
    bad = [{"task": 0, "result": {}}, {"task": 1, "result": dict(good[1], stop_reason=7)},
           {"task": 2, "result": dict(good[2], T_e_mean="x")}]
    (out / JOURNAL).write_text("".join(json.dumps(r) + "\n" for r in bad))
    capsys.readouterr()
    assert main(["sweep", str(sweep), "--out", str(out), "--workers", "1", "--quiet"]) == 0, capsys.readouterr().err
    assert "3 of 3 points" in capsys.readouterr().out   # all three run again
    import pandas as pd
    from fullspeed.workflows.sweep import load_sweep

    table = load_sweep(out)
    assert list(table["stop_reason"]) == ["done"] * 3 and table["T_e_mean"].notna().all()
    assert pd.api.types.is_float_dtype(table["T_e_mean"])


# --- H3: the last NULL checks -------------------------------------------------------------------

def test_h3_thermal_init_and_fw_design_refuse_null():
    import subprocess
    import sys

    code = ("from fullspeed._core import ffi, lib\n"
            "assert lib.fs_thermal_init(ffi.NULL, ffi.new('fs_thermal_config *')) == lib.FS_ERR_NULL\n"
            "assert lib.fs_thermal_init(ffi.new('fs_thermal *'), ffi.NULL) == lib.FS_ERR_NULL\n"
            "assert lib.fs_thermal_init(ffi.NULL, ffi.NULL) == lib.FS_ERR_NULL\n"
            "lib.fs_fw_design(ffi.NULL, 1000.0, False)\nlib.fs_fw_design(ffi.NULL, 1000.0, True)\nprint('returned')\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)   # a crash is a signal here
    assert r.returncode == 0 and r.stdout.strip() == "returned", (r.returncode, r.stderr[-500:])


# --- H4: a sweep's pool ends with its parent -------------------------------------------------------

def test_h4_kill_9_of_a_sweep_s_parent_ends_its_pool(tmp_path):
    import os
    import subprocess
    import sys

    sweep = tmp_path / "s.toml"
    sweep.write_text('name = "t-pdeath"\nbase = "yang2022-encoder-speedstep"\nmetrics = ["T_e_mean"]\n'
                     '[overrides]\nduration = 2.0\n[axes]\n"references.speed_rpm" = [100.0, 200.0, 300.0, 400.0]\n')
    p = subprocess.Popen([sys.executable, "-m", "fullspeed", "sweep", str(sweep), "--out", str(tmp_path / "o"),
                          "--workers", "2", "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)

    def group() -> list[int]:
        pids = []
        for d in os.listdir("/proc"):
            if d.isdigit():
                try:
                    if os.getpgid(int(d)) == p.pid and int(d) != p.pid:
                        pids.append(int(d))
                except ProcessLookupError:
                    pass
        return pids
    try:
        t0 = time.monotonic()
        while len(group()) < 3 and time.monotonic() - t0 < 60:   # the forkserver, the tracker, the workers
            time.sleep(0.1)
        assert len(group()) >= 3, "the pool did not start"
        os.kill(p.pid, signal.SIGKILL)   # the parent alone, as the OOM killer does
        p.wait()
        t0 = time.monotonic()
        while group() and time.monotonic() - t0 < 20:
            time.sleep(0.1)
        left = group()
        assert not left, f"{len(left)} processes of the pool outlived their parent"
    finally:
        for pid in group():
            os.kill(pid, signal.SIGKILL)


# --- W6: bench/pil.py's options ------------------------------------------------------------

def _pil():
    from pathlib import Path

    from script_loader import load_script
    return load_script(Path(__file__).resolve().parents[1] / "bench" / "pil.py", "bench_pil_third")


@pytest.mark.parametrize("argv,words", [
    (["--loop-duration", "nan"], "--loop-duration"), (["--loop-duration", "-1"], "--loop-duration"),
    (["--duration", "inf"], "--duration"), (["--out", "FILE"], "is a file"), (["--out", "/proc"], "cannot be written"),
    (["--scenario", "BIG"], "trace.decimation")])
def test_w6_pil_options_are_refused_in_one_line_before_anything_is_built(tmp_path, capsys, monkeypatch, argv, words):
    pil = _pil()
    monkeypatch.setattr(pil, "pil_report", lambda *a, **k: pytest.fail("the PIL ran before the refusal"))
    (tmp_path / "file").write_text("")
    big = tmp_path / "big.toml"   # run takes it (decimation 3); the PIL's trace of every sample would be 5 GB
    big.write_text(BASE.replace("duration = 0.05", "duration = 1000.0") + "[trace]\ndecimation = 3\n")
    argv = [{"FILE": str(tmp_path / "file"), "BIG": str(big)}.get(a, a) for a in argv]
    assert pil.main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and words in err and "Traceback" not in err, err


# --- S5, C3: what a map's errors show ---------------------------------------------------------

def test_s5_c3_a_map_s_errors_show_a_bounded_header_and_a_reason(tmp_path):
    sio = pytest.importorskip("scipy.io")
    secret = tmp_path / "secret.txt"
    secret.write_text("root:x:0:0:" + "s" * 500 + "\n" + GRID_CSV)
    (tmp_path / "map.csv").symlink_to(secret)
    with pytest.raises(ConfigError, match="has no column") as e:
        fluxmap.load_map(tmp_path / "map.csv", "magnetic.file")
    assert len(str(e.value)) < 400 and "s" * 200 not in str(e.value)
    f = tmp_path / "map.mat"
    sio.savemat(f, _syre(), do_compression=True)
    f.write_bytes(f.read_bytes()[:300])   # cut short inside a compressed variable
    with pytest.raises(ConfigError) as e:
        fluxmap.load_map(f, "magnetic.file")
    assert not str(e.value).rstrip().endswith(":"), str(e.value)


@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2", "two renames"])
def test_f3_replace_folder_puts_the_new_set_in_place_whole(tmp_path, monkeypatch, exchange):
    from fullspeed.model import files

    if not exchange:   # a system or file system without RENAME_EXCHANGE
        monkeypatch.setattr(files, "_exchange", lambda a, b: False)
    out = tmp_path / "id"
    files.replace_folder(out, {"a.toml": "1", "b.toml": "2"})
    files.replace_folder(out, {"a.toml": "3"}, owned=("b.toml",))
    assert {p.name: p.read_text() for p in out.iterdir()} == {"a.toml": "3"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["id"]
    real = os.rename if not exchange else None

    def cut(a, b):   # the rename that would put the new set in place fails (a full disk, a kill)
        if str(b) == str(out) and str(a).endswith(".new"):
            raise KeyboardInterrupt
        return real(a, b)
    if not exchange:
        monkeypatch.setattr(files.os, "rename", cut)
    else:
        monkeypatch.setattr(files, "_exchange", lambda a, b: (_ for _ in ()).throw(KeyboardInterrupt()))
    with pytest.raises(KeyboardInterrupt):
        files.replace_folder(out, {"a.toml": "4"}, owned=("b.toml",))
    assert {p.name: p.read_text() for p in out.iterdir()} == {"a.toml": "3"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["id"]


# --- C5: bench/pil.py's closed-loop verdict ---------------------------------------------------

def _loop_run(stop_h, stop_t, lock_h=None, lock_t=None):
    side = lambda stop, lock: {"stop_reason": stop, "lock_lost_at": lock, "recoveries": 0, "speed_error_pct": 0.5,  # noqa: E731
                               "theta_err_deg": {"mean": 1.0}, "i_q_error_rms": 0.2}
    return {"host": side(stop_h, lock_h), "target": side(stop_t, lock_t), "stages_host": [1, 3], "stages_target": [1, 3]}


@pytest.mark.parametrize("stop", ["done", "overcurrent", "overspeed"])
def test_c5_the_same_stop_on_host_and_target_is_agreement(stop):
    """The verdict compares the target's run with the host's: both ending in
    the same stop (an identical overcurrent trip included) agree; a stop on one
    side only does not."""
    v = _pil().loop_verdict(_loop_run(stop, stop))
    assert v["checks"]["same stop"] and v["within"], v
    other = "overcurrent" if stop == "done" else "done"
    v = _pil().loop_verdict(_loop_run(stop, other))
    assert not v["checks"]["same stop"] and not v["within"], v


# --- C6: a sweep's random axes and a sweep of nothing but errors --------------------------------

def _sweep_file(tmp_path, axis: str, samples: int = 3):
    (tmp_path / "base.toml").write_text(BASE)
    f = tmp_path / "mc.toml"
    f.write_text(f'name = "mc"\nbase = "base.toml"\nsamples = {samples}\nmetrics = ["T_e_mean"]\n[axes]\n{axis}\n')
    return f


@pytest.mark.parametrize("axis,words", [
    ('"load.speed_rpm" = { normal = [1, 1e307] }', ("axes.load.speed_rpm.normal", "1e+307", "1e+06")),
    ('"load.speed_rpm" = { uniform = [2e6, 3e6] }', ("axes.load.speed_rpm.uniform", "2000000", "1e+06")),
    ('"trace.decimation" = { integers = [-9, 0] }', ("axes.trace.decimation.integers", "-9", "trace.decimation"))])
def test_c6_a_random_axis_none_of_whose_draws_is_valid_is_refused_before_any_point(tmp_path, capsys, axis, words):
    """Draws the schema refuses, every one: one line naming the axis, its
    distribution and what the field allows, exit 2, nothing run or written."""
    f = _sweep_file(tmp_path, axis)
    one_line_exit_2(capsys, "sweep", str(f), "--out", str(tmp_path / "o"), "--workers", "1", "--quiet", words=words)
    assert not (tmp_path / "o").exists()


def test_c6_a_random_axis_with_some_valid_draws_runs_and_its_refused_draws_are_rows(tmp_path, capsys):
    """Draws the schema takes and draws it refuses: the sweep runs, a refused
    draw is its point's error row (a tail of a distribution past a limit)."""
    f = _sweep_file(tmp_path, '"trace.decimation" = { integers = [-2, 3] }', samples=8)
    rc = main(["sweep", str(f), "--out", str(tmp_path / "o"), "--workers", "1", "--quiet"])
    out = capsys.readouterr().out
    assert rc == 0 and "8 of 8 points" in out and "error (ConfigError" in out, out


def test_c6_a_sweep_whose_points_all_end_in_error_does_not_exit_0(tmp_path, capsys, monkeypatch):
    """Every point an error row (here the engine refusing each point): the
    table is written, and the summary and the exit status say no point ran."""
    import fullspeed.workflows.sweep as sweep_mod

    def refuse(sc):
        raise RuntimeError("the core refused the point")
    monkeypatch.setattr(sweep_mod, "simulate", refuse)
    f = _sweep_file(tmp_path, '"load.speed_rpm" = { uniform = [100, 200] }')
    rc = main(["sweep", str(f), "--out", str(tmp_path / "o"), "--workers", "1", "--quiet"])
    cap = capsys.readouterr()
    assert rc == 1, (rc, cap.out, cap.err)
    assert "every point ended in an error" in cap.err, cap.err
    assert (tmp_path / "o" / "results.parquet").exists() or (tmp_path / "o" / "results.csv").exists()


# --- C7: a name matplotlib's font cannot draw; the progress bar's end ------------------------------

def test_c7_a_run_of_a_cjk_name_draws_its_figure_quietly_and_keeps_the_name(tmp_path, capsys):
    """A scenario named in CJK: no glyph warning on stderr (a font that has the
    glyphs where one is installed, else the boxes drawn without a word), and
    the name in the figure's own text (its PNG title)."""
    import warnings

    from PIL import Image

    name = "电机测试-ラン"
    f = tmp_path / "cjk.toml"
    f.write_text(BASE.replace('name = "bad"', f'name = "{name}"'))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        rc = main(["run", str(f), "--out", str(tmp_path / "o"), "--quiet"])
    err = capsys.readouterr().err
    assert rc == 0, err
    assert "Glyph" not in err and not [w for w in seen if "Glyph" in str(w.message)], (err, [str(w.message) for w in seen])
    assert Image.open(tmp_path / "o" / "run.png").text.get("Title") == name


def test_c7_the_progress_bar_ends_at_the_last_period_without_a_tqdm_warning(monkeypatch, capsys):
    """A duration just short of a whole number of periods (0.04996 s: 500
    periods of 0.1 ms, 0.05 s): the bar counts periods, it cannot pass its
    total, so no TqdmWarning ("clamping frac") reaches the user."""
    import warnings

    monkeypatch.setenv("TQDM_MININTERVAL", "0")   # a refresh at every update: the last one too
    monkeypatch.setenv("TQDM_MINITERS", "0")
    sc = scenario_from_dict({**BASE_DATA, "duration": 0.04996})
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        res = simulate(sc, progress=True)
    assert res.stop_reason == "done" and res.sim_time == pytest.approx(0.05)
    assert not [str(w.message) for w in seen if "tqdm" in type(w.message).__module__], [str(w.message) for w in seen]
    assert "TqdmWarning" not in capsys.readouterr().err


# --- C8: the temporaries a kill leaves are removed by the next write ---------------------------------

def _dead_pid() -> int:
    import subprocess

    p = subprocess.Popen(["true"])
    p.wait()
    return p.pid


def _aged(path, seconds=3600.0):
    os.utime(path, (time.time() - seconds, time.time() - seconds))
    return path


def test_c8_a_write_removes_its_own_stale_temporaries_and_nothing_else(tmp_path):
    """The next write of a file removes the hidden temporaries of earlier
    writes of that file that no live process holds and that are older than
    the writer; a live writer's, a newer one, another file's and the user's
    own hidden files stay."""
    from fullspeed.model import files

    dead, live = _dead_pid(), os.getppid()
    stale = [f".metrics.json.{dead}.k2x_9abc.tmp.json",
             ".metrics.json.ab3def_7.tmp.json"]              # named before the pid was: by its age alone
    kept = [f".metrics.json.{live}.abcdefgh.tmp.json",      # a live process's write
            f".traces.npz.{dead}.abcdefgh.tmp.npz",         # another file's
            ".metrics.json.notes", ".metrics.json.abcdefgh.tmp.json.bak"]   # not a write's
    for n in stale + kept:
        (tmp_path / n).write_text("x")
        _aged(tmp_path / n)
    newer = f".metrics.json.{dead}.newer123.tmp.json"      # newer than this process
    (tmp_path / newer).write_text("x")
    files.write_json(tmp_path / "metrics.json", {"a": 1})
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted(["metrics.json", newer, *kept]), left


def test_c8_replace_folder_removes_the_sets_a_kill_left_beside_it(tmp_path):
    from fullspeed.model import files

    dead = _dead_pid()
    new = tmp_path / f".id.{dead}.a1b2c3d4.new"
    old = tmp_path / ".id.q9w8e7r6.old"
    for d in (new, old / "x"):
        d.mkdir(parents=True)
        (d / "a.toml").write_text("half")
    _aged(new), _aged(old)
    files.replace_folder(tmp_path / "id", {"a.toml": "1"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["id"]


def test_c8_a_write_killed_by_sigkill_leaves_a_temporary_the_next_command_removes(tmp_path):
    """As the report's injected kills: a process killed in the middle of a
    write leaves its hidden temporary; the next process that writes the file
    there removes it (and the file is the new one)."""
    import subprocess
    import sys

    target = tmp_path / "results.csv"
    kill = ("import os, signal, sys; from fullspeed.model.files import write_with\n"
            "write_with(sys.argv[1], lambda tmp: (tmp.write_text('half'), os.kill(os.getpid(), signal.SIGKILL)))\n")
    p = subprocess.run([sys.executable, "-c", kill, str(target)])
    assert p.returncode == -signal.SIGKILL
    left = [q.name for q in tmp_path.iterdir()]
    assert len(left) == 1 and left[0].startswith(".results.csv.") and left[0].endswith(".tmp.csv"), left
    time.sleep(0.05)
    write = "import sys; from fullspeed.model.files import write_atomic; write_atomic(sys.argv[1], 'whole')\n"
    subprocess.run([sys.executable, "-c", write, str(target)], check=True)
    assert [q.name for q in tmp_path.iterdir()] == ["results.csv"] and target.read_text() == "whole"


# --- O1: a long run's figure does not hold its trace again ------------------------------------------

def test_o1_a_line_is_drawn_through_each_slice_s_extremes_in_order():
    """A long line is reduced to each slice's least and greatest samples, in
    time order: its extremes, a one-sample spike and a NaN gap survive; a
    short line is drawn whole."""
    from fullspeed.sim.plots import PLOT_SLICES, drawn

    rng = np.random.default_rng(7)
    n = 123_457
    t = np.arange(n) * 1e-4
    y = rng.normal(size=n)
    y[77_777], y[5], y[n - 1], y[40_000] = 50.0, -50.0, 30.0, np.nan
    td, yd = drawn(t, y)
    assert len(td) == len(yd) <= 2 * PLOT_SLICES + 2 and np.all(np.diff(td) >= 0)
    assert 50.0 in yd and -50.0 in yd and 30.0 in yd and np.isnan(yd).sum() == 2   # the NaN: its slice's min and max
    k = n // PLOT_SLICES
    for j in rng.integers(0, PLOT_SLICES, 50):   # every slice: its extremes drawn
        part = y[j * k:(j + 1) * k]
        inside = yd[(td >= t[j * k]) & (td <= t[(j + 1) * k - 1])]
        if not np.isnan(part).any():
            assert part.max() in inside and part.min() in inside
    ts, ys = drawn(t[:3000], y[:3000])
    assert np.array_equal(ts, t[:3000]) and np.array_equal(ys, y[:3000])


def test_o1_a_long_run_s_figure_costs_a_fraction_of_its_trace(tmp_path):
    """The figure of a 4 s run (40,000 samples a channel): the memory drawing
    it allocates (tracemalloc's peak, numpy's arrays included) is well under
    the trace's size; drawn whole it was 0.9 of it (every line's points
    copied and transformed by matplotlib)."""
    import tracemalloc

    from fullspeed.sim.plots import plot_run

    res = simulate(scenario_from_dict({**BASE_DATA, "duration": 4.0}))
    trace = sum(v.nbytes for v in res.traces.values())
    tracemalloc.start()
    try:
        plot_run(res, tmp_path / "run.png")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 0.5 * trace, (peak, trace)
