"""Figures of a run: speed, currents, angle and angle error, duties."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .units import rad_s_to_rpm  # noqa: E402


def plot_run(res, path: str | Path, title: str | None = None) -> Path:
    tr = res.traces
    t = tr["t"]
    fig, ax = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    ax[0].plot(t, rad_s_to_rpm(tr["w_m"]), label="speed")
    if res.scenario.data["controller"]["mode"] == "speed":
        ax[0].plot(t, rad_s_to_rpm(tr["w_m_ref"]), "--", label="reference")
    ax[0].plot(t, rad_s_to_rpm(tr["w_m_hat"]), ":", label="estimate")
    ax[0].set_ylabel("speed (rpm)")
    ax[1].plot(t, tr["i_d"], label="$i_d$")
    ax[1].plot(t, tr["i_q"], label="$i_q$")
    if res.scenario.data["controller"]["mode"] in ("speed", "current"):
        ax[1].plot(t, tr["i_d_ref"], "--", label="$i_d^*$")
        ax[1].plot(t, tr["i_q_ref"], "--", label="$i_q^*$")
    ax[1].set_ylabel("current (A)")
    ax[2].plot(t, np.degrees(tr["theta_err"]), "r", lw=0.8, label="actual - used")
    ax[2].set_ylabel("angle error (el.deg)")
    for k, ph in enumerate("abc"):
        ax[3].plot(t, tr[f"duty_{ph}"], lw=0.8, label=f"$d_{ph}$")
    ax[3].set_ylabel("duty")
    ax[3].set_xlabel("time (s)")
    for a in ax:
        a.grid(True, alpha=0.3)
        a.legend(loc="upper right", fontsize=8)
    fig.suptitle(title or res.scenario.name)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
