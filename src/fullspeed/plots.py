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
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return Path(path)
