"""C unit tests: compile each csrc/tests/test_*.c with the sanitizers and run it.

Each C test names the library sources it needs (relative to csrc/) on a
``fs-test-sources:`` line in its leading comment. The program is built with
``gcc -std=c99 -O1 -g -Wall -Wextra -Werror -fsanitize=address,undefined
-fno-sanitize-recover=all -Icsrc`` into a temporary directory and run; the
test fails if compilation fails (warnings included) or the program exits
non-zero, and shows the compiler's or the program's output.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CSRC = ROOT / "csrc"
TEST_DIR = CSRC / "tests"

CFLAGS = [
    "-std=c99",
    "-O1",
    "-g",
    "-Wall",
    "-Wextra",
    "-Werror",
    "-fsanitize=address,undefined",
    "-fno-sanitize-recover=all",
    f"-I{CSRC}",
]

# Known bugs in the code under test: the C test stays, marked as an expected
# failure (strict: it must fail until the bug is fixed, then this entry goes).
KNOWN_BUGS: dict[str, str] = {}

SOURCES_RE = re.compile(r"fs-test-sources:([^\n]*)")


def c_tests() -> list[str]:
    return sorted(p.name for p in TEST_DIR.glob("test_*.c"))


def declared_sources(test_file: Path) -> list[Path]:
    m = SOURCES_RE.search(test_file.read_text())
    if m is None:
        raise AssertionError(f"{test_file.name}: no 'fs-test-sources:' line in its leading comment")
    names = m.group(1).replace("*/", " ").split()
    paths = [CSRC / n for n in names]
    missing = [str(p) for p in paths if not p.is_file()]
    assert not missing, f"{test_file.name}: declared sources missing: {missing}"
    return paths


def _params():
    out = []
    for name in c_tests():
        marks = []
        if name in KNOWN_BUGS:
            marks.append(pytest.mark.xfail(reason=KNOWN_BUGS[name], strict=True))
        out.append(pytest.param(name, id=name[:-2], marks=marks))
    return out


@pytest.fixture(scope="session")
def gcc() -> str:
    path = shutil.which(os.environ.get("CC_FOR_C_TESTS", "gcc"))
    if path is None:
        pytest.skip("gcc not found on PATH: the C unit tests need gcc with ASan/UBSan")
    return path


@pytest.fixture(scope="session")
def build_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("c_units")


def test_every_c_test_is_collected():
    assert c_tests(), f"no C tests found in {TEST_DIR}"


@pytest.mark.parametrize("name", _params())
def test_c_unit(name: str, gcc: str, build_dir: Path):
    src = TEST_DIR / name
    exe = build_dir / name[:-2]
    cmd = [gcc, *CFLAGS, str(src), *map(str, declared_sources(src)), "-o", str(exe), "-lm"]
    comp = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    if comp.returncode != 0:
        pytest.fail(
            f"compilation of {name} failed ({comp.returncode}):\n$ {' '.join(cmd)}\n"
            f"{comp.stdout}{comp.stderr}",
            pytrace=False,
        )
    env = dict(os.environ)
    env.setdefault("ASAN_OPTIONS", "detect_leaks=1:abort_on_error=0")
    env.setdefault("UBSAN_OPTIONS", "print_stacktrace=1")
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120, env=env, cwd=build_dir)
    print(run.stdout, end="")
    if run.returncode != 0:
        pytest.fail(
            f"{name} failed (exit {run.returncode}):\n{run.stdout}{run.stderr}",
            pytrace=False,
        )
