"""The flux map the drive's identification read (csrc/control/fs_mapid.h),
made a map the loader takes (model/fluxmap.py), and held against the truth.

The drive reads, at standstill, psi_d(i_d, 0) - psi_f at i_d = k i_max / 4
(k = -4..4, the d sweep), and at the d levels k = -3..3 psi_q(i_d, j i_max / 8)
and psi_d(i_d, j i_max / 8) - psi_d(i_d, 0) (j = 1..8, the q sweeps, as far
as the disc and the rotor's motion let them go); where the rotor may turn,
psi_d(i_d, 0) at speed from the steady voltage equations (absolute: no
psi_f needed). The grid is i_d = k i_max / 4 by i_q = j i_max / 8, j = -8..8
(psi_q odd and psi_d even in i_q); each point is "measured", "at speed" or
"extrapolated" (outside the disc, or beyond what the sweeps reached: along
i_q from the last two points read, the rows at +-i_max from their
neighbours').
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from ..design.start import POLARITY_ASYMMETRY, carrier_asymmetry, d_asymmetry
from ..model.fluxmap import interp

ND, NQ = 9, 8          # fs_mapid.h: FS_MAPID_ND, FS_MAPID_NQ
GOAL_PCT = 3.0         # claim B-MAPID: the RMS error over the disc within 3 % of psi_f


def readings(ident) -> dict:
    """The map's readings from a drive's fs_ident (its fs_mapid's result and
    DCURVE's), as plain lists (a journal row holds them)."""
    m, r = ident.map.res, ident.res
    return {"dpsi_d": list(m.dpsi_d), "n_d": list(m.n_d), "asym": m.asym, "flipped": int(m.flipped),
            "decided": int(m.decided), "L_pos": m.L_pos, "L_neg": m.L_neg,
            "psi_q": [list(r) for r in m.psi_q], "dpsi_dq": [list(r) for r in m.dpsi_dq],
            "i_d_at": [list(r) for r in m.i_d_at], "n_q": [list(r) for r in m.n_q],
            "i_q_amp": list(m.i_q_amp), "limit": list(m.limit), "motion": list(m.motion),
            "impulse_left": list(m.impulse_left), "d_amp": m.d_amp, "d_limit": m.d_limit, "d_growth": m.d_growth,
            "axis_offset": m.axis_offset,
            "psi_d_w": list(r.psi_d_w), "i_d_w": list(r.i_d_w), "w_d_w": list(r.w_d_w)}


def assemble(rd: dict, i_max: float, psi_f: float, L_d: float) -> dict:
    """The grid (the loader's layout: i_d, i_q axes, psi_d[k][l], psi_q[k][l])
    and each point's source, from the readings; psi_f anchors the standstill
    d sweep where the speed did not read a level; L_d moves a q reading from
    the d current it was taken at to its level."""
    i_d = np.array([0.25 * (k - ND // 2) * i_max for k in range(ND)])
    i_q = np.array([(j - NQ) * i_max / NQ for j in range(2 * NQ + 1)])
    psi_d, psi_q = np.full((ND, 2 * NQ + 1), np.nan), np.full((ND, 2 * NQ + 1), np.nan)
    src = np.full((ND, 2 * NQ + 1), "extrapolated", dtype=object)
    # the d axis: at speed where read (absolute), else the standstill sweep on psi_f
    d0 = np.array([psi_f + rd["dpsi_d"][k] if rd["n_d"][k] else np.nan for k in range(ND)])
    speed = np.array([rd["psi_d_w"][k] if rd["w_d_w"][k] else np.nan for k in range(ND)])
    # at speed in pairs +-k only: read on one side alone, the speed's absolute level beside the standstill
    # sweep's (its psi_f anchor and what the dead time leaves in it) on the other puts a step between them
    # into the axis, an asymmetry the machine does not have (siemens-1ft6084, linear: 10 % at +-i_max/2,
    # read at speed at +i_max/4 and +i_max/2 only, where its lock held the rotor)
    speed = np.where(np.isfinite(speed) & np.isfinite(speed[::-1]), speed, np.nan)
    speed[ND // 2] = psi_f
    axis = np.where(np.isfinite(speed), speed, d0)
    read = np.isfinite(axis)
    for k in range(ND):
        if read[k]:
            src[k, NQ] = "at speed" if np.isfinite(speed[k]) and k != ND // 2 else "measured"
    if read.sum() >= 2:   # the ends the sweeps did not reach: along the axis from the last two read
        idx = np.flatnonzero(read)
        for k in np.flatnonzero(~read):
            a, b = (idx[:2] if k < idx[0] else idx[-2:]) if (k < idx[0] or k > idx[-1]) else (idx[idx < k][-1], idx[idx > k][0])
            axis[k] = axis[a] + (axis[b] - axis[a]) * (k - a) / (b - a)
    psi_d[:, NQ], psi_q[:, NQ] = axis, 0.0
    slope = np.gradient(axis, i_d) if np.isfinite(axis).all() else np.full(ND, L_d)
    for k in range(ND):
        for j in range(1, NQ + 1):
            if not rd["n_q"][k][j - 1]:
                continue
            shift = i_d[k] - rd["i_d_at"][k][j - 1]   # the held d current a little off its level
            pd = axis[k] + rd["dpsi_dq"][k][j - 1] + slope[k] * shift
            pq = rd["psi_q"][k][j - 1]
            for side in (1, -1):
                psi_d[k, NQ + side * j], psi_q[k, NQ + side * j] = pd, side * pq
                src[k, NQ + side * j] = "measured"
    spread = _fill(psi_d, psi_q, src)
    out = _beyond({"i_d": i_d, "i_q": i_q, "psi_d": psi_d, "psi_q": psi_q, "source": src})
    out["spread"] = spread
    out["rise_moved"] = _rising(out)
    return out


def rising(x: np.ndarray, tiny: float) -> np.ndarray:
    """The sequence nearest x (least squares) that rises: pool adjacent
    violators, then each value at least tiny above the one before it."""
    blocks: list[list[float]] = []   # [mean, count]
    for v in x:
        blocks.append([float(v), 1.0])
        while len(blocks) > 1 and blocks[-2][0] >= blocks[-1][0]:
            m2, n2 = blocks.pop()
            m1, n1 = blocks.pop()
            blocks.append([(m1 * n1 + m2 * n2) / (n1 + n2), n1 + n2])
    y = np.concatenate([np.full(int(n), m) for m, n in blocks])
    for j in range(1, y.size):
        y[j] = max(y[j], y[j - 1] + tiny)
    return y


def _rising(grid: dict) -> float:
    """A flux that does not rise with its own current is no machine (the
    loader refuses it): readings a few tenths of a per cent of psi_f off,
    taken while a free rotor swung, can fall between two grid steps where
    the incremental inductance is small (the grin hub motor's 0.13 mH, with
    more of its d levels read on a free rotor in an experiment: psi_q 2.4 ->
    2.8 mWb the wrong way at i_d = 0.75 i_max, and no machine.toml). Each
    row of psi_q along i_q and each column of psi_d along i_d is made the
    nearest rising one (rising()); a map that rose is left as it was.
    Returns the largest change, Wb (0 where every reading rose)."""
    moved = 0.0
    tiny = 1e-7 * max(float(np.max(np.abs(grid["psi_d"]))), float(np.max(np.abs(grid["psi_q"]))), 1e-6)
    for key, axis in (("psi_q", 1), ("psi_d", 0)):
        a = np.asarray(grid[key], float)
        b = np.apply_along_axis(rising, axis, a, tiny)
        moved = max(moved, float(np.max(np.abs(b - a))))
        grid[key] = b
    return moved


def _beyond(grid: dict) -> dict:
    """The grid one step beyond +-i_max on both axes, each flux carried on
    linearly from the last two points (marked extrapolated). A map that ends
    at the current limit has no incremental inductance there: the design's
    differences past its edge read the loader's clamp, a slope of zero, and
    the injection's cross-saturation table designed from the map
    (design.xcomp), whose lead is the saliency axis' turn by those slopes,
    came out 73..83 el.deg at the limit on zoo machines 2 and 4 (the
    truth's 19 and 14; the true fluxes on the same grid gave the same: the
    grid's edge, not the readings); 13 and 11 now. (B-MAPID's runs did not
    move with it: their currents stay off that end of the table.) The
    disc's points, and so the map's error, are inside."""
    i_d, i_q = grid["i_d"], grid["i_q"]
    out = {"i_d": np.r_[2 * i_d[0] - i_d[1], i_d, 2 * i_d[-1] - i_d[-2]],
           "i_q": np.r_[2 * i_q[0] - i_q[1], i_q, 2 * i_q[-1] - i_q[-2]]}
    for key in ("psi_d", "psi_q"):
        a = grid[key]
        a = np.vstack([2 * a[0] - a[1], a, 2 * a[-1] - a[-2]])
        out[key] = np.hstack([(2 * a[:, 0] - a[:, 1])[:, None], a, (2 * a[:, -1] - a[:, -2])[:, None]])
    src = np.full(out["psi_d"].shape, "extrapolated", dtype=object)
    src[1:-1, 1:-1] = grid["source"]
    out["source"] = src
    return out


N_FALL = 3   # steps the fall is fitted over (saturation_ratio): more average the noise, fewer follow the knee


def saturation_ratio(row, have: list[int]) -> float | None:
    """The ratio by which a q sweep's incremental inductance fell a grid
    step over its last readings, within [0, 1]: a saturating iron's flux is
    concave in its own current, its incremental inductance falling, never
    rising (a ratio above 1 is the readings' noise on a linear axis: 1).
    From the flux's rise per grid step between consecutive points read, the
    last N_FALL of them, fitted as a geometric fall (log-linear least
    squares): two steps alone carry each one's noise into the ratio, about
    7 % on examples/own-machine (steps of 2 mWb, 0.1 mWb off), whose map
    then came out 3.0 % of psi_f off from 30 el.deg against 2.7 % with a
    straight line. None where fewer than two points beside zero current
    were read (no fall to see). row: psi_q along i_q (index NQ + j at
    i_q = j i_max / NQ)."""
    pts = [0] + list(have)
    if len(pts) < 3:
        return None
    pts = pts[-(N_FALL + 1):]
    x = np.array([0.5 * (a + b) for a, b in zip(pts[:-1], pts[1:])])
    s = np.array([(row[NQ + b] - row[NQ + a]) / (b - a) for a, b in zip(pts[:-1], pts[1:])])
    if not np.all(s > 0):
        return 1.0   # a step that did not rise: noise on a flat reading, nothing to carry a fall from
    slope = np.polyfit(x, np.log(s), 1)[0]
    return float(min(max(math.exp(slope), 0.0), 1.0))


def _fill(psi_d, psi_q, src) -> np.ndarray:
    """What was not read: along i_q, psi_q from the row's last point read on
    by its last incremental L_q, falling a grid step by the ratio it fell
    over the readings (saturation_ratio; linear where it did not fall) and
    psi_d held at its last (the cross-saturation's change beyond the sweep
    is not known; a line through two readings a grid step apart, carried
    five steps on, multiplies their noise: 26 % of psi_f on the locked
    Prius-like machine whose sweeps reached 35 A of 250); then whole rows
    from the nearest row read (its changes along i_q). Returns the spread of
    the extrapolated psi_q: how far the straight line (the fall stopping
    where the readings end) lies from it, per point (0 where read), a
    measure of what the readings leave open beyond them."""
    spread = np.zeros(psi_q.shape)
    for k in range(ND):
        have = [j for j in range(1, NQ + 1) if src[k, NQ + j] != "extrapolated"]
        if not have or not np.isfinite(psi_d[k, NQ]):
            continue
        j1 = have[-1]
        j0 = have[-2] if len(have) > 1 else 0
        r = saturation_ratio(psi_q[k], have)
        r = 1.0 if r is None else r   # one point read: its slope carried on (no fall seen)
        s1 = (psi_q[k, NQ + j1] - psi_q[k, NQ + j0]) / (j1 - j0)   # Wb a grid step: the last incremental L_q read
        for j in range(1, NQ + 1):
            if j in have:
                continue
            if j < j1:   # between readings: linear
                lo = max(i for i in [0] + have if i < j)
                hi = min(i for i in have if i > j)
                f = (j - lo) / (hi - lo)
                for side in (1, -1):
                    psi_d[k, NQ + side * j] = psi_d[k, NQ + side * lo] + f * (psi_d[k, NQ + side * hi] - psi_d[k, NQ + side * lo])
                    psi_q[k, NQ + side * j] = psi_q[k, NQ + side * lo] + f * (psi_q[k, NQ + side * hi] - psi_q[k, NQ + side * lo])
                continue
            n = j - j1
            ext = s1 * sum(r ** m for m in range(1, n + 1))   # the incremental L_q falling on by r a step
            for side in (1, -1):
                psi_d[k, NQ + side * j] = psi_d[k, NQ + side * j1]
                psi_q[k, NQ + side * j] = psi_q[k, NQ + side * j1] + side * ext
                spread[k, NQ + side * j] = abs(s1 * n - ext)
    rows = [k for k in range(ND) if np.isfinite(psi_d[k]).all()]
    for k in range(ND):
        if k in rows or not rows:
            continue
        near = min(rows, key=lambda r: abs(r - k))
        base = psi_d[k, NQ] if np.isfinite(psi_d[k, NQ]) else psi_d[near, NQ]
        psi_d[k] = base + psi_d[near] - psi_d[near, NQ]
        psi_q[k] = psi_q[near]
        spread[k] = spread[near]
        for j in range(2 * NQ + 1):
            if j != NQ or not np.isfinite(psi_d[k, NQ]):
                src[k, j] = "extrapolated"
    return spread


def spread_pct(grid: dict, psi_f: float, i_max: float) -> float:
    """The RMS over the current limit's disc of the map's extrapolation
    spread (grid["spread"], _fill), % of psi_f: what its readings leave
    open, from the drive's readings alone (no truth needed)."""
    a, b = disc_points(i_max)
    i_d, i_q = grid["i_d"][1:-1], grid["i_q"][1:-1]   # the spread is on the grid inside its step beyond the limit
    mag = {"i_d": i_d, "i_q": i_q, "psi_d": grid["spread"], "psi_q": grid["spread"]}
    return 100.0 * math.sqrt(float(np.mean((interp(mag, "psi_d", a, b) / psi_f) ** 2)))


def disc_points(i_max: float, n: int = 41) -> tuple[np.ndarray, np.ndarray]:
    """An even grid of currents within the current limit's disc (41 x 41
    over the square: 1,257 points inside)."""
    g = np.linspace(-i_max, i_max, n)
    a, b = np.meshgrid(g, g, indexing="ij")
    inside = a * a + b * b <= i_max * i_max * (1 + 1e-9)
    return a[inside], b[inside]


def map_errors(grid: dict, true_flux, psi_f: float, i_max: float) -> dict:
    """RMS and largest error of the identified map (bilinear on its grid, as
    the loader's map is read) against the true fluxes over the disc, % of
    psi_f: psi_d, psi_q and both together (the claim's figure)."""
    a, b = disc_points(i_max)
    mag = {"i_d": grid["i_d"], "i_q": grid["i_q"], "psi_d": grid["psi_d"], "psi_q": grid["psi_q"]}
    td, tq = true_flux(a, b)
    ed = (interp(mag, "psi_d", a, b) - td) / psi_f
    eq = (interp(mag, "psi_q", a, b) - tq) / psi_f
    return {"rms_pct": 100.0 * math.sqrt(float(np.mean(np.r_[ed, eq] ** 2))),
            "rms_d_pct": 100.0 * math.sqrt(float(np.mean(ed ** 2))), "rms_q_pct": 100.0 * math.sqrt(float(np.mean(eq ** 2))),
            "max_pct": 100.0 * float(np.max(np.abs(np.r_[ed, eq]))), "points": int(a.size)}


def constant_errors(L_d: float, L_q: float, psi_f_id: float, true_flux, psi_f: float, i_max: float) -> dict:
    """The same for the constant-parameter model of the identified L_d, L_q,
    psi_f (psi_d = psi_f + L_d i_d, psi_q = L_q i_q): what the map adds."""
    a, b = disc_points(i_max)
    td, tq = true_flux(a, b)
    ed, eq = (psi_f_id + L_d * a - td) / psi_f, (L_q * b - tq) / psi_f
    return {"rms_pct": 100.0 * math.sqrt(float(np.mean(np.r_[ed, eq] ** 2))),
            "max_pct": 100.0 * float(np.max(np.abs(np.r_[ed, eq])))}


def true_grid(true_flux, i_max: float) -> dict:
    """The true fluxes on the identified map's grid (for its asymmetry)."""
    i_d = np.array([0.25 * (k - ND // 2) * i_max for k in range(ND)])
    i_q = np.array([(j - NQ) * i_max / NQ for j in range(2 * NQ + 1)])
    a, b = np.meshgrid(i_d, i_q, indexing="ij")
    td, tq = true_flux(a.ravel(), b.ravel())
    return {"i_d": i_d, "i_q": i_q, "psi_d": td.reshape(a.shape), "psi_q": tq.reshape(a.shape)}


def _grid_machine(grid: dict) -> SimpleNamespace:
    """A map's grid as design.start reads a machine's flux map."""
    return SimpleNamespace(magnetic={"model": "fluxmap", "i_d": list(grid["i_d"]), "i_q": list(grid["i_q"]),
                                     "psi_d": np.asarray(grid["psi_d"]).tolist(), "psi_q": np.asarray(grid["psi_q"]).tolist()})


def asymmetry(grid: dict, i_pulse: float) -> float | None:
    """The d-axis asymmetry polarity detection decides on (design.start:
    the incremental L_d at -i_pulse against +i_pulse), of a map's grid."""
    return d_asymmetry(_grid_machine(grid), i_pulse)


def polarity_report(grid: dict, truth: dict | None, i_pulse: float) -> dict:
    """The identified map's d-axis asymmetry at the polarity pulses (its
    size, and the truth's on the same grid: how well the map was read) and
    its sign, as polarity detection reads it (design.start.carrier_asymmetry:
    the carrier larger where the d current adds to the magnet, D > 0): the
    pulses decide where D >= POLARITY_ASYMMETRY, would read the south pole
    where D <= -POLARITY_ASYMMETRY ("reversed"), and cannot decide between.
    A d axis whose saturation falls inside a cell of the grid reads an
    asymmetry of the right size and the wrong sign: the Baldor PM-SyRM's at
    +-9.3 A, -20 % on the i_max/4 grid (its bump, 43 mH at +3 A, inside one
    4.7 A cell) against -2 % on its own map; the drive designed from the
    file then takes the motion test."""
    ident = asymmetry(grid, i_pulse)
    got = carrier_asymmetry(_grid_machine(grid), i_pulse)
    D = None if got is None else float(got[0])
    out = {"i_pulse": i_pulse, "asymmetry": ident, "signed": D, "needed": POLARITY_ASYMMETRY,
           "decides": bool(D is not None and D >= POLARITY_ASYMMETRY),
           "reversed": bool(D is not None and D <= -POLARITY_ASYMMETRY)}
    if truth is not None:
        out["asymmetry_truth"] = asymmetry(truth, i_pulse)
    return out


def csv_text(grid: dict, machine: str) -> str:
    """The grid as the CSV the loader reads (model/fluxmap.py), each point's
    source in the comment above it."""
    lines = [f"# {machine}: flux map identified by `fullspeed identify` (csrc/control/fs_mapid.h)",
             "# peak phase currents and flux linkages, magnet on +d (amplitude-invariant dq)",
             "# source of each row's point: m measured (standstill sweeps), s at speed (steady voltage equations),",
             "# e extrapolated (outside the current limit's disc, or beyond what the sweeps reached)",
             "i_d [A],i_q [A],psi_d [Wb],psi_q [Wb]"]
    code = {"measured": "m", "at speed": "s", "extrapolated": "e"}
    for k, a in enumerate(grid["i_d"]):
        lines.append("# " + "".join(code[s] for s in grid["source"][k]))
        for j, b in enumerate(grid["i_q"]):
            # the currents as they are (17 digits): the grid must reach i_max as machine.toml gives it
            lines.append(f"{a:.17g},{b:.17g},{grid['psi_d'][k, j]:.9g},{grid['psi_q'][k, j]:.9g}")
    return "\n".join(lines) + "\n"


def measured_csv_text(rd: dict, i_max: float, psi_f: float, machine: str) -> str:
    """The points as the drive read them (before the grid): the d axis at
    standstill (relative to psi_f, here added) and at speed, and each q
    sweep's points at the d current they were read at."""
    lines = [f"# {machine}: the points `fullspeed identify` read (fluxmap.csv is the grid made of them)",
             "# method: standstill d sweep (psi_d on psi_f), at speed (steady voltage equations), standstill q sweep",
             "method,i_d [A],i_q [A],psi_d [Wb],psi_q [Wb]"]
    for k in range(ND):
        a = 0.25 * (k - ND // 2) * i_max
        if rd["n_d"][k]:
            lines.append(f"standstill d sweep,{a:.9g},0,{psi_f + rd['dpsi_d'][k]:.9g},0")
        if rd["w_d_w"][k]:
            lines.append(f"at speed,{rd['i_d_w'][k]:.9g},0,{rd['psi_d_w'][k]:.9g},0")
    for k in range(ND):
        base = rd["psi_d_w"][k] if rd["w_d_w"][k] else psi_f + rd["dpsi_d"][k]
        for j in range(1, NQ + 1):
            if rd["n_q"][k][j - 1]:
                b = j * i_max / NQ
                lines.append(f"standstill q sweep,{rd['i_d_at'][k][j - 1]:.9g},{b:.9g},"
                             f"{base + rd['dpsi_dq'][k][j - 1]:.9g},{rd['psi_q'][k][j - 1]:.9g}")
    return "\n".join(lines) + "\n"
