"""zou2021: the indirect matrix converter drive - modulation up to a transfer
ratio of 1 and wide-speed flux weakening (secs. 3-6, Figs. 3, 4, 9-19).

The reading taken (the figures are missing from the text; captions and the
text around them decide):
- PART_1, eqs. (26)-(31): the input is the q voltage the current regulator
  asks for minus the one realised after over-modulation; the output is added
  to i_d0* (= 0), i_q* is the speed loop's; the current circle of eq. (24)
  (I_max) limits the reference. The regulators are the paper's internal-model
  PIs (sec. 5.1, its refs. [21, 22]; sec. 4.2: k_p = L_s w_c, k_i = R_s w_c)
  and keep the over-modulation excess in their integrals, as eq. (26)'s
  v_q* = w (L i_d0* + psi_f) says: the scenarios' gains = "internal_model",
  fw_excess = "held" (fs_fw.h). Wound back by an anti-windup instead
  (WOUND_BACK, the reproduction's earlier reading) the low-pass of eq. (30)
  holds i_d only on a standing q-current error, which the speed integral
  carries in i_q*.
- PART_2, eqs. (32)-(33): alpha from a PI on |i*| - I_lim, gated by the
  polarity of i_d_fw (sec. 4.4); I_lim < I_max is its threshold.
- The i_d = 0 baseline of Figs. 9 and 15 (curves A, a): the linear region.
  Sec. 2 runs i_d = 0 with both stages' linear SVM and switches the inverter
  to over-modulation when PART_1's output is non-zero; Table 1 puts MTPA in
  region A alone (q <= 0.866); the abstract compares with "the MTPA method"
  and the conclusions raise the VTR "from 0.866 to 1". Its current limit is
  I_max (eq. (24)).
"""
from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..._core import ffi, lib
from ...design.checks import top_speed
from ...design.scenario import load_scenario
from ...model.machines import Machine
from ...model.schema import deep_merge
from ...model.units import rad_s_to_rpm
from ...sim.metrics import window_mask
from ...sim.runner import Result
from ...workflows.journal import run_tasks
from ..registry import Measurement, register
from .common import grid_and_legends, run, save_figure, sweep_dir

F_GRID = 50.0
H_MAX = 40          # THD: harmonics 2..40 (2 kHz), below the 2.5 kHz Nyquist limit of the period means
PAPER_THD = {"A": 7.89, "B": 18.16, "C": 23.54}        # %, secs. 5.3.1-5.3.3
PAPER_RIPPLE = {"A": 0.8, "B": 7.0, "C": 10.0}         # N m peak-to-peak
REGION_FIGURE = {"A": 11, "B": 12, "C": 13}
STRATEGIES = {     # Figs. 9 and 15: curves A, B, C
    "id0": {"controller": {"flux_weakening": False, "depth_control": False}, "converter": {"modulation": "linear"}},
    "part1": {"controller": {"depth_control": False}, "converter": {"modulation": "om1"}},
    "part12": {},
}
PART1_ONLY = STRATEGIES["part1"]
# not one of the paper's curves: i_d = 0 with the inverter stage allowed to over-modulate (OM-I)
ID0_OM1 = {"controller": {"flux_weakening": False, "depth_control": False}, "converter": {"modulation": "om1"}}


# PART_1 as the reproduction first read it: eq. (31)'s gain of 1 on the pole-placement regulators,
# whose anti-windup winds the over-modulation excess back every sample (fs_fw.h)
WOUND_BACK = {"controller": {"gains": "designed", "fw_excess": "wound_back", "fw_gain": 1.0}}


def eq12(alpha: float) -> float:
    """eq. (12): the sector mean of the dc link over V_im."""
    return 9.0 / math.pi * (math.log(math.tan(math.pi / 3 - alpha / 2)) + 2.0 / math.sqrt(3.0) * math.sin(alpha))


@lru_cache(maxsize=None)
def _run(name: str, variant: str = "part12") -> Result:
    """A catalog scenario under one of the strategies, run once per reproduction."""
    return run(name, STRATEGIES[variant] or None)


def _grid_v_im(res: Result) -> float:
    return res.scenario.data["converter"]["grid_ll_rms"] * math.sqrt(2.0 / 3.0)


