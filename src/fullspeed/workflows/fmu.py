"""The drive and the closed loop as FMI co-simulation units (FMUs).

`fullspeed export SCENARIO --fmu --out DIR` writes DIR/<name>-drive.fmu: the
controller, built from csrc/control and the very configuration the firmware
gets (export.render's fs_config.c), stepped one control period a doStep
(csrc/fmu/fs_fmu_drive.c). `--fmu-system` writes DIR/<name>-system.fmu: the
plant, the converter, the sensors and the drive as fullspeed simulates them
(csrc/plant, csrc/sim, csrc/control on the fs_sim_config sim.config builds,
serialized as C by export's initializer; csrc/fmu/fs_fmu_system.c), the
master's reference and load in place of the scenario's profiles. FMI 3.0
by default, 2.0 with `--fmi 2`.

An FMU is a zip: modelDescription.xml (every variable with its unit),
binaries/<platform>/<modelIdentifier>.so built here with the C compiler the
C core is built with (cc, or $CC) and the core's flags, and sources/ with
every C file and sources/buildDescription.xml (FMI 3.0's build description;
an FMI 2.0 FMU also lists its files in the model description), so that
another platform builds it from source. The FMI headers in
csrc/fmu/fmi2, csrc/fmu/fmi3 are the Modelica Association's (2-clause BSD,
as FMPy's package carries them).

The variables are numbered in one table per model (DRIVE, SYSTEM below); the
C side reads them through fs_fmu_vars.h, generated from the same table.
`fmu_checks` below are the independent tool's checks (FMPy): validation,
the system FMU against fullspeed's run, and the drive FMU against the host's
drive on fullspeed's plant.
"""
from __future__ import annotations

import hashlib
import os
import platform
import re
import shutil
import subprocess
import tempfile
import uuid
import zipfile
from importlib.metadata import version
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from .._core import ffi, lib
from ..design.scenario import load_scenario
from ..model.errors import ConfigError
from ..model.files import out_folder, out_path, write_with
from ..model.scenario import Scenario
from ..sim.config import build_config
from ..sim.runner import CHANNELS
from .export import c_comment, c_double, field_comments, initializer, render

VERSION = version("fullspeed")

CSRC = Path(__file__).resolve().parents[3] / "csrc"   # src/fullspeed/workflows/ -> the checkout
# The C core's flags (fullspeed/_build.py) and position-independent code:
# the same arithmetic as the host's simulation, bit for bit.
CFLAGS = ["-O2", "-std=c99", "-fno-math-errno", "-fPIC", "-fvisibility=hidden"]

# host (system, machine) -> (FMI 3.0 platform tuple, FMI 2.0 platform folder or None, suffix)
PLATFORMS = {
    ("Linux", "x86_64"): ("x86_64-linux", "linux64", ".so"),
    ("Linux", "aarch64"): ("aarch64-linux", None, ".so"),
    ("Darwin", "x86_64"): ("x86_64-darwin", "darwin64", ".dylib"),
    ("Darwin", "arm64"): ("aarch64-darwin", None, ".dylib"),
}

# SI units of the variables, as FMI base-unit exponents
UNITS = {
    "s": {"s": 1}, "A": {"A": 1}, "V": {"kg": 1, "m": 2, "s": -3, "A": -1}, "W": {"kg": 1, "m": 2, "s": -3},
    "rad": {"rad": 1}, "rad/s": {"rad": 1, "s": -1}, "rad/s2": {"rad": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2}, "Ohm": {"kg": 1, "m": 2, "s": -3, "A": -2},
    "H": {"kg": 1, "m": 2, "s": -2, "A": -2}, "Wb": {"kg": 1, "m": 2, "s": -2, "A": -1},
    "kg.m2": {"kg": 1, "m": 2}, "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1}, "1": {},
}


@dataclass(frozen=True)
class Var:
    name: str
    type: str              # Real, Integer, Boolean
    causality: str         # independent, input, parameter, output
    unit: str | None
    description: str
    when: object = None    # sc -> bool: in this scenario's FMU (None: always)
    channel: str | None = None   # the system's outputs: the trace channel shown
    start: object = 0.0    # a number, or (sc, cfg) -> number
    continuous: bool = False     # an output of the plant's state (else a sampled value, held)


def _speed(sc):
    return sc.data["controller"]["mode"] == "speed"


def _current(sc):
    return sc.data["controller"]["mode"] == "current"


