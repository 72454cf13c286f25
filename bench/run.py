"""fullspeed's benchmarks in one command: wall time against motulator and
motulator-export's native C, where fullspeed's time goes per simulated
sample (breakdown.py), the drive step's instructions per control step, the Cortex-M4F build, the
position estimators against motulator on its own examples, the
drive step run on an emulated Cortex-M4F (processor in the loop: per mode
the target's instructions per step, stack, RAM and the replay's largest
difference from the host; the loop closed through the emulator), and
what each optional plant effect costs (effects.py).

Each part runs on its own and skips, saying why, where this machine lacks
what it needs (a Python >= 3.12 for motulator, valgrind, the ARM
toolchain, QEMU). The report is printed, and written to --out as JSON
(bench.json) beside the printout (bench.txt).

Usage: python bench/run.py [--repeat N] [--steps N] [--out DIR]
                          [--only wall,breakdown,estimators,instructions,firmware,pil,effects]
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import breakdown  # noqa: E402
import effects  # noqa: E402
import estimators  # noqa: E402
import firmware  # noqa: E402
import instructions  # noqa: E402
import pil  # noqa: E402
import wall  # noqa: E402

PARTS = ("wall", "breakdown", "estimators", "instructions", "firmware", "pil", "effects")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="wall: rounds of the three engines (default 3)")
    ap.add_argument("--steps", type=int, default=20000, help="instructions: measured steps (default 20000)")
    ap.add_argument("--out", type=Path, default=Path("out/bench"), help="where bench.json goes (default out/bench)")
    ap.add_argument("--only", default=",".join(PARTS), help="comma-separated parts to run (default all)")
    a = ap.parse_args(argv)
    parts = [p.strip() for p in a.only.split(",") if p.strip()]
    bad = [p for p in parts if p not in PARTS]
    if bad or a.repeat < 1 or a.steps < 1:
        what = f"--only = {','.join(bad)}: must be among {', '.join(PARTS)}" if bad else \
            f"--repeat = {a.repeat}, --steps = {a.steps}: must be >= 1"
        print(what, file=sys.stderr)
        return 2
    report, status, texts = {}, 0, []
    a.out.mkdir(parents=True, exist_ok=True)
    for part in parts:
        if part == "wall":
            rep = wall.wall_report(a.repeat)
            text = wall.format_report(rep)
        elif part == "breakdown":
            rep = breakdown.breakdown_report()
            text = breakdown.format_report(rep)
        elif part == "effects":
            rep = effects.effects_report(a.repeat)
            text = effects.format_report(rep)
        elif part == "estimators":
            rep = estimators.estimators_report(a.out)
            text = estimators.format_report(rep)
        elif part == "instructions":
            rep = instructions.instructions_report(steps=a.steps)
            text = instructions.format_report(rep)
        elif part == "firmware":
            rep = firmware.firmware_report(os_size=True)
            text = firmware.format_report(rep)
        else:
            rep = pil.pil_report()
            text = pil.format_report(rep)
        print(text + "\n", flush=True)
        texts.append(text)
        report[part] = rep
        if rep.get("status") == "fail":
            status = 1
        (a.out / "bench.json").write_text(json.dumps(report, indent=2, default=str))
        (a.out / "bench.txt").write_text("\n\n".join(texts) + "\n")
    print(f"written: {a.out / 'bench.json'}")
    return status


if __name__ == "__main__":
    sys.exit(main())
