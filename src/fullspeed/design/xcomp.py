"""A cross-saturation table (injection.xcomp) against the scenario that uses
it: the table holds the estimator's own bias at the settings it was
measured with (workflows.calibrate records them), so a scenario with a
setting that moves that bias is refused, and one with another machine or
carrier warned, one line naming the field."""
from __future__ import annotations

import math

from ..model.errors import ConfigError


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
