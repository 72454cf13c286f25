"""The firmware's integration layer on the host (tests/c/firmware_app_host.c):
firmware/drive_app.c with the exported configuration over a recording
board: the carrier set to the configuration's T_pwm (a timer that cannot
make it refused), duties of 1/2 and the PWM on before the first step, the
speed reference ramped, the drive's halt on an undetermined polarity turning
the PWM off, the overcurrent trip, stop."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_the_integration_layer_keeps_the_contract(tmp_path):
    cc = shutil.which("gcc")
    if cc is None:
        pytest.skip("gcc not found on PATH")
    srcs = [*sorted((ROOT / "csrc" / "control").glob("*.c")), ROOT / "firmware" / "drive_app.c",
            ROOT / "firmware" / "fs_config.c", ROOT / "tests" / "c" / "firmware_app_host.c"]
    exe = tmp_path / "app"
    build = subprocess.run([cc, "-std=c11", "-O1", "-Wall", "-Wextra", "-Werror", "-fsanitize=address,undefined",
                            "-fno-sanitize-recover=all", f"-I{ROOT / 'csrc' / 'control'}", f"-I{ROOT / 'firmware'}",
                            *map(str, srcs), "-lm", "-o", str(exe)], capture_output=True, text=True, timeout=300)
    assert build.returncode == 0, build.stderr[-3000:]
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    assert "0 failures" in run.stdout
