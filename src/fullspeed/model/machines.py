"""Machine parameter sets as given: the catalog (machines/*.toml), machine
files and inline tables, validated field by field. The bench's limits and
bandwidths a file leaves out stay None here: design.machine forms them (and
checks what depends on them)."""
from __future__ import annotations

import math
import tomllib
import warnings
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from .errors import ConfigError
from .files import package_names
from .fluxmap import FluxMapWarning, consistency_warnings, gross_disagreement, load_map
from .schema import NOTES, C, F, I, N, NONNEG, POS, S, T, Spec, even_grid, finite_number, read_toml, validate
from .units import rpm_to_rad_s

MAGNETIC = {
    "model": C("linear", "algebraic", "fluxmap", default="linear", doc="linear: L_d, L_q, psi_f of [electrical]; algebraic saturation; a flux map (or file = ...)"),
    # the algebraic model's coefficients and exponents (fs_magnetic.h)
    "a_dd": NONNEG(0.0, hi=1e100, doc="algebraic: d self-saturation coefficient (fs_magnetic.h)"),
    "a_qq": NONNEG(0.0, hi=1e100, doc="algebraic: q self-saturation coefficient"),
    "a_dq": NONNEG(0.0, hi=1e100, doc="algebraic: cross-saturation coefficient"),
    "S": NONNEG(0.0, hi=20.0, doc="algebraic: exponent of a_dd"), "T": NONNEG(0.0, hi=20.0, doc="algebraic: exponent of a_qq"),
    "U": NONNEG(0.0, hi=20.0, doc="algebraic: d exponent of a_dq"), "V": NONNEG(0.0, hi=20.0, doc="algebraic: q exponent of a_dq"),
    # fluxmap: psi_d[k][l], psi_q[k][l] at currents i_d[k], i_q[l] (regular grids)
    "i_d": Spec("any", None, doc="A, fluxmap: the d currents, rising in even steps"), "i_q": Spec("any", None, doc="A, fluxmap: the q currents, rising in even steps"),
    "psi_d": Spec("any", None, doc="Wb, fluxmap: psi_d[k][l] at (i_d[k], i_q[l])"), "psi_q": Spec("any", None, doc="Wb, fluxmap: psi_q[k][l] at (i_d[k], i_q[l])"),
    "source": S("", doc="where the magnetics come from"), "reason": S("", doc="why this model"),
    "file": S(None, doc="a flux map file, .csv or SyR-e .mat (fullspeed.model.fluxmap), beside the machine file; sets model, i_d, i_q, psi_d, psi_q"),
    "torque": Spec("any", None, doc="N m, torque[k][l] at (i_d[k], i_q[l]) where the map file gives it (checked against the fluxes)"),
}

# Bounds are what a drive on a bench can be: generous, but they keep every
# value finite in float32 and every run a finite number of steps.
BENCH = {
    "u_dc": POS(hi=1e5, doc="V"), "f_pwm": F(lo=100.0, hi=1e6, doc="Hz"), "t_dead": NONNEG(0.0, hi=1e-4, doc="s"),
    "sampling": C("single", "double", default="single", doc="current sampling once or twice per PWM period"),
    # left out: designed (design.rules; `fullspeed design` prints them with their reasons)
    "i_max": POS(None, hi=1e5, doc="A, current limit; default designed: 1.5 x rated"),
    "i_trip": POS(None, hi=1e5, doc="A, overcurrent trip; default designed: 1.25 x i_max"), "i_lim": POS(None, hi=1e5, doc="A, imc: I_lim of zou2021 eq. (33); optional"),
    "adc_bits": I(12, 0, 24, doc="current ADC resolution (0: ideal)"), "adc_range": POS(None, hi=1e6, doc="A, the ADC's +- full scale; default designed: 1.2 x i_trip"),
    "noise_i": NONNEG(0.0, hi=1e4, doc="A, rms current-sensor noise"), "encoder_bits": I(0, 0, 32, doc="encoder resolution (0: ideal)"),
    "bw_current": POS(None, hi=1e6, doc="rad/s, current loop; default designed from the sampling rate"),
    "bw_speed": POS(None, hi=1e6, doc="rad/s, speed loop; default designed: bw_current / 30"),
    "bw_pll": POS(None, hi=1e6, doc="rad/s, encoder PLL; default designed from bw_speed"),
    "bw_pll_smo": POS(None, hi=1e6, doc="rad/s, the back-EMF observer's PLL; default designed from the blending band"),
    # the indirect matrix converter's grid and input filter (zou2021)
    "u_dc_min": POS(None, hi=1e5, doc="V, imc: optional"), "u_grid_ll_rms": POS(None, hi=1e5, doc="V, imc: grid line-line rms; optional"),
    "f_grid": POS(None, hi=1e4, doc="Hz, imc: optional"), "l_filter": POS(None, hi=10.0, doc="H, imc input filter: optional"),
    "r_filter": POS(None, hi=1e6, doc="ohm, imc input filter: optional"), "c_filter": POS(None, hi=10.0, doc="F, imc input filter: optional"),
    "reasons": NOTES(doc="why each value (text by field name)"),
}

