"""Figures of a run (speed, currents, torque, voltage, angle error, stages) and of a sweep."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..design.drawing import save_figure  # noqa: E402
from ..design.rules import u_linear  # noqa: E402
from ..model.units import rad_s_to_rpm  # noqa: E402
from .metrics import STAGES  # noqa: E402


# one colour per stage (metrics.STAGES), light enough to sit behind the traces
STAGE_COLOURS = ("#dddddd", "#c6dbef", "#fdd0a2", "#fcbba1", "#c7e9c0", "#dadaeb", "#fff2ae", "#f4cae4", "#ff9999")


# a long run's line is drawn through the least and the greatest sample of each of
# PLOT_SLICES slices of its samples, in their order: the figure's 1,210 pixel
# columns (11 in at 110 dpi) show no more of it, and its spikes stay. Drawn whole,
# a 60 s run's 600,000 samples a line cost 360 MB in matplotlib (the figure was
# most of a run's peak memory, 1.1x its trace besides the trace itself).
PLOT_SLICES = 2000


def drawn(t: np.ndarray, y) -> tuple[np.ndarray, np.ndarray]:
    """(t, y) as plot_run draws it: whole when short, else each slice's
    minimum and maximum (a NaN, where there is one: a gap in the line)."""
    y = np.asarray(y)
    n = min(len(t), len(y))
    k = n // PLOT_SLICES
    if k < 3:   # no fewer points
        return t[:n], y[:n]
    m = k * PLOT_SLICES
    part = y[:m].reshape(PLOT_SLICES, k)
    start = np.arange(0, m, k)[:, None]
    idx = np.sort(np.hstack([start + part.argmin(axis=1)[:, None], start + part.argmax(axis=1)[:, None]]), axis=1).ravel()
    if m < n:   # the rest, shorter than a slice: its own least and greatest
        idx = np.r_[idx, np.sort([m + int(np.argmin(y[m:n])), m + int(np.argmax(y[m:n]))])]
    return t[idx], y[idx]


def modulation_index(res) -> np.ndarray:
    """The controller's voltage reference against the modulator's linear
    limit at each sample (u_dc / sqrt 3 on three phases, scaled with the dc
    link's trace): 1 is the edge of linear modulation."""
    sc, tr = res.scenario, res.traces
    u_lin = u_linear(sc.data["converter"]["u_dc"], sc.machine.phases) * np.asarray(tr["u_dc"]) / sc.data["converter"]["u_dc"]
    return np.hypot(tr["u_d_ref"], tr["u_q_ref"]) / np.maximum(u_lin, 1e-12)


def _stage_bands(ax_all, ax_bar, t, stage) -> None:
    """The drive's stages: shaded behind every panel, and labelled bars in ax_bar."""
    s = np.asarray(stage).astype(int)
    if not s.size:
        return
    k = np.r_[0, np.flatnonzero(np.diff(s)) + 1, s.size - 1]
    dt = float(t[1] - t[0]) if t.size > 1 else 0.0
    from matplotlib.patches import Patch

    # a legend entry per stage, in the order entered (narrow bands carry no label)
    ax_bar.legend(handles=[Patch(facecolor=STAGE_COLOURS[c], edgecolor="k", lw=0.3, label=STAGES[c])
                           for c in dict.fromkeys(s[k[:-1]])],
                  loc="upper left", bbox_to_anchor=(1.0, 1.6), fontsize=7, frameon=False)
    for a, b in zip(k[:-1], k[1:]):
        t0, t1, code = float(t[a]), float(t[b]) + (dt if b == s.size - 1 else 0.0), s[a]
        for ax in ax_all:
            ax.axvspan(t0, t1, color=STAGE_COLOURS[code], alpha=0.35, lw=0, zorder=0)
        ax_bar.broken_barh([(t0, t1 - t0)], (0, 1), color=STAGE_COLOURS[code], edgecolor="k", lw=0.3)
        if t1 - t0 > 0.04 * (float(t[-1]) - float(t[0]) + dt):   # a label where it fits
            ax_bar.text(0.5 * (t0 + t1), 0.5, STAGES[code], ha="center", va="center", fontsize=7)
    ax_bar.set_ylim(0, 1)
    ax_bar.set_yticks([])
    ax_bar.set_ylabel("stage", rotation=0, ha="right", va="center")


def plot_run(res, path: str | Path, title: str | None = None) -> Path:
    """A run's figure: speed and its reference; the currents against the
    current limit; torque and load; the voltage against its limit
    (modulation index); the angle error; the drive's stage as labelled
    bands (shaded behind every panel too)."""
    sc, tr = res.scenario, res.traces
    t = tr["t"]
    mode = sc.data["controller"]["mode"]
    i_max = sc.data["controller"]["i_max"]
    fig, ax = plt.subplots(6, 1, figsize=(11, 12), sharex=True,
                           gridspec_kw={"height_ratios": [3, 3, 2, 2, 2, 0.6]})
    ax[0].plot(*drawn(t, rad_s_to_rpm(tr["w_m"])), label="speed")
    if mode == "speed":
        ax[0].plot(*drawn(t, rad_s_to_rpm(tr["w_m_ref"])), "--", label="reference")
    ax[0].plot(*drawn(t, rad_s_to_rpm(tr["w_m_hat"])), ":", label="used by the loops")
    ax[0].set_ylabel("speed (rpm)")
    ax[1].plot(*drawn(t, tr["i_d"]), label="$i_d$")
    ax[1].plot(*drawn(t, tr["i_q"]), label="$i_q$")
    if mode in ("speed", "current"):
        ax[1].plot(*drawn(t, tr["i_d_ref"]), "--", lw=0.8, label="$i_d^*$")
        ax[1].plot(*drawn(t, tr["i_q_ref"]), "--", lw=0.8, label="$i_q^*$")
    if sc.data["controller"]["flux_weakening"]:
        ax[1].plot(*drawn(t, tr["i_d_fw"]), lw=0.8, label="$i_{d,fw}$")
    ax[1].plot(*drawn(t, np.hypot(tr["i_d"], tr["i_q"])), "k", lw=0.5, alpha=0.6, label="$|i|$")
    for sgn in (1, -1):
        ax[1].axhline(sgn * i_max, color="r", ls="-.", lw=0.8, label="$\\pm i_{max}$" if sgn > 0 else None)
    ax[1].set_ylabel("current (A)")
    ax[2].plot(*drawn(t, tr["T_e"]), label="$T_e$")
    ax[2].plot(*drawn(t, tr["T_L"]), label="$T_L$ (load)")
    ax[2].set_ylabel("torque (N m)")
    ax[3].plot(*drawn(t, modulation_index(res)), lw=0.8, label="$|u^*| / (u_{dc}/\\sqrt{3})$")
    ax[3].axhline(1.0, color="r", ls="-.", lw=0.8, label="linear limit")
    t_over, over = drawn(t, np.asarray(tr["overmod"]) > 0)
    if over.any():
        ax[3].fill_between(t_over, 0, 1, where=over, transform=ax[3].get_xaxis_transform(), color="r", alpha=0.15,
                           lw=0, label="over-modulating")
    ax[3].set_ylabel("modulation index")
    ax[4].plot(*drawn(t, np.degrees(tr["theta_err"])), "r", lw=0.8, label="true - used")
    if sc.data["controller"]["angle"] in ("smo", "hfi", "blend", "swvi"):
        ax[4].plot(*drawn(t, np.degrees(tr["est_err"])), "k", lw=0.5, alpha=0.6, label="true - estimate")
    ax[4].set_ylabel("angle error (el.deg)")
    _stage_bands(ax[:5], ax[5], t, tr["stage"])
    ax[5].set_xlabel("time (s)")
    if t.size > 1:
        ax[5].set_xlim(float(t[0]), float(t[-1]))
    for a in ax[:5]:
        a.grid(True, alpha=0.3)
        a.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, frameon=False)
    fig.suptitle(title or sc.name)
    return save_figure(fig, path, 110, title or sc.name)


