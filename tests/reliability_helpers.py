"""Helpers of the reliability tests (issue 40) and their fuzzers: a time
guard that turns a hang into a failure, and an identification without its
simulation."""
from __future__ import annotations

import contextlib
import signal


@contextlib.contextmanager
def within(seconds: int, what: str):
    """Fail (not hang) when the block takes longer than `seconds`: a guard
    against the hangs of the report, not a measure of speed."""
    def alarm(signum, frame):
        raise AssertionError(f"{what}: no outcome within {seconds} s (a hang)")
    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def fake_identification(sc, ok: bool = True):
    """What fullspeed.workflows.identify.identify returns for sc when every
    quantity is identified at the truth (ok) or none is: for the tests of
    where and how the result is written, without the minutes of simulation."""
    from fullspeed.workflows import identify as idf

    m = sc.machine
    truth = {"R_s": m.R_s, "L_d": m.L_d, "L_q": m.L_q, "psi_f": m.psi_f, "J": m.J, "B": 0.0, "T_c": 0.0, "u_e": 0.5,
             "L_d_nominal": m.L_d, "L_q_nominal": m.L_q}
    return idf.Identification(m.name, {q: "ok" if ok else "failed" for q in idf.QUANTITIES},
                              {q: "" if ok else "no answer" for q in idf.QUANTITIES},
                              dict(truth, i_e=1.0) if ok else {}, truth, "done" if ok else "failed", 1.0, 0.1)
