"""Instructions per control step of fs_drive_step, per mode, counted by callgrind.

Why instructions and not time: an instruction count (valgrind's Ir) is
deterministic on a given machine and compiler, so it can be compared between
commits and modes, where a host timing could not. It is a host (x86-64, gcc
-O2) figure for the float32 code as it is; it ranks the modes and tracks
growth, while bench/firmware.py answers what fits on the target.

bench/step_harness.c closes the drive around a small plant on the machine of
the yang2022 catalog entry (read here from its TOML and passed to the
harness), so every path a real drive runs does run: it warms up, then a
measured block of steps runs with callgrind collecting only inside
fs_drive_step (--toggle-collect), and instrumentation switched on only for
that block by callgrind client requests. Without valgrind/callgrind.h the
block is measured as the difference of two runs (warm-up + block, warm-up
alone), which counts the same instructions.

Goal of the project (issue 4): blended sensorless FOC <= 2,500 instructions
per step. Goals are reported, not enforced; the exit status is non-zero only
when a measurement fails (build, run, or a harness whose drive does not
regulate, whose figure would mean nothing).

Usage: python bench/instructions.py [--steps N] [--warmup N] [--workdir DIR]
"""
from __future__ import annotations

import argparse
import math
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CSRC = ROOT / "csrc"
HARNESS_C = Path(__file__).resolve().parent / "step_harness.c"
MACHINE_TOML = ROOT / "src" / "fullspeed" / "machines" / "yang2022.toml"
CFLAGS = ["-std=c11", "-O2", "-g", "-Wall", "-Wextra"]
INSTALL_HINT = "apt-get install valgrind"

GOAL_MODE = "blended"
GOAL_IR_PER_STEP = 2500
REFERENCE_MODE = "SMO"

# The operating point: above the 260 rpm upper blending limit of yang2022 and
# the observer's 100 rpm validity, so the SMO alone runs the loops; half the
# rated torque as load so the current loop works against a real reference.
# The injection modes set their own speed in the harness's table (rotating
# HFI at 100 rpm, blended at 200 rpm inside the band, where all of it runs).
SPEED_RPM = 500.0
T_LOAD = 1.0
# SMO design as the scenarios default it (src/fullspeed/scenario.py).
SMO_MARGIN, SMO_CUTOFF_MIN_RPM, SMO_VALID_RPM, SMO_TOP_SPEED_X_RATED = 1.5, 20.0, 100.0, 1.5

# A measured block is trusted only if the drive regulates in it.
MAX_SPEED_ERR_RPM = 0.05 * SPEED_RPM
MAX_ANGLE_ERR_DEG = 20.0


@dataclass(frozen=True)
class Mode:
    """A mode to report: its label and its name in step_harness.c's table.

    A mode the harness does not list is reported as "not built yet"; building
    it is one entry in the harness's MODES table.
    """
    label: str
    harness: str


MODES = (
    Mode("encoder FOC", "encoder"),
    Mode("SMO", "smo"),
    Mode("rotating HFI", "hfi-rotating"),
    Mode("blended", "blended"),
    Mode("square-wave HFI", "hfi-square"),
)


def machine_params(toml_path: Path = MACHINE_TOML) -> dict[str, float]:
    """The harness's name=value parameters, from a machine catalog entry."""
    with open(toml_path, "rb") as f:
        m = tomllib.load(f)
    el, me, b, r = m["electrical"], m["mechanical"], m["bench"], m["rated"]
    p = m["pole_pairs"]
    rpm = 2.0 * math.pi / 60.0
    T_pwm = 1.0 / b["f_pwm"]
    return {
        "Ts": T_pwm / 2.0 if b["sampling"] == "double" else T_pwm, "T_pwm": T_pwm,
        "u_dc": b["u_dc"], "t_dead": b["t_dead"],
        "R_s": el["R_s"], "L_d": el["L_d"], "L_q": el["L_q"], "psi_f": el["psi_f"],
        "pole_pairs": p, "J": me["J"], "B": me["B"],
        "i_max": b["i_max"], "bw_current": b["bw_current"], "bw_speed": b["bw_speed"], "bw_pll": b["bw_pll"],
        "smo_bw_pll": b.get("bw_pll_smo", 2.0 * math.pi * 40.0),
        "smo_w_e_max": p * SMO_TOP_SPEED_X_RATED * r["speed_rpm"] * rpm,
        "smo_margin": SMO_MARGIN, "smo_w_c_min": p * SMO_CUTOFF_MIN_RPM * rpm,
        "smo_w_valid": p * SMO_VALID_RPM * rpm,
        "speed_rpm": SPEED_RPM, "T_load": T_LOAD,
        "noise_i": b.get("noise_i", 0.0), "encoder_bits": b["encoder_bits"],
        "inj_u_h": m["injection"]["u_h"], "inj_f_h": m["injection"].get("f_h") or _designed_carrier(el, b),
        "blend_lower_rpm": m["blending"]["lower_rpm"], "blend_upper_rpm": m["blending"]["upper_rpm"],
    }


