"""A repository script that is no package module (bench/, tools/,
examples/) loaded as a module for its tests."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path


def load_script(path: Path, name: str):
    """The script at path as the module `name`, registered in sys.modules
    before it runs (dataclasses look their module up there)."""
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod
