"""B-MAPID's second half (reproduce.papers.mapid): how one machine's runs on
its identified map are judged against its runs on the true map; and the
identified map's CSV keeps its currents exactly, so that a grid reaching
i_max still reaches it once read back."""
import numpy as np

from fullspeed.model.fluxmap import load_map
from fullspeed.reproduce.papers.mapid import ANGLE_TOL, THETA0_DEG, verdict
from fullspeed.workflows.mapid import csv_text

DONE = {"stop_reason": "done", "lock_lost_at": None, "refused": None}


def runs(*err_max, **kw):
    return [{**DONE, "theta0_deg": a, "err_max": e, **kw} for a, e in zip(THETA0_DEG, err_max)]


def test_the_runs_means_are_judged_against_the_true_maps():
    n = len(THETA0_DEG)
    assert n > 1 and len(set(THETA0_DEG)) == n and THETA0_DEG[0] == 0.0   # the claim's own angle first
    assert verdict(runs(*[5.0] * n), runs(*[5.0 + 0.9 * ANGLE_TOL] * n))["verdict"] == "within"
    assert verdict(runs(*[5.0] * n), runs(*[5.0 + 1.1 * ANGLE_TOL] * n))["verdict"] == "outside"
    assert verdict(runs(*[9.0] * n), runs(*[3.0] * n))["verdict"] == "within"   # better is within
    # two modes (zoo 0's and 10's identified runs): the majority's mode, the own angle's run among them,
    # is not the verdict; the mean over all the runs is
    m = n // 2 + 1
    high = runs(*[5.0] * m, *[5.0 + 1.5 * ANGLE_TOL * n / (n - m)] * (n - m))
    judged = verdict(runs(*[5.0] * n), high)
    assert judged["verdict"] == "outside" and abs(judged["diff_deg"] - 1.5 * ANGLE_TOL) < 1e-9
    assert judged["identified"]["least"] == 5.0
    low = runs(*[6.5 * ANGLE_TOL] * m, *[(6.5 - n / (n - m)) * ANGLE_TOL] * (n - m))
    assert verdict(runs(*[5.0 * ANGLE_TOL] * n), low)["verdict"] == "within"


def test_one_run_that_does_not_complete_decides():
    n = len(THETA0_DEG)
    lost = runs(*[4.0] * n)
    lost[-1] = {**lost[-1], "lock_lost_at": 0.675}
    judged = verdict(runs(*[5.0] * n), lost)
    assert judged["verdict"] == f"outside: the identified map's run lost lock at 0.675 s from {THETA0_DEG[-1]:g} el.deg"
    assert judged["identified"]["completed"] == n - 1
    tripped = runs(*[25.0] * n)
    own = THETA0_DEG.index(0.0)   # the claim's own angle: named by nothing
    tripped[own] = {**tripped[own], "stop_reason": "overcurrent"}
    assert verdict(tripped, runs(*[6.0] * n))["verdict"] == "not comparable: the true map's run stopped: overcurrent"


def test_the_identified_csv_keeps_its_currents_exactly(tmp_path):
    i_max = 19.935231234567891   # nine digits would write 19.9352312: below i_max, and the loader refuses the map
    i_d, i_q = np.linspace(-i_max, 0.5 * i_max, 5), np.linspace(-i_max, i_max, 7)
    D, Q = np.meshgrid(i_d, i_q, indexing="ij")
    grid = {"i_d": i_d, "i_q": i_q, "psi_d": 0.1 + 1e-3 * D, "psi_q": 2e-3 * Q,
            "source": [["measured"] * i_q.size for _ in i_d]}
    (tmp_path / "map.csv").write_text(csv_text(grid, "m"))
    mag = load_map(tmp_path / "map.csv", "magnetic.file")
    assert mag["i_q"][-1] == i_max and mag["i_d"][0] == -i_max
