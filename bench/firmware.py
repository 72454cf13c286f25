"""Cross-compile the control library for a Cortex-M4F: its size, and no double precision.

Why: csrc/control is meant to run unchanged on a drive's microcontroller.
A Cortex-M4F has a single-precision FPU only, so one stray double (a `0.5`
literal, `fabs` for `fabsf`) turns into a software-emulated __aeabi_d* call
in the interrupt; and flash is small (the project's goal, issue 4: <= 32 KB
of text for the whole control library). Host builds see neither.

What it does, in a temporary directory (never the source tree):
  - compiles every csrc/control/*.c with CFLAGS below (-Werror=double-promotion:
    an implicit float -> double promotion is already a failure);
  - links the firmware image: firmware/*.c (the configuration exported from
    the beyond-full-range scenario, the integration layer drive_app.c and the
    stand-in board) with the library compiled again with the firmware's
    options (OPTIONS: no matrix converter, five phases, square wave,
    identification, online adaptation, motion test or I/f start; see
    fs_drive.h), newlib-nano, --gc-sections and -lm, so the libm float
    routines that a real image carries are counted;
  - reports text/data/bss (arm-none-eabi-size) of the library objects (summed,
    all options on) and of the image, and which libm functions were linked;
  - FAILS (exit 1, one line naming the symbol or instruction and where) if a
    double-precision operation is in the objects or the image: a double
    soft-float helper (__aeabi_d*, __aeabi_*2d, __*df*), a .f64 instruction,
    or a double libm function (sin, sqrt, fabs, ... where the float one ends in f).
Objects are compiled with -g as well (which does not change the code) so a
finding can name file:line.

The size goal (the image's flash, text + data, <= 32 KB: issue 23, at the
-O2 the drive's instruction counts are measured at) is reported, not
enforced; with --os the same image is linked at -Os as well, for the
flash a size-optimised build needs. Without the toolchain the check is
skipped (exit 0) with one line saying how to install it.

Usage: python bench/firmware.py [--csrc DIR] [--workdir DIR] [--os] [--firmware DIR]
"""
from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CSRC = ROOT / "csrc"
FIRMWARE = ROOT / "firmware"
PREFIX = "arm-none-eabi-"
INSTALL_HINT = "apt-get install gcc-arm-none-eabi libnewlib-arm-none-eabi"
TEXT_GOAL = 32 * 1024
# The firmware's compile-time options (fs_drive.h): a three-phase inverter
# drive on the blend with flux weakening leaves these out (it keeps the
# dead-time compensation on the predicted current, its default while it
# injects: 1,288 B of flash at -O2), and, for a machine known by L_d, L_q,
# psi_f (the catalog's beyond-full-range), the flux map (4.7 kB); the yang2022
# machine's pulses decide its polarity: neither the motion test nor the I/f start.
OPTIONS = ["-DFS_WITH_IMC=0", "-DFS_WITH_FIVE_PHASE=0", "-DFS_WITH_SWVI=0", "-DFS_WITH_IDENT=0", "-DFS_WITH_ADAPT=0",
           "-DFS_WITH_FLUXMAP=0", "-DFS_WITH_MOTION_TEST=0", "-DFS_WITH_IF_START=0"]
# The image is linked with link-time optimisation: at -O2 it inlines the
# single-use static functions across files and drops what no path reaches
# (40,536 B of flash without, 32,160 B with, for the image below as it was
# before it kept FS_WITH_DTCOMP).
LTO = ["-flto"]

CPU_FLAGS = ["-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard"]
# -fno-math-errno as the host's core is built (src/fullspeed/_build.py): the
# drive never reads errno, and without it each sqrtf carries a test and a
# branch to a libm call for a negative argument (VSQRT alone gives its NaN)
CFLAGS = [*CPU_FLAGS, "-O2", "-std=c11", "-fno-math-errno", "-Wall", "-Wextra", "-Wdouble-promotion",
          "-Werror=double-promotion", "-ffunction-sections", "-fdata-sections", "-g"]
LDFLAGS = [*CPU_FLAGS, "-O2", "--specs=nano.specs", "--specs=nosys.specs", "-Wl,--gc-sections"]

