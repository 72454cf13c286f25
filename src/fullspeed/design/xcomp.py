"""A cross-saturation table (injection.xcomp): designed from the machine's
magnetics where the scenario gives none (designed_table), and checked
against the scenario that uses it: a measured table holds the estimator's
own bias at the settings it was measured with (workflows.calibrate records
them), so a scenario with a setting that moves that bias is refused, and
one with another machine or carrier warned, one line naming the field."""
from __future__ import annotations

import math

import numpy as np

from ..model.errors import ConfigError
from .envelope import flux_table
from .memo import Memo
from .magnetics import SALIENCY_FLOOR, incremental_inductances, incremental_saliency, map_flux, mtpa_locus
from .rules import Value


# The settings a table records, each with the field that sets it; those whose
# change moves the estimator's own bias by a known amount refuse the table,
# the rest warn (a different machine or carrier: a table to check, perhaps
# still the right one).
SETTING_FIELDS = {"estimator": "controller.angle", "leak": "injection.leak", "sequence": "injection.sequence",
                  "machine": "machine", "u_h": "injection.u_h", "f_h": "injection.f_h",
                  "bw_filter_p": "injection.bw_filter_p", "bw_filter_n": "injection.bw_filter_n"}
SETTINGS_REFUSED = ("estimator", "leak", "sequence")


def table_settings(d: dict, machine_name: str) -> dict:
    """What a cross-saturation table measured (or used) in a scenario
    depends on beside the machine's magnetics: the estimator, its bias-moving
    settings, the machine and the carrier (filters left to fs_hfi_init:
    "designed")."""
    inj = d["injection"]
    square = d["controller"]["angle"] == "swvi"
    out = {"estimator": "square" if square else "rotating", "machine": machine_name,
           "u_h": float(inj["u_h"]), "f_h": float(inj["f_h"])}
    if square:
        out["sequence"] = inj["sequence"]
    else:
        out["leak"] = inj["leak"]
        for key in ("bw_filter_p", "bw_filter_n"):
            out[key] = "designed" if inj[key] is None else float(inj[key])
    return out


def check_table_settings(d: dict, machine_name: str, source=None) -> list[str]:
    """The scenario's injection.xcomp table against the settings it was
    measured with: ConfigError on a refused difference, one warning line per
    other difference; nothing for a table that records none (an inline
    table the user wrote) or the square wave's fitted polynomial."""
    xc = d["injection"].get("xcomp")
    rec = xc.get("settings") if isinstance(xc, dict) else None
    if not rec or d["controller"]["angle"] not in ("hfi", "blend", "swvi"):   # no injection: the table is not read
        return []
    now = table_settings(d, machine_name)
    warnings = []
    for key, field in SETTING_FIELDS.items():
        if key not in rec or key not in now:
            continue
        a, b = rec[key], now[key]
        same = (math.isclose(a, b, rel_tol=1e-6) if isinstance(a, float) and isinstance(b, float) else a == b)
        if same:
            continue
        a_s, b_s = (_shown(v) for v in (a, b))
        why = (f"the cross-saturation table (injection.xcomp) was measured with {key} = {a_s}, and the estimator's "
               f"own bias at that setting is in it")
        if key in SETTINGS_REFUSED:
            raise ConfigError(field, b, f"must be {a_s} with this table: {why}; calibrate one with this setting "
                                        "(fullspeed calibrate SCENARIO)", source)
        warnings.append(f"{field} = {b_s}: {why}; with {b_s} it may hold a different bias (fullspeed calibrate to check)")
    return warnings


def _shown(v) -> str:
    """A setting as a message shows it: a float to 6 digits (1111.11, not
    1111.111111111111; 5.0 stays 5.0), anything else as its repr."""
    if not isinstance(v, float):
        return repr(v)
    s = f"{v:.6g}"
    return s + ".0" if s.lstrip("-").isdigit() else s


# The designed table (injection.xcomp left out on a machine with a flux map
# or an algebraic model): the saliency axis of the incremental inductances
# along the locus the drive's current follows, as fs_xcomp.h holds it.
XCOMP_N = 33             # csrc/control/fs_xcomp.h FS_XCOMP_MAX: the finest even grid the estimator holds
LOCUS_N = 257            # points the locus is searched on before the grid is read off it
XCOMP_NEGLIGIBLE = 0.05  # el.deg: a largest lead below this (no cross term: a_dq = 0, a linear model) is no table


