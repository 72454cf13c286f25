"""Registry of the claims that ``fullspeed reproduce`` must show.

One :class:`Claim` per row of ``CLAIMS.md`` (kept beside the repository, in
``../shared/CLAIMS.md``), in the same order, none left out.  ``text`` and
``target`` are copied verbatim from that table; ``unit`` is the unit of the
value a run measures, and ``scenario`` names the scenario that produces it.

Scenario names are kebab-case and prefixed with the paper.  A claim that is
computed from several runs names the scenario that aggregates them (for
example ``zou2021-thd-trend`` reads the three region runs).

Only the standard library is used, so the registry can be imported before the
compiled core is built.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Claim", "CLAIMS", "PAPERS", "claims_for", "claims_markdown"]

PAPERS: tuple[str, ...] = ("yang2022", "zou2021", "yu2022", "beyond")


@dataclass(frozen=True)
class Claim:
    """One claim of a paper (or of ours, ``paper == "beyond"``)."""

    id: str
    """Stable identifier, e.g. ``"Y-SMO-SS"``."""
    paper: str
    """``"yang2022"``, ``"zou2021"``, ``"yu2022"`` or ``"beyond"``."""
    text: str
    """The conditions, as in CLAIMS.md."""
    target: str
    """The paper's number or bound, as text, as in CLAIMS.md."""
    unit: str
    """Unit of the measured value (``""`` if dimensionless or a count)."""
    scenario: str
    """Name of the scenario that produces the measured value."""

    def __post_init__(self) -> None:
        if self.paper not in PAPERS:
            raise ValueError(
                f"paper = {self.paper!r}: must be one of {', '.join(PAPERS)}"
            )


