"""Scenarios: a machine, its converter, timing, sensors, controller, load and
reference profiles, read from TOML and validated field by field."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from . import _core
from . import design as dz
from .errors import ConfigError, MissingFields
from .files import path_kind
from .machines import Machine, catalog_data, machine_from_dict
from .schema import MISSING, B, C, F, I, N, NONNEG, POS, P, S, Spec, T, deep_merge, even_grid, finite_number, parse_toml, read_toml, validate
from .units import rpm_to_rad_s

SCENARIO = {
    "name": S(doc="the scenario's name (out/<name>/ by default)"), "description": S("", doc="one line for `fullspeed list`"),
    "paper": S("", doc="the paper it reproduces, if any"),
    "duration": POS(hi=1e4, doc="simulated time, s"),
    "machine": Spec("any", MISSING, doc="a catalog name, a machine file (.toml), or a table: the fields of [machine] below, or catalog = \"name\" and the fields to override"),
    "converter": T({
        "kind": C("inverter", "imc", default="inverter",
                  doc="imc: the indirect matrix converter of zou2021 (grid, LC filter, rectifier and inverter stages)"),
        "inverter": C("averaged", "switching", default=None, doc="default switching; the imc's is averaged per rectifier interval"),
        "u_dc": POS(None, hi=1e5, doc="V; default the machine's bench"), "f_pwm": F(None, lo=100.0, hi=1e6, doc="Hz, PWM carrier; default the machine's bench"),
        "t_dead": NONNEG(None, hi=1e-4, doc="s, dead time; default the machine's bench"), "u_on": NONNEG(0.0, hi=1e3, doc="V, device on-state drop"),
        "r_on": NONNEG(0.0, hi=1e3, doc="ohm, device on-state resistance: the drop is sign(i) u_on + r_on i"),
        # the matrix converter (defaults from the machine's bench)
        "modulation": C("linear", "om1", "om2", default="om2",
                        doc="imc: the highest region (zou2021 sec. 3.3): linear, over-modulation I (CASE 1) or II (CASE 1 and 2)"),
        "grid_ll_rms": POS(None, hi=1e5, doc="V, line-line rms"), "f_grid": POS(None, hi=1e4, doc="Hz"),
        "l_filter": POS(None, hi=10.0, doc="H"), "r_filter": POS(None, hi=1e6, doc="ohm, in parallel with l_filter"), "c_filter": POS(None, hi=10.0, doc="F"),
    }, default={}),
    "timing": T({
        "sampling": C("single", "double", default=None, doc="current sampling once or twice per PWM period; default the machine's bench"),
        "delay": B(True, doc="one control period of computation delay"),
        "h_max": F(None, lo=1e-9, hi=1e-3, doc="longest integration step, s; default from the machine's time constants; at least 1/1000 of the control period"),
    }, default={}),
    "sensors": T({
        "adc_bits": I(None, 0, 24, doc="current ADC resolution (0: ideal); default the machine's bench"),
        "adc_range": POS(None, hi=1e6, doc="A, the ADC's +- full scale; default the machine's bench"),
        "noise_i": NONNEG(None, hi=1e4, doc="A, rms current-sensor noise; default the machine's bench"),
        "encoder_bits": I(None, 0, 32, doc="encoder resolution (0: ideal); default the machine's bench"),
        "seed": I(1, 0, 2**63 - 1, doc="the noise generator's seed"),
    }, default={}),
    "controller": T({
        "mode": C("off", "voltage", "vf", "current", "speed", doc="what the drive controls: nothing, dq voltages, V/f, currents or speed (the references below)"),
        "angle": C("encoder", "true", "smo", "hfi", "blend", "swvi", default="encoder",
                   doc="the loops' angle: encoder, the true angle, the sliding-mode observer, rotating HF injection, their blend, or square-wave injection"),
        "gains": C("designed", "internal_model", "paper", default="designed",
                   doc="PI gains: designed from the bandwidths (the current PIs by pole placement, or internal_model: "
                       "k_p = bw_current L, k_i = bw_current R_s, zou2021's), or the machine's [paper_gains]"),
        "bw_current": POS(None, hi=1e6, doc="rad/s, current loop; default the machine's bench (designed)"),
        "bw_speed": POS(None, hi=1e6, doc="rad/s, speed loop; default the machine's bench (designed)"),
        "bw_pll": POS(None, hi=1e6, doc="rad/s, the encoder's speed PLL; default the machine's bench (designed)"),
        "i_max": POS(None, hi=1e5, doc="A, current limit; default the machine's bench (designed)"),
        "T_max": POS(None, hi=1e6, doc="N m, torque limit; default the MTPA torque at i_max"),
        "dead_time_comp": B(True, doc="compensate the converter's dead time"),
        "i_dead_band": NONNEG(None, hi=1e5, doc="A, below this the dead-time compensation ramps to zero; default 1 % of i_max"),
        "dead_time_predict": B(None, doc="the compensation takes each edge's sign from the current predicted there "
                                         "(fs_dtcomp.h); default true where the drive injects (angle hfi or blend): the "
                                         "carrier's current crosses zero within the period at standstill"),
        "xy_control": B(False, doc="five phases: PI control of the x-y current in the d3-q3 frame at bw_current (fs_xyctrl.h)"),
        "vf_gain": NONNEG(0.0, hi=1e3, doc="V per electrical rad/s"), "vf_boost": NONNEG(0.0, hi=1e5, doc="V, V/f boost at zero frequency"),
        # the controller's parameters relative to the true machine's
        "R_s_scale": F(1.0, lo=0.01, hi=100.0, doc="the controller's R_s over the machine's (a mismatch)"),
        "L_d_scale": F(1.0, lo=0.01, hi=100.0, doc="the controller's L_d over the machine's"),
        "L_q_scale": F(1.0, lo=0.01, hi=100.0, doc="the controller's L_q over the machine's"),
        "psi_f_scale": F(1.0, lo=0.01, hi=100.0, doc="the controller's psi_f over the machine's"),
        "J_scale": F(1.0, lo=0.01, hi=100.0, doc="the controller's J over the machine's"),
        # zou2021 PART_1 voltage-error-feedback flux weakening on top of MTPA
        "flux_weakening": B(False, doc="speed mode: voltage-error-feedback flux weakening above the base speed (zou2021 PART_1)"),
        "fw_top_speed_rpm": POS(None, hi=1e6, doc="w_r,max of eq. (31); default the observer's top speed"),
        "fw_gain": POS(None, hi=1e6, doc="multiplies beta of eq. (31): the loop's dc gain at the top speed (the paper: 1); default designed in the drive's init (fs_drive.h: 50 wound back, 1/4 held)"),
        "fw_cutoff": POS(None, hi=1e6, doc="rad/s, the low-pass of eq. (30); default designed in the drive's init (fs_drive.h; the paper: bw_current)"),
        "fw_excess": C("wound_back", "held", default="wound_back",
                       doc="the over-modulation excess flux weakening feeds on: wound back by the current PIs' anti-windup "
                           "(eq. (30) then holds i_d on a standing current error), or held in their integrals as zou2021's "
                           "eq. (26) reads (with gains = \"internal_model\"; fs_fw.h)"),
        # zou2021 PART_2: the matrix converter's rectifier modulation-depth controller
        "depth_control": B(False, doc="imc, speed mode with flux weakening and modulation om2: alpha from eq. (33); else from the demanded VTR"),
        "i_lim": POS(None, hi=1e5, doc="A, I_lim of eq. (33); default the machine's bench i_lim"),
        # loss of lock of the estimator the loops use (fs_lock.h)
        "lock": C("off", "detect", "stop", "recover", default="detect",
                  doc="detect: traced (lock_resid, lock_lost); stop: the run ends with stop reason loss_of_lock; "
                      "recover: zero current, then the observer's estimate or the start sequence again (fs_drive.h), "
                      "and the stop once lock_retries are spent"),
        "lock_time": POS(0.02, hi=10.0, doc="s off track, net (each step weighted by how far over, up to twice: fs_lock.h), before lock counts as lost"),
        "recover_time": POS(0.05, hi=10.0, doc="s of zero current before a recovery re-acquires"),
        "lock_retries": I(3, 0, 1000, doc="recoveries before a loss of lock stops the run"),
        "param_adapt": B(False, doc="online correction of R_s and psi_f while sensorless (fs_param_adapt.h)"),
        "adapt_time": POS(5.0, hi=1e4, doc="s, its least squares' forgetting time: long against the drive's cycle of operating points, short against the machine's heating"),
    }),
    # the estimator (yang2022 sec. 2); used from `handover` on, running from t = 0
    "observer": T({
        "handover": NONNEG(0.0, hi=1e4, doc="s: the loops switch from the encoder to the observer"),
        "k": NONNEG(0.0, hi=1e6, doc="V; 0: margin x the bound of eq. (18)"),
        "margin": F(1.5, lo=1.0, hi=100.0, lo_open=True, doc="the SMO gain over its bound of eq. (18) when k = 0"),
        "delta": NONNEG(0.0, hi=1e5, doc="A; floored at k Ts / L_d"),
        "cutoff_min_rpm": POS(None, hi=1e6, doc="floor of the adaptive filter's cutoff, as a mechanical speed; default 1/8 of the lower blending speed (yang2022: 20 rpm)"),
        "bw_pll": POS(None, hi=1e6, doc="rad/s; default from the machine's bench"),
        "valid_rpm": NONNEG(None, hi=1e6, doc="the observer's estimate is trusted above this speed; default 5/8 of the lower blending speed (yang2022: 100 rpm)"),
        "top_speed_rpm": POS(None, hi=1e6, doc="for the gain bound; default 1.5 x rated"),
        "lag": C("exact", "paper", default="exact", doc="form = \"paper\": the adaptive filter's phase lag compensated exactly, or by pi/4 as the paper writes it"),
        "form": C("paper", "tracking", default="tracking",
                  doc="tracking: fullspeed's, exact in discrete time, with a motion observer on the measured torque whose "
                      "bandwidth follows the EMF (fs_smo.h); paper: the SMO and PLL of yang2022 sec. 2 (its scenarios pin it)"),
        # how the sensorless drive starts: on the encoder until `handover`, or
        # sensorless from standstill with an I/f start
        "start": C("encoder", "if", default="encoder", doc="sensorless start: on the encoder until handover, or I/f from standstill"),
        "i_start": POS(None, hi=1e5, doc="A; default half of i_max"),
        "start_accel_rpm_s": POS(None, hi=1e9, doc="frame acceleration; default from a quarter of the start current's torque"),
        "start_handover_rpm": POS(None, hi=1e6, doc="the loops take the observer here; default twice valid_rpm"),
    }, default={}),
    # HF voltage injection: rotating (yang2022 sec. 3) for angle = "hfi" or
    # "blend", square-wave (yu2022 sec. 2) for angle = "swvi"
    "injection": T({
        "u_h": POS(None, hi=1e4, doc="V; default the machine's [injection]"),
        "f_h": POS(None, hi=1e5, doc="Hz; default the machine's [injection], else designed: f_s / 10, fewer samples a period where the current loop would act on the carrier's sidebands (fullspeed design); at most a quarter of the sampling rate"),
        "bw_filter_p": POS(None, hi=1e6, doc="rad/s, SRFF at +w_h; default w_h / 20 (fs_hfi.h)"),
        "bw_filter_n": POS(None, hi=1e6, doc="rad/s, SRFF at -w_h + 2 w_r; default w_h / 20"),
        "bw_observer": POS(None, hi=1e6, doc="rad/s, motion observer; default bw_filter_n (tracking = \"paper\": bw_filter_n / 5)"),
        "tracking": C("paper", "lag", default="lag",
                      doc="hfi/blend: lag designs the motion observer with the negative-sequence filter's lag in its loop "
                          "(fs_motion_obs.h: five times faster, less error under a load it does not know), the loops' "
                          "speed from a second observer at the paper's rule on its angle (fs_hfi.h); paper: Fig. 5 on "
                          "the error as it is (the yang2022 scenarios pin it)"),
        "leak": C("keep", "remove", default=None,
                  doc="hfi/blend: remove takes the fundamental's leak out of the negative carrier (fs_hfi_filter.h: no "
                      "load-proportional bias); keep: the paper's filter; default remove with tracking = \"lag\" (whose "
                      "observer is designed for the double lag it makes), keep with \"paper\" (whose observer, blind to "
                      "that lag, rings with it)"),
        "xcomp": Spec("any", None, doc="cross-saturation table {i_q = [A...], delta_deg = [...]} on an even grid, or a TOML file holding it, or (swvi) \"paper\": the machine's fitted error polynomial"),
        "stop_rpm": POS(None, hi=1e6, doc="blend: the injection stops above this speed (resumes below 0.9 of it); default 1.2 x the upper blending speed"),
        "sequence": C("optimized", "conventional", default="optimized", doc="swvi: the time sequence of yu2022 sec. 3.2"),
        "bw_pll": POS(None, hi=1e6, doc="swvi: PLL bandwidth, rad/s (k_p = 2 w_b, k_i = w_b^2); default the machine's [injection]"),
        "carrier": B(True, doc="swvi: false keeps the loops' timing without the carrier (comparison runs, on the encoder)"),
    }, default={}),
    "polarity": T({
        "enabled": B(True, doc="detect the magnet polarity before starting sensorless on injection"),
        "i_pulse": POS(None, hi=1e5, doc="A, d-current pulses; default half of controller.i_max"),
        "t_lock": NONNEG(None, hi=10.0, doc="s, the estimator settles first: >= 6 / w_b_n + 2 / w_o (fade-in, filters, observer; w_o the slower observer's, with tracking = \"lag\" the speed's); default 0.06 s or that bound x 1.2, the longer"),
        "t_pulse": POS(None, hi=10.0, doc="s, each pulse: >= 6 / w_b_p (the carrier amplitude settles in the first half); default 0.02 s or that bound x 1.2, the longer"),
        "i_pulse_max": POS(None, hi=1e5, doc="A, the largest pulse of the retries when the first pair decides nothing; default controller.i_max less the carrier's peak"),
    }, default={}),
    "blending": T({
        "lower_rpm": NONNEG(None, hi=1e6, doc="eq. (28), the injection alone below; default the machine's [blending], else designed"),
        "upper_rpm": POS(None, hi=1e6, doc="eq. (28), the back-EMF observer alone above; default the machine's [blending], else designed"),
        "bw_observer": POS(None, hi=1e6, doc="rad/s, the motion observer after the blend (Fig. 6); default that of the injection's (with injection.tracking = \"lag\": the paper's rule, bw_filter_n / 5)"),
        "gate": B(True, doc="the SMO's weight only once it has converged, the injection stopped only then (fs_blend.h); false: eq. (28) alone (the paper's)"),
    }, default={}),
    "load": T({
        "kind": C("torque", "speed", "speed_pi", "brake", default="torque",
                  doc="brake: a passive brake (powder, eddy current), torque = its magnitude against the motion"),
        "torque": P(0.0, hi=1e6, doc="N m, kind torque or brake"), "speed_rpm": P(0.0, hi=1e6, doc="kind speed or speed_pi: the speed the load holds"),
        "torque_pu": P(None, hi=100.0, doc="the torque as a fraction of the machine's rated torque (instead of torque)"),
        "bandwidth": POS(100.0, hi=1e6, doc="load machine speed loop, rad/s"), "J_load": NONNEG(0.0, hi=1e5, doc="kg m^2, the load machine's inertia (speed_pi)"),
    }, default={}),
    "references": T({
        "speed_rpm": P(0.0, hi=1e6, doc="mode speed"), "i_d": P(0.0, hi=1e5, doc="A, mode current"), "i_q": P(0.0, hi=1e5, doc="A, mode current"),
        "speed_pu": P(None, hi=100.0, doc="the speed as a fraction of the machine's rated speed (instead of speed_rpm)"),
        "u_d": P(0.0, hi=1e5, doc="V, mode voltage"), "u_q": P(0.0, hi=1e5, doc="V, mode voltage"),
        "frame_rpm": P(0.0, hi=1e6, doc="modes voltage and vf: the frame's speed"),
    }, default={}),
    "initial": T({"theta_e_deg": F(0.0, -360.0, 360.0, doc="the rotor's angle at t = 0"), "speed_rpm": F(0.0, -1e6, 1e6, doc="the rotor's speed at t = 0")}, default={}),
    # faults of the drive's hardware, each from its time on (fs_sim.h); a load
    # impact is a [load] torque profile
    "faults": T({
        "t_sensor": NONNEG(0.0, hi=1e4, doc="s: the current-sensor errors act from here"),
        "i_offset": N([], doc="A added to each phase's sensed current (a, b, c, ...)"),
        "i_gain": N([], doc="each phase sensor's relative gain error (0.1 reads 10 % high)"),
        "open_phase": C("none", "a", "b", "c", default="none", doc="three phases on the inverter"),
        "t_open": NONNEG(0.0, hi=1e4, doc="s"),
        "t_encoder_stop": POS(None, hi=1e4, doc="s: the encoder's reading freezes here"),
        "u_dc_scale": P(1.0, hi=10.0, doc="the dc link relative to converter.u_dc: a sag or a step (inverter)"),
    }, default={}),
    # the machine's heating (its [thermal] table, csrc/plant/fs_thermal.h)
    "thermal": T({
        "enabled": B(False, doc="R_s and the magnet follow the winding's and magnets' temperatures"),
        "time_scale": F(1.0, lo=1.0, hi=1e6, doc="the heat capacities divided by this: minutes of heating in seconds"),
        "T_amb": F(None, lo=-50.0, hi=300.0, doc="degC; default the machine's"),
        "T_winding0": F(None, lo=-50.0, hi=300.0, doc="degC; default the ambient"),
        "T_magnet0": F(None, lo=-50.0, hi=300.0, doc="degC; default the ambient"),
    }, default={}),
    # the machine's spatial harmonics (its [harmonics] table, csrc/plant/fs_pmsm.h)
    "harmonics": T({"enabled": B(False, doc="the flux depends on the rotor angle: back-EMF and saliency harmonics, cogging")},
                   default={}),
    "trace": T({"decimation": I(1, 1, 10**6, doc="record every n-th control period")}, default={}),
    "metrics": T({"steady": Spec("any", None, doc="[t_start, t_end] s, the steady window; default the last flat stretch of the references and load after the loop settles (fullspeed.metrics)")}, default={}),
}


# The trace is held in memory: one row of doubles per recorded sample.
TRACE_ROW_BYTES = 8 * _core.lib.FS_CH_N
TRACE_MAX_BYTES = 2e9


@dataclass(frozen=True)
class Scenario:
    name: str
    machine: Machine
    data: dict          # validated, with the bench's values filled in
    source: str | None = None
    # "section.key" -> design.Value for every setting that was designed or
    # given (where it came from, and why), and one-line warnings about what
    # the scenario asks (feasibility, plausibility, what polarity detection
    # cannot see)
    design: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)

    @property
    def duration(self) -> float:
        return self.data["duration"]

    def section(self, key: str) -> dict:
        return self.data[key]


def scenario_names() -> list[str]:
    root = resources.files("fullspeed") / "scenarios"
    return sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".toml"))


def _machine_file(raw: str, source) -> Path:
    """A machine file named by a scenario: beside the scenario first."""
    p = Path(raw)
    if not p.is_absolute() and source and path_kind(Path(source).parent / p) == "file":
        p = Path(source).parent / p
    return p


def _machine_of(raw, source) -> Machine:
    if isinstance(raw, str) and raw.endswith(".toml"):
        p = _machine_file(raw, source)
        return machine_from_dict(read_toml(p, "machine"), str(p))
    if isinstance(raw, str):
        raw = {"catalog": raw}
    if not isinstance(raw, dict):
        raise ConfigError("machine", raw, "must be a catalog name, a machine file (.toml) or a table", source)
    raw = dict(raw)
    if "zoo" in raw:   # a machine of the seeded zoo (fullspeed.zoo), its fields overridable
        from . import zoo
        k, seed = raw.pop("zoo"), raw.pop("zoo_seed", zoo.SEED)
        for key, v in (("machine.zoo", k), ("machine.zoo_seed", seed)):
            whole = isinstance(v, int) or (isinstance(v, float) and v.is_integer())   # a sweep's range gives floats
            if isinstance(v, bool) or not whole or not 0 <= v < 2**31:
                raise ConfigError(key, v, "must be an integer in 0 .. 2^31 - 1", source)
        k, seed = int(k), int(seed)
        return machine_from_dict(deep_merge(zoo.machine(k, seed), raw), source)
    name = raw.pop("catalog", None)
    if name is not None:
        if not isinstance(name, str):
            raise ConfigError("machine.catalog", name, "must be a catalog name (string)", source)
        base = catalog_data(name, source)
        return machine_from_dict(deep_merge(base, raw), source)
    return machine_from_dict(raw, source)


def scenario_from_dict(data: dict, source: str | None = None) -> Scenario:
    if not isinstance(data, dict):
        raise ConfigError("scenario", data, "must be a table", source)
    missing = []   # the scenario's required fields not given, and its machine's, refused together
    d = validate(data, SCENARIO, "", source, missing)
    if missing:
        if "machine" in d:
            try:
                _machine_of(d["machine"], source)
            except MissingFields as exc:
                missing += exc.entries
        raise MissingFields(missing)
    m = _machine_of(d["machine"], source)
    b = m.bench
    _per_unit(d, data, m, source)
    conv, tim, sen, ctl = d["converter"], d["timing"], d["sensors"], d["controller"]
    if conv["kind"] == "imc":
        _imc_fields(d, m, source)
    if conv["inverter"] is None:
        conv["inverter"] = "switching"
    for key in ("u_dc", "f_pwm", "t_dead"):
        if conv[key] is None:
            conv[key] = b[key]
    if tim["sampling"] is None:
        tim["sampling"] = b["sampling"]
    for key in ("adc_bits", "adc_range", "encoder_bits", "noise_i"):
        if sen[key] is None:
            sen[key] = b[key]
    notes: dict = {}
    for key in ("bw_current", "bw_speed", "bw_pll", "i_max"):
        if ctl[key] is None:
            ctl[key] = b[key]
            notes[f"controller.{key}"] = m.design[key]
        else:
            notes[f"controller.{key}"] = dz.Value(ctl[key], m.design[key].unit, "given in the scenario", True)
    obs = d["observer"]
    band = _band(d, m)
    if obs["bw_pll"] is None:
        if b.get("bw_pll_smo") is not None:
            notes["observer.bw_pll"] = dz.Value(b["bw_pll_smo"], "rad/s", "given in the machine file (bench.bw_pll_smo)", True)
        else:
            notes["observer.bw_pll"] = dz.design_observer_pll(dz.machine_values(m), rpm_to_rad_s(band["lower_rpm"].value),
                                                              ctl["bw_speed"], ctl["bw_current"])
        obs["bw_pll"] = notes["observer.bw_pll"].value
    for key, share in (("valid_rpm", 0.625), ("cutoff_min_rpm", 0.125)):
        if obs[key] is None:   # where the observer is trusted, and its filter's floor, against the band it blends in
            obs[key] = share * band["lower_rpm"].value
            notes[f"observer.{key}"] = dz.Value(obs[key], "rpm", f"{share:g} x the lower blending speed (yang2022: "
                                                f"{share * 160:g} rpm of 160): trusted inside the band, filtering below it")
    if ctl["angle"] in ("smo", "blend") and not obs["cutoff_min_rpm"] > 0:   # the SMO's filter needs a floor
        raise ConfigError("observer.cutoff_min_rpm", obs["cutoff_min_rpm"], "must be > 0 (the default, 1/8 of the "
                          f"lower blending speed {band['lower_rpm'].value:g} rpm, is 0): set it", source)
    if ctl["angle"] == "smo" and "bw_speed" not in data.get("controller", {}):
        # the speed comes from the observer's PLL: keep its lag (a double pole)
        # small at the speed loop's crossover, as the bench's encoder PLL does
        ctl["bw_speed"] = min(ctl["bw_speed"], obs["bw_pll"] / 6.0)
    if obs["top_speed_rpm"] is None:
        obs["top_speed_rpm"] = 1.5 * m.w_m_rated * 60 / (2 * math.pi)
        if not obs["top_speed_rpm"] >= 1e-3:
            raise ConfigError("machine.rated.speed_rpm", m.w_m_rated * 60 / (2 * math.pi), "must be >= 1e-3 rpm "
                              "(1.5 x it is the observer's top speed; a denormal one divides by zero)", source)
    if not obs["top_speed_rpm"] >= 1e-3:   # the SMO's gain bound and h_max divide by it
        raise ConfigError("observer.top_speed_rpm", obs["top_speed_rpm"], "must be >= 1e-3 rpm", source)
    if tim["h_max"] is None:
        # RK4 within a PWM segment: a fifth of the shortest electrical time
        # constant and of the time the rotor turns a radian (el.) at the top
        # speed keeps the local error near (h / tau)^5 / 120 < 3e-6
        tau = min(m.L_d, m.L_q) / m.R_s if m.R_s > 0 else math.inf
        w_top = m.pole_pairs * rpm_to_rad_s(obs["top_speed_rpm"])
        tim["h_max"] = min(0.2 * tau, 0.2 / w_top if w_top > 0 else math.inf, 1e-3)   # w_top underflows to 0 at 5e-324 rpm
        if conv["kind"] == "imc":   # and a fifth of a radian of the input filter's resonance
            tim["h_max"] = min(tim["h_max"], 0.2 * math.sqrt(conv["l_filter"] * conv["c_filter"]))
    if ctl["fw_top_speed_rpm"] is None:
        ctl["fw_top_speed_rpm"] = obs["top_speed_rpm"]
    if obs["start"] == "if":
        if ctl["angle"] != "smo" or ctl["mode"] != "speed":
            raise ConfigError("observer.start", "if", "needs controller.mode = \"speed\" and controller.angle = \"smo\"", source)
        if obs["handover"] != 0.0:
            raise ConfigError("observer.handover", obs["handover"], "must be 0 with start = \"if\" (sensorless from t = 0)", source)
        if obs["i_start"] is None:
            obs["i_start"] = 0.5 * ctl["i_max"]
        if obs["i_start"] > ctl["i_max"]:
            raise ConfigError("observer.i_start", obs["i_start"], f"must be <= controller.i_max ({ctl['i_max']:g} A)", source)
        if obs["start_handover_rpm"] is None:
            obs["start_handover_rpm"] = 2.0 * obs["valid_rpm"]
        if obs["start_accel_rpm_s"] is None:
            # a quarter of the torque the start current makes at a 90 deg load angle
            T = 0.25 * 1.5 * m.pole_pairs * m.psi_f * obs["i_start"]
            obs["start_accel_rpm_s"] = T / m.J * 60 / (2 * math.pi)
        for key, why in (("start_handover_rpm", "twice valid_rpm"), ("start_accel_rpm_s", "from the magnet flux psi_f")):
            if not obs[key] > 0:   # a default that came out 0: the I/f start would never hand over
                raise ConfigError(f"observer.{key}", obs[key], f"must be > 0 (the default is {why}): set it", source)
    if d["injection"]["leak"] is None:   # the filter the observer is designed for (fs_hfi.h)
        d["injection"]["leak"] = "remove" if d["injection"]["tracking"] == "lag" else "keep"
    if ctl["angle"] in ("hfi", "blend"):
        pll_given = "bw_pll" in data.get("observer", {}) or b.get("bw_pll_smo") is not None
        _injection_fields(d, m, source, bw_speed_given="bw_speed" in data.get("controller", {}) or m.design["bw_speed"].given,
                          designed_pll=None if pll_given else lambda bw_speed: dz.design_observer_pll(
                              dz.machine_values(m), rpm_to_rad_s(band["lower_rpm"].value), bw_speed, ctl["bw_current"]))
    if ctl["angle"] == "swvi":
        _swvi_fields(d, m, source, bw_speed_given="bw_speed" in data.get("controller", {}))
    if ctl["gains"] == "paper":
        _paper_gains(d, m, source)
    if obs["handover"] > d["duration"]:
        raise ConfigError("observer.handover", obs["handover"], f"must be <= duration ({d['duration']:g} s)", source)
    if ctl["T_max"] is None:
        try:
            ctl["T_max"] = m.mtpa_torque(ctl["i_max"])
        except ValueError:   # a machine that makes no torque (a passive load): only the speed mode needs it
            if ctl["mode"] == "speed":
                raise ConfigError("controller.T_max", "missing", f"is required: {m.name} makes no torque by MTPA at {ctl['i_max']:g} A", source) from None
            ctl["T_max"] = 1.0
    if ctl["i_dead_band"] is None:
        ctl["i_dead_band"] = 0.01 * ctl["i_max"]
    if ctl["dead_time_predict"] is None:   # the carrier's current crosses zero within the period (fs_dtcomp.h)
        ctl["dead_time_predict"] = ctl["angle"] in ("hfi", "blend")
    # consistency between fields
    T_pwm, Ts = 1.0 / conv["f_pwm"], _control_period(d)
    if conv["t_dead"] >= 0.5 * T_pwm:
        raise ConfigError("converter.t_dead", conv["t_dead"], f"must be shorter than half the PWM period ({0.5 * T_pwm:g} s)"
                          + (", the control period with double sampling" if tim["sampling"] == "double" else ""), source)
    if tim["h_max"] < 1e-3 * Ts:   # a run of finite steps: at most a thousand RK4 steps per control period
        given = "h_max" in data.get("timing", {})
        raise ConfigError("timing.h_max", tim["h_max"], f"must be >= {1e-3 * Ts:g} s, a thousandth of the control period"
                          + ("" if given else f" (the default, a fifth of {m.name}'s shortest time constant L/R or "
                             "of a radian at the top speed, is shorter: check R_s, L_d, L_q and observer.top_speed_rpm)"), source)
    if ctl["i_max"] >= m.bench["i_trip"]:
        raise ConfigError("controller.i_max", ctl["i_max"], f"must be below the trip level bench.i_trip ({m.bench['i_trip']:g} A)", source)
    rows = d["duration"] / (Ts * d["trace"]["decimation"])
    if rows * TRACE_ROW_BYTES > TRACE_MAX_BYTES:
        need = math.ceil(d["duration"] / Ts * TRACE_ROW_BYTES / TRACE_MAX_BYTES)
        raise ConfigError("trace.decimation", d["trace"]["decimation"], f"must be >= {need}: {d['duration']:g} s at Ts = {Ts:g} s "
                          f"would trace {rows * TRACE_ROW_BYTES / 1e9:.3g} GB, above the {TRACE_MAX_BYTES / 1e9:g} GB limit", source)
    for sec, key, limit in (("controller", "bw_current", 1.0), ("controller", "fw_cutoff", 1.0), ("controller", "bw_speed", 0.5),
                            ("controller", "bw_pll", 0.5), ("observer", "bw_pll", 0.5)):
        if d[sec][key] is not None and d[sec][key] * Ts > limit:   # None: designed in C
            raise ConfigError(f"{sec}.{key}", d[sec][key], f"must be <= {limit / Ts:g} rad/s for the control period {Ts:g} s", source)
    _fault_fields(d, m, source)
    _thermal_fields(d, m, source)
    if ctl["xy_control"] and m.phases != 5:
        raise ConfigError("controller.xy_control", True, "needs a five-phase machine (the x-y plane)", source)
    steady = d["metrics"]["steady"]
    if steady is not None:
        ok = (isinstance(steady, list) and len(steady) == 2
              and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in steady)
              and 0 <= steady[0] < steady[1] <= d["duration"])
        if not ok:
            raise ConfigError("metrics.steady", steady, f"must be [t_start, t_end] with 0 <= t_start < t_end <= duration ({d['duration']:g})", source)
    for key in ("u_h", "f_h"):
        if f"injection.{key}" not in notes and d["injection"][key] is not None and ctl["angle"] in ("hfi", "blend", "swvi"):
            notes[f"injection.{key}"] = dz.Value(d["injection"][key], "", "given in the machine file or the scenario", True)
    notes.update(d.pop("_notes", {}))
    from .calibrate import check_table_settings
    from .checks import warnings_of
    warnings = warnings_of(d, m) + check_table_settings(d, m.name, source)
    return Scenario(name=d["name"], machine=m, data=d, source=source, design=notes, warnings=warnings)


def _per_unit(d: dict, data: dict, m: Machine, source) -> None:
    """Profiles given per unit of the machine's rating, into SI/rpm ones."""
    for sec, pu, key, base in (("references", "speed_pu", "speed_rpm", m.w_m_rated * 60 / (2 * math.pi)),
                               ("load", "torque_pu", "torque", m.T_rated)):
        if d[sec][pu] is None:
            continue
        if key in data.get(sec, {}):
            raise ConfigError(f"{sec}.{pu}", "given", f"and {sec}.{key} are one setting: give one of them", source)
        t, y = d[sec][pu]
        d[sec][key] = (t, [v * base for v in y])


