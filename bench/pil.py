"""Processor in the loop: the drive step on an emulated Cortex-M4F (QEMU mps2-an386).

Why: csrc/control is meant to run unchanged on the drive's microcontroller.
Compiling it for the target (bench/firmware.py) says nothing about whether it
computes the same numbers there; this runs it.

Replay, per angle source (MODES): a closed-loop simulation runs on the host
with the simulator's drive step recorded (every fs_drive_in and fs_drive_out,
from t = 0); the recorded inputs are then stepped through fs_drive_step built
for the target, from the same fs_drive_init, and the target's outputs are
compared with the host's sample by sample (duties, angle, speed, stage, ...).

Recording: csrc/sim/fs_sim.c is not edited. The host simulator is compiled a
second time, as a shared library, with fs_sim.c alone built with
-Dfs_drive_step=pil_hook_step: bench/pil/pil_hook.c steps the real drive and
keeps a copy of the input and output. (A hook in fs_sim.c would mean an edit
to a file others change every day, for a test's sake; the trace lacks the
ADC's quantization and the fifth phase.) The same hook, pointed at two
FIFOs, closes the loop through the emulator: the plant on the host, the
controller on the target, one sample per exchange.

Cost: a QEMU TCG plugin (bench/pil/insn_count.c) counts the executed guest
instructions and records the count each time pil_mark() runs, which the
target calls before and after each step: instructions per fs_drive_step,
exactly (QEMU does not model the Cortex-M4's pipeline: instructions, not
cycles; the DWT cycle counter is not emulated). The target paints its stack
and reports the deepest the steps went.

Usage: python bench/pil.py [--modes blend,smo] [--duration S] [--loop MODE] [--loop-duration S] [--scenario NAME_OR_TOML] [--out DIR]
Without the toolchain or QEMU it prints one line saying what to install and
exits 0.
"""
from __future__ import annotations

import argparse
import hashlib
import importlib.util
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CSRC = ROOT / "csrc"
HERE = ROOT / "bench" / "pil"
INSTALL_HINT = "apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm"


