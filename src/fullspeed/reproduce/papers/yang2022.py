"""yang2022: the sliding-mode observer claims (sec. 5.2, Figs. 8-11)."""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ...model.units import rpm_to_rad_s
from ..registry import Measurement, register
from .common import (error_map, error_stats, figure_angle, figure_dynamic, figure_map, lock_held, lock_kept,
                     pp_falls_with_speed, run, sweep_dir)

SS = "yang2022-smo-steady-400rpm"


@register("Y-SMO-SS")
def smo_steady(out: Path) -> Measurement:
    # the machine with its spatial harmonics (machines/yang2022.toml [harmonics]), and without beside
    res = {iq: run(SS, {"references": {"i_q": iq}, "harmonics": {"enabled": True}}) for iq in (5.0, 25.0)}
    plain = {iq: run(SS, {"references": {"i_q": iq}}) for iq in (5.0, 25.0)}
    st = {iq: error_stats(r, 0.5, 1.0) for iq, r in res.items()}
    sp = {iq: error_stats(r, 0.5, 1.0) for iq, r in plain.items()}
    value = {"mean_5A": st[5.0]["mean"], "pp_5A": st[5.0]["pp"],
             "mean_25A": st[25.0]["mean"], "pp_25A": st[25.0]["pp"],
             "pp_5A_sinusoidal": sp[5.0]["pp"], "pp_25A_sinusoidal": sp[25.0]["pp"]}
    ok = (all(lock_kept(r) for r in res.values()) and abs(value["mean_5A"]) < 5
          and abs(value["mean_25A"]) < 5 and value["pp_25A"] > value["pp_5A"])
    fig = figure_angle([(f"400 rpm, {iq:g} A", r) for iq, r in res.items()], (0.95, 0.98), (0.5, 1.0),
                       out / "Y-SMO-SS.png", "SMO steady state (cf. yang2022 Fig. 8)")
    note = ("Mean and pp over 0.5-1.0 s, current sensors with 0.1 A noise and 12-bit quantization, on the machine "
            "with its spatial harmonics (machines/yang2022.toml [harmonics]: a 12-slot / 10-pole concentrated "
            "winding assumed, back-EMF harmonics 3 % (5th), -1 % (7th), 0.8 % (11th), 0.5 % (13th), saliency "
            "harmonics of 2-3 % at order 6, cogging 1 % of rated torque, each chosen with its reason there, not "
            "fitted to this claim). The harmonics that act with the current (the saliency harmonics) make the "
            "observer's ripple grow with it; with a sinusoidal machine (pp_5A_sinusoidal, pp_25A_sinusoidal) "
            "the ripple is the sensor noise's, which does not grow with the current. The other yang2022 claims "
            "run on the sinusoidal machine, as they were calibrated.")
    if not value["pp_25A"] > value["pp_5A"]:
        note += " The ripple does not grow with the current on this harmonic content."
    return Measurement(value, ok, note, [fig])


SPEEDS = list(range(200, 1601, 200))
CURRENTS = [5.0, 10.0, 15.0, 20.0, 25.0]


@register("Y-SMO-MAP", cost=4)
def smo_map(out: Path) -> Measurement:
    mean, pp, locked, pp_seeds = error_map(SS, CURRENTS, SPEEDS,
                                           lambda iq, n: {"references": {"i_q": iq}, "load": {"speed_rpm": n}},
                                           sweep_dir(out, "Y-SMO-MAP"))
    spearman, falls = pp_falls_with_speed(pp, SPEEDS)
    value = {"max_abs_mean": float(np.max(np.abs(mean))), "min_spearman_pp_speed": max(spearman),
             "pp_at_200rpm_25A": float(pp[-1, 0]), "pp_at_1600rpm_25A": float(pp[-1, -1]),
             "min_spearman_per_seed": [max(pp_falls_with_speed(p, SPEEDS)[0]) for p in pp_seeds]}
    ok = locked and value["max_abs_mean"] < 6 and all(falls)
    fig = figure_map(SPEEDS, CURRENTS, mean, pp, out / "Y-SMO-MAP.png", "SMO error over speed and current (cf. yang2022 Fig. 9)")
    note = (f"40 points x {len(pp_seeds)} sensor-noise seeds, 1 s each, speed held by the load machine; statistics "
            "over 0.5-1.0 s, each point's mean and pp averaged over the seeds (pp is an extreme of the noise; "
            "at 800-1200 rpm it sits at the sensors' floor, where one draw can swap neighbours: the least "
            f"Spearman per seed {', '.join(f'{x:.2f}' for x in value['min_spearman_per_seed'])}). "
            "'pp falls as speed rises' is taken as: pp at 1600 rpm below pp at 200 rpm and a "
            f"Spearman rank correlation of pp with speed <= -0.8, at every current (measured: {', '.join(f'{s:.2f}' for s in spearman)}).")
    return Measurement(value, ok, note, [fig])