def _bench_of(d: dict, m: Machine) -> dict:
    """The machine's bench with the scenario's converter and sensors: what
    the injection and the band are designed against."""
    conv, sen = d["converter"], d["sensors"]
    return {**m.bench, "u_dc": conv["u_dc"], "f_pwm": conv["f_pwm"], "t_dead": conv["t_dead"],
            "sampling": d["timing"]["sampling"], "adc_bits": sen["adc_bits"], "adc_range": sen["adc_range"],
            "noise_i": sen["noise_i"]}


def _band(d: dict, m: Machine) -> dict:
    """The blending band: the machine's [blending], else designed."""
    mb = m.extra.get("blending", {})
    bench = _bench_of(d, m)
    f_h = d["injection"]["f_h"] or m.extra.get("injection", {}).get("f_h") or _carrier(d, m).value
    band = dz.design_band(dz.machine_values(m), bench, f_h)
    return {k: dz.Value(float(mb[k]), "rpm", "given in the machine file", True) if k in mb else band[k]
            for k in ("lower_rpm", "upper_rpm")}


def controller_model(ctl: dict, m: Machine) -> dict:
    """R_s, L_d, L_q as the controller knows them: the machine's times the
    controller's *_scale (a model error on purpose)."""
    return {"R_s": m.R_s * ctl["R_s_scale"], "L_d": m.L_d * ctl["L_d_scale"], "L_q": m.L_q * ctl["L_q_scale"]}


