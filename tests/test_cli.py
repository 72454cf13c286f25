"""The command line: the main scenario, and bad input as one clean line."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest



def fullspeed(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "fullspeed", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=300, env={**os.environ, "PYTHONWARNINGS": "ignore"})


def test_encoder_speedstep_runs_and_holds_speed(tmp_path):
    out = tmp_path / "run"
    p = fullspeed("run", "yang2022-encoder-speedstep", "--out", str(out), "--quiet")
    assert p.returncode == 0, p.stderr
    m = json.loads((out / "metrics.json").read_text())
    assert m["stop_reason"] == "done"
    assert abs(m["speed_ref_rpm"] - 1000.0) < 1e-3
    assert abs(m["speed_error_pct"]) < 0.5
    assert m["T_e_mean"] > 2.0  # carries the rated load
    assert (out / "run.png").stat().st_size > 10_000
    assert "simulated s per wall s" in p.stdout


def write_scenario(tmp_path, text):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    return f


def bad(machine='machine = "yang2022"\n', extra=""):
    return f'name = "bad"\nduration = 0.01\n{machine}[controller]\nmode = "current"\n{extra}'


@pytest.mark.parametrize("text, field", [
    (bad("", '[machine]\ncatalog = "yang2022"\n[machine.electrical]\nL_d = -1e-5\n'), "machine.electrical.L_d"),
    (bad(extra='[converter]\nfrequency = 5\n'), "converter.frequency"),
    (bad('machine = "no-such-motor"\n'), "machine.catalog"),
    (bad(extra='[references]\nspeed_rpm = [[0.1, 0], [0.05, 10]]\n'), "references.speed_rpm[1]"),
    (bad(extra='[controller]\n'), "toml"),
    (bad(extra='[timing]\nh_max = "fast"\n'), "timing.h_max"),
])
def test_bad_input_is_one_line_exit_2(tmp_path, text, field):
    f = write_scenario(tmp_path, text)
    p = fullspeed("run", str(f), "--out", str(tmp_path / "o"), "--quiet")
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    assert field in lines[0]
    assert "Traceback" not in p.stderr
    assert not (tmp_path / "o").exists()


def test_negative_inductance_message_names_value_and_rule(tmp_path):
    f = write_scenario(tmp_path, bad("", '[machine]\ncatalog = "yang2022"\n[machine.electrical]\nL_d = -1e-5\n'))
    p = fullspeed("run", str(f), "--quiet")
    assert "-1e-05" in p.stderr and ">= 1e-08" in p.stderr and "(H)" in p.stderr


@pytest.mark.parametrize("cmd", ["run", "identify"])
def test_a_machine_file_given_as_a_scenario_is_refused_as_one(tmp_path, cmd):
    """The new user's slip: the machine file where the scenario belongs. Refused
    as a machine file, with how a scenario names it, not by its first key a
    scenario does not know ('kind = ipmsm: unknown key')."""
    machine = Path(__file__).resolve().parents[1] / "examples" / "own-machine" / "my48v.toml"
    p = fullspeed(cmd, str(machine), "--out", str(tmp_path / "o"))
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    assert "pole_pairs = 4" in lines[0] and "this is a machine file" in lines[0]
    assert 'machine = "my48v.toml"' in lines[0] and "unknown key" not in lines[0]
    assert not (tmp_path / "o").exists()


def test_unknown_scenario_name():
    p = fullspeed("run", "no-such-scenario", "--quiet")
    assert p.returncode == 2 and "unknown scenario" in p.stderr


def test_reproduce_lists_every_claim_measured_or_not(tmp_path, monkeypatch):
    """Every claim is in claims.json and the report, in CLAIMS.md's order:
    measured, failing its measurement (value null, the reason), or not yet
    measurable. (The measurements themselves take minutes: the README's
    first command runs them, and each claim's own tests check its pieces.)"""
    from fullspeed.reproduce import report as rp   # importing it registers the real measurements
    from fullspeed.reproduce.claims import CLAIMS
    from fullspeed.reproduce.registry import Measurement

    def measured(out):
        return Measurement({"x": 1.0}, True, "measured")

    def broken(out):
        raise RuntimeError("no such run")

    real = dict(rp.MEASURES)
    fake = {cid: (measured if n % 2 else broken) for n, cid in enumerate(real)}
    monkeypatch.setattr(rp, "MEASURES", fake)
    rows = rp.reproduce(None, tmp_path, progress=False, lanes=1)   # the fakes are this process's
    assert [r["id"] for r in rows] == [c.id for c in CLAIMS]
    written = json.loads((tmp_path / "claims.json").read_text())
    assert written["claims"] == rows and written["complete"] is True and written["not_run"] == []
    keys = {"id", "paper", "text", "target", "value", "unit", "pass", "scenario"}
    for r in rows:
        assert keys <= set(r)
        if r["id"] not in real:
            assert r["value"] is None and r["pass"] is False and r["note"].startswith("not yet measurable: ")
        elif fake[r["id"]] is broken:
            assert r["value"] is None and r["pass"] is False and "RuntimeError: no such run" in r["note"]
        else:
            assert r["value"] == {"x": 1.0} and r["pass"] is True
    report = (tmp_path / "report.md").read_text()
    assert all(f"## {c.id} (" in report for c in CLAIMS)


@pytest.mark.parametrize("cmd", [["run", "yang2022-encoder-speedstep", "--quiet"], ["export", "beyond-full-range"],
                                 ["sweep", "beyond-zoo", "--quiet"], ["reproduce", "--paper", "yu2022", "--quiet"]])
def test_an_output_folder_that_cannot_be_one_is_refused_before_the_work(tmp_path, cmd):
    """--out on a file, or under one: one line naming --out, exit 2, at once
    (run simulated first and then failed with exit 3 writing its traces)."""
    f = tmp_path / "a-file"
    f.write_text("kept")
    for out, why in ((f, "is a file, not a folder"), (f / "sub", "cannot be written")):
        p = fullspeed(*cmd, "--out", str(out))
        assert p.returncode == 2 and "error: --out = '" in p.stderr and why in p.stderr, (cmd, p.returncode, p.stderr[-500:])
        assert len(p.stderr.strip().splitlines()) == 1 and "simulated" not in p.stdout
    assert f.read_text() == "kept"


def test_export_help_names_the_fmu_as_it_is_written(tmp_path):
    # the help said --fmu writes <name>-drive.fmu, yet --name is refused with --fmu: an FMU is named after its scenario
    text = " ".join(fullspeed("export", "--help").stdout.split())
    assert "<scenario name>-drive.fmu" in text and "<scenario name>-system.fmu" in text and "<name>-" not in text
    assert "not with --fmu" in text
    p = fullspeed("export", "beyond-full-range", "--fmu", "--name", "x", "--out", str(tmp_path))
    assert p.returncode == 2 and "an FMU is named after its scenario (<scenario name>-drive.fmu" in p.stderr


@pytest.mark.parametrize("command, name, says", [
    ("design", "nosuch", "target = 'nosuch': unknown machine or scenario"),
    ("map", "nosuch", "target = 'nosuch': unknown machine or scenario"),
    ("run", "nosuch", "scenario = 'nosuch': unknown scenario"),
    ("design", "nosuch.toml", "target = 'nosuch.toml': file not found"),   # it said machine = ...
    ("map", "nosuch.toml", "target = 'nosuch.toml': file not found")])
def test_an_unknown_name_is_refused_as_what_the_command_takes(tmp_path, command, name, says):
    # design and map take a machine or a scenario: 'unknown scenario' there sent the user to the wrong list
    p = fullspeed(command, name, cwd=tmp_path)
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1 and says in lines[0], p.stderr
    assert not list(tmp_path.iterdir())