def _voltage(sc):
    return sc.data["controller"]["mode"] == "voltage"


def _frame(sc):
    return sc.data["controller"]["mode"] in ("voltage", "vf")


def _five(sc):
    return sc.machine.phases == 5


def _sensorless(sc):
    return sc.data["controller"]["angle"] in ("smo", "hfi", "blend", "swvi")


def _torque_load(sc):
    return sc.data["load"]["kind"] in ("torque", "brake")


def _speed_load(sc):
    return sc.data["load"]["kind"] in ("speed", "speed_pi")


def _profile0(name):
    """The start of a profile of the configuration (SI), as fs_sim reads it at t = 0."""
    return lambda sc, cfg: profile_values(getattr(cfg, name), np.zeros(1))[0]


def _drive_field(name):
    return lambda sc, cfg: float(getattr(cfg.drive, name))


TIME = Var("time", "Real", "independent", "s", "simulation time")
REFERENCES = [
    Var("w_m_ref", "Real", "input", "rad/s", "speed reference, mechanical (speed mode)", _speed, start=_profile0("w_m_ref")),
    Var("i_d_ref", "Real", "input", "A", "d-current reference (current mode)", _current, start=_profile0("i_d_ref")),
    Var("i_q_ref", "Real", "input", "A", "q-current reference (current mode)", _current, start=_profile0("i_q_ref")),
    Var("u_d_ref", "Real", "input", "V", "d-voltage reference (voltage mode)", _voltage, start=_profile0("u_d_ref")),
    Var("u_q_ref", "Real", "input", "V", "q-voltage reference (voltage mode)", _voltage, start=_profile0("u_q_ref")),
    Var("w_e_ref", "Real", "input", "rad/s", "the open-loop frame's electrical speed (voltage and V/f modes)", _frame,
        start=_profile0("w_e_ref")),
]
# The drive: one fs_drive_step a doStep (csrc/fmu/fs_fmu_drive.c)
DRIVE = [TIME] + [
    Var(f"i_{p}", "Real", "input", "A", f"phase {p}'s current sampled at the carrier's peak, positive into the machine",
        None if p in "abc" else _five) for p in "abcde"
] + [
    Var("u_dc", "Real", "input", "V", "dc-link voltage, sampled", start=lambda sc, cfg: cfg.inverter.u_dc),
    Var("theta_m_enc", "Real", "input", "rad", "encoder angle, mechanical, 0 with the d axis on phase a (read while "
        "sensorless is false)", lambda sc: sc.data["controller"]["angle"] != "true"),
    Var("theta_e_ext", "Real", "input", "rad", "external angle, electrical", lambda sc: sc.data["controller"]["angle"] == "true"),
    Var("w_e_ext", "Real", "input", "rad/s", "external speed, electrical", lambda sc: sc.data["controller"]["angle"] == "true"),
    *REFERENCES,
    Var("sensorless", "Boolean", "input", None, "the loops on the estimator (else on the encoder); the scenario's at t = 0",
        _sensorless, start=lambda sc, cfg: profile_values(cfg.sensorless, np.zeros(1))[0] > 0.5),
    Var("R_s", "Real", "parameter", "Ohm", "stator resistance the controller assumes", start=_drive_field("R_s")),
    Var("L_d", "Real", "parameter", "H", "d inductance the controller assumes", start=_drive_field("L_d")),
    Var("L_q", "Real", "parameter", "H", "q inductance the controller assumes", start=_drive_field("L_q")),
    Var("psi_f", "Real", "parameter", "Wb", "magnet flux the controller assumes", start=_drive_field("psi_f")),
    Var("J", "Real", "parameter", "kg.m2", "inertia the controller assumes", start=_drive_field("J")),
    Var("B", "Real", "parameter", "N.m.s/rad", "viscous friction the controller assumes", start=_drive_field("B")),
    Var("i_max", "Real", "parameter", "A", "current limit, peak", start=_drive_field("i_max")),
    Var("T_max", "Real", "parameter", "N.m", "torque limit", start=_drive_field("T_max")),
    Var("bw_current", "Real", "parameter", "rad/s", "current loop bandwidth (0: the paper's gains as exported)",
        start=_drive_field("bw_current")),
    Var("bw_speed", "Real", "parameter", "rad/s", "speed loop bandwidth", start=_drive_field("bw_speed")),
    Var("bw_pll", "Real", "parameter", "rad/s", "encoder PLL bandwidth", start=_drive_field("bw_pll")),
    Var("lock_time", "Real", "parameter", "s", "loss-of-lock time (0: no monitor)", start=_drive_field("lock_time")),
] + [
    Var(f"duty_{p}", "Real", "output", "1", f"leg {p}'s duty for the next update instant, 0..1",
        None if p in "abc" else _five, start=0.5) for p in "abcde"
] + [
    Var("theta_e", "Real", "output", "rad", "the angle the loops use, electrical"),
    Var("w_e", "Real", "output", "rad/s", "the speed the loops use, electrical"),
    Var("theta_est", "Real", "output", "rad", "the estimator's angle, electrical (used or not)"),
    Var("w_est", "Real", "output", "rad/s", "the estimator's speed, electrical"),
    Var("est_valid", "Boolean", "output", None, "the estimator's output is valid", start=False),
    Var("i_d_hat", "Real", "output", "A", "measured d current in the controller's frame"),
    Var("i_q_hat", "Real", "output", "A", "measured q current in the controller's frame"),
    Var("i_d_cmd", "Real", "output", "A", "the d-current reference the loops follow"),
    Var("i_q_cmd", "Real", "output", "A", "the q-current reference the loops follow"),
    Var("T_ref", "Real", "output", "N.m", "the torque reference"),
    Var("stage", "Integer", "output", None, "operating stage (fs_drive_stage: 1 encoder, 2 polarity, 3 I/f start, "
        "4 injection, 5 blend, 6 back-EMF, 7 flux weakening, 8 recovery)", start=0),
    Var("fault", "Integer", "output", None, "the drive refused to go on (fs_drive_fault: 1 polarity undetermined, "
        "2 lock lost and not re-acquired, 3 overspeed, 4 the I/f start never handed over): turn the PWM off",
        start=0),
    Var("lock_lost", "Boolean", "output", None, "the loss-of-lock monitor latched: turn the PWM off", start=False),
]
# The closed loop: the runner's sample and period a doStep (csrc/fmu/fs_fmu_system.c)
AT_END = "at the step's end"
AT_SAMPLE = "at the step's sample, held over it"
SYSTEM = [TIME, *REFERENCES] + [
    Var("T_load", "Real", "input", "N.m", "load torque on the shaft (a brake: its magnitude)", _torque_load,
        start=_profile0("T_load")),
    Var("w_load", "Real", "input", "rad/s", "the load machine's speed (the shaft's, for an ideal speed load)", _speed_load,
        start=_profile0("w_load")),
    Var("dw_load", "Real", "input", "rad/s2", "its slope over the coming step (0: held)", _speed_load),
    Var("w_m", "Real", "output", "rad/s", f"shaft speed, mechanical, {AT_END}", channel="w_m", continuous=True),
    Var("theta_e", "Real", "output", "rad", f"rotor angle, electrical, {AT_END}", channel="theta_e", continuous=True),
    Var("T_e", "Real", "output", "N.m", f"electromagnetic torque, {AT_END}", channel="T_e", continuous=True),
] + [
    Var(f"i_{p}", "Real", "output", "A", f"phase {p}'s current, {AT_END}", channel=f"i_{p}", continuous=True) for p in "abc"
] + [
    Var("i_d", "Real", "output", "A", f"d current, rotor frame, {AT_END}", channel="i_d", continuous=True),
    Var("i_q", "Real", "output", "A", f"q current, rotor frame, {AT_END}", channel="i_q", continuous=True),
    Var("u_dc", "Real", "output", "V", "dc-link voltage over the step (0 before the first)"),
    Var("i_dc", "Real", "output", "A", "mean current drawn from the dc link over the step"),
    Var("P_dc", "Real", "output", "W", "mean power drawn from the dc link over the step (the machine's input energy "
        "plus the devices' conduction loss)"),
    Var("theta_err", "Real", "output", "rad", f"true minus the loops' angle, electrical, {AT_SAMPLE}", channel="theta_err"),
    Var("est_err", "Real", "output", "rad", f"true minus the estimator's angle, {AT_SAMPLE}", channel="est_err"),
    Var("w_m_hat", "Real", "output", "rad/s", f"the loops' speed, mechanical, {AT_SAMPLE}", channel="w_m_hat"),
    Var("T_ref", "Real", "output", "N.m", f"the drive's torque reference, {AT_SAMPLE}", channel="T_ref"),
] + [
    Var(f"duty_{p}", "Real", "output", "1", f"leg {p}'s duty, {AT_SAMPLE}", channel=f"duty_{p}") for p in "abc"
] + [
    Var("stage", "Integer", "output", None, f"the drive's operating stage (fs_drive_stage), {AT_SAMPLE}", channel="stage"),
    Var("lock_lost", "Boolean", "output", None, f"the drive's loss-of-lock flag, {AT_SAMPLE}", channel="lock_lost"),
    Var("stop", "Integer", "output", None, "0 running; else why the closed loop stopped (fs_run_status: 2 NaN, "
        "3 overcurrent, 4 loss of lock, 5 polarity undetermined, 6 overspeed, 7 start failed)"),
]
MODELS = {"drive": DRIVE, "system": SYSTEM}