# The third-harmonic (d3-q3) plane of a five-phase machine, linear:
# psi_d3 = L_d3 i_d3 + psi_f3, psi_q3 = L_q3 i_q3 (yu2022 eq. (1)).
THIRD_HARMONIC = {"L_d3": F(lo=1e-8, hi=10.0), "L_q3": F(lo=1e-8, hi=10.0), "psi_f3": NONNEG(hi=100.0)}

# The two-node thermal model (csrc/plant/fs_thermal.h): winding and
# magnets, their thermal resistances and heat capacities, the temperature
# [electrical] holds at, and the losses' and parameters' coefficients.
THERMAL = {
    "T_ref": F(20.0, lo=-50.0, hi=300.0, doc="degC: R_s and psi_f of [electrical] are at this temperature"),
    "T_amb": F(40.0, lo=-50.0, hi=300.0, doc="degC: ambient (housing sink, coolant)"),
    "R_wa": POS(hi=1e4, doc="K/W, winding to ambient"), "R_wm": POS(hi=1e4, doc="K/W, winding to magnets"),
    "R_ma": POS(hi=1e4, doc="K/W, magnets to ambient"),
    "C_w": POS(hi=1e9, doc="J/K, winding node"), "C_m": POS(hi=1e9, doc="J/K, magnet node"),
    "alpha_cu": F(0.00393, lo=-0.05, hi=0.05, doc="1/K, copper's resistance coefficient"),
    "alpha_br": F(-0.0012, lo=-0.05, hi=0.05, doc="1/K, the magnet's remanence coefficient"),
    "k_rotor": F(0.1, lo=0.0, hi=1.0, doc="share of the iron loss ([losses]) in the rotor (heats the magnets)"),
    "reasons": NOTES(doc="why each value (text)"),
}

# The iron loss (csrc/plant/fs_losses.h), for the thermal model's heat and,
# where a scenario draws it ([losses] iron), the plant's drag: hysteresis and
# eddy currents, P_fe = P_fe_ref [k_hyst f r^beta + (1 - k_hyst) f^2 r^2],
# f the speed over speed_fe_rpm, r the stator flux over psi_f. The
# mechanical losses are [mechanical] B and T_coulomb.
LOSSES = {
    "P_fe_ref": NONNEG(hi=1e9, doc="W, iron loss at speed_fe_rpm with the magnet's flux"),
    "speed_fe_rpm": POS(hi=1e6, doc="the speed P_fe_ref is at"),
    "k_hyst": F(lo=0.0, hi=1.0, doc="hysteresis share of P_fe_ref (the rest: eddy currents)"),
    "beta": F(2.0, lo=1.0, hi=3.0, doc="the hysteresis loss's flux exponent (Steinmetz; the eddy loss's is 2)"),
    "source": S(doc="where the coefficients come from: a published source, or \"assumed\" and how they were formed"),
    "reasons": NOTES(doc="why each value (text)"),
}