def _carrier(d: dict, m: Machine) -> dz.Value:
    """The rotating carrier's designed frequency, against the current loop
    as the controller designs it (its model of the machine, its timing)."""
    ctl = d["controller"]
    mv = {**dz.machine_values(m), **controller_model(ctl, m)}
    return dz.design_carrier(mv, _bench_of(d, m), ctl["bw_current"] if ctl["gains"] == "designed" else None,
                             d["timing"]["delay"])


def _thermal_fields(d: dict, m: Machine, source) -> None:
    if d["harmonics"]["enabled"]:
        if m.harmonics is None:
            raise ConfigError("harmonics.enabled", True, f"needs a [harmonics] table in the machine {m.name}", source)
        if m.phases != 3:
            raise ConfigError("harmonics.enabled", True, "spatial harmonics are modelled on three-phase machines", source)
        if d["faults"]["open_phase"] != "none":
            raise ConfigError("harmonics.enabled", True, "not modelled with an open phase (faults.open_phase)", source)
    th = d["thermal"]
    if not th["enabled"]:
        return
    if m.thermal is None:
        raise ConfigError("thermal.enabled", True, f"needs a [thermal] table in the machine {m.name}", source)
    if m.magnetic["model"] == "fluxmap":
        raise ConfigError("thermal.enabled", True, "a flux map's magnet temperature is not modelled: "
                          "the machine's magnetic model must be linear or algebraic", source)
    if th["T_amb"] is None:
        th["T_amb"] = m.thermal["T_amb"]
    for key in ("T_winding0", "T_magnet0"):
        if th[key] is None:
            th[key] = th["T_amb"]


