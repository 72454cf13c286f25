"""Helpers shared by the paper modules: running a catalog scenario with
overrides, windows of traces, and figures."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ...design.scenario import load_scenario  # noqa: E402
from ...model.schema import deep_merge  # noqa: E402
from ...model.units import rad_s_to_rpm  # noqa: E402
from ...sim.metrics import angle_error_stats, window_mask  # noqa: E402
from ...sim.runner import Result, simulate  # noqa: E402
from ...workflows.journal import run_tasks  # noqa: E402


def run(name: str, overrides: dict | None = None, warn: bool = True) -> Result:
    """Catalog scenario `name` with the overrides, run (warn=False: its
    warnings not formed, for a caller that reads none)."""
    return simulate(load_scenario(name, overrides, warn))


def error_stats(res: Result, t0: float, t1: float, channel: str = "est_err") -> dict:
    """Position error (actual - estimated) over [t0, t1], el.deg."""
    m = window_mask(res["t"], t0, t1)
    return angle_error_stats(res[channel][m])


def lock_kept(res: Result) -> bool:
    return res.stop_reason == "done"


def lock_held(res: Result, t0: float, limit_deg: float = 45.0) -> bool:
    """The run ended normally and the estimate stayed within limit_deg of the
    rotor from t0 on (an injection estimator that loses lock jumps by pi or
    runs away; one that keeps it stays near the cross-saturation offset)."""
    m = res["t"] >= t0
    return lock_kept(res) and bool(np.all(np.abs(np.degrees(res["est_err"][m])) < limit_deg))


def save_figure(fig, path: Path, title: str) -> str:
    """Title, layout, write, close; the file's name for the report."""
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path.name


def grid_and_legends(axes) -> None:
    """A light grid on each axis, and its legend where it has labels."""
    for a in axes:
        a.grid(True, alpha=0.3)
        if a.get_legend_handles_labels()[0]:
            a.legend(loc="upper right", fontsize=8)


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


def figure_dynamic(res: Result, path: Path, title: str, t_win: tuple[float, float],
                   weight: bool = False) -> str:
    """Like Figs. 10-11 (14-15): q current, speed, angle and position error;
    with weight, the blending weight too (Figs. 16-17)."""
    t = res["t"]
    m = window_mask(t, *t_win)
    fig, ax = plt.subplots(5 if weight else 4, 1, figsize=(7, 10 if weight else 8), sharex=True)
    if weight:
        ax[4].plot(t[m], res["g_w"][m], label="$g_w$ (1: SMO)")
        ax[4].plot(t[m], res["inject"][m], ":", label="injecting")
        ax[4].set_ylabel("weight")
        ax[4].set_xlabel("time (s)")
    if np.any(res["inject"][m] > 0):   # the fundamental the loop sees, not the HF carrier
        ax[0].plot(t[m], res["i_q_hat"][m], label="$i_q$ (fundamental, controller frame)")
    else:
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
    grid_and_legends(ax)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path.name


def map_point(task: dict) -> dict:
    """One run of a map (a sweep task): the error's mean and pp over
    [t0, t1], el.deg, and whether it kept lock (from t_lock on, if given)."""
    r = run(task["scenario"], task["overrides"])
    s = error_stats(r, task["t0"], task["t1"])
    held = lock_held(r, task["t_lock"]) if task["t_lock"] is not None else lock_kept(r)
    return {"mean": s["mean"], "pp": s["pp"], "locked": held, "stop_reason": r.stop_reason}


def sweep_dir(out: Path, claim: str) -> Path:
    """Where a claim's runs are journaled (workflows.journal), afresh each
    reproduction: reused results from older code would not be measured."""
    return out / "sweeps" / claim


MAP_SEEDS = (1, 2, 3)   # each map point's pp is an extreme of sensor noise: its expectation taken over three
                        # noise draws (one draw put 'pp falls with speed' at the noise edge: Spearman -0.79 / -0.83
                        # by the last digit of the trigonometry)


def error_map(scenario: str, currents: list[float], speeds: list[float], overrides, out: Path,
              t0: float = 0.5, t1: float = 1.0, t_lock: float | None = None, seeds=MAP_SEEDS):
    """Mean and pp error (el.deg) over [t0, t1] at each (current, speed) of
    a map (Figs. 9, 13), each averaged over the sensor-noise seeds, with
    overrides(i_q, rpm) giving each run's changes; whether every run kept
    lock (held within 45 deg from t_lock on, if given); and pp per seed
    (seed, current, speed). The runs go through the sweep engine, in
    parallel, into out."""
    tasks = [{"scenario": scenario, "overrides": deep_merge(overrides(iq, float(n)), {"sensors": {"seed": sd}}),
              "t0": t0, "t1": t1, "t_lock": t_lock}
             for sd in seeds for iq in currents for n in speeds]
    res = run_tasks(map_point, tasks, out, fresh=True)
    shape = (len(seeds), len(currents), len(speeds))
    mean = np.array([r["mean"] if r["mean"] is not None else np.nan for r in res]).reshape(shape)
    pp = np.array([r["pp"] if r["pp"] is not None else np.nan for r in res]).reshape(shape)
    return mean.mean(axis=0), pp.mean(axis=0), all(r.get("locked", False) for r in res), pp


def pp_falls_with_speed(pp: np.ndarray, speeds: list[float]) -> tuple[list[float], list[bool]]:
    """'pp falls as speed rises', at each current (row): the Spearman rank
    correlation of pp with speed, and whether it is <= -0.8 with pp at the
    top speed below pp at the lowest."""
    ranks = np.argsort(np.argsort(pp, axis=1), axis=1)
    rs = np.argsort(np.argsort(np.array(speeds)))
    rho = [float(np.corrcoef(ranks[a], rs)[0, 1]) for a in range(pp.shape[0])]
    return rho, [bool(pp[a, -1] < pp[a, 0] and rho[a] <= -0.8) for a in range(pp.shape[0])]


def figure_map(speeds, currents, mean, pp, path: Path, title: str) -> str:
    """Mean and pp error over speed, one line per current (Figs. 9, 13)."""
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for a, iq in enumerate(currents):
        ax[0].plot(speeds, mean[a], "o-", label=f"{iq:g} A")
        ax[1].plot(speeds, pp[a], "o-", label=f"{iq:g} A")
    ax[0].set_ylabel("mean error (el.deg)")
    ax[1].set_ylabel("peak-peak error (el.deg)")
    for x in ax:
        x.set_xlabel("speed (rpm)")
        x.grid(True, alpha=0.3)
        x.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path.name