def profile_values(prof, t: np.ndarray) -> np.ndarray:
    """A profile of the C configuration (fs_profile, SI) at times t, with
    fs_pwl_eval's arithmetic (csrc/sim/fs_profile.c), so that a master
    feeding these values gives the runner's doubles bit for bit."""
    n = prof.n
    t = np.asarray(t, dtype=float)
    if n == 0:
        return np.zeros_like(t)
    tp = np.array([prof.t[k] for k in range(n)])
    yp = np.array([prof.y[k] for k in range(n)])
    k = np.clip(np.searchsorted(tp, t, side="right") - 1, 0, max(n - 2, 0))
    k1 = np.minimum(k + 1, n - 1)
    t0, t1, y0, y1 = tp[k], tp[k1], yp[k], yp[k1]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (y1 - y0) / (t1 - t0)
        y = np.where(t1 <= t0, y1, y0 + s * (t - t0))
    return np.where(t <= tp[0], yp[0], np.where(t >= tp[-1], yp[-1], y))


def control_period(cfg) -> float:
    """The runner's control period as fs_sim_create computes it (a double)."""
    return 0.5 * cfg.inverter.T_pwm if cfg.sampling == lib.FS_SAMPLING_DOUBLE else cfg.inverter.T_pwm


def variables(kind: str, sc: Scenario) -> list[tuple[int, Var]]:
    """(value reference, variable) of this scenario's FMU of kind (drive, system)."""
    return [(vr, v) for vr, v in enumerate(MODELS[kind]) if v.when is None or v.when(sc)]


def _start(v: Var, sc, cfg):
    return v.start(sc, cfg) if callable(v.start) else v.start


def _xml_value(v: Var, x) -> str:
    if v.type == "Boolean":
        return "true" if x else "false"
    return str(int(x)) if v.type == "Integer" else c_double(float(x))


# -- C: the variables' table and the closed loop's configuration --------------

def vars_c(kind: str, sc: Scenario, cfg, fmi: int, token: str) -> tuple[str, str]:
    """(fs_fmu_vars.h, fs_fmu_vars.c) of the scenario's FMU (fs_fmu.h says what they hold)."""
    present = dict(variables(kind, sc))
    if fmi == 2:
        present.pop(0, None)   # FMI 2.0 has no time variable
    table = MODELS[kind]
    kinds = {"Real": "FS_FMU_REAL", "Integer": "FS_FMU_INT", "Boolean": "FS_FMU_BOOL"}
    causes = {"input": "FS_FMU_INPUT", "parameter": "FS_FMU_PARAMETER", "output": "FS_FMU_OUTPUT", "independent": "0"}
    banner = f"/* Generated by fullspeed.workflows.fmu for `{c_comment(sc.name)}` ({kind}, FMI {fmi}.0): do not edit. */\n"
    enum = ",\n".join(f"    FS_VR_{v.name.upper()} = {vr}" for vr, v in enumerate(table))
    header = (banner + "#ifndef FS_FMU_VARS_H\n#define FS_FMU_VARS_H\n\n"
              f"/* the communication step: one control period, s */\n#define FS_FMU_TS {c_double(control_period(cfg))}\n"
              f"#define FS_FMU_TOKEN \"{token}\"\n\nenum {{\n{enum},\n    FS_FMU_NV\n}};\n\n"
              "extern const unsigned char fs_fmu_type[FS_FMU_NV];       /* 0: not in this FMU */\n"
              "extern const unsigned char fs_fmu_causality[FS_FMU_NV];\n"
              "extern const double fs_fmu_start_value[FS_FMU_NV];\n"
              "extern const int fs_fmu_channel[FS_FMU_NV];             /* the trace channel shown, or -1 */\n"
              "extern const char *const fs_fmu_name[FS_FMU_NV];\n\n#endif\n")

    def row(values):
        return "{" + ", ".join(values) + "}"

    starts = [c_double(float(_start(v, sc, cfg))) if vr in present else "0.0" for vr, v in enumerate(table)]
    source = (banner + "#include \"fs_fmu.h\"\n\n"
              f"const unsigned char fs_fmu_type[FS_FMU_NV] = "
              f"{row(kinds[v.type] if vr in present else '0' for vr, v in enumerate(table))};\n"
              f"const unsigned char fs_fmu_causality[FS_FMU_NV] = {row(causes[v.causality] for v in table)};\n"
              f"const double fs_fmu_start_value[FS_FMU_NV] = {row(starts)};\n"
              f"const int fs_fmu_channel[FS_FMU_NV] = "
              f"{row(str(CHANNELS.index(v.channel)) if v.channel else '-1' for v in table)};\n"
              f"const char *const fs_fmu_name[FS_FMU_NV] = {row(chr(34) + v.name + chr(34) for v in table)};\n")
    return header, source


