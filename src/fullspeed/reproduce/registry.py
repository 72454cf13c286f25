"""The registry the papers' measurements fill: claim id -> the function that
measures it, and the claims that cannot be measured yet with the reason.
The papers' modules import this and register; the report reads it and
never the other way round."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable


@dataclass
class Measurement:
    value: object                 # a number, or a dict of numbers
    passed: bool
    note: str = ""                # how it was measured, or why it differs from the paper
    figures: list[str] = field(default_factory=list)   # PNG paths relative to the output dir


# claim id -> function(out_dir: Path) -> Measurement; filled by the modules
# that implement the papers' parts.
MEASURES: dict[str, Callable[[Path], Measurement]] = {}

NOT_YET: dict[str, str] = {}   # claim id (or paper) -> why it cannot be measured yet

# claim id -> the name of the runs it shares in memory with other claims (a
# module's cache): the claims sharing one name are measured one after the
# other in one process, so that the runs are made once.
SHARES: dict[str, str] = {}

# claim id -> its cost (s), roughly: its CPU time in a reproduction
# (claims.json cpu_s, docs/performance.md; B-PIL's with the firmware's
# build, as on a fresh clone; only their order counts): the reproduction
# starts the longest first, so that the short ones fill the cores at the end.
COST: dict[str, float] = {}
COST_DEFAULT = 1.0   # a claim of a few runs


def register(claim_id: str, shares: str | None = None, cost: float = COST_DEFAULT):
    """Registers a measurement function for a claim in MEASURES, with the
    runs it shares with other claims (SHARES) and its rough wall time (COST)."""
    def deco(fn):
        MEASURES[claim_id] = fn
        COST[claim_id] = cost
        if shares is not None:
            SHARES[claim_id] = shares
        return fn
    return deco
