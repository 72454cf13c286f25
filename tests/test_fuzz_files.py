"""Fuzzing what reaches files (issue 40), beside tests/test_fuzz.py's
scenarios: hostile names through `fullspeed export` (into generated C) and
`fullspeed identify` (into a folder name and TOML), and flux-map files (CSV
and .mat) through the loader. Every outcome is a clean one: an export that
compiles to an object holding its one constant and nothing else, TOML that
reads back the name it was given, files only inside the output folder, a
map or a one-line ConfigError; never another exception, never a hang.
"""
from __future__ import annotations

import collections
import contextlib
import io
import shutil
import subprocess
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from fullspeed.cli import main
from fullspeed.model.errors import ConfigError
from fullspeed.model.fluxmap import load_map
from fullspeed.model.schema import toml_string

from reliability_helpers import fake_identification, within

ROOT = Path(__file__).resolve().parents[1]
CC = shutil.which("cc") or shutil.which("gcc")
TIME_LIMIT = 30   # s per case
OUTCOMES: collections.Counter = collections.Counter()

BASE = ('name = "fuzz"\nduration = 0.05\nmachine = "yang2022"\n[controller]\nmode = "current"\nangle = "encoder"\n'
        '[references]\ni_q = 5.0\n[load]\nkind = "torque"\ntorque = 0.0\n')

# pieces that have broken generated text before: comment ends and starts, line
# splices, trigraphs, preprocessor lines, quotes, path parts, controls, bidi
PIECES = ["*/", "/*", "//", "\\", "\\\n", "??/", "??=", "\n", "\r", "#include <stdio.h>", "#define X", '"', "'", "..",
          "/", "\u0000", "\u007f", "\u202e", "\u2066", "\ufeff", "\U0001F680", "int pwned(void){return 1;}", "x", " "]
names = st.one_of(st.text(max_size=40), st.lists(st.sampled_from(PIECES), max_size=8).map("".join),
                  st.text(alphabet=st.characters(codec="utf-8"), min_size=1, max_size=300))


def cli(*argv) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = main(list(argv))
    return rc, err.getvalue()


def refused_cleanly(rc: int, err: str, case) -> bool:
    assert "Traceback" not in err and "internal error" not in err, (err, case)
    if rc != 2:
        return False
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("fullspeed: warning: ")]
    assert len(lines) == 1 and lines[0].startswith("fullspeed: error: "), (err, case)
    return True


def scenario_text(name: str, machine: str | None) -> str:
    text = BASE.replace('name = "fuzz"', f"name = {toml_string(name)}")
    if machine is not None:
        text = text.replace('machine = "yang2022"', f'machine = {{ catalog = "yang2022", name = {toml_string(machine)} }}')
    return text


def write(path: Path, text: str) -> None:
    path.write_text(text, encoding="utf-8", errors="surrogatepass")