def _load_firmware():
    spec = importlib.util.spec_from_file_location("bench_firmware", ROOT / "bench" / "firmware.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(spec.name, mod)
    spec.loader.exec_module(mod)
    return mod


fw = _load_firmware()

# One catalog scenario per angle source (and the matrix converter), with the
# stretch replayed: from t = 0 (the drive's state starts at fs_drive_init)
# through the stages that matter. Durations are capped by --duration.
MODES = {
    "encoder": ("yang2022-encoder-speedstep", 1.2),
    "smo": ("yang2022-smo-ramp", 1.0),             # encoder start, sensorless from 0.6 s
    "hfi": ("yang2022-hfi-iqstep", 0.6),           # polarity detection, injection at 100 rpm
    "blend": ("beyond-full-range", 3.2),           # polarity, injection, blend, SMO, flux weakening
    "swvi": ("beyond-swvi-3ph", 1.0),
    "swvi-5ph": ("yu2022-seq-dyn", 0.6),           # five phases
    "imc": ("zou2021-experiment", 0.6),            # the matrix converter, depth control
}
# Where the open-loop replay stops being a comparison: once the loops run on
# the sliding-mode observer's estimate (smo: the handover at 0.6 s; blend: the
# observer valid from about 0.65 s, and the loss-of-lock monitor comparing it
# with the blend), the observer integrates the drive's own voltage, which
# depends on its estimate, against recorded currents that do not respond to
# that voltage: a one-ulp difference grows without the plant to pull it back
# (duties differed by 0.5 within 0.3 s while the target's sinf/cosf were
# newlib's). The replay is compared up to there and the loop closed through
# the emulator covers the rest (closed_loop). With the library's own
# trigonometry (fs_cis, fs_atan2f) no result differs in these runs and the
# replay is identical all through (the report's "then" column), but the
# libm functions the inits still call (expf, expm1f, tanhf) differ from
# glibc's on some arguments, and one designed gain an ulp apart would grow
# the same way.
COMPARE_UNTIL = {"smo": 0.6, "blend": 0.6}
# Largest differences allowed between target and host per output, and why:
# the arithmetic is IEEE binary32 on both and the trigonometry is the
# library's own (fs_cis, fs_atan2f: the same bits on both), so what differs
# is the rest of libm (newlib's logf in the matrix converter's step, expf
# and expm1f in the inits, against glibc's: an ulp on some arguments) and
# what the loops and observers make of it. A
# duty difference of 1e-3 is 0.1 % of the period (4 ns of a 10 kHz
# carrier); an angle of 5e-3 rad is 0.3 el.deg.
TOLERANCE = {"duty": 1e-3, "theta_e": 5e-3, "w_e_rel": 1e-3, "stage": 0}
MAGIC = 0x4C495046
OUT_HEADER = 8 * 4      # pil_header_out: 8 words
CFLAGS_HOST = ["-O3", "-std=c99", "-fno-math-errno", "-fPIC"]   # as src/fullspeed/_build.py compiles the core (its
# link-time optimisation left out: it moves no bit, bench/trace_hashes.py, and would slow the build on a fresh clone)


class PilError(Exception):
    """A build or a run that failed; the message is one line."""


def tools() -> dict | None:
    """The cross toolchain, QEMU and a host cc, or None if any is missing."""
    arm = fw.toolchain()
    qemu = shutil.which("qemu-system-arm")
    cc = shutil.which("cc") or shutil.which("gcc")
    if arm is None or qemu is None or cc is None:
        return None
    return {**arm, "qemu": qemu, "cc": cc}


def _run(cmd, what: str, **kw) -> subprocess.CompletedProcess:
    res = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if res.returncode != 0:
        err = (res.stderr or res.stdout).strip().splitlines()
        first = next((ln for ln in err if "error" in ln.lower()), err[0] if err else f"exit {res.returncode}, no output")
        raise PilError(f"{what} failed: {first.strip()}")
    return res


def _parallel(jobs: list[tuple[list[str], str]]) -> None:
    """Run compile commands two at a time (the machine's cores)."""
    errors: list[str] = []

    def work(batch):
        for cmd, what in batch:
            try:
                _run(cmd, what)
            except PilError as e:
                errors.append(str(e))
    threads = [threading.Thread(target=work, args=(jobs[k::2],)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if errors:
        raise PilError(errors[0])


def _digest(paths: list[Path], extra: str) -> str:
    h = hashlib.sha256(extra.encode())
    for p in sorted(paths):
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


# -- builds -------------------------------------------------------------------

@dataclass
class Builds:
    target: Path          # the PIL image
    mark: int             # address of pil_mark
    plugin: Path
    host_sim: Path        # the simulator with the recording hook
    work: Path
    su: dict = field(default_factory=dict)   # -fstack-usage: function -> (bytes, kind)


def layout_header() -> str:
    from fullspeed.workflows.export import layout_asserts
    lines = ["/* Generated by bench/pil.py: the host's layouts, which the replay's bytes follow. */",
             "#include <stddef.h>", '#include "fs_drive.h"']
    for c in ("fs_drive_config", "fs_drive_in", "fs_drive_out"):
        lines += layout_asserts(c)
    return "\n".join(lines) + "\n"


# A build's directory is shared by every run with the same sources and flags
# (the work directory defaults to one under the system's temp, and engineers
# run from worktrees at the same commit): a run that found it incomplete used
# to compile and link into it while another run read it, and a linker that
# has just opened pil.elf leaves it empty until it finishes; nm on the empty
# file exits 1 without a word ("nm failed: exit 1" in a full reproduction
# run beside another). Each run now builds in a directory of its own and
# renames it into place whole, with COMPLETE written last: a directory under
# the key's name is finished, and one without the mark (an older layout, a
# build that was killed) is set aside, not read.
COMPLETE = "COMPLETE"


def _publish(stage: Path, d: Path) -> None:
    """Rename the finished stage to d; if another run published d first, keep
    theirs (the same sources and flags) and drop the stage."""
    (stage / COMPLETE).write_text("")
    if d.exists() and not (d / COMPLETE).is_file():   # incomplete: set aside, whoever reads it already failed
        aside = Path(tempfile.mkdtemp(prefix=d.name + ".stale-", dir=d.parent))
        try:
            os.rename(d, aside / d.name)
        except FileNotFoundError:
            pass
        shutil.rmtree(aside, ignore_errors=True)
    try:
        os.rename(stage, d)
    except OSError:
        if not (d / COMPLETE).is_file():
            raise
        shutil.rmtree(stage, ignore_errors=True)


def _link_image(t: dict, objs: list[Path], elf: Path, what: str) -> None:
    """An image for QEMU's mps2-an386: our startup, newlib-nano, its libm."""
    _run([t["gcc"], *fw.CPU_FLAGS, "-O2", "-nostartfiles", "--specs=nano.specs", "--specs=nosys.specs",
          "-Wl,--gc-sections", f"-T{HERE / 'mps2_an386.ld'}", *map(str, objs), "-lm", "-o", str(elf)], what)


def _host_build(t: dict, work: Path) -> Path:
    """The recording host simulator and the QEMU plugin, in a directory of
    their own keyed by their sources and flags (COMPLETE): the target's
    builds (the PIL image's flags, the firmware's) share them, where each
    built them again, the same objects (about 7 s of CPU on a fresh clone)."""
    host_srcs = (sorted((CSRC / "control").glob("*.c")) + sorted((CSRC / "plant").glob("*.c"))
                 + sorted((CSRC / "sim").glob("*.c")))
    key = "host-" + _digest([*host_srcs, *sorted(CSRC.glob("*/*.h")), HERE / "pil_hook.c", HERE / "insn_count.c"],
                            " ".join(CFLAGS_HOST))
    d = work / key
    if not (d / COMPLETE).is_file():
        st = Path(tempfile.mkdtemp(prefix=key + ".build-", dir=work))
        try:
            jobs, hobjs = [], []
            for src in [*host_srcs, HERE / "pil_hook.c"]:
                o = st / (src.stem + ".o")
                hook = ["-Dfs_drive_step=pil_hook_step"] if src.name == "fs_sim.c" else []
                jobs.append(([t["cc"], *CFLAGS_HOST, *hook, f"-I{CSRC}", "-c", str(src), "-o", str(o)], f"compiling {src.name} for the host"))
                hobjs.append(o)
            jobs.append(([t["cc"], "-O2", "-shared", "-fPIC", str(HERE / "insn_count.c"), "-o", str(st / "insn_count.so")],
                         "building the QEMU plugin"))
            _parallel(jobs)
            _run([t["cc"], "-shared", *map(str, hobjs), "-lm", "-o", str(st / "host_sim.so")], "linking the host simulator")
            _publish(st, d)
        finally:
            shutil.rmtree(st, ignore_errors=True)   # gone if published
    return d


def build(t: dict, work: Path, extra_flags: list[str] = ()) -> Builds:
    """Build the target image into work, with the plugin and the recording host simulator
    (_host_build) beside it (each reused when its sources are unchanged; see COMPLETE)."""
    work.mkdir(parents=True, exist_ok=True)
    host = _host_build(t, work)
    control = sorted((CSRC / "control").glob("*.c"))
    headers = sorted(CSRC.glob("*/*.h"))
    key = _digest([*control, *headers, *HERE.iterdir()], " ".join([*fw.CFLAGS, *extra_flags]))
    d = work / key
    if not (d / COMPLETE).is_file():
        st = Path(tempfile.mkdtemp(prefix=key + ".build-", dir=work))
        try:
            (st / "pil_layout.h").write_text(layout_header())
            flags = [*fw.CFLAGS, *extra_flags, "-fstack-usage", f"-I{CSRC / 'control'}", f"-I{st}"]
            jobs, objs = [], []
            for src in [*control, HERE / "startup.c", HERE / "pil_target.c"]:
                o = st / "arm" / (src.stem + ".o")
                o.parent.mkdir(exist_ok=True)
                jobs.append(([t["gcc"], *flags, "-c", str(src), "-o", str(o)], f"compiling {src.name} for the target"))
                objs.append(o)
            _parallel(jobs)
            _link_image(t, objs, st / "pil.elf", "linking the PIL image")
            _publish(st, d)
        finally:
            shutil.rmtree(st, ignore_errors=True)   # gone if published
    tgt = d / "pil.elf"
    nm = _run([t["nm"], str(tgt)], f"nm {tgt}").stdout
    mark = next((int(ln.split()[0], 16) & ~1 for ln in nm.splitlines() if ln.split()[-1] == "pil_mark"), None)
    if mark is None:
        raise PilError("pil_mark not found in the PIL image")
    return Builds(tgt, mark, host / "insn_count.so", host / "host_sim.so", d, stack_usage(d / "arm"))


def stack_usage(objdir: Path) -> dict[str, tuple[int, str]]:
    out = {}
    for su in objdir.glob("*.su"):
        for ln in su.read_text().splitlines():
            loc, size, kind = ln.rsplit("\t", 2)
            out[loc.rsplit(":", 1)[-1]] = (int(size), kind)
    return out


def static_stack(t: dict, b: Builds, root: str = "fs_drive_step") -> int:
    """The deepest call chain from root in the image, summing -fstack-usage frames
    (calls found in the disassembly; libm's frames, without .su, from their push)."""
    dis = _run([t["objdump"], "-d", str(b.target)], "objdump").stdout
    calls: dict[str, set[str]] = {}
    push: dict[str, int] = {}
    fn = None
    for ln in dis.splitlines():
        if ln.endswith(">:") and " <" in ln:
            fn = ln.split("<", 1)[1][:-2]
            calls[fn] = set()
            continue
        if fn is None or "\t" not in ln:
            continue
        ins = ln.split("\t")
        op = ins[2].strip() if len(ins) > 2 else ""
        args = ins[3] if len(ins) > 3 else ""
        if op in ("bl", "b.w", "b") and "<" in args:
            tgt = args.split("<", 1)[1].split(">")[0].split("+")[0]
            if tgt != fn:
                calls[fn].add(tgt)
        if op in ("push", "push.w", "stmdb") and fn not in push:
            push[fn] = 4 * (args.count(",") + 1)
        if op in ("vpush",) and "{" in args:
            push[fn] = push.get(fn, 0) + 4 * (args.count(",") + 1)

    def frame(f: str) -> int:
        base = f.split(".")[0]
        return b.su.get(f, b.su.get(base, (push.get(f, 0), "")))[0]
    best: dict[str, int] = {}

    def deep(f: str, seen: frozenset) -> int:
        if f in best:
            return best[f]
        sub = max((deep(g, seen | {f}) for g in calls.get(f, ()) if g not in seen), default=0)
        best[f] = frame(f) + sub
        return best[f]
    return deep(root, frozenset())


# -- the host side --------------------------------------------------------------

def _core():
    from fullspeed import _core
    return _core.ffi, _core.lib


def np_dtype(cname: str) -> np.dtype:
    """A numpy structured dtype of a cffi struct (its leaves: float, int, bool and arrays of them)."""
    ffi, _ = _core()
    fmt = {"float": "<f4", "int": "<i4", "_Bool": "u1", "unsigned int": "<u4", "double": "<f8"}

    def of(t):
        if t.kind == "struct":
            return np.dtype({"names": [n for n, _ in t.fields], "formats": [of(f.type) for _, f in t.fields],
                             "offsets": [f.offset for _, f in t.fields], "itemsize": ffi.sizeof(t)})
        if t.kind == "array":
            return np.dtype((of(t.item), (t.length,)))
        if t.kind == "enum":
            return np.dtype("<i4")
        return np.dtype(fmt[t.cname])
    return of(ffi.typeof(cname))


@dataclass
class Recording:
    mode: str
    scenario: str
    cfg: bytes            # the fs_drive_config
    ins: bytes            # n x fs_drive_in
    outs: np.ndarray      # n fs_drive_out (structured), the closed loop's
    phases: int
    trace: np.ndarray | None = None
    status: str = "done"


def _host_lib(b: Builds):
    from cffi import FFI
    xffi = FFI()
    xffi.cdef("""
        void *fs_sim_create(const void *cfg, char *err, int err_len);
        void fs_sim_destroy(void *sim);
        int fs_sim_run(void *sim, double t_end, double *trace, int max_rows, int *rows);
        void pil_record(void *in, void *out, long cap);
        long pil_recorded(void);
        void pil_remote(int fd_to, int fd_from);
        int pil_remote_error(void);
        void pil_trig(const float *xy, float *out, long n);
    """)
    return xffi, xffi.dlopen(str(b.host_sim))


def simulate(b: Builds, scenario: str, duration: float, remote: tuple[int, int] | None = None, record: bool = True):
    """Run the scenario for duration on the recording host simulator.
    Returns (cfg bytes, ins, outs, n, trace, status, sc)."""
    from fullspeed.design.scenario import load_scenario
    from fullspeed.sim import STOP_REASONS, build_config
    ffi, lib = _core()
    sc = load_scenario(scenario, overrides={"trace": {"decimation": 1}})
    duration = min(duration, sc.duration)   # the scenario's profiles as written, run to here
    cfg, keep = build_config(sc)
    n_max = int(round(duration / cfg.drive.Ts)) + 2
    ins = ffi.new("fs_drive_in[]", n_max) if record else ffi.NULL
    outs = ffi.new("fs_drive_out[]", n_max) if record else ffi.NULL
    xffi, xlib = _host_lib(b)
    addr = lambda p: xffi.cast("void *", int(ffi.cast("uintptr_t", p)))   # noqa: E731
    xlib.pil_record(addr(ins), addr(outs), n_max if record else 0)
    xlib.pil_remote(*(remote or (-1, -1)))
    err = xffi.new("char[]", 512)
    sim = xlib.fs_sim_create(addr(cfg), err, 512)
    if sim == xffi.NULL:
        raise PilError(f"{scenario}: {xffi.string(err).decode()}")
    try:
        trace = np.empty((n_max, lib.FS_CH_N))
        rows = xffi.new("int *")
        rc = xlib.fs_sim_run(sim, duration, xffi.cast("double *", trace.ctypes.data), n_max, rows)
        status = STOP_REASONS.get(rc, f"stop {rc}")
        if remote and xlib.pil_remote_error():
            status = "target lost"
    finally:
        xlib.fs_sim_destroy(sim)
        xlib.pil_remote(-1, -1)
    n = xlib.pil_recorded() if record else 0
    cfg_bytes = bytes(ffi.buffer(ffi.addressof(cfg, "drive")))
    del keep
    return cfg_bytes, ins, outs, n, trace[: rows[0]], status, sc


def record(b: Builds, mode: str, duration: float | None = None) -> Recording:
    ffi, _ = _core()
    scenario, dur = MODES[mode]
    dur = min(dur, duration) if duration else dur
    cfg, ins, outs, n, trace, status, sc = simulate(b, scenario, dur)
    in_b = bytes(ffi.buffer(ins, n * ffi.sizeof("fs_drive_in")))
    out_a = np.frombuffer(bytes(ffi.buffer(outs, n * ffi.sizeof("fs_drive_out"))), dtype=np_dtype("fs_drive_out"))
    return Recording(mode, scenario, cfg, in_b, out_a, sc.machine.phases, trace, status)


def replay_host(rec: Recording) -> np.ndarray:
    """The recorded inputs through the host's fs_drive_step (the cffi core), open loop."""
    ffi, lib = _core()
    n = len(rec.ins) // ffi.sizeof("fs_drive_in")
    cfg = ffi.new("fs_drive_config *")
    ffi.memmove(cfg, rec.cfg, len(rec.cfg))
    drv = ffi.new("fs_drive *")
    if lib.fs_drive_init(drv, cfg) != lib.FS_OK:
        raise PilError(f"{rec.mode}: fs_drive_init refused the recorded configuration ({ffi.string(drv.fail).decode()})")
    ins = ffi.new("fs_drive_in[]", n)
    ffi.memmove(ins, rec.ins, len(rec.ins))
    outs = ffi.new("fs_drive_out[]", n)
    for k in range(n):
        lib.fs_drive_step(drv, ins + k, outs + k)
    return np.frombuffer(bytes(ffi.buffer(outs)), dtype=np_dtype("fs_drive_out"))


# -- the target side ------------------------------------------------------------

def _qemu_cmd(t: dict, b: Builds, counts: Path | None, hist: Path | None = None) -> list[str]:
    cmd = [t["qemu"], "-M", "mps2-an386", "-display", "none", "-monitor", "none", "-serial", "none",
           "-semihosting-config", "enable=on,target=native", "-kernel", str(b.target)]
    if counts is not None:
        cmd += ["-plugin", f"{b.plugin},mark={b.mark:#x},out={counts}" + (f",hist={hist}" if hist else "")]
    return cmd


def _in_header(n: int, block: int) -> bytes:
    ffi, _ = _core()
    return np.array([MAGIC, n, block, ffi.sizeof("fs_drive_config"), ffi.sizeof("fs_drive_in"),
                     ffi.sizeof("fs_drive_out")], dtype="<u4").tobytes()


def _out_trailer(raw: bytes, what: str) -> dict:
    if len(raw) < OUT_HEADER:
        raise PilError(f"{what}: the target wrote no result")
    w = np.frombuffer(raw[-OUT_HEADER:], dtype="<u4")
    if w[0] != MAGIC:
        raise PilError(f"{what}: the target's output is malformed")
    return {"status": int(np.int32(w[1])), "sizeof_fs_drive": int(w[2]), "stack_used": int(w[6]), "steps": int(w[7])}


def _profile(t: dict, b: Builds, hist: np.ndarray, steps: int) -> dict[str, float]:
    """Instructions per step by function (its own instructions, not its callees'), largest first."""
    out = {}
    harness = {"main", "sh_call", "sh_exit", "pil_mark", "stack_paint", "stack_used", "Reset_Handler", "Default_Handler"}
    for ln in _run([t["nm"], "-S", "--defined-only", str(b.target)], f"nm {b.target}").stdout.splitlines():
        p = ln.split()
        if len(p) == 4 and p[2] in "tTwW" and p[3].split(".")[0] not in harness:
            a, n = int(p[0], 16) & ~1, int(p[1], 16)
            tot = int(hist[a >> 1:(a + n) >> 1].sum())
            if tot:
                out[p[3]] = out.get(p[3], 0.0) + tot / steps
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def _step_counts(raw: bytes, steps: int) -> np.ndarray:
    """Instructions per step from the plugin's counts at each pil_mark: two marks
    back to back first (the marking's own cost), then one before and one after each step."""
    c = np.frombuffer(raw, dtype="<u8").astype(np.int64)
    overhead = c[1] - c[0]
    pairs = c[2:2 + 2 * steps]
    pairs = pairs[: len(pairs) // 2 * 2].reshape(-1, 2)
    return pairs[:, 1] - pairs[:, 0] - overhead


def _insn_stats(ins: np.ndarray, stage: np.ndarray) -> dict:
    per = {int(s): {"steps": int((stage == s).sum()), "mean": float(ins[stage == s].mean()), "max": int(ins[stage == s].max())}
           for s in np.unique(stage)}
    return {"mean": float(ins.mean()), "max": int(ins.max()), "min": int(ins.min()),
            "p99": float(np.percentile(ins, 99)), "per_stage": per}


def replay_target(t: dict, b: Builds, rec: Recording, count: bool = True, timeout: float = 300.0,
                  profile: bool = False) -> tuple[np.ndarray, dict]:
    """The recorded inputs through fs_drive_step on the emulated Cortex-M4F
    (profile: info["profile"], instructions per step by function)."""
    ffi, _ = _core()
    n = len(rec.ins) // ffi.sizeof("fs_drive_in")
    with tempfile.TemporaryDirectory(prefix="fs-pil-") as tmp:
        tmp = Path(tmp)
        (tmp / "pil_in.bin").write_bytes(_in_header(n, 64) + rec.cfg + rec.ins)
        counts = tmp / "counts.bin" if count else None
        t0 = time.perf_counter()
        hist = tmp / "hist.bin" if profile and count else None
        res = subprocess.run(_qemu_cmd(t, b, counts, hist), cwd=tmp, capture_output=True, text=True, timeout=timeout)
        wall = time.perf_counter() - t0
        raw = (tmp / "pil_out.bin").read_bytes() if (tmp / "pil_out.bin").exists() else b""
        if res.returncode != 0:
            raise PilError(f"{rec.mode}: QEMU exited {res.returncode}: {(res.stderr or res.stdout).strip()[:200]}")
        info = _out_trailer(raw, rec.mode)
        info["wall_s"] = wall
        size = ffi.sizeof("fs_drive_out")
        outs = np.frombuffer(raw[: info["steps"] * size], dtype=np_dtype("fs_drive_out"))
        if count:
            info["insns"] = _step_counts(counts.read_bytes(), info["steps"])
        if hist is not None:
            info["profile"] = _profile(t, b, np.frombuffer(hist.read_bytes(), dtype="<u8"), max(info["steps"], 1))
    if info["status"] != 0:
        raise PilError(f"{rec.mode}: fs_drive_init on the target returned {info['status']}")
    return outs, info


# -- comparison -----------------------------------------------------------------

def _wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


def _unequal(h: np.ndarray, g: np.ndarray, phases: int) -> dict[str, np.ndarray]:
    """Per output field, the steps where h and g differ (NaN equals NaN; only the
    first `phases` duties, the rest are not written; the matrix converter's
    intervals left out)."""
    out = {}
    for f in h.dtype.names:
        if f == "rect":
            continue
        a, b = h[f], g[f]
        if f == "duty":
            a, b = a[:, :phases], b[:, :phases]
        ne = (a != b) & ~(np.isnan(a) & np.isnan(b)) if a.dtype.kind == "f" else a != b
        out[f] = ne.reshape(len(h), -1).any(axis=1)
    return out


def compare(rec: Recording, host: np.ndarray, target: np.ndarray) -> dict:
    """Largest differences target - host per output, where they first appear, and the verdict."""
    n = min(len(host), len(target))
    h, g = host[:n], target[:n]
    p = rec.phases
    d_duty = np.abs(g["duty"][:, :p].astype(np.float64) - h["duty"][:, :p])
    d_th = np.abs(_wrap(g["theta_e"].astype(np.float64) - h["theta_e"]))
    w_scale = max(1.0, float(np.max(np.abs(h["w_e"]))))
    d_w = np.abs(g["w_e"].astype(np.float64) - h["w_e"]) / w_scale
    d_st = g["stage"] != h["stage"]
    ne = _unequal(h, g, p)
    differ = np.any(list(ne.values()), axis=0) if ne else np.zeros(n, bool)
    first = int(np.argmax(differ)) if differ.any() else None
    first_fields = [f for f, v in ne.items() if first is not None and v[first]]
    res = {
        "steps": n, "steps_host": len(host), "steps_target": len(target),
        "identical_steps": int(n - differ.sum()),
        "first_difference": first, "first_fields": first_fields,
        "max_duty": float(d_duty.max(initial=0.0)), "max_theta_e": float(d_th.max(initial=0.0)),
        "max_w_e_rel": float(d_w.max(initial=0.0)), "stage_mismatches": int(d_st.sum()),
        "at_max_duty": int(np.argmax(d_duty.max(axis=1))) if n else None,
    }
    res["within"] = bool(n == len(host) == len(target) and res["max_duty"] <= TOLERANCE["duty"]
                         and res["max_theta_e"] <= TOLERANCE["theta_e"] and res["max_w_e_rel"] <= TOLERANCE["w_e_rel"]
                         and res["stage_mismatches"] <= TOLERANCE["stage"])
    return res


# A step's instructions by what runs: the library's trigonometry (fs_cis:
# cos and sin of one angle from one argument reduction; fs_atan2f), and
# libm's share:
# newlib's sinf/cosf (their own argument reduction in every call) and
# fmaxf/fminf (calls that classify both arguments; an FPv4 has no VMAXNM),
# which csrc/control no longer calls (nonzero here would say one came back),
# and the rest of libm.
LIBM_GROUPS = {"fs_cis, fs_atan2f": ("fs_cis", "cis_far", "fs_atan2f"),
               "sinf/cosf": ("sinf", "cosf", "__kernel_sinf", "__kernel_cosf", "__ieee754_rem_pio2f", "__kernel_rem_pio2f"),
               "fmaxf/fminf": ("fmaxf", "fminf", "__fpclassifyf"),
               "other libm": ("atanf", "atan2f", "__ieee754_atan2f", "expf", "__ieee754_expf", "expm1f", "logf",
                              "__ieee754_logf", "fmodf", "__ieee754_fmodf", "sqrtf", "__ieee754_sqrtf", "floorf", "ceilf",
                              "tanf", "__kernel_tanf", "tanhf", "finitef", "scalbnf")}


def cost_groups(profile: dict[str, float]) -> dict[str, float]:
    out = {g: sum(profile.get(f, 0.0) for f in fs) for g, fs in LIBM_GROUPS.items()}
    out["the drive's own code"] = sum(profile.values()) - sum(out.values())
    return out


def run_mode(t: dict, b: Builds, mode: str, duration: float | None = None, profile: bool = False) -> dict:
    rec = record(b, mode, duration)
    host = replay_host(rec)
    ffi, _ = _core()
    deterministic = bool(len(host) == len(rec.outs) and not np.any(list(_unequal(host, rec.outs, rec.phases).values())))
    target, info = replay_target(t, b, rec, profile=profile)
    Ts = float(np.frombuffer(rec.cfg[16:20], "<f4")[0])
    until = COMPARE_UNTIL.get(mode)
    n_cmp = min(len(host), int(round(until / Ts))) if until else len(host)
    cmp = compare(rec, host[:n_cmp], target[:n_cmp])
    cmp["until_s"] = until
    if until:
        whole = compare(rec, host, target)
        cmp["after"] = {k: whole[k] for k in ("max_duty", "max_theta_e", "max_w_e_rel", "stage_mismatches")}
    ins = info["insns"]   # binned by the target's own stage: the path it executed
    return {
        "mode": mode, "scenario": rec.scenario, "duration_s": float(len(host) * Ts),
        "sim_status": rec.status, "host_replay_equals_closed_loop": deterministic,
        "compare": cmp,
        "insns": _insn_stats(ins, target["stage"][: len(ins)]),
        "stack_used": info["stack_used"], "sizeof_fs_drive": info["sizeof_fs_drive"], "qemu_wall_s": info["wall_s"],
        **({"profile": dict(list(info["profile"].items())[:20]), "cost_groups": cost_groups(info["profile"])}
           if profile else {}),
    }


def _host_metrics(sc, trace: np.ndarray, status: str, wall: float) -> dict:
    from fullspeed.sim.metrics import compute_metrics
    from fullspeed.sim import CHANNELS, Result
    t_end = float(trace[-1, 0]) if len(trace) else 0.0
    res = Result(sc, dict(zip(CHANNELS, trace.T)), status, None if status == "done" else t_end, wall, t_end)
    return compute_metrics(res)


def closed_loop(t: dict, b: Builds, mode: str, duration: float | None = None, timeout: float = 600.0,
                scenario: str | None = None) -> dict:
    """The plant on the host, fs_drive_step on the emulated target, one sample per
    exchange over two FIFOs; the same run with the host's drive step beside it.
    On the mode's catalog scenario, or on `scenario` (a name or a TOML file)."""
    from fullspeed.design.scenario import load_scenario
    from fullspeed.sim import build_config
    ffi, _ = _core()
    scenario = scenario or MODES[mode][0]
    sc = load_scenario(scenario, overrides={"trace": {"decimation": 1}})
    dur = min(duration, sc.duration) if duration else sc.duration   # the whole scenario by default
    cfg, _keep = build_config(sc)
    cfg_bytes = bytes(ffi.buffer(ffi.addressof(cfg, "drive")))
    t0 = time.perf_counter()
    *_, trace_h, status_h, _sc = simulate(b, scenario, dur, record=False)
    wall_h = time.perf_counter() - t0
    with tempfile.TemporaryDirectory(prefix="fs-pil-loop-") as tmp:
        tmp = Path(tmp)
        os.mkfifo(tmp / "pil_in.bin")
        os.mkfifo(tmp / "pil_out.bin")
        counts, hist = tmp / "counts.bin", tmp / "hist.bin"
        qemu = subprocess.Popen(_qemu_cmd(t, b, counts, hist), cwd=tmp, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        timer = threading.Timer(timeout, qemu.kill)
        timer.start()
        try:
            fd_w = os.open(tmp / "pil_in.bin", os.O_WRONLY)
            fd_r = os.open(tmp / "pil_out.bin", os.O_RDONLY)
            os.write(fd_w, _in_header(0xFFFFFFFF, 1) + cfg_bytes)
            t0 = time.perf_counter()
            *_, trace_t, status_t, _sc = simulate(b, scenario, dur, remote=(fd_w, fd_r), record=False)
            wall_t = time.perf_counter() - t0
            os.close(fd_w)
            rest = b""
            while chunk := os.read(fd_r, 65536):
                rest += chunk
            os.close(fd_r)
            qemu.wait(timeout=30)
            ins = _step_counts(counts.read_bytes(), len(trace_t))
            prof = _profile(t, b, np.frombuffer(hist.read_bytes(), dtype="<u8"), max(len(ins), 1))
        finally:
            timer.cancel()
            if qemu.poll() is None:
                qemu.kill()
    info = _out_trailer(rest, f"{mode} closed loop") if status_t != "target lost" else {"steps": 0}
    m_h = _host_metrics(sc, trace_h, status_h, wall_h)
    m_t = _host_metrics(sc, trace_t, status_t, wall_t)
    keys = ["stop_reason", "speed_rpm", "speed_error_pct", "i_d_error_rms", "i_q_error_rms", "T_e_mean", "T_e_pp",
            "i_phase_max", "lock_lost_at", "recoveries", "true_loss_at"]
    pick = lambda m: {k: m.get(k) for k in keys} | {"theta_err_deg": m.get("theta_err_deg"), "est_err_deg": m.get("est_err_deg")}  # noqa: E731
    n = min(len(trace_h), len(trace_t))
    col = {c: k for k, c in enumerate(__import__("fullspeed.sim", fromlist=["CHANNELS"]).CHANNELS)}
    dw = np.abs(trace_t[:n, col["w_m"]] - trace_h[:n, col["w_m"]])
    dth = np.abs(_wrap(trace_t[:n, col["theta_err"]] - trace_h[:n, col["theta_err"]]))
    return {"mode": mode, "scenario": scenario, "duration_s": dur, "steps_target": info["steps"],
            "insns": _insn_stats(ins, trace_t[: len(ins), col["stage"]].astype(int)),
            "profile": dict(list(prof.items())[:20]), "cost_groups": cost_groups(prof),
            "host": pick(m_h), "target": pick(m_t), "wall_s": {"host": wall_h, "target_in_loop": wall_t},
            "max_w_m_diff_rpm": float(dw.max(initial=0.0) * 60 / (2 * np.pi)),
            "max_theta_err_diff_deg": float(np.degrees(dth.max(initial=0.0))),
            "stages_host": _stages(trace_h[:, col["stage"]]), "stages_target": _stages(trace_t[:, col["stage"]]),
            "steady_window": m_h.get("steady_window")}


def _stages(stage: np.ndarray) -> list[int]:
    """The sequence of operating stages visited (fs_drive_stage), repeats removed."""
    s = stage.astype(int)
    return [int(x) for k, x in enumerate(s) if k == 0 or x != s[k - 1]]


PROBE = ["sinf", "cosf", "atan2f", "expf", "expm1f", "logf", "sqrtf", "tanhf", "atanf", "fmodf", "tanf", "x*y+y",
         "fs_cosf", "fs_sinf", "fs_atan2f"]


def libm_probe(t: dict, b: Builds, n: int = 20000, seed: int = 1) -> dict:
    """How often the target's float libm (newlib) differs from the host's (glibc),
    per function, on arguments like the drive's (angles within +-4 rad, exponents
    within +-4), in units in the last place. x*y+y is the control: basic
    arithmetic, IEEE binary32 on both, never contracted to a fused multiply-add;
    so are fs_cosf, fs_sinf and fs_atan2f, the library's trigonometry, which
    the drive calls instead of libm's."""
    import ctypes
    import ctypes.util
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-4.0, 4.0, size=(n, 2)).astype(np.float32)
    elf = b.work / "libm_probe.elf"
    if not elf.is_file():   # built aside and renamed into place: b.work is shared (COMPLETE)
        with tempfile.TemporaryDirectory(prefix="probe-", dir=b.work) as st:
            objs = []
            for src in (HERE / "startup.c", HERE / "libm_probe.c", CSRC / "control" / "fs_transforms.c"):
                o = Path(st) / (src.stem + ".probe.o")
                _run([t["gcc"], *fw.CFLAGS, f"-I{CSRC / 'control'}", "-c", str(src), "-o", str(o)], f"compiling {src.name}")
                objs.append(o)
            _link_image(t, objs, Path(st) / "probe.elf", "linking the libm probe")
            os.replace(f"{st}/probe.elf", elf)
    with tempfile.TemporaryDirectory(prefix="fs-pil-probe-") as tmp:
        (Path(tmp) / "probe_in.bin").write_bytes(xy.tobytes())
        cmd = [t["qemu"], "-M", "mps2-an386", "-display", "none", "-monitor", "none", "-serial", "none",
               "-semihosting-config", "enable=on,target=native", "-kernel", str(elf)]
        _run(cmd, "the libm probe", cwd=tmp, timeout=120)
        tgt = np.frombuffer((Path(tmp) / "probe_out.bin").read_bytes(), dtype="<f4").reshape(n, len(PROBE))
    m = ctypes.CDLL(ctypes.util.find_library("m"))
    f1 = ctypes.c_float

    def fn(name, argc):
        f = getattr(m, name)
        f.restype, f.argtypes = f1, [f1] * argc
        return f
    s, c, a2, e, em, lg, sq, th, at, fm, tn = (fn(k, 2 if k in ("atan2f", "fmodf") else 1) for k in PROBE[:11])
    host = np.empty_like(tgt)
    for k, (x, y) in enumerate(xy.astype(np.float64)):
        host[k, :12] = [s(x), c(x), a2(y, x), e(y), em(y), lg(abs(float(np.float32(x))) + float(np.float32(1e-3))),
                        sq(abs(x)), th(y), at(x), fm(x, float(np.float32(6.2831853))), tn(float(np.float32(0.4) * np.float32(x))),
                        np.float32(np.float32(x) * np.float32(y)) + np.float32(y)]
    xffi, xlib = _host_lib(b)
    xy32, own = np.ascontiguousarray(xy), np.empty(3 * n, dtype=np.float32)
    xlib.pil_trig(xffi.cast("float *", xy32.ctypes.data), xffi.cast("float *", own.ctypes.data), n)
    host[:, 12:15] = own.reshape(n, 3)
    ulp = np.abs(tgt.view("<i4").astype(np.int64) - host.view("<i4").astype(np.int64))
    return {name: {"differ_pct": float(100.0 * np.mean(ulp[:, j] != 0)), "max_ulp": int(ulp[:, j].max())}
            for j, name in enumerate(PROBE)}


def fused_in_image(t: dict, b: Builds) -> dict[str, int]:
    """Functions of the PIL image holding fused multiply-adds (vfma, vfms, vfnma, vfnms)."""
    out: dict[str, int] = {}
    fn = None
    for ln in _run([t["objdump"], "-d", str(b.target)], "objdump").stdout.splitlines():
        if ln.endswith(">:") and " <" in ln:
            fn = ln.split("<", 1)[1][:-2]
        elif fn and "\tvf" in ln and any(op in ln for op in ("vfma", "vfms", "vfnma", "vfnms")):
            out[fn] = out.get(fn, 0) + 1
    return out


F_CPU = 168e6
F_ISR = (10e3, 20e3)
# Issue 23's goal, the blended sensorless step in <= 2,500 Thumb-2
# instructions, read as the mean over the blended run closed through the
# emulator (firmware build): what the controller costs the processor, as
# VESC's FOC interrupt (some 4,200 cycles at 168 MHz) is a typical time.
# The interrupt's deadline is the worst step's: the report gives the
# largest, its share of the budget at 20 kHz, and the cycles per
# instruction that budget leaves it (QEMU counts instructions, not cycles).
GOAL_BLEND = 2500
# The closed loop through the emulator against the host's, on the metrics of
# the run: what "the same" means. The runs part after the first differing
# ulp (libm) and meet again where the loops hold them; the steady speed error
# and the angle errors agree to a few thousandths.
LOOP_TOLERANCE = {"speed_error_pct": 0.01, "theta_err_mean_deg": 0.05, "i_q_error_rms_rel": 0.01}


def blend_goal(insns: dict, what: str) -> dict:
    """The goal on the blended run's instruction statistics (_insn_stats): met on
    the mean; the largest step against the 20 kHz budget."""
    budget = F_CPU / F_ISR[1]
    return {"insns_blend": GOAL_BLEND, "read_as": "mean", "mean": insns["mean"], "max": insns["max"],
            "met": insns["mean"] <= GOAL_BLEND, "from": what,
            "max_of_budget_20k": insns["max"] / budget, "cpi_left_20k": budget / insns["max"],
            "per_stage": insns["per_stage"]}


def loop_verdict(r: dict) -> dict:
    h, g = r["host"], r["target"]
    checks = {"same stages": r["stages_host"] == r["stages_target"],
              # agreement of the target with the host: the same stop on both sides, an identical
              # trip included (the run's own outcome is printed beside the verdict, not judged here)
              "same stop": h["stop_reason"] == g["stop_reason"],
              "same lock": h["lock_lost_at"] == g["lock_lost_at"] and h["recoveries"] == g["recoveries"]}
    if h.get("speed_error_pct") is not None and g.get("speed_error_pct") is not None:
        checks["speed error"] = abs(h["speed_error_pct"] - g["speed_error_pct"]) <= LOOP_TOLERANCE["speed_error_pct"]
    if h.get("theta_err_deg") and g.get("theta_err_deg"):
        checks["angle error"] = abs(h["theta_err_deg"]["mean"] - g["theta_err_deg"]["mean"]) <= LOOP_TOLERANCE["theta_err_mean_deg"]
    if h.get("i_q_error_rms"):
        checks["i_q error"] = abs(h["i_q_error_rms"] - g["i_q_error_rms"]) <= LOOP_TOLERANCE["i_q_error_rms_rel"] * h["i_q_error_rms"]
    return {"within": all(checks.values()), "checks": checks}


def firmware_leaves_out(scenario: str) -> str | None:
    """What of a scenario the firmware's build (bench/firmware.py's OPTIONS)
    leaves out, or None: its drive would be refused there at init (and the
    export's source fails that build: workflows/export.capabilities)."""
    from fullspeed.design.scenario import load_scenario
    from fullspeed.workflows.export import capabilities
    off = {o[2:].split("=")[0] for o in fw.OPTIONS if o.endswith("=0")}
    out = [what for macro, what in capabilities(load_scenario(scenario)) if macro in off]
    return ", ".join(out) or None


def pil_report(modes: list[str] | None = None, duration: float | None = None, loop: str | None = "blend",
               loop_duration: float | None = None, work: Path | None = None, scenario: str | None = None) -> dict:
    """Replay every mode, close the loop for one (on its catalog scenario, or on
    `scenario`: a user's, which is then also run on the firmware's build when
    that build keeps what it uses), probe libm; {"status": ok | fail | skipped, ...}."""
    base = {"tolerance": TOLERANCE, "loop_tolerance": LOOP_TOLERANCE, "f_cpu": F_CPU}
    t = tools()
    if t is None:
        return {**base, "status": "skipped", "reason": f"PIL skipped: arm-none-eabi-gcc with newlib, qemu-system-arm or cc not found (install: {INSTALL_HINT})"}
    work = Path(work) if work else Path(tempfile.gettempdir()) / "fullspeed-pil"
    try:
        b = build(t, work)
        rep = {**base, "status": "ok", "reason": None, "image": fw.sizes(t, [b.target])[b.target.name],
               "static_stack_fs_drive_step": static_stack(t, b), "modes": {}}
        for m in modes or list(MODES):
            rep["modes"][m] = run_mode(t, b, m, duration, profile=m == "encoder")
        if loop or scenario:
            rep["closed_loop"] = closed_loop(t, b, loop, loop_duration, scenario=scenario)
            rep["closed_loop"]["verdict"] = loop_verdict(rep["closed_loop"])
        left_out = firmware_leaves_out(scenario) if scenario else None
        if left_out:
            rep["firmware_build"] = {"skipped": f"the firmware's build leaves out {left_out}, which {scenario} uses"}
        elif scenario or loop == "blend":
            # the cost as the firmware builds it (bench/firmware.py: its options and link-time
            # optimisation, which inlines across files; the painted stack means nothing there)
            bf = build(t, work, extra_flags=[*fw.LTO, *fw.OPTIONS])
            lf = closed_loop(t, bf, loop, loop_duration, scenario=scenario)
            rep["firmware_build"] = {"flags": [*fw.LTO, *fw.OPTIONS], "image": fw.sizes(t, [bf.target])[bf.target.name],
                                     "insns": lf["insns"], "cost_groups": lf["cost_groups"], "profile": lf["profile"],
                                     "verdict": loop_verdict(lf)}
        rep["libm"] = libm_probe(t, b)
        rep["fused_multiply_add"] = fused_in_image(t, b)
    except (PilError, subprocess.TimeoutExpired, OSError) as e:
        return {**base, "status": "fail", "reason": str(e).splitlines()[0]}
    bad = [m for m, r in rep["modes"].items() if not r["compare"]["within"]]
    if "closed_loop" in rep and not rep["closed_loop"]["verdict"]["within"]:
        bad.append(f"closed loop ({scenario or loop})")
    # the blend's cost from the loop closed through the emulator (every stage, on a true trajectory),
    # judged on the firmware's build where it ran (what ships), else on the PIL image's
    # (claim B-PIL's goal is on the catalog's blended run: not judged on a user's scenario)
    src, what = ((None, None) if scenario else
                 (rep["firmware_build"], "firmware build, closed loop") if "firmware_build" in rep else
                 (rep.get("closed_loop"), "closed loop") if loop == "blend" else (rep["modes"].get("blend"), "replay"))
    if src:
        rep["goal"] = blend_goal(src["insns"], what)
    if "verdict" in rep.get("firmware_build", {}) and not rep["firmware_build"]["verdict"]["within"]:
        bad.append("closed loop (firmware build)")
    if bad:
        rep["status"], rep["reason"] = "fail", "outside the stated tolerance: " + ", ".join(bad)
    return rep


STAGES = {0: "open", 1: "sensor", 2: "polarity", 3: "start", 4: "injection", 5: "blend", 6: "back-EMF",
          7: "flux-weak.", 8: "recovery"}


def format_report(rep: dict) -> str:
    if rep["status"] == "skipped":
        return rep["reason"]
    if "modes" not in rep:
        return f"PIL FAIL: {rep['reason']}"
    im = rep["image"]
    # the flags that shape the code (not the warnings, the debug info or the sections)
    flags = " ".join(f for f in fw.CFLAGS if not f.startswith("-W") and f not in ("-g", "-ffunction-sections", "-fdata-sections"))
    lines = [f"PIL: fs_drive_step on QEMU mps2-an386 (Cortex-M4F), arm-none-eabi-gcc {flags}; "
             f"image text {im['text']} B, data {im['data']} B, bss {im['bss']} B",
             f"  instructions per step counted by a TCG plugin (exact; not cycles). Budget at {F_CPU / 1e6:.0f} MHz: "
             + ", ".join(f"{F_CPU / f:.0f} cycles at {f / 1e3:.0f} kHz" for f in F_ISR),
             "  (insn mean and max over every replayed step; the differences and `identical` over the compared"
             " ones, `compared` of them, within the replay window)",
             f"  {'mode':<9}{'compared':>9}{'insn mean':>10}{'max':>6}{'% of 20k':>9}{'stack':>6}{'RAM':>6}"
             f"{'max |d duty|':>13}{'max |d th|':>11}{'identical':>10}  replay window"]
    for m, r in rep["modes"].items():
        c, i = r["compare"], r["insns"]
        win = f"0-{c['until_s']:g} s (then: duty {c['after']['max_duty']:.2g})" if c.get("until_s") else "whole"
        lines.append(f"  {m:<9}{c['steps']:>9}{i['mean']:>10.0f}{i['max']:>6}{100 * i['max'] / (F_CPU / F_ISR[1]):>8.0f}%"
                     f"{r['stack_used']:>6}{r['sizeof_fs_drive']:>6}{c['max_duty']:>13.2g}{c['max_theta_e']:>11.2g}"
                     f"{100 * c['identical_steps'] / max(c['steps'], 1):>9.0f}%  {win}"
                     + ("" if c["within"] else "  OUTSIDE TOLERANCE"))
    if "goal" in rep:
        per = ", ".join(f"{STAGES.get(k, k)} {v['mean']:.0f}/{v['max']}" for k, v in sorted(rep["goal"]["per_stage"].items()))
        lines.append(f"  blend per stage (mean/max instructions, {rep['goal']['from']}): {per}")
    looped = (rep.get("closed_loop") or {}).get("scenario", "blend")
    for m, r in [*rep["modes"].items(), (f"{looped} (closed loop)", rep.get("closed_loop") or {}),
                 (f"{looped} (firmware build " + " ".join(rep.get("firmware_build", {}).get("flags", [])) + ")",
                  rep.get("firmware_build") or {})]:
        if "cost_groups" in r:
            top = ", ".join(f"{k} {v:.0f}" for k, v in list(r["profile"].items())[:8])
            lines.append(f"  {m}, instructions per step by what runs: "
                         + ", ".join(f"{k} {v:.0f}" for k, v in r["cost_groups"].items()) + f"; largest: {top}")
    lines.append(f"  stack: measured (painted) above; static call graph from fs_drive_step (-fstack-usage): "
                 f"{rep['static_stack_fs_drive_step']} B")
    lm = rep["libm"]
    lines.append("  where differences come from: target libm (newlib) vs host (glibc), % of arguments differing (max ulp): "
                 + ", ".join(f"{k} {v['differ_pct']:.1f}% ({v['max_ulp']})" for k, v in lm.items() if not k.startswith("fs_"))
                 + "; the drive's trigonometry (fs_cis, not libm's): "
                 + ", ".join(f"{k} {v['differ_pct']:.1f}%" for k, v in lm.items() if k.startswith("fs_")))
    fused = rep["fused_multiply_add"]
    lines.append(f"  fused multiply-add in the image only in: {', '.join(sorted(fused)) or 'nowhere'} "
                 "(csrc/control is ISO C: -std=c11 implies -ffp-contract=off)")
    if "goal" in rep:
        g = rep["goal"]
        lines.append(f"goal: blended step <= {g['insns_blend']} instructions, the mean over the run ({g['from']}): "
                     f"mean {g['mean']:.0f}: {'met' if g['met'] else 'NOT met'}; the largest step {g['max']} is "
                     f"{100 * g['max_of_budget_20k']:.0f} % of the {F_CPU / F_ISR[1]:.0f} cycles at {F_ISR[1] / 1e3:.0f} kHz "
                     f"(it fits at up to {g['cpi_left_20k']:.1f} cycles per instruction)")
    fb = rep.get("firmware_build") or {}
    if "goal" not in rep and ("insns" in fb or "skipped" in fb):   # a user's scenario: its cost, no claim to judge
        if "skipped" in fb:
            lines.append(f"firmware build: not run ({fb['skipped']})")
        else:
            i = fb["insns"]
            lines.append(f"cost on the firmware's build, closed loop on {looped}: mean {i['mean']:.0f}, largest {i['max']} "
                         f"instructions per step: {100 * i['max'] / (F_CPU / F_ISR[1]):.0f} % of the "
                         f"{F_CPU / F_ISR[1]:.0f} cycles at {F_ISR[1] / 1e3:.0f} kHz at one cycle per instruction")
    if "closed_loop" in rep:
        r = rep["closed_loop"]
        lines.append(f"closed loop through the emulator: {r['scenario']} {r['duration_s']:g} s, {r['steps_target']} exchanges "
                     f"({r['wall_s']['target_in_loop']:.1f} s wall; host alone {r['wall_s']['host']:.1f} s)")
        for k in ("speed_error_pct", "i_d_error_rms", "i_q_error_rms", "T_e_pp", "i_phase_max"):
            if r["host"].get(k) is not None:
                lines.append(f"  {k:<16} host {r['host'][k]:>10.5g}   target in the loop {r['target'][k]:>10.5g}")
        for k in ("theta_err_deg",):
            if r["host"].get(k):
                lines.append(f"  {k} mean/pp  host {r['host'][k]['mean']:.4f}/{r['host'][k]['pp']:.4f}   "
                             f"target {r['target'][k]['mean']:.4f}/{r['target'][k]['pp']:.4f}")
        lines.append(f"  stop: host {r['host']['stop_reason']}, target in the loop {r['target']['stop_reason']}")
        lines.append(f"  stages: host {r['stages_host']}, target {r['stages_target']}; largest trajectory differences: "
                     f"speed {r['max_w_m_diff_rpm']:.3g} rpm, angle error {r['max_theta_err_diff_deg']:.3g} deg")
        v = r["verdict"]
        lines.append(f"  verdict: {'within' if v['within'] else 'OUTSIDE'} tolerance ({', '.join(k for k, ok in v['checks'].items() if ok)} agree)")
    if rep["status"] == "fail":
        lines.append(f"FAIL: {rep['reason']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modes", default=",".join(MODES), help="comma-separated modes (default all)")
    ap.add_argument("--duration", type=float, help="cap each replay at this many seconds")
    ap.add_argument("--loop", default="blend", help="the mode whose loop is closed through the emulator ('' for none)")
    ap.add_argument("--loop-duration", type=float, help="s (default: the whole scenario)")
    ap.add_argument("--scenario", help="close the loop on this scenario (a catalog name or your TOML) instead of "
                                       "the --loop mode's; its cost is also measured on the firmware's build")
    ap.add_argument("--out", type=Path, help="write pil.json here")
    a = ap.parse_args(argv)
    modes = [m for m in a.modes.split(",") if m]
    bad = [m for m in modes + ([a.loop] if a.loop else []) if m not in MODES]
    if bad:
        print(f"--modes/--loop = {','.join(bad)}: must be among {', '.join(MODES)}", file=sys.stderr)
        return 2
    from fullspeed.design.scenario import load_scenario
    from fullspeed.model.errors import ConfigError
    from fullspeed.model.files import out_folder
    for opt, v in (("--duration", a.duration), ("--loop-duration", a.loop_duration)):
        if v is not None and not (math.isfinite(v) and v > 0):
            print(f"{opt} = {v}: must be a number of seconds > 0", file=sys.stderr)
            return 2
    for opt, check in (("--scenario", a.scenario and (lambda: load_scenario(a.scenario, overrides={"trace": {"decimation": 1}}))),
                       ("--out", a.out and (lambda: out_folder(a.out)))):
        try:   # refused here, in one line, before anything is built (the scenario as closed_loop loads it)
            if check:
                check()
        except ConfigError as e:   # it names the field; the scenario's is a field of the scenario
            print(f"{opt}: {e}" if opt == "--scenario" else str(e), file=sys.stderr)
            return 2
    rep = pil_report(modes, a.duration, a.loop or None, a.loop_duration, scenario=a.scenario)
    print(format_report(rep))
    if a.out:
        from fullspeed.model.files import write_atomic
        write_atomic(a.out / "pil.json", json.dumps(rep, indent=2, default=str))   # a temporary name, renamed
    return 1 if rep["status"] == "fail" else 0


if __name__ == "__main__":
    sys.exit(main())
