"""Bit-identity of the simulator's outputs across a change meant to be a
pure speed-up (csrc/sim, the Python front): every trace channel at every
sample, the metrics and the stop of a set of scenarios, hashed.

The set: every catalog scenario, and variants that take the paths the
catalog leaves out (the switching inverter on the bench's example, current
noise, a sensor fault, an open phase, a dc-link sag, the thermal model, a
coarse trace decimation, the loss meters with the devices and the iron
loss on the switching and the averaged inverter) and the examples' own
machine (a flux map). Run it before the change with --write FILE and after
it with --check FILE: it prints the scenarios whose hashes moved and exits
1 if any did.

Usage: python bench/trace_hashes.py --write FILE | --check FILE [--only NAME,...]
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

VARIANTS = {
    "bench-motulator-2kw:switching": ("bench-motulator-2kw", {"converter": {"inverter": "switching"}}),
    "bench-motulator-2kw:noise": ("bench-motulator-2kw", {"converter": {"inverter": "switching"},
                                                         "sensors": {"noise_i": 0.05, "adc_bits": 12}}),
    "bench-motulator-2kw:decimation": ("bench-motulator-2kw", {"trace": {"decimation": 7}}),
    "bench-motulator-2kw:sensor-fault": ("bench-motulator-2kw", {"faults": {"t_sensor": 1.0, "i_offset": [0.2, 0.0, 0.0],
                                                                           "i_gain": [0.0, 0.05, 0.0],
                                                                           "t_encoder_stop": 1.3}}),
    "bench-motulator-2kw:open-phase": ("bench-motulator-2kw", {"faults": {"open_phase": "b", "t_open": 1.2}}),
    "bench-motulator-2kw:dc-sag": ("bench-motulator-2kw", {"faults": {"u_dc_scale": [[0.0, 1.0], [1.0, 1.0], [1.05, 0.7],
                                                                                    [1.6, 0.7]]}}),
    "yang2022-encoder-speedstep:losses": ("yang2022-encoder-speedstep", {"losses": {"devices": True, "iron": True}}),
    "yang2022-encoder-speedstep:losses-averaged": ("yang2022-encoder-speedstep",
                                                   {"converter": {"inverter": "averaged"},
                                                    "losses": {"devices": True, "iron": True}}),
    "own-machine:full-range": (str(ROOT / "examples" / "own-machine" / "my48v-full-range.toml"), {}),
    "lock-loss": (str(ROOT / "examples" / "lock-loss" / "lock-loss.toml"), {}),
}


WALL_KEYS = ("wall_time", "speed_ratio")   # the metrics that time the run: not outputs of the model


def cases() -> dict[str, tuple[str, dict]]:
    names = sorted(p.stem for p in (ROOT / "src" / "fullspeed" / "scenarios").glob("*.toml"))
    return {**{n: (n, {}) for n in names}, **VARIANTS}


def digest(name: str, overrides: dict) -> str:
    """sha256 of the run's traces (every channel's bytes, in order), its
    metrics (JSON with every float's repr; not the wall time) and its stop."""
    import numpy as np
    import fullspeed.sim as fs
    from fullspeed.design.scenario import load_scenario
    from fullspeed.model.files import json_safe
    res = fs.simulate(load_scenario(name, overrides))
    h = hashlib.sha256()
    for ch, v in res.traces.items():
        h.update(ch.encode())
        h.update(np.ascontiguousarray(v, dtype=np.float64).tobytes())
    metrics = {k: v for k, v in json_safe(res.metrics).items() if k not in WALL_KEYS}
    h.update(json.dumps(metrics, sort_keys=True, default=repr).encode())
    h.update(f"{res.stop_reason} {res.stop_time!r} {res.adc_saturated_at!r} {res.polarity!r} {res.halt!r}".encode())
    return h.hexdigest()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--write", type=Path)
    g.add_argument("--check", type=Path)
    ap.add_argument("--only", default="", help="comma-separated case names (default all)")
    a = ap.parse_args(argv)
    todo = cases()
    if a.only:
        want = [n.strip() for n in a.only.split(",") if n.strip()]
        bad = [n for n in want if n not in todo]
        if bad:
            print(f"--only = {','.join(bad)}: not a case (the catalog's scenarios and {', '.join(VARIANTS)})",
                  file=sys.stderr)
            return 2
        todo = {n: todo[n] for n in want}
    got = {}
    for n, (src, ov) in todo.items():
        try:
            got[n] = digest(src, ov)
        except Exception as exc:    # a case that cannot run is a result too: its error, hashed as text
            got[n] = f"error: {type(exc).__name__}: {exc}"
        print(f"{n}: {got[n][:16]}", flush=True)
    if a.write:
        a.write.write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
        return 0
    before = json.loads(a.check.read_text())
    moved = [n for n in got if before.get(n) != got[n]]
    print(f"{len(got) - len(moved)} of {len(got)} cases the same to the bit"
          + (f"; moved: {', '.join(moved)}" if moved else ""))
    return 1 if moved else 0


if __name__ == "__main__":
    sys.exit(main())
