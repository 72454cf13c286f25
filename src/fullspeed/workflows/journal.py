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
import select
import signal
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

from ..model.errors import ConfigError, EngineError
from ..model.files import json_safe, path_kind, read_text, write_json

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
    # a worker's journal_name, where it has one, keeps the journals it wrote
    # before it moved to another module resumable
    name = getattr(fn, "journal_name", f"{fn.__module__}.{fn.__qualname__}")
    text = json.dumps({"fn": name, "tasks": tasks}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def read_journal(path: Path, n: int, check: Callable[[dict], bool] | None = None) -> dict[int, dict]:
    """The finished tasks by index. A line cut short by a kill is dropped and
    the file truncated to its last whole line, so appends stay well formed.
    A line that is not a task's result (garbage, NULs, a record without a
    result table, a result `check` refuses: a hand-edited or foreign line
    with wrong types or without what the task returns) is skipped: its task
    runs again."""
    kind = path_kind(path)
    if kind is None:
        return {}
    if kind != "file":
        raise ConfigError("journal", str(path), "is not a regular file; remove it (the sweep then starts over)")
    raw = path.read_bytes()
    whole = raw[: raw.rfind(b"\n") + 1]
    if len(whole) != len(raw):
        with open(path, "r+b") as f:
            f.truncate(len(whole))
    done = {}
    for line in whole.splitlines():
        try:
            rec = json.loads(line)
        except (ValueError, RecursionError):   # not JSON, not UTF-8, nested beyond the parser
            continue
        if not isinstance(rec, dict):
            continue
        k, result = rec.get("task"), rec.get("result")
        if type(k) is int and 0 <= k < n and k not in done and isinstance(result, dict) \
                and (check is None or check(result)):
            done[k] = result
    return done


def _read_stamp(path: Path) -> dict | None:
    """tasks.json's content, or None when it is missing or unreadable."""
    try:
        d = json.loads(read_text(path, "tasks.json", limit=2**20))
    except (ConfigError, ValueError, RecursionError):
        return None
    return d if isinstance(d, dict) else None


class _Journal:
    def __init__(self, path: Path):
        self._f = open(path, "a", encoding="utf-8")

    def record(self, index: int, result: dict) -> None:
        self._f.write(json.dumps({"task": index, "result": result}, allow_nan=False) + "\n")
        self._f.flush()
        os.fsync(self._f.fileno())

    def close(self) -> None:
        self._f.close()


class _Interrupts:
    """Notes a Ctrl-C while the tasks run in this process, even when a task
    swallows it (simulate keeps an interrupted run's traces and returns):
    the task that was interrupted is then not journaled as finished."""

    def __init__(self):
        self.seen = False
        self._prev = None

    def __enter__(self):
        if threading.current_thread() is threading.main_thread() \
                and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            self._prev = signal.signal(signal.SIGINT, self._handler)
        return self

    def _handler(self, signum, frame):
        self.seen = True
        raise KeyboardInterrupt

    def __exit__(self, *exc):
        if self._prev is not None:
            signal.signal(signal.SIGINT, self._prev)


def _worker_init(parent: int, then: Callable | None = None, then_args: tuple = ()) -> None:
    """Worker processes leave Ctrl-C to the parent, which stops them, and
    end when the parent ends, however it ends (kill -9, the OOM killer):
    nothing else would wake them (each holds its queue's writing end as
    well), and the forkserver and the resource tracker, which live as long
    as a worker holds their pipes, end after them. Then then(*then_args)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_exit_with, args=(parent,), daemon=True, name="fullspeed-parent-watch").start()
    if then is not None:
        then(*then_args)


_PRELOAD: set[str] = set()   # the modules this process's forkserver imports when it starts (preload)


def preload(*modules: str) -> None:
    """Adds modules to those this process's forkserver imports once, when it
    first starts, for every worker it forks after: each worker would import
    them again (about 0.5 s of CPU each time: numpy, the core, the figures).
    No effect once the server runs."""
    import multiprocessing

    _PRELOAD.update(modules)
    multiprocessing.get_context("forkserver").set_forkserver_preload(["__main__", *sorted(_PRELOAD)])


def _worker_pool(workers: int, then: Callable | None = None, then_args: tuple = (), modules: tuple[str, ...] = ()):
    """A pool of `workers` processes (forkserver: no copy of this process's
    state, `modules` preloaded) that leave Ctrl-C to this process and end
    with it (_worker_init), each running then(*then_args) first; stop it
    early with _stop."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    preload(*modules)
    return ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("forkserver"),
                               initializer=_worker_init, initargs=(os.getpid(), then, then_args))