CLAIMS: tuple[Claim, ...] = (
    # --- yang2022 ----------------------------------------------------
    Claim(
        id="Y-SMO-SS",
        paper="yang2022",
        text="SMO, 400 rpm held by the load machine, iq = 5 A and iq = 25 A",
        target="abs(mean) < 5 el.deg at both; pp at 25 A larger than at 5 A",
        unit="el.deg",
        scenario="yang2022-smo-steady-400rpm",
    ),
    Claim(
        id="Y-SMO-MAP",
        paper="yang2022",
        text="SMO, speeds 200..1600 rpm (step 200) x iq 5..25 A (step 5), speed held",
        target=(
            "abs(mean) < 6 el.deg at every point; pp falls as speed rises (at each "
            "current)"
        ),
        unit="el.deg",
        scenario="yang2022-smo-map",
    ),
    Claim(
        id="Y-SMO-IQSTEP",
        paper="yang2022",
        text="SMO, 400 rpm held, iq* 5 -> 15 A at t = 1.0 s",
        target="max < 5 el.deg through the step",
        unit="el.deg",
        scenario="yang2022-smo-iqstep",
    ),
    Claim(
        id="Y-SMO-RAMP",
        paper="yang2022",
        text=(
            "SMO in speed control, ramp 200 -> 800 rpm from t = 1.8 s, load torque "
            "0.1 N m"
        ),
        target="max < 25 el.deg during the ramp",
        unit="el.deg",
        scenario="yang2022-smo-ramp",
    ),
    Claim(
        id="Y-HFI-SS",
        paper="yang2022",
        text=(
            "rotating HFI, 100 rpm held, iq = 5 A and 25 A, machine with "
            "cross-saturation"
        ),
        target=(
            "abs(mean) < 5 el.deg at 5 A; at 25 A between 8 and 22 el.deg (paper: "
            "about 15)"
        ),
        unit="el.deg",
        scenario="yang2022-hfi-steady-100rpm",
    ),
    Claim(
        id="Y-HFI-MAP",
        paper="yang2022",
        text="rotating HFI, speeds 25..200 rpm x iq 5..25 A, speed held",
        target=(
            "mean error grows with current and changes by < 3 el.deg with speed at "
            "each current; pp falls as speed rises"
        ),
        unit="el.deg",
        scenario="yang2022-hfi-map",
    ),
    Claim(
        id="Y-HFI-IQSTEP",
        paper="yang2022",
        text="rotating HFI, 100 rpm held, iq* 5 -> 20 A at t = 1.0 s",
        target=(
            "error settles between 10 and 30 el.deg (paper: about 20); no loss of "
            "lock"
        ),
        unit="el.deg",
        scenario="yang2022-hfi-iqstep",
    ),
    Claim(
        id="Y-HFI-RAMP",
        paper="yang2022",
        text="rotating HFI in speed control, 50 -> 200 rpm ramp, 0.1 N m",
        target="max < 20 el.deg during the ramp",
        unit="el.deg",
        scenario="yang2022-hfi-ramp",
    ),
    Claim(
        id="Y-BLEND-IQSTEP",
        paper="yang2022",
        text=(
            "blended, 200 rpm held (inside the 160..260 rpm blending band), iq* 5 -> "
            "15 A at t = 1.0 s"
        ),
        target="max < 10 el.deg (paper: about 7)",
        unit="el.deg",
        scenario="yang2022-blend-iqstep",
    ),
    Claim(
        id="Y-BLEND-ACCDEC",
        paper="yang2022",
        text=(
            "blended, speed control, 100 -> 400 rpm during 1.1..1.4 s, 400 -> 100 "
            "rpm during 3.4..3.7 s, 0.1 N m"
        ),
        target="max < 10 el.deg; weight follows estimated speed; no loss of lock",
        unit="el.deg",
        scenario="yang2022-blend-accdec",
    ),
    Claim(
        id="Y-POLARITY",
        paper="yang2022",
        text="standstill, initial rotor angle every 10 el.deg over a turn",
        target="magnet polarity found right at all 36 angles",
        unit="",
        scenario="yang2022-polarity",
    ),
    # --- zou2021 -----------------------------------------------------
    Claim(
        id="Z-VPN",
        paper="zou2021",
        text="rectifier stage alone, alpha from 0 to pi/6",
        target=(
            "mean dc-link voltage per sector: CASE 1 = 9 ln3/(2 pi) Vim, CASE 2 = 3 "
            "sqrt3/pi Vim, eq. (12) at every alpha; each within 1 %"
        ),
        unit="%",
        scenario="zou2021-rectifier-vpn",
    ),
    Claim(
        id="Z-VTR",
        paper="zou2021",
        text=(
            "modulator with a passive load, output amplitude demanded beyond each "
            "limit"
        ),
        target=(
            "fundamental VTR (FFT of the output line voltage) saturates at 0.866 "
            "(linear), 0.954 (OM-I), 1.00 (OM-II), each within 0.01"
        ),
        unit="",
        scenario="zou2021-modulator-vtr",
    ),
    Claim(
        id="Z-SPEEDRANGE",
        paper="zou2021",
        text="torque-speed envelopes with id = 0, with PART_1, with PART_1 + PART_2",
        target=(
            "at the same load torque, max speed +30 % (PART_1) and +35 % (PART_1 + "
            "PART_2) over id = 0, each within 5 points; envelopes plotted"
        ),
        unit="%",
        scenario="zou2021-speed-range",
    ),
    Claim(
        id="Z-REGION-A",
        paper="zou2021",
        text="1000 -> 1200 rpm at 0.1 s, 10 N m load at 0.2 s",
        target=(
            "speed tracks with zero steady error; alpha = 0; input-current THD and "
            "torque ripple reported beside the paper's 7.89 % and 0.8 N m"
        ),
        unit="%, N m",
        scenario="zou2021-region-a",
    ),
    Claim(
        id="Z-REGION-B",
        paper="zou2021",
        text="1200 -> 1500 rpm, 10 N m",
        target=(
            "flux weakening active (id < 0), inverter in OM; THD beside 18.16 %, "
            "torque ripple beside 7 N m"
        ),
        unit="%, N m",
        scenario="zou2021-region-b",
    ),
    Claim(
        id="Z-REGION-C",
        paper="zou2021",
        text="1500 -> 1750 rpm, 10 N m",
        target="alpha > 0 (OM-II); THD beside 23.54 %, ripple beside 10 N m",
        unit="%, N m",
        scenario="zou2021-region-c",
    ),
    Claim(
        id="Z-THD-TREND",
        paper="zou2021",
        text="the three regions above",
        target=(
            "THD(A) < THD(B) < THD(C); each within a factor 0.6..1.4 of the paper's "
            "value"
        ),
        unit="%",
        scenario="zou2021-thd-trend",
    ),
    Claim(
        id="Z-RISE",
        paper="zou2021",
        text="1500 -> 1750 rpm, 10 N m, PART_1 alone vs PART_1 + PART_2",
        target="rise time shorter with PART_2",
        unit="s",
        scenario="zou2021-rise-time",
    ),
    Claim(
        id="Z-EXP",
        paper="zou2021",
        text=(
            "the paper's bench conditions: 150 V input, Imax 8.8 A, Ilim 6 A; 200 -> "
            "550 rpm at 5 N m"
        ),
        target="speed range +30 % / +35 % as above; rise time shorter with PART_2",
        unit="%, s",
        scenario="zou2021-experiment",
    ),
    # --- yu2022 ------------------------------------------------------
    Claim(
        id="U-FILTERLESS",
        paper="yu2022",
        text="d-axis current step with injection on",
        target=(
            "extracted HF current amplitude varies by < 10 mA; fundamental current "
            "with and without injection differs by < 2 % of the step"
        ),
        unit="A, %",
        scenario="yu2022-filterless-idstep",
    ),
    Claim(
        id="U-SEQ-DYN",
        paper="yu2022",
        text="0 -> 50 rpm step, no load; conventional vs optimized sequence",
        target=(
            "max error smaller with the optimized sequence (paper: 0.204 -> 0.162 "
            "rad)"
        ),
        unit="rad",
        scenario="yu2022-seq-dyn",
    ),
    Claim(
        id="U-SEQ-SS",
        paper="yu2022",
        text="300 rpm, no load",
        target=(
            "conventional: estimate lags (error > 0); optimized: error < 0 and "
            "within 30 % of -1.5 we Ts"
        ),
        unit="rad",
        scenario="yu2022-seq-ss-300rpm",
    ),
    Claim(
        id="U-XCOUPLE",
        paper="yu2022",
        text="150 rpm, rated-load step, with and without cross-saturation compensation",
        target=(
            "steady error about -0.3 rad without and abs < 0.05 rad with; "
            "load-release swing smaller with"
        ),
        unit="rad",
        scenario="yu2022-xcouple",
    ),
    Claim(
        id="U-STARTUP",
        paper="yu2022",
        text="0 -> 50 rpm at 1.0 s with rated load (11 N m)",
        target="max error <= 0.26 rad",
        unit="rad",
        scenario="yu2022-startup",
    ),
    Claim(
        id="U-ULTRALOW",
        paper="yu2022",
        text="5 rpm, no load and rated load",
        target="stable; abs(error) <= 0.08 rad at rated load",
        unit="rad",
        scenario="yu2022-ultralow",
    ),
    Claim(
        id="U-THIRD",
        paper="yu2022",
        text="nearest-four-vector SVPWM",
        target="d3-q3 current RMS < 5 % of the fundamental",
        unit="%",
        scenario="yu2022-xcouple",
    ),
    # --- beyond ------------------------------------------------------
    Claim(
        id="B-FULLRANGE",
        paper="beyond",
        text=(
            "yang2022 machine, sensorless all the way: standstill start under rated "
            "torque (polarity, injection), blending, SMO, flux weakening to the "
            "machine's voltage-limited top speed, then a reversal through zero under "
            "load"
        ),
        target=(
            "no loss of lock; max error < 10 el.deg outside the 50 ms after each "
            "step"
        ),
        unit="el.deg",
        scenario="beyond-full-range",
    ),
    Claim(
        id="B-XCOMP-3PH",
        paper="beyond",
        text=(
            "rotating HFI on the yang2022 machine at 100 rpm, 25 A, with "
            "cross-saturation compensation"
        ),
        target="abs(mean) < 5 el.deg (uncompensated: about 15)",
        unit="el.deg",
        scenario="beyond-xcomp-3ph",
    ),
    Claim(
        id="B-SWVI-3PH",
        paper="beyond",
        text=(
            "square-wave injection with the optimized sequence on the yang2022 "
            "three-phase machine, 0..200 rpm under rated load"
        ),
        target="max error < 10 el.deg",
        unit="el.deg",
        scenario="beyond-swvi-3ph",
    ),
    Claim(
        id="B-ROBUST",
        paper="beyond",
        text=(
            "blended sensorless, 200 runs with R, Ld, Lq, psi_f each off by up to "
            "+-20 % (random), sensor noise on"
        ),
        target="lock kept in >= 95 % of runs",
        unit="%",
        scenario="beyond-robust",
    ),
    Claim(
        id="B-ZOO",
        paper="beyond",
        text=(
            'a seeded zoo of >= 100 plausible PMSMs (2..12 pole pairs, 100 W..50 '
            'kW, L_q/L_d 1.2..3.5, 24..700 V links, 8..20 kHz, with and without '
            'magnetic saturation), datasheet fields only, every other setting '
            'designed: standstill start under load, flux weakening where the link '
            'requires it, reversal'
        ),
        target=(
            '0 silent failures (a run 90 el.deg off for 20 ms net is always flagged'
            ' by a stop reason or a loss of lock); >= 95 % of the saturating '
            'machines keep max error < 15 el.deg outside the 50 ms after each step'
        ),
        unit="el.deg",
        scenario="beyond-zoo",
    ),
    Claim(
        id="B-LOCK",
        paper="beyond",
        text=(
            'the loss-of-lock monitor over healthy runs and runs driven to lose '
            'lock (parameters x0.5..x2, load impacts beyond the torque limit, '
            'reversals faster than the current allows, polarity forced pi off)'
        ),
        target=(
            'detection >= 99 % of true losses (90 el.deg off for 20 ms net); false '
            'alarms <= 1 % of healthy runs; median delay <= 20 ms'
        ),
        unit="%",
        scenario="beyond-lock",
    ),
    Claim(
        id="B-IDENT",
        paper="beyond",
        text=(
            'self-commissioning (inverter voltage error, R_s, L_d, L_q, psi_f, J) '
            'over the zoo, with dead time, sensor noise and quantization'
        ),
        target=(
            '95th-percentile errors: R_s 3 %, L_d and L_q 5 %, psi_f 3 %, J 10 %; '
            'every failed identification names its step and reason'
        ),
        unit="%",
        scenario="beyond-ident",
    ),
    Claim(
        id="B-PIL",
        paper="beyond",
        text=(
            'the drive step of each angle source built for a Cortex-M4F and run in '
            'an emulator on inputs recorded from a host simulation; one sensorless '
            'run closed through the emulator'
        ),
        target=(
            "outputs equal to the host's within the tolerance the report states and"
            ' explains; closed-loop metrics within 1 % (angle error within 0.5 '
            "el.deg) of the host run's; blended step <= 2,500 Thumb-2 instructions"
        ),
        unit="el.deg",
        scenario="beyond-pil",
    ),
    Claim(
        id="B-THERMAL",
        paper="beyond",
        text=(
            'yang2022 machine, blended sensorless at rated load while winding and '
            'magnet heat over their thermal time constants (R_s and psi_f follow)'
        ),
        target=(
            'lock kept; max error < 10 el.deg with online correction of R_s and '
            'psi_f; the error without correction reported beside'
        ),
        unit="el.deg",
        scenario="beyond-thermal",
    ),
    Claim(
        id="B-REAL",
        paper="beyond",
        text=(
            'a catalog of >= 8 machines with published parameters (a traction '
            'IPMSM, an appliance IPMSM, the measured Baldor PM-SyRM map, a surface-'
            'PM servo or kit motor, a hub motor, a small high-speed motor), '
            'datasheet fields and maps only, every other setting designed; '
            'standstill start under 50 % rated torque, acceleration into flux '
            "weakening, a load step to 80 % of the envelope's torque at 1.5 x base "
            'speed, reversal under load'
        ),
        target=(
            'each machine either runs sensorless with max error < 10 el.deg outside'
            ' the 50 ms after each step and abs(steady mean) < 2 el.deg, or is '
            'refused before the start naming the physical cause; with the encoder, '
            "torque held at six speeds within 5 % of the map's own envelope; "
            'sensorless holds what the encoder holds'
        ),
        unit="el.deg",
        scenario="beyond-real",
    ),
    Claim(
        id="B-START",
        paper="beyond",
        text=(
            "the zoo's machines without saturation asymmetry or without saliency "
            '(linear magnetics; L_q/L_d 1.0..1.2), datasheet fields only, the start'
            ' designed by the machine (alignment or I/f where injection cannot '
            'decide)'
        ),
        target=(
            ">= 95 % start and run the full range sensorless; the rotor's motion "
            'before closed loop reported and bounded; 0 silent failures'
        ),
        unit="%",
        scenario="beyond-start",
    ),
    Claim(
        id="B-MAPID",
        paper="beyond",
        text=(
            'flux-map identification (standstill, and at speed where the rotor may '
            'turn) on the saturating machines of the zoo and the published catalog,'
            ' with dead time, sensor noise and quantization'
        ),
        target=(
            'psi_d, psi_q RMS error <= 3 % of psi_f (of the rated flux for a PM-'
            "SyRM) over the current limit's disc; the identified map in the "
            'controller keeps the sensorless error within 1 el.deg of the true '
            "map's on B-REAL's scenario"
        ),
        unit="%",
        scenario="beyond-mapid",
    ),
    Claim(
        id="B-FMU",
        paper="beyond",
        text=(
            "beyond-full-range's blended drive exported as a co-simulation FMU of "
            'the controller and of the closed-loop system, FMI 3.0 and 2.0, run by '
            'an independent FMI tool (FMPy)'
        ),
        target=(
            "the tool's validation passes; the controller FMU's outputs bit-"
            "identical to the host drive's; the system FMU's traces equal "
            "fullspeed's own run"
        ),
        unit="1",
        scenario="beyond-fmu",
    ),
)