# The converter's power semiconductors (csrc/plant/fs_losses.h): a named
# module's transistor and diode, each the straight line of its output
# characteristic (threshold and slope resistance) at the junction
# temperature of the values, and the commutation energies at (I_ref,
# V_ref), scaled by power laws of the current and the voltage. The matrix
# converter's rectifier and inverter stages use the same devices.
CONVERTER = {
    "module": S(doc="the module the values come from: maker and part number"),
    "source": S(doc="its datasheet (and revision), the junction temperature the values are at, what was derived"),
    "kind": C("igbt", "mosfet", default="igbt", doc="mosfet: the channel conducts both ways, its body diode only in the dead time"),
    "u_t": NONNEG(hi=100.0, doc="V, the transistor's threshold (V_CE0; a MOSFET: 0)"),
    "r_t": NONNEG(hi=100.0, doc="ohm, the transistor's slope resistance (r_CE; a MOSFET: R_DS(on))"),
    "u_d": NONNEG(hi=100.0, doc="V, the diode's threshold (V_F0)"),
    "r_d": NONNEG(hi=100.0, doc="ohm, the diode's slope resistance"),
    "E_on": NONNEG(hi=100.0, doc="J, the transistor's turn-on energy at I_ref and V_ref"),
    "E_off": NONNEG(hi=100.0, doc="J, its turn-off energy there"),
    "E_rr": NONNEG(hi=100.0, doc="J, the diode's reverse-recovery energy there"),
    "I_ref": POS(hi=1e6, doc="A, the current of the datasheet's energies"),
    "V_ref": POS(hi=1e6, doc="V, their voltage"),
    "k_i_t": F(1.0, lo=0.0, hi=3.0, doc="the transistor energies' current exponent (Semikron's application manual: about 1)"),
    "k_v_t": F(1.35, lo=0.0, hi=3.0, doc="their voltage exponent (IGBTs: 1.3 to 1.4)"),
    "k_i_d": F(0.6, lo=0.0, hi=3.0, doc="the recovery energy's current exponent (about 0.6)"),
    "k_v_d": F(0.6, lo=0.0, hi=3.0, doc="its voltage exponent (about 0.6)"),
    "reasons": NOTES(doc="why each value, and how it was read or derived (text)"),
}

# Spatial harmonics (csrc/plant/fs_pmsm.h): the back-EMF's harmonics of
# orders 5, 7, 11, 13 relative to its fundamental (signed: 1 = in phase at
# theta = 0), the saliency harmonics as the flux transform's terms of orders
# 6 and 12 (dd, qq, dq), and the cogging torque.
HARMONICS = {
    **{f"emf{n}": F(0.0, lo=-0.5, hi=0.5, doc=f"E_{n} / E_1") for n in (5, 7, 11, 13)},
    **{f"sal{k}_{ax}": F(0.0, lo=-0.2, hi=0.2, doc=f"the flux transform's {ax} term of order {k} (relative)")
       for k in (6, 12) for ax in ("dd", "qq", "dq")},
    "cogging_Nm": NONNEG(0.0, hi=1e6, doc="N m, amplitude"),
    "cogging_order": Spec("choice", 12, choices=(6, 12, 18, 24), doc="per electrical turn: LCM(slots, 2p) / p"),
    "reasons": NOTES(doc="why each value (text)"),
}

