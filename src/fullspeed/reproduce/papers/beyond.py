"""Beyond the papers: one sensorless drive over the whole speed range
(B-FULLRANGE), its robustness to parameter error (B-ROBUST), the
self-commissioning over the machine zoo (B-IDENT) and its flux map
(B-MAPID),
cross-saturation compensation of the rotating injection (B-XCOMP-3PH),
yu2022's square-wave injection on the three-phase machine (B-SWVI-3PH),
the loss-of-lock monitor's campaign (B-LOCK), and the drive on a machine
that heats (B-THERMAL)."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np

from ...design.rules import u_linear
from ...model.scenario import xcomp_table
from ...model.units import rad_s_to_rpm
from ...sim.metrics import STAGES, stage_changes, window_mask
from ...workflows import lock_campaign
from ...workflows.calibrate import write_table, xsat_table
from ...workflows.identify import GOALS_PCT, MAP_GOAL_PCT, campaign_summary, map_summary, sensorless_on_identified, zoo_campaign
from ...workflows.sweep import load_sweep_file, run_sweep
from ..registry import Measurement, register
from . import zoo
from .mapid import ANGLE_TOL, THETA0_DEG, identified_against_true
from .common import (error_stats, figure_angle, figure_dynamic, grid_and_legends, lock_held, plt,
                     run, save_figure, sweep_dir)

# The sequence a sensorless drive passes from standstill into flux weakening,
# back down and through zero (fs_drive.h, fs_drive_stage).
FULL_RANGE_STAGES = ["polarity", "injection", "blend", "backemf", "flux_weakening", "backemf", "blend",
                     "injection", "blend", "backemf"]


def _calibrated(scenario: str, shipped: str, i_q_max: float, out: Path) -> tuple[dict, float]:
    """A cross-saturation table calibrated in this run (written to out), and
    how far it is from the one the scenarios ship with, el.deg."""
    fresh, _ = xsat_table(scenario, i_q_max=i_q_max)
    write_table(fresh, out)
    ref = xcomp_table(shipped, None)
    return fresh, float(np.max(np.abs(np.array(fresh["delta_deg"]) - np.array(ref["delta_deg"]))))


@register("B-XCOMP-3PH")
def xcomp_3ph(out: Path) -> Measurement:
    fresh, drift = _calibrated("beyond-xcomp-3ph", "yang2022-xsat", 40.0, out / "B-XCOMP-3PH-table.toml")
    comp = run("beyond-xcomp-3ph", {"injection": {"xcomp": fresh}})
    plain = run("beyond-xcomp-3ph", {"injection": {"xcomp": False}})
    sc, su = error_stats(comp, 0.5, 1.0), error_stats(plain, 0.5, 1.0)
    value = {"mean_compensated": sc["mean"], "mean_uncompensated": su["mean"],
             "pp_compensated": sc["pp"], "table_vs_shipped_max_diff": drift}
    ok = lock_held(comp, 0.2) and abs(sc["mean"]) < 5
    fig = figure_angle([("uncompensated", plain), ("compensated", comp)], (0.9, 0.96), (0.5, 1.0),
                       out / "B-XCOMP-3PH.png", "Rotating HFI at 100 rpm, 25 A: cross-saturation compensation")
    note = ("Offline calibration (fullspeed calibrate, this run): current control with the encoder in "
            "the loop and the estimator alongside at 100 rpm, i_q stepped -40..40 A in 17 points, the "
            "estimate's lead theta_hat - theta measured at each (written to B-XCOMP-3PH-table.toml), with "
            "the scenario's estimator (the defaults: the leak removed, the table then the machine's HF axis). "
            "Online, the estimator expects the negative carrier at 2 (theta_hat + delta(i_q)), in its "
            "filter's frame (fs_hfi.h). The "
            "scenario file uses the table shipped in fullspeed/calibration/yang2022-xsat.toml; "
            "table_vs_shipped_max_diff is how far this run's calibration is from it.")
    return Measurement(value, ok, note, [fig])


# B-SWVI-3PH: the run's error is taken from T_SWVI on: the rotor starts 50
# el.deg from the estimate, and the load is taken on from 0.1 s.
T_SWVI = 0.1


@register("B-SWVI-3PH")
def swvi_3ph(out: Path) -> Measurement:
    fresh, drift = _calibrated("beyond-swvi-3ph-100rpm", "yang2022-swvi-xsat", 60.0, out / "B-SWVI-3PH-table.toml")
    comp = run("beyond-swvi-3ph", {"injection": {"xcomp": fresh}})
    plain = run("beyond-swvi-3ph", {"injection": {"xcomp": False}})
    held_c = error_stats(run("beyond-swvi-3ph-100rpm", {"injection": {"xcomp": fresh}}), 0.5, 1.0)
    held_u = error_stats(run("beyond-swvi-3ph-100rpm", {"injection": {"xcomp": False}}), 0.5, 1.0)
    sc, su = error_stats(comp, T_SWVI, comp.scenario.duration), error_stats(plain, T_SWVI, plain.scenario.duration)
    top = window_mask(comp["t"], 1.6, 2.0)   # the 200 rpm hold
    value = {"max_error_deg": sc["max"], "max_error_uncompensated_deg": su["max"],
             "speed_at_top_rpm": float(rad_s_to_rpm(np.mean(comp["w_m"][top]))),
             "speed_at_top_uncompensated_rpm": float(rad_s_to_rpm(np.mean(plain["w_m"][top]))),
             "speed_min_at_load_rpm": float(rad_s_to_rpm(np.min(comp["w_m"][comp["t"] < 0.5]))),
             "mean_100rpm_25A_compensated": held_c["mean"], "mean_100rpm_25A_uncompensated": held_u["mean"],
             "table_vs_shipped_max_diff": drift, "stop_reason": comp.stop_reason}
    ok = lock_held(comp, T_SWVI) and sc["max"] < 10.0
    fig = figure_dynamic(comp, out / "B-SWVI-3PH.png",
                         "Square-wave injection, yang2022 machine, rated load",
                         (0.0, comp.scenario.duration))
    note = ("Scenario beyond-swvi-3ph: yu2022's square-wave injection (filterless, optimized sequence) on "
            "the yang2022 machine, speed control on the estimate from the first sample; the rotor starts "
            "50 el.deg from the estimate, rated load (2 N m, active) is taken on at standstill over "
            "0.1-0.3 s (the rotor is pushed back to speed_min_at_load_rpm: the speed loop's 20 rad/s, "
            "which the estimate's noise sets, is slow against it), then 0 -> 200 -> 0 rpm under it. "
            f"Max |error| from {T_SWVI:g} s to the end. The carrier (4 V at 2.5 kHz, a quarter of the "
            "sampling rate) and the bandwidths are chosen in the scenario files, with their reasons. Cross-saturation: a table calibrated in this run by "
            "fullspeed calibrate on beyond-swvi-3ph-100rpm (encoder in the loop, i_q -60..60 A, written to "
            "B-SWVI-3PH-table.toml); its error there at 25 A is the mean_100rpm_25A values. Uncompensated, "
            "the same run still reaches 200 rpm, with the error of max_error_uncompensated_deg: the "
            "estimate leads the rotor by the saliency axis' turn under load. No polarity detection is "
            "built for the square wave: it finds the axis, not the magnet's pole (started 100 el.deg "
            "from the estimate this scenario still ends on the right pole, from 130 el.deg on the wrong one).")
    return Measurement(value, bool(ok), note, [fig])


def top_speed_stats(res, t0: float, t1: float) -> dict:
    """At the top speed: the speed, the voltage against the modulator's
    linear limit, the current against i_max, and the flux-weakening current."""
    m = window_mask(res["t"], t0, t1)
    d = res.scenario.data
    u = np.hypot(res["u_d_ref"][m], res["u_q_ref"][m]) / u_linear(d["converter"]["u_dc"], res.scenario.machine.phases)
    i = np.hypot(res["i_d"][m], res["i_q"][m]) / d["controller"]["i_max"]
    return {"speed_rpm": float(rad_s_to_rpm(np.mean(res["w_m"][m]))), "u_over_u_lin": float(np.mean(u)),
            "i_over_i_max_max": float(np.max(i)), "i_d_fw": float(np.mean(res["i_d_fw"][m])),
            "overmod_fraction": float(np.mean(res["overmod"][m]))}


def _figure_full_range(res, path: Path, title: str) -> str:
    t = res["t"]
    fig, ax = plt.subplots(5, 1, figsize=(9, 12), sharex=True)
    ax[0].plot(t, rad_s_to_rpm(res["w_m_ref"]), "k:", label="reference")
    ax[0].plot(t, rad_s_to_rpm(res["w_m"]), label="actual")
    ax[0].plot(t, rad_s_to_rpm(res["w_m_est"]), "--", label="estimated")
    ax[0].set_ylabel("speed (rpm)")
    ax[1].plot(t, res["i_d_hat"], lw=0.7, label="$i_d$ (fundamental)")
    ax[1].plot(t, res["i_q_hat"], lw=0.7, label="$i_q$ (fundamental)")
    ax[1].plot(t, res["i_d_fw"], "--", label="$i_{d,fw}$")
    ax[1].plot(t, res["T_L"] * 10, "k:", label="load (N m x 10)")
    ax[1].set_ylabel("current (A)")
    ax[2].step(t, res["stage"], where="post")
    used = sorted(set(int(x) for x in res["stage"]))
    ax[2].set_yticks(used, [STAGES[k] for k in used])
    ax[2].set_ylabel("stage")
    ax[3].plot(t, res["g_w"], label="$g_w$ (1: SMO)")
    ax[3].plot(t, res["inject"], ":", label="injecting")
    ax[3].set_ylabel("weight")
    ax[4].plot(t, np.degrees(res["est_err"]), "r", lw=0.6)
    ax[4].set_ylabel("error (el.deg)")
    ax[4].set_xlabel("time (s)")
    grid_and_legends(ax)
    return save_figure(fig, path, title)


@register("B-FULLRANGE")
def full_range(out: Path) -> Measurement:
    res = run("beyond-full-range", {"controller": {"lock": "detect"}})   # a loss is seen, not recovered
    no_fw = run("beyond-full-range", {"controller": {"lock": "detect", "flux_weakening": False}})
    t = res["t"]
    seq = stage_changes(res)
    names = [n for _, n in seq]
    t_pol = next((ts for ts, n in seq if n != "polarity"), t[-1])   # polarity detection over
    e = np.abs(np.degrees(res["est_err"][t >= t_pol]))
    top = top_speed_stats(res, 3.2, 3.5)
    top_no_fw = top_speed_stats(no_fw, 3.2, 3.5)
    lost = np.flatnonzero(res["lock_lost"] > 0)
    value = {"max_error_deg": float(np.max(e)) if e.size else None,
             "loss_of_lock_at": float(t[lost[0]]) if lost.size else None,
             "stages": " > ".join(names), "top_speed_rpm": top["speed_rpm"],
             "top_u_over_u_lin": top["u_over_u_lin"], "top_i_over_i_max": top["i_over_i_max_max"],
             "top_i_d_fw": top["i_d_fw"], "without_fw_speed_rpm": top_no_fw["speed_rpm"],
             "stop_reason": res.stop_reason}
    ok = (res.stop_reason == "done" and not lost.size and e.size and np.max(e) < 10.0
          and names == FULL_RANGE_STAGES)
    fig = _figure_full_range(res, out / "B-FULLRANGE.png",
                             "Sensorless from standstill under rated load into flux weakening and through zero")
    when = ", ".join(f"{n} {ts:.3f} s" for ts, n in seq)
    note = (f"Scenario beyond-full-range: rated load (2 N m, active) taken on at standstill on injection, "
            f"then 0 -> 4400 rpm -> 300 -> -300 rpm under it. Stages entered: {when}. The error is taken "
            f"over the whole run after polarity detection ({t_pol:.3f} s), no window excluded. At the top "
            f"speed (3.2-3.5 s) the voltage reference is {top['u_over_u_lin']:.3f} of the linear limit "
            f"u_dc/sqrt3 ({100 * top['overmod_fraction']:.0f} % of samples over-modulated), the current at most "
            f"{top['i_over_i_max_max']:.3f} of i_max, i_d_fw {top['i_d_fw']:.1f} A. Without flux weakening "
            f"the same reference reaches {top_no_fw['speed_rpm']:.0f} rpm (its voltage "
            f"{top_no_fw['u_over_u_lin']:.3f} of the limit). The loss-of-lock monitor ran in detect mode.")
    return Measurement(value, bool(ok), note, [fig])


def _figure_robust(err_max, err_mean, kept, path: Path, title: str) -> str:
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for a, v, label in ((ax[0], err_max, "max |error| (el.deg)"), (ax[1], err_mean, "mean error (el.deg)")):
        a.hist(v[kept & np.isfinite(v)], bins=25, label="kept lock")
        if np.any(~kept & np.isfinite(v)):
            a.hist(v[~kept & np.isfinite(v)], bins=25, label="lost")
        a.set_xlabel(label)
        a.set_ylabel("runs")
    grid_and_legends(ax)
    return save_figure(fig, path, title)


@register("B-ROBUST", cost=13)
def robust(out: Path) -> Measurement:
    folder = sweep_dir(out, "B-ROBUST")
    shutil.rmtree(folder, ignore_errors=True)   # measured afresh (common.sweep_dir)
    sw = load_sweep_file("beyond-robust")
    _, rows = run_sweep(sw, folder, plot=False)

    def col(name: str) -> np.ndarray:   # the table's column, None as NaN
        return np.array([np.nan if r[name] is None else r[name] for r in rows], dtype=float)

    finished = np.array([r["stop_reason"] == "done" for r in rows])
    err = col("est_err_deg.max")
    by_truth = finished & (np.nan_to_num(err, nan=180.0) < 45.0)
    by_monitor = finished & np.isnan(col("lock_lost_at"))
    kept = by_truth & by_monitor
    pct = 100.0 * float(np.mean(kept))
    refused = [r for r in rows if r["stop_reason"] == "error"]
    value = {"kept_pct": pct, "runs": len(rows), "kept_by_truth": int(by_truth.sum()),
             "kept_by_monitor": int(by_monitor.sum()), "refused": len(refused),
             "max_error_deg_p50": float(np.nanpercentile(err[finished], 50)),
             "max_error_deg_p95": float(np.nanpercentile(err[finished], 95)),
             "max_error_deg_worst": float(np.nanmax(err[finished]))}
    fig = _figure_robust(err, col("est_err_deg.mean"), kept, out / "B-ROBUST.png",
                         f"B-ROBUST: {len(rows)} runs, R, L_d, L_q, psi_f each x U(0.8, 1.2); {pct:.1f} % kept lock")
    why = "; ".join(sorted(set(str(r["error"]) for r in refused)))[:400]
    note = (f"Sweep beyond-robust (seed {sw.seed}) on scenario beyond-robust: standstill start with polarity "
            "detection, 1 N m load, up through the blend to 600 rpm and down to 100 rpm, current-sensor noise "
            "drawn afresh per run. Lock counts as kept when the run ends normally, the error stays inside 45 "
            "el.deg over 0.3-2.0 s and the loss-of-lock monitor never latched; both judges are given. "
            + (f"{len(refused)} draws were refused before running and count as not kept: the controller's "
               f"L_d and L_q came within 1 % of each other, so there is no model saliency to design the "
               f"injection estimator for ({why})." if len(refused) else ""))
    return Measurement(value, pct >= 95.0, note, [fig])


# B-THERMAL: the error is taken from T_THERMAL on (polarity detection, the
# load taken on at standstill and the first ramp to 100 rpm are over); the
# scenario's speed cycle (4 s from 0.8 s) holds 100 rpm (injection alone)
# over [0.3, 1.5] s and 600 rpm (back-EMF observer alone) over [2.3, 3.5] s
# of each cycle, the first 0.3 s after each ramp left out.
T_THERMAL = 1.0
THERMAL_CYCLE = (0.8, 4.0)
THERMAL_HOLDS = {"injection": (0.3, 1.5), "backemf": (2.3, 3.5)}


def _hold_means(res, which: str) -> np.ndarray:
    """Mean error (el.deg) of each cycle's hold of one estimator."""
    t0, period = THERMAL_CYCLE
    a, b = THERMAL_HOLDS[which]
    e = np.degrees(res["est_err"])
    n = int((res.scenario.duration - t0) // period)
    return np.array([np.mean(e[window_mask(res["t"], t0 + k * period + a, t0 + k * period + b)]) for k in range(n)])


def _thermal_lock(res) -> bool:
    """Lock kept: the run ended, nothing was lost or recovered, and the
    estimate stayed within 45 el.deg from T_THERMAL on."""
    return lock_held(res, T_THERMAL) and not np.any(res["lock_lost"] > 0) and res["recoveries"][-1] == 0


def _figure_thermal(fixed, plain, path: Path, title: str) -> str:
    t = fixed["t"]
    fig, ax = plt.subplots(4, 1, figsize=(9, 11), sharex=True)
    ax[0].plot(t, fixed["T_winding"], label="winding")
    ax[0].plot(t, fixed["T_magnet"], label="magnets")
    ax[0].set_ylabel("temperature (degC)")
    ax[1].plot(t, 1e3 * fixed["R_s_true"], "k", label="$R_s$ true")
    ax[1].plot(t, 1e3 * fixed["R_s_hat"], "--", label="$R_s$ corrected online")
    ax[1].plot(t, 1e3 * plain["R_s_hat"], ":", label="$R_s$ uncorrected")
    ax[1].set_ylabel("resistance (mOhm)")
    ax[2].plot(t, 1e3 * fixed["psi_f_true"], "k", label=r"$\psi_f$ true (open circuit)")
    ax[2].plot(t, 1e3 * fixed["psi_f_hat"], "--", label=r"$\psi_f$ corrected online (under load)")
    ax[2].plot(t, 1e3 * plain["psi_f_hat"], ":", label=r"$\psi_f$ uncorrected")
    ax[2].set_ylabel("magnet flux (mWb)")
    ax[3].plot(t, np.degrees(plain["est_err"]), lw=0.5, label="uncorrected")
    ax[3].plot(t, np.degrees(fixed["est_err"]), lw=0.5, label="corrected")
    ax[3].set_ylabel("error (el.deg)")
    ax[3].set_xlabel("time (s)")
    grid_and_legends(ax)
    return save_figure(fig, path, title)


def _figure_lock(rows: list[dict], path: Path, title: str) -> str:
    """Detection delays of the true losses, and when the flags came in the
    runs that never truly lost, by kind."""
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for kind in lock_campaign.KINDS:
        v = [lock_campaign.judge(r) for r in rows if r["kind"] == kind]
        d = [1e3 * x["delay"] for x in v if x["delay"] is not None]
        if d:
            ax[0].plot(sorted(d), np.arange(1, len(d) + 1), "o-", ms=3, label=kind)
    ax[0].set_xlabel("detection delay (ms)")
    ax[0].set_ylabel("true losses detected (cumulative)")
    kinds = [k for k in lock_campaign.KINDS if any(r["kind"] == k for r in rows)]
    s = lock_campaign.summary(rows)
    ax[1].bar(kinds, [s[k]["not_lost"] for k in kinds], label="runs that never truly lost")
    ax[1].bar(kinds, [s[k]["false_alarms"] for k in kinds], label="flagged all the same")
    ax[1].set_ylabel("runs")
    grid_and_legends(ax)
    return save_figure(fig, path, title)


@register("B-THERMAL", cost=5)
def thermal(out: Path) -> Measurement:
    fixed = run("beyond-thermal", {"controller": {"param_adapt": True}})
    plain = run("beyond-thermal", {"controller": {"param_adapt": False}})
    cold = run("beyond-thermal", {"controller": {"param_adapt": False}, "thermal": {"enabled": False}})
    T = fixed.scenario.duration
    sf, sp = error_stats(fixed, T_THERMAL, T), error_stats(plain, T_THERMAL, T)
    end = window_mask(fixed["t"], T - 4.0, T)   # the last cycle
    value = {"max_error_deg": sf["max"], "max_error_uncorrected_deg": sp["max"],
             "max_error_cold_deg": error_stats(cold, T_THERMAL, T)["max"],
             "T_winding_end_degC": float(fixed["T_winding"][-1]), "T_magnet_end_degC": float(fixed["T_magnet"][-1]),
             "R_s_rise_pct": float(100 * (fixed["R_s_true"][-1] / fixed.scenario.machine.R_s - 1)),
             "psi_f_fall_pct": float(100 * (1 - fixed["psi_f_true"][-1] / fixed.scenario.machine.psi_f)),
             "R_s_hat_error_pct_last_cycle": float(100 * np.max(np.abs(fixed["R_s_hat"][end] / fixed["R_s_true"][end] - 1))),
             "psi_f_hat_error_pct_last_cycle": float(100 * np.max(np.abs(fixed["psi_f_hat"][end] / fixed["psi_f_true"][end] - 1))),
             "stop_reason": fixed.stop_reason}
    for which in THERMAL_HOLDS:
        for name, res in (("corrected", fixed), ("uncorrected", plain), ("cold", cold)):
            m = _hold_means(res, which)
            value[f"{which}_mean_first_last_{name}_deg"] = [float(m[0]), float(m[-1])]
    ok = _thermal_lock(fixed) and sf["max"] < 10.0
    fig = _figure_thermal(fixed, plain, out / "B-THERMAL.png",
                          "yang2022 machine heating at rated load, blended sensorless: with and without online R_s, psi_f")
    scale = fixed.scenario.data["thermal"]["time_scale"]
    note = (f"Scenario beyond-thermal: rated load (2 N m) taken on at standstill on injection, then a 4 s speed cycle "
            f"(100 rpm on injection alone, 600 rpm on the back-EMF observer alone, through the blend both ways) for "
            f"{T:g} s, the two-node thermal model of the machine's [thermal] table running with its heat capacities "
            f"divided by {scale:g} ({T * scale / 60:.0f} min of heating; the temperatures reached depend on the "
            f"thermal resistances and losses only). The winding reaches {value['T_winding_end_degC']:.0f} degC "
            f"(R_s +{value['R_s_rise_pct']:.0f} % over the controller's 20 degC value), the magnets "
            f"{value['T_magnet_end_degC']:.0f} degC (open-circuit psi_f -{value['psi_f_fall_pct']:.1f} %). Max |error| "
            f"from {T_THERMAL:g} s on. Each estimator's mean error over its holds, first and last cycle: the back-EMF "
            f"observer drifts with R_s (R_s i_d along d, against the EMF w psi_f along q), which the correction removes; "
            f"the injection estimator drifts with R_s (its carrier phase compensation, fs_hfi.h), which the correction "
            f"reaches, and with the magnet (the saturation its cross-saturation table was calibrated at, cold), which it does "
            f"not. The cold run is the same cycle with the thermal model off (machine at 20 degC). The online "
            f"correction (csrc/control/fs_param_adapt.h) fits the q-axis voltage equation u_q - w L_d i_d = R_s i_q + "
            f"w psi_f over a 5 s window of the cycle's operating points; its psi_f is the flux under load, which "
            f"cross-saturation lowers below the open-circuit value the plant traces (psi_f_hat_error_pct_last_cycle).")
    return Measurement(value, bool(ok), note, [fig])


# B-LOCK measures the claim's campaign, lock_campaign's original set (358 runs). Its added set (144 probes of
# the checks fs_monitor.h gained: the yang2022 full range as a base of its own, pi-off starts from 150 and 210
# el.deg, twelve more zoo machines; about 12 s of CPU, 40 % of the campaign) is neither in the claim's
# statement nor in its verdict: `python -m fullspeed.workflows.lock_campaign OUT` runs it beside the original
# set and prints both, and tests/test_lock.py runs a sample of it.
@register("B-LOCK", cost=16)
def lock(out: Path) -> Measurement:
    folder = sweep_dir(out, "B-LOCK")
    shutil.rmtree(folder, ignore_errors=True)   # measured afresh (common.sweep_dir)
    rows = lock_campaign.run_campaign(folder, added=False)
    s = lock_campaign.summary(rows)
    (out / "B-LOCK-table.md").write_text(lock_campaign.table(s) + "\n")
    a, h = s["all"], s["healthy"]
    value = {"runs": a["runs"], "true_losses": a["true_losses"], "detected": a["detected"],
             "detection_pct": a["detection_pct"], "healthy_runs": h["not_lost"],
             "false_alarms_healthy": h["false_alarms"], "false_alarm_pct": h["false_alarm_pct"],
             "flagged_without_true_loss": a["false_alarms"], "of_them_slipping": a["slipping_flags"],
             "delay_median_ms": a["delay_median_ms"], "delay_worst_ms": a["delay_worst_ms"], "refused": a["errors"]}
    ok = (value["detection_pct"] is not None and value["detection_pct"] >= 99.0
          and value["false_alarm_pct"] is not None and value["false_alarm_pct"] <= 1.0
          and value["delay_median_ms"] is not None and value["delay_median_ms"] <= 20.0)
    flagged = [r for r in rows if lock_campaign.judge(r)["false_alarm"]]
    stopped = sum(r["stop_reason"] not in ("done", "error") for r in flagged)
    pol = [r["flag_at"] for r in rows if r["kind"] == "polarity" and r.get("flag_at") is not None]
    fig = _figure_lock(rows, out / "B-LOCK.png", f"B-LOCK: {a['runs']} runs, {a['true_losses']} true losses")
    note = (f"Campaign fullspeed.workflows.lock_campaign (seed {lock_campaign.SEED}), monitor in detect mode so that every run "
            "goes on to its end; the claim's " + lock_campaign.ORIGINAL
            + " Truth: metrics.true_loss_at (the loops' angle "
            "more than 90 el.deg off in a sensorless stage for 20 ms net). Delay: first lock_lost minus the true "
            "loss, 0 for a flag before it. False alarms: runs of the healthy kind that never truly lost and were "
            f"flagged: {value['false_alarms_healthy']} in {value['healthy_runs']} (none in 190 bounds the rate below "
            "1.6 % with 95 % confidence). The pi-off starts"
            + (f" were flagged {1e3 * min(pol):.0f}-{1e3 * max(pol):.0f} ms after the start, median "
               f"{1e3 * float(np.median(pol)):.0f} ms" if pol else " were not flagged") + ". Beside them, "
            f"{value['flagged_without_true_loss']} runs were flagged without a true loss; "
            f"{value['of_them_slipping']} of these had the error past 90 el.deg for 20 ms or more in all (an estimate "
            "slipping through +-180 el.deg, which the net count of the truth does not see as lost), the others are "
            f"overloads beyond the torque limit and parameters off by x2 that swing the estimate; {stopped} of the "
            f"{len(flagged)} ended in a protection stop. By kind: B-LOCK-table.md. The campaign's added set (144 "
            "probes of the slip and jump checks: the yang2022 full range as a base, pi-off starts from 150 and 210 "
            "el.deg, twelve more zoo machines) is not the claim's and is not run here: python -m "
            "fullspeed.workflows.lock_campaign OUT runs it beside this set."
            + "".join(f" Zoo machine {k} left out: its scenario is refused ({why})." for k, why in
                      lock_campaign.ZOO_REFUSED.items()))
    return Measurement(value, bool(ok), note, [fig])


# B-MAPID: the zoo's saturating machines are its even indices; MAPID_SAMPLE of
# them (k = 0, 2, ..): the fewest whose 95th percentile is not the worst alone
# (numpy's interpolation puts it between the two largest of 20), about 8 s on
# two idle cores. The published catalog's flux-map machines are not in the
# campaign yet: on a free shaft their standstill steps do not hold the rotor
# (prius2004-mg2, syre-thor, baldor-ecs101m0h7ef4 turn it in LEVELS); locked,
# they are identified (identify's [identify] locked = true).
MAPID_SAMPLE = 20
# The second half on the first MAPID_SENSORLESS of them: B-REAL's scenario twice per machine (about 4 s of
# simulation each, switching inverter): 12 runs, about 20 s on two cores
MAPID_SENSORLESS = 6
MAPID_KEEP = range(0, 2 * MAPID_SENSORLESS, 2)


# B-IDENT: the whole zoo (an identification takes 4-12 s simulated, 6 s the
# median, its flux map's steps included; about 0.2 s of CPU, the 50
# sensorless runs on the identified parameters about 0.3 s each: 32 s of
# CPU in all). What a 95th percentile needs: n runs hold the true p95 below
# their k-th largest with probability P(Binomial(n, 0.05) >= k): 95 % takes
# n >= 59 for the largest (k = 1), 93 for the second, 124 for the third.
# 100 decide "p95 <= goal" with 96 % confidence by the second largest, not
# the largest alone (a sample of 59 would leave the worst run deciding the
# claim); numpy's p95 of 100 lies between the 95th and 96th values. Kept at
# the zoo's 100 (the claim says "over the zoo").
IDENT_SAMPLE = 100
# output folder -> zoo machine -> its identification in this reproduction (B-MAPID's machines are among B-IDENT's:
# the same identification, zoo_identification(k), made once)
IDENTIFIED: dict[Path, dict[int, dict]] = {}


@register("B-IDENT", shares="the zoo's runs", cost=31)
def ident(out: Path) -> Measurement:
    # B-MAPID's second half runs its first machines on their identified files: written here
    rows = zoo_campaign(range(IDENT_SAMPLE), out / "B-IDENT-runs", keep=MAPID_KEEP)
    IDENTIFIED[out] = {int(r["k"]): r for r in rows}
    s = campaign_summary(rows)
    # identify, then run sensorless: lock kept as often on the identified parameters as on the true ones (on the
    # true ones B-ZOO's runs where it ran before in this process: the same scenario, zoo.RUNS)
    sl = sensorless_on_identified(rows, out / "B-IDENT-sensorless", true_runs=zoo.RUNS.get(out))
    path = out / "B-IDENT.json"
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps({"summary": s, "rows": rows}, indent=1, default=str))
    tmp.replace(path)
    value = {f"{q}_p95_pct": s[q]["p95"] for q in GOALS_PCT}
    value.update({"machines": s["machines"], "failed_pct": s["failed_pct"],
                  "sensorless_kept_true": sl["kept_true"], "sensorless_kept_identified": sl["kept_identified"],
                  "sensorless_machines": sl["machines"]})
    within = all(s[q]["p95"] is not None and s[q]["p95"] <= goal for q, goal in GOALS_PCT.items())
    as_often = sl["kept_identified"] >= sl["kept_true"]
    named = s["failed_with_reason"] == round(s["failed_pct"] * s["machines"] / 100.0)
    note = (f"fullspeed.workflows.identify.zoo_campaign over zoo machines 0..{IDENT_SAMPLE - 1} (seed of fullspeed.model.zoo), "
            "each from a seeded random rotor angle on its own bench (switching inverter with dead time, 12-bit "
            "quantization, sensor noise), a free shaft with its friction. L_d and L_q against the plant's "
            "incremental inductance at zero current. Per quantity p50 / p95 / worst |error| %: "
            + "; ".join(f"{q} {s[q]['p50']:.2f} / {s[q]['p95']:.2f} / {s[q]['max']:.2f}" for q in GOALS_PCT
                        if s[q]["p95"] is not None)
            + f". {s['failed_pct']:.1f} % failed, {s['failed_with_reason']} of them each quantity with its step and "
              "reason" + (": " + json.dumps(s["failures"])[:400] if s["failures"] else "")
            + ". Rows in B-IDENT.json. Then sensorless (scenario beyond-zoo, the zoo's saturating machines, whose "
              "polarity pulses read the saturation's asymmetry) on the true and on the identified parameters "
              f"(controller.*_scale): lock kept (completed, nothing flagged, no true loss) in {sl['kept_true']} and "
              f"{sl['kept_identified']} of {sl['machines']}" + (f"; the machines whose outcome differs: {sl['differ']}"
                                                                 if sl["differ"] else "") + ".")
    return Measurement(value, within and named and as_often, note)




