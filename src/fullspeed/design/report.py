"""What `fullspeed design` prints: every designed (and given) setting of a
scenario with its reason, the forms its estimators run in, and the
machine's envelope (design.envelope) at the scenario's current limit and
converter."""
from __future__ import annotations

import textwrap

import numpy as np

from ..model.scenario import SCENARIO, Scenario
from ..model.units import rad_s_to_rpm
from .checks import voltage_limit
from .envelope import LIMITS, Envelope, envelope, table_speeds


# The settings that choose an estimator's form, per angle source: `fullspeed
# design` prints them with their values (fullspeed's defaults unless the
# scenario set them) and what each does, so that a user sees what runs
ESTIMATOR_FORMS = {
    "smo": ("observer.form",),
    "hfi": ("injection.tracking", "injection.leak", "controller.dead_time_predict"),
    "blend": ("observer.form", "injection.tracking", "injection.leak", "blending.gate", "controller.dead_time_predict"),
    "swvi": ("injection.sequence",),
}


# the starts design.start chooses, as the report names them
START_NAMES = {"pulses": "injection, the magnet's polarity by d-current pulses (fs_polarity.h)",
               "motion": "injection, the magnet's polarity by a bounded motion test (fs_motion_test.h)",
               "if": "an I/f start into the back-EMF observer (fs_if_start.h)",
               "known": "at a known angle (no polarity detection)",
               "sensor": "on the encoder (or the true angle) until observer.handover",
               "none": "none (no closed loop)"}


def start_lines(sc: Scenario) -> list[str]:
    """The start the design chose (design.start), why, and the rotor's
    largest turn it allows before the loops close."""
    st = sc.data.get("start", {})
    kind = st.get("kind")
    if kind is None:
        return []
    out = [f"start (start.method = {st['method']}, allow_motion = {str(st['allow_motion']).lower()}): {START_NAMES[kind]}",
           *(f"  {w}" for w in textwrap.wrap(f"why: {st['reason']}", 110))]
    bound = st.get("c", {}).get("bound_deg")
    if bound is not None:
        p = sc.machine.pole_pairs
        out.append(f"  the rotor turns by at most {bound:.4g} el.deg ({bound / p:.4g} deg mechanical) before the loops close "
                   "on the estimate")
    return out


def design_report(sc: Scenario) -> str:
    """The designed (and given) settings of a scenario, one a line with its
    reason: what `fullspeed design` prints."""
    m = sc.machine
    lines = [f"{m.name}: {m.description or m.source or ''}".rstrip(": "),
             "bench (machine file; designed where left out):"]
    for k, v in m.design.items():   # the bench's by their field's name, a flux map's values as map.<name>
        name = k if "." in k else f"bench.{k}"
        lines.append(f"  {name:<22s} {v.value:12.5g} {v.unit:<6s} {'given' if v.given else 'designed'}: {v.reason}")
    lines.append(f"scenario {sc.name}:")
    for k, v in sc.design.items():
        lines.append(f"  {k:<22s} {v.value:12.5g} {v.unit:<6s} {'given' if v.given else 'designed'}: {v.reason}")
    lines += start_lines(sc)
    forms = ESTIMATOR_FORMS.get(sc.data["controller"]["angle"], ())
    if forms:
        lines.append(f"estimators (controller.angle = {sc.data['controller']['angle']}; each can be set in the scenario):")
        for key in forms:
            sec, name = key.split(".")
            value = sc.data[sec][name]
            value = str(value).lower() if isinstance(value, bool) else value
            doc = textwrap.wrap(SCENARIO[sec].table[name].doc, 96)
            lines.append(f"  {key:<29s} {value:<9s} {doc[0]}")
            lines.extend(f"  {'':<39s} {d}" for d in doc[1:])
    lines.append("(the PI, PLL and observer gains are designed from these in fs_drive_init; `fullspeed export` writes them)")
    return "\n".join(lines)


