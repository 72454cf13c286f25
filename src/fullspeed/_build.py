"""cffi builder for the C core (fullspeed._core).

The cdef is read from the public headers themselves, with preprocessor lines
removed, so the C structs and their Python view cannot drift apart.
"""
from __future__ import annotations

import os
import platform
import re
import subprocess
import sysconfig
from pathlib import Path

from cffi import FFI

ROOT = Path(__file__).resolve().parents[2]
CSRC = ROOT / "csrc"

# Public headers in dependency order: these form the cdef.
HEADERS = [
    "control/fs_types.h",
    "control/fs_transforms.h",
    "control/fs_fluxmap.h",
    "control/fs_pi.h",
    "control/fs_svpwm.h",
    "control/fs_vsd.h",
    "control/fs_pwm5.h",
    "control/fs_pll.h",
    "control/fs_lpf.h",
    "control/fs_motion_obs.h",   # the SMO's tracking form holds one
    "control/fs_smo.h",
    "control/fs_current_ctrl.h",
    "control/fs_dtcomp.h",
    "control/fs_xyctrl.h",
    "control/fs_speed_ctrl.h",
    "control/fs_mtpa.h",
    "control/fs_param_adapt.h",
    "control/fs_fw.h",
    "control/fs_fwmap.h",
    "control/fs_srff.h",
    "control/fs_hfi_filter.h",
    "control/fs_blend.h",
    "control/fs_xcomp.h",
    "control/fs_hfi.h",
    "control/fs_swvi.h",
    "control/fs_polarity.h",
    "control/fs_motion_test.h",
    "control/fs_if_start.h",
    "control/fs_lock.h",
    "control/fs_monitor.h",
    "control/fs_imc.h",
    "control/fs_mapid.h",
    "control/fs_ident.h",
    "control/fs_drive.h",
    "plant/fs_losses.h",
    "plant/fs_magnetic.h",
    "plant/fs_pmsm.h",
    "plant/fs_thermal.h",
    "plant/fs_inverter.h",
    "plant/fs_grid.h",
    "sim/fs_sim.h",
    "sim/fs_pulse_peak.h",
]
SOURCE_DIRS = ["control", "plant", "sim"]


def cdef_text() -> str:
    out = []
    for h in HEADERS:
        text = (CSRC / h).read_text()
        text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
        lines = [ln for ln in text.splitlines() if not ln.lstrip().startswith("#")]
        out.append("\n".join(lines))
    text = "\n".join(out)
    # cffi wants array sizes it can evaluate: the enum constant becomes `...`
    return re.sub(r"\[FS_[A-Z_]+\]", "[...]", text)


def sources() -> list[str]:
    files = []
    for d in SOURCE_DIRS:
        files += sorted(str((CSRC / d / f.name).relative_to(ROOT)) for f in (CSRC / d).glob("*.c"))
    return files