# The estimators' defaults on this machine (scenario [injection] and
# [blending] fields left out come from here), and the paper's printed gains.
INJECTION = {
    "kind": C("rotating", "square", default="rotating", doc="the carrier these defaults are for"),
    "u_h": POS(None, hi=1e4, doc="V, carrier amplitude; default designed (rotating)"), "f_h": POS(None, hi=1e5, doc="Hz, carrier; default designed (rotating)"),
    "bw_pll": POS(None, hi=1e6, doc="rad/s, square wave's PLL; optional"),
    "xcomp_paper": N(None, doc="swvi: the fitted error polynomial, el.rad in i_q (A)"),
}
# the same names as the scenario's [blending], which overrides them
BLENDING = {"lower_rpm": NONNEG(None, hi=1e6, doc="default designed"), "upper_rpm": POS(None, hi=1e6, doc="default designed")}
RENAMED = {"blending.omega_lower_rpm": "blending.lower_rpm", "blending.omega_upper_rpm": "blending.upper_rpm",
           **{f"thermal.{k}": f"losses.{k}" for k in ("P_fe_ref", "speed_fe_rpm", "k_hyst")}}
PAPER_GAINS = {k: (POS if k in ("current_kp_d", "current_kp_q", "speed_kp") else NONNEG)(None, hi=1e9, doc="optional: as printed, V/A, V/(A s), A s/rad, A/rad") for k in (   # the PIs need k_p > 0
    "current_kp_d", "current_ki_d", "current_kp_q", "current_ki_q", "speed_kp", "speed_ki", "pll_kp", "pll_ki")}
BENCH_EXPERIMENT = {k: POS(None, hi=1e6, doc="optional: the experiment's value (SI)") for k in ("u_grid_ll_rms", "f_grid", "u_dc", "u_dc_min", "i_max", "i_lim")}

MACHINE = {
    "name": S(doc="the machine's name"), "description": S("", doc="one line for `fullspeed list`"), "source": S("", doc="where the values come from"),
    "kind": C("ipmsm", "spmsm", doc="interior (L_d < L_q) or surface (L_d = L_q) magnets"),
    "phases": Spec("choice", 3, choices=(3, 5), doc="five: also [third_harmonic]"),
    "pole_pairs": I(lo=1, hi=100, doc="pole pairs"),
    "electrical": T({"R_s": NONNEG(hi=1e3, doc="ohm"), "L_d": F(lo=1e-8, hi=10.0, doc="H"),
                     "L_q": F(lo=1e-8, hi=10.0, doc="H"), "psi_f": NONNEG(hi=100.0, doc="Wb")}),
    "mechanical": T({"J": F(lo=1e-9, hi=1e5, doc="kg m^2"), "B": NONNEG(0.0, hi=1e4, doc="N m s/rad, viscous friction"),
                     "T_coulomb": NONNEG(0.0, hi=1e6, doc="N m, Coulomb friction")}),
    "rated": T({"torque": POS(hi=1e6, doc="N m"), "current": POS(hi=1e5, doc="A, peak phase (rms x sqrt 2)"), "speed_rpm": POS(hi=1e6, doc="rated speed"),
                "voltage": POS(None, hi=1e5, doc="V, peak phase; optional"), "power": POS(None, hi=1e9, doc="W; optional")}),
    "magnetic": T(MAGNETIC, default={}),
    "bench": T(BENCH),
    "injection": T(INJECTION, default=None), "blending": T(BLENDING, default=None),
    "paper_gains": T(PAPER_GAINS, default=None, doc="a paper's printed PI gains (controller.gains = \"paper\")"),
    "third_harmonic": Spec("any", None, doc="five phases: L_d3, L_q3 (H) and psi_f3 (Wb) of the third-harmonic plane"),
    "thermal": T(THERMAL, default=None, doc="the two-node thermal model (csrc/plant/fs_thermal.h), used where a scenario enables it"),
    "harmonics": T(HARMONICS, default=None, doc="spatial harmonics (csrc/plant/fs_pmsm.h), used where a scenario enables them"),
    "losses": T(LOSSES, default=None, doc="the iron loss (csrc/plant/fs_losses.h): heat for [thermal], a drag where a scenario's [losses] iron is on"),
    "converter": T(CONVERTER, default=None, doc="the converter's module (csrc/plant/fs_losses.h), acting where a scenario's [losses] devices is on"),
    "bench_experiment": T(BENCH_EXPERIMENT, default=None, doc="a paper's experimental bench, where it differs"), "derivations": NOTES(doc="how values were derived (text)"),
}


@dataclass(frozen=True)
class Machine:
    """A machine with the bench it is run on (all SI)."""
    name: str
    kind: str
    phases: int
    pole_pairs: int
    R_s: float
    L_d: float
    L_q: float
    psi_f: float
    J: float
    B: float
    T_coulomb: float
    T_rated: float
    i_rated: float          # A peak
    w_m_rated: float        # rad/s
    u_rated: float | None   # V peak phase, the rated voltage where given ([rated] voltage)
    magnetic: dict
    bench: dict
    extra: dict = field(default_factory=dict)   # injection, blending, ... as given
    source: str = ""
    description: str = ""
    # five phases: the third-harmonic plane from [third_harmonic] (0 for three phases)
    L_d3: float = 0.0       # H
    L_q3: float = 0.0       # H
    psi_f3: float = 0.0     # Wb
    thermal: dict | None = None   # [thermal] as validated (THERMAL), None without one
    harmonics: dict | None = None  # [harmonics] as validated (HARMONICS), None without one
    losses: dict | None = None     # [losses] as validated (LOSSES), None without one
    converter: dict | None = None  # [converter] as validated (CONVERTER), None without one
    # the bench's limits and bandwidths as given or designed (design.rules.Value, by key;
    # empty until design.machine.design_machine has formed them)
    design: dict = field(default_factory=dict)
    P_rated: float | None = None  # W, the rated power where given ([rated] power)
    origin: str | None = None     # where its table was read (a machine file, the scenario holding it): errors name it
    prefix: str = "machine"       # the fields' prefix in that file's errors


def catalog_names() -> list[str]:
    return package_names("machines")


# The catalog's machines that are the papers' (and the bench's peer), beside the published ones
PAPER_MACHINES = ("motulator-2kw-ipmsm", "yang2022", "yu2022", "zou2021")


def published_machines() -> list[str]:
    """The catalog's published machines (src/fullspeed/machines: each value with
    its source), the papers' left out: what claim B-REAL runs."""
    return [n for n in catalog_names() if n not in PAPER_MACHINES]


def catalog_data(name: str, source: str | None = None) -> dict:
    names = catalog_names()
    if name not in names:
        raise ConfigError("machine.catalog", name, "unknown machine; the catalog has " + ", ".join(names), source)
    root = resources.files("fullspeed") / "machines"
    data = tomllib.loads((root / f"{name}.toml").read_text())
    mag = data.get("magnetic")
    if isinstance(mag, dict) and isinstance(mag.get("file"), str) and not Path(mag["file"]).is_absolute():
        mag["file"] = str(Path(str(root)) / mag["file"])   # a catalog machine's flux map sits beside its file
    return data