@register("Y-SMO-IQSTEP")
def smo_iqstep(out: Path) -> Measurement:
    r = run("yang2022-smo-iqstep")
    s = error_stats(r, 0.8, 1.5)
    fig = figure_dynamic(r, out / "Y-SMO-IQSTEP.png", "SMO, i_q step 5 -> 15 A at 400 rpm (cf. Fig. 10)", (0.8, 1.5))
    return Measurement(s["max"], lock_kept(r) and s["max"] < 5, "max |error| over 0.8-1.5 s (the step at 1.0 s).", [fig])


@register("Y-SMO-RAMP")
def smo_ramp(out: Path) -> Measurement:
    r = run("yang2022-smo-ramp")
    s = error_stats(r, 1.8, 2.3)
    fig = figure_dynamic(r, out / "Y-SMO-RAMP.png", "SMO, speed ramp 200 -> 800 rpm, 0.1 N m (cf. Fig. 11)", (1.5, 3.0))
    note = "max |error| during the ramp, 1.8-2.3 s; the ramp's length is not in the paper: 0.5 s chosen."
    return Measurement(s["max"], lock_kept(r) and s["max"] < 25, note, [fig])


# --- rotating HF injection (sec. 5.3) and blending (sec. 5.4) -------------

HFI_SS = "yang2022-hfi-steady-100rpm"
T_LOCK = 0.2   # s: after the polarity detection (0.1 s) and the first settling


def _iq_ramp(iq: float) -> dict:
    """i_q brought in after the polarity detection, as in the scenario."""
    return {"references": {"i_q": [[0.0, 0.0], [0.2, 0.0], [0.3, iq]]}}


CROSS_SAT_NOTE = (
    "The yang2022 machine's cross-saturation is a calibration (machines/yang2022.toml, [magnetic]): "
    "its strength was set so that this scenario's sensorless error at 100 rpm and 25 A is the paper's "
    "15 el.deg (Fig. 12b); everything else (other currents, speeds, steps) follows from the model. "
    "The estimate leads the rotor, so the error (actual - estimated) is negative; the targets are "
    "compared in magnitude, the paper's sign convention not being given. ")


@register("Y-HFI-SS")
def hfi_steady(out: Path) -> Measurement:
    res = {iq: run(HFI_SS, _iq_ramp(iq)) for iq in (5.0, 25.0)}
    st = {iq: error_stats(r, 0.5, 1.0) for iq, r in res.items()}
    value = {"mean_5A": st[5.0]["mean"], "pp_5A": st[5.0]["pp"],
             "mean_25A": st[25.0]["mean"], "pp_25A": st[25.0]["pp"]}
    ok = (all(lock_held(r, T_LOCK) for r in res.values()) and abs(value["mean_5A"]) < 5
          and 8 <= abs(value["mean_25A"]) <= 22)
    fig = figure_angle([(f"100 rpm, {iq:g} A", r) for iq, r in res.items()], (0.9, 0.96), (0.5, 1.0),
                       out / "Y-HFI-SS.png", "Rotating HFI steady state (cf. yang2022 Fig. 12)")
    note = (CROSS_SAT_NOTE + "So the value at 25 A is the calibration point, not an independent check; "
            "the one at 5 A is a prediction. Mean and pp over 0.5-1.0 s, sensorless from t = 0 (polarity "
            "detection, then i_q ramped in at 0.2-0.3 s); speed held at 100 rpm by the load machine.")
    return Measurement(value, ok, note, [fig])


