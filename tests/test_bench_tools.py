"""Tests of the benchmark tools, bench/firmware.py, bench/instructions.py and bench/breakdown.py's split.

What could be wrong with them: a double-precision detector that sees nothing
(then "no doubles" means nothing), a firmware image that the linker emptied,
a harness whose drive does not regulate (so the counted paths are not a real
drive's), and a count that includes the warm-up or nothing at all. Tests
needing the ARM toolchain or valgrind skip, with the reason, where those are
absent. No timing assertions; the whole file runs in seconds.
"""
from __future__ import annotations

import math
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]


def _load(name: str):
    return load_script(ROOT / "bench" / f"{name}.py", f"bench_{name}")


fw = _load("firmware")
ins = _load("instructions")

TOOLS = fw.toolchain()
needs_arm = pytest.mark.skipif(TOOLS is None, reason=f"arm-none-eabi-gcc with newlib not found ({fw.INSTALL_HINT})")
needs_valgrind = pytest.mark.skipif(shutil.which("valgrind") is None or shutil.which("gcc") is None,
                                    reason="valgrind or gcc not found (apt-get install valgrind)")

PLANTED = """\
#include <math.h>
float scale(float x) { return (float)((double)x * 1.1); }
float wave(float x) { return (float)sin((double)x); }
"""
CLEAN = """\
#include <math.h>
float wave(float x) { return sinf(x) * 0.5f + fabsf(x) + sqrtf(x); }
"""


# ---- firmware -------------------------------------------------------------

@needs_arm
def test_detector_flags_a_planted_double_and_passes_float(tmp_path):
    (tmp_path / "planted.c").write_text(PLANTED)
    (tmp_path / "clean.c").write_text(CLEAN)
    bad = fw.compile_c(TOOLS, tmp_path / "planted.c", tmp_path / "planted.o")
    good = fw.compile_c(TOOLS, tmp_path / "clean.c", tmp_path / "clean.o")
    found = fw.double_findings(TOOLS, [bad])
    assert any("__aeabi_dmul" in f and "planted.c:2" in f for f in found), found
    assert any("calls sin " in f and "planted.c:3" in f for f in found), found
    assert fw.double_findings(TOOLS, [good]) == []


@needs_arm
def test_detector_flags_f64_instructions(tmp_path):
    # a double-precision FPU turns the same source into .f64 instructions
    (tmp_path / "planted.c").write_text(PLANTED)
    m7 = [f for f in fw.CFLAGS if not f.startswith(("-mcpu=", "-mfpu="))] + ["-mcpu=cortex-m7", "-mfpu=fpv5-d16"]
    obj = fw.compile_c(TOOLS, tmp_path / "planted.c", tmp_path / "planted.o", flags=m7)
    found = fw.double_findings(TOOLS, [obj])
    assert any(".f64 instruction 'vmul.f64" in f and "planted.c:2 in scale" in f for f in found), found


@needs_arm
def test_implicit_promotion_fails_with_one_line(tmp_path, capsys):
    control = tmp_path / "csrc" / "control"
    control.mkdir(parents=True)
    (control / "half.c").write_text("float half(float x) { return x * 0.5; }\n")
    rep = fw.firmware_report(csrc=tmp_path / "csrc", workdir=tmp_path / "out")
    assert rep["status"] == "fail"
    assert "half.c:1" in rep["reason"] and "double-promotion" in rep["reason"]
    assert fw.main(["--csrc", str(tmp_path / "csrc")]) == 1
    assert "FAIL: compiling half.c" in capsys.readouterr().out


@pytest.fixture(scope="module")
def firmware(tmp_path_factory):
    if TOOLS is None:
        pytest.skip(f"arm-none-eabi-gcc with newlib not found ({fw.INSTALL_HINT})")
    work = tmp_path_factory.mktemp("firmware")
    before = _source_tree()
    rep = fw.firmware_report(workdir=work)
    assert _source_tree() == before, "the firmware build wrote into the source tree"
    return rep, work


def _source_tree() -> set[Path]:
    return {p for d in ("csrc/control", "firmware", "bench") for p in (ROOT / d).iterdir()}


def test_the_library_builds_without_doubles(firmware):
    rep, work = firmware
    assert rep["status"] == "ok", rep["reason"]
    assert rep["doubles"] == []
    objects = rep["library"]["objects"]
    assert set(objects) == {p.stem + ".o" for p in (ROOT / "csrc" / "control").glob("*.c")}
    assert rep["library"]["text"] == sum(o["text"] for o in objects.values())
    assert rep["goal"]["met"] == (rep["image"]["text"] + rep["image"]["data"] <= fw.TEXT_GOAL)
    assert (work / "firmware.elf").is_file()