def plot_sweep(sw, rows: list[dict], path: str | Path) -> Path | None:
    """The papers' maps: a line per metric over a 1-D sweep, a heat map per
    metric over the first two grid axes of a 2-D one, and for a Monte Carlo
    (random axes only) each metric's distribution. Up to six metrics;
    failed points are left blank. None when there is nothing to draw."""
    grid = sw.grid
    names = [m for m in sw.metrics if any(isinstance(r.get(m), (int, float)) for r in rows)][:6]
    if not names or len(grid) > 2:
        return None

    def value(r, m):
        v = r.get(m)
        return float(v) if isinstance(v, (int, float)) and r["stop_reason"] != "error" else np.nan

    n = len(names)
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 3.6), squeeze=False)
    for ax, m in zip(axes[0], names):
        if not grid:
            vals = np.array([value(r, m) for r in rows])
            ax.hist(vals[np.isfinite(vals)], bins=min(30, max(5, len(vals) // 5)))
            ax.set_xlabel(m)
            ax.set_ylabel("points")
        elif len(grid) == 1:
            a = grid[0]
            xs = np.array([r[a.name] for r in rows], dtype=float)
            ys = np.array([value(r, m) for r in rows])
            if sw.samples > 1:
                ax.plot(xs, ys, ".", alpha=0.5)
            else:
                order = np.argsort(xs)
                ax.plot(xs[order], ys[order], "o-")
            ax.set_xlabel(a.name)
            ax.set_ylabel(m)
            ax.grid(True, alpha=0.3)
        else:
            a, b = grid
            acc = np.zeros((len(a.values), len(b.values)))
            cnt = np.zeros_like(acc)
            for r in rows:
                v = value(r, m)
                if np.isfinite(v):
                    i, j = a.values.index(r[a.name]), b.values.index(r[b.name])
                    acc[i, j] += v
                    cnt[i, j] += 1
            z = np.where(cnt > 0, acc / np.maximum(cnt, 1), np.nan)
            im = ax.imshow(z, origin="lower", aspect="auto", cmap="viridis")
            ax.set_xticks(range(len(b.values)), [f"{v:g}" for v in b.values], rotation=45, fontsize=7)
            ax.set_yticks(range(len(a.values)), [f"{v:g}" for v in a.values], fontsize=7)
            ax.set_xlabel(b.name)
            ax.set_ylabel(a.name)
            ax.set_title(m + (" (mean of samples)" if sw.samples > 1 else ""), fontsize=9)
            fig.colorbar(im, ax=ax)
    fig.suptitle(f"sweep {sw.name}: {len(rows)} points")
    return save_figure(fig, path, 100, f"sweep {sw.name}")