def claims_for(paper: str | None = None) -> tuple[Claim, ...]:
    """Claims of one paper section, in CLAIMS.md order; ``None`` = all."""
    if paper is None:
        return CLAIMS
    if paper not in PAPERS:
        raise ValueError(f"paper = {paper!r}: must be one of {', '.join(PAPERS)}")
    return tuple(c for c in CLAIMS if c.paper == paper)


def claims_markdown() -> str:
    """docs/CLAIMS.md: the registry as a table per paper (a test keeps the
    page equal to this)."""
    lines = [
        "# Claims that `fullspeed reproduce` measures",
        "",
        "Generated from `src/fullspeed/reproduce/claims.py` (`fullspeed.reproduce.claims.claims_markdown`); a test keeps this page",
        "equal to the registry. `fullspeed reproduce --out DIR` runs the scenario behind each claim and writes",
        "`DIR/claims.json` (`claims`, per claim: id, paper, text, target, value, unit, pass, scenario, wall_s,",
        "cpu_s, lane (0: the foreground process, the longest claims') and start_s (from the reproduction's start);",
        "`complete`, false while it runs or when it was stopped, and `not_run`, the claims not measured then) and",
        "`DIR/report.md` with the figures; `--paper` runs one part. A claim that cannot be measured yet is listed",
        "with no value and `pass: false`, never left out.",
        "",
        "Position error is the actual minus the estimated electrical angle, wrapped to (-180, 180] el.deg; mean",
        "and pp (max minus min) are taken over the run's steady window; speeds are mechanical rpm; \"held by the",
        "load machine\": a speed-controlled load machine imposes the speed, as on the papers' benches.",
    ]
    for paper in PAPERS:
        lines += ["", f"## {paper}", "", "| id | conditions | target | unit | scenario |", "|---|---|---|---|---|"]
        lines += [f"| {c.id} | {c.text} | {c.target} | {c.unit} | `{c.scenario}` |".replace("\n", " ")
                  for c in claims_for(paper)]
    return "\n".join(lines) + "\n"


def _check_unique() -> None:
    seen: set[str] = set()
    for c in CLAIMS:
        if c.id in seen:
            raise RuntimeError(f"duplicate claim id {c.id!r}")
        seen.add(c.id)


_check_unique()