def test_the_image_keeps_the_drive_step_and_its_libm(firmware):
    rep, work = firmware
    im = rep["image"]
    # the step is linked (not garbage-collected) with the trigonometry it calls: the library's own
    # (fs_cis, fs_atan2f), not newlib's, whose sinf/cosf/tanf/atan2f/atanf and fmaxf/fminf the drive
    # no longer calls
    assert im["text"] > rep["library"]["objects"]["fs_drive.o"]["text"]
    nm = fw._run([fw.toolchain()["nm"], str(work / "firmware.elf")], "nm")
    assert {"fs_cis", "fs_atan2f"} <= {ln.split()[-1] for ln in nm.splitlines()}
    # -fno-math-errno: every square root a VSQRT instruction, none a call into libm
    assert "sqrtf" not in im["libm"]
    asm = fw._run([fw.toolchain()["objdump"], "-d", str(work / "firmware.elf")], "objdump")
    assert "vsqrt.f32" in asm
    assert not {"sinf", "cosf", "tanf", "atan2f", "atanf", "fmaxf", "fminf"} & set(im["libm"])
    assert not set(im["libm"]) & fw.DOUBLE_LIBM
    assert im["bss"] > 0  # the fs_drive instance


def test_missing_toolchain_is_a_skip(monkeypatch, capsys):
    monkeypatch.setattr(fw, "toolchain", lambda prefix=fw.PREFIX: None)
    assert fw.firmware_report()["status"] == "skipped"
    assert fw.main([]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and fw.INSTALL_HINT in out[0]


# ---- instructions ---------------------------------------------------------

WARMUP = 2000  # 0.2 s at 10 kHz: loops settled, observer converged and handed over


@pytest.fixture(scope="module")
def harness(tmp_path_factory):
    if shutil.which("gcc") is None:
        pytest.skip("host gcc not found")
    return ins.build_harness(ins.CSRC, tmp_path_factory.mktemp("harness"))


@pytest.mark.parametrize("mode", ["encoder", "smo"])
def test_harness_drives_a_plausible_machine(harness, mode):
    summary, duties = ins.run_harness(harness, mode, WARMUP, 400, trace=True)
    assert len(duties) == 400
    flat = [d for step in duties for d in step]
    assert all(math.isfinite(d) and 0.0 <= d <= 1.0 for d in flat)
    # a turning rotor: the duties change every step, and not by the rail
    assert all(a != b for a, b in zip(duties, duties[1:]))
    assert 0.0 < min(flat) < max(flat) < 1.0
    # the loops regulate: speed held, the angle the loops use is the rotor's
    assert summary["speed_err_max_rpm"] < ins.MAX_SPEED_ERR_RPM
    assert summary["angle_err_max_deg"] < ins.MAX_ANGLE_ERR_DEG
    assert summary["i_q_mean"] > 0.0  # motoring against the load
    assert summary["est_valid"] == 1


def test_harness_lists_its_modes_and_refuses_others(harness):
    assert {"encoder", "smo"} <= set(ins.harness_modes(harness))
    res = subprocess.run([str(harness), "no-such-mode", "1", "1"], capture_output=True, text=True)
    assert res.returncode != 0 and "unknown mode" in res.stderr


@needs_valgrind
def test_ir_per_step_is_positive_and_scales(harness, tmp_path):
    a = ins.count_instructions(harness, "smo", WARMUP, 300, tmp_path)
    b = ins.count_instructions(harness, "smo", WARMUP, 600, tmp_path)
    later = ins.count_instructions(harness, "smo", 2 * WARMUP, 300, tmp_path)
    assert a["method"] == "client requests"
    # a step with sin, cos, the loops and the modulator is hundreds of instructions
    assert 100 < a["ir_per_step"] < 100_000
    # twice the steps, twice the count; a longer warm-up is not counted
    assert b["ir_total"] == pytest.approx(2 * a["ir_total"], rel=0.05)
    assert later["ir_total"] == pytest.approx(a["ir_total"], rel=0.05)


@needs_valgrind
def test_without_client_requests_the_count_is_the_same(harness, tmp_path):
    plain = ins.build_harness(ins.CSRC, tmp_path / "plain", callgrind_h=False)
    a = ins.count_instructions(harness, "encoder", WARMUP, 300, tmp_path)
    d = ins.count_instructions(plain, "encoder", WARMUP, 300, tmp_path)
    assert d["method"] == "difference of runs"
    assert d["ir_total"] == pytest.approx(a["ir_total"], rel=0.01)


@needs_valgrind
def test_report_marks_unbuilt_modes_and_the_goal(tmp_path):
    rep = ins.instructions_report(workdir=tmp_path, steps=300, warmup=WARMUP)
    assert rep["status"] == "ok", rep["reason"]
    modes = rep["modes"]
    assert list(modes) == [m.label for m in ins.MODES]
    for label in ("encoder FOC", "SMO"):
        assert modes[label]["status"] == "ok" and modes[label]["ir_per_step"] > 0
    built = set(ins.harness_modes(ins.build_harness(ins.CSRC, tmp_path / "list")))
    for m in ins.MODES:
        assert (modes[m.label]["status"] == "not built yet") == (m.harness not in built)
    g = rep["goal"]
    if modes["blended"]["status"] == "not built yet":
        assert g["met"] is None and g["status"] == "not built yet"
    else:
        assert modes["blended"]["status"] == "ok", modes["blended"].get("reason")
        assert g["met"] == (modes["blended"]["ir_per_step"] <= g["max_ir_per_step"])
        # the blend runs the SMO and the injection estimator on top of the loops
        assert modes["blended"]["ir_per_step"] > modes["SMO"]["ir_per_step"]
    assert g["reference"]["ir_per_step"] == modes["SMO"]["ir_per_step"]
    assert ("not built yet" in ins.format_report(rep)) == any(m.harness not in built for m in ins.MODES)


def test_missing_valgrind_is_a_skip(monkeypatch, capsys):
    real = shutil.which
    monkeypatch.setattr(ins.shutil, "which", lambda name: None if name == "valgrind" else real(name))
    assert ins.instructions_report()["status"] == "skipped"
    assert ins.main([]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and "valgrind" in out[0] and "skipped" in out[0]


@needs_arm
def test_a_firmware_whose_drive_uses_what_the_build_leaves_out_fails_naming_it(tmp_path, capsys):
    """A new user's firmware: a copy of firmware/ with their export, a drive that
    starts by the motion test, which the build's options leave out. The build
    fails naming the option (it said "goal met", and the drive would have been
    refused at fs_drive_init on the board)."""
    import shutil

    from fullspeed.workflows.export import export
    mine = tmp_path / "my-fw"
    shutil.copytree(ROOT / "firmware", mine)
    scen = tmp_path / "mine.toml"
    scen.write_text('name = "mine"\nduration = 1.0\nmachine = "yang2022"\n[start]\nmethod = "motion"\n'
                    '[controller]\nmode = "speed"\nangle = "blend"\n[references]\nspeed_rpm = 300.0\n')
    export(str(scen), mine, "fs_config")
    assert "-DFS_WITH_MOTION_TEST=0" in fw.OPTIONS
    assert fw.main(["--firmware", str(mine)]) == 1
    out = capsys.readouterr().out
    assert "FAIL: compiling fs_config.c" in out and "motion test" in out and "FS_WITH_MOTION_TEST=1" in out


def test_the_breakdown_finds_the_plant_where_the_runner_inlined_its_integration():
    """bench/breakdown.py split: the plant is the integration's function
    where it has one (the switching inverter's general period), else, where
    the runner inlined it (the averaged ideal period since 28e53ed), the RK4
    step it calls, and it says which; with neither it refuses rather than
    count the plant as the runner's."""
    bd = _load("breakdown")
    base = {"total": 1000, "incl": {"fs_sim_run_cols": 0, "fs_drive_step": 0, "fs_pmsm_rk4_at": 0}}
    one = {"total": 2600, "incl": {"fs_sim_run_cols": 1500, "fs_drive_step": 600, "fs_pmsm_rk4_at": 700}}   # one row traced
    met = {"total": 1100, "incl": {}}
    inlined = {"total": 3000, "incl": {"fs_sim_run_cols": 1800, "fs_drive_step": 600, "fs_pmsm_rk4_at": 700}}
    rep = bd.split(base, inlined, met, one, 1, 10)
    assert rep["plant_counted_as"] == list(bd.PLANT_CALLEES)
    assert rep["per_sample"]["plant"] == pytest.approx(70.0) and rep["per_sample"]["control"] == pytest.approx(60.0)
    assert rep["per_sample"]["tracing"] == pytest.approx(30.0) and rep["per_sample"]["runner"] == pytest.approx(20.0)
    named = {"total": 3000, "incl": {**inlined["incl"], "integrate_period_general": 900}}
    rep = bd.split(base, named, met, one, 1, 10)
    assert rep["plant_counted_as"] == list(bd.PLANT_FNS) and rep["per_sample"]["plant"] == pytest.approx(90.0)
    with pytest.raises(RuntimeError, match="cannot be told apart"):
        bd.split(base, {"total": 3000, "incl": {"fs_sim_run_cols": 1800, "fs_drive_step": 600}}, met, one, 1, 10)