def _designed_carrier(el: dict, b: dict) -> float:
    """The carrier a scenario designs where the machine leaves f_h out
    (design.design_carrier, against the bench's current loop), Hz."""
    from fullspeed.design.rules import design_carrier
    return design_carrier(el, {"f_pwm": b["f_pwm"], "sampling": b["sampling"]}, b["bw_current"]).value


class BenchError(Exception):
    """A build or run that failed; the message is one line."""


def _run(cmd: list[str], what: str, cwd: Path | None = None) -> str:
    res = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd)
    if res.returncode != 0:
        err = (res.stderr or res.stdout).strip().splitlines()
        first = next((ln for ln in err if "error" in ln), err[0] if err else f"exit {res.returncode}")
        raise BenchError(f"{what} failed: {first.strip()}")
    return res.stdout


def build_harness(csrc: Path, out: Path, cc: str = "gcc", callgrind_h: bool = True) -> Path:
    """Compile the harness with the control library (host gcc -O2) into out."""
    out.mkdir(parents=True, exist_ok=True)
    exe = out / "step_harness"
    sources = sorted((Path(csrc) / "control").glob("*.c"))
    if not sources:
        raise BenchError(f"no control sources under {Path(csrc) / 'control'}")
    flags = CFLAGS + ([] if callgrind_h else ["-DFS_BENCH_NO_CALLGRIND"])
    _run([cc, *flags, f"-I{Path(csrc) / 'control'}", str(HARNESS_C), *map(str, sources), "-lm", "-o", str(exe)],
         "compiling the step harness")
    return exe


def harness_modes(exe: Path) -> list[str]:
    return _run([str(exe), "--list"], "step_harness --list").split()


def _args(exe: Path, mode: str, warmup: int, steps: int, params: dict[str, float], trace: bool) -> list[str]:
    return [str(exe), mode, str(warmup), str(steps), *(["--trace"] if trace else []),
            *(f"{k}={v!r}" for k, v in params.items())]


def _summary(stdout: str) -> dict[str, float | str]:
    """The harness's last line, name=value pairs, numbers as floats."""
    lines = stdout.strip().splitlines()
    if not lines or not lines[-1].startswith("mode="):
        raise BenchError(f"step_harness printed no summary line: {stdout[-200:]!r}")
    out: dict[str, float | str] = {}
    for pair in lines[-1].split():
        k, _, v = pair.partition("=")
        try:
            out[k] = float(v)
        except ValueError:
            out[k] = v
    return out


def run_harness(exe: Path, mode: str, warmup: int, steps: int, params: dict[str, float] | None = None,
                trace: bool = False) -> tuple[dict, list[tuple[float, float, float]]]:
    """Run natively: the summary, and with trace the measured steps' duties."""
    stdout = _run(_args(exe, mode, warmup, steps, params or machine_params(), trace), f"step_harness {mode}")
    duties = [tuple(float(x) for x in ln.split()) for ln in stdout.strip().splitlines()[:-1]] if trace else []
    return _summary(stdout), duties


