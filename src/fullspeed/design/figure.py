"""envelope.png, as `fullspeed design` writes it: the machine's torque and
power against speed at the current limit and the converter's voltage, the
MTPA, flux-weakening and MTPV regions shaded, and the currents along it.
Apart from report (which the command line imports at start) so that
matplotlib loads only when a figure is drawn."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..model.units import rad_s_to_rpm  # noqa: E402
from .drawing import save_figure  # noqa: E402
from .envelope import REGIONS, Envelope  # noqa: E402

REGION_COLOURS = {"MTPA": "#c6dbef", "FW": "#fdd0a2", "MTPV": "#c7e9c0"}
REGION_NAMES = {"MTPA": "MTPA (current limit)", "FW": "flux weakening (current and voltage)", "MTPV": "MTPV (voltage)"}


def plot_envelope(env: Envelope, path: Path, how: str = "") -> None:
    """Torque and power (top), i_d and i_q (bottom) against speed, regions shaded."""
    n = rad_s_to_rpm(env.w_m)
    fig, ax = plt.subplots(2, 1, figsize=(9, 7), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    for a in ax:
        for r in REGIONS:
            inside = env.region == r
            if not inside.any():
                continue
            k = np.flatnonzero(inside)
            lo, hi = n[max(k[0] - 1, 0)] if r != "MTPA" else n[k[0]], n[k[-1]]
            a.axvspan(lo, hi, color=REGION_COLOURS[r], alpha=0.6, lw=0, label=REGION_NAMES[r] if a is ax[0] else None)
    ax[0].plot(n, env.T, "C0", lw=1.8, label="T_max")
    ax[0].set_ylabel("torque (N m)", color="C0")
    pw = ax[0].twinx()
    pw.plot(n, env.P / 1e3, "C3", lw=1.5, label="P_max")
    pw.set_ylabel("power (kW)", color="C3")
    pw.set_ylim(bottom=0)
    ax[0].set_ylim(bottom=0)
    ax[0].axvline(rad_s_to_rpm(env.w_base), color="k", ls=":", lw=0.8)
    ax[0].annotate(f"base {rad_s_to_rpm(env.w_base):.0f} rpm", (rad_s_to_rpm(env.w_base), env.T_base), fontsize=8,
                   xytext=(4, -12), textcoords="offset points")
    h0, l0 = ax[0].get_legend_handles_labels()
    h1, l1 = pw.get_legend_handles_labels()
    ax[0].legend(h0 + h1, l0 + l1, fontsize=8, loc="upper right")
    top = "infinite top speed" if not env.top_finite else f"top speed {rad_s_to_rpm(env.w_top):.0f} rpm"
    ax[0].set_title(f"{env.machine}: envelope at {env.i_max:g} A and |u| <= {env.u_max:.4g} V, characteristic current "
                    f"{env.i_ch:.4g} A, {top}\n({how or 'linear modulation'})", fontsize=9)
    ax[1].plot(n, env.i_d, "C0", label="i_d")
    ax[1].plot(n, env.i_q, "C1", label="i_q")
    ax[1].plot(n, np.hypot(env.i_d, env.i_q), "k--", lw=0.8, label="|i|")
    ax[1].axhline(-env.i_ch, color="C0", ls=":", lw=0.8, label="-i_ch")
    ax[1].set_ylabel("current (A)")
    ax[1].set_xlabel("speed (rpm)")
    ax[1].legend(fontsize=8, loc="lower left")
    for a in ax:
        a.grid(alpha=0.3)
    save_figure(fig, path, 110, f"{env.machine}: envelope")
