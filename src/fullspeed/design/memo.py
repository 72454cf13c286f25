"""The design's searches kept for the machine they were made for: a
campaign loads the same machine hundreds of times (B-LOCK's 30 cases a
base, B-REAL's held-torque runs, Z-SPEEDRANGE's bisections), and each load
searched its envelope, its MTPA locus and its cross-saturation table
again, with the same inputs and so the same result (in Z-SPEEDRANGE and
B-REAL most of the claim's CPU; docs/performance.md).

A result is kept under its machine's content (machine_key: every field of
the Machine, its flux map's numbers exactly) and the search's other
arguments, so two machine objects read from the same file share it, and
a machine changed in any field does not. The caller gets its own copy
where the result could be changed (Memo's copies).
"""
from __future__ import annotations

import collections
import copy
import dataclasses
import json

from ..model.machines import Machine



def _plain(x):
    """What json cannot write, written exactly: arrays as lists, dataclasses
    (design.rules.Value) as their fields, the rest by repr."""
    if hasattr(x, "tolist"):
        return x.tolist()
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {f.name: getattr(x, f.name) for f in dataclasses.fields(x)}
    return repr(x)


def machine_key(m: Machine) -> str:
    """m's every field as canonical text (floats by repr: exact)."""
    return json.dumps({f.name: getattr(m, f.name) for f in dataclasses.fields(m)}, sort_keys=True, default=_plain)


class Memo:
    """make(m, *args) kept under (machine_key(m), args) for the `keep` most
    recently used (a campaign's cases run base after base: a few suffice);
    made on a copy of m, which the caller may change after; copies=True
    hands each caller a deep copy of the result (one the caller may
    change), else the kept object (one only read)."""

    def __init__(self, make, copies: bool, keep: int):
        self.make, self.copies, self.keep = make, copies, keep
        self.kept: collections.OrderedDict = collections.OrderedDict()

    def __call__(self, m: Machine, *args):
        key = (machine_key(m), args)
        if key in self.kept:
            self.kept.move_to_end(key)
            out = self.kept[key]
        else:
            out = self.make(copy.deepcopy(m), *args)   # an exception is not kept: the next call raises it again
            self.kept[key] = out
            if len(self.kept) > self.keep:
                self.kept.popitem(last=False)
        return copy.deepcopy(out) if self.copies else out