def parse_machine(data: dict, source: str | None = None, prefix: str = "machine") -> Machine:
    """A machine table validated as given: the bench's designed fields
    (left out of the file) are None (design.machine.machine_from_dict
    forms them)."""
    for old, new in RENAMED.items():   # a renamed field is refused with its new name
        table, key = old.split(".")
        given = data.get(table) if isinstance(data, dict) else None
        if isinstance(given, dict) and key in given:
            raise ConfigError(f"{prefix}.{old}", given[key], f"is now called {prefix}.{new} (one name for one setting, as in a scenario)", source)
    d = validate(data, MACHINE, prefix, source)
    if d["magnetic"]["file"] is not None:
        d["magnetic"] = _magnetic_file(d["magnetic"], f"{prefix}.magnetic", source)
    e, m, r, b = d["electrical"], d["mechanical"], d["rated"], d["bench"]
    if d["kind"] == "ipmsm" and not e["L_d"] < e["L_q"]:
        raise ConfigError(f"{prefix}.electrical.L_d", e["L_d"],
                          f"an interior-magnet machine needs L_d < L_q (L_q = {e['L_q']:g})", source)
    if d["kind"] == "spmsm" and not math.isclose(e["L_d"], e["L_q"], rel_tol=0.05):
        raise ConfigError(f"{prefix}.electrical.L_q", e["L_q"],
                          f"a surface-magnet machine needs L_q = L_d ({e['L_d']:g}) within 5 %", source)
    if b["t_dead"] >= 0.5 / b["f_pwm"]:
        raise ConfigError(f"{prefix}.bench.t_dead", b["t_dead"], f"must be shorter than half the PWM period ({0.5 / b['f_pwm']:g} s)", source)
    th = {"L_d3": 0.0, "L_q3": 0.0, "psi_f3": 0.0}
    if d["phases"] == 5 or d.get("third_harmonic") is not None:   # given: checked whatever the phases
        if not isinstance(d.get("third_harmonic"), dict):
            raise ConfigError(f"{prefix}.third_harmonic", d.get("third_harmonic", "missing"),
                              "must be a [third_harmonic] table with L_d3 > 0 (H), L_q3 > 0 (H) and psi_f3 >= 0 (Wb)"
                              + (" (a five-phase machine needs one)" if d["phases"] == 5 else ""), source)
        d["third_harmonic"] = validate(d["third_harmonic"], THIRD_HARMONIC, f"{prefix}.third_harmonic", source)
        if d["phases"] == 5:
            th = d["third_harmonic"]
    poly = (d["injection"] or {}).get("xcomp_paper")
    if poly is not None and not 1 <= len(poly) <= 4:
        raise ConfigError(f"{prefix}.injection.xcomp_paper", poly, "must list 1 to 4 coefficients (a cubic in i_q at most)", source)
    if d["magnetic"]["model"] == "fluxmap":
        _check_fluxmap(d["magnetic"], f"{prefix}.magnetic", source)
        gross = gross_disagreement(d["magnetic"], e)
        if gross:
            raise ConfigError(f"{prefix}.electrical.{gross[0]}", gross[1], gross[2], source)
        for line in consistency_warnings(d["magnetic"], e, d["pole_pairs"], d["phases"], d["name"]):
            warnings.warn(line, FluxMapWarning, stacklevel=2)
    extra = {k: {kk: vv for kk, vv in d[k].items() if vv is not None}
             for k in ("injection", "blending", "paper_gains", "third_harmonic", "bench_experiment") if d.get(k) is not None}
    return Machine(
        name=d["name"], kind=d["kind"], phases=d["phases"], pole_pairs=d["pole_pairs"],
        R_s=e["R_s"], L_d=e["L_d"], L_q=e["L_q"], psi_f=e["psi_f"],
        J=m["J"], B=m["B"], T_coulomb=m["T_coulomb"],
        T_rated=r["torque"], i_rated=r["current"], w_m_rated=rpm_to_rad_s(r["speed_rpm"]), u_rated=r["voltage"],
        P_rated=r["power"], magnetic=d["magnetic"], bench=b, extra=extra, source=d["source"], description=d["description"],
        L_d3=th["L_d3"], L_q3=th["L_q3"], psi_f3=th["psi_f3"], thermal=d["thermal"],
        harmonics=d["harmonics"], losses=d["losses"], converter=d["converter"], origin=source, prefix=prefix,
    )


def _magnetic_file(mag: dict, field: str, source) -> dict:
    """[magnetic] file = "map.csv": the map read (beside the machine or
    scenario file first), its fields in place of the table's."""
    p = Path(mag["file"])
    if not p.is_absolute() and source and (Path(source).parent / p).is_file():
        p = Path(source).parent / p
    given = [k for k in ("i_d", "i_q", "psi_d", "psi_q", "torque") if mag[k] is not None]
    if given:
        raise ConfigError(f"{field}.{given[0]}", "given", "must be left out with file = ... (the file holds the map)", source)
    return {**mag, **load_map(p, f"{field}.file", source)}


