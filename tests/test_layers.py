"""The Python front in layers (src/fullspeed/__init__.py names them): every
import, those inside functions included, runs from a layer to itself or to
one below; no module reaches itself through imports; below the top no
import sits inside a function (none is needed to dodge a circle; the top,
which nothing imports, loads a command's layers when it runs); no private
name is taken from another module. Read from the sources with ast, nothing
imported."""
from __future__ import annotations

import ast
import shutil
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"

# bottom up; the package's root modules (fullspeed, fullspeed.cli, fullspeed.__main__) are the top
LAYERS = ("model", "design", "sim", "workflows", "reproduce")
TOP = len(LAYERS)


def modules(src: Path) -> dict[str, Path]:
    out = {}
    for p in sorted((src / "fullspeed").rglob("*.py")):
        parts = p.relative_to(src).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = p
    return out


def layer(module: str) -> int:
    """0 for model .. 4 for reproduce, TOP for the root's modules."""
    parts = module.split(".")
    return LAYERS.index(parts[1]) if len(parts) > 1 and parts[1] in LAYERS else TOP


def imports(src: Path) -> list[tuple[str, str, int, bool, list[str]]]:
    """(importer, imported module, line, inside a function, names taken) for
    every import of a module of the package."""
    mods = modules(src)
    out = []
    for m, p in mods.items():
        tree = ast.parse(p.read_text())
        pkg = m.split(".") if p.name == "__init__.py" else m.split(".")[:-1]
        inner = set()
        for fn in ast.walk(tree):
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                inner |= {id(n) for n in ast.walk(fn)}
        for nd in ast.walk(tree):
            if isinstance(nd, ast.ImportFrom):
                base = ".".join(pkg[:len(pkg) - nd.level + 1] + ([nd.module] if nd.module else [])) if nd.level else nd.module
                for a in nd.names:   # a submodule by name, else a name of the base module
                    target = f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base
                    names = [] if target != base else [a.name]
                    if target in mods and target != m:
                        out.append((m, target, nd.lineno, id(nd) in inner, names))
            elif isinstance(nd, ast.Import):
                for a in nd.names:
                    t = a.name
                    while t and t not in mods:
                        t = t.rpartition(".")[0]
                    if t and t != m:
                        out.append((m, t, nd.lineno, id(nd) in inner, []))
    return out


def circles(edges) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    graph: dict[str, set[str]] = {}
    for a, b, *_ in edges:
        graph.setdefault(a, set()).add(b)
        graph.setdefault(b, set())
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def findings(src: Path = SRC) -> list[str]:
    """Every breach of the layering, one line each, naming the two modules."""
    edges = imports(src)
    out = []
    for a, b, line, inner, names in edges:
        if layer(b) > layer(a):
            out.append(f"{a} (line {line}) imports {b}: a layer imports only itself and those below it "
                       f"({' < '.join(LAYERS)} < the root)")
        if inner and layer(a) < TOP:
            out.append(f"{a} (line {line}) imports {b} inside a function: at the top, or move what both need down")
        private = [n for n in names if n.startswith("_") and not n.startswith("__")]
        if private and b != "fullspeed._core":
            out.append(f"{a} (line {line}) takes the private name(s) {', '.join(private)} from {b}: make it public "
                       "where it belongs, or move it down")
    for comp in circles(edges):
        out.append("an import circle: " + " -> ".join(comp))
    return out


def test_the_package_is_in_layers_without_circles():
    assert findings() == []


def test_every_layer_is_a_subpackage_and_every_module_in_one():
    mods = modules(SRC)
    for name in LAYERS:
        assert f"fullspeed.{name}" in mods, f"fullspeed/{name}/__init__.py"
    root = sorted(m for m in mods if layer(m) == TOP)
    assert root == ["fullspeed", "fullspeed.__main__", "fullspeed._build", "fullspeed.cli"]
    # the C core's builder runs before the package exists: it imports nothing of it
    assert not [e for e in imports(SRC) if e[0] == "fullspeed._build"]


def _copy(tmp_path: Path) -> Path:
    shutil.copytree(SRC / "fullspeed", tmp_path / "fullspeed", ignore=shutil.ignore_patterns("*.so", "__pycache__"))
    return tmp_path


def test_a_circle_or_an_upward_import_is_found_and_named(tmp_path):
    src = _copy(tmp_path)
    units = src / "fullspeed" / "model" / "units.py"
    units.write_text(units.read_text() + "\n\nfrom ..sim.metrics import STAGES  # noqa\n")
    found = findings(src)
    assert any("fullspeed.model.units" in f and "imports fullspeed.sim.metrics" in f for f in found), found
    circle = [f for f in found if f.startswith("an import circle")]
    assert circle and "fullspeed.model.units" in circle[0] and "fullspeed.sim.metrics" in circle[0], found


def test_an_import_inside_a_function_and_a_private_name_are_found(tmp_path):
    src = _copy(tmp_path)
    rules = src / "fullspeed" / "design" / "rules.py"
    rules.write_text(rules.read_text() + "\n\ndef _late():\n    from ..model.files import _fsync_dir  # noqa\n")
    found = findings(src)
    assert any("fullspeed.design.rules" in f and "inside a function" in f for f in found), found
    assert any("private name(s) _fsync_dir from fullspeed.model.files" in f for f in found), found