def system_c(sc: Scenario, cfg) -> tuple[str, str]:
    """(fs_system.h, fs_system.c): the scenario's fs_sim_config as C, its
    profiles and flux map as static arrays, every value exact (floats to 9
    digits, doubles to 17: export's literals)."""
    comments = {**field_comments(CSRC / "control"), **field_comments(CSRC / "plant"), **field_comments(CSRC / "sim")}
    arrays: list[str] = []

    def pointer(path: str, _value) -> str:
        parent = cfg
        for part in path.split(".")[:-1]:
            parent = getattr(parent, part)
        leaf = path.split(".")[-1]
        n = parent.map_n_d * parent.map_n_q if leaf.startswith("map_") else parent.n
        data = getattr(parent, leaf)
        name = "fs_system_" + path.replace(".", "_")
        vals = [c_double(data[k]) for k in range(n)]
        body = ",\n".join("    " + ", ".join(vals[k:k + 6]) for k in range(0, n, 6))
        arrays.append(f"static const double {name}[{n}] = {{\n{body}\n}};")
        return name

    def describe(struct, field, path, value):
        return comments.get((struct, field), field)

    body = initializer("fs_sim_config", cfg[0], describe, pointer)
    banner = (f"/* Generated by fullspeed.workflows.fmu: the fs_sim_config fullspeed builds for scenario "
              f"{c_comment(sc.name)}\n * (fullspeed.sim.build_config), byte for byte; do not edit. */\n")
    header = (banner + "#ifndef FS_SYSTEM_H\n#define FS_SYSTEM_H\n\n#include \"fs_sim.h\"\n\n"
              "extern const fs_sim_config fs_system;\n\n#endif\n")
    source = (banner + "#include <math.h>\n#include <stddef.h>\n#include \"fs_system.h\"\n\n" + "\n\n".join(arrays)
              + "\n\nconst fs_sim_config fs_system = {\n" + "\n".join(body) + "\n};\n")
    return header, source


# -- XML ----------------------------------------------------------------------

def _units_xml(used: set[str], indent: str = "    ") -> str:
    out = [f"{indent}<UnitDefinitions>"]
    for u in sorted(used):
        base = " ".join(f'{k}="{e}"' for k, e in UNITS[u].items())
        out.append(f"{indent}  <Unit name={quoteattr(u)}>" + (f"<BaseUnit {base}/>" if base else "") + "</Unit>")
    return "\n".join(out + [f"{indent}</UnitDefinitions>"])


LOG_CATEGORIES = ('  <LogCategories>\n'
                  '    <Category name="logEvents" description="a stop of the closed loop, the drive halting"/>\n'
                  '    <Category name="logStatusError" description="a call refused, and why"/>\n'
                  '  </LogCategories>')


def _initial(v: Var, kind: str) -> str | None:
    """FMI's initial of an output: the drive's hold their start values until
    the first step; the closed loop's are computed from the initial state."""
    if v.causality != "output":
        return None
    return "exact" if kind == "drive" else "calculated"


def _variability(v: Var) -> str:
    if v.causality == "parameter":
        return "fixed"
    if v.type != "Real" or (v.causality == "output" and not v.continuous):
        return "discrete"
    return "continuous"


def model_description(kind: str, sc: Scenario, cfg, fmi: int, ident: str, token: str, sources: list[str]) -> str:
    """modelDescription.xml of the scenario's FMU of kind, FMI 3.0 or 2.0."""
    vs = variables(kind, sc)
    if fmi == 2:
        vs = [(vr, v) for vr, v in vs if v.causality != "independent"]
    Ts = control_period(cfg)
    what = ("the drive (csrc/control, fs_drive_step) on the exported configuration" if kind == "drive"
            else "the closed loop (plant, converter, sensors, drive) as fullspeed simulates it")
    desc = (f"fullspeed {VERSION}: {what}, scenario {sc.name}; one doStep is one control period, "
            f"{Ts:.9g} s")
    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    head = (f'<?xml version="1.0" encoding="UTF-8"?>\n<fmiModelDescription fmiVersion="{fmi}.0" '
            f'modelName={quoteattr(xml_text(f"{sc.name}-{kind}"))} description={quoteattr(xml_text(desc))} '
            f'{"instantiationToken" if fmi == 3 else "guid"}="{token}" generationTool="fullspeed {VERSION}" '
            f'generationDateAndTime="{stamp}" variableNamingConvention="flat"'
            + (' numberOfEventIndicators="0"' if fmi == 2 else "") + ">")
    common = (f'modelIdentifier="{ident}" canHandleVariableCommunicationStepSize="false" '
              'canBeInstantiatedOnlyOncePerProcess="false" canGetAndSetFMUState="false" canSerializeFMUState="false"')
    if fmi == 3:
        cs = f'  <CoSimulation {common} fixedInternalStepSize="{c_double(Ts)}" hasEventMode="false"/>'
    else:
        files = "\n".join(f'      <File name={quoteattr(s)}/>' for s in sources if s.endswith(".c"))
        cs = (f'  <CoSimulation {common.replace("FMUState", "FMUstate")} canInterpolateInputs="false" '
              f'canNotUseMemoryManagementFunctions="true">\n    <SourceFiles>\n{files}\n    </SourceFiles>\n'
              '  </CoSimulation>')
    units = _units_xml({v.unit for _, v in vs if v.unit}, "  ")
    exp = f'  <DefaultExperiment startTime="0" stopTime="{c_double(sc.duration)}" stepSize="{c_double(Ts)}"/>'
    lines = ["  <ModelVariables>"]
    for vr, v in vs:
        attrs = f'name={quoteattr(v.name)} valueReference="{vr}" description={quoteattr(v.description)} ' \
                f'causality="{v.causality}"'
        if v.causality != "independent":
            attrs += f' variability="{_variability(v)}"'
        init = _initial(v, kind)
        if init:
            attrs += f' initial="{init}"'
        start = None if v.causality == "independent" or init == "calculated" else _xml_value(v, _start(v, sc, cfg))
        unit = f' unit="{v.unit}"' if v.unit else ""
        if fmi == 3:
            tag = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}[v.type]
            lines.append(f'    <{tag} {attrs}' + (f' start="{start}"' if start is not None else "") + unit + "/>")
        else:
            inner = f'<{v.type}' + (unit if v.type == "Real" else "") + (f' start="{start}"' if start is not None else "") + "/>"
            lines.append(f"    <ScalarVariable {attrs}>{inner}</ScalarVariable>")
    lines.append("  </ModelVariables>")
    outputs = [(i, vr) for i, (vr, v) in enumerate(vs, 1) if v.causality == "output"]
    calculated = [(i, vr) for i, vr in outputs if _initial(vs[i - 1][1], kind) == "calculated"]
    if fmi == 3:
        struct = ([f'    <Output valueReference="{vr}"/>' for _, vr in outputs]
                  + [f'    <InitialUnknown valueReference="{vr}"/>' for _, vr in calculated])
        ms = "  <ModelStructure>\n" + "\n".join(struct) + "\n  </ModelStructure>"
    else:
        outs = "\n".join(f'      <Unknown index="{i}"/>' for i, _ in outputs)
        inits = "\n".join(f'      <Unknown index="{i}"/>' for i, _ in calculated)
        ms = (f"  <ModelStructure>\n    <Outputs>\n{outs}\n    </Outputs>\n"
              + (f"    <InitialUnknowns>\n{inits}\n    </InitialUnknowns>\n" if inits else "") + "  </ModelStructure>")
    return "\n".join([head, cs, units, LOG_CATEGORIES, exp, *lines, ms, "</fmiModelDescription>"]) + "\n"


