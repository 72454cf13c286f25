"""The machine's envelope: the most torque it makes at each speed within the
current limit and the voltage the converter gives, in steady state; the
currents that make it (MTPA, flux weakening on the voltage limit, MTPV);
the optimum current for any torque and speed; and what follows from them:
base speed, characteristic current, top speed.

The magnetics are the plant's: a flux map as model.fluxmap.interp reads it
(bilinear on its grid), the linear and algebraic models as
csrc/plant/fs_magnetic.c computes them (fs_mag_flux, through the C core),
tabulated once on a fine grid over the second quadrant of the current disc
and then read as a map (bilinear interpolation reproduces a linear model
exactly; the algebraic model to about 1e-5 of its flux on TABLE_N points).

The limits. Current: |i| <= i_max. Voltage: in steady state the rotor
frame's u = R_s i + j w_e psi(i), and we hold
    |j w_e psi(i) + R_s i| <= u_lin,   u_lin = u_dc / sqrt3 (rules.u_linear),
the modulator's linear limit less the resistive drop R_s i, taken as the
vector it is (in phase with the current). Why: that is the steady state
the drive's current loops reach with linear modulation, exactly; its
magnitude instead (w_e |psi| <= u_lin - R_s |i|, the textbook ellipse
psi_max = (u_lin - R_s i_max) / w_e) is low by R_s |i| (1 - cos) of the
angle between i and u: 2 to 4 % of the torque near base speed on the
trial's Prius, where the trial's own envelope (this one) is what the
drive was compared with. Saturation deforms the ellipse where psi(i) is a
map. Braking needs less voltage than motoring (the drop opposes the EMF):
the envelope is the motoring one, which a braking point meets too. The
drive's minimum-phase-error over-modulation (fs_svpwm.h) gives up to
OVERMODULATION = 1.049 x u_lin in the fundamental (+4.9 %) beyond this,
where its flux weakening lets the voltage reference leave the hexagon's
inscribed circle.

How the optimum is found, at each speed: along each current direction
(angle gamma from +d, 90..180 deg for motoring; braking is the mirror
image) the torque rises with |i|, so the best current on that ray is the
largest |i| within both limits (found on RAY_N magnitudes, then by
bisection to the limit's edge); the best direction is located on a scan
of ANGLE_N angles and refined by golden section. That covers all three
regions without knowing which one applies: MTPA (|i| = i_max, the voltage
slack: below base speed), flux weakening (|i| = i_max on the voltage
limit) and MTPV (the voltage limit alone, |i| < i_max: where the
characteristic current is inside the current limit).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._core import ffi, lib
from ..model.errors import ConfigError
from ..model.fluxmap import interp, interp_tables
from ..model.machines import Machine
from ..model.units import rad_s_to_rpm
from .memo import Memo
from .rules import u_linear

# the current limit as a scenario's reader finds it: the scenario's, else the machine file's bench
I_MAX_FIELD = "controller.i_max (machine.bench.i_max where the scenario leaves it)"

# the fundamental of minimum-phase-error over-modulation at its limit, over u_dc/sqrt3: the reference's
# direction kept on the hexagon's boundary all round, (6/pi) ln(sqrt3) (fs_svpwm.h)
OVERMODULATION = 6.0 / math.pi * math.log(math.sqrt(3.0))
ANGLE_N = 721        # current angles of the scan, 90..180 deg: 0.125 deg apart (the golden section refines the best)
RAY_N = 129          # current magnitudes per ray, 0..i_max: where the ray leaves the limits, refined by bisection
TABLE_N = 257        # a linear or algebraic model tabulated per axis over 0..i_max (and a margin): the plant's C model
BISECTIONS = 64      # halvings of a bracket where speed does not matter (a scalar's)
ROOT_STEPS = 14      # false-position (Illinois) steps on a bracket one grid step wide: superlinear, to 1e-12 of i_max
GOLDEN = 40          # golden-section steps on a 2- or 4-angle bracket (0.5 deg at most): 0.5 deg x 0.618^40 = 4e-11 rad
SPEEDS_N = 241       # speeds of the envelope's arrays, 0..the end (base speed and the MTPV onset added)
TOP_SHOWN = 0.1      # an infinite top speed: the arrays run to where the torque falls to this share of standstill's
REGIONS = ("MTPA", "FW", "MTPV")
LIMITS = {"MTPA": "current", "FW": "current+voltage", "MTPV": "voltage (MTPV)"}   # the limits active in each region


@dataclass(frozen=True)
class Envelope:
    """A machine's envelope at a link and a current limit (SI: rad/s
    mechanical, N m, W, A). Arrays are per speed, rising from 0; region[k]
    is "MTPA" (current limit), "FW" (current and voltage) or "MTPV"
    (voltage, |i| < i_max). The torque is the motoring one; braking's is
    its negative (the voltage limit depends on |i| only)."""
    machine: str
    u_dc: float
    i_max: float
    u_max: float              # V peak phase: the modulator's linear limit the voltage is held within
    w_m: np.ndarray
    T: np.ndarray
    P: np.ndarray
    i_d: np.ndarray
    i_q: np.ndarray
    region: np.ndarray
    w_base: float             # rad/s: the highest speed at i_max on MTPA
    T_base: float             # N m: the MTPA torque at i_max (the envelope below base speed)
    i_ch: float               # A: the characteristic current, -i_ch cancels psi_d at i_q = 0
    i_ch_note: str            # how it was found (the map's range, an extrapolation)
    w_top: float              # rad/s: the no-load voltage-limited top speed; inf where i_ch <= i_max
    w_mtpv: float | None      # rad/s: where MTPV takes over from flux weakening; None without MTPV
    mtpa: dict = field(default_factory=dict)   # the MTPA locus: T, i_d, i_q, w_m (the speed each point reaches)

    @property
    def top_finite(self) -> bool:
        return math.isfinite(self.w_top)


def plant_mag(m: Machine):
    """The plant's magnetic model of m (linear or algebraic, fs_magnetic.h)
    as an initialised fs_mag (its config kept alive with it)."""
    mag = m.magnetic
    if mag["model"] not in ("linear", "algebraic"):
        raise ValueError(f"plant_mag: {mag['model']} (a flux map is read with model.fluxmap.interp)")
    cfg = ffi.new("fs_mag_config *")
    cfg.kind = lib.FS_MAG_ALGEBRAIC if mag["model"] == "algebraic" else lib.FS_MAG_LINEAR
    cfg.L_d, cfg.L_q, cfg.psi_f = m.L_d, m.L_q, m.psi_f
    if mag["model"] == "algebraic":
        for k in ("a_dd", "a_qq", "a_dq", "S", "T", "U", "V"):
            setattr(cfg, k, mag[k])
    st = ffi.new("fs_mag *")
    status = lib.fs_mag_init(st, cfg)
    if status != lib.FS_OK:
        raise ConfigError("machine.magnetic", mag["model"], f"the plant's magnetic model refuses it (status {status})")
    return st


def plant_flux(st, i_d, i_q) -> tuple[np.ndarray, np.ndarray]:
    """psi_d, psi_q of a plant_mag model at currents (arrays of one shape),
    point by point through fs_mag_flux (fs_mag_flux_n: one call)."""
    i_d, i_q = np.broadcast_arrays(np.asarray(i_d, float), np.asarray(i_q, float))
    d, q = np.ascontiguousarray(i_d.ravel()), np.ascontiguousarray(i_q.ravel())
    out_d, out_q = np.empty(d.size), np.empty(d.size)
    lib.fs_mag_flux_n(st, ffi.from_buffer("double[]", d), ffi.from_buffer("double[]", q), d.size,
                      ffi.from_buffer("double[]", out_d), ffi.from_buffer("double[]", out_q))
    return out_d.reshape(i_d.shape), out_q.reshape(i_d.shape)


def flux_table(m: Machine, i_max: float, points: int = TABLE_N) -> dict:
    """The machine's fluxes over the second quadrant of the current disc as
    a map (model.fluxmap's layout): a flux map as it is (it must reach
    -i_max on d and +i_max on q), the plant's C model tabulated."""
    mag = m.magnetic
    if mag["model"] == "fluxmap":
        i_d, i_q = mag["i_d"], mag["i_q"]
        if i_d[0] > -i_max * (1 - 1e-9) or i_d[-1] < 0 or i_q[-1] < i_max * (1 - 1e-9) or i_q[0] > 0:
            raise ConfigError(I_MAX_FIELD, i_max,
                              f"must be within {m.name}'s flux map for its envelope: the map spans i_d "
                              f"{i_d[0]:g}..{i_d[-1]:g} A and i_q {i_q[0]:g}..{i_q[-1]:g} A, the envelope needs "
                              f"i_d -i_max..0 and i_q 0..i_max")
        return {k: np.asarray(mag[k], float) for k in ("i_d", "i_q", "psi_d", "psi_q")}
    n = points if mag["model"] == "algebraic" else 2   # bilinear is exact on a linear model from its corners
    h = i_max / (n - 1)
    margin = 8 if n > 2 else 1   # grid steps beyond the quadrant's axes: the rays at 90 and 180 deg stay inside
    e_d = -i_max + h * np.arange(n + margin)
    e_q = h * np.arange(-margin, n)
    D, Q = np.meshgrid(e_d, e_q, indexing="ij")
    psi_d, psi_q = plant_flux(plant_mag(m), D, Q)
    return {"model": "fluxmap", "i_d": e_d, "i_q": e_q, "psi_d": psi_d, "psi_q": psi_q}


