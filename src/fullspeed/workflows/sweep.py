"""Sweeps: one base scenario run over axes of its fields, in parallel,
resumable, as one table.

A sweep file is TOML:

    name = "my-map"
    base = "yang2022-smo-steady-400rpm"  # a catalog scenario, or a TOML path (relative to this file)
    seed = 1                             # for the random axes (Monte Carlo)
    samples = 1                          # random draws per grid point
    metrics = ["est_err_deg.mean"]       # what to keep (metrics.METRIC_NAMES); default all

    [overrides]                          # applied to every point
    duration = 1.0

    [axes]                               # the first varies slowest
    "references.i_q" = [5.0, 15.0, 25.0]                  # values
    "load.speed_rpm" = { linspace = [200.0, 1600.0, 8] }  # or range = [start, stop, step]
    "controller.R_s_scale" = { uniform = [0.8, 1.2] }     # or normal = [mean, sd], integers = [lo, hi]
    "load.speed_rpm,initial.speed_rpm" = [100.0, 200.0]   # several fields set to one value

The grid axes make a Cartesian product; each of its points is drawn
`samples` times on the random axes. The draws come from one generator seeded
by `seed`, in point order, so they do not depend on how the points are run.
"""
from __future__ import annotations

import csv
import itertools
import json
import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from ..design.scenario import scenario_from_dict
from ..model.errors import ConfigError, MissingFields
from ..model.files import package_names, path_kind, write_json, write_with
from ..model.scenario import SCENARIO, scenario_names, with_overrides
from ..model.schema import finite_number, parse_toml, read_toml
from ..sim.metrics import METRIC_NAMES, flat_metrics
from ..sim.plots import plot_sweep
from ..sim.runner import simulate
from .journal import DASK_TIMEOUT, JOURNAL, read_journal, run_tasks

GRID_KINDS = ("values", "linspace", "range")
RANDOM_KINDS = ("uniform", "normal", "integers")
TOP_KEYS = {"name", "description", "base", "seed", "samples", "metrics", "overrides", "axes"}
RESULT_COLUMNS = ("stop_reason", "stop_time", "error", "wall_s")
MAX_POINTS = 10**5   # 1.4 h on one core at 0.05 s a point, a day at 1 s: beyond, split the sweep
CHECKED_VALUES = 64  # an axis's values checked before the start (all of a shorter axis; else its ends and a spread)
RUN_METRICS = ("stop_reason", "stop_time", "wall_time")   # every row has them (wall_time as wall_s)


@dataclass(frozen=True)
class Axis:
    name: str                  # the column: the key as written
    fields: tuple[str, ...]    # dotted scenario fields it sets
    kind: str                  # GRID_KINDS or RANDOM_KINDS
    values: tuple = ()         # grid axes: the values
    params: tuple = ()         # random axes: the distribution's parameters

    @property
    def random(self) -> bool:
        return self.kind in RANDOM_KINDS


@dataclass
class Sweep:
    name: str
    base: dict                 # the base scenario's raw TOML data
    base_source: str
    axes: list[Axis]
    seed: int = 0
    samples: int = 1
    metrics: list[str] = field(default_factory=list)   # beyond RUN_METRICS
    overrides: dict = field(default_factory=dict)
    description: str = ""

    @property
    def grid(self) -> list[Axis]:
        return [a for a in self.axes if not a.random]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a.values) for a in self.grid)

    def points(self) -> list[dict]:
        """Each point's axis values by column, in run order."""
        rng = np.random.default_rng(self.seed)
        rand = [a for a in self.axes if a.random]
        out = []
        for combo in itertools.product(*(a.values for a in self.grid)):
            for s in range(self.samples):
                p = {a.name: v for a, v in zip(self.grid, combo)}
                if self.samples > 1:
                    p["sample"] = s
                for a in rand:
                    p[a.name] = _draw(rng, a)
                out.append(p)
        return out

    def merged(self) -> dict:
        """The base with the overrides, as run's --set merges them (a field
        of a machine given by name goes into that machine, a file resolved
        beside the base); where an axis sets a field of that machine, the
        machine as its table once here, not its file read at every point."""
        data = with_overrides(self.base, self.overrides, self.base_source)
        keys = {f.split(".")[1] for a in self.axes for f in a.fields if f.startswith("machine.")}
        if keys and not {"catalog", "zoo"} & keys:
            data = with_overrides(data, {"machine": {}}, self.base_source)   # no field: the machine as its table
        return data

    def tasks(self) -> list[dict]:
        tasks = []
        base = self.merged()
        for p in self.points():
            data = base
            for a in self.axes:
                data = _set_axis(data, a, p[a.name], self.base_source)
            tasks.append({"scenario": data, "source": self.base_source, "metrics": self.metrics})
        return tasks


