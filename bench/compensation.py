"""What the dead-time compensation on the predicted current (fs_dtcomp.h,
controller.dead_time_predict) and the x-y current control (fs_xyctrl.h,
controller.xy_control) change, each against the same run without: the
rotating injection's error at low speed (yang2022, 100 rpm, 5 and 25 A, and
25 A with the cross-saturation table), the square wave's lead (U-SEQ-SS)
and the five-phase machine's third-harmonic current (U-THIRD's run).
A measurement, not a timing: printed as a table and as JSON.

Usage: python bench/compensation.py
"""
from __future__ import annotations

import json

import numpy as np

from fullspeed.sim.metrics import window_mask
from fullspeed.reproduce.papers.common import error_stats, run
from fullspeed.reproduce.papers.yu2022 import TS, XSAT, _err


def injection_error(pred: bool) -> dict:
    out = {}
    for iq in (5.0, 25.0):
        s = error_stats(run("yang2022-hfi-steady-100rpm", {"references": {"i_q": iq}, "controller": {"dead_time_predict": pred}}), 0.5, 1.0)
        out[f"hfi_100rpm_{iq:g}A"] = {"mean": s["mean"], "pp": s["pp"]}
    s = error_stats(run("beyond-xcomp-3ph", {"controller": {"dead_time_predict": pred}}), 0.5, 1.0)
    out["hfi_100rpm_25A_xcomp"] = {"mean": s["mean"], "pp": s["pp"]}
    return out


def seq_lead(pred: bool) -> float:
    r = run("yu2022-seq-ss-300rpm", {"injection": {"sequence": "optimized"}, "controller": {"dead_time_predict": pred}})
    w_e = r.scenario.machine.pole_pairs * float(np.mean(r["w_m"][window_mask(r["t"], 1.0, 1.6)]))
    return float(np.mean(_err(r, 1.0, 1.6))) / (-1.5 * w_e * TS)


def third_pct(xy: bool, pred: bool) -> float:
    r = run("yu2022-xcouple", {"injection": {"xcomp": XSAT}, "controller": {"xy_control": xy, "dead_time_predict": pred}})
    m = window_mask(r["t"], 1.7, 2.0)
    return float(100 * np.sqrt(np.mean(r["i_d3"][m] ** 2 + r["i_q3"][m] ** 2) / np.mean(r["i_d"][m] ** 2 + r["i_q"][m] ** 2)))


def main() -> int:
    rep = {}
    for pred in (False, True):
        key = "predicted" if pred else "sampled"
        rep[key] = {**injection_error(pred), "U-SEQ-SS_optimized_vs_eq18": seq_lead(pred),
                    "U-THIRD_pct_open_loop_xy": third_pct(False, pred), "U-THIRD_pct_xy_control": third_pct(True, pred)}
    for key, r in rep.items():
        print(f"dead-time compensation on the {key} current:")
        for k, v in r.items():
            print(f"  {k:34s} " + (f"mean {v['mean']:+.3f} pp {v['pp']:.3f} el.deg" if isinstance(v, dict) else f"{v:.3f}"))
    print(json.dumps(rep))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
