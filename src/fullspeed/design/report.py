"""What `fullspeed design` prints: every designed (and given) setting of a
scenario with its reason, and the forms its estimators run in."""
from __future__ import annotations

import textwrap

from ..model.scenario import SCENARIO, Scenario


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
    for k, v in m.design.items():
        lines.append(f"  bench.{k:<16s} {v.value:12.5g} {v.unit:<6s} {'given' if v.given else 'designed'}: {v.reason}")
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
