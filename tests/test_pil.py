"""Processor in the loop (bench/pil.py): the drive step on an emulated Cortex-M4F.

What could be wrong: a target that does not run the step at all (outputs
left at zero would differ, and the instruction count would be tiny), a
replay fed other inputs than the simulator's (the host's open-loop replay
must reproduce the closed loop's outputs exactly), a comparison that sees no
difference (a planted one must be found), struct layouts that differ between
host and target (static asserts in the target build, sizes checked at run
time), and a closed loop through the emulator that silently falls back to the
host's step (the target reports how many steps it ran). Without the cross
toolchain and QEMU these tests skip, saying what to install.
"""
from __future__ import annotations

from pathlib import Path

import pytest

from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]
pil = load_script(ROOT / "bench" / "pil.py", "bench_pil")

TOOLS = pil.tools()
pytestmark = pytest.mark.skipif(TOOLS is None, reason=f"PIL needs the ARM toolchain and QEMU: {pil.INSTALL_HINT}")


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    return pil.build(TOOLS, tmp_path_factory.mktemp("pil"))


@pytest.mark.parametrize("mode", list(pil.MODES))
def test_replay_on_the_target_within_tolerance(builds, mode):
    r = pil.run_mode(TOOLS, builds, mode)
    c = r["compare"]
    assert r["sim_status"] == "done"
    assert r["host_replay_equals_closed_loop"], "the recorded inputs do not reproduce the simulator's outputs"
    assert c["steps_target"] == c["steps_host"] > 1000
    assert c["within"], (f"{mode}: duty {c['max_duty']:.3g}, theta {c['max_theta_e']:.3g}, w {c['max_w_e_rel']:.3g}, "
                         f"stages {c['stage_mismatches']} (tolerance {pil.TOLERANCE})")
    ins = r["insns"]
    # a drive step is a few thousand instructions: not the marking's overhead, not a runaway loop
    assert 500 < ins["mean"] <= ins["max"] < 20000
    assert 0 < r["stack_used"] < 4096
    # the target's RAM for the drive: the host's layout with 4-byte pointers (drv->fail and the MTPA
    # config's table: their size and the padding their 8-byte alignment adds on the host)
    ffi = pil._core()[0]
    assert r["sizeof_fs_drive"] == _size_ilp32(ffi, ffi.typeof("fs_drive"))[0]