def _fault_fields(d: dict, m: Machine, source) -> None:
    f = d["faults"]
    for key, lo, hi in (("i_offset", -1e5, 1e5), ("i_gain", -0.99, 10.0)):
        v = f[key]
        if len(v) > m.phases or not all(lo <= x <= hi for x in v):
            raise ConfigError(f"faults.{key}", v, f"must list at most {m.phases} values (phases a, b, ...), each in [{lo:g}, {hi:g}]", source)
    if f["open_phase"] != "none" and (m.phases != 3 or d["converter"]["kind"] != "inverter"):
        raise ConfigError("faults.open_phase", f["open_phase"], "is modelled on a three-phase machine fed by the inverter", source)
    scale = f["u_dc_scale"][1]
    if min(scale) < 0.01:
        raise ConfigError("faults.u_dc_scale", min(scale), "must stay >= 0.01 (a dc link that collapses to zero is a stop, not a sag)", source)
    if d["converter"]["kind"] != "inverter" and any(x != 1.0 for x in scale):
        raise ConfigError("faults.u_dc_scale", scale, "applies to the inverter's dc link (the matrix converter's follows the grid)", source)


def _imc_fields(d: dict, m: Machine, source) -> None:
    """The indirect matrix converter (zou2021): the grid and filter from the
    bench, and what the averaged model of fs_sim.h does not have."""
    conv, ctl, tim, b = d["converter"], d["controller"], d["timing"], m.bench
    if m.phases != 3:
        raise ConfigError("converter.kind", "imc", f"drives three phases; {m.name} has {m.phases}", source)
    for key, bkey in (("grid_ll_rms", "u_grid_ll_rms"), ("f_grid", "f_grid"), ("l_filter", "l_filter"),
                      ("r_filter", "r_filter"), ("c_filter", "c_filter")):
        if conv[key] is None:
            if b.get(bkey) is None:
                raise ConfigError(f"converter.{key}", "missing", f"is required: {m.name}'s bench has no {bkey}", source)
            conv[key] = b[bkey]
    if conv["inverter"] == "switching":
        raise ConfigError("converter.inverter", "switching", "must be \"averaged\" with kind = \"imc\" (the inverter stage is averaged per rectifier interval)", source)
    conv["inverter"] = "averaged"
    for key in ("t_dead", "u_on"):
        if conv[key]:
            raise ConfigError(f"converter.{key}", conv[key], "must be 0 with kind = \"imc\" (the model has no dead time or device drops)", source)
    conv["t_dead"] = 0.0
    if tim["sampling"] == "double":
        raise ConfigError("timing.sampling", "double", "must be \"single\" with kind = \"imc\"", source)
    tim["sampling"] = "single"
    if ctl["angle"] == "swvi":
        raise ConfigError("controller.angle", "swvi", "square-wave injection is not available with kind = \"imc\"", source)
    if ctl["i_lim"] is None:
        ctl["i_lim"] = b.get("i_lim") or ctl["i_max"] or b["i_max"]
    i_max = ctl["i_max"] or b["i_max"]
    if ctl["depth_control"] and ctl["i_lim"] > i_max:
        raise ConfigError("controller.i_lim", ctl["i_lim"], f"must be <= controller.i_max ({i_max:g} A)", source)


