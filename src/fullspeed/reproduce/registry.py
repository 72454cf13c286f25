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


def register(claim_id: str):
    """Registers a measurement function for a claim in MEASURES."""
    def deco(fn):
        MEASURES[claim_id] = fn
        return fn
    return deco
