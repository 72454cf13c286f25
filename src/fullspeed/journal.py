"""Durable parallel execution of many independent tasks, the engine under
sweeps and the reproduction's maps.

Each task is a JSON-able dict; fn(task) returns a JSON-able dict. Results are
appended to `journal.jsonl` in the output folder by this (the parent)
process, one line per finished task, flushed and fsynced before the next:
a run killed at any instant (even by SIGKILL) loses at most the tasks still
in flight, and started again on the same folder runs only those. The folder's
`tasks.json` names what the journal belongs to, so a different set of tasks
is refused instead of mixed in.

Tasks run in N local worker processes, or on a Dask cluster (an optional
dependency) when an address is given. A task that raises is recorded with
its reason and does not stop the others.
"""
from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable
from pathlib import Path

from .errors import ConfigError
from .metrics import json_safe

JOURNAL = "journal.jsonl"
TASKS = "tasks.json"


def default_workers() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:   # not on Linux
        return max(1, os.cpu_count() or 1)


def guarded(fn: Callable[[dict], dict], task: dict) -> dict:
    """fn(task), or the reason it failed: one line, never an exception."""
    try:
        return fn(task)
    except Exception as exc:  # a failing point is recorded, the sweep goes on
        msg = str(exc).splitlines()[0] if str(exc) else ""
        return {"stop_reason": "error", "error": f"{type(exc).__name__}: {msg}"}


def _identity(fn: Callable, tasks: list[dict]) -> str:
    text = json.dumps({"fn": f"{fn.__module__}.{fn.__qualname__}", "tasks": tasks}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def read_journal(path: Path, n: int) -> dict[int, dict]:
    """The finished tasks by index. A line cut short by a kill is dropped and
    the file truncated to its last whole line, so appends stay well formed."""
    if not path.exists():
        return {}
    raw = path.read_bytes()
    whole = raw[: raw.rfind(b"\n") + 1]
    if len(whole) != len(raw):
        with open(path, "r+b") as f:
            f.truncate(len(whole))
    done = {}
    for line in whole.splitlines():
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:
            continue
        k = rec.get("task")
        if isinstance(k, int) and 0 <= k < n and k not in done:
            done[k] = rec["result"]
    return done


class _Journal:
    def __init__(self, path: Path):
        self._f = open(path, "a", encoding="utf-8")

    def record(self, index: int, result: dict) -> None:
        self._f.write(json.dumps({"task": index, "result": result}, allow_nan=False) + "\n")
        self._f.flush()
        os.fsync(self._f.fileno())

    def close(self) -> None:
        self._f.close()


def _local(fn, tasks: dict[int, dict], workers: int):
    """(index, result) as tasks finish, in `workers` processes (1: here)."""
    if workers == 1:
        for k, task in tasks.items():
            yield k, guarded(fn, task)
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    ctx = multiprocessing.get_context("forkserver")
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        futures = {pool.submit(guarded, fn, task): k for k, task in tasks.items()}
        for fut in as_completed(futures):
            try:
                yield futures[fut], fut.result()
            except BrokenProcessPool:
                # a worker died (a crash in the core): not recorded, so the
                # next start of the same command runs it again
                continue


def _dask(fn, tasks: dict[int, dict], address: str):
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise ConfigError("--dask", address, "needs dask.distributed: pip install 'fullspeed[sweep]'") from None
    try:
        client = Client(address, timeout="10s")
    except (OSError, TimeoutError) as exc:
        raise ConfigError("--dask", address, f"no Dask scheduler answers there ({exc})") from None
    try:
        futures = {client.submit(guarded, fn, task, pure=False): k for k, task in tasks.items()}
        for fut in as_completed(futures):
            yield futures[fut], fut.result()
    finally:
        client.close()


def run_tasks(fn: Callable[[dict], dict], tasks: list[dict], out: Path, workers: int | None = None,
              dask: str | None = None, progress: bool = False, fresh: bool = False,
              desc: str = "runs") -> list[dict]:
    """Every task's result, in the tasks' order; resumes from out's journal.

    fn must be importable by name (a module-level function) so that worker
    processes can run it. fresh: forget an earlier journal in out.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ident = _identity(fn, tasks)
    journal, stamp = out / JOURNAL, out / TASKS
    if fresh:
        journal.unlink(missing_ok=True)
    if stamp.exists() and journal.exists():
        old = json.loads(stamp.read_text()).get("identity")
        if old != ident:
            raise ConfigError("--out", str(out), "holds the journal of a different sweep; "
                              "choose another folder or remove this one")
    stamp.write_text(json.dumps({"identity": ident, "tasks": len(tasks)}))
    done = read_journal(journal, len(tasks))
    todo = {k: t for k, t in enumerate(tasks) if k not in done}
    workers = workers or default_workers()
    if workers < 1:
        raise ConfigError("--workers", workers, "must be at least 1")
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(tasks), initial=len(done), desc=desc, unit="run", smoothing=0.1)
    rec = _Journal(journal)
    try:
        stream = _dask(fn, todo, dask) if dask else _local(fn, todo, min(workers, max(1, len(todo))))
        for k, result in stream:
            result = json_safe(result)   # as a resumed run reads it back
            rec.record(k, result)
            done[k] = result
            if bar is not None:
                bar.update(1)
    finally:
        rec.close()
        if bar is not None:
            bar.close()
    return [done.get(k) for k in range(len(tasks))]
