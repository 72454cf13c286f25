"""Writing files safely: names derived from user input stay file names,
and a file appears whole or not at all."""
from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path


def file_name(name: str) -> str:
    """A name as a file name inside the output folder: no separators, no
    leading dots (a machine called '../../x' stays in out/)."""
    return re.sub(r"[^\w.-]", "_", name).lstrip(".") or "unnamed"


def write_atomic(path: str | Path, text: str) -> Path:
    """text (UTF-8) written to a temporary name beside path and renamed into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
