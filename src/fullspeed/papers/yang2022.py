"""yang2022: the sliding-mode observer claims (sec. 5.2, Figs. 8-11)."""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..reproduce import MEASURES, Measurement
from .common import error_stats, figure_angle, figure_dynamic, lock_kept, run

SS = "yang2022-smo-steady-400rpm"


def _register(claim_id):
    def deco(fn):
        MEASURES[claim_id] = fn
        return fn
    return deco


@_register("Y-SMO-SS")
def smo_steady(out: Path) -> Measurement:
    res = {iq: run(SS, {"references": {"i_q": iq}}) for iq in (5.0, 25.0)}
    st = {iq: error_stats(r, 0.5, 1.0) for iq, r in res.items()}
    value = {"mean_5A": st[5.0]["mean"], "pp_5A": st[5.0]["pp"],
             "mean_25A": st[25.0]["mean"], "pp_25A": st[25.0]["pp"]}
    ok = (all(lock_kept(r) for r in res.values()) and abs(value["mean_5A"]) < 5
          and abs(value["mean_25A"]) < 5 and value["pp_25A"] > value["pp_5A"])
    fig = figure_angle([(f"400 rpm, {iq:g} A", r) for iq, r in res.items()], (0.95, 0.98), (0.5, 1.0),
                       out / "Y-SMO-SS.png", "SMO steady state (cf. yang2022 Fig. 8)")
    note = ("Mean and pp over 0.5-1.0 s, current sensors with 0.1 A noise and 12-bit quantization. "
            "The mean errors are well inside the paper's 5 el.deg. ")
    if not value["pp_25A"] > value["pp_5A"]:
        note += ("The paper's growth of the ripple with current is not reproduced: the simulated "
                 "machine has a sinusoidal back-EMF, no slotting and no spatial harmonics, so the "
                 "ripple comes from sensor noise, whose effect on the angle does not grow with the "
                 "current (the EMF the observer tracks, w psi_f at i_d = 0, does not either). The "
                 "model is left as it is; the ripple sources the paper's bench has are a candidate "
                 "for the plant (back-EMF harmonics, a flux map with slot effects).")
    return Measurement(value, ok, note, [fig])


SPEEDS = list(range(200, 1601, 200))
CURRENTS = [5.0, 10.0, 15.0, 20.0, 25.0]


@_register("Y-SMO-MAP")
def smo_map(out: Path) -> Measurement:
    mean = np.zeros((len(CURRENTS), len(SPEEDS)))
    pp = np.zeros_like(mean)
    locked = True
    for a, iq in enumerate(CURRENTS):
        for b, n in enumerate(SPEEDS):
            r = run(SS, {"references": {"i_q": iq}, "load": {"speed_rpm": float(n)}})
            locked &= lock_kept(r)
            s = error_stats(r, 0.5, 1.0)
            mean[a, b], pp[a, b] = s["mean"], s["pp"]
    # "pp falls as speed rises": at each current, the rank correlation of pp with speed
    ranks = np.argsort(np.argsort(pp, axis=1), axis=1)
    rs = np.argsort(np.argsort(np.array(SPEEDS)))
    spearman = [float(np.corrcoef(ranks[a], rs)[0, 1]) for a in range(len(CURRENTS))]
    falls = [bool(pp[a, -1] < pp[a, 0] and spearman[a] <= -0.8) for a in range(len(CURRENTS))]
    value = {"max_abs_mean": float(np.max(np.abs(mean))), "min_spearman_pp_speed": max(spearman),
             "pp_at_200rpm_25A": float(pp[-1, 0]), "pp_at_1600rpm_25A": float(pp[-1, -1])}
    ok = locked and value["max_abs_mean"] < 6 and all(falls)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for a, iq in enumerate(CURRENTS):
        ax[0].plot(SPEEDS, mean[a], "o-", label=f"{iq:g} A")
        ax[1].plot(SPEEDS, pp[a], "o-", label=f"{iq:g} A")
    ax[0].set_ylabel("mean error (el.deg)")
    ax[1].set_ylabel("peak-peak error (el.deg)")
    for x in ax:
        x.set_xlabel("speed (rpm)")
        x.grid(True, alpha=0.3)
        x.legend(fontsize=8)
    fig.suptitle("SMO error over speed and current (cf. yang2022 Fig. 9)")
    fig.tight_layout()
    fig.savefig(out / "Y-SMO-MAP.png", dpi=100)
    plt.close(fig)
    note = ("40 runs, 1 s each, speed held by the load machine; statistics over 0.5-1.0 s. "
            "'pp falls as speed rises' is taken as: pp at 1600 rpm below pp at 200 rpm and a "
            f"Spearman rank correlation of pp with speed <= -0.8, at every current (measured: {', '.join(f'{s:.2f}' for s in spearman)}).")
    return Measurement(value, ok, note, ["Y-SMO-MAP.png"])


@_register("Y-SMO-IQSTEP")
def smo_iqstep(out: Path) -> Measurement:
    r = run("yang2022-smo-iqstep")
    s = error_stats(r, 0.8, 1.5)
    fig = figure_dynamic(r, out / "Y-SMO-IQSTEP.png", "SMO, i_q step 5 -> 15 A at 400 rpm (cf. Fig. 10)", (0.8, 1.5))
    return Measurement(s["max"], lock_kept(r) and s["max"] < 5, "max |error| over 0.8-1.5 s (the step at 1.0 s).", [fig])


@_register("Y-SMO-RAMP")
def smo_ramp(out: Path) -> Measurement:
    r = run("yang2022-smo-ramp")
    s = error_stats(r, 1.8, 2.3)
    fig = figure_dynamic(r, out / "Y-SMO-RAMP.png", "SMO, speed ramp 200 -> 800 rpm, 0.1 N m (cf. Fig. 11)", (1.5, 3.0))
    note = "max |error| during the ramp, 1.8-2.3 s; the ramp's length is not in the paper: 0.5 s chosen."
    return Measurement(s["max"], lock_kept(r) and s["max"] < 25, note, [fig])