# Double-precision soft-float helpers: the ARM EABI names (__aeabi_dmul,
# __aeabi_f2d, ...) and libgcc's (__muldf3, __extendsfdf2, __fixdfsi, ...).
DOUBLE_HELPER = re.compile(r"^__aeabi_(d[a-z0-9]+|[a-z0-9]+2d)$|^__[a-z]+df[a-z0-9]*$")
# The double functions of <math.h> (their float versions end in f), and
# newlib's internal double kernels.
DOUBLE_LIBM = frozenset("""
    sin cos tan asin acos atan atan2 sinh cosh tanh asinh acosh atanh sincos
    exp exp2 expm1 log log2 log10 log1p logb pow sqrt cbrt hypot erf erfc tgamma lgamma
    fabs fmod fmax fmin fdim fma floor ceil round trunc rint nearbyint lround lrint llround llrint
    remainder remquo copysign ldexp frexp modf scalbn scalbln ilogb nextafter
""".split())
DOUBLE_LIBM_INTERNAL = re.compile(r"^__(ieee754|kernel)_\w*[^f]$")
FUNC_TYPES = set("TtWwUi")  # nm types of code and undefined symbols


class BuildError(Exception):
    """A compile or link that failed; the message is one line."""


def toolchain(prefix: str = PREFIX) -> dict[str, str] | None:
    """Paths of gcc, size, nm, objdump, or None if any (or newlib) is missing."""
    tools = {t: shutil.which(prefix + t) for t in ("gcc", "size", "nm", "objdump")}
    if not all(tools.values()):
        return None
    spec = subprocess.run([tools["gcc"], *CPU_FLAGS, "-print-file-name=nano.specs"],
                          capture_output=True, text=True).stdout.strip()
    if not Path(spec).is_absolute() or not Path(spec).is_file():
        return None  # the compiler without newlib
    return tools


def _run(cmd: list[str], what: str) -> str:
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        err = (res.stderr or res.stdout).strip().splitlines()
        first = next((ln for ln in err if "error" in ln), err[0] if err else f"exit {res.returncode}")
        raise BuildError(f"{what} failed: {first.strip()}")
    return res.stdout


def compile_c(tools: dict, src: Path, obj: Path, include: list[Path] = (), flags: list[str] = CFLAGS) -> Path:
    _run([tools["gcc"], *flags, *(f"-I{d}" for d in include), "-c", str(src), "-o", str(obj)], f"compiling {src.name}")
    return obj


def sizes(tools: dict, files: list[Path]) -> dict[str, dict[str, int]]:
    """text/data/bss per file (Berkeley format of arm-none-eabi-size)."""
    out = _run([tools["size"], "-B", *map(str, files)], "size")
    res = {}
    for line in out.splitlines()[1:]:
        text, data, bss, _dec, _hex, name = line.split(None, 5)
        res[Path(name).name] = {"text": int(text), "data": int(data), "bss": int(bss)}
    return res


def _double_symbol(name: str) -> bool:
    return bool(DOUBLE_HELPER.match(name)) or name in DOUBLE_LIBM or bool(DOUBLE_LIBM_INTERNAL.match(name))


def double_findings(tools: dict, files: list[Path]) -> list[str]:
    """One line per double-precision operation in the objects or images.

    From the disassembly (with relocations and line numbers): .f64 instructions
    and calls of double helpers or functions, each with file:line where the
    debug information has it, else the function. From nm: double symbols
    referenced or defined that the disassembly did not already place.
    """
    findings: list[str] = []
    placed: set[tuple[str, str, str]] = set()  # (file, what, where)

    def add(f: Path, what: str, where: str, text: str) -> None:
        if (f.name, what, where) not in placed:
            placed.add((f.name, what, where))
            findings.append(text)

    loc_re = re.compile(r"^(\S+\.[ch]):(\d+)")
    func_re = re.compile(r"^[0-9a-f]+ <(.+)>:$")
    target_re = re.compile(r"<([A-Za-z_.$][\w.$]*)(?:\+0x[0-9a-f]+)?>|R_ARM_\w+\s+([A-Za-z_][\w.$]*)")
    for f in files:
        func, loc = "?", None
        for line in _run([tools["objdump"], "-d", "-r", "-l", str(f)], f"objdump {f.name}").splitlines():
            if m := func_re.match(line):
                func, loc = m.group(1), None
                continue
            if m := loc_re.match(line):
                loc = f"{Path(m.group(1)).name}:{m.group(2)}"
                continue
            where = f"{loc} in {func}" if loc else f"in {func}"
            if re.search(r"\.f64\b", line):
                insn = " ".join(line.split("\t")[2:]).strip() or line.strip()
                add(f, insn.split()[0], where, f"{f.name}: .f64 instruction '{insn}' {where}")
            for m in target_re.finditer(line):
                sym = m.group(1) or m.group(2)
                if sym != func and _double_symbol(sym):
                    add(f, sym, where, f"{f.name}: calls {sym} {where}")
        seen = {what for name, what, _ in placed if name == f.name}
        for line in _run([tools["nm"], str(f)], f"nm {f.name}").splitlines():
            parts = line.split()
            if len(parts) >= 2 and parts[-2] in FUNC_TYPES and _double_symbol(parts[-1]) and parts[-1] not in seen:
                kind = "references" if parts[-2] in "Uw" else "defines"
                add(f, parts[-1], "", f"{f.name}: {kind} {parts[-1]}")
    return findings