def saliency_lead(mag: dict, i_d, i_q) -> np.ndarray:
    """The lead delta = theta_hat - theta_r (rad) of the axis a rotating
    carrier's negative sequence points to, at currents (arrays), from the
    map's incremental inductances (central differences over one grid step:
    the carrier's current swings over about that).

    yang2022 eq. (24) with cross-saturation: with psi_h = L i_h,
    L = [[L_dd, L_dq], [L_qd, L_qq]] the incremental inductances, the carrier
    current is i_h = L^-1 int u_h; as a complex vector z = d + jq, any 2 x 2
    matrix M acts as M z = a z + b conj(z), b = ((M_dd - M_qq) + j (M_qd + M_dq)) / 2,
    and in the stationary frame b picks up e^{j 2 theta_r}. For
    M = L^-1 = [[L_qq, -L_dq], [-L_qd, L_dd]] / det L,
      b = ((L_qq - L_dd) - j (L_dq + L_qd)) / (2 det L),
    so the negative sequence is I_n e^{j(-w_h t + 2 theta_r + pi/2 + 2 delta)} with
      delta = 1/2 atan2(-(L_dq + L_qd), L_qq - L_dd),
    which is eq. (24) when L_dq = L_qd = 0 (delta = 0 for L_qq > L_dd) and
    yu2022's delta = -phi_dq / 2 (eqs. (19)-(21)) for L_dq = L_qd. The
    estimator locks theta_hat on theta_r + delta: the table's lead."""
    L_dd, L_dq, L_qd, L_qq = incremental_inductances(map_flux(mag), i_d, i_q, mag["i_d"][1] - mag["i_d"][0],
                                                     mag["i_q"][1] - mag["i_q"][0])
    return 0.5 * np.arctan2(-(L_dq + L_qd), L_qq - L_dd)


def designed_table(m, i_max: float, i_d: float | None = None):
    """The cross-saturation table the design forms from m's magnetics
    (a flux map, or the plant's algebraic model tabulated), and its Value
    for `fullspeed design`; (None, None) where it would correct nothing.

    The locus: the map's MTPA (what the speed loop's torque asks), or i_d
    held at a given current (a current-controlled scenario's). The grid: XCOMP_N
    even points over +-the locus's largest i_q, up to where the incremental
    saliency falls below magnetics.SALIENCY_FLOOR (the injection holds no
    angle beyond; fs_xcomp holds the last value). i_q < 0 mirrors it: the
    maps are symmetric in i_q (model.fluxmap), so delta(-i_q) = -delta(i_q)."""
    return _TABLES(m, i_max, i_d)


def _designed_table(m, i_max: float, i_d: float | None):
    mag = flux_table(m, i_max)
    if i_d is None:
        T, d, q = mtpa_locus(mag, i_max, m.phases, m.pole_pairs)
        torque = (q, T)
        d, q = np.interp(np.linspace(0, q[-1], LOCUS_N), q, d), np.linspace(0, q[-1], LOCUS_N)
        how = "on the map's MTPA locus"
    else:
        q = np.linspace(0.0, math.sqrt(max(i_max ** 2 - i_d ** 2, 0.0)), LOCUS_N)
        d = np.full_like(q, i_d)
        torque = None
        how = f"at i_d = {i_d:g} A (the scenario's)"
    sal = incremental_saliency(mag, d, q)
    low = np.flatnonzero(sal < SALIENCY_FLOOR)
    end = low[0] - 1 if low.size else LOCUS_N - 1
    if end < 1:
        return None, None
    grid = np.linspace(-q[end], q[end], XCOMP_N)
    i_d_grid = np.interp(np.abs(grid), q, d)
    lead = np.degrees(np.sign(grid) * saliency_lead(mag, i_d_grid, np.abs(grid)))
    k = XCOMP_N // 2 + int(np.argmax(np.abs(lead[XCOMP_N // 2:])))   # the largest, named on the motoring side
    if abs(lead[k]) < XCOMP_NEGLIGIBLE:
        return None, None
    cut = (f"; held beyond {q[end]:.3g} A, where the incremental saliency falls below {SALIENCY_FLOOR:g}"
           if low.size else "")
    table = {"i_q": [float(x) for x in grid], "delta_deg": [float(x) for x in lead],
             "source": f"designed from {m.name}'s magnetics: the incremental inductances' saliency axis {how}",
             "settings": {"estimator": "rotating", "machine": m.name}}
    at_T = f", {np.interp(grid[k], *torque):.3g} N m" if torque is not None else ""
    why = (f"the largest lead of the carrier's saliency axis, {lead[k]:+.3g} el.deg at i_q = {grid[k]:.3g} A "
           f"(i_d = {i_d_grid[k]:.3g} A{at_T}) {how}: the table (33 points over +-{q[end]:.3g} A{cut}) takes it out "
           "of the injection's angle")
    return table, Value(float(abs(lead[k])), "deg", why)


_TABLES = Memo(_designed_table, copies=True, keep=16)   # B-LOCK's cases of one base, B-ROBUST's draws: one machine