HFI_SPEEDS = [25, 50, 100, 150, 200]
HFI_CURRENTS = [5.0, 10.0, 15.0, 20.0, 25.0]


@register("Y-HFI-MAP", cost=3)
def hfi_map(out: Path) -> Measurement:
    def overrides(iq, n):
        return {**_iq_ramp(iq), "load": {"speed_rpm": n}, "initial": {"speed_rpm": n}}

    mean, pp, locked, pp_seeds = error_map(HFI_SS, HFI_CURRENTS, HFI_SPEEDS, overrides, sweep_dir(out, "Y-HFI-MAP"),
                                           t_lock=T_LOCK)
    grows = bool(np.all(np.diff(np.abs(mean), axis=0) > 0))
    spread = np.ptp(mean, axis=1)
    spearman, falls = pp_falls_with_speed(pp, HFI_SPEEDS)
    value = {"mean_5A": float(np.mean(mean[0])), "mean_25A": float(np.mean(mean[-1])),
             "max_spread_with_speed": float(np.max(spread)), "min_spearman_pp_speed": max(spearman),
             "pp_at_25rpm_5A": float(pp[0, 0]), "pp_at_200rpm_5A": float(pp[0, -1])}
    ok = locked and grows and value["max_spread_with_speed"] < 3 and all(falls)
    fig = figure_map(HFI_SPEEDS, HFI_CURRENTS, mean, pp, out / "Y-HFI-MAP.png",
                     "Rotating HFI error over speed and current (cf. yang2022 Fig. 13)")
    note = (CROSS_SAT_NOTE + f"{len(HFI_SPEEDS) * len(HFI_CURRENTS)} points x {len(pp_seeds)} sensor-noise seeds, "
            "1 s each, speed held by the load machine; statistics over 0.5-1.0 s, each point's averaged over the "
            "seeds. 'Grows with current': |mean| rises with i_q at "
            f"every speed ({'yes' if grows else 'no'}); the spread of the mean over speed at each current: "
            f"{', '.join(f'{x:.2f}' for x in spread)} el.deg; 'pp falls as speed rises': pp at 200 rpm below "
            "pp at 25 rpm and a Spearman rank correlation of pp with speed <= -0.8 at every current "
            f"(measured: {', '.join(f'{x:.2f}' for x in spearman)}).")
    return Measurement(value, ok, note, [fig])


@register("Y-HFI-IQSTEP")
def hfi_iqstep(out: Path) -> Measurement:
    r = run("yang2022-hfi-iqstep")
    settled = error_stats(r, 1.3, 1.5)
    peak = error_stats(r, 0.8, 1.5)
    value = {"settled_mean": settled["mean"], "max": peak["max"]}
    ok = lock_held(r, T_LOCK) and 10 <= abs(settled["mean"]) <= 30
    fig = figure_dynamic(r, out / "Y-HFI-IQSTEP.png", "HFI, i_q step 5 -> 20 A at 100 rpm (cf. Fig. 14)", (0.8, 1.5))
    note = (CROSS_SAT_NOTE + "Settled value: mean over 1.3-1.5 s. The paper reports about 20 el.deg at "
            "20 A here but about 15 el.deg at 25 A in its steady state (Fig. 12b): the two cannot both "
            "come from one machine. Calibrated to the steady state, the model gives the error that "
            "cross-saturation makes at 20 A, which is smaller than the paper's step test shows.")
    return Measurement(value, ok, note, [fig])


@register("Y-HFI-RAMP")
def hfi_ramp(out: Path) -> Measurement:
    r = run("yang2022-hfi-ramp")
    s = error_stats(r, 1.8, 2.5)
    fig = figure_dynamic(r, out / "Y-HFI-RAMP.png", "HFI speed control, ramp 50 -> 200 rpm, 0.1 N m (cf. Fig. 15)", (1.5, 3.0))
    note = ("max |error| over the ramp and its settling, 1.8-2.5 s; sensorless from standstill "
            "(polarity detection first); the ramp's length is not in the paper: 0.5 s chosen.")
    return Measurement(s["max"], lock_held(r, T_LOCK) and s["max"] < 20, note, [fig])