def _draw(rng: np.random.Generator, a: Axis):
    if a.kind == "uniform":
        return float(rng.uniform(*a.params))
    if a.kind == "normal":
        return float(rng.normal(*a.params))
    return int(rng.integers(a.params[0], a.params[1], endpoint=True))


def _nested(dotted: str, value) -> dict:
    """{"a": {"b": value}} for "a.b"."""
    out = value
    for k in reversed(dotted.split(".")):
        out = {k: out}
    return out


def _check_field(dotted: str, source: str) -> None:
    """The field exists in the scenario schema (machine fields are checked
    when each point's scenario is built)."""
    keys = dotted.split(".")
    table = SCENARIO
    for n, k in enumerate(keys):
        if k not in table:
            where = ".".join(keys[:n]) or "the scenario"
            raise ConfigError(f"axes.{dotted}", k, f"is not a field of {where}; allowed: {', '.join(sorted(table))}", source)
        spec = table[k]
        if spec.kind == "any":
            return
        if spec.kind != "table":
            if n != len(keys) - 1:
                raise ConfigError(f"axes.{dotted}", dotted, f"{'.'.join(keys[:n + 1])} is a value, not a table", source)
            return
        table = spec.table
    raise ConfigError(f"axes.{dotted}", dotted, "names a table; an axis sets one value", source)


_number = finite_number
INT64 = 2**63   # numpy's random integers are int64


def _axis(name: str, raw, source: str) -> Axis:
    fields = tuple(f.strip() for f in name.split(","))
    for f in fields:
        _check_field(f, source)
    key = f"axes.{name}"
    if isinstance(raw, list):
        if not raw:
            raise ConfigError(key, raw, "must list at least one value", source)
        return Axis(name, fields, "values", tuple(raw))
    if not isinstance(raw, dict) or len(raw) != 1:
        raise ConfigError(key, raw, "must be a list of values or a table with one of: "
                          + ", ".join(GRID_KINDS[1:] + RANDOM_KINDS), source)
    (kind, p), = raw.items()
    if kind not in GRID_KINDS[1:] + RANDOM_KINDS:
        raise ConfigError(f"{key}.{kind}", p, "unknown; allowed: " + ", ".join(GRID_KINDS[1:] + RANDOM_KINDS), source)
    want = {"linspace": "[start, stop, count]", "range": "[start, stop, step]", "uniform": "[low, high]",
            "normal": "[mean, sd]", "integers": "[low, high] (both included)"}[kind]
    n = 3 if kind in ("linspace", "range") else 2
    if not isinstance(p, list) or len(p) != n or not all(_number(x) for x in p):
        raise ConfigError(f"{key}.{kind}", p, f"must be {want} of finite numbers", source)
    if kind == "linspace":
        if not (isinstance(p[2], int) and 1 <= p[2] <= MAX_POINTS):
            raise ConfigError(f"{key}.linspace", p, f"the count must be an integer from 1 to {MAX_POINTS}", source)
        return Axis(name, fields, kind, tuple(float(x) for x in np.linspace(float(p[0]), float(p[1]), p[2])))
    if kind == "range":
        start, stop, step = (float(x) for x in p)
        span = stop - start   # inf for bounds near the largest double
        if step == 0 or not math.isfinite(span) or span / step < 0 or span / step > MAX_POINTS:
            raise ConfigError(f"{key}.range", p, "the step must be non-zero, point from start to stop, "
                              f"and give at most {MAX_POINTS} values", source)
        count = int(math.floor((stop - start) / step + 1e-9)) + 1
        return Axis(name, fields, kind, tuple(float(start + k * step) for k in range(count)))
    if kind == "uniform" and not (p[0] < p[1] and math.isfinite(float(p[1]) - float(p[0]))):
        raise ConfigError(f"{key}.uniform", p, "must have low < high, high - low a finite double", source)
    if kind == "normal" and not (p[1] >= 0 and math.isfinite(abs(float(p[0])) + 10 * float(p[1]))):
        raise ConfigError(f"{key}.normal", p, "must have sd >= 0 and |mean| + 10 sd a finite double", source)
    if kind == "integers" and not (all(isinstance(x, int) for x in p) and -INT64 <= p[0] <= p[1] < INT64):
        raise ConfigError(f"{key}.integers", p, "must be integers with low <= high, both in [-2^63, 2^63)", source)
    return Axis(name, fields, kind, params=tuple(p) if kind == "integers" else tuple(float(x) for x in p))