def _root(f, lo: np.ndarray, hi: np.ndarray, steps: int = ROOT_STEPS) -> tuple[np.ndarray, np.ndarray]:
    """Elementwise bracket [lo, hi] of a root of f (f(lo) <= 0 < f(hi);
    arrays), narrowed by false position with the Illinois rule (the end
    kept twice has its value halved): lo, on the f <= 0 side, and the end
    nearer the root by |f|."""
    f_lo, f_hi = f(lo), f(hi)
    kept = np.zeros(lo.shape, int)   # +1: lo moved last, -1: hi moved last
    for _ in range(steps):
        span = f_hi - f_lo
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(span > 0, lo - f_lo * (hi - lo) / span, 0.5 * (lo + hi))
        x = np.clip(x, lo, hi)
        fx = f(x)
        inside = fx <= 0.0
        f_hi = np.where(inside & (kept == 1), 0.5 * f_hi, f_hi)     # lo moved twice: halve the far end's value
        f_lo = np.where(~inside & (kept == -1), 0.5 * f_lo, f_lo)
        lo, f_lo = np.where(inside, x, lo), np.where(inside, fx, f_lo)
        hi, f_hi = np.where(inside, hi, x), np.where(inside, f_hi, fx)
        kept = np.where(inside, 1, -1)
    return lo, np.where(-f_lo <= f_hi, lo, hi)