def libm_functions(tools: dict, image: Path, libm: Path) -> tuple[list[str], list[str]]:
    """The functions of libm in the image: public names, and internal ones."""
    def defined(path: Path) -> set[str]:
        out = _run([tools["nm"], "--defined-only", str(path)], f"nm {path.name}")
        return {p[-1] for p in (ln.split() for ln in out.splitlines()) if len(p) == 3 and p[1] in "TW"}
    linked = sorted(defined(libm) & defined(image))
    return [s for s in linked if not s.startswith("_")], [s for s in linked if s.startswith("_")]


def _total(per_file: dict[str, dict[str, int]]) -> dict[str, int]:
    return {k: sum(v[k] for v in per_file.values()) for k in ("text", "data", "bss")}


def _link_image(tools: dict, sources: list[Path], firmware: Path, control: Path, work: Path, opt: str) -> Path:
    """The firmware image (firmware/*.c and the library with OPTIONS, LTO) at -O2 or -Os."""
    o = [f"-{opt}" if f == "-O2" else f for f in CFLAGS]
    trim = work / f"options{'' if opt == 'O2' else '-' + opt}"
    trim.mkdir(exist_ok=True)
    lib_objs = [compile_c(tools, src, trim / (src.stem + ".o"), flags=[*o, *OPTIONS, *LTO]) for src in sources]
    # the firmware's own sources with the library's options: they read fs_drive.h's FS_WITH_* too (an exported
    # configuration checks them, workflows/export.capabilities: one that uses what the build leaves out fails here)
    app_objs = [compile_c(tools, src, trim / ("app_" + src.stem + ".o"), include=[control, Path(firmware)],
                          flags=[*o, *OPTIONS, *LTO])
                for src in sorted(Path(firmware).glob("*.c"))]
    image = work / ("firmware.elf" if opt == "O2" else f"firmware-{opt}.elf")
    _run([tools["gcc"], *[f"-{opt}" if f == "-O2" else f for f in LDFLAGS], *LTO,
          f"-Wl,-Map={image.with_suffix('.map')}", *map(str, lib_objs), *map(str, app_objs),
          "-lm", "-o", str(image)], f"linking the firmware image (-{opt})")
    return image


