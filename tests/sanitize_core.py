"""The C core (fullspeed._core) built with AddressSanitizer and
UndefinedBehaviorSanitizer, and Python run on it in a subprocess.

The build reuses the cffi builder's header list, cdef and sources
(src/fullspeed/_build.py) and differs only in the compiler and linker flags;
it goes into a directory of the caller's (tmpdir/fullspeed_san/fullspeed/),
never into src/fullspeed, so the normal _core.abi3.so is left alone.

A Python process cannot load an ASan-instrumented extension unless the ASan
runtime is the first library loaded: `sanitized_env` gives LD_PRELOAD and the
sanitizer options. `python tests/sanitize_core.py run CORE SCRIPT [ARGS...]`
then installs a meta-path finder that resolves `fullspeed._core` (and only
that) to CORE, checks that the loaded module is that file, and runs SCRIPT as
__main__; the rest of fullspeed comes from wherever it is installed (here the
source tree, by the editable install).

    python tests/sanitize_core.py build DIR     # prints the built module's path
"""
from __future__ import annotations

import importlib.abc
import importlib.util
import os
import runpy
import shutil
import subprocess
import sys
from pathlib import Path

MODULE = "fullspeed._core"
SANITIZERS = "address,undefined,float-cast-overflow"
# -fno-wrapv: Python's own CFLAGS (which distutils puts first) carry -fwrapv,
# which would make signed overflow defined and hide it from UBSan; the later
# -O1 likewise overrides their -O3.
CFLAGS = [f"-fsanitize={SANITIZERS}", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer",
          "-fno-wrapv", "-O1", "-g", "-std=c99", "-Wall", "-Wextra", "-fno-math-errno"]
LDFLAGS = [f"-fsanitize={SANITIZERS}"]
RUNTIMES = ("libasan.so", "libubsan.so")
ASAN_OPTIONS = "detect_leaks=0:abort_on_error=1"
UBSAN_OPTIONS = "print_stacktrace=1:halt_on_error=1"


def _cc() -> str | None:
    return shutil.which(os.environ.get("CC", "gcc"))


def runtime_libraries() -> list[str] | None:
    """The sanitizer runtimes the compiler links against, or None if it has
    no ASan runtime (gcc prints the bare name back when it has no such file)."""
    cc = _cc()
    if cc is None:
        return None
    out = []
    for name in RUNTIMES:
        r = subprocess.run([cc, f"-print-file-name={name}"], capture_output=True, text=True)
        path = r.stdout.strip()
        if r.returncode != 0 or not os.path.isabs(path) or not os.path.exists(path):
            return None
        out.append(path)
    return out


def missing_toolchain() -> str | None:
    """Why the sanitized core cannot be built here, or None."""
    if _cc() is None:
        return "gcc not found on PATH (CC): the sanitized core needs gcc with ASan/UBSan"
    if runtime_libraries() is None:
        return f"{_cc()} has no sanitizer runtime ({', '.join(RUNTIMES)}): install libasan/libubsan"
    return None


def build(tmpdir: str | os.PathLike, verbose: bool = False) -> Path:
    """Compile the sanitized core into tmpdir/fullspeed_san; returns the module's path."""
    from cffi import FFI

    from fullspeed import _build

    root = Path(tmpdir) / "fullspeed_san"
    root.mkdir(parents=True, exist_ok=True)
    ffi = FFI()
    ffi.cdef(_build.cdef_text())
    ffi.set_source(
        MODULE,
        "".join(f'#include "{h}"\n' for h in _build.HEADERS),
        # _build's sources are relative to the repository; cffi compiles in tmpdir
        sources=[str(_build.ROOT / s) for s in _build.sources()],
        include_dirs=[str(_build.CSRC)],
        extra_compile_args=CFLAGS,
        extra_link_args=LDFLAGS,
        libraries=["m"],
    )
    env_cc = os.environ.get("CC")
    os.environ["CC"] = _cc() or "gcc"   # the runtimes found above are this compiler's
    try:
        out = Path(ffi.compile(tmpdir=str(root), verbose=verbose))
    finally:
        if env_cc is None:
            os.environ.pop("CC", None)
        else:
            os.environ["CC"] = env_cc
    return out.resolve()


def sanitized_env(base: dict | None = None) -> dict:
    """The environment a subprocess needs to load the sanitized core."""
    env = dict(os.environ if base is None else base)
    libs = runtime_libraries()
    if libs is None:
        raise RuntimeError(missing_toolchain())
    env["LD_PRELOAD"] = " ".join(libs + ([env["LD_PRELOAD"]] if env.get("LD_PRELOAD") else []))
    env["ASAN_OPTIONS"] = ASAN_OPTIONS
    env["UBSAN_OPTIONS"] = UBSAN_OPTIONS
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    return env


def run(core: str | os.PathLike, script: str | os.PathLike, args=(), timeout: float | None = None,
        cwd: str | os.PathLike | None = None) -> subprocess.CompletedProcess:
    """Run SCRIPT in a fresh Python on the sanitized core; output captured."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "run", str(core), str(script), *map(str, args)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=sanitized_env(), cwd=cwd)


class _CoreFinder(importlib.abc.MetaPathFinder):
    """Resolves fullspeed._core to one given extension file."""

    def __init__(self, path: str):
        self.path = path

    def find_spec(self, fullname, path=None, target=None):
        if fullname != MODULE:
            return None
        return importlib.util.spec_from_file_location(MODULE, self.path)


def install(core: str | os.PathLike):
    """Make `import fullspeed._core` load CORE in this process; returns the module."""
    core = str(Path(core).resolve())
    if MODULE in sys.modules:
        raise RuntimeError(f"{MODULE} is already imported from {sys.modules[MODULE].__file__}")
    sys.meta_path.insert(0, _CoreFinder(core))
    import fullspeed._core as mod

    if os.path.realpath(mod.__file__) != os.path.realpath(core):
        raise RuntimeError(f"{MODULE} loaded from {mod.__file__}, not the sanitized {core}")
    return mod


def _main(argv: list[str]) -> int:
    if len(argv) == 2 and argv[0] == "build":
        print(build(argv[1]))
        return 0
    if len(argv) >= 3 and argv[0] == "run":
        install(argv[1])
        script = argv[2]
        sys.argv = [script, *argv[3:]]
        runpy.run_path(script, run_name="__main__")
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(_main(sys.argv[1:]))