def sweep_names() -> list[str]:
    return package_names("sweeps")


def _base_data(base, here: Path | None, source: str) -> tuple[dict, str]:
    if not isinstance(base, str):
        raise ConfigError("base", base, "must be a catalog scenario's name or a TOML file's path", source)
    p = Path(base)
    if p.suffix == ".toml":
        p = p if p.is_absolute() or here is None else here / p
        return read_toml(p, "base", source), str(p)
    if base in scenario_names():
        src = f"scenarios/{base}.toml"
        return parse_toml((resources.files("fullspeed") / "scenarios" / f"{base}.toml").read_text(), "toml", src), src
    raise ConfigError("base", base, "unknown scenario; `fullspeed list` shows the catalog", source)


def sweep_from_dict(d: dict, source: str, here: Path | None = None) -> Sweep:
    for k in d:
        if k not in TOP_KEYS:
            raise ConfigError(k, d[k], "unknown key; allowed: " + ", ".join(sorted(TOP_KEYS)), source)
    absent = [(source, k, hint, False) for k, hint in (("name", "text"), ("base", "a catalog scenario or a .toml file"),
                                                       ("axes", "a table of scenario fields and their values")) if k not in d]
    if absent:
        raise MissingFields(absent)
    if not isinstance(d["name"], str) or not d["name"]:
        raise ConfigError("name", d["name"], "must be a non-empty string", source)
    base, base_src = _base_data(d["base"], here, source)
    seed, samples = d.get("seed", 0), d.get("samples", 1)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
        raise ConfigError("seed", seed, "must be an integer in [0, 2^63)", source)
    if isinstance(samples, bool) or not isinstance(samples, int) or not 1 <= samples <= MAX_POINTS:
        raise ConfigError("samples", samples, f"must be an integer from 1 to {MAX_POINTS}", source)
    metrics = d.get("metrics", list(METRIC_NAMES))
    if not isinstance(metrics, list) or not metrics:
        raise ConfigError("metrics", metrics, "must be a non-empty list of metric names", source)
    for m in metrics:
        if m not in METRIC_NAMES:
            raise ConfigError("metrics", m, "unknown metric; allowed: " + ", ".join(METRIC_NAMES), source)
    overrides = d.get("overrides", {})
    if not isinstance(overrides, dict):
        raise ConfigError("overrides", overrides, "must be a table of scenario fields", source)
    if not isinstance(d["axes"], dict) or not d["axes"]:
        raise ConfigError("axes", d["axes"], "must be a table with at least one axis", source)
    axes = [_axis(k, v, source) for k, v in d["axes"].items()]
    cols = [f for a in axes for f in a.fields]
    if len(set(cols)) != len(cols):
        raise ConfigError("axes", list(d["axes"]), "each field may be set by one axis only", source)
    if samples > 1 and not any(a.random for a in axes):
        raise ConfigError("samples", samples, "more than 1 needs a random axis (uniform, normal, integers)", source)
    n_points = math.prod(len(a.values) for a in axes if not a.random) * samples
    if n_points > MAX_POINTS:
        raise ConfigError("axes", list(d["axes"]), f"give {n_points} points with samples = {samples}; at most {MAX_POINTS}", source)
    sw = Sweep(name=d["name"], base=base, base_source=base_src, axes=axes, seed=seed, samples=samples,
               metrics=[m for m in metrics if m not in RUN_METRICS], overrides=overrides, description=d.get("description", ""))
    check_points(sw, source)
    return sw


def check_points(sw: Sweep, source: str) -> None:
    """The base with the overrides, and with each grid value in turn, is a
    valid scenario: a mistake is one line now, not one failed row per point.
    A long axis is checked at its first and last values, its extremes and a
    spread of CHECKED_VALUES in all, so that the start stays quick; a value
    in between that the scenario refuses is a row with its error.
    A random axis is checked on its own draws (the sweep's, from its seed),
    chosen the same way: refused when none of them is valid (a distribution
    beyond the field's range); one that is partly valid runs, a draw the
    scenario refuses being its point's error row (a tail past a limit)."""
    # each checked for its refusal alone: no warning formed; a file the base names is found beside
    # the base, as its points run (run_point), and a refusal names the sweep
    base = sw.base_source
    try:
        data = sw.merged()
        scenario_from_dict(data, base, warn=False)
    except ConfigError as exc:
        raise _noted(exc, "the base with its overrides", source) from None
    for a in sw.grid:
        for v in _checked(a.values):
            try:
                scenario_from_dict(_set_axis(data, a, v, base), base, warn=False)
            except ConfigError as exc:
                raise _noted(exc, f"axes.{a.name} = {v!r}", source) from None
    points = sw.points() if any(a.random for a in sw.axes) else []
    for a in sw.axes:
        if a.random:
            _check_draws(data, a, _checked(tuple(p[a.name] for p in points)), source, base)