def scenario_envelope(sc: Scenario) -> tuple[Envelope, str]:
    """The envelope of a scenario's machine at its controller's current
    limit and its converter's voltage, and how that voltage is given."""
    u, how = voltage_limit(sc.data, sc.machine)
    return envelope(sc.machine, sc.data["converter"]["u_dc"], sc.data["controller"]["i_max"], u_max=u), how


def envelope_report(env: Envelope, how: str) -> str:
    """The envelope as `fullspeed design` prints it: base speed,
    characteristic current, top speed, and the torque, power and currents
    at about a dozen speeds (with the base speed and the MTPV onset)."""
    rpm = rad_s_to_rpm
    k_base = int(np.argmin(np.abs(env.w_m - env.w_base)))
    lines = [f"envelope of {env.machine} (steady state, within {env.i_max:g} A and {how}: |u| <= {env.u_max:.4g} V peak):",
             f"  base speed             {rpm(env.w_base):9.1f} rpm   {env.T_base:.4g} N m on MTPA at i_max, "
             f"{env.P[k_base] / 1e3:.4g} kW",
             f"  characteristic current {env.i_ch:9.4g} A     i_d = -{env.i_ch:.4g} A cancels psi_d at i_q = 0 ({env.i_ch_note}): "
             + ("within" if env.i_ch <= env.i_max else "beyond") + f" i_max = {env.i_max:g} A"]
    if env.top_finite:
        lines.append(f"  top speed              {rpm(env.w_top):9.1f} rpm   no load, voltage-limited: with i_d = "
                     f"{env.i_d[-1]:.4g} A the voltage reaches {env.u_max:.4g} V with no torque left (the characteristic "
                     "current is beyond i_max: flux weakening on the current limit up to there)")
    else:
        # the MTPV onset may lie beyond the table's last speed (SyR-e's THOR: none found up to its end)
        onset = (f"above {rpm(env.w_mtpv):.1f} rpm MTPV" if env.w_mtpv is not None
                 else f"beyond the table's last speed, {rpm(env.w_m[-1]):.0f} rpm, MTPV")
        lines.append(f"  top speed               infinite     the characteristic current is within i_max: {onset} "
                     f"holds the torque falling about as 1/speed (no voltage limit to "
                     f"the speed at no load; mechanics and iron losses limit it); the table runs to "
                     f"{rpm(env.w_m[-1]):.0f} rpm, where the torque is {100 * env.T[-1] / env.T[0]:.0f} % of standstill's")
    if env.w_mtpv is not None and env.top_finite:
        lines.append(f"  MTPV from              {rpm(env.w_mtpv):9.1f} rpm   the voltage alone limits the torque there, "
                     "below i_max")
    marks = {k_base: "base speed"}
    if env.w_mtpv is not None:
        marks[int(np.argmin(np.abs(env.w_m - env.w_mtpv)))] = "MTPV onset"
    rows = sorted({int(np.argmin(np.abs(env.w_m - w))) for w in table_speeds(env.w_m[-1])} | set(marks))
    lines.append(f"  {'rpm':>9s} {'T_max N m':>10s} {'P_max kW':>9s} {'i_d A':>9s} {'i_q A':>9s}  limit")

    def shown(x, scale):   # what the searches leave of a zero (the angle to 1e-8 rad) shown as zero
        return 0.0 if abs(x) < 1e-6 * scale else x
    for k in rows:
        T, P, i_d, i_q = (shown(x, s) for x, s in ((env.T[k], env.T_base), (env.P[k] / 1e3, env.P.max() / 1e3),
                                                   (env.i_d[k], env.i_max), (env.i_q[k], env.i_max)))
        lines.append(f"  {rpm(env.w_m[k]):9.1f} {T:10.4g} {P:9.4g} {i_d:9.4g} {i_q:9.4g}  "
                     f"{LIMITS[env.region[k]]:<16s}{marks.get(k, '')}".rstrip())
    return "\n".join(lines)
