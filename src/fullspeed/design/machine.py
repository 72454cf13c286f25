"""A machine as the drive is designed for it: the bench's limits and
bandwidths its file leaves out formed by the rules (design.rules), and
what depends on them checked (the trip level above the current limit, the
ADC's range above the trip level, a flux map reaching the current limit).
Also the MTPA torque a current gives, from the controller's own table."""
from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

from .._core import ffi, lib
from ..model.errors import ConfigError
from ..model.fluxmap import FluxMapWarning, check_coverage, coverage_limit, map_range
from ..model.machines import Machine, machine_data, parse_machine
from .magnetics import controller_map, controller_values
from .memo import Memo
from .rules import I_MAX_PER_RATED, Value, design_bench


def design_machine(m: Machine) -> Machine:
    """m with its bench complete: each field left out designed, each with
    its reason in m.design (errors name the file m was read from)."""
    source, prefix = m.origin, m.prefix
    b = dict(m.bench)
    fluxmap = m.magnetic["model"] == "fluxmap"
    # a measured map may stop short of 1.5 x rated: the designed limit is held within it, a given one is checked below
    i_cover = coverage_limit(m.magnetic) if fluxmap and b.get("i_max") is None else None
    designed = design_bench({"i_rated": m.i_rated}, b, i_cover)
    if i_cover is not None and designed["i_max"].value < I_MAX_PER_RATED * m.i_rated:
        warnings.warn(f"{prefix}.bench.i_max: {m.name}'s flux map covers {map_range(m.magnetic)}: the current limit is held to "
                      f"{i_cover:g} A, below the {I_MAX_PER_RATED * m.i_rated:g} A designed from the rated current "
                      f"({I_MAX_PER_RATED:g} x {m.i_rated:g} A)"
                      + (f", below the rated current itself: the machine cannot make its rated torque ({m.T_rated:g} N m) "
                         "on this map" if i_cover < m.i_rated else "")
                      + "; give bench.i_max within the map to choose another", FluxMapWarning, stacklevel=2)
    b.update({k: v.value for k, v in designed.items()})
    if not b["i_trip"] > b["i_max"]:
        raise ConfigError(f"{prefix}.bench.i_trip", b["i_trip"], f"must be > bench.i_max ({b['i_max']:g})", source)
    if b["adc_bits"] and not b["adc_range"] >= b["i_trip"]:
        raise ConfigError(f"{prefix}.bench.adc_range", b["adc_range"], f"must be >= bench.i_trip ({b['i_trip']:g})", source)
    if fluxmap:
        check_coverage(m.magnetic, b["i_max"], f"{prefix}.magnetic", source)
        designed.update(map_model(m, b["i_max"]))
    return dataclasses.replace(m, bench=b, design=designed)


def map_model(m: Machine, i_max: float) -> dict[str, Value]:
    """A flux map's values for the controller's model (design.magnetics.controller_values),
    by name "map.<field>": the magnet's flux, the secant inductances at the MTPA
    point of rated current and the incremental ones at half of it (found once
    per machine and limit: design.memo)."""
    return _MAP_MODELS(m, i_max)


def _map_model(m: Machine, i_max: float) -> dict[str, Value]:
    cv = controller_values(m.magnetic, i_max, m.i_rated, m.phases, m.pole_pairs)
    why = {"psi_f": ("Wb", "the map's psi_d at zero current"),
           "L_d": ("H", "the map's secant inductance at the MTPA point of rated current: the decoupling is exact there"),
           "L_q": ("H", "the map's secant inductance at the MTPA point of rated current"),
           "L_d_hf": ("H", "the map's incremental inductance at half the rated current on MTPA: what the carrier sees"),
           "L_q_hf": ("H", "the map's incremental inductance at half the rated current on MTPA")}
    return {f"map.{k}": Value(float(cv[k]), unit, reason) for k, (unit, reason) in why.items()}


_MAP_MODELS = Memo(_map_model, copies=True, keep=16)   # each load of a flux-map machine (B-REAL's ~150) searched its MTPA


def machine_from_dict(data: dict, source: str | None = None, prefix: str = "machine") -> Machine:
    """A machine table, validated (model.machines.parse_machine) and designed."""
    return design_machine(parse_machine(data, source, prefix))


def load_machine(name_or_path: str | Path) -> Machine:
    """A catalog machine by name or a machine file, validated and designed."""
    data, source = machine_data(name_or_path)
    return machine_from_dict(data, source)


def mtpa_torque(m: Machine, i: float) -> float:
    """Torque on the MTPA locus at current magnitude i, from the controller's
    own MTPA table (csrc/control/fs_mtpa.c): on the machine's flux map where
    it has one (the map on the controller's grid for i as its current
    limit, searched as fs_drive_init searches it), else the linear model
    (the 2004 Prius MG2: 486 N m at 250 A on its map, 1044 with its
    unsaturated inductances)."""
    mt = ffi.new("fs_mtpa *")
    cfg = ffi.new("fs_mtpa_config *", {"L_d": m.L_d, "L_q": m.L_q, "psi_f": m.psi_f,
                                       "pole_pairs": m.pole_pairs, "i_max": i,
                                       "phases": m.phases})
    keep = []
    if m.magnetic["model"] == "fluxmap":
        cm = controller_map(m.magnetic, i)
        tab = ffi.new("fs_fluxmap_table *", {k: cm[k] for k in ("di_d", "i_d0", "di_q", "psi_scale", "psi_d", "psi_q")})
        fm = ffi.new("fs_fluxmap *")
        if lib.fs_fluxmap_init(fm, tab) != lib.FS_OK:
            raise ValueError(f"{m.name}'s flux map does not rise with its currents")
        keep += [tab, fm]
        cfg.map = fm
    if lib.fs_mtpa_init(mt, cfg) != lib.FS_OK:
        raise ValueError(f"no MTPA torque for {m.name} at {i:g} A")
    return float(mt.T[lib.FS_MTPA_N - 1])