def _golden_max(f, a: np.ndarray, b: np.ndarray, steps: int = GOLDEN) -> tuple[np.ndarray, np.ndarray]:
    """Elementwise maximum of f on [a, b] by golden section (f unimodal
    there; it takes and returns arrays of a's shape): the argument and value."""
    r = 0.5 * (math.sqrt(5.0) - 1.0)
    x1, x2 = b - r * (b - a), a + r * (b - a)
    f1, f2 = f(x1), f(x2)
    for _ in range(steps):
        right = f2 > f1          # the maximum lies in [x1, b]
        a = np.where(right, x1, a)
        b = np.where(right, b, x2)
        x_new = np.where(right, a + r * (b - a), b - r * (b - a))
        f_new = f(x_new)
        x1, f1, x2, f2 = (np.where(right, x2, x_new), np.where(right, f2, f_new),
                          np.where(right, x_new, x1), np.where(right, f_new, f1))
    best = f1 >= f2
    return np.where(best, x1, x2), np.where(best, f1, f2)


class Limits:
    """A machine within its current and voltage limits: fluxes, torque and
    the voltage limit's excess at any current, and the searches on them.
    coarse: a quarter of the scan's angles and magnitudes (and of an
    algebraic model's table): scan_torque's lower bound for a quick check."""

    def __init__(self, m: Machine, u_dc: float, i_max: float, u_max: float | None = None, coarse: bool = False):
        if not (math.isfinite(u_dc) and u_dc > 0):
            raise ConfigError("u_dc", u_dc, "must be a finite voltage > 0 V")
        if not (math.isfinite(i_max) and i_max > 0):
            raise ConfigError("i_max", i_max, "must be a finite current > 0 A")
        self.m, self.u_dc, self.i_max = m, float(u_dc), float(i_max)
        self.u = u_linear(u_dc, m.phases) if u_max is None else float(u_max)
        if not (math.isfinite(self.u) and self.u > 0):
            raise ConfigError("u_max", u_max, "must be a finite voltage > 0 V")
        self.R, self.p, self.k = m.R_s, m.pole_pairs, 0.5 * m.phases * m.pole_pairs
        if not self.R * i_max < self.u:
            raise ConfigError(I_MAX_FIELD, i_max, f"must be below u_lin / R_s = {self.u / self.R:.4g} A: the resistive drop "
                              f"R_s i_max = {self.R * i_max:.4g} V would take all of the {self.u:.4g} V the "
                              f"converter gives")
        cut = 4 if coarse else 1
        self.mag = flux_table(m, i_max, (TABLE_N - 1) // cut + 1)
        self.gam = np.linspace(0.5 * math.pi, math.pi, (ANGLE_N - 1) // cut + 1)
        self.rad = np.linspace(0.0, i_max, (RAY_N - 1) // cut + 1)
        # the scan: every (magnitude, angle) point with the speed at which it reaches the voltage limit
        I, G = np.meshgrid(self.rad, self.gam, indexing="ij")
        d, q = I * np.cos(G), I * np.sin(G)
        T, w = self.torque(d, q), self.w_limit(d, q)
        order = np.argsort(-w.ravel(), kind="stable")
        self._w_desc = w.ravel()[order]
        T_sorted = T.ravel()[order]
        run = np.maximum.accumulate(T_sorted)
        self._best = order[np.maximum.accumulate(np.where(T_sorted >= run, np.arange(T_sorted.size), 0))]
        self._scan_T, self._scan_w = T, w
        self._suffix_w = np.maximum.accumulate(w[::-1], axis=0)[::-1]   # per ray, the fastest point at or beyond each magnitude
        self._locus = None

    # --- the machine at a current --------------------------------------------------------------
    def flux(self, i_d, i_q):
        psi_d, psi_q = interp_tables(self.mag, ("psi_d", "psi_q"), i_d, i_q)
        return psi_d, psi_q

    def flux_anywhere(self, i_d: float, i_q: float) -> tuple[float, float]:
        """The fluxes at one current anywhere (not only in the envelope's
        quadrant): the map over its range, the plant's C model."""
        mag = self.m.magnetic
        if mag["model"] == "fluxmap":
            return float(interp(mag, "psi_d", i_d, i_q)), float(interp(mag, "psi_q", i_d, i_q))
        psi_d, psi_q = plant_flux(plant_mag(self.m), i_d, i_q)
        return float(psi_d), float(psi_q)

    def torque(self, i_d, i_q):
        psi_d, psi_q = self.flux(i_d, i_q)
        return self.k * (psi_d * i_q - psi_q * i_d)

    def excess(self, i_d, i_q, w_e):
        """|j w_e psi + R_s i| - u_lin: the voltage limit's excess (<= 0 within it)."""
        psi_d, psi_q = self.flux(i_d, i_q)
        return np.hypot(self.R * i_d - w_e * psi_q, self.R * i_q + w_e * psi_d) - self.u

    def at_limit(self, i_d, i_q):
        """Whether currents are on the current limit (to 1e-9 of it)."""
        return np.hypot(i_d, i_q) >= self.i_max * (1 - 1e-9)

    def w_limit(self, i_d, i_q):
        """The electrical speed at which a current reaches the voltage limit:
        the root w >= 0 of |j w psi + R_s i| = u_lin, a w^2 + 2 b w + c = 0
        (inf where its flux is 0; -1 where the drop alone exceeds the limit)."""
        psi_d, psi_q = self.flux(i_d, i_q)
        a = psi_d ** 2 + psi_q ** 2
        b = self.R * (i_q * psi_d - i_d * psi_q)      # R_s T / k: >= 0 motoring
        c = self.R ** 2 * (i_d ** 2 + i_q ** 2) - self.u ** 2
        root = np.sqrt(np.maximum(b * b - a * c, 0.0))
        with np.errstate(divide="ignore", invalid="ignore"):   # the form without cancellation for either sign of b
            w = np.where(b >= 0, -c / (b + root), (root - b) / a)
        return np.where(c < 0, np.where(np.isnan(w), np.inf, w), -1.0)

    # --- searches ------------------------------------------------------------------------------
    def ray_limit(self, gam, w_e):
        """The largest |i| <= i_max on each ray (angle gam) within the voltage
        limit at electrical speed w_e (arrays of one shape); nan where none."""
        c, s = np.cos(gam)[..., None], np.sin(gam)[..., None]
        w = np.asarray(w_e, float)[..., None]
        ok = self.excess(self.rad * c, self.rad * s, w) <= 0.0
        n = self.rad.size
        last = n - 1 - np.argmax(ok[..., ::-1], axis=-1)
        none = ~ok.any(axis=-1)
        lo, hi = self.rad[last], self.rad[np.minimum(last + 1, n - 1)]
        c, s, w = c[..., 0], s[..., 0], w[..., 0]
        lo, _ = _root(lambda x: self.excess(x * c, x * s, w), lo, hi)
        return np.where(none, np.nan, np.where(last == n - 1, self.i_max, lo))

    def _ray_torque(self, gam, w_e):
        I = self.ray_limit(gam, w_e)
        none = np.isnan(I)
        I = np.where(none, 0.0, I)
        return np.where(none, -np.inf, self.torque(I * np.cos(gam), I * np.sin(gam)))

    def _scan_count(self, w_e):
        return np.searchsorted(-self._w_desc, -np.asarray(w_e, float), side="right")   # scan points that reach w_e

    def scan_torque(self, w_e) -> np.ndarray:
        """The most torque of the scan's currents within both limits at
        electrical speeds w_e: a lower bound of the envelope's (-inf where
        none reaches w_e)."""
        count = self._scan_count(np.atleast_1d(w_e))
        T = self._scan_T.ravel()[self._best[np.maximum(count - 1, 0)]]
        return np.where(count > 0, T, -np.inf)

    def best(self, w_e) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The most torque within both limits at electrical speeds w_e (an
        array): torque, i_d, i_q (nan beyond the top speed).

        Per speed, the scan bounds each ray's best torque: at least that of
        its last magnitude within the limits, at most that of the next one
        (the torque rises along a ray); the rays whose bound reaches the
        best ray's lower bound are searched to the limit's edge, and the
        best of them is refined by golden section between its neighbours.
        (Where the torque along the limit is flat, near the MTPV onset, the
        best scanned point may lie many rays from the optimum.)"""
        w_e = np.atleast_1d(np.asarray(w_e, float))
        count = self._scan_count(w_e)
        n_a, n_r = self.gam.size, self.rad.size
        last = np.stack([np.searchsorted(-self._suffix_w[:, j], -w_e, side="right") for j in range(n_a)], axis=1) - 1
        T_lo = np.where(last >= 0, self._scan_T[np.maximum(last, 0), np.arange(n_a)], -np.inf)
        T_hi = np.where(last >= 0, self._scan_T[np.minimum(last + 1, n_r - 1), np.arange(n_a)], -np.inf)
        s, j = np.nonzero((T_hi >= T_lo.max(axis=1, keepdims=True)) & (count > 0)[:, None])
        h = self._ray_torque(self.gam[j], w_e[s])
        pick = np.lexsort((h, s))   # by speed, then torque: the last of each speed is its best ray
        tail = np.r_[s[pick][1:] != s[pick][:-1], True][:s.size]
        j_best = np.zeros(w_e.shape, int)
        j_best[s[pick][tail]] = j[pick][tail]
        a = self.gam[np.maximum(j_best - 1, 0)]
        b = self.gam[np.minimum(j_best + 1, n_a - 1)]
        g, T = _golden_max(lambda x: self._ray_torque(x, w_e), a, b)
        g0 = self.gam[j_best]   # the best ray itself: kept where the section found no better
        T0 = self._ray_torque(g0, w_e)
        g, T = np.where(T0 > T, g0, g), np.maximum(T, T0)
        I = self.ray_limit(g, w_e)
        none = (count == 0) | ~np.isfinite(T)
        nan = np.full(w_e.shape, np.nan)
        I = np.where(none, np.nan, I)
        return np.where(none, nan, T), I * np.cos(g), I * np.sin(g)

    def mtpa(self, I) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The MTPA point at current magnitudes I (an array): the angle of
        most torque, scanned then refined; torque, i_d, i_q."""
        I = np.atleast_1d(np.asarray(I, float))
        T = self.torque(np.outer(I, np.cos(self.gam)), np.outer(I, np.sin(self.gam)))
        j = np.argmax(T, axis=1)
        a = self.gam[np.maximum(j - 2, 0)]
        b = self.gam[np.minimum(j + 2, self.gam.size - 1)]
        g, T = _golden_max(lambda x: self.torque(I * np.cos(x), I * np.sin(x)), a, b)
        return T, I * np.cos(g), I * np.sin(g)

    def w_top(self) -> tuple[float, float]:
        """The highest electrical speed at which a current within i_max
        meets the voltage limit (the torque falls to zero there) and its
        i_d: on the d axis, where q current only adds flux (the scan of
        the quadrant is the check: the larger of the two is taken)."""
        I = np.linspace(0.0, self.i_max, 4 * RAY_N)
        w = self.w_limit(-I, 0.0 * I)
        k = int(np.argmax(w))
        a, b = I[max(k - 1, 0)], I[min(k + 1, I.size - 1)]
        x, w_d = _golden_max(lambda x: self.w_limit(-x, 0.0 * x), np.array([a]), np.array([b]))
        w_scan = float(np.max(self._scan_w))
        if w_scan > w_d[0]:
            flat = int(np.argmax(self._scan_w))
            r, j = divmod(flat, self.gam.size)
            return w_scan, float(self.rad[r] * math.cos(self.gam[j]))
        return float(w_d[0]), -float(x[0])

    def characteristic_current(self) -> tuple[float, str]:
        """The i_d magnitude that cancels psi_d at i_q = 0, and how it was found."""
        m = self.m
        if m.magnetic["model"] == "fluxmap":
            e_d = np.asarray(m.magnetic["i_d"], float)
            col = interp(m.magnetic, "psi_d", e_d, 0.0 * e_d)
            neg = np.flatnonzero((col[:-1] <= 0.0) & (col[1:] > 0.0))
            if neg.size:
                k = neg[-1]   # the crossing nearest zero current; bilinear: linear within the cell
                i = e_d[k] + (e_d[k + 1] - e_d[k]) * (-col[k]) / (col[k + 1] - col[k])
                return -float(i), "where the map's psi_d(i_d, 0) crosses zero"
            slope = (col[1] - col[0]) / (e_d[1] - e_d[0])
            if col[0] > 0 and slope > 0:
                i = e_d[0] - col[0] / slope
                return -float(i), (f"beyond the map's {e_d[0]:g} A (psi_d {col[0]:.4g} Wb there): extrapolated "
                                   "along its last step")
            return math.inf, f"psi_d(i_d, 0) does not fall to zero on the map (down to {e_d[0]:g} A)"
        st = plant_mag(m)

        def psi_d(i):
            return float(plant_flux(st, i, 0.0)[0])
        if psi_d(0.0) <= 0.0:
            return 0.0, "no magnet flux"
        lo = -max(m.psi_f / m.L_d, 1e-12)   # the linear model's, expanded until psi_d < 0
        for _ in range(200):
            if psi_d(lo) < 0.0:
                break
            lo *= 2.0
        else:
            return math.inf, "psi_d(i_d, 0) does not fall to zero"
        hi = 0.0
        for _ in range(BISECTIONS + 40):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if psi_d(mid) < 0.0 else (lo, mid)
        return -0.5 * (lo + hi), ("psi_f / L_d" if m.magnetic["model"] == "linear" else
                                  "where the plant's psi_d(i_d, 0) crosses zero (fs_mag_flux)")

    def mtpa_current(self, T: float) -> tuple[float, float] | None:
        """The least current making torque T >= 0 (on MTPA): i_d, i_q; None
        beyond the MTPA torque at i_max."""
        I = np.linspace(0.0, self.i_max, RAY_N)
        T_k, _, _ = self.mtpa(I)
        if T > T_k[-1]:
            return None
        k = max(int(np.searchsorted(T_k, T)), 1)   # T_k rises with I
        _, x = _root(lambda x: self.mtpa(x)[0] - T, np.array([I[k - 1]]), np.array([I[k]]), steps=3 * ROOT_STEPS)
        _, d, q = self.mtpa(x)
        return float(d[0]), float(q[0])

    def mtpa_locus(self) -> dict:
        """The MTPA locus at the scan's magnitudes: T, i_d, i_q and w_e, the
        electrical speed at which each point meets the voltage limit."""
        if self._locus is None:
            T, d, q = self.mtpa(self.rad)
            self._locus = {"T": T, "i_d": d, "i_q": q, "w_e": self.w_limit(d, q)}
        return self._locus

    def mtpa_speed(self, T: float) -> float:
        """The highest electrical speed at which the MTPA current for torque
        T meets the voltage limit (where a drive without flux weakening
        stops; along the locus, interpolated between its RAY_N points:
        within about 1e-4); 0 beyond the MTPA torque at i_max."""
        a = self.mtpa_locus()
        if abs(T) > a["T"][-1]:
            return 0.0
        return float(np.interp(abs(T), a["T"], a["w_e"]))

    def optimum_current(self, T: float, w_e: float) -> tuple[float, float, str] | None:
        """The least current making torque T (>= 0) at electrical speed w_e
        within both limits: (i_d, i_q, region), region "MTPA" where the
        MTPA point meets the voltage limit, else "FW" (on the voltage
        limit, from the MTPA point along the constant-torque curve towards
        the d axis); None where T lies outside the envelope at w_e."""
        if T <= 0.0:
            return 0.0, 0.0, "MTPA"
        i = self.mtpa_current(T)
        if i is None:
            return None
        if self.excess(*i, w_e) <= 0.0:
            return i[0], i[1], "MTPA"
        T_max, d_max, q_max = (float(x[0]) for x in self.best(np.array([w_e])))
        if not T <= T_max:
            return None
        gam = np.linspace(math.atan2(i[1], i[0]), math.pi, ANGLE_N)
        I_T = self._ray_current(T, gam)
        ok = np.isfinite(I_T) & (self.excess(I_T * np.cos(gam), I_T * np.sin(gam), w_e) <= 0.0)
        if not ok.any():   # T within the angle scan's resolution of the envelope's: its current
            return d_max, q_max, "FW"
        j = max(int(np.argmax(ok)), 1)   # the first angle whose current meets the voltage limit
        a, b = gam[j - 1], gam[j]
        for _ in range(BISECTIONS):
            mid = 0.5 * (a + b)
            I_m = self._ray_current(T, np.array([mid]))[0]
            inside = np.isfinite(I_m) and self.excess(I_m * math.cos(mid), I_m * math.sin(mid), w_e) <= 0.0
            a, b = (a, mid) if inside else (mid, b)
        I_b = self._ray_current(T, np.array([b]))[0]
        return float(I_b * math.cos(b)), float(I_b * math.sin(b)), "FW"

    def _ray_current(self, T: float, gam: np.ndarray) -> np.ndarray:
        """|i| on each ray where the torque reaches T (inf where i_max does not)."""
        c, s = np.cos(gam), np.sin(gam)
        reach = self.torque(self.i_max * c, self.i_max * s) >= T
        _, x = _root(lambda x: self.torque(x * c, x * s) - T, np.zeros(gam.shape), np.full(gam.shape, self.i_max),
                     steps=3 * ROOT_STEPS)
        return np.where(reach, x, np.inf)


# Limits kept per machine and limits (design.memo): a campaign's scenarios of one machine check their
# references against the same Limits, whose MTPA locus is then found once. Each holds about 5 MB (the scan).
_LIMITS = Memo(Limits, copies=False, keep=8)


def limits(m: Machine, u_dc: float, i_max: float, u_max: float | None = None, coarse: bool = False) -> Limits:
    """Limits(m, u_dc, i_max, u_max, coarse), made once per machine and
    limits (only read: its searches do not change it)."""
    return _LIMITS(m, u_dc, i_max, u_max, coarse)


def envelope(m: Machine, u_dc: float, i_max: float, n: int = SPEEDS_N, u_max: float | None = None,
             w_end: float | None = None) -> Envelope:
    """The envelope of machine m (designed: design.machine) on a link of
    u_dc and a current limit i_max (A peak), at n speeds from standstill to
    the top speed (finite), or to where the torque falls to TOP_SHOWN of
    its standstill value (infinite top speed; w_end, mechanical rad/s,
    instead), with the base speed, the MTPV onset and table_speeds among
    them. u_max: the voltage limit (V peak phase) where it is not the
    modulator's linear limit of u_dc (a matrix converter's)."""
    return _ENVELOPES(m, u_dc, i_max, n, u_max, w_end)


def _envelope(m: Machine, u_dc: float, i_max: float, n: int, u_max: float | None, w_end: float | None) -> Envelope:
    lim = limits(m, u_dc, i_max, u_max)
    p = lim.p
    T_base, d0, q0 = (float(x[0]) for x in lim.mtpa(i_max))
    w_base_e = float(lim.w_limit(d0, q0))
    i_ch, note = lim.characteristic_current()
    inside = i_ch <= i_max and lim.R * i_ch < lim.u
    w_top_e, i_d_top = (math.inf, math.nan) if inside else lim.w_top()
    if inside:
        w_end_e = p * w_end if w_end else _torque_falls(lim, TOP_SHOWN * T_base, w_base_e)
    else:
        w_end_e = w_top_e
    w = np.linspace(0.0, w_end_e, n)
    T, i_d, i_q = lim.best(w)
    w_mtpv_e = _mtpv_onset(lim, w, i_d, i_q, w_base_e)
    extra = np.r_[w_base_e, [] if w_mtpv_e is None else [w_mtpv_e], p * table_speeds(w_end_e / p)[:-1]]
    extra = extra[np.min(np.abs(extra[:, None] - w[None, :]), axis=1) > 1e-12 * w_end_e]   # not twice
    T_x, d_x, q_x = lim.best(extra)
    order = np.argsort(np.r_[w, extra], kind="stable")
    w, T, i_d, i_q = (np.r_[a, b][order] for a, b in ((w, extra), (T, T_x), (i_d, d_x), (i_q, q_x)))
    if not inside:   # at the top speed itself the torque is zero, on the d axis
        T[-1], i_d[-1], i_q[-1] = 0.0, i_d_top, 0.0
    region = np.where(w <= w_base_e, "MTPA", np.where(lim.at_limit(i_d, i_q), "FW", "MTPV"))
    a = lim.mtpa_locus()
    return Envelope(
        machine=m.name, u_dc=float(u_dc), i_max=float(i_max), u_max=lim.u,
        w_m=w / p, T=T, P=T * w / p, i_d=i_d, i_q=i_q, region=region,
        w_base=w_base_e / p, T_base=T_base, i_ch=float(i_ch), i_ch_note=note,
        w_top=w_top_e / p, w_mtpv=None if w_mtpv_e is None else w_mtpv_e / p,
        mtpa={"T": a["T"], "i_d": a["i_d"], "i_q": a["i_q"], "w_m": a["w_e"] / p})


SECTIONS = 16        # speeds per round of a multisection (one vectorised search per round)
ROUNDS = 6           # rounds: the bracket shrinks by SECTIONS^ROUNDS = 1.7e7


_ENVELOPES = Memo(_envelope, copies=True, keep=16)   # B-REAL's and B-MAPID's scenarios read their machine's


def _crossing(inside, lo: float, hi: float, rounds: int = ROUNDS) -> float:
    """The speed between lo (inside(lo) true) and hi (false) where the
    predicate inside(speeds) -> bools turns false, by multisection."""
    for _ in range(rounds):
        x = np.linspace(lo, hi, SECTIONS + 1)
        ok = inside(x)
        ok[0], ok[-1] = True, False
        k = int(np.argmin(ok))   # the first false
        lo, hi = x[k - 1], x[k]
    return hi


NICE_STEPS = (1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0)   # x 10^k rpm: a table's speed step
TABLE_ROWS = 12


def table_speeds(w_end: float, rows: int = TABLE_ROWS) -> np.ndarray:
    """About `rows` round speeds (mechanical rad/s) from standstill to
    w_end: 0, s, 2 s, ... in rpm with s the least of NICE_STEPS x 10^k
    that takes at most rows - 1 steps to w_end (and w_end itself)."""
    rpm_end = w_end * 60.0 / (2.0 * math.pi)
    if not (math.isfinite(rpm_end) and rpm_end > 0):
        return np.zeros(1)
    want = rpm_end / (rows - 1)
    e = 10.0 ** math.floor(math.log10(want))
    step = next((k * e for k in NICE_STEPS + (10.0,) if k * e >= want * (1 - 1e-12)), 10.0 * e)
    rpm = np.arange(0.0, rpm_end * (1 + 1e-12), step)
    rpm = rpm[rpm < rpm_end * (1 - 1e-9)]
    return np.r_[rpm, rpm_end] * (2.0 * math.pi / 60.0)


def _torque_falls(lim: Limits, T_low: float, w_from: float) -> float:
    """The electrical speed above w_from at which the envelope's torque
    falls to T_low (it falls with speed)."""
    def above(w):   # nan: no current reaches w (beyond the scan's resolution): fallen
        T = lim.best(w)[0]
        return np.isfinite(T) & (T > T_low)
    w = w_from * 2.0 ** np.arange(25)   # up to 1.7e7 x base speed
    k = int(np.argmin(above(w)))
    return _crossing(above, w[k - 1] if k else w_from, w[k], rounds=2)   # where the table ends: 1/256 of the bracket


def _mtpv_onset(lim: Limits, w, i_d, i_q, w_base_e: float) -> float | None:
    """The electrical speed where the optimum leaves the current limit
    (MTPV), between the grid's speeds w (optimum i_d, i_q); None where it
    never does."""
    inner = (w > w_base_e) & np.isfinite(i_d) & ~lim.at_limit(i_d, i_q)   # nan: beyond (or at) the top speed
    if not inner.any():
        return None
    k = int(np.argmax(inner))
    return _crossing(lambda x: lim.at_limit(*lim.best(x)[1:]), w[k - 1], w[k])


def torque_at(env: Envelope, w_m):
    """The envelope's torque at mechanical speeds w_m (rad/s, either sign;
    a number or an array): interpolated between its speeds (within about
    1e-4 of the search at the speed itself); zero beyond a finite top
    speed. Beyond the last speed of an infinite one it is not known:
    ValueError (envelope(..., w_end=) reaches further)."""
    w = np.abs(np.asarray(w_m, float))
    end = env.w_m[-1]
    if not env.top_finite and np.any(w > end * (1 + 1e-12)):
        raise ValueError(f"torque_at: {rad_s_to_rpm(float(np.max(w))):.5g} rpm is beyond {env.machine}'s envelope, computed "
                         f"to {rad_s_to_rpm(end):.5g} rpm (its top speed is infinite): envelope(..., w_end=) reaches further")
    T = np.where(w > env.w_top, 0.0, np.interp(w, env.w_m, env.T))
    return float(T) if np.ndim(w_m) == 0 else T