def _injection_fields(d: dict, m: Machine, source, bw_speed_given: bool = True, designed_pll=None) -> None:
    """Fill in and check the injection, polarity and blending tables."""
    ctl, inj, pol, bl = d["controller"], d["injection"], d["polarity"], d["blending"]
    cm = controller_model(ctl, m)
    L_d, L_q = cm["L_d"], cm["L_q"]
    _check_saliency(ctl, m, source)
    band = _band(d, m)
    designed = dz.design_injection(dz.machine_values(m), _bench_of(d, m), ctl["i_max"], rpm_to_rad_s(band["upper_rpm"].value),
                                   _carrier(d, m))
    _machine_injection(inj, m, ("u_h", "f_h"), source, designed)
    if not inj["u_h"] > 0.0:   # designed as nothing (fs_hfi_init would refuse it, blaming the carrier's frequency)
        raise ConfigError("injection.u_h", inj["u_h"], f"must be > 0 V: {designed['u_h'].reason}", source)
    d.setdefault("_notes", {}).update(inj.pop("_notes", {}))
    Ts = _control_period(d)
    _check_carrier(inj["f_h"], Ts, source)
    for key in ("bw_filter_p", "bw_filter_n", "bw_observer"):
        if inj[key] is not None and inj[key] * Ts > 0.5:
            raise ConfigError(f"injection.{key}", inj[key], f"must be <= {0.5 / Ts:g} rad/s for the control period {Ts:g} s", source)
    h = _hfi_design(inj, Ts, L_d, L_q, source)   # the bandwidths and the held amplitude as the estimator designs them
    # the observer whose speed the loops take: the blend's, or the injection's speed observer (fs_hfi.h: with
    # tracking = "lag" not the fast one, whose speed carries the angle's response to the loop's own current)
    w_o = (bl["bw_observer"] if ctl["angle"] == "blend" else None) or h.w_o_blend
    if not bw_speed_given and ctl["bw_speed"] > 0.5 * w_o:
        # the speed loop at half its bandwidth keeps the observer's lag small (on the machine zoo: 28 of 50
        # saturating machines within 15 el.deg instead of 18 at bw_current / 30)
        ctl["bw_speed"] = 0.5 * w_o
        notes = d.setdefault("_notes", {})
        notes["controller.bw_speed"] = dz.Value(ctl["bw_speed"], "rad/s", (
            f"half the observer whose speed the loop uses ({w_o:.4g} rad/s): its lag stays small "
            "(bw_current / 30 would be faster than the observer)"))
        if designed_pll is not None:   # the back-EMF observer's PLL, designed against the speed loop, follows it
            d["observer"]["bw_pll"] = designed_pll(ctl["bw_speed"]).value
            notes["observer.bw_pll"] = designed_pll(ctl["bw_speed"])
    w_b_p, w_b_n, w_o, w_o_speed = h.cfg.w_b_p, h.cfg.w_b_n, h.cfg.obs.bandwidth, min(h.cfg.obs.bandwidth, h.w_o_blend)
    for key, w in (("bw_filter_p", w_b_p), ("bw_filter_n", w_b_n), ("bw_observer", w_o)):
        if w * Ts > 0.5:   # a default derived from the carrier
            raise ConfigError(f"injection.{key}", w, f"must be <= {0.5 / Ts:g} rad/s for the control period {Ts:g} s (default from f_h; set it)", source)
    u_lin = _u_linear(d, m)
    if h.u_amp >= u_lin:
        raise ConfigError("injection.u_h", inj["u_h"], f"must be below {u_lin * inj['u_h'] / h.u_amp:.3g} V: the held carrier, u_h / sinc(pi f_h Ts) = {h.u_amp:.3g} V, inside the linear modulation limit u_dc/sqrt3", source)
    i_hf = inj["u_h"] / (2 * math.pi * inj["f_h"] * min(L_d, L_q))   # the carrier current's peak (fs_drive.c)
    if not i_hf < 0.5 * ctl["i_max"]:
        raise ConfigError("injection.u_h", inj["u_h"], f"must be below {inj['u_h'] * 0.5 * ctl['i_max'] / i_hf:.3g} V: the carrier current's peak, u_h / (2 pi f_h min(L_d, L_q)) = {i_hf:.3g} A, must stay below half of controller.i_max ({ctl['i_max']:g} A)", source)
    if bl["bw_observer"] is not None and bl["bw_observer"] * Ts > 0.5:
        raise ConfigError("blending.bw_observer", bl["bw_observer"], f"must be <= {0.5 / Ts:g} rad/s for the control period {Ts:g} s", source)
    if pol["enabled"]:
        t_lock_min, t_pulse_min = 6.0 / w_b_n + 2.0 / w_o_speed, 6.0 / w_b_p   # the slower observer settles too
        for key, t_min, t_default in (("t_lock", t_lock_min, 0.06), ("t_pulse", t_pulse_min, 0.02)):
            if pol[key] is None:   # 20 % above the settling bound: noise and the rounding to samples
                pol[key] = max(t_default, 1.2 * t_min)
                d.setdefault("_notes", {})[f"polarity.{key}"] = dz.Value(
                    pol[key], "s", f"{t_default:g} s (yang2022's bench) or 1.2 x the settling bound {t_min:.3g} s, the longer")
        if pol["t_lock"] < t_lock_min:
            raise ConfigError("polarity.t_lock", pol["t_lock"], f"must be >= {t_lock_min:.3g} s: 6 / w_b_n + 2 / w_o, the fade-in, the filters and the observers settle first", source)
        if pol["t_pulse"] < t_pulse_min:
            raise ConfigError("polarity.t_pulse", pol["t_pulse"], f"must be >= {t_pulse_min:.3g} s: 6 / w_b_p, the carrier amplitude settles in each pulse's first half", source)
    if inj["xcomp"] is not None:
        inj["xcomp"] = _xcomp_table(inj["xcomp"], source)
    if pol["i_pulse"] is None:
        pol["i_pulse"] = 0.5 * ctl["i_max"]
    if pol["i_pulse"] > ctl["i_max"]:
        raise ConfigError("polarity.i_pulse", pol["i_pulse"], f"must be <= controller.i_max ({ctl['i_max']:g} A)", source)
    if pol["i_pulse_max"] is not None and not pol["i_pulse"] <= pol["i_pulse_max"] <= ctl["i_max"]:
        raise ConfigError("polarity.i_pulse_max", pol["i_pulse_max"], f"must be within polarity.i_pulse ({pol['i_pulse']:g} A) .. controller.i_max ({ctl['i_max']:g} A)", source)
    if ctl["angle"] == "blend":
        for key in ("lower_rpm", "upper_rpm"):
            if bl[key] is None:
                bl[key] = band[key].value
                d["_notes"][f"blending.{key}"] = band[key]
            else:
                d["_notes"][f"blending.{key}"] = dz.Value(bl[key], "rpm", "given in the scenario", True)
        if not bl["upper_rpm"] > bl["lower_rpm"]:
            raise ConfigError("blending.upper_rpm", bl["upper_rpm"], f"must be > blending.lower_rpm ({bl['lower_rpm']:g})", source)
        if inj["stop_rpm"] is None:
            inj["stop_rpm"] = 1.2 * bl["upper_rpm"]
        if not 0.9 * inj["stop_rpm"] >= bl["upper_rpm"]:
            raise ConfigError("injection.stop_rpm", inj["stop_rpm"], f"must be >= upper_rpm / 0.9 = {bl['upper_rpm'] / 0.9:g} (the injection resumes at 0.9 x stop_rpm)", source)


