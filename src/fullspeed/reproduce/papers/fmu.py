"""B-FMU: beyond-full-range's blended drive as FMI co-simulation units
(workflows.fmu), FMI 3.0 and 2.0, checked by FMPy (workflows.fmu_check).

The scenario runs for its first FMU_SECONDS: polarity detection, the
rated load taken on at standstill on injection, the ramp through the blend
into the back-EMF observer (the stages the equality covers are in the
value). Measured where FMPy is installed (the test extra) and the host has
an FMI platform folder; otherwise listed as not measured, with the reason.
"""
from __future__ import annotations

import importlib.util
import json
import time
from pathlib import Path

from ...design.scenario import load_scenario
from ...model.errors import ConfigError
from ...workflows.fmu import export_fmu
from ...workflows.fmu_check import drive_vs_host, system_vs_run, validate
from ..registry import Measurement, register

SCENARIO = "beyond-full-range"
# Simulated seconds: 15,000 control periods at 10 kHz, from standstill
# through polarity, injection under the rated load and the blend into the
# back-EMF observer; equality over them is equality of the same arithmetic
# (the full 7 s would add flux weakening and 55 s of FMPy stepping).
FMU_SECONDS = 1.5


@register("B-FMU", cost=9)
def fmu(out: Path) -> Measurement:
    if importlib.util.find_spec("fmpy") is None:
        return Measurement(None, False, "not measured: FMPy, the independent FMI tool, is not installed "
                                        "(pip install fmpy, or the test extra: pip install -e '.[test]')")
    sc = load_scenario(SCENARIO, {"duration": FMU_SECONDS, "metrics": {"steady": [0.0, FMU_SECONDS]}})
    value, ok = {"scenario": SCENARIO, "seconds": FMU_SECONDS}, True
    for fmi in (3, 2):
        t0 = time.perf_counter()
        try:
            drive, system = export_fmu(sc, out / f"B-FMU-fmi{fmi}", ("drive", "system"), fmi)
        except ConfigError as e:
            return Measurement(None, False, f"not measured: {e}")
        built = time.perf_counter() - t0
        problems = {"drive": validate(drive), "system": validate(system)}
        sys_eq, drv_eq = system_vs_run(system, sc), drive_vs_host(drive, sc)
        value[f"fmi{fmi}"] = {
            "sizes_bytes": {"drive": drive.stat().st_size, "system": system.stat().st_size},
            "validation_problems": problems, "system_vs_run": sys_eq, "drive_vs_host": drv_eq,
            "build_s": round(built, 1), "total_s": round(time.perf_counter() - t0, 1)}
        ok = ok and not any(problems.values()) and sys_eq["bitwise"] and drv_eq["bitwise"] \
            and sys_eq["steps"] > 0 and drv_eq["steps"] > 0
    (out / "B-FMU.json").write_text(json.dumps(value, indent=2))
    note = ("fullspeed export --fmu and --fmu-system (FMI 3.0 and 2.0, binaries built here with cc) of "
            f"{SCENARIO}, its first {FMU_SECONDS:g} s. FMPy's validate_fmu on both model descriptions; FMPy's "
            "simulate_fmu of the system FMU, its inputs the scenario's speed reference and load torque at every "
            "control instant, against fullspeed's run: the plant's outputs at each step's end against the run's "
            "next sample, the drive's against the step's sample, the dc-link power against the run's input "
            "energy (largest absolute differences; 0 is bit for bit). The drive FMU stepped through FMPy's API "
            "on fullspeed's plant (fs_sim_sample / fs_sim_actuate), the host's fs_drive_step alongside on the "
            "same inputs, and its duties against fullspeed's run. Full figures: B-FMU.json.")
    return Measurement(value, ok, note)