def firmware_report(csrc: Path = CSRC, workdir: Path | None = None, firmware: Path = FIRMWARE,
                    os_size: bool = False) -> dict:
    """Build and check; returns {"status": "ok" | "fail" | "skipped", "reason", ...}.

    csrc is the directory holding control/. With workdir None the build goes
    to a temporary directory that is removed afterwards. os_size: the image
    linked at -Os too (rep["image_Os"]).
    """
    base = {"flags": CFLAGS, "options": OPTIONS, "ldflags": [*LDFLAGS, "-lm"], "goal": {"max_flash": TEXT_GOAL, "met": None}}
    tools = toolchain()
    if tools is None:
        return {**base, "status": "skipped",
                "reason": f"firmware check skipped: arm-none-eabi-gcc with newlib not found (install: {INSTALL_HINT})"}
    control = Path(csrc) / "control"
    sources = sorted(control.glob("*.c"))
    if not sources:
        return {**base, "status": "fail", "reason": f"no C sources in {control}"}
    with tempfile.TemporaryDirectory(prefix="fs-firmware-") as tmp:
        work = Path(workdir) if workdir is not None else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        objs, errors = [], []
        for src in sources:
            try:
                objs.append(compile_c(tools, src, work / (src.stem + ".o")))
            except BuildError as e:
                errors.append(str(e))
        if errors:
            return {**base, "status": "fail", "reason": errors[0], "errors": errors}
        lib = sizes(tools, objs)
        rep = {**base, "status": "ok", "reason": None, "library": {**_total(lib), "objects": lib}}
        try:
            image = _link_image(tools, sources, firmware, control, work, "O2")
            libm = Path(_run([tools["gcc"], *CPU_FLAGS, "-print-file-name=libm.a"], "locating libm").strip())
            public, internal = libm_functions(tools, image, libm)
            rep["image"] = {**sizes(tools, [image])[image.name], "libm": public, "libm_internal": internal}
            flash = rep["image"]["text"] + rep["image"]["data"]
            rep["goal"] = {"max_flash": TEXT_GOAL, "flash": flash, "met": flash <= TEXT_GOAL}
            if os_size:
                im_os = _link_image(tools, sources, firmware, control, work, "Os")
                sz = sizes(tools, [im_os])[im_os.name]
                rep["image_Os"] = {**sz, "flash": sz["text"] + sz["data"]}
            # the LTO objects hold no machine code: the image is where the firmware's code is checked
            rep["doubles"] = double_findings(tools, [*objs, image])
        except BuildError as e:
            return {**rep, "status": "fail", "reason": str(e)}
    if rep["doubles"]:
        more = f" (and {len(rep['doubles']) - 1} more)" if len(rep["doubles"]) > 1 else ""
        rep["status"], rep["reason"] = "fail", f"double precision: {rep['doubles'][0]}{more}"
    return rep


def format_report(rep: dict) -> str:
    if rep["status"] == "skipped":
        return rep["reason"]
    lines = [f"firmware: Cortex-M4F, arm-none-eabi-gcc {' '.join(rep['flags'])}"]
    if "library" in rep:
        lines.append(f"  {'':<16}{'text':>8}{'data':>8}{'bss':>8}")
        lib = rep["library"]
        lines.append(f"  {'control library':<16}{lib['text']:>8}{lib['data']:>8}{lib['bss']:>8}"
                     f"   sum of {len(lib['objects'])} objects")
    if "image" in rep:
        im = rep["image"]
        lines.append(f"  {'linked image':<16}{im['text']:>8}{im['data']:>8}{im['bss']:>8}"
                     f"   firmware/*.c, {' '.join([*rep['options'], *LTO])}, {' '.join(rep['ldflags'][len(CPU_FLAGS) + 1:])}")
        lines.append(f"  libm linked: {' '.join(im['libm'])} (+ internal: {' '.join(im['libm_internal'])})")
        if "image_Os" in rep:
            io = rep["image_Os"]
            lines.append(f"  {'image at -Os':<16}{io['text']:>8}{io['data']:>8}{io['bss']:>8}   the same, -Os for -O2")
        lines.append("  double precision: " + ("none" if not rep["doubles"] else f"{len(rep['doubles'])} found"))
        lines += [f"    {d}" for d in rep["doubles"]]
    g = rep["goal"]
    if g.get("met") is not None:
        lines.append(f"goal: firmware image flash (text + data) at -O2 {g['flash']} B <= {g['max_flash']} B: "
                     f"{'met' if g['met'] else 'NOT met'}"
                     + (f" (at -Os: {rep['image_Os']['flash']} B)" if "image_Os" in rep else ""))
    if rep["status"] == "fail":
        lines.append(f"FAIL: {rep['reason']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--csrc", type=Path, default=CSRC, help="directory holding control/ (default: the repo's)")
    ap.add_argument("--workdir", type=Path, default=None, help="keep the objects, image and map here")
    ap.add_argument("--os", action="store_true", help="link the image at -Os as well")
    ap.add_argument("--firmware", type=Path, default=FIRMWARE,
                    help="the firmware's sources (default: the repo's firmware/): e.g. a copy of it with your "
                         "`fullspeed export ... --out DIR --name fs_config` in place of fs_config.[ch]")
    a = ap.parse_args(argv)
    if not (a.firmware / "fs_config.c").is_file():
        print(f"--firmware = {a.firmware}: holds no fs_config.c (fullspeed export SCENARIO --out {a.firmware} "
              "--name fs_config writes it)", file=sys.stderr)
        return 2
    rep = firmware_report(a.csrc, a.workdir, firmware=a.firmware, os_size=a.os)
    print(format_report(rep))
    return 1 if rep["status"] == "fail" else 0


if __name__ == "__main__":
    sys.exit(main())
