"""docs/lock-loss.png: what the drive does when it loses lock at speed
(csrc/control/fs_drive_protect.h), on lock-loss.toml beside this file.

Three runs of motulator's 2.2 kW IPMSM, blended sensorless at 1000 rpm:
  1. the default (controller.lock = "recover"): a 50 ms load impact of
     2.5 x T_max throws the rotor back through zero, the estimate loses it;
     the drive holds zero current for 50 ms, its back-EMF observer catches
     the spinning rotor from the voltage the current loops apply (a flying
     restart), and the loops take it back to 1000 rpm;
  2. the same impact with controller.lock = "detect": the loss is flagged
     and the drive goes on driving on the false estimate (here until its
     estimator finds the rotor by itself, 70 ms later);
  3. the load stays at 1.5 x T_max (more than the drive can hold): the
     rotor runs backwards, the observer does not catch it during the wait,
     and the drive stops with the PWM off.

Usage: python examples/lock-loss/make_figure.py [OUT.png]   (default docs/lock-loss.png)
"""
from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fullspeed.design.scenario import load_scenario  # noqa: E402
from fullspeed.model.units import rad_s_to_rpm  # noqa: E402
from fullspeed.sim import simulate  # noqa: E402
from fullspeed.sim.metrics import STAGES, lock_lines  # noqa: E402
from fullspeed.sim.plots import STAGE_COLOURS  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
SCENARIO = HERE / "lock-loss.toml"
HOLD = [[0.0, 0.0], [0.2, 0.0], [0.3, 7.0], [1.0, 7.0], [1.002, 34.5]]   # 1.5 x T_max (23.0 N m) from 1.0 s on
RUNS = (("default (lock = \"recover\"): 50 ms impact of 2.5 T_max", {}),
        ("lock = \"detect\": the same impact", {"controller": {"lock": "detect"}}),
        ("default: the load held at 1.5 T_max", {"load": {"torque": HOLD}}))
T_VIEW = (0.9, 1.5)


def _shade(ax, t, stage) -> None:
    s = np.asarray(stage).astype(int)
    k = np.r_[0, np.flatnonzero(np.diff(s)) + 1, s.size - 1]
    for a, b in zip(k[:-1], k[1:]):
        ax.axvspan(t[a], t[b], color=STAGE_COLOURS[s[a]], alpha=0.5, lw=0, zorder=0)


def main(out: Path) -> Path:
    fig, ax = plt.subplots(2, 3, figsize=(13, 6), sharex=True, sharey="row")
    seen = set()
    for j, (title, ov) in enumerate(RUNS):
        res = simulate(load_scenario(SCENARIO, ov))
        tr, m = res.traces, res.metrics
        t = tr["t"]
        for a in ax[:, j]:
            _shade(a, t, tr["stage"])
        seen |= set(np.asarray(tr["stage"]).astype(int))
        ax[0, j].plot(t, rad_s_to_rpm(tr["w_m_ref"]), "k:", lw=1, label="reference")
        ax[0, j].plot(t, rad_s_to_rpm(tr["w_m"]), "C0", lw=1.5, label="rotor (truth)")
        ax[0, j].plot(t, rad_s_to_rpm(tr["w_m_hat"]), "C1--", lw=1.2, label="the loops' estimate")
        ax[1, j].plot(t, np.degrees(tr["theta_err"]), "C3", lw=1)
        what = lock_lines(m) or [f"lock lost at {m['lock_lost_at']:.3f} s: the drive went on" if m.get("lock_lost_at") else ""]
        if res.stop_reason != "done":
            what.append(f"stopped at {res.stop_time:.3f} s with the PWM off ({res.stop_reason})")
            for a in ax[:, j]:
                a.axvline(res.stop_time, color="k", lw=1.5)
        ax[0, j].set_title(title, fontsize=9)
        ax[1, j].text(0.02, 0.03, "\n".join(_wrap(w) for w in what), transform=ax[1, j].transAxes, fontsize=6.5,
                      va="bottom", bbox={"facecolor": "white", "alpha": 0.8, "lw": 0})
        ax[1, j].set_xlabel("t (s)")
    ax[0, 0].set_ylabel("speed (rpm)")
    ax[1, 0].set_ylabel("angle error, true - used (el.deg)")
    ax[0, 0].legend(fontsize=7, loc="lower right")
    ax[0, 0].set_xlim(*T_VIEW)
    ax[1, 0].set_ylim(-190, 190)
    from matplotlib.patches import Patch
    fig.legend(handles=[Patch(color=STAGE_COLOURS[c], alpha=0.5, label=f"stage {STAGES[c]}") for c in sorted(seen)],
               loc="upper center", bbox_to_anchor=(0.5, 0.95), ncol=len(seen), fontsize=7, frameon=False)
    fig.suptitle("Loss of lock at speed: the flying restart, detection alone, and the stop "
                 "(examples/lock-loss, motulator-2kw-ipmsm blended sensorless)", fontsize=10, y=0.99)
    fig.tight_layout(rect=(0, 0, 1, 0.91))
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def _wrap(text: str, width: int = 70) -> str:
    words, lines, line = text.split(), [], ""
    for w in words:
        if len(line) + len(w) + 1 > width:
            lines.append(line)
            line = w
        else:
            line = f"{line} {w}".strip()
    return "\n".join(lines + [line])


if __name__ == "__main__":
    print(main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "lock-loss.png"))
