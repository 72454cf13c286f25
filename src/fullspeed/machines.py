"""Machine parameter sets: the catalog (machines/*.toml) and inline tables."""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from .errors import ConfigError
from .schema import ANY, C, I, NONNEG, POS, S, T, Spec, validate
from .units import rpm_to_rad_s

MAGNETIC = {
    "model": C("linear", "algebraic", "fluxmap", default="linear"),
    "a_dd": NONNEG(0.0), "a_qq": NONNEG(0.0), "a_dq": NONNEG(0.0),
    "S": NONNEG(0.0), "T": NONNEG(0.0), "U": NONNEG(0.0), "V": NONNEG(0.0),
    # fluxmap: psi_d[k][l], psi_q[k][l] at currents i_d[k], i_q[l] (regular grids)
    "i_d": Spec("any", None), "i_q": Spec("any", None),
    "psi_d": Spec("any", None), "psi_q": Spec("any", None),
    "source": S(""), "reason": S(""),
}

BENCH = {
    "u_dc": POS(), "f_pwm": POS(), "t_dead": NONNEG(0.0),
    "sampling": C("single", "double", default="single"),
    "i_max": POS(), "i_trip": POS(), "i_lim": POS(None),
    "adc_bits": I(12, 0, 24), "adc_range": POS(), "noise_i": NONNEG(0.0),
    "encoder_bits": I(0, 0, 32),
    "bw_current": POS(), "bw_speed": POS(), "bw_pll": POS(), "bw_pll_smo": POS(None),
    # the indirect matrix converter's grid and input filter (zou2021)
    "u_dc_min": POS(None), "u_grid_ll_rms": POS(None), "f_grid": POS(None),
    "l_filter": POS(None), "r_filter": POS(None), "c_filter": POS(None),
    "reasons": Spec("any", {}),
}

# The third-harmonic (d3-q3) plane of a five-phase machine, linear:
# psi_d3 = L_d3 i_d3 + psi_f3, psi_q3 = L_q3 i_q3 (yu2022 eq. (1)).
THIRD_HARMONIC = {"L_d3": POS(), "L_q3": POS(), "psi_f3": NONNEG()}

MACHINE = {
    "name": S(), "description": S(""), "source": S(""),
    "kind": C("ipmsm", "spmsm"),
    "phases": Spec("choice", 3, choices=(3, 5)),
    "pole_pairs": I(lo=1, hi=100),
    "electrical": T({"R_s": NONNEG(), "L_d": POS(), "L_q": POS(), "psi_f": NONNEG()}),
    "mechanical": T({"J": POS(), "B": NONNEG(0.0), "T_coulomb": NONNEG(0.0)}),
    "rated": T({"torque": POS(), "current": POS(), "speed_rpm": POS(),
                "voltage": POS(None), "power": POS(None)}),
    "magnetic": T(MAGNETIC, default={}),
    "bench": T(BENCH),
    # tables owned by the estimator issues, validated where they are used
    "injection": ANY, "blending": ANY, "paper_gains": ANY,
    "third_harmonic": ANY, "bench_experiment": ANY, "derivations": ANY,
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
    magnetic: dict
    bench: dict
    extra: dict = field(default_factory=dict)   # injection, blending, ... as given
    source: str = ""
    description: str = ""
    # five phases: the third-harmonic plane from [third_harmonic] (0 for three phases)
    L_d3: float = 0.0       # H
    L_q3: float = 0.0       # H
    psi_f3: float = 0.0     # Wb

    def mtpa_torque(self, i: float) -> float:
        """Torque on the MTPA locus at current magnitude i (linear model), from
        the controller's own MTPA table (csrc/control/fs_mtpa.c)."""
        from ._core import ffi, lib

        m = ffi.new("fs_mtpa *")
        cfg = ffi.new("fs_mtpa_config *", {"L_d": self.L_d, "L_q": self.L_q, "psi_f": self.psi_f,
                                           "pole_pairs": self.pole_pairs, "i_max": i,
                                           "phases": self.phases})
        if lib.fs_mtpa_init(m, cfg) != lib.FS_OK:
            raise ValueError(f"no MTPA torque for {self.name} at {i:g} A")
        return float(m.T[lib.FS_MTPA_N - 1])


def catalog_names() -> list[str]:
    root = resources.files("fullspeed") / "machines"
    return sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".toml"))