def _exit_with(pid: int) -> None:
    """Wait for process pid to end (a pidfd on Linux, else a poll each
    second), then end this process."""
    try:
        fd = os.pidfd_open(pid)
    except (AttributeError, OSError):   # not Linux >= 5.3, or pid already gone
        fd = None
    if fd is not None:
        select.select([fd], [], [])     # readable once the process has ended
    else:
        while True:
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                break
            except PermissionError:     # alive, another user's: not ours to end
                pass
            time.sleep(1.0)
    os._exit(1)


def _stop(pool) -> None:
    """No queued task starts; the running ones are ended now."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(5)


def _deaths(procs) -> str:
    """How the pool's worker processes ended, for the message."""
    why = []
    for p in procs:
        code = p.exitcode
        if code is not None and code < 0:
            try:
                why.append(f"pid {p.pid} by {signal.Signals(-code).name}")
            except ValueError:
                why.append(f"pid {p.pid} by signal {-code}")
        elif code:
            why.append(f"pid {p.pid} with exit status {code}")
    return ", ".join(why) or "a worker process ended abruptly"


MAX_POOL_RESTARTS = 3   # a task that kills its worker every time (a crash in the core) cannot hold the rest forever


def _local(fn, tasks: dict[int, dict], workers: int):
    """(index, result) as tasks finish, in `workers` processes (in_pool;
    1: here)."""
    if workers == 1:
        with _Interrupts() as intr:
            for k, task in tasks.items():
                result = guarded(fn, task)
                if intr.seen:   # the task swallowed the interrupt: its result is not a finished one
                    raise KeyboardInterrupt
                yield k, result
        return
    yield from in_pool(guarded, {k: (fn, task) for k, task in tasks.items()}, workers, modules=(fn.__module__,),
                       what="tasks", retry="; run the same command again to retry them")


# CPU seconds the pool workers of this process spent in the calls they
# returned (in_pool adds each call's): beside time.process_time(), what a
# claim's campaign cost, its workers included (reproduce.report's cpu_s)
WORKER_CPU = [0.0]


def cpu_spent() -> float:
    """This process's CPU time with its pools' calls' (WORKER_CPU) and its
    waited-for children's (a compiler, an emulator), s."""
    import resource
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + WORKER_CPU[0] + ch.ru_utime + ch.ru_stime


def _timed(call: Callable, *a):
    """call(*a) in a worker, with the CPU time it took there."""
    t0 = time.process_time()
    result = call(*a)
    return result, time.process_time() - t0


def in_pool(call: Callable, args: dict, workers: int, then: Callable | None = None, then_args: tuple = (),
            modules: tuple[str, ...] = (), what: str = "tasks", retry: str = ""):
    """(k, call(*args[k])) as each finishes, in `workers` processes
    (_worker_pool: then, then_args, modules), started in args' order.

    Ctrl-C stops at once: nothing queued starts, what runs is ended and not
    reported. A worker that dies (killed, out of memory, a crash) costs the
    calls that were running or queued in its pool: they run again in a new
    pool, up to MAX_POOL_RESTARTS times, each time with a message; the keys
    of those still not run after that are not yielded (the message names
    how many `what`, then `retry`)."""
    from concurrent.futures import as_completed
    from concurrent.futures.process import BrokenProcessPool

    todo = dict(args)
    for attempt in range(MAX_POOL_RESTARTS + 1):
        pool = _worker_pool(min(workers, len(todo)), then, then_args, modules)
        broken = False
        try:
            futures = {pool.submit(_timed, call, *a): k for k, a in todo.items()}
            procs = list((getattr(pool, "_processes", None) or {}).values())
            for fut in as_completed(futures):
                try:
                    result, cpu = fut.result()
                except BrokenProcessPool:
                    broken = True
                    continue
                WORKER_CPU[0] += cpu
                del todo[futures[fut]]
                yield futures[fut], result
        except BaseException:   # Ctrl-C, or the caller stopped reading
            _stop(pool)
            raise
        pool.shutdown(wait=True)
        if not broken or not todo:
            return
        why = _deaths(procs)
        if attempt < MAX_POOL_RESTARTS:
            print(f"fullspeed: a worker process died ({why}); its pool's {len(todo)} unfinished {what} run again",
                  file=sys.stderr)
        else:
            print(f"fullspeed: {len(todo)} {what} not run: worker processes died {MAX_POOL_RESTARTS + 1} times "
                  f"(last: {why}){retry}", file=sys.stderr)