FLUX_MAX = 100.0   # Wb: a flux map's largest |flux| the loader takes (a machine's is a few Wb at most)
FALLING_SHARE = 0.9   # of a map's steps along a current where its flux falls: an axis of the other sign, not a bad point


def _check_fluxmap(mag: dict, prefix: str, source) -> None:
    """A measured flux map: regular current grids and a monotonic, finite
    table psi[k][l] at (i_d[k], i_q[l])."""
    grids = {}
    for name in ("i_d", "i_q"):
        g = mag[name]
        ok = (isinstance(g, list) and 2 <= len(g) <= 1000 and all(finite_number(x) for x in g))
        if not (ok and even_grid(g)):
            raise ConfigError(f"{prefix}.{name}", g, "must be a rising, evenly spaced list of 2..1000 currents (A)", source)
        grids[name] = g
    n_d, n_q = len(grids["i_d"]), len(grids["i_q"])
    for name in ("psi_d", "psi_q"):
        tab = mag[name]
        ok = (isinstance(tab, list) and len(tab) == n_d
              and all(isinstance(row, list) and len(row) == n_q for row in tab)
              and all(finite_number(x) for row in tab for x in row))
        if not ok:
            raise ConfigError(f"{prefix}.{name}", "table", f"must be a {n_d} x {n_q} table (rows i_d, columns i_q) of finite fluxes within +-{FLUX_MAX:g} Wb", source)
        big = max(abs(x) for row in tab for x in row)
        if big > FLUX_MAX:
            # a machine's flux linkage is a few Wb at most; a thousand times that is a map in mWb read as Wb
            unit = (f"; {big / 1000:g} Wb if the file's values are in mWb: say so in its header "
                    f"('{name} [mWb]')") if big <= 1000 * FLUX_MAX else ""
            raise ConfigError(f"{prefix}.{name}", big, f"(its largest |flux|, Wb) must be within +-{FLUX_MAX:g} Wb{unit}",
                              source)
    psi_d, psi_q = mag["psi_d"], mag["psi_q"]
    for k in range(n_d - 1):
        for n in range(n_q):
            if not psi_d[k + 1][n] > psi_d[k][n]:
                raise ConfigError(f"{prefix}.psi_d[{k + 1}][{n}]", psi_d[k + 1][n],
                                  f"must be above psi_d[{k}][{n}] = {psi_d[k][n]:g}: the flux must rise with i_d (a monotonic map)"
                                  + _other_sign(psi_d, 0, "i_d", "psi_d"), source)
    for k in range(n_d):
        for n in range(n_q - 1):
            if not psi_q[k][n + 1] > psi_q[k][n]:
                raise ConfigError(f"{prefix}.psi_q[{k}][{n + 1}]", psi_q[k][n + 1],
                                  f"must be above psi_q[{k}][{n}] = {psi_q[k][n]:g}: the flux must rise with i_q (a monotonic map)"
                                  + _other_sign(psi_q, 1, "i_q", "psi_q"), source)


def _other_sign(tab, axis: int, current: str, flux: str) -> str:
    """Beside a refusal of a map not rising with its current: where the flux
    falls with it over (nearly) the whole map (FALLING_SHARE of its steps),
    that current's axis has the other sign; else nothing."""
    falls = np.mean(np.diff(np.asarray(tab, float), axis=axis) < 0) > FALLING_SHARE
    return (f"; it falls with {current} across the map: its {current} axis (or {flux}) has the other sign, negate one "
            "of them") if falls else ""


def machine_data(name_or_path: str | Path) -> tuple[dict, str]:
    """A machine file (.toml) or a catalog machine by name, as its table and
    where it came from."""
    p = Path(name_or_path)
    if p.suffix == ".toml":
        return read_toml(p, "machine"), str(p)
    return catalog_data(str(name_or_path)), f"machines/{name_or_path}.toml"