@pytest.mark.skipif(CC is None, reason="no host C compiler")
@settings(max_examples=24, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(name=names, machine=st.one_of(st.none(), names), folder=st.one_of(st.none(), names),
       c_name=st.one_of(st.just("fs_config"), st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,20}", fullmatch=True), names))
def test_fuzzed_names_through_export(name, machine, folder, c_name):
    """Scenario name, machine name, a folder of the scenario's path and
    --name: exit 0 with a pair that compiles to exactly the constant, or
    one line of refusal (exit 2)."""
    tmp = Path(tempfile.mkdtemp(prefix="fuzz-export-"))
    try:
        src = tmp / "s.toml"
        if folder:
            part = folder.replace("/", "_").replace("\u0000", "_")[:100]
            if part not in (".", ".."):
                try:
                    (tmp / part).mkdir()
                    src = tmp / part / "s.toml"
                except (OSError, ValueError, UnicodeEncodeError):
                    pass
        write(src, scenario_text(name, machine))
        out = tmp / "out"
        case = (name, machine, folder, c_name)
        with within(TIME_LIMIT, repr(case)):
            rc, err = cli("export", str(src), "--out", str(out), "--name", c_name)
        if refused_cleanly(rc, err, case):
            OUTCOMES["export refused"] += 1
            return
        assert rc == 0, (rc, err, case)
        obj = tmp / "x.o"
        r = subprocess.run([CC, "-std=c99", "-Wall", "-Wextra", "-Werror", f"-I{ROOT / 'csrc' / 'control'}", f"-I{out}",
                            "-c", str(out / f"{c_name}.c"), "-o", str(obj)], capture_output=True, text=True)
        assert r.returncode == 0, (r.stderr, case)
        nm = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout.split()
        assert nm[-2:] == ["R", c_name] and len(nm) == 3, (nm, case)
        OUTCOMES["export compiled"] += 1
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(machine=names, default_folder=st.booleans())
def test_fuzzed_machine_names_through_identify(machine, default_folder):
    """The machine's name makes identify's default folder and goes into its
    TOML: exit 0 with every file inside the work folder and the name read
    back as given, or one line of refusal before the identification."""
    import fullspeed.workflows.identify as idf

    tmp = Path(tempfile.mkdtemp(prefix="fuzz-identify-"))
    work = tmp / "w"
    work.mkdir()
    ran = []

    def fake(sc, **kw):   # the identification's result at the truth: what is fuzzed is where and how it is written
        ran.append(sc.machine.name)
        return fake_identification(sc)
    real = idf.identify
    idf.identify = fake
    try:
        write(work / "s.toml", scenario_text("id", machine))
        argv = ["identify", "s.toml"] + ([] if default_folder else ["--out", "o"])
        with within(TIME_LIMIT, repr(machine)), contextlib.chdir(work):
            rc, err = cli(*argv)
        if refused_cleanly(rc, err, machine):
            assert not ran, "refused after the identification ran"
            OUTCOMES["identify refused"] += 1
            return
        assert rc == 0, (rc, err, machine)
        written = [p for p in tmp.rglob("*") if p.is_file() and p.name != "s.toml"]
        assert len(written) == 2 and all(p.resolve().is_relative_to(work.resolve()) for p in written), written
        back = {p.name: tomllib.loads(p.read_text(encoding="utf-8")) for p in written}
        assert back["identification.toml"]["machine"] == ran[0]
        assert back["machine.toml"]["name"] == f"{ran[0]}-identified"
        OUTCOMES["identify written"] += 1
    finally:
        idf.identify = real
        shutil.rmtree(tmp, ignore_errors=True)


# --- flux-map files ---------------------------------------------------------------------

UNITS = ["A", "kA", "mA", "Wb", "mWb", "Vs", "N m", "Nm", "", "x", " A ", "A]", "[A"]
COLS = ["i_d", "i_q", "psi_d", "psi_q", "T", "id", "Iq", "psid", "flux_q", "torque", "other", ""]


@st.composite
def csv_texts(draw) -> str:
    pad = st.sampled_from(["", " ", "  ", " " * draw(st.integers(0, 5000))])
    if draw(st.booleans()):   # the columns a map needs, written in their many ways
        cols = ["i_d", "i_q", "psi_d", "psi_q"] + draw(st.lists(st.sampled_from(["T", "other"]), max_size=1))
        units = {"i_d": "A", "i_q": "A", "psi_d": "mWb", "psi_q": "Vs", "T": "N m", "other": "x"}
        header = ",".join(f"{draw(pad)}{c}{draw(pad)}[{draw(pad)}{units[c]}{draw(pad)}]{draw(pad)}" for c in cols)
    else:
        cols = draw(st.lists(st.sampled_from(COLS), min_size=1, max_size=6))
        header = ",".join(f"{draw(pad)}{c}{draw(pad)}{draw(st.sampled_from(['[', '(', '']))}{draw(pad)}"
                          f"{draw(st.sampled_from(UNITS))}{draw(pad)}{draw(st.sampled_from([']', ')', '']))}{draw(pad)}"
                          for c in cols)
    n_d, n_q = draw(st.integers(1, 6)), draw(st.integers(1, 6))
    corrupt = draw(st.integers(0, 2)) == 0
    cell = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.integers(-10**6, 10**6).map(str),
                     st.sampled_from(["", "x", "1e999", "-0", "0x10", "1" + "0" * 200_000, '"1"']))
    rows = []
    for k in range(n_d):
        for m in range(n_q):
            vals = [str(float(k)), str(float(m)), str(10.0 + k), str(1e-3 * m)]
            row = [vals[j] if j < 4 and not (corrupt and draw(st.integers(0, 9)) == 0) else draw(cell)
                   for j in range(len(cols))]
            rows.append(",".join(row))
    lines = ["# a map", header, *rows]
    if draw(st.booleans()):
        lines[1] = "\ufeff" + lines[1]
    return "\n".join(lines) + "\n"


def _load(path: Path, what) -> str:
    with within(TIME_LIMIT, repr(what)[:200]):
        try:
            mag = load_map(path, "magnetic.file")
        except ConfigError as e:
            assert "\n" not in str(e), str(e)
            return "refused"
    assert mag["model"] == "fluxmap" and np.isfinite(np.asarray(mag["psi_d"])).all()
    assert len(mag["i_d"]) >= 2 and len(mag["i_q"]) >= 2
    return "read"


def _plain_csv(units: str) -> str:
    """A map the loader reads: 3 x 2 points, the fluxes in `units`."""
    rows = [f"{d:g},{q:g},{10.0 + d:g},{1e-3 * q:g}" for d in (-1.0, 0.0, 1.0) for q in (0.0, 1.0)]
    return "\n".join(["# a map", f"i_d [A],i_q [A],psi_d [{units}],psi_q [{units}]", *rows]) + "\n"


# Two maps that read, whatever the draws: hypothesis draws its numbers partly from constants in the modules
# already imported, so the fuzzed draws (and how many of them read) depend on which tests ran before
@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(csv_texts())
@example(_plain_csv("mWb"))
@example(_plain_csv("Vs"))
def test_fuzzed_csv_flux_maps_read_or_refused_in_one_line(text):
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "map.csv"
        write(f, text)
        OUTCOMES[f"csv {_load(f, text[:300])}"] += 1


@st.composite
def mat_dicts(draw) -> dict:
    i_d, i_q = np.meshgrid([-20.0, 0.0, 20.0], [0.0, 10.0, 20.0][: draw(st.integers(1, 3))], indexing="ij")
    base = {"Id": i_q, "Iq": -i_d, "Fd": 1e-3 * i_q, "Fq": -(0.01 + 1e-3 * i_d), "T": 0.1 * i_q}
    for k in draw(st.lists(st.sampled_from(sorted(base)), unique=True, max_size=3)):   # wrong shapes, types, values, or gone
        base[k] = draw(st.sampled_from([base[k][:, :1], base[k].ravel(), base[k] * np.nan, base[k] + 1j, np.array("text"),
                                        np.zeros((0, 0)), 5.0, None]))
    base = {k: v for k, v in base.items() if v is not None}
    extra = {f"J{k}": np.zeros((draw(st.integers(1, 400)), 100)) for k in range(draw(st.integers(0, 2)))}
    layout = draw(st.sampled_from(["top", "motorModel", "bare", "number"]))
    if layout == "motorModel":
        return {"motorModel": {"FluxMap_dq": base, **extra}}
    if layout == "number":
        return {"motorModel": {"FluxMap_dq": 5.0}}
    return {**base, **extra} if layout == "top" else extra or {"x": np.zeros(1)}


@settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(mat_dicts(), st.booleans(), st.integers(0, 3))
def test_fuzzed_mat_flux_maps_read_or_refused_in_one_line(data, compress, cut):
    sio = pytest.importorskip("scipy.io")
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "map.mat"
        sio.savemat(f, data, do_compression=compress)
        if cut:   # a file cut short, or its middle overwritten
            raw = f.read_bytes()
            f.write_bytes(raw[: len(raw) * cut // 4] if cut < 3 else raw[:200] + b"\xff" * 64 + raw[264:])
        OUTCOMES[f"mat {_load(f, (sorted(data), compress, cut))}"] += 1


def test_fuzzing_of_files_reached_every_outcome():
    """The cases above (run first) were not degenerate: each surface both
    accepted and refused."""
    print("fuzz outcomes (files):", dict(OUTCOMES))
    for k in ("export compiled", "export refused", "identify written", "identify refused", "csv read", "csv refused",
              "mat read", "mat refused"):
        assert OUTCOMES[k] >= 2, OUTCOMES