def _noted(exc: ConfigError, where: str, source: str) -> ConfigError:
    if isinstance(exc, MissingFields):
        return exc.noted(where)
    return ConfigError(exc.field, exc.value, f"{exc.allowed} ({where})", source)


def _check_draws(data: dict, a: Axis, draws: list, source: str, base: str) -> None:
    """At least one of a random axis's draws is a valid scenario, else the
    axis's refusal: its distribution, the first draw and what the field allows."""
    first = None
    for v in draws:
        try:
            scenario_from_dict(_set_axis(data, a, v, base), base, warn=False)
            return
        except ConfigError as exc:
            first = first or (v, exc)
    v, exc = first
    raise ConfigError(f"axes.{a.name}.{a.kind}", list(a.params),
                      f"none of its {len(draws)} draws checked is valid: {v!r} is refused: {exc.allowed}", source)


def _checked(values: tuple) -> list:
    """All values of a short axis; of a long one, the ends, the extremes and an even spread."""
    n = len(values)
    if n <= CHECKED_VALUES:
        return list(values)
    picks = {0, n - 1} | {round(k * (n - 1) / (CHECKED_VALUES - 3)) for k in range(CHECKED_VALUES - 3)}
    nums = [k for k, v in enumerate(values) if finite_number(v)]
    if nums:
        picks |= {min(nums, key=lambda k: values[k]), max(nums, key=lambda k: values[k])}
    return [values[k] for k in sorted(picks)]


def _set_axis(data: dict, a: Axis, value, source: str) -> dict:
    for f in a.fields:
        data = with_overrides(data, _nested(f, value), source)
    return data


def load_sweep_file(name_or_path: str | Path) -> Sweep:
    """A sweep by catalog name or TOML path."""
    p = Path(name_or_path)
    kind = path_kind(p)
    # a file by that name wins; a folder by a catalog name (an earlier --out) does not shadow the catalog
    if p.suffix == ".toml" or kind == "file" or (str(name_or_path) not in sweep_names() and kind is not None):
        return sweep_from_dict(read_toml(p, "sweep"), str(p), p.parent)
    if str(name_or_path) in sweep_names():
        source = f"sweeps/{name_or_path}.toml"
        return sweep_from_dict(parse_toml((resources.files("fullspeed") / "sweeps" / f"{name_or_path}.toml").read_text(),
                                          "toml", source), source, None)
    raise ConfigError("sweep", str(name_or_path), "neither a TOML file nor a catalog sweep ("
                      + ", ".join(sweep_names()) + ")")


def run_point(task: dict) -> dict:
    """One point: build its scenario, run it, keep the chosen metrics (its
    scalars: the warnings, a list, are never among them, so none is formed)."""
    res = simulate(scenario_from_dict(task["scenario"], task["source"], warn=False))
    if res.stop_reason == "interrupted":   # Ctrl-C: not a finished point (the sweep stops, the point runs on resume)
        raise KeyboardInterrupt
    m = flat_metrics(res.metrics)
    out = {k: m[k] for k in task["metrics"]}
    out.update(stop_reason=res.stop_reason, stop_time=res.stop_time, wall_s=res.wall_time)
    return out


def point_result_ok(result: dict) -> bool:
    """A result as run_point (or journal.guarded, for a point that raised)
    returns it: stop_reason a string; a finished point's wall_s a number;
    every other value of its column's type (text, a flag, a count, a
    number) or empty. A journal line that is not is run again, instead of
    an empty row or a table that cannot be written."""
    if not isinstance(result.get("stop_reason"), str):
        return False
    if result["stop_reason"] != "error" and not _real(result.get("wall_s")):
        return False
    for k, v in result.items():
        ok = (isinstance(v, str) if k in ("stop_reason", "error") else isinstance(v, bool) if k == "silent_failure"
              else type(v) is int if k == "recoveries" else _real(v))
        if v is not None and not ok:
            return False
    return True