def build_description(ident: str, sources: list[str]) -> str:
    """sources/buildDescription.xml (FMI 3.0's schema; FMI 2.0.4 takes it too)."""
    files = "\n".join(f"      <SourceFile name={quoteattr(s)}/>" for s in sources if s.endswith(".c"))
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<fmiBuildDescription fmiVersion="3.0">\n'
            f'  <BuildConfiguration modelIdentifier="{ident}" description="every file of sources/, C99, with the math '
            'library; the arithmetic of the simulation needs no fused multiply-add (-ffp-contract=off where the '
            'target has one) and no errno from the math functions">\n'
            f'    <SourceFileSet language="C99" compilerOptions="{escape(" ".join(CFLAGS[:3]))} -ffp-contract=off">\n'
            f"{files}\n    </SourceFileSet>\n"
            '    <Library name="m" external="true" description="the C math library"/>\n'
            "  </BuildConfiguration>\n</fmiBuildDescription>\n")


# -- the build ----------------------------------------------------------------

def _sources(kind: str, fmi: int) -> dict[str, Path]:
    """{path inside sources/: file of the checkout} for an FMU of kind."""
    dirs = ["control"] + (["plant", "sim"] if kind == "system" else [])
    out = {f"{d}/{p.name}": p for d in dirs for p in sorted((CSRC / d).glob("*.[ch]"))}
    for name in ("fs_fmu.h", "fs_fmi_inst.h", "fs_fmi_inst.c", f"fs_fmu_{kind}.c", f"fs_fmi{fmi}.c"):
        out[f"fmu/{name}"] = CSRC / "fmu" / name
    for p in sorted((CSRC / "fmu" / f"fmi{fmi}").glob("*.h")):
        out[f"fmi{fmi}/{p.name}"] = p
    return out


def xml_text(text: str) -> str:
    """Text from the input for an XML attribute: XML 1.0 allows no control
    character but tab and newline, so each is written <U+XXXX>."""
    return "".join(ch if ch in "\t\n" or (ord(ch) >= 32 and ord(ch) != 127) else f"<U+{ord(ch):04X}>" for ch in text)


def identifier(name: str, kind: str) -> str:
    """The FMU's modelIdentifier: a C identifier from the scenario's name."""
    ident = re.sub(r"\W", "_", f"{name}_{kind}", flags=re.ASCII)
    return ident if re.match(r"[A-Za-z_]", ident) else "fs_" + ident


def host_platform(fmi: int) -> tuple[str, str]:
    """(binaries folder, library suffix) for this machine, or a ConfigError."""
    key = (platform.system(), platform.machine())
    if key not in PLATFORMS or PLATFORMS[key][fmi == 2] is None:
        raise ConfigError("--fmi", fmi, f"binaries for {key[0]} {key[1]} are not built here (FMI {fmi}.0 names no "
                          "folder for it, or fullspeed does not know it); the FMU's sources build elsewhere", None)
    tuple3, folder2, suffix = PLATFORMS[key]
    return (tuple3 if fmi == 3 else folder2), suffix


# Objects of the checkout's C files (control, plant, sim: no generated header
# reaches them) by (compiler, flags, file, every header of csrc): an export of
# both FMUs, or a test session's four, compiles each once.
_OBJECTS: dict[str, bytes] = {}


def _compiler() -> str:
    return os.environ.get("CC") or shutil.which("cc") or "cc"


def _compile(src: Path, name: str, what: str) -> Path:
    """sources/name compiled to an object beside it (from the cache where it may be)."""
    cc, obj = _compiler(), src / (name + ".o")
    key = None
    if name.split("/")[0] in ("control", "plant", "sim") and not name.endswith(("fs_config.c", "fs_system.c")):
        h = hashlib.sha256("\0".join([cc, *CFLAGS, name]).encode())
        h.update((src / name).read_bytes())
        for header in sorted(CSRC.rglob("*.h")):
            h.update(header.read_bytes())
        key = h.hexdigest()
        if key in _OBJECTS:
            obj.write_bytes(_OBJECTS[key])
            return obj
    cmd = [cc, *CFLAGS, "-c", str(src / name), "-o", str(obj)]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"building {what} failed at {name} ({cc}):\n{done.stderr[-4000:]}")
    if key is not None:
        _OBJECTS[key] = obj.read_bytes()
    return obj