def _check_carrier(f_h: float, Ts: float, source) -> None:
    """The rotating carrier's limit, fs_hfi_w_h_max's rule (the one C applies):
    more than 4 samples per carrier period, w_h Ts < pi/2 in float32."""
    w_max = _core.lib.fs_hfi_w_h_max(Ts)
    if not float(_core.ffi.cast("float", 2 * math.pi * f_h)) <= w_max:   # w_h as the C config holds it
        raise ConfigError("injection.f_h", f_h, f"must be at most {w_max / (2 * math.pi):.10g} Hz: more than 4 samples per carrier "
                          f"period at Ts = {Ts:g} s, w_h Ts below pi/2 in float32 (a quarter of the sampling rate, {0.25 / Ts:g} Hz, "
                          "is not below it there)", source)


def _check_saliency(ctl: dict, m: Machine, source) -> None:
    cm = controller_model(ctl, m)
    L_d, L_q = cm["L_d"], cm["L_q"]
    if not abs(L_q - L_d) > 0.01 * 0.5 * (L_d + L_q):
        scaled = ctl["L_d_scale"] != 1.0 or ctl["L_q_scale"] != 1.0
        whose = (f"the controller's model of {m.name} (L_d x {ctl['L_d_scale']:g}, L_q x {ctl['L_q_scale']:g}) has"
                 if scaled else f"{m.name} has")
        raise ConfigError("controller.angle", ctl["angle"],
                          f"injection needs a salient machine model; {whose} L_d = {L_d:g} H within 1 % of L_q = {L_q:g} H "
                          "(no saliency to design the estimator for)", source)