@register("Y-BLEND-IQSTEP")
def blend_iqstep(out: Path) -> Measurement:
    r = run("yang2022-blend-iqstep")
    s = error_stats(r, 0.8, 1.5)
    g = float(np.mean(r["g_w"][r["t"] >= 0.8]))
    fig = figure_dynamic(r, out / "Y-BLEND-IQSTEP.png", "Blended, i_q step 5 -> 15 A at 200 rpm (cf. Fig. 16)",
                         (0.8, 1.5), weight=True)
    note = (f"max |error| over 0.8-1.5 s; the weight at 200 rpm is {g:.2f} (band 160-260 rpm), so the "
            "HFI's cross-saturation error enters the blend with 1 - g_w, as the paper explains.")
    return Measurement({"max": s["max"], "g_w": g}, lock_held(r, T_LOCK) and s["max"] < 10, note, [fig])


@register("Y-BLEND-ACCDEC")
def blend_accdec(out: Path) -> Measurement:
    r = run("yang2022-blend-accdec")
    s = error_stats(r, 1.0, 4.5)
    bl = r.scenario.data["blending"]
    p = r.scenario.machine.pole_pairs
    lo, hi = (p * rpm_to_rad_s(bl[k]) for k in ("lower_rpm", "upper_rpm"))
    # eq. (28) on the speed estimate of the step before (the drive's order)
    w_prev = np.abs(p * r["w_m_est"][:-1])
    expected = np.clip((w_prev - lo) / (hi - lo), 0.0, 1.0)
    follow = float(np.max(np.abs(r["g_w"][1:] - expected)[r["t"][1:] >= T_LOCK]))
    value = {"max": s["max"], "weight_vs_speed_max_dev": follow}
    ok = lock_held(r, T_LOCK) and s["max"] < 10 and follow < 1e-3
    fig = figure_dynamic(r, out / "Y-BLEND-ACCDEC.png", "Blended speed control, 100 -> 400 -> 100 rpm (cf. Fig. 17)",
                         (0.8, 4.5), weight=True)
    note = ("max |error| over 1.0-4.5 s; 'weight follows estimated speed': the largest difference "
            "between the weight used and eq. (28) on the estimated speed. The injection stops above "
            f"{r.scenario.data['injection']['stop_rpm']:g} rpm and resumes below 0.9 of it (fading over "
            "the filters' settling time): the paper does not say whether it kept injecting.")
    return Measurement(value, ok, note, [fig])


@register("Y-POLARITY")
def polarity(out: Path) -> Measurement:
    angles = list(range(0, 360, 10))
    right, final = [], []
    for a in angles:
        r = run("yang2022-polarity", {"initial": {"theta_e_deg": float(a)}})
        e = float(np.degrees(r["est_err"][-1]))
        final.append(e)
        right.append(r.stop_reason == "done" and abs(e) < 45.0 and r["phase"][-1] == 0)
    value = {"right": int(sum(right)), "of": len(angles), "max_abs_final_error": float(np.max(np.abs(final)))}
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot(angles, final, "o")
    ax.set_xlabel("initial rotor angle (el.deg)")
    ax.set_ylabel("error after detection (el.deg)")
    ax.grid(True, alpha=0.3)
    ax.set_title("Magnet polarity detection at standstill")
    fig.tight_layout()
    fig.savefig(out / "Y-POLARITY.png", dpi=100)
    plt.close(fig)
    note = ("The paper requires a polarity detection and leaves the method open. Ours (fs_polarity.h): "
            "the injection locks on the axis for 60 ms, then d-current pulses of +-30 A (half of i_max), "
            "20 ms each, along the estimated d axis; the positive-sequence carrier amplitude grows when the "
            "pulse adds to the magnet flux and saturates the iron (the machine's asymmetric d saturation, "
            "machines/yang2022.toml); if it grows less on the positive pulse, the estimate is turned by pi. "
            "Right: |error| < 45 el.deg at the end of the run (0.12 s; the detection ends at 0.1 s).")
    return Measurement(value, all(right), note, ["Y-POLARITY.png"])
