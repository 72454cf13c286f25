"""Helpers shared by the paper modules: running a catalog scenario with
overrides, windows of traces, and figures."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..metrics import angle_error_stats, window_mask  # noqa: E402
from ..scenario import load_scenario  # noqa: E402
from ..sim import Result, simulate  # noqa: E402


def run(name: str, overrides: dict | None = None) -> Result:
    return simulate(load_scenario(name, overrides))


def error_stats(res: Result, t0: float, t1: float, channel: str = "est_err") -> dict:
    """Position error (actual - estimated) over [t0, t1], el.deg."""
    m = window_mask(res["t"], t0, t1)
    return angle_error_stats(res[channel][m])


def lock_kept(res: Result) -> bool:
    return res.stop_reason == "done"


def figure_angle(results: list[tuple[str, Result]], t_show: tuple[float, float],
                 t_err: tuple[float, float], path: Path, title: str) -> str:
    """Like the papers' steady-state figures: actual and estimated angle over a
    few electrical periods, and the error over the window."""
    fig, ax = plt.subplots(2, len(results), figsize=(5 * len(results), 5.5), squeeze=False)
    for k, (label, res) in enumerate(results):
        t = res["t"]
        m = window_mask(t, *t_show)
        ax[0, k].plot(t[m], np.degrees(res["theta_e"][m]), label="actual")
        ax[0, k].plot(t[m], np.degrees(res["theta_est"][m]), "--", label="estimated")
        ax[0, k].set_ylabel("angle (el.deg)")
        ax[0, k].set_title(label)
        ax[0, k].legend(loc="upper right", fontsize=8)
        m = window_mask(t, *t_err)
        ax[1, k].plot(t[m], np.degrees(res["est_err"][m]), "r", lw=0.8)
        ax[1, k].set_ylabel("error (el.deg)")
        ax[1, k].set_xlabel("time (s)")
        for a in ax[:, k]:
            a.grid(True, alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path.name


def figure_dynamic(res: Result, path: Path, title: str, t_win: tuple[float, float]) -> str:
    """Like Figs. 10-11: q current, speed, angle and position error."""
    from ..units import rad_s_to_rpm

    t = res["t"]
    m = window_mask(t, *t_win)
    fig, ax = plt.subplots(4, 1, figsize=(7, 8), sharex=True)
    ax[0].plot(t[m], res["i_q"][m], label="$i_q$")
    ax[0].plot(t[m], res["i_q_ref"][m], "--", label="$i_q^*$")
    ax[0].set_ylabel("current (A)")
    ax[1].plot(t[m], rad_s_to_rpm(res["w_m"][m]), label="actual")
    ax[1].plot(t[m], rad_s_to_rpm(res["w_m_est"][m]), "--", label="estimated")
    ax[1].set_ylabel("speed (rpm)")
    ax[2].plot(t[m], np.degrees(res["theta_e"][m]), lw=0.6, label="actual")
    ax[2].plot(t[m], np.degrees(res["theta_est"][m]), "--", lw=0.6, label="estimated")
    ax[2].set_ylabel("angle (el.deg)")
    ax[3].plot(t[m], np.degrees(res["est_err"][m]), "r", lw=0.8)
    ax[3].set_ylabel("error (el.deg)")
    ax[3].set_xlabel("time (s)")
    for a in ax:
        a.grid(True, alpha=0.3)
        if a.get_legend_handles_labels()[0]:
            a.legend(loc="upper right", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path.name
