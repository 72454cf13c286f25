"""The controller as a scenario configures it: its model of the machine
(the machine's R_s, L_d, L_q times the scenario's *_scale) and its injection
estimator as fs_hfi_init designs it. One place for each, used by the
scenario's design, the load-time checks and the C configuration."""
from __future__ import annotations

import math

from .._core import ffi, lib
from ..model.errors import ConfigError
from ..model.machines import Machine


def controller_model(ctl: dict, m: Machine) -> dict:
    """R_s, L_d, L_q, psi_f as the controller knows them: the machine's times
    the controller's *_scale (a model error on purpose). A flux map's machine
    (design.machine.map_model): its map's psi_f, secant L_d, L_q and, for the
    injection, its incremental L_d_hf, L_q_hf."""
    if "map.L_d" in m.design:
        v = {k: m.design[f"map.{k}"].value for k in ("psi_f", "L_d", "L_q", "L_d_hf", "L_q_hf")}
        return {"R_s": m.R_s * ctl["R_s_scale"], "psi_f": v["psi_f"] * ctl["psi_f_scale"],
                "L_d": v["L_d"] * ctl["L_d_scale"], "L_q": v["L_q"] * ctl["L_q_scale"],
                "L_d_hf": v["L_d_hf"] * ctl["L_d_scale"], "L_q_hf": v["L_q_hf"] * ctl["L_q_scale"]}
    return {"R_s": m.R_s * ctl["R_s_scale"], "L_d": m.L_d * ctl["L_d_scale"], "L_q": m.L_q * ctl["L_q_scale"],
            "psi_f": m.psi_f * ctl["psi_f_scale"]}


def injection_inductances(cm: dict) -> tuple[float, float]:
    """The inductances the rotating carrier sees, from controller_model's
    values: a flux map's incremental ones where it runs, else L_d, L_q (the
    drive's rule, fs_drive.h L_d_hf)."""
    return cm.get("L_d_hf", cm["L_d"]), cm.get("L_q_hf", cm["L_q"])


def hfi_design(inj: dict, Ts: float, L_d: float, L_q: float, source=None):
    """The injection estimator as fs_hfi_init designs it (its defaults and
    the held carrier amplitude): one place for those rules, the C one."""
    cfg = ffi.new("fs_hfi_config *", {"Ts": Ts, "delay": 1.0, "u_h": inj["u_h"], "w_h": 2 * math.pi * inj["f_h"],
                                      "L_d": L_d, "L_q": L_q,
                                      "w_b_p": inj["bw_filter_p"] or 0.0, "w_b_n": inj["bw_filter_n"] or 0.0,
                                      "leak": inj["leak"] == "remove", "lag": inj["tracking"] == "lag"})
    cfg.obs.J, cfg.obs.pole_pairs, cfg.obs.bandwidth = 1.0, 1, inj["bw_observer"] or 0.0
    h = ffi.new("fs_hfi *")
    st = lib.fs_hfi_init(h, cfg)
    if st != lib.FS_OK:
        raise ConfigError("injection", f"f_h = {inj['f_h']:g} Hz", ffi.string(lib.fs_status_str(st)).decode(), source)
    return h
