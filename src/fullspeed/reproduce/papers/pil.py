"""B-PIL: the drive step on an emulated Cortex-M4F (bench/pil.py).

Measured where the source tree's bench/ is present and the ARM toolchain and
QEMU are installed; otherwise listed as not measured, with the reason.
"""
from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

from ..registry import Measurement, register

BENCH = Path(__file__).resolve().parents[4] / "bench" / "pil.py"   # src/fullspeed/reproduce/papers/ -> the checkout
# The claim's closed-loop criterion: each metric within 1 % of the host run's,
# the angle errors within 0.5 el.deg.
LOOP_METRICS = ("speed_rpm", "i_d_error_rms", "i_q_error_rms", "T_e_mean", "T_e_pp", "i_phase_max")


def _bench_pil():
    spec = importlib.util.spec_from_file_location("bench_pil", BENCH)
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(spec.name, mod)
    spec.loader.exec_module(mod)
    return mod


def loop_within_claim(host: dict, target: dict) -> dict[str, bool]:
    out = {k: abs(target[k] - host[k]) <= 0.01 * abs(host[k]) for k in LOOP_METRICS
           if host.get(k) is not None and target.get(k) is not None}
    for k in ("theta_err_deg", "est_err_deg"):
        if host.get(k) and target.get(k):
            out[k] = abs(target[k]["mean"] - host[k]["mean"]) <= 0.5 and abs(target[k]["max"] - host[k]["max"]) <= 0.5
    return out


@register("B-PIL", cost=18)
def pil(out: Path) -> Measurement:
    if not BENCH.is_file():
        return Measurement(None, False, "not measured: bench/pil.py is not here (an installed package without "
                                        "the source tree); run the reproduction from a clone")
    mod = _bench_pil()
    rep = mod.pil_report()
    if rep["status"] == "skipped":
        return Measurement(None, False, f"not measured: {rep['reason']}")
    (out / "B-PIL.json").write_text(json.dumps(rep, indent=2, default=str))
    (out / "B-PIL.txt").write_text(mod.format_report(rep) + "\n")
    if "modes" not in rep:
        return Measurement(None, False, f"measurement failed: {rep['reason']}")
    loop = rep["closed_loop"]
    claim_loop = loop_within_claim(loop["host"], loop["target"])
    value = {
        "replay": {m: {"max_duty_diff": r["compare"]["max_duty"], "max_theta_diff_rad": r["compare"]["max_theta_e"],
                       "within": r["compare"]["within"], "compared_until_s": r["compare"]["until_s"],
                       "insns_mean": r["insns"]["mean"], "insns_max": r["insns"]["max"], "stack_bytes": r["stack_used"]}
                   for m, r in rep["modes"].items()},
        "closed_loop": {"scenario": loop["scenario"], "host": loop["host"], "target": loop["target"],
                        "criteria": claim_loop, "stages_equal": loop["stages_host"] == loop["stages_target"]},
        "blend_insns_mean": rep["goal"]["mean"], "blend_insns_max": rep["goal"]["max"],
        "blend_max_of_budget_20k": rep["goal"]["max_of_budget_20k"],
        "blend_insns_by_what": rep.get("firmware_build", loop).get("cost_groups"),
        "blend_insns_from": rep["goal"]["from"],
        "sizeof_fs_drive": next(iter(rep["modes"].values()))["sizeof_fs_drive"],
        "libm_differ_pct": {k: v["differ_pct"] for k, v in rep["libm"].items()},
    }
    ok_replay = all(r["compare"]["within"] for r in rep["modes"].values())
    ok_loop = all(claim_loop.values()) and value["closed_loop"]["stages_equal"]
    ok = ok_replay and ok_loop and rep["goal"]["met"]
    fails = [w for w, good in (("replay", ok_replay), ("closed loop", ok_loop),
                               (f"instructions: blended step mean {rep['goal']['mean']:.0f} > {rep['goal']['insns_blend']}",
                                rep["goal"]["met"])) if not good]
    note = ("bench/pil.py (full report: B-PIL.txt, B-PIL.json). The drive step built for a Cortex-M4F "
            "(arm-none-eabi-gcc -O2, hard float) runs on QEMU mps2-an386. Replay: the simulator's drive inputs, "
            "recorded from t = 0 for each angle source, stepped on the target and compared with the host's "
            f"outputs (tolerance: duty {mod.TOLERANCE['duty']:g}, angle {mod.TOLERANCE['theta_e']:g} rad, speed "
            f"{mod.TOLERANCE['w_e_rel']:g} relative, stage exact). The arithmetic is IEEE binary32 on both, "
            "csrc/control has no fused multiply-add (ISO C, -ffp-contract=off) and its trigonometry is its own "
            "(fs_cis, fs_atan2f: the same bits on both); the outputs part only where a libm result differs by an "
            "ulp (newlib's logf in the matrix converter's step; expf and expm1f in the inits) and stay within "
            "about 1e-6. Where the loops run on the sliding-mode observer (smo from its "
            "0.6 s handover, the blend from 0.6 s) an open-loop replay stops being a comparison: the observer "
            "integrates the drive's own voltage against recorded currents that do not respond to it, so an ulp "
            "grows; the replay is compared up to there and the loop closed through the emulator "
            f"({loop['scenario']}, {loop['duration_s']:g} s, plant on the host, one sample per exchange) covers the "
            "rest: its metrics against the host run's are the closed_loop values (criteria: each within 1 %, "
            "angle errors within 0.5 el.deg). Instructions per step are counted exactly by a QEMU plugin (not "
            "cycles: QEMU has no Cortex-M4 timing), on the firmware's build (bench/firmware.py's options, link-time "
            "optimisation) in the closed loop; the goal is read on the mean over the run (the processor's load), "
            "and blend_insns_max, the largest step, is the interrupt's deadline: blend_max_of_budget_20k is its "
            "share of 8,400 cycles (168 MHz, 20 kHz). blend_insns_by_what splits the mean between the library's "
            "trigonometry (fs_cis, fs_atan2f), newlib's sinf/cosf and fmaxf/fminf (0: csrc/control no longer calls them), the "
            "rest of libm and the drive's own code. " + ("All met." if ok else "Not met: " + "; ".join(fails) + "."))
    return Measurement(value, bool(ok), note)