DASK_TIMEOUT = 60.0   # s: a cluster with no worker, or no answer, for this long is an error


def _dask(fn, tasks: dict[int, dict], address: str, timeout: float = DASK_TIMEOUT):
    """(index, result) as tasks finish on the Dask scheduler at address.
    A cluster with no worker for `timeout` seconds, or a scheduler that is
    lost, ends in an EngineError (one line); what finished is kept."""
    try:
        from distributed import Client, wait
    except ImportError:
        raise ConfigError("--dask", address, "needs dask.distributed: pip install 'fullspeed[sweep]'") from None
    import logging
    from concurrent.futures import CancelledError

    from distributed.comm.core import CommClosedError

    try:
        client = Client(address, timeout="10s")
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        msg = " ".join(str(exc).split())[:160]
        raise ConfigError("--dask", address, f"no Dask scheduler answers there ({type(exc).__name__}: {msg}); "
                          "give tcp://HOST:PORT", None) from None
    # a lost scheduler is our one line, not Dask's logged tracebacks (its loggers have their own levels)
    quiet = [logging.getLogger(n) for n in list(logging.root.manager.loggerDict) if n.split(".")[0] == "distributed"]
    levels = [lg.level for lg in quiet]
    for lg in quiet:
        lg.setLevel(logging.CRITICAL)
    try:
        futures = {client.submit(guarded, fn, task, pure=False): k for k, task in tasks.items()}
        pending = set(futures)
        idle = time.monotonic()
        while pending:
            try:
                done, pending = wait(pending, timeout=min(2.0, timeout), return_when="FIRST_COMPLETED")
            except TimeoutError:
                done = set()
            if done:
                idle = time.monotonic()
            elif client.scheduler_info().get("workers"):
                idle = time.monotonic()
            elif time.monotonic() - idle > timeout:
                raise EngineError(f"the Dask cluster at {address} has had no worker for {timeout:g} s; "
                                  f"{len(pending)} tasks not run: start workers and run the same command again")
            for fut in done:
                yield futures[fut], fut.result()
    except (OSError, CancelledError, CommClosedError) as exc:
        raise EngineError(f"lost the Dask scheduler at {address} ({type(exc).__name__}); "
                          "what finished is kept: run the same command again to resume") from None
    finally:
        try:
            client.close(timeout=5)
        except Exception:   # the scheduler is gone already
            pass
        for lg, level in zip(quiet, levels):
            lg.setLevel(level)


def run_tasks(fn: Callable[[dict], dict], tasks: list[dict], out: Path, workers: int | None = None,
              dask: str | None = None, progress: bool = False, fresh: bool = False,
              desc: str = "runs", dask_timeout: float = DASK_TIMEOUT) -> list[dict]:
    """Every task's result, in the tasks' order; resumes from out's journal.

    fn must be importable by name (a module-level function) so that worker
    processes can run it; its attribute journal_check, where it has one,
    says which journaled results are its own (read_journal). fresh: forget
    an earlier journal in out.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    ident = _identity(fn, tasks)
    journal, stamp = out / JOURNAL, out / TASKS
    if fresh:
        journal.unlink(missing_ok=True)
    old = _read_stamp(stamp)
    if old is not None and path_kind(journal) is not None and old.get("identity") != ident:
        raise ConfigError("--out", str(out), "holds the journal of a different sweep; "
                          "choose another folder or remove this one")
    new = {"identity": ident, "tasks": len(tasks)}
    if old != new:   # written once, atomically: a kill here leaves the old stamp or the new one
        write_json(stamp, new)
    done = read_journal(journal, len(tasks), getattr(fn, "journal_check", None))
    todo = {k: t for k, t in enumerate(tasks) if k not in done}
    workers = workers or default_workers()
    if workers < 1:
        raise ConfigError("--workers", workers, "must be at least 1")
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(tasks), initial=len(done), desc=desc, unit="run", smoothing=0.1)
    rec = _Journal(journal)
    stream = _dask(fn, todo, dask, dask_timeout) if dask else _local(fn, todo, min(workers, max(1, len(todo))))
    try:
        for k, result in stream:
            result = json_safe(result)   # as a resumed run reads it back
            rec.record(k, result)
            done[k] = result
            if bar is not None:
                bar.update(1)
    finally:
        stream.close()   # stops the workers at once when we leave early (Ctrl-C, a full disk)
        rec.close()
        if bar is not None:
            bar.close()
    return [done.get(k) for k in range(len(tasks))]