def _machine_injection(inj: dict, m: Machine, keys, source, designed: dict | None = None) -> None:
    """Fields left out of [injection] from the machine's [injection], else
    from the design (the rotating carrier's), else required."""
    mi = m.extra.get("injection", {})
    for key in keys:
        if inj[key] is None:
            if key in mi:
                inj[key] = float(mi[key])
            elif designed is not None and key in designed:
                inj[key] = designed[key].value
                inj.setdefault("_notes", {})[f"injection.{key}"] = designed[key]
            else:
                raise ConfigError(f"injection.{key}", "missing", f"is required: {m.name} has no [injection].{key}", source)


def _control_period(d: dict) -> float:
    T_pwm = 1.0 / d["converter"]["f_pwm"]
    return T_pwm / 2 if d["timing"]["sampling"] == "double" else T_pwm


def _u_linear(d: dict, m: Machine) -> float:
    """The modulator's linear limit: u_dc / sqrt 3, or u_dc / (2 cos(pi/10)) on five phases."""
    u_dc = d["converter"]["u_dc"]
    return u_dc / (2 * math.cos(math.pi / 10)) if m.phases == 5 else u_dc / math.sqrt(3)


def _swvi_fields(d: dict, m: Machine, source, bw_speed_given: bool) -> None:
    """The square-wave injection (yu2022): carrier at a quarter of the sampling
    rate, the PLL, the sequence and the cross-saturation compensation."""
    ctl, inj = d["controller"], d["injection"]
    _check_saliency(ctl, m, source)
    if ctl["mode"] not in ("current", "speed"):
        raise ConfigError("controller.mode", ctl["mode"], "must be \"current\" or \"speed\" with angle = \"swvi\"", source)
    if ctl["lock"] == "recover":
        raise ConfigError("controller.lock", "recover", "must be \"off\", \"detect\" or \"stop\" with angle = \"swvi\": "
                          "the square wave has no restart sequence (no polarity detection)", source)
    _machine_injection(inj, m, ("u_h", "f_h", "bw_pll"), source)
    Ts = _control_period(d)
    if not math.isclose(inj["f_h"], 0.25 / Ts, rel_tol=1e-6):
        raise ConfigError("injection.f_h", inj["f_h"], f"must be 1 / (4 Ts) = {0.25 / Ts:g} Hz: the filterless processing takes four samples per carrier period (yu2022 sec. 2.2)", source)
    if inj["bw_pll"] * Ts > 0.5:
        raise ConfigError("injection.bw_pll", inj["bw_pll"], f"must be <= {0.5 / Ts:g} rad/s for the control period {Ts:g} s", source)
    if not bw_speed_given and ctl["gains"] != "paper":
        # the speed is the PLL's PI output (fs_swvi.h), whose zero keeps its lag
        # small up to about half the PLL's bandwidth (yu2022: 31 against 57.5 rad/s)
        ctl["bw_speed"] = min(ctl["bw_speed"], inj["bw_pll"] / 2.0)
    if inj["u_h"] >= _u_linear(d, m):
        raise ConfigError("injection.u_h", inj["u_h"], f"must be below the linear modulation limit {_u_linear(d, m):.4g} V", source)
    xc = inj["xcomp"]
    if xc == "paper":
        poly = m.extra.get("injection", {}).get("xcomp_paper")
        if poly is None:
            raise ConfigError("injection.xcomp", xc, f"{m.name} has no [injection].xcomp_paper (a fitted error polynomial)", source)
        inj["xcomp"] = {"poly_error": [float(x) for x in poly]}
    elif xc is not None:
        inj["xcomp"] = _xcomp_table(xc, source)