def _link(src: Path, names: list[str], lib_path: Path, what: str) -> None:
    """The shared library of the C files names in sources/ src, compiled in parallel."""
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        objs = list(pool.map(lambda n: _compile(src, n, what), names))
    cmd = [_compiler(), *CFLAGS, "-shared", "-o", str(lib_path), *map(str, objs), "-lm"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"linking {what} failed ({cmd[0]}):\n{done.stderr[-4000:]}")


def build_fmu(sc: Scenario, kind: str, fmi: int, out: Path) -> Path:
    """Build out/<scenario>-<kind>.fmu (kind: drive or system; fmi: 3 or 2)."""
    if kind == "drive" and sc.data["converter"]["kind"] == "imc":
        raise ConfigError("converter.kind", "imc", "the drive's FMU has no outputs for the matrix converter's rectifier "
                          "intervals; export the closed loop (--fmu-system) or an inverter scenario", sc.source)
    folder, suffix = host_platform(fmi)
    path = out_path(out, f"{sc.name}-{kind}", "scenario name", sc.source, ".fmu")
    cfg, _keep = build_config(sc)
    token = "{" + str(uuid.uuid4()) + "}"
    ident = identifier(sc.name, kind)
    files = {k: p.read_text() for k, p in _sources(kind, fmi).items()}
    files["fmu/fs_fmu_vars.h"], files["fmu/fs_fmu_vars.c"] = vars_c(kind, sc, cfg, fmi, token)
    if kind == "drive":
        files["control/fs_config.h"], files["control/fs_config.c"] = render(sc, "fs_config")
    else:
        files["sim/fs_system.h"], files["sim/fs_system.c"] = system_c(sc, cfg)
    names = sorted(files)
    with tempfile.TemporaryDirectory(prefix="fullspeed-fmu-") as tmp:
        src = Path(tmp) / "sources"
        for name, text in files.items():
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            (src / name).write_text(text)
        lib_path = Path(tmp) / f"{ident}{suffix}"
        _link(src, [n for n in names if n.endswith(".c")], lib_path, path.name)
        md = model_description(kind, sc, cfg, fmi, ident, token, names)
        bd = build_description(ident, names)

        def write(tmp_zip: Path):
            with zipfile.ZipFile(tmp_zip, "w", zipfile.ZIP_DEFLATED) as zf:
                zf.writestr("modelDescription.xml", md)
                zf.write(lib_path, f"binaries/{folder}/{ident}{suffix}")
                for name in names:
                    zf.writestr(f"sources/{name}", files[name])
                zf.writestr("sources/buildDescription.xml", bd)
                zf.writestr("documentation/licenses/fmi-headers.txt", FMI_LICENSE_NOTE)
        write_with(path, write)
    return path


FMI_LICENSE_NOTE = ("sources/fmi2/*.h and sources/fmi3/*.h are the FMI standard's headers, Copyright the MODELISAR "
                    "consortium and the Modelica Association Project \"FMI\", licensed under the 2-Clause BSD License; "
                    "the licence text is at the head of each file.\n")


def export_fmu(scenario, out: str | Path, kinds=("drive",), fmi: int = 3, overrides: dict | None = None) -> list[Path]:
    """Write out/<name>-drive.fmu and/or out/<name>-system.fmu for a scenario
    (name, path or Scenario), FMI 3.0 or 2.0."""
    if fmi not in (2, 3):
        raise ConfigError("--fmi", fmi, "must be 2 or 3 (FMI 2.0 or 3.0)", None)
    bad = [k for k in kinds if k not in MODELS]
    if bad or not kinds:
        raise ConfigError("kind", bad or kinds, f"must be among {sorted(MODELS)}", None)
    if not (CSRC / "fmu" / "fs_fmu.h").is_file():
        raise ConfigError("--fmu", str(CSRC), "an FMU is built from the source tree's csrc/, which is not here (an "
                          "installed package without it): export from a clone", None)
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario, overrides or None)
    out = out_folder(out)
    for k in kinds:
        host_platform(fmi)
        out_path(out, f"{sc.name}-{k}", "scenario name", sc.source, ".fmu")   # before any build
    return [build_fmu(sc, k, fmi, out) for k in kinds]