def catalog_data(name: str, source: str | None = None) -> dict:
    names = catalog_names()
    if name not in names:
        raise ConfigError("machine.catalog", name, "unknown machine; the catalog has " + ", ".join(names), source)
    root = resources.files("fullspeed") / "machines"
    return tomllib.loads((root / f"{name}.toml").read_text())


def machine_from_dict(data: dict, source: str | None = None, prefix: str = "machine") -> Machine:
    d = validate(data, MACHINE, prefix, source)
    e, m, r, b = d["electrical"], d["mechanical"], d["rated"], d["bench"]
    if d["kind"] == "ipmsm" and not e["L_d"] < e["L_q"]:
        raise ConfigError(f"{prefix}.electrical.L_d", e["L_d"],
                          f"an interior-magnet machine needs L_d < L_q (L_q = {e['L_q']:g})", source)
    if d["kind"] == "spmsm" and not math.isclose(e["L_d"], e["L_q"], rel_tol=0.05):
        raise ConfigError(f"{prefix}.electrical.L_q", e["L_q"],
                          f"a surface-magnet machine needs L_q = L_d ({e['L_d']:g}) within 5 %", source)
    if not b["i_trip"] > b["i_max"]:
        raise ConfigError(f"{prefix}.bench.i_trip", b["i_trip"], f"must be > bench.i_max ({b['i_max']:g})", source)
    if b["adc_bits"] and not b["adc_range"] >= b["i_trip"]:
        raise ConfigError(f"{prefix}.bench.adc_range", b["adc_range"], f"must be >= bench.i_trip ({b['i_trip']:g})", source)
    if b["t_dead"] >= 0.5 / b["f_pwm"]:
        raise ConfigError(f"{prefix}.bench.t_dead", b["t_dead"], f"must be shorter than half the PWM period ({0.5 / b['f_pwm']:g} s)", source)
    th = {"L_d3": 0.0, "L_q3": 0.0, "psi_f3": 0.0}
    if d["phases"] == 5:
        if not isinstance(d.get("third_harmonic"), dict):
            raise ConfigError(f"{prefix}.third_harmonic", d.get("third_harmonic", "missing"),
                              "a five-phase machine needs a [third_harmonic] table with L_d3 > 0 (H), "
                              "L_q3 > 0 (H) and psi_f3 >= 0 (Wb)", source)
        th = validate(d["third_harmonic"], THIRD_HARMONIC, f"{prefix}.third_harmonic", source)
    extra = {k: d[k] for k in ("injection", "blending", "paper_gains", "third_harmonic", "bench_experiment") if d.get(k) is not None}
    return Machine(
        name=d["name"], kind=d["kind"], phases=d["phases"], pole_pairs=d["pole_pairs"],
        R_s=e["R_s"], L_d=e["L_d"], L_q=e["L_q"], psi_f=e["psi_f"],
        J=m["J"], B=m["B"], T_coulomb=m["T_coulomb"],
        T_rated=r["torque"], i_rated=r["current"], w_m_rated=rpm_to_rad_s(r["speed_rpm"]),
        magnetic=d["magnetic"], bench=b, extra=extra, source=d["source"], description=d["description"],
        L_d3=th["L_d3"], L_q3=th["L_q3"], psi_f3=th["psi_f3"],
    )


def load_machine(name_or_path: str | Path) -> Machine:
    p = Path(name_or_path)
    if p.suffix == ".toml" and p.exists():
        return machine_from_dict(tomllib.loads(p.read_text()), str(p))
    return machine_from_dict(catalog_data(str(name_or_path)), f"machines/{name_or_path}.toml")