def _paper_gains(d: dict, m: Machine, source) -> None:
    """The machine's [paper_gains]: current PIs in V/A and V/(A s) per axis,
    the speed PI in A per mechanical rad/s (and per rad), turned into torque
    with the torque constant (phases / 2) p psi_f."""
    g = m.extra.get("paper_gains")
    keys = ("current_kp_d", "current_ki_d", "current_kp_q", "current_ki_q", "speed_kp", "speed_ki")
    if not g or any(k not in g for k in keys):
        raise ConfigError("controller.gains", "paper", f"{m.name} has no complete [paper_gains] ({', '.join(keys)})", source)
    k_T = 0.5 * m.phases * m.pole_pairs * m.psi_f
    d["controller"]["paper_gains"] = {
        "k_p_d": g["current_kp_d"], "k_i_d": g["current_ki_d"], "k_p_q": g["current_kp_q"], "k_i_q": g["current_ki_q"],
        "k_p_w": g["speed_kp"] * k_T, "k_i_w": g["speed_ki"] * k_T,
    }


def _hfi_design(inj: dict, Ts: float, L_d: float, L_q: float, source=None):
    """The injection estimator as fs_hfi_init designs it (its defaults and
    the held carrier amplitude): one place for those rules, the C one."""
    from ._core import ffi, lib

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


def _xcomp_path(raw: str, source) -> Path:
    """A table's file: a relative path against the scenario's own folder
    first, then the working directory; else a table shipped with the
    package, by name."""
    p = Path(raw)
    here = [Path(source).parent / p] if source and path_kind(source) == "file" and not p.is_absolute() else []
    for t in here + [p, Path(str(resources.files("fullspeed") / "calibration" / f"{raw}.toml"))]:
        if path_kind(t) is not None:
            return t
    raise ConfigError("injection.xcomp", raw, "file not found (nor a table in fullspeed/calibration)", source)


def _xcomp_table(raw, source) -> dict:
    """The cross-saturation table: inline, or the path of a TOML file holding it."""
    where = "injection.xcomp"
    if isinstance(raw, str):
        p = _xcomp_path(raw, source)
        try:
            raw = read_toml(p, where, source)
        except ConfigError as exc:   # name the field, and the file in it
            raise ConfigError(where, raw, f"{p}: {exc.allowed}", source) from None
        raw = raw.get("xcomp", raw)
    # what `fullspeed calibrate` writes beside the table (its provenance and quality) is accepted and not used;
    # the settings it was measured with are kept for calibrate.check_table_settings
    if not isinstance(raw, dict) or set(raw) - {"i_q", "delta_deg", "source", "spread_deg", "speed_rpm", "residual_deg", "settings"} \
            or not {"i_q", "delta_deg"} <= set(raw):
        raise ConfigError(where, raw if not isinstance(raw, dict) else sorted(raw), "must be a table with i_q = [A...] and delta_deg = [el.deg...]", source)
    i_q, delta = raw["i_q"], raw["delta_deg"]
    ok = (isinstance(i_q, list) and isinstance(delta, list) and 2 <= len(i_q) == len(delta) <= 33
          and all(finite_number(x) for x in i_q + delta))
    if not ok:
        raise ConfigError(where, "table", "i_q and delta_deg must be lists of 2..33 finite numbers of the same length", source)
    if not even_grid(i_q):
        raise ConfigError(f"{where}.i_q", i_q, "must rise in even steps", source)
    if not all(abs(x) < 90.0 for x in delta):
        raise ConfigError(f"{where}.delta_deg", delta, "must lie within +-90 el.deg", source)
    out = {"i_q": [float(x) for x in i_q], "delta_deg": [float(x) for x in delta]}
    if "settings" in raw:
        st = raw["settings"]
        if not isinstance(st, dict) or not all(isinstance(v, (str, int, float)) and not isinstance(v, bool) for v in st.values()):
            raise ConfigError(f"{where}.settings", st, "must be a table of the settings it was measured with (names and numbers)", source)
        out["settings"] = {k: float(v) if isinstance(v, int) else v for k, v in st.items()}
    return out


def load_scenario(name_or_path: str | Path, overrides: dict | None = None) -> Scenario:
    """A catalog scenario by name, or a TOML file by path; overrides are merged
    into the raw data before validation."""
    p = Path(name_or_path)
    names = scenario_names()
    # a file by that name wins; a folder by a catalog name (an earlier run's
    # --out) does not shadow the catalog
    kind = path_kind(p)
    if p.suffix == ".toml" or kind == "file" or (str(name_or_path) not in names and kind is not None):
        source = str(p)
        data = read_toml(p, "scenario")
    else:
        if str(name_or_path) not in names:
            raise ConfigError("scenario", str(name_or_path), "unknown scenario; `fullspeed list` shows the catalog", None)
        source = f"scenarios/{name_or_path}.toml"
        data = parse_toml((resources.files("fullspeed") / "scenarios" / f"{name_or_path}.toml").read_text(), "toml", source)
    if overrides:
        base = data.get("machine")
        if isinstance(base, str) and isinstance(overrides.get("machine"), dict) \
                and not {"catalog", "zoo"} & set(overrides["machine"]):
            # a field of a named machine (--set machine.bench.f_pwm=20000): merged into that
            # machine, not replacing the name with a table of the one field
            data = {**data, "machine": _machine_table(base, source)}
        data = deep_merge(data, overrides)
    return scenario_from_dict(data, source)


def _machine_table(raw: str, source) -> dict:
    """A scenario's machine given by name (a catalog machine, or a machine
    file beside the scenario) as the table that names it, for merging fields
    into: {"catalog": name}, or the file's fields."""
    if not raw.endswith(".toml"):
        return {"catalog": raw}
    p = _machine_file(raw, source)
    table = read_toml(p, "machine")
    mag = table.get("magnetic")
    if isinstance(mag, dict) and isinstance(mag.get("file"), str) and not Path(mag["file"]).is_absolute():
        # the flux map lies beside the machine file, which the merged table no longer is
        table["magnetic"] = {**mag, "file": str(p.parent / mag["file"])}
    return table