def _callgrind_ir(exe: Path, mode: str, warmup: int, steps: int, params: dict[str, float],
                  out_file: Path, instr_atstart: bool) -> tuple[int, dict]:
    """Ir collected inside fs_drive_step, and the harness's summary."""
    cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out_file}",
           "--collect-atstart=no", "--toggle-collect=fs_drive_step",
           f"--instr-atstart={'yes' if instr_atstart else 'no'}",
           *_args(exe, mode, warmup, steps, params, False)]
    summary = _summary(_run(cmd, f"callgrind on step_harness {mode}"))
    text = out_file.read_text()
    events = re.search(r"^events:\s*(.+)$", text, re.M)
    col = events.group(1).split().index("Ir") if events else 0
    totals = re.search(r"^totals:\s*(.+)$", text, re.M) or re.search(r"^summary:\s*(.+)$", text, re.M)
    if totals is None:
        raise BenchError(f"no totals in callgrind output {out_file}")
    return int(totals.group(1).split()[col]), summary


def count_instructions(exe: Path, mode: str, warmup: int, steps: int, workdir: Path,
                       params: dict[str, float] | None = None) -> dict:
    """Ir inside fs_drive_step over the measured block, and how it was measured."""
    params = params or machine_params()
    out = Path(workdir) / f"callgrind.{mode}.out"
    ir, summary = _callgrind_ir(exe, mode, warmup, steps, params, out, instr_atstart=False)
    method = "client requests"
    if not summary.get("callgrind"):
        # no client requests compiled in: instrument from the start, subtract the warm-up
        ir, summary = _callgrind_ir(exe, mode, warmup, steps, params, out, instr_atstart=True)
        ir0, _ = _callgrind_ir(exe, mode, warmup, 0, params, out, instr_atstart=True)
        ir, method = ir - ir0, "difference of runs"
    if steps > 0 and ir <= 0:
        raise BenchError(f"{mode}: no instructions collected inside fs_drive_step (inlined or renamed?)")
    return {"ir_total": ir, "ir_per_step": ir / steps if steps else 0.0, "method": method, "harness": summary}


def _check(summary: dict, sensorless: bool) -> str | None:
    """Why a measured block does not represent a working drive, or None."""
    if not summary["finite"] or not 0.0 <= summary["duty_min"] <= summary["duty_max"] <= 1.0:
        return f"duties not finite or outside [0, 1] ({summary['duty_min']}..{summary['duty_max']})"
    if summary["speed_err_max_rpm"] > MAX_SPEED_ERR_RPM:
        return f"speed error {summary['speed_err_max_rpm']:.3g} rpm > {MAX_SPEED_ERR_RPM:g} rpm"
    if summary["angle_err_max_deg"] > MAX_ANGLE_ERR_DEG:
        return f"angle error {summary['angle_err_max_deg']:.3g} el.deg > {MAX_ANGLE_ERR_DEG:g}"
    if sensorless and not summary["est_valid"]:
        return "the estimator was not valid throughout the measured block"
    return None