def is_gcc() -> bool:
    """The C compiler setuptools calls (CC, else Python's own) is GCC: clang,
    Apple's cc among them, takes none of GCC's --param."""
    cc = (os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc").split()
    try:
        out = subprocess.run([cc[0], "--version"], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return False
    return "Free Software Foundation" in out and "clang" not in out


# GCC's inliner allowed functions of up to 200 instructions not declared inline (30 at -O3) and the library
# 400 % growth (40 %). At 100 and 200 % (97a3c88), the drive's step then takes the small functions it calls a few times a sample into
# its body (fs_cis, nine calls a step, fs_atan2f, the motion observer's step, the modulation), where each
# call had spilled the float registers the SysV ABI leaves to the caller. On the wall bench's averaged
# example the step's wall time 240 -> 219 ns a sample (rdtsc around it, GCC 12) and the C loop about 4 %
# faster; inlining changes no arithmetic (no contraction, no reassociation): bench/trace_hashes.py 45 of 45
# the same to the bit. Either parameter alone did not move the step (the growth limit stopped the first).
# At 200 and 400 %, with the vectorizer off (below), the runner's loop also takes the period's advance and
# the overcurrent check's phase currents, the step the lock residual (with the loss-of-lock monitor) and
# the current references the MTPA: 59 fewer instructions a sample and the C loop 5.00 -> 4.80 ms on the
# averaged example (the least of 20 runs in each of 16 alternated processes), the blended drive's example
# 15.0 -> 14.3 ms, a zoo machine's run the same (110.8 -> 111.1 ms); 45 of 45 traces the same to the bit.
INLINING = ["--param=max-inline-insns-auto=200", "--param=inline-unit-growth=400"] if is_gcc() else []
# The runner clears the drive's output struct (fs_drive_out, 160 B) before every step (the fields a mode
# leaves unwritten read 0); GCC's generic x86-64 tuning expands that memset as `rep stosq`, whose start-up
# costs tens of cycles a sample on the machine measured (perf: a tenth of fs_sim_run_cols's samples on that
# one instruction). Memsets of known size up to 256 B as a loop of 16-byte stores instead, larger ones the
# library's: the loop 378.7 -> 370.8 ns a sample on the wall bench's averaged example (the least of 20 runs
# in each of 8 alternated processes); the same bytes, so no output moves (bench/trace_hashes.py 45 of 45).
# x86 only (the option is the x86 back end's); portable across x86-64 machines (no instruction set beyond SSE2).
STRINGOPS = (["-mmemset-strategy=vector_loop:256:noalign,libcall:-1:noalign"]
             if is_gcc() and platform.machine() in ("x86_64", "AMD64") else [])

ffibuilder = FFI()
ffibuilder.cdef(cdef_text())
ffibuilder.set_source(
    "fullspeed._core",
    "".join(f'#include "{h}"\n' for h in HEADERS),
    sources=sources(),
    include_dirs=[str(CSRC)],
    # -O3: 5.6 % fewer instructions than -O2 in a zoo run's loop (callgrind, fs_sim_run_cols: 1.529 against
    # 1.620 G), the outputs the same to the bit (bench/trace_hashes.py, 45 of 45: -std=c99 keeps the
    # contraction into FMA off, and nothing here allows reassociation). Link-time optimisation with the
    # library's own calls bound inside it (-fno-semantic-interposition: the drive's and the plant's units
    # call each other across files, which -fPIC alone leaves as calls through the PLT): 72 M fewer
    # instructions over a zoo run (2.709 against 2.781 G, the process's callgrind total; about 5 % of
    # the core's), 45 of 45 the same to the bit; the contraction stated off for the link's code generation too.
    # No vectorizer (-fno-tree-vectorize: neither GCC's loop nor its basic-block (SLP) vectorizer): this
    # core's loops run over 3 to 15 phases or states and its structs are written a field at a time, where
    # -O3's vector code (alias checks, peeled epilogues, packing scalars into vectors and out again) does
    # more than the scalar code it replaces. On the wall bench's example the C loop 5.60 -> 5.05 ms averaged
    # and 10.75 -> 8.77 ms switching (the least of 20 runs in each of 14 and 10 alternated processes),
    # 173 fewer instructions a sample averaged (callgrind); without the loop vectorizer alone 5.15 ms, without
    # the SLP one alone 5.39. Vectorizing here reorders no sum (no -ffast-math), so its loss changes no
    # value: bench/trace_hashes.py 45 of 45 the same to the bit. The firmware's build (bench/firmware.py) is
    # its own and keeps its flags.
    extra_compile_args=["-O3", "-std=c99", "-Wall", "-Wextra", "-fno-math-errno", "-ffp-contract=off",
                        "-fno-tree-vectorize", "-fno-semantic-interposition", "-flto", *INLINING, *STRINGOPS],
    extra_link_args=["-O3", "-ffp-contract=off", "-fno-tree-vectorize", "-fno-semantic-interposition", "-flto",
                     *INLINING, *STRINGOPS],
    libraries=["m"],
)

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