@register("B-MAPID", shares="the zoo's runs", cost=7)
def mapid(out: Path) -> Measurement:
    ks = range(0, 2 * MAPID_SAMPLE, 2)
    known = IDENTIFIED.get(out, {})
    rows = ([known[k] for k in ks] if all(k in known for k in ks)
            else zoo_campaign(ks, out / "B-MAPID-runs", keep=MAPID_KEEP))
    s = map_summary(rows)
    sl = identified_against_true(rows, out)
    path = out / "B-MAPID.json"
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps({"summary": s, "sensorless": sl,
                               "rows": [{k: r.get(k) for k in ("k", "machine", "description", "ended_in", "status", "reason",
                                                               "map", "motion", "times")} for r in rows]},
                              indent=1, default=str))
    tmp.replace(path)
    value = {"rms_p95_pct": s["p95"], "rms_p50_pct": s["p50"], "rms_max_pct": s["max"],
             "constant_model_rms_p95_pct": s["constant_p95"], "machines": s["machines"], "identified": s["identified"],
             "sensorless_within_1_deg": sl["within"], "sensorless_comparable": sl["comparable"],
             "sensorless_machines": sl["machines"]}
    first = s["identified"] == s["machines"] and s["p95"] is not None and s["p95"] <= MAP_GOAL_PCT
    second = sl["comparable"] > 0 and sl["within"] == sl["comparable"]
    times = [r["times"]["quantities"]["map"] for r in rows if r.get("times")]
    note = (f"First half: fullspeed.workflows.identify.zoo_campaign on the zoo's saturating machines k = 0, 2, .., "
            f"{2 * MAPID_SAMPLE - 2} (seed of fullspeed.model.zoo), each from a seeded random rotor angle on its own bench "
            "(switching inverter with dead time, 12-bit quantization, sensor noise), a free shaft with its friction: "
            "the map identified at standstill (fs_mapid.h: a d sweep and q sweeps at 7 d levels, each of zero torque "
            "impulse and sized against the rotor's motion from the machine file's psi_f and J, the speed voltage of "
            "the rotor's swing taken out) and its d axis at speed "
            "(steady voltage equations), held against the plant's magnetics on 1,257 points of the current limit's "
            f"disc. RMS error, % of psi_f, p50 / p95 / worst: {s['p50']:.2f} / {s['p95']:.2f} / {s['max']:.2f} "
            f"({s['identified']} of {s['machines']} identified"
            + (f"; not: {json.dumps(s['not_identified'])[:300]}" if s["not_identified"] else "")
            + f"); the constant L_d, L_q, psi_f the map replaces: p50 {s['constant_p50']:.2f}, p95 {s['constant_p95']:.2f}. "
            + (f"The map's steps take {np.median(times):.2f} s on the drive (median; MAP, CHECK and DCURVE). " if times else "")
            + f"First half {'met' if first else 'not met'}. "
            + f"Second half, on the first {sl['machines']} of them with a machine file identified (k = "
            + ", ".join(str(r["k"]) for r in sl["rows"]) + "): B-REAL's full-range scenario (reproduce.papers.real) "
            "sensorless on the true machine, the drive designed from the true machine and then from the identified "
            "machine file (scenario field plant_machine: the true machine turns), each from the rotor's initial angles "
            + ", ".join(f"{a:g}" for a in THETA0_DEG) + " el.deg (the largest error is chaotic in the start: one pair "
            "of runs moves by more than the tolerance); the mean over them of the identified map's largest error "
            f"(outside the 50 ms after each step) at most {ANGLE_TOL:g} el.deg above the true map's mean: "
            f"{sl['within']} of {sl['comparable']} comparable (a machine one of whose true-map runs does not complete "
            "is not comparable: B-REAL's own finding). Per machine (k: true / identified mean largest error "
            "[least..most], el.deg, or why not): "
            + "; ".join(f"{r['k']}: " + ("{} / {}".format(*(f"{r[w]['mean']:.2f} [{r[w]['least']:.2f}..{r[w]['most']:.2f}]"
                                                         for w in ("true", "identified")))
                                         if "diff_deg" in r else r["verdict"]) for r in sl["rows"])
            + f". Second half {'met' if second else 'not met'}. Rows in B-MAPID.json.")
    return Measurement(value, first and second, note)