def _compiler(cc: str) -> str:
    try:
        return subprocess.run([cc, "-dumpfullversion"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return "?"


def instructions_report(csrc: Path = CSRC, workdir: Path | None = None, steps: int = 20000,
                        warmup: int | None = None, modes: tuple[Mode, ...] = MODES) -> dict:
    """Ir per fs_drive_step for every mode in `modes` (warm-up defaults to `steps`).

    Returns {"status": "ok" | "fail" | "skipped", "reason", "modes": {label: {...}},
    "goal": {...}, ...}; a mode's "status" is "ok", "not built yet" or "fail".
    """
    warmup = steps if warmup is None else warmup
    base = {"steps": steps, "warmup": warmup, "speed_rpm": SPEED_RPM, "T_load": T_LOAD, "modes": {}}
    for tool, hint in (("valgrind", INSTALL_HINT), ("gcc", "apt-get install gcc")):
        if shutil.which(tool) is None:
            return {**base, "status": "skipped", "reason": f"{tool} not found: skipped (install: {hint})",
                    "goal": _goal({})}
    with tempfile.TemporaryDirectory(prefix="fs-instructions-") as tmp:
        work = Path(workdir) if workdir is not None else Path(tmp)
        try:
            exe = build_harness(Path(csrc), work)
            built = set(harness_modes(exe))
        except BenchError as e:
            return {**base, "status": "fail", "reason": str(e), "goal": _goal({})}
        params = machine_params()
        results, failures = {}, []
        for mode in modes:
            if mode.harness not in built:
                results[mode.label] = {"status": "not built yet"}
                continue
            try:
                r = count_instructions(exe, mode.harness, warmup, steps, work, params)
                why = _check(r["harness"], sensorless=mode.harness != "encoder")
            except BenchError as e:
                r, why = {}, str(e)
            r["status"] = "fail" if why else "ok"
            if why:
                r["reason"] = why
                failures.append(f"{mode.label}: {why}")
            results[mode.label] = r
    return {**base, "status": "fail" if failures else "ok", "reason": "; ".join(failures) or None,
            "compiler": f"gcc {_compiler('gcc')} {' '.join(CFLAGS)}", "modes": results, "goal": _goal(results)}


def _goal(results: dict) -> dict:
    g = {"mode": GOAL_MODE, "max_ir_per_step": GOAL_IR_PER_STEP, "met": None}
    r = results.get(GOAL_MODE, {"status": "not built yet"})
    g["status"] = r["status"]
    if r["status"] == "ok":
        g["ir_per_step"] = r["ir_per_step"]
        g["met"] = r["ir_per_step"] <= GOAL_IR_PER_STEP
    ref = results.get(REFERENCE_MODE, {})
    g["reference"] = {"mode": REFERENCE_MODE, "ir_per_step": ref.get("ir_per_step")}
    return g


def format_report(rep: dict) -> str:
    if rep["status"] == "skipped":
        return rep["reason"]
    lines = [f"instructions per fs_drive_step: callgrind Ir, {rep.get('compiler', 'gcc')}, "
             f"{rep['steps']} steps after {rep['warmup']} warm-up, yang2022 with a {rep['T_load']:g} N m load "
             f"at the speed in the table (the injection modes at low speed, the blend inside its band)"]
    if rep["status"] == "fail" and not rep["modes"]:
        return "\n".join(lines + [f"FAIL: {rep['reason']}"])
    lines.append(f"  {'mode':<16} {'Ir/step':>9}  {'speed':>8}  {'speed err':>10}  {'angle err':>10}")
    for label, r in rep["modes"].items():
        if r["status"] == "not built yet":
            lines.append(f"  {label:<16} {'not built yet':>9}")
        elif r["status"] == "fail" and "harness" not in r:
            lines.append(f"  {label:<16} FAIL: {r['reason']}")
        else:
            h = r["harness"]
            lines.append(f"  {label:<16} {r['ir_per_step']:>9.1f}  {h['speed_rpm']:>4.0f} rpm  {h['speed_err_max_rpm']:>6.3g} rpm"
                         f"  {h['angle_err_max_deg']:>5.3g} deg" + (f"  FAIL: {r['reason']}" if r["status"] == "fail" else ""))
    g = rep["goal"]
    ref = g["reference"]["ir_per_step"]
    ref_txt = f" ({g['reference']['mode']}: {ref:.1f} Ir/step for reference)" if ref is not None else ""
    verdict = {True: "met", False: "NOT met", None: g["status"]}[g["met"]]
    got = f" {g['ir_per_step']:.1f}" if g.get("ir_per_step") is not None else ""
    lines.append(f"goal: {g['mode']} sensorless FOC <= {g['max_ir_per_step']} Ir/step:{got} {verdict}{ref_txt}")
    if rep["status"] == "fail":
        lines.append(f"FAIL: {rep['reason']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--csrc", type=Path, default=CSRC, help="directory holding control/ (default: the repo's)")
    ap.add_argument("--steps", type=int, default=20000, help="measured steps (default 20000)")
    ap.add_argument("--warmup", type=int, default=None, help="warm-up steps (default: as many as measured)")
    ap.add_argument("--workdir", type=Path, default=None, help="keep the build and callgrind files here")
    a = ap.parse_args(argv)
    if a.steps < 1 or (a.warmup is not None and a.warmup < 0):
        ap.error("--steps must be >= 1 and --warmup >= 0")
    rep = instructions_report(a.csrc, a.workdir, a.steps, a.warmup)
    print(format_report(rep))
    return 1 if rep["status"] == "fail" else 0


if __name__ == "__main__":
    sys.exit(main())
