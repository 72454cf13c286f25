"""B-MAPID's second half (reproduce.papers.mapid): how one machine's run on
its identified map is judged against its run on the true map; and the
identified map's CSV keeps its currents exactly, so that a grid reaching
i_max still reaches it once read back."""
import numpy as np

from fullspeed.model.fluxmap import load_map
from fullspeed.reproduce.papers.mapid import ANGLE_TOL, verdict
from fullspeed.workflows.mapid import csv_text

DONE = {"stop_reason": "done", "lock_lost_at": None, "refused": None}


def test_a_run_is_judged_against_the_true_maps():
    assert verdict({**DONE, "err_max": 5.0}, {**DONE, "err_max": 5.0 + 0.9 * ANGLE_TOL})["verdict"] == "within"
    assert verdict({**DONE, "err_max": 5.0}, {**DONE, "err_max": 5.0 + 1.1 * ANGLE_TOL})["verdict"] == "outside"
    assert verdict({**DONE, "err_max": 9.0}, {**DONE, "err_max": 3.0})["verdict"] == "within"   # better is within
    lost = verdict({**DONE, "err_max": 5.0}, {**DONE, "err_max": 4.0, "lock_lost_at": 0.675})
    assert lost["verdict"] == "outside: the identified map's run lost lock at 0.675 s"
    tripped = verdict({**DONE, "stop_reason": "overcurrent", "err_max": 25.0}, {**DONE, "err_max": 6.0})
    assert tripped["verdict"] == "not comparable: the true map's run stopped: overcurrent"


def test_the_identified_csv_keeps_its_currents_exactly(tmp_path):
    i_max = 19.935231234567891   # nine digits would write 19.9352312: below i_max, and the loader refuses the map
    i_d, i_q = np.linspace(-i_max, 0.5 * i_max, 5), np.linspace(-i_max, i_max, 7)
    D, Q = np.meshgrid(i_d, i_q, indexing="ij")
    grid = {"i_d": i_d, "i_q": i_q, "psi_d": 0.1 + 1e-3 * D, "psi_q": 2e-3 * Q,
            "source": [["measured"] * i_q.size for _ in i_d]}
    (tmp_path / "map.csv").write_text(csv_text(grid, "m"))
    mag = load_map(tmp_path / "map.csv", "magnetic.file")
    assert mag["i_q"][-1] == i_max and mag["i_d"][0] == -i_max