def _real(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


run_point.journal_name = "fullspeed.sweep.run_point"   # its module before the layers (journal._identity)
run_point.journal_check = point_result_ok


def columns(sw: Sweep) -> list[str]:
    axis_cols = [a.name for a in sw.grid] + (["sample"] if sw.samples > 1 else []) + [a.name for a in sw.axes if a.random]
    return ["point"] + axis_cols + sw.metrics + list(RESULT_COLUMNS)


def rows_of(sw: Sweep, results: list[dict | None]) -> list[dict]:
    cols = columns(sw)
    rows = []
    for k, (p, r) in enumerate(zip(sw.points(), results)):
        if r is None:
            continue
        row = {c: None for c in cols}
        row.update(point=k, **p)
        row.update({c: r.get(c) for c in cols if c in r})
        rows.append(row)
    return rows


def _pyarrow():
    """pyarrow and its parquet module, or None when not installed."""
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError:
        return None
    return pyarrow, pyarrow.parquet


def _drop_other_table(out: Path, name: str) -> None:
    """Remove the table of the other format an earlier run in out wrote
    (pyarrow installed or removed since): this run's table supersedes it, and
    two could disagree (load_sweep reads results.parquet first). Removed
    before the new one is written: a kill between leaves no table, and
    load_sweep the journal's rows, never the stale table beside the new."""
    other = out / ("results.csv" if name == "results.parquet" else "results.parquet")
    if other.is_symlink() or path_kind(other) == "file":   # a folder or a device of that name is not ours
        other.unlink(missing_ok=True)


def write_table(rows: list[dict], cols: list[str], out: Path) -> Path:
    """results.parquet with pyarrow, else results.csv; the other format's
    table of an earlier run there is removed."""
    arrow = _pyarrow()
    if arrow is None:
        def write_csv(tmp: Path):
            with open(tmp, "w", newline="") as f:
                w = csv.DictWriter(f, fieldnames=cols)
                w.writeheader()
                w.writerows(rows)
        _drop_other_table(out, "results.csv")
        return write_with(out / "results.csv", write_csv)
    pa, pq = arrow
    table = pa.Table.from_pylist(rows, schema=_schema(rows, cols))
    _drop_other_table(out, "results.parquet")
    return write_with(out / "results.parquet", lambda tmp: pq.write_table(table, tmp))


def _schema(rows, cols):
    import pyarrow as pa

    types = []
    for c in cols:
        vals = [r[c] for r in rows if r[c] is not None]
        if vals and all(isinstance(v, str) for v in vals) or not vals and c in ("stop_reason", "error"):
            types.append(pa.string())
        elif vals and all(isinstance(v, int) and not isinstance(v, bool) for v in vals):
            types.append(pa.int64())
        else:
            types.append(pa.float64())
    return pa.schema(list(zip(cols, types)))


def run_sweep(sw: Sweep, out: Path, workers: int | None = None, dask: str | None = None,
              progress: bool = False, plot: bool = True, dask_timeout: float = DASK_TIMEOUT) -> tuple[Path, list[dict]]:
    """Run the missing points of sw into out; write the table (and a figure)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "sweep.json", {
        "name": sw.name, "description": sw.description, "base": sw.base_source, "seed": sw.seed,
        "samples": sw.samples, "columns": columns(sw),
        "axes": [{"name": a.name, "fields": a.fields, "kind": a.kind, "values": a.values, "params": a.params}
                 for a in sw.axes],
        "points": sw.points()})
    results = run_tasks(run_point, sw.tasks(), out, workers=workers, dask=dask, progress=progress, desc=sw.name,
                        dask_timeout=dask_timeout)
    rows = rows_of(sw, results)
    path = write_table(rows, columns(sw), out)
    if plot:
        write_with(out / "sweep.png", lambda tmp: plot_sweep(sw, rows, tmp) is not None)
    return path, rows


def load_sweep(folder: str | Path):
    """A sweep's table as a pandas DataFrame: the written table, or, for a
    sweep that has not finished, the points its journal holds."""
    import pandas as pd

    folder = Path(folder)
    for name, read in (("results.parquet", pd.read_parquet), ("results.csv", pd.read_csv)):
        if (folder / name).exists():
            try:
                return read(folder / name)
            except Exception:   # torn by an older version's in-place write: the journal holds the rows
                break
    meta = folder / "sweep.json"
    if not meta.exists():
        raise ConfigError("folder", str(folder), "holds no sweep (no results table, no sweep.json)")
    info = json.loads(meta.read_text())
    done = read_journal(folder / JOURNAL, len(info["points"]), point_result_ok)
    rows = [{"point": k, **info["points"][k], **r} for k, r in sorted(done.items())]
    return pd.DataFrame(rows, columns=info["columns"])