def spectrum(res: Result, t0: float, t1: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Amplitude spectrum of the grid current of phase a (its period means)
    over the whole grid cycles in [t0, t1]: Hz, A, and the cycle count (the
    bin of the fundamental)."""
    t = res["t"]
    n_cyc = math.floor((t1 - t0) * F_GRID + 1e-9)
    m = window_mask(t, t0, t0 + n_cyc / F_GRID - 0.5 * (t[1] - t[0]))
    x = res["i_grid_a"][m]
    return np.fft.rfftfreq(x.size, t[1] - t[0]), 2.0 * np.abs(np.fft.rfft(x)) / x.size, n_cyc


def thd(res: Result, t0: float, t1: float) -> float:
    """THD of the grid current of phase a, %: harmonics 2..H_MAX over the
    fundamental, over the whole grid cycles in [t0, t1]."""
    _, amp, n_cyc = spectrum(res, t0, t1)
    h = n_cyc * np.arange(1, H_MAX + 1)   # bins of the harmonics
    return 100.0 * float(np.sqrt(np.sum(amp[h[1:]] ** 2)) / amp[h[0]])


def rise_time(res: Result, t_step: float, n0: float, n1: float) -> float:
    """10 % -> 90 % of a speed step n0 -> n1 (rpm), s; nan if not reached."""
    t, n = res["t"], rad_s_to_rpm(res["w_m"])
    after = t >= t_step
    lo, hi = n0 + 0.1 * (n1 - n0), n0 + 0.9 * (n1 - n0)
    k_lo = np.flatnonzero(after & (n >= lo))
    k_hi = np.flatnonzero(after & (n >= hi))
    if k_lo.size == 0 or k_hi.size == 0:
        return math.nan
    return float(t[k_hi[0]] - t[k_lo[0]])


def settling_time(res: Result, t_step: float, n1: float, band: float = 0.02) -> float:
    """From the step until the speed stays within band x n1 of n1 (rpm), s."""
    t, n = res["t"], rad_s_to_rpm(res["w_m"])
    outside = (t >= t_step) & (np.abs(n - n1) > band * abs(n1))
    return float(t[np.flatnonzero(outside)[-1]] - t_step) if outside.any() else 0.0


def region_stats(res: Result) -> dict:
    """The steady window's speed error, THD, torque ripple, d-current, depth
    angle and the share of over-modulated periods."""
    t0, t1 = res.scenario.data["metrics"]["steady"]
    m = window_mask(res["t"], t0, t1)
    n_ref = rad_s_to_rpm(res["w_m_ref"][m][-1])
    return {
        "speed_error_rpm": float(np.mean(rad_s_to_rpm(res["w_m"][m])) - n_ref),
        "thd_pct": thd(res, t0, t1),
        "torque_ripple_pp_Nm": float(np.ptp(res["T_e"][m])),
        "torque_mean_Nm": float(np.mean(res["T_e"][m])),
        "i_d_mean_A": float(np.mean(res["i_d"][m])),
        "alpha_mean_rad": float(np.mean(res["alpha"][m])),
        "alpha_max_run_rad": float(np.max(res["alpha"])),
        "overmod_share": float(np.mean(res["overmod"][m])),
        "v_pn_mean_V": float(np.mean(res["v_pn"][m])),
    }


def _held(name: str, overrides: dict, n: float, T: float) -> bool:
    """The drive holds n rpm under T N m: the speed ramped to n over 0.4 s is
    within 1 % of it over the last 0.2 s, and the run was not stopped."""
    ov = {**overrides, "references": {"speed_rpm": [[0.0, 0.0], [0.4, n], [0.8, n]]}, "load": {"torque": T}}
    res = run(name, ov, warn=False)   # a bisection's probe past the envelope: its warning is read by no one
    if res.stop_reason != "done":
        return False
    m = window_mask(res["t"], 0.6, 0.8)
    return abs(float(np.mean(rad_s_to_rpm(res["w_m"][m]))) - n) < 0.01 * n


HINT_BAND = 0.07   # the search starts within +-7 % of the analytic limit (the envelopes lie within 1.5 % of it)


def max_speed(name: str, overrides: dict, T: float, lo: float, hi: float, tol: float = 5.0,
              hint: float | None = None) -> float:
    """The highest speed held under T, by bisection over runs (rpm); with
    the analytic limit as a hint, within HINT_BAND of it when the band
    brackets the held speed (two runs say so), else over [lo, hi]."""
    if hint is not None and math.isfinite(hint):
        a, b = max(lo, (1.0 - HINT_BAND) * hint), min(hi, (1.0 + HINT_BAND) * hint)
        if a < b and _held(name, overrides, a, T) and not _held(name, overrides, b, T):
            lo, hi = a, b
        elif not _held(name, overrides, lo, T):
            return math.nan
    elif not _held(name, overrides, lo, T):
        return math.nan
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if _held(name, overrides, mid, T):
            lo = mid
        else:
            hi = mid
    return lo


def envelope_point(task: dict) -> dict:
    """One point of an envelope (a sweep task): the highest speed held."""
    return {"rpm": max_speed(task["scenario"], task["overrides"], task["T"], task["lo"], task["hi"],
                             hint=task.get("hint"))}


def envelopes(name: str, torques: list[float], extra: dict, lo: float, hi: float, out: Path,
              strategies: dict = STRATEGIES) -> dict:
    """Highest held speed per strategy and torque (Figs. 9 and 15); the
    searches run through the sweep engine, in parallel, into out."""
    tasks = []
    for key, ov in strategies.items():
        merged = deep_merge(extra, ov)
        sc = load_scenario(name, merged)
        ctl, conv = sc.data["controller"], sc.data["converter"]
        V = VTR[conv["modulation"]] * conv["grid_ll_rms"] * math.sqrt(2.0 / 3.0)
        I = ctl["i_max"] if ctl["flux_weakening"] else None
        tasks += [{"scenario": name, "overrides": merged, "T": T, "lo": lo, "hi": hi,
                   "hint": limit_rpm(sc.machine, T, V, I)} for T in torques]
    res = run_tasks(envelope_point, tasks, out, fresh=True)
    rpm = [r["rpm"] if r.get("rpm") is not None else math.nan for r in res]
    n = len(torques)
    return {key: rpm[k * n:(k + 1) * n] for k, key in enumerate(strategies)}


def limit_rpm(m: Machine, T: float, V: float, I: float | None = None) -> float:
    """The highest speed (rpm) at which the machine makes the load torque T
    (plus its friction) in steady state, eq. (22) with R_s, within the phase
    voltage amplitude V: with i_d = 0 (I None) or with the current on the
    circle of radius I; nan if I cannot make T."""
    w_m = 0.0
    for _ in range(30):   # the friction depends on the speed: a fixed point
        T_m = T + m.T_coulomb + m.B * w_m
        i_q = T_m / (1.5 * m.pole_pairs * m.psi_f)   # the surface-magnet machine's: no reluctance torque
        if I is not None and i_q >= I:
            return math.nan
        w_m = top_speed(m, V, T_m, 0.0 if I is None else -math.sqrt(I * I - i_q * i_q))
    return rad_s_to_rpm(w_m)


# each region's largest VTR, sec. 3.3 and eqs. (20)-(21) (CASE 1; CASE 2 at alpha = pi/6), as the modulator has them
VTR = {"linear": lib.fs_imc_vtr_max(lib.FS_IMC_LINEAR, 0.0), "om1": lib.fs_imc_vtr_max(lib.FS_IMC_OM1, 0.0),
       "om2": lib.fs_imc_vtr_max(lib.FS_IMC_OM2, math.pi / 6)}


def limits(m: Machine, torques: list[float], V_im: float, i_max: float, i_lim: float) -> dict:
    """The analytic envelopes (rpm per torque): i_d = 0 in the linear region
    and in OM-I; PART_1 (OM-I) and PART_1 + PART_2 (OM-II) with the current
    on I_max (eq. (24)) and on I_lim."""
    curves = {"id0": ("linear", None), "id0_om1": ("om1", None),
              "part1": ("om1", i_max), "part12": ("om2", i_max),
              "part1_ilim": ("om1", i_lim), "part12_ilim": ("om2", i_lim)}
    return {k: [limit_rpm(m, T, VTR[mod] * V_im, I) for T in torques] for k, (mod, I) in curves.items()}


def limit_gains(lim: dict, k: int) -> dict:
    """The gains (%) the analytic envelopes give at torque index k, per
    reading of the baseline (linear or OM-I) and of the current limit."""
    g = {}
    for base in ("id0", "id0_om1"):
        for cap in ("", "_ilim"):
            key = f"{'linear' if base == 'id0' else 'OM-I'} baseline, {'I_lim' if cap else 'I_max'}"
            g[key] = tuple(100.0 * (lim[c + cap][k] / lim[base][k] - 1.0) for c in ("part1", "part12"))
    return g


ENVELOPE_LABELS = {"id0": "A: i_d = 0 (linear)", "part1": "B: PART_1", "part12": "C: PART_1 + PART_2",
                   "id0_om1": "i_d = 0 with OM-I", "part1_ilim": "B at I_lim", "part12_ilim": "C at I_lim",
                   "part1_wound_back": "B, excess wound back"}


def _figure_envelopes(torques, env, lim: dict, path: Path, title: str) -> str:
    """Left: the measured envelopes (markers) on the analytic limits (lines).
    Right: the gains over the linear i_d = 0 against torque, measured and
    analytic, with the paper's +30 % and +35 % (each +-5 points) shaded."""
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
    colors = {"id0": "C0", "id0_om1": "C7", "part1": "C1", "part12": "C2", "part1_wound_back": "C3"}
    for key, speeds in env.items():
        ax[0].plot(speeds, torques, "o", color=colors.get(key), label=f"{ENVELOPE_LABELS[key]}, measured")
    for key, speeds in lim.items():
        base = key.replace("_ilim", "")
        ax[0].plot(speeds, torques, ":" if key.endswith("_ilim") else "-", color=colors[base], lw=1.0,
                   label=f"{ENVELOPE_LABELS[key]}, limit")
    ax[0].set_xlabel("highest steady speed (rpm)")
    ax[0].set_ylabel("load torque (N m)")
    ax[0].legend(fontsize=6, ncol=2)
    b = ax[1]
    for lo, hi, c in ((25.0, 35.0, "C1"), (30.0, 40.0, "C2")):
        b.axhspan(lo, hi, color=c, alpha=0.12)
    for key in ("part1", "part12", "part1_wound_back"):
        if key in env:
            b.plot(torques, [100.0 * (x / a - 1.0) for x, a in zip(env[key], env["id0"])], "o-", color=colors[key],
                   label=f"{ENVELOPE_LABELS[key]} over A, measured")
    for key in ("part1", "part12"):
        for base, cap, style in (("id0", "", "-"), ("id0_om1", "", "--"), ("id0_om1", "_ilim", ":")):
            b.plot(torques, [100.0 * (x / a - 1.0) for x, a in zip(lim[key + cap], lim[base])], style,
                   color=colors[key], lw=0.9,
                   label=f"{ENVELOPE_LABELS[key][:1]} limit over {'A' if base == 'id0' else 'OM-I i_d = 0'}"
                         f"{', at I_lim' if cap else ''}")
    b.set_xlabel("load torque (N m)")
    b.set_ylabel("speed range over i_d = 0 (%)")
    b.legend(fontsize=7, ncol=2)
    for a in ax:
        a.grid(True, alpha=0.3)
    return save_figure(fig, path, title)


def _figure_region(res: Result, path: Path, title: str) -> str:
    """Like Figs. 11-13: speed, torque, stator currents, v_pn and alpha, i_d,
    and the grid current's spectrum over the steady window."""
    t = res["t"]
    fig, ax = plt.subplots(3, 2, figsize=(11, 7.5))
    a = ax[0, 0]
    a.plot(t, rad_s_to_rpm(res["w_m"]), label="n")
    a.plot(t, rad_s_to_rpm(res["w_m_ref"]), "--", label="n*")
    a.set_ylabel("speed (rpm)")
    a.legend(fontsize=8)
    ax[0, 1].plot(t, res["T_e"], lw=0.6)
    ax[0, 1].set_ylabel("T_e (N m)")
    for ch in ("i_a", "i_b", "i_c"):
        ax[1, 0].plot(t, res[ch], lw=0.5)
    ax[1, 0].set_ylabel("i_A, i_B, i_C (A)")
    ax[1, 1].plot(t, res["v_pn"], lw=0.5, label="v_pn, period mean")
    ax[1, 1].set_ylabel("v_pn (V)")
    b = ax[1, 1].twinx()
    b.plot(t, res["alpha"], "r", lw=1.0)
    b.set_ylabel("alpha (rad)", color="r")
    ax[2, 0].plot(t, res["i_d"], lw=0.6, label="i_d")
    ax[2, 0].plot(t, res["i_q"], lw=0.6, label="i_q")
    ax[2, 0].set_ylabel("current (A)")
    ax[2, 0].legend(fontsize=8)
    t0, t1 = res.scenario.data["metrics"]["steady"]
    f, amp, _ = spectrum(res, t0, t1)
    k = f <= H_MAX * F_GRID
    ax[2, 1].bar(f[k], amp[k], width=8.0)
    ax[2, 1].set_xlabel("frequency (Hz)")
    ax[2, 1].set_ylabel("grid current i_a (A)")
    for x in ax.flat:
        x.grid(True, alpha=0.3)
    for x in ax[:2, :].flat:
        x.set_xlabel("time (s)")
    return save_figure(fig, path, title)


def _v_pn(theta: float, alpha: float, u=ffi.new("float[3]"), r=ffi.new("fs_imc_rect *")) -> float:
    """fs_imc_rectifier's period mean over V_im at input angle theta (the
    buffers are allocated once)."""
    for k in range(3):
        u[k] = math.cos(theta - k * 2 * math.pi / 3)
    lib.fs_imc_rectifier(u, alpha, r)
    return r.v_pn


@register("Z-VPN")
def vpn(out: Path) -> Measurement:
    """The rectifier's sector means from fs_imc_rectifier on ideal input
    voltages, and in the plant from the passive-load runs."""
    alphas = np.linspace(0.0, math.pi / 6, 7)
    theta = (np.arange(3600) + 0.5) * (math.pi / 6) / 3600   # midpoints over sector 1
    worst, per_alpha = 0.0, []
    for alpha in alphas:
        means = [np.mean([_v_pn(th, float(alpha)) for th in theta + sector * math.pi / 6]) for sector in range(12)]
        dev = 100.0 * max(abs(x / eq12(alpha) - 1.0) for x in means)
        worst = max(worst, dev)
        per_alpha.append(dev)
    plant = {}
    for mod in ("om1", "om2"):
        res = run("zou2021-modulator-vtr", {"converter": {"modulation": mod}})
        m = window_mask(res["t"], 0.1, 0.3)
        alpha = float(np.mean(res["alpha"][m]))
        plant[mod] = 100.0 * (float(np.mean(res["v_pn"][m])) / (_grid_v_im(res) * eq12(alpha)) - 1.0)
    value = {"max_dev_pct": worst, "dev_pct_per_alpha": per_alpha,
             "eq9_over_Vim": eq12(0.0), "eq10_over_Vim": eq12(math.pi / 6),
             "plant_dev_pct_case1": plant["om1"], "plant_dev_pct_case2": plant["om2"]}
    ok = worst < 1.0 and all(abs(v) < 1.0 for v in plant.values())
    fig, ax = plt.subplots(figsize=(6, 3.5))
    th = np.linspace(0, 2 * math.pi, 1441)
    for alpha in (0.0, math.pi / 12, math.pi / 6):
        v = [_v_pn(x, alpha) for x in th]
        ax.plot(np.degrees(th), v, label=f"alpha = {math.degrees(alpha):.0f} deg (eq. (12): {eq12(alpha):.4f})")
    ax.set_xlabel("input angle w_i t (deg)")
    ax.set_ylabel("v_pn / V_im")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    fig_name = save_figure(fig, out / "Z-VPN.png", "Rectifier stage: period-mean dc link (Fig. 3b)")
    note = ("fs_imc_rectifier on ideal input voltages, 3600 points per sector, all 12 sectors, alpha in 7 steps "
            "from 0 to pi/6: the worst sector mean's deviation from eq. (12) (alpha = 0 is eq. (9), pi/6 eq. (10)). "
            "In the plant (passive load, 7.6 A, the grid behind the LC filter): the mean v_pn over 10 grid "
            "cycles against eq. (12) x the grid's V_im, CASE 1 alone (om1) and alpha = pi/6 (om2); the filter's "
            "drop and the one-period prediction of the input voltage are in that difference.")
    return Measurement(value, ok, note, [fig_name])


@register("Z-VTR")
def vtr(out: Path) -> Measurement:
    targets = {"linear": 0.866, "om1": 0.954, "om2": 1.00}
    value, runs = {}, {}
    for mod in targets:
        res = run("zou2021-modulator-vtr", {"converter": {"modulation": mod}})
        t = res["t"]
        m = window_mask(t, 0.1, 0.3)
        x = res["u_ab"][m]
        spec = 2.0 * np.abs(np.fft.rfft(x)) / x.size
        k = int(round(40.0 * x.size * (t[1] - t[0])))   # the 40 Hz bin
        value[f"vtr_{mod}"] = float(spec[k] / math.sqrt(3.0) / _grid_v_im(res))
        runs[mod] = res
    ok = all(abs(value[f"vtr_{k}"] - v) <= 0.01 for k, v in targets.items())
    fig, ax = plt.subplots(3, 1, figsize=(7, 6.5), sharex=True)
    for a, (mod, res) in zip(ax, runs.items()):
        m = window_mask(res["t"], 0.1, 0.15)
        a.plot(res["t"][m], res["u_ab"][m], lw=0.6)
        a.set_ylabel("u_AB (V)")
        a.set_title(f"{mod}: VTR {value['vtr_' + mod]:.4f}", fontsize=9)
        a.grid(True, alpha=0.3)
    ax[-1].set_xlabel("time (s)")
    fig_name = save_figure(fig, out / "Z-VTR.png", "Output line voltage, period means, 40 Hz demanded at 2 V_im (Fig. 4b)")
    note = ("40 Hz output (k_m = 0.8) demanded at twice the input amplitude on an R-L load; the fundamental of the "
            "period-mean output line voltage u_A - u_B by FFT over 0.2 s (8 output, 10 input cycles), over sqrt3 "
            "and the grid's V_im. linear: the reference held inside sqrt3/2 V_im; om1: CASE 1 and "
            "minimum-phase-error over-modulation on the period's hexagon; om2: alpha from the demanded ratio "
            "(pi/6 here).")
    return Measurement(value, ok, note, [fig_name])


def _envelopes_sim(out: Path) -> tuple[list[float], dict]:
    torques = [2.5, 5.0, 7.5, 10.0, 12.5, 15.0]
    env = envelopes("zou2021-speed-range", torques, {}, 500.0, 3000.0, sweep_dir(out, "Z-SPEEDRANGE"),
                    {**STRATEGIES, "id0_om1": ID0_OM1, "part1_wound_back": deep_merge(PART1_ONLY, WOUND_BACK)})
    return torques, env


def _gains(torques: list[float], env: dict, T: float, base: str = "id0") -> tuple[float, float]:
    k = torques.index(T)
    return 100.0 * (env["part1"][k] / env[base][k] - 1.0), 100.0 * (env["part12"][k] / env[base][k] - 1.0)


def _bench_limits(name: str, torques: list[float], overrides: dict | None = None) -> dict:
    """limits() for a scenario's machine, grid and current limits."""
    sc = load_scenario(name, overrides)
    ctl = sc.data["controller"]
    return limits(sc.machine, torques, sc.data["converter"]["grid_ll_rms"] * math.sqrt(2.0 / 3.0),
                  ctl["i_max"], ctl["i_lim"])


# The paper's two benches (Figs. 9 and 15): the simulation's 380 V with I_max 15 A at the regions' 10 N m, and
# the prototype's 150 V with I_max 8.8 A at its 5 N m (sec. 6.1); the load torque, the search's bounds, I_lim.
# Both on the plant with the IMC's devices (the envelopes of Fig. 9 over six torques run on ideal switches, which
# moves their gains by less than a point: the speed-range scenario leaves the devices out to keep the search lean).
DEVICES = {"losses": {"devices": True}}
SIM_BENCH = {"overrides": DEVICES, "T": 10.0, "lo": 500.0, "hi": 3000.0, "i_lim": 12.0}
PROTOTYPE = {"overrides": {**DEVICES, "converter": {"grid_ll_rms": 150.0},
                           "controller": {"i_max": 8.8, "i_lim": 6.0, "fw_top_speed_rpm": 600.0}},
             "T": 5.0, "lo": 100.0, "hi": 1200.0, "i_lim": 6.0}


def at_i_lim(i_lim: float) -> dict:
    """B and C held at I_lim: the current limit at I_lim, PART_2's threshold 0.5 A below it."""
    return {"controller": {"i_max": i_lim, "i_lim": i_lim - 0.5}}


def ilim_strategies(i_lim: float) -> dict:
    """The over-modulating reading: i_d = 0 in OM-I, B and C held at I_lim."""
    return {"id0_om1": ID0_OM1, "part1_ilim": deep_merge(PART1_ONLY, at_i_lim(i_lim)), "part12_ilim": at_i_lim(i_lim)}


@lru_cache(maxsize=None)
def _prototype_envelopes(out: Path) -> dict:
    """The prototype bench's envelopes at 5 N m under both readings (Z-EXP's and Z-SPEEDRANGE's table)."""
    b = PROTOTYPE
    env = envelopes("zou2021-speed-range", [b["T"]], b["overrides"], b["lo"], b["hi"], sweep_dir(out, "Z-EXP"),
                    {**STRATEGIES, **ilim_strategies(b["i_lim"])})
    return {k: v[0] for k, v in env.items()}


def reading_gains(env: dict) -> dict:
    """The gains (%) of B and C over A under each reading, from one bench's envelopes at one torque."""
    def gain(key, base):
        return 100.0 * (env[key] / env[base] - 1.0)
    return {"linear i_d = 0, B and C to I_max": (gain("part1", "id0"), gain("part12", "id0")),
            "OM-I i_d = 0, B and C held at I_lim": (gain("part1_ilim", "id0_om1"), gain("part12_ilim", "id0_om1"))}


def within(g: tuple) -> bool:
    """+30 % / +35 %, each within 5 points (CLAIMS.md)."""
    return abs(g[0] - 30.0) <= 5.0 and abs(g[1] - 35.0) <= 5.0


@register("Z-SPEEDRANGE", shares="zou2021 envelopes", cost=8)
def speed_range(out: Path) -> Measurement:
    torques, env = _envelopes_sim(out)
    g1, g12 = _gains(torques, env, 10.0)
    k = torques.index(10.0)
    lim = _bench_limits("zou2021-speed-range", torques)
    b = SIM_BENCH
    sim = {key: v[0] for key, v in envelopes("zou2021-speed-range", [b["T"]], b["overrides"], b["lo"], b["hi"],
                                            sweep_dir(out, "Z-SPEEDRANGE-devices"),
                                            {**STRATEGIES, **ilim_strategies(b["i_lim"])}).items()}
    proto = _prototype_envelopes(out)
    table = {"simulation: 380 V, I_max 15 A, 10 N m": reading_gains(sim),
             "prototype: 150 V, I_max 8.8 A, 5 N m": reading_gains(proto)}
    table_sim_text = table["simulation: 380 V, I_max 15 A, 10 N m"]["linear i_d = 0, B and C to I_max"]
    value = {"gain_part1_pct": table_sim_text[0], "gain_part12_pct": table_sim_text[1], "torque_Nm": 10.0,
             "gains_ideal_switches_pct": (g1, g12),
             "gains_by_reading_and_bench_pct": table,
             "envelopes_by_reading_rpm": {"simulation": sim, "prototype": proto},
             "gain_part1_wound_back_pct": 100.0 * (env["part1_wound_back"][k] / env["id0"][k] - 1.0),
             "limit_gains_at_10Nm_pct": limit_gains(lim, k),
             "envelopes_rpm": env, "limits_rpm": lim, "torques_Nm": torques,
             "gains_per_torque_pct": {f"{T:g}": _gains(torques, env, T) for T in torques}}
    value["envelope_dev_from_limit_pct"] = {
        key: max(100.0 * abs(x / y - 1.0) for x, y in zip(env[key], lim[key])) for key in ("id0", "part1", "part12")}
    ok = within(table_sim_text)
    fig_name = _figure_envelopes(torques, env, lim, out / "Z-SPEEDRANGE.png",
                                 "Torque-speed envelopes, 380 V input (Fig. 9), on the voltage and current limits")
    m = load_scenario("zou2021-speed-range").machine
    ratio = {b: I * m.L_d / m.psi_f for b, I in (("simulation", 15.0), ("prototype", 8.8))}
    rows = []
    for bench, gains in table.items():
        for reading, g in gains.items():
            rows.append(f"{bench}, {reading}: +{g[0]:.1f} / +{g[1]:.1f} % ({'within' if within(g) else 'outside'})")
    sim_g, proto_g = table.values()
    both = [r for r in sim_g if within(sim_g[r]) and within(proto_g[r])]
    note = ("Each envelope point: the highest speed reference the drive holds within 1 % over 0.2 s after a 0.4 s "
            "ramp under the load torque, by bisection over runs (5 rpm). The table's envelopes run on the plant "
            "with the IMC's devices (the machine's [converter] module); those of the figure, over six torques, "
            "on ideal switches (gains_ideal_switches_pct at 10 N m, against the devices' gain_part1_pct, "
            "gain_part12_pct: the drops move every curve alike). Curve A is i_d = 0, B PART_1 (OM-I), C PART_1 + PART_2; "
            "PART_1's excess held by the paper's internal-model regulators (eq. (26), fs_fw.h). The paper does "
            "not say whether A over-modulates, nor whether B and C run to I_max or are held at I_lim; its text "
            "favours a linear A (sec. 2, Table 1, the abstract's 'MTPA method') and says nothing of B at I_lim "
            "(sec. 4.4 takes C past I_lim toward I_max), while its Region C (1750 rpm at 10 N m, "
            f"+{100.0 * (1750.0 / lim['id0'][k] - 1.0):.0f} % over the linear A's {lim['id0'][k]:.0f} rpm limit) "
            "argues for an over-modulating A. Both readings on both of the paper's benches "
            "(gains_by_reading_and_bench_pct; the same sentence, +30 % / +35 %, is in sec. 5.2 and sec. 6.2): "
            + "; ".join(rows) + ". "
            + ("No one reading is within 5 points on both benches: " if not both else
               f"Only {', '.join(both)} is within 5 points on both benches: ")
            + "the flux-weakening gain follows I_max L_s / psi_f, the share of the magnet's flux the current can "
            f"cancel: {ratio['simulation']:.2f} in the simulation and {ratio['prototype']:.2f} on the prototype, on "
            "Table 2's machine, so a reading that gives the paper's numbers on one bench misses them on the "
            "other. The claim is scored on the text's reading (linear A, the simulation bench, gain_part1_pct, "
            "gain_part12_pct); the measured envelopes lie on the machine's analytic limits (limits_rpm: eq. (22) "
            "with R_s in steady state, the VTR of eq. (20) and the current circle; envelope_dev_from_limit_pct). "
            "With the excess "
            "wound back (gain_part1_wound_back_pct) the standing q-current error fills the circle early and B "
            "ends lower.")
    return Measurement(value, ok, note, [fig_name])


def _region(claim: str, key: str, out: Path) -> tuple[Result, dict, str]:
    res = _run(f"zou2021-region-{key.lower()}")
    st = region_stats(res)
    fig = _figure_region(res, out / f"{claim}.png", f"Region {key} (Fig. {REGION_FIGURE[key]})")
    return res, st, fig


def _region_note(key: str) -> str:
    return (f"Steady window {{}}: THD of the grid current of phase a (period means, whole grid cycles, harmonics "
            f"2..{H_MAX}); torque ripple as the peak-to-peak of T_e sampled once per period (the switching ripple "
            f"inside a period is not modelled: the inverter stage is averaged per rectifier interval). Paper: THD "
            f"{PAPER_THD[key]} %, ripple {PAPER_RIPPLE[key]} N m.")


@register("Z-REGION-A", shares="zou2021 region runs")
def region_a(out: Path) -> Measurement:
    res, st, fig = _region("Z-REGION-A", "A", out)
    ok = (res.stop_reason == "done" and abs(st["speed_error_rpm"]) < 0.005 * 1200.0
          and st["alpha_max_run_rad"] == 0.0 and abs(st["i_d_mean_A"]) < 0.1)
    return Measurement(st, ok, _region_note("A").format("0.3-0.4 s") + " Passes on: speed error below 0.5 %, "
                       "alpha = 0 throughout, mean i_d within 0.1 A of 0.", [fig])


@register("Z-REGION-B", shares="zou2021 region runs")
def region_b(out: Path) -> Measurement:
    res, st, fig = _region("Z-REGION-B", "B", out)
    ok = (res.stop_reason == "done" and st["i_d_mean_A"] < -1.0 and st["overmod_share"] > 0.5
          and abs(st["speed_error_rpm"]) < 0.005 * 1500.0)
    return Measurement(st, ok, _region_note("B").format("0.4-0.6 s") + " Passes on: i_d < -1 A, more than half "
                       "the periods over-modulated, speed error below 0.5 %.", [fig])


@register("Z-REGION-C", shares="zou2021 region runs")
def region_c(out: Path) -> Measurement:
    res, st, fig = _region("Z-REGION-C", "C", out)
    ok = res.stop_reason == "done" and st["alpha_mean_rad"] > 0.0 and abs(st["speed_error_rpm"]) < 0.005 * 1750.0
    return Measurement(st, ok, _region_note("C").format("0.4-0.6 s") + " Passes on: alpha > 0 (over-modulation "
                       "II), speed error below 0.5 %.", [fig])


def iq_error(res: Result) -> float:
    """Mean i_q* - i_q over the steady window, A: the standing q-current error."""
    m = window_mask(res["t"], *res.scenario.data["metrics"]["steady"])
    return float(np.mean(res["i_q_ref"][m] - res["i_q"][m]))


DROPS = ("u_t", "r_t", "u_d", "r_d")       # the module's conduction parameters (machine [converter])
DROP_SCALES = (0.0, 0.5, 1.0, 1.5, 2.0)    # Z-THD-TREND: the module's drops scaled (0: ideal switches)
I_DROPS = 12.0                             # A: the regions' current, at which the drops are quoted


def scaled_drops(k: float) -> dict:
    """Overrides that scale the machine's module's conduction drops by k."""
    cv = load_scenario("zou2021-region-c").machine.converter
    return {"machine": {"converter": {key: k * cv[key] for key in DROPS}}}


def drops_at(k: float, i: float = I_DROPS) -> dict:
    """The drops at current i with the module's scaled by k, V: an IGBT, a diode, and the rectifier's path
    (two bidirectional switches, each an IGBT and a diode)."""
    cv = load_scenario("zou2021-region-c").machine.converter
    igbt, diode = k * (cv["u_t"] + cv["r_t"] * i), k * (cv["u_d"] + cv["r_d"] * i)
    return {"igbt_V": igbt, "diode_V": diode, "rectifier_path_V": 2.0 * (igbt + diode)}


def _figure_thd(c: Result, wb: Result, sweep: list[dict], drops: list[dict], thd_b: float, path: Path) -> str:
    """Left: Region C's q current under the two readings of PART_1. Middle:
    Region C's grid-current THD against the depth angle PART_2 holds (I_lim
    lowered step by step). Right: Regions B's and C's THD against the
    devices' drops (the module's scaled); the paper's values beside."""
    fig, ax = plt.subplots(1, 3, figsize=(16, 4.5))
    for res, label, c_ in ((c, "excess held (eq. (26))", "C0"), (wb, "excess wound back", "C3")):
        t = res["t"]
        ax[0].plot(t, res["i_q_ref"], color=c_, lw=1.2, label=f"i_q*, {label}")
        ax[0].plot(t, res["i_q"], color=c_, lw=0.4, alpha=0.7, label=f"i_q, {label}")
    ax[0].set_xlabel("time (s)")
    ax[0].set_ylabel("q current (A)")
    ax[0].set_title("Region C, 1500 -> 1750 rpm at 10 N m", fontsize=9)
    ax[0].legend(fontsize=7)
    a = [p["alpha_mean_rad"] for p in sweep]
    ax[1].plot(a, [p["thd_pct"] for p in sweep], "o-", label="Region C, I_lim lowered (labels: I_lim, A)")
    for p in sweep:
        ax[1].annotate(f"{p['i_lim_A']:g}", (p["alpha_mean_rad"], p["thd_pct"]), fontsize=7,
                       textcoords="offset points", xytext=(4, -10))
    ax[1].axhline(thd_b, color="C1", ls="--", label=f"Region B, model ({thd_b:.1f} %)")
    ax[1].set_xlabel("mean depth angle alpha over the steady window (rad)")
    x = [p["rectifier_path_V"] for p in drops]
    ax[2].plot(x, [p["thd_C_pct"] for p in drops], "o-", color="C2", label="Region C")
    ax[2].plot(x, [p["thd_B_pct"] for p in drops], "s-", color="C1", label="Region B")
    for p in drops:
        ax[2].annotate(f"x{p['scale']:g}", (p["rectifier_path_V"], p["thd_C_pct"]), fontsize=7,
                       textcoords="offset points", xytext=(4, -10))
    ax[2].set_xlabel(f"the rectifier path's drop at {I_DROPS:g} A (V; labels: the module's drops x)")
    for a_ in ax[1:]:
        a_.axhline(PAPER_THD["B"], color="C1", ls=":", label=f"Region B, paper ({PAPER_THD['B']} %)")
        a_.axhline(PAPER_THD["C"], color="C2", ls=":", label=f"Region C, paper ({PAPER_THD['C']} %)")
        a_.set_ylabel("grid current THD (%)")
        a_.legend(fontsize=7)
    for x_ in ax:
        x_.grid(True, alpha=0.3)
    return save_figure(fig, path, "Region C: PART_1's q-current error, and the THD the depth angle and the devices set")


def rectifier_drop(res: Result) -> dict:
    """The rectifier's mean dc-link current and drop over the steady window, from the loss meters: the
    current the converter's input power over the mean v_pn, the drop its loss over that current."""
    t0, t1 = res.scenario.data["metrics"]["steady"]
    m = window_mask(res["t"], t0, t1)
    k0, k1 = np.flatnonzero(m)[[0, -1]]
    i_dc = (res["E_dc"][k1] - res["E_dc"][k0]) / (res["t"][k1] - res["t"][k0]) / float(np.mean(res["v_pn"][m]))
    return {"i_dc_A": float(i_dc), "rectifier_V": float((res["E_rect"][k1] - res["E_rect"][k0])
                                                        / (res["t"][k1] - res["t"][k0]) / i_dc)}


def crossing(xs: list[float], ys: list[float]) -> float | None:
    """The first x where y (linear between the points) rises through 0, or None."""
    for (x0, y0), (x1, y1) in zip(zip(xs, ys), zip(xs[1:], ys[1:])):
        if y0 < 0.0 <= y1:
            return x0 + (x1 - x0) * (-y0) / (y1 - y0)
    return None


@register("Z-THD-TREND", shares="zou2021 region runs")
def thd_trend(out: Path) -> Measurement:
    thds, runs = {}, {}
    for key in "ABC":
        runs[key] = res = _run(f"zou2021-region-{key.lower()}")
        thds[key] = thd(res, *res.scenario.data["metrics"]["steady"])
    ratios = {k: thds[k] / PAPER_THD[k] for k in thds}
    c = runs["C"]
    wb = run("zou2021-region-c", WOUND_BACK)
    st_c, st_wb = region_stats(c), region_stats(wb)
    m = window_mask(c["t"], *c.scenario.data["metrics"]["steady"])
    sweep = []
    for i_lim in (12.0, 11.5, 11.0, 10.5, 10.0):
        st = region_stats(c if i_lim == 12.0 else run("zou2021-region-c", {"controller": {"i_lim": i_lim}}))
        sweep.append({"i_lim_A": i_lim, "alpha_mean_rad": st["alpha_mean_rad"], "thd_pct": st["thd_pct"]})
    drops = []
    for k in DROP_SCALES:
        if k == 1.0:
            st_b, st_k = region_stats(runs["B"]), st_c
        else:
            st_b = region_stats(run("zou2021-region-b", scaled_drops(k)))
            st_k = region_stats(run("zou2021-region-c", scaled_drops(k)))
        drops.append({"scale": k, **drops_at(k), "thd_B_pct": st_b["thd_pct"], "thd_C_pct": st_k["thd_pct"],
                      "alpha_C_mean_rad": st_k["alpha_mean_rad"]})
    k_x = crossing([p["scale"] for p in drops], [p["thd_C_pct"] - p["thd_B_pct"] for p in drops])
    dead = {key: region_stats(run(f"zou2021-region-{key.lower()}", {"converter": {"t_dead": 2e-6}}))
            for key in "BC"}
    cv = c.scenario.machine.converter
    eff = rectifier_drop(c)
    value = {**{f"thd_{k}_pct": v for k, v in thds.items()}, **{f"ratio_{k}": v for k, v in ratios.items()},
             "module": cv["module"], "drops_at_12A_V": drops_at(1.0), "rectifier_in_region_C": eff,
             "alpha_C_mean_rad": st_c["alpha_mean_rad"],
             "i_ref_C_A": float(np.mean(np.hypot(c["i_d_ref"][m], c["i_q_ref"][m]))), "i_lim_A": 12.0,
             "thd_against_drops": drops,
             "drop_scale_where_C_passes_B": k_x,
             "drops_at_12A_where_C_passes_B_V": drops_at(k_x) if k_x is not None else None,
             "thd_B_C_with_2us_dead_time_pct": (dead["B"]["thd_pct"], dead["C"]["thd_pct"]),
             "iq_error_C_A": iq_error(c), "iq_error_C_wound_back_A": iq_error(wb),
             "thd_C_wound_back_pct": st_wb["thd_pct"], "alpha_C_wound_back_rad": st_wb["alpha_mean_rad"],
             "thd_C_against_alpha": sweep}
    ok = thds["A"] < thds["B"] < thds["C"] and all(0.6 <= r <= 1.4 for r in ratios.values())
    fig_name = _figure_thd(c, wb, sweep, drops, thds["B"], out / "Z-THD-TREND.png")
    d1 = drops_at(1.0)
    order = " < ".join(f"{k} {thds[k]:.1f} %" for k in sorted(thds, key=thds.get))
    note = (f"THD of the grid current (harmonics 2..{H_MAX}) in the three regions' steady windows, on the plant "
            f"with the IMC's devices: {cv['module']} at 125 degC (machine [converter]; at the regions' 12 A "
            f"{d1['igbt_V']:.2f} V an IGBT, {d1['diode_V']:.2f} V a diode, {d1['rectifier_path_V']:.2f} V on the "
            f"rectifier's path of two IGBTs and two diodes). Measured: {order}; ratios to the paper "
            f"{ratios['A']:.2f} / {ratios['B']:.2f} / {ratios['C']:.2f}. What decides the order: Region C's THD "
            "is set by the depth angle PART_2 holds (thd_C_against_alpha: it rises with alpha, CASE 2's 5th and "
            "7th harmonics), and 1750 rpm at 10 N m sits so close to what PART_1 reaches at I_lim with CASE 1 "
            "that a few volts of the converter's own drop set that angle (thd_against_drops, the figure's right: "
            "the module's drops scaled from ideal switches to twice). Ideal switches leave alpha at "
            f"{drops[0]['alpha_C_mean_rad']:.3f} rad and THD(C) {drops[0]['thd_C_pct']:.1f} %; the module's "
            f"drops raise them to {st_c['alpha_mean_rad']:.3f} rad and {thds['C']:.1f} %; "
            + (f"THD(C) passes THD(B) at {k_x:.2f} x the module's drops ({drops_at(k_x)['rectifier_path_V']:.2f} V "
               f"on the rectifier's path, {drops_at(k_x)['igbt_V']:.2f} V an IGBT at 12 A). "
               if k_x is not None else "THD(C) stays below THD(B) up to twice the module's drops. ")
            + f"(The rectifier carries the dc link's current, {eff['i_dc_A']:.1f} A in Region C's mean, so its "
            f"path drops {eff['rectifier_V']:.2f} V there.) "
            + ("So the order holds with this module. " if ok else
               "So with this module at its datasheet's 125 degC the order B < C does not hold, and the claim "
               "fails on the measured THD(C) < THD(B); at 150 degC its V_CEsat rises from 2.15 to 2.25 V, not "
               "the third more the order needs. ")
            + "A 2 us dead time in the stage (its compensation on) moves B and C to "
            f"{dead['B']['thd_pct']:.1f} and {dead['C']['thd_pct']:.1f} % "
            "(thd_B_C_with_2us_dead_time_pct): in over-modulation one or two legs are clamped and do not "
            "switch. The paper leaves out what else sets these values: the grid's impedance (here stiff), the "
            "filter's damping topology (here R parallel to L), the switching sequence inside a period and the "
            "THD's harmonic range; the model neglects the switching ripple inside a rectifier interval. With "
            "PART_1's excess wound back the standing q-current error (iq_error_C_wound_back_A) raises |i*| "
            "above I_lim, alpha saturates at pi/6 and the THD overshoots the paper's (thd_C_wound_back_pct). "
            "Region B's THD is high for its alpha = 0: at 1500 rpm the output frequency equals the grid's, so "
            "the inverter stage's power ripple at 6 f_o = 300 Hz lands on the grid current's 250 and 350 Hz "
            "lines with the rectifier's own (the paper's 250 and 350 Hz); at 1750 rpm it lands on 300 and 400 Hz.")
    return Measurement(value, ok, note, [fig_name])


@register("Z-RISE", shares="zou2021 region runs")
def rise(out: Path) -> Measurement:
    both = _run("zou2021-region-c")
    part1 = run("zou2021-rise-time")
    t1, t12 = rise_time(part1, 0.2, 1500.0, 1750.0), rise_time(both, 0.2, 1500.0, 1750.0)
    value = {"rise_part1_s": t1, "rise_part12_s": t12, "shorter_pct": 100.0 * (1.0 - t12 / t1)}
    ok = t12 < t1
    fig, ax = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    for res, label in ((part1, "PART_1"), (both, "PART_1 + PART_2")):
        ax[0].plot(res["t"], rad_s_to_rpm(res["w_m"]), label=label)
        ax[1].plot(res["t"], np.hypot(res["i_d"], res["i_q"]), lw=0.6, label=label)
    ax[0].set_ylabel("speed (rpm)")
    ax[1].set_ylabel("|i_s| (A)")
    ax[1].set_xlabel("time (s)")
    for a in ax:
        a.legend(fontsize=8)
        a.grid(True, alpha=0.3)
    fig_name = save_figure(fig, out / "Z-RISE.png", "1500 -> 1750 rpm at 10 N m (Fig. 10)")
    note = "10 % -> 90 % of the 1500 -> 1750 rpm step; PART_1 alone keeps the rectifier in CASE 1."
    return Measurement(value, ok, note, [fig_name])


def _figure_experiment(runs: dict, i_lim: float, i_max: float, path: Path) -> str:
    """Like Fig. 16: speed, |i_s| against I_lim and I_max, the depth angle
    and where the inverter stage over-modulates, PART_1 alone and with
    PART_2, on the bench as specified and on the calibrated one."""
    fig, ax = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    styles = ("-", "--")
    for (label, res), c_ in zip(runs.items(), ("C0", "C1", "C2", "C3")):
        t = res["t"]
        m = window_mask(t, 0.19, 0.32)
        ls = styles[0] if "150 V" in label else styles[1]
        ax[0].plot(t[m], rad_s_to_rpm(res["w_m"][m]), ls, color=c_, label=label)
        ax[1].plot(t[m], np.hypot(res["i_d"][m], res["i_q"][m]), ls, color=c_, lw=0.7, label=label)
        ax[2].plot(t[m], res["alpha"][m], ls, color=c_, label=label)
        ax[3].plot(t[m], res["overmod"][m], ls, color=c_, lw=0.7, label=label)
    for y in (200.0 + 0.1 * 350.0, 200.0 + 0.9 * 350.0, 200.0 + 0.98 * 350.0):
        ax[0].axhline(y, color="k", ls=":", lw=0.7)
    ax[1].axhline(i_lim, color="k", ls="--", lw=0.7, label="I_lim")
    ax[1].axhline(i_max, color="k", ls=":", lw=0.7, label="I_max")
    ax[0].set_ylabel("speed (rpm)")
    ax[1].set_ylabel("|i_s| (A)")
    ax[2].set_ylabel("alpha (rad)")
    ax[3].set_ylabel("over-modulating")
    ax[3].set_xlabel("time (s)")
    grid_and_legends(ax)
    return save_figure(fig, path, "Prototype bench: 200 -> 550 rpm at 5 N m (Fig. 16); dotted: the 10, 90 and 98 % speeds")


def _rise_window(res: Result, n0: float, n1: float) -> np.ndarray:
    """The samples between the first 10 % and the first 90 % crossing of a step n0 -> n1 after 0.2 s."""
    t, n = res["t"], rad_s_to_rpm(res["w_m"])
    after = t >= 0.2
    k0 = np.flatnonzero(after & (n >= n0 + 0.1 * (n1 - n0)))[0]
    k1 = np.flatnonzero(after & (n >= n0 + 0.9 * (n1 - n0)))[0]
    return np.arange(k0, k1 + 1)


def time_to(res: Result, t_step: float, n0: float, n1: float, share: float = 0.98) -> float:
    """From the step until the speed first reaches n0 + share (n1 - n0), s; nan if never."""
    t, n = res["t"], rad_s_to_rpm(res["w_m"])
    k = np.flatnonzero((t >= t_step) & (n >= n0 + share * (n1 - n0)))
    return float(t[k[0]] - t_step) if k.size else math.nan


def _exp(v_ll: float, variant: dict | None = None, speed_rpm: float = 550.0) -> Result:
    """The prototype's test (zou2021-experiment) at grid voltage v_ll, line-line rms."""
    ov = {"converter": {"grid_ll_rms": v_ll},
          "references": {"speed_rpm": [[0.0, 200.0], [0.2, 200.0], [0.2, speed_rpm], [0.6, speed_rpm]]}}
    return run("zou2021-experiment", deep_merge(ov, variant or {}))


def _steady(res: Result) -> dict:
    m = window_mask(res["t"], 0.4, 0.6)
    return {"speed_rpm": float(np.mean(rad_s_to_rpm(res["w_m"][m]))), "alpha_rad": float(np.mean(res["alpha"][m])),
            "i_s_A": float(np.mean(np.hypot(res["i_d"][m], res["i_q"][m]))), "i_d_A": float(np.mean(res["i_d"][m]))}


def _bisect(ok, lo: float, hi: float, tol: float = 0.25) -> float:
    """The boundary between ok(lo) and not ok(hi) (either side may be the true one), to tol."""
    want = ok(lo)
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if ok(mid) == want:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


CAL_RANGE = (100.0, 150.0)   # V line-line rms: the calibration's search, from 2/3 of the prototype's 150 V to it


def calibrate_bench() -> dict:
    """The prototype's effective voltage from its reported operating point
    (Fig. 16, sec. 6.3: at 550 rpm and 5 N m "the stator current is greater
    than I_lim, PART_2 plays its role"): the band of grid voltages at which
    the drive with PART_1 + PART_2 holds 550 rpm under 5 N m with PART_2
    acting (alpha > 0) in the steady state, by bisection over runs on the
    plant with its devices; the calibrated bench is the band's middle."""
    def acts(v):
        return _steady(_exp(v))["alpha_rad"] > 1e-3

    def holds(v):
        return abs(_steady(_exp(v))["speed_rpm"] - 550.0) < 0.01 * 550.0

    lo, hi = CAL_RANGE
    if acts(hi) or not acts(lo) or holds(lo) or not holds(hi):
        raise ValueError(f"the calibration's range {lo:g}..{hi:g} V does not bracket PART_2's onset and the "
                         "550 rpm limit")
    v_hi = _bisect(acts, lo, hi)          # below it PART_2 acts
    v_lo = _bisect(holds, hi, lo)         # above it the drive holds 550 rpm

    def weakens(v):   # Fig. 18: PART_1 alone weakens the flux at 400 rpm and 5 N m
        return _steady(_exp(v, PART1_ONLY, speed_rpm=400.0))["i_d_A"] < -0.1

    v_18 = _bisect(weakens, lo, hi) if weakens(lo) and not weakens(hi) else math.nan
    return {"band_V": (v_lo, v_hi), "grid_ll_rms_V": 0.5 * (v_lo + v_hi), "fig18_below_V": v_18}


def _rise_stats(part1: Result, both: Result) -> dict:
    t1, t12 = rise_time(part1, 0.2, 200.0, 550.0), rise_time(both, 0.2, 200.0, 550.0)
    d1, d12 = time_to(part1, 0.2, 200.0, 550.0), time_to(both, 0.2, 200.0, 550.0)
    return {"rise_part1_s": t1, "rise_part12_s": t12, "rise_shorter_pct": 100.0 * (1.0 - t12 / t1),
            "to_98pct_part1_s": d1, "to_98pct_part12_s": d12, "to_98pct_shorter_pct": 100.0 * (1.0 - d12 / d1)}


@register("Z-EXP", shares="zou2021 envelopes")
def experiment(out: Path) -> Measurement:
    b = PROTOTYPE
    env = _prototype_envelopes(out)
    g1, g12 = reading_gains(env)["linear i_d = 0, B and C to I_max"]
    lim = _bench_limits("zou2021-speed-range", [b["T"]], b["overrides"])
    both = run("zou2021-experiment")
    part1 = run("zou2021-experiment", PART1_ONLY)
    spec = _rise_stats(part1, both)
    s1, s12 = settling_time(part1, 0.2, 550.0), settling_time(both, 0.2, 550.0)
    st = _steady(both)
    k = _rise_window(both, 200.0, 550.0)
    cal = calibrate_bench()
    v = cal["grid_ll_rms_V"]
    both_c, part1_c = _exp(v), _exp(v, PART1_ONLY)
    st_c = _steady(both_c)
    calibrated = {**cal, **_rise_stats(part1_c, both_c), "i_s_steady_A": st_c["i_s_A"],
                  "alpha_steady_rad": st_c["alpha_rad"], "fraction_of_150V": v / 150.0}
    value = {"gain_part1_pct": g1, "gain_part12_pct": g12, "envelopes_rpm_at_5Nm": env,
             "limits_rpm_at_5Nm": {k_: v_[0] for k_, v_ in lim.items()},
             **spec, "settling_2pct_part1_s": s1, "settling_2pct_part12_s": s12,
             "overmod_share_in_rise": float(np.mean(both["overmod"][k])),
             "alpha_mean_in_rise_rad": float(np.mean(both["alpha"][k])),
             "i_s_steady_A": st["i_s_A"], "alpha_max_run_rad": float(np.max(both["alpha"])),
             "calibrated_bench": calibrated}
    ok = abs(g1 - 30.0) <= 5.0 and abs(g12 - 35.0) <= 5.0 and spec["rise_part12_s"] < spec["rise_part1_s"]
    fig_name = _figure_experiment({"150 V, PART_1": part1, "150 V, PART_1 + PART_2": both,
                                   f"{v:.1f} V, PART_1": part1_c, f"{v:.1f} V, PART_1 + PART_2": both_c},
                                  6.0, 8.8, out / "Z-EXP.png")
    c = calibrated

    def ms(x):
        return f"{1e3 * x:.1f} ms" if math.isfinite(x) else "not reached"

    fig18 = (f"Fig. 18's flux weakening by PART_1 at 400 rpm and 5 N m needs the voltage below {c['fig18_below_V']:.1f} V, "
             + ("inside the band" if c["fig18_below_V"] >= c["band_V"][0] else "below the band: the paper's figures "
                "do not meet at one effective voltage on Table 2's machine")
             if math.isfinite(c["fig18_below_V"]) else "PART_1 alone does not weaken the flux at 400 rpm in the range")
    note = ("The prototype's conditions (sec. 6.1): 150 V input, I_max 8.8 A, I_lim 6 A, on Table 2's machine, "
            "the plant with the IMC's devices; the envelope search of Z-SPEEDRANGE at 5 N m (the text's reading: "
            "linear i_d = 0 baseline, the current limit I_max, PART_1's excess held), and the 200 -> 550 rpm step "
            "of Fig. 16 measured by its 10-90 % rise and by the time to 98 % of the step. As specified, the "
            f"speed range passes (+{g1:.1f} / +{g12:.1f} %) and the rise does not: {1e3 * spec['rise_part1_s']:.1f} ms "
            f"with PART_1 and {1e3 * spec['rise_part12_s']:.1f} ms with PART_2 (to 98 %: "
            f"{1e3 * spec['to_98pct_part1_s']:.1f} / {1e3 * spec['to_98pct_part12_s']:.1f} ms). What decides it: "
            "the rise is spent at the current limit (8.8 A) below the voltage limit (the inverter stage "
            "over-modulates in overmod_share_in_rise of it), and at 550 rpm the drive needs "
            f"{st['i_s_A']:.1f} A, far below I_lim, so PART_2 has nothing to do: this machine at 150 V has more "
            "voltage than the prototype had (its Region B, Fig. 18, needs flux weakening at 400 rpm and 5 N m, "
            f"where this machine's linear limit is {lim['id0'][0]:.0f} rpm). Beside it, the bench calibrated to "
            "the paper's reported operating point: Fig. 16 and sec. 6.3 put the steady 550 rpm at 5 N m at a "
            "current above I_lim with PART_2 acting; by bisection over runs the grid voltages at which that "
            f"holds span {c['band_V'][0]:.1f} to {c['band_V'][1]:.1f} V (below, 550 rpm is not held; above, "
            f"alpha stays 0), and the calibrated bench is their middle, {v:.1f} V ({100 * c['fraction_of_150V']:.0f} % "
            f"of 150 V: what the prototype's supply, cabling and devices would have left; {fig18}). There the steady "
            f"current is {c['i_s_steady_A']:.2f} A with alpha {c['alpha_steady_rad']:.2f} rad, and PART_2 changes "
            f"the 10-90 % rise from {ms(c['rise_part1_s'])} to {ms(c['rise_part12_s'])} ({c['rise_shorter_pct']:.1f} % "
            f"shorter; paper: 4.8 %) and the time to 98 % from {ms(c['to_98pct_part1_s'])} to "
            f"{ms(c['to_98pct_part12_s'])}. The 10-90 % rise is "
            "a poor measure here: its 90 % point (515 rpm) sits at the voltage limit's knee, so it jumps with a "
            "volt of supply; the time to 98 % is the approach PART_2 shortens. The calibration is to the "
            "paper's figures, not to a stated number: the claim is scored as specified.")
    return Measurement(value, ok, note, [fig_name])