def _size_ilp32(ffi, t) -> tuple[int, int]:
    """Size and alignment of a cffi type with 4-byte pointers (a 32-bit target), all else as on the host."""
    if t.kind == "pointer":
        return 4, 4
    if t.kind == "array":
        size, align = _size_ilp32(ffi, t.item)
        return size * t.length, align
    if t.kind == "struct":
        end, align = 0, 1
        for _, f in t.fields:
            size, a = _size_ilp32(ffi, f.type)
            end = -(-end // a) * a + size
            align = max(align, a)
        return -(-end // align) * align, align
    return ffi.sizeof(t), ffi.alignof(t)


def test_a_planted_difference_is_found(builds):
    rec = pil.record(builds, "encoder", 0.05)
    host = pil.replay_host(rec)
    other = host.copy()
    other["duty"][123, 1] += 2e-3
    c = pil.compare(rec, host, other)
    assert not c["within"] and c["first_difference"] == 123 and c["first_fields"] == ["duty"]
    assert c["max_duty"] == pytest.approx(2e-3, rel=1e-3)
    assert pil.compare(rec, host, host)["identical_steps"] == len(host)


def test_closed_loop_through_the_emulator(builds):
    """The blend from standstill (polarity, injection, blend, the back-EMF
    observer) with the controller on the target: the same course as the host's."""
    r = pil.closed_loop(TOOLS, builds, "blend", 1.2)
    assert r["steps_target"] == int(round(1.2 / 1e-4))   # every step ran on the target
    v = pil.loop_verdict(r)
    assert v["within"], v
    assert r["stages_target"][:4] == [2, 4, 5, 6]
    assert r["max_w_m_diff_rpm"] < 5.0 and r["max_theta_err_diff_deg"] < 2.0
    assert r["insns"]["per_stage"][4]["mean"] > r["insns"]["per_stage"][6]["mean"]   # injection costs more than the SMO alone


def test_libm_is_where_target_and_host_part(builds):
    lm = pil.libm_probe(TOOLS, builds, n=4000)
    assert lm["x*y+y"]["differ_pct"] == 0.0 and lm["sqrtf"]["differ_pct"] == 0.0   # IEEE arithmetic: identical
    assert lm["sinf"]["differ_pct"] > 0.0 and all(v["max_ulp"] <= 2 for v in lm.values())
    # the drive's trigonometry is its own: the same bits on both
    assert lm["fs_cosf"]["differ_pct"] == lm["fs_sinf"]["differ_pct"] == lm["fs_atan2f"]["differ_pct"] == 0.0
    assert not [f for f in pil.fused_in_image(TOOLS, builds) if f.startswith("fs_") or f.startswith("drive_")]


def test_the_goal_is_read_on_the_mean_and_the_largest_step_against_the_budget():
    """Issue 23's <= 2,500 instructions: the mean over the blended run; the
    largest step is held against 8,400 cycles (168 MHz, 20 kHz)."""
    g = pil.blend_goal({"mean": 2400.0, "max": 4200, "per_stage": {}}, "closed loop")
    assert g["met"] and g["max_of_budget_20k"] == pytest.approx(0.5) and g["cpi_left_20k"] == pytest.approx(2.0)
    assert not pil.blend_goal({"mean": 2501.0, "max": 2600, "per_stage": {}}, "closed loop")["met"]
    assert pil.blend_goal({"mean": 2500.0, "max": 9000, "per_stage": {}}, "closed loop")["met"]   # a slow step: the budget says it


def test_a_build_directory_is_read_only_when_complete(builds, tmp_path):
    """Runs with the same sources share a build directory. One left as a
    concurrent linker leaves it (pil.elf opened, still empty; the rest there)
    is not read: it is rebuilt (nm on it failed with "exit 1" before)."""
    key = builds.work.name
    half = tmp_path / key
    half.mkdir()
    for f in ("pil.elf", "insn_count.so", "host_sim.so"):
        (half / f).write_bytes(b"")
    b = pil.build(TOOLS, tmp_path)
    assert b.work == half and (half / pil.COMPLETE).is_file() and b.mark == builds.mark
    assert b.target.stat().st_size == builds.target.stat().st_size
    # no stage nor stale copy left behind: the target's directory and the host's (_host_build)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([key, builds.host_sim.parent.name])
    assert b.host_sim.parent.name == builds.host_sim.parent.name and (b.host_sim.parent / pil.COMPLETE).is_file()


def test_the_firmwares_build_shares_the_host_simulator_and_the_plugin(builds):
    """The firmware's flags make a target of their own; the recording host
    simulator and the QEMU plugin, whose sources and flags are the same, are
    the PIL image's, not built again."""
    made = builds.host_sim.stat().st_mtime_ns
    bf = pil.build(TOOLS, builds.work.parent, extra_flags=[*pil.fw.LTO, *pil.fw.OPTIONS])
    assert bf.work != builds.work and bf.target != builds.target
    assert bf.host_sim == builds.host_sim and bf.plugin == builds.plugin
    assert builds.host_sim.stat().st_mtime_ns == made


def test_a_second_publisher_keeps_the_first_build(tmp_path):
    d = tmp_path / "key"
    for who in ("first", "second"):
        st = tmp_path / f"stage-{who}"
        st.mkdir()
        (st / "who").write_text(who)
        pil._publish(st, d)
    assert (d / "who").read_text() == "first" and sorted(p.name for p in tmp_path.iterdir()) == ["key"]


def test_a_users_scenario_closes_the_loop_through_the_emulator(builds, tmp_path):
    """--scenario: a user's scenario (here the blended full-range one at a
    20 kHz carrier) run with the plant on the host and the drive on the
    target, the same as the host's drive step; one the firmware's build
    cannot run is named, not attempted."""
    f = tmp_path / "my20k.toml"
    f.write_text('name = "my20k"\nduration = 0.3\nmachine = { catalog = "yang2022", bench = { f_pwm = 20000.0 } }\n'
                 '[controller]\nmode = "speed"\nangle = "blend"\n[references]\nspeed_rpm = 300.0\n')
    r = pil.closed_loop(TOOLS, builds, "blend", scenario=str(f))
    assert r["scenario"] == str(f) and r["steps_target"] == 6000   # 0.3 s at 20 kHz, every step on the target
    assert pil.loop_verdict(r)["within"] and r["max_theta_err_diff_deg"] == 0.0
    assert pil.firmware_leaves_out(str(f)) is None
    assert pil.firmware_leaves_out("beyond-swvi-3ph") == "the square-wave injection (controller.angle = swvi)"
    assert pil.firmware_leaves_out("zou2021-experiment") == "the matrix converter (converter.kind = imc)"
