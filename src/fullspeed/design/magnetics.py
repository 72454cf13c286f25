"""What the design takes from a flux map: the MTPA locus searched on the
map, the incremental saliency an injection estimator sees along it, and the
values the controller is given (psi_f, secant and incremental inductances,
the MTPA table), and the map as the controller holds it (controller_map).
The map itself is read and checked in model.fluxmap."""
from __future__ import annotations

import numpy as np

from .._core import lib
from ..model.fluxmap import interp, interp_tables, table_at, zero_current_values

MTPA_N = 64          # csrc/control/fs_mtpa.h FS_MTPA_N
MTPA_ANGLES = 4001   # current angles searched per magnitude, 90..180 deg: 0.0225 deg apart
MTPA_ROWS = 2        # magnitudes searched a pass: their arrays (8,002 points) stay in the cache, where the
                     # whole grid's (256,064) went to memory and back a dozen times (4x the time, the same values)


def mtpa_locus(mag: dict, i_max: float, phases: int, pole_pairs: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The map's MTPA locus at |i| = i_max k / (MTPA_N - 1): per magnitude
    the current angle of most torque, (phases/2) p (psi_d i_q - psi_q i_d),
    searched over the second quadrant. Returns T, i_d, i_q."""
    I = i_max * np.arange(MTPA_N) / (MTPA_N - 1)
    g = np.linspace(0.5 * np.pi, np.pi, MTPA_ANGLES)
    cos_g, sin_g = np.cos(g), np.sin(g)
    T_best, d, q = np.empty(MTPA_N), np.empty(MTPA_N), np.empty(MTPA_N)
    for r0 in range(0, MTPA_N, MTPA_ROWS):   # each row as the whole grid's would be, a few rows a pass
        rows = slice(r0, r0 + MTPA_ROWS)
        i_d, i_q = np.outer(I[rows], cos_g), np.outer(I[rows], sin_g)
        psi_d, psi_q = interp_tables(mag, ("psi_d", "psi_q"), i_d, i_q)
        T = 0.5 * phases * pole_pairs * (psi_d * i_q - psi_q * i_d)
        best = np.argmax(T, axis=1)
        r = np.arange(T.shape[0])
        T_best[rows], d[rows], q[rows] = T[r, best], i_d[r, best], i_q[r, best]
    d[0] = q[0] = T_best[0] = 0.0
    return T_best, d, q


SALIENCY_FLOOR = 0.05   # (L_q - L_d) / (L_q + L_d) of the incremental inductances below which an injection
                        # estimator has little to lock on (yang2022's machine: 0.16 unloaded); at 0 it cannot tell the axis


def map_flux(mag: dict):
    """A flux map as a function (i_d, i_q) -> (psi_d, psi_q), bilinear as
    the plant reads it."""
    return lambda i_d, i_q: tuple(interp_tables(mag, ("psi_d", "psi_q"), i_d, i_q))


def incremental_inductances(flux, i_d, i_q, h_d: float, h_q: float | None = None):
    """The incremental inductance matrix d(psi_d, psi_q)/d(i_d, i_q) of
    flux(i_d, i_q) -> (psi_d, psi_q) at currents, by central differences of
    +-h_d along d and +-h_q (default h_d) along q: L_dd, L_dq (d psi_d / d
    i_q), L_qd (d psi_q / d i_d), L_qq, H."""
    h_q = h_d if h_q is None else h_q
    (a_d, a_q), (b_d, b_q) = flux(i_d + h_d, i_q), flux(i_d - h_d, i_q)
    (c_d, c_q), (e_d, e_q) = flux(i_d, i_q + h_q), flux(i_d, i_q - h_q)
    return (a_d - b_d) / (2 * h_d), (c_d - e_d) / (2 * h_q), (a_q - b_q) / (2 * h_d), (c_q - e_q) / (2 * h_q)


def incremental_saliency(mag: dict, i_d, i_q) -> np.ndarray:
    """(L_max - L_min) / (L_max + L_min) of the incremental inductance matrix
    d(psi_d, psi_q)/d(i_d, i_q) (its eigenvalues: what a carrier sees), as
    the plant's bilinear map has it, signed: negative where the q path has
    saturated below the d path (the axis an injection finds turns by 90 el.deg)."""
    h = 1e-3 * (mag["i_d"][1] - mag["i_d"][0])
    L_dd = (interp(mag, "psi_d", i_d + h, i_q) - interp(mag, "psi_d", i_d - h, i_q)) / (2 * h)
    L_qq = (interp(mag, "psi_q", i_d, i_q + h) - interp(mag, "psi_q", i_d, i_q - h)) / (2 * h)
    L_dq = 0.5 * ((interp(mag, "psi_d", i_d, i_q + h) - interp(mag, "psi_d", i_d, i_q - h))
                  + (interp(mag, "psi_q", i_d + h, i_q) - interp(mag, "psi_q", i_d - h, i_q))) / (2 * h)
    half = np.sqrt((0.5 * (L_qq - L_dd)) ** 2 + L_dq ** 2)
    return np.sign(L_qq - L_dd) * half / (0.5 * (L_qq + L_dd))


def saliency_warnings(mag: dict, i_max: float, phases: int, pole_pairs: int, T_rated: float, name: str) -> list[str]:
    """One line when the injection's saliency, along the map's MTPA locus,
    falls below SALIENCY_FLOOR before rated torque: the torque an injection
    estimator can carry at low speed on this machine."""
    T, d, q = mtpa_locus(mag, i_max, phases, pole_pairs)
    sal = incremental_saliency(mag, d, q)
    low = np.flatnonzero((sal < SALIENCY_FLOOR) & (T <= T_rated))
    if not low.size:
        return []
    k = low[0]
    return [f"injection: on {name}'s flux map the incremental saliency (L_q - L_d)/(L_q + L_d) falls from {sal[0]:.2f} at "
            f"no load to {sal[k]:.2f} at {T[k]:.3g} N m ({np.hypot(d[k], q[k]):.3g} A on the MTPA locus), below "
            f"{SALIENCY_FLOOR:g}: at low speed the injection cannot hold the rotor's angle under more torque than that "
            f"(rated {T_rated:g} N m)"]


def controller_values(mag: dict, i_max: float, i_rated: float, phases: int, pole_pairs: int) -> dict:
    """What the controller takes from a flux map: psi_f at zero current; the
    secant inductances at the MTPA point of rated current (the decoupling
    feeds w psi forward, exact there); the incremental inductances at half
    the rated current on the locus (what the injection's carrier sees where
    it runs, loaded); and the MTPA table."""
    T, d, q = mtpa_locus(mag, i_max, phases, pole_pairs)
    psi_f = table_at(mag, "psi_d", 0.0, 0.0)
    I = i_max * np.arange(MTPA_N) / (MTPA_N - 1)
    i_d_r, i_q_r = float(np.interp(i_rated, I, d)), float(np.interp(i_rated, I, q))
    L_d = (psi_f - table_at(mag, "psi_d", i_d_r, i_q_r)) / -i_d_r if i_d_r < -1e-9 * i_max else zero_current_values(mag)["L_d"]
    L_q = table_at(mag, "psi_q", i_d_r, i_q_r) / i_q_r
    i_d_h, i_q_h = float(np.interp(0.5 * i_rated, I, d)), float(np.interp(0.5 * i_rated, I, q))
    h_d, h_q = mag["i_d"][1] - mag["i_d"][0], mag["i_q"][1] - mag["i_q"][0]
    L_d_hf = (table_at(mag, "psi_d", i_d_h + h_d, i_q_h) - table_at(mag, "psi_d", i_d_h - h_d, i_q_h)) / (2 * h_d)
    L_q_hf = (table_at(mag, "psi_q", i_d_h, i_q_h + h_q) - table_at(mag, "psi_q", i_d_h, i_q_h - h_q)) / (2 * h_q)
    return {"psi_f": psi_f, "L_d": L_d, "L_q": L_q, "L_d_hf": L_d_hf, "L_q_hf": L_q_hf,
            "mtpa_T": T, "mtpa_i_d": d, "mtpa_i_q": q}


def controller_map(mag: dict, i_max: float, psi_f_scale: float = 1.0, L_d_scale: float = 1.0,
                   L_q_scale: float = 1.0) -> dict:
    """The machine's map on the controller's grid (csrc/control/fs_fluxmap.h):
    FS_FLUXMAP_ND d currents from -i_max to i_max / 2 (flux weakening's
    deepest, the polarity pulses' largest), FS_FLUXMAP_NQ q currents from 0
    to i_max (the map's mirror image below), the fluxes as 16-bit counts of
    psi_scale (the largest flux at 32,000 counts). A model error on purpose
    (the scenario's *_scale) scales the magnet's flux psi_d(0, 0) and the
    currents' parts of the fluxes apart."""
    i_d, i_q, D, Q = _controller_grid(i_max)
    psi_d, psi_q = interp(mag, "psi_d", D, Q), interp(mag, "psi_q", D, Q)
    if mag["i_q"][1] - mag["i_q"][0] > (1.0 + 1e-9) * (i_q[1] - i_q[0]):   # a map coarser along i_q than this grid
        psi_d, psi_q = _coarse_q(mag, D, Q, "psi_d"), _coarse_q(mag, D, Q, "psi_q")
    psi_f = table_at(mag, "psi_d", 0.0, 0.0)
    return _controller_table(i_d, i_q, psi_f_scale * psi_f + L_d_scale * (psi_d - psi_f), L_q_scale * psi_q)


def pchip_slopes(y: np.ndarray, h: float) -> np.ndarray:
    """The slopes of the monotone cubic (PCHIP: Fritsch and Carlson 1980, the
    interior and end slopes as scipy.interpolate.PchipInterpolator forms
    them) through points y on an even grid of step h."""
    y = np.asarray(y, float)
    delta = np.diff(y) / h
    d = np.zeros_like(y)
    same = delta[:-1] * delta[1:] > 0.0
    d[1:-1][same] = 2.0 / (1.0 / delta[:-1][same] + 1.0 / delta[1:][same])   # the harmonic mean (even steps)
    for end, d0, d1 in ((0, delta[0], delta[1]), (-1, delta[-1], delta[-2])):
        e = 0.5 * (3.0 * d0 - d1)   # the three-point end slope, kept within the shape
        if np.sign(e) != np.sign(d0):
            e = 0.0
        elif np.sign(d0) != np.sign(d1) and abs(e) > 3.0 * abs(d0):
            e = 3.0 * d0
        d[end] = e
    return d


def pchip(x0: float, h: float, y: np.ndarray, x) -> np.ndarray:
    """The monotone cubic through y at x0 + k h, at x (held at the ends)."""
    y = np.asarray(y, float)
    d = pchip_slopes(y, h)
    u = np.clip((np.asarray(x, float) - x0) / h, 0.0, y.size - 1.0)
    k = np.minimum(u.astype(int), y.size - 2)
    t = u - k
    h00, h10, h01, h11 = (2 * t ** 3 - 3 * t ** 2 + 1), (t ** 3 - 2 * t ** 2 + t), (-2 * t ** 3 + 3 * t ** 2), (t ** 3 - t ** 2)
    return h00 * y[k] + h10 * h * d[k] + h01 * y[k + 1] + h11 * h * d[k + 1]


def _coarse_q(mag: dict, D, Q, name: str) -> np.ndarray:
    """A flux (name) at the controller's grid (D, Q) from a map coarser along
    i_q than that grid: on the monotone cubic through each of the map's rows
    (pchip), linear between rows. Read bilinear, such a map's incremental
    inductances (what the back-EMF observer's transient and the flux
    weakening read off the controller's table) jump at each of its points
    and are flat between. On the 2004 Prius MG2 identified locked (the
    sweeps' i_max / 8, twice the controller's step; L_q falling from 6 to
    2.7 mH by 100 A), and on its true map read on that grid, B-REAL's
    reversal under 200 N m at -352 rpm swung the back-EMF observer's speed
    until the lock was lost, from 4 and 3 of 5 initial angles 0..0.1 el.deg
    apart; on the cubic, from none (3.9..5.5 el.deg, the true map's
    4.2..7.4). psi_d too: its change along i_q, the cross-saturation, read
    on the same curve as psi_q's (psi_q alone moved B-MAPID's zoo machine 0
    from 3.65 to 3.93 el.deg mean, both to 3.50, its true map's 2.85).
    A map as fine as the controller's grid (the catalog's) is read as it was."""
    e_d, e_q = np.asarray(mag["i_d"], float), np.asarray(mag["i_q"], float)
    h = e_q[1] - e_q[0]
    rows = np.array([pchip(e_q[0], h, r, Q[0]) for r in np.asarray(mag[name], float)])   # each row at Q's columns
    x = np.clip((D[:, 0] - e_d[0]) / (e_d[1] - e_d[0]), 0.0, e_d.size - 1.0)
    k = np.minimum(x.astype(int), e_d.size - 2)
    a = (x - k)[:, None]
    return (1 - a) * rows[k] + a * rows[k + 1]


def linear_controller_map(psi_f: float, L_d: float, L_q: float, i_max: float) -> dict:
    """The map a machine given by constants makes, on the controller's grid
    (controller_map): psi_d = psi_f + L_d i_d, psi_q = L_q i_q. The drive
    plans its flux weakening on it (fs_fwmap.h) as on a measured one."""
    i_d, i_q, D, Q = _controller_grid(i_max)
    return _controller_table(i_d, i_q, psi_f + L_d * D, L_q * Q)


def _controller_grid(i_max: float):
    i_d = np.linspace(-i_max, 0.5 * i_max, lib.FS_FLUXMAP_ND)
    i_q = np.linspace(0.0, i_max, lib.FS_FLUXMAP_NQ)
    return (i_d, i_q, *np.meshgrid(i_d, i_q, indexing="ij"))


def _controller_table(i_d, i_q, psi_d, psi_q) -> dict:
    scale = float(max(np.abs(psi_d).max(), np.abs(psi_q).max())) / 32000.0
    return {"di_d": float(i_d[1] - i_d[0]), "i_d0": float(i_d[0]), "di_q": float(i_q[1] - i_q[0]), "psi_scale": scale,
            "psi_d": np.rint(psi_d / scale).astype(int).ravel().tolist(),
            "psi_q": np.rint(psi_q / scale).astype(int).ravel().tolist()}
