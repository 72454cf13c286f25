"""The current loops' incremental inductances (fs_fluxmap_slopes): continuous
across the lines of the controller's grid, where the bilinear map's own
slope steps from one cell's to the next. On SyR-e's THOR's FEA map L_qq
steps by a quarter at i_q = 11 A; a loop whose gains took that step each
time the measured current crossed the line chattered from sample to sample
at the voltage limit (fs_current_ctrl.h).

What could be wrong: the slopes stepping at a line all the same (a
neighbour's cell misread, a stride wrong, a guard at the grid's last
interior line off by one), the cell's own slope not kept at its centre,
the mirror image below i_q = 0 or the grid's edges read past the table."""
import pytest

from fullspeed._core import ffi, lib
from fullspeed.design.scenario import scenario_from_dict
from fullspeed.sim import Simulation

ND, NQ = lib.FS_FLUXMAP_ND, lib.FS_FLUXMAP_NQ


@pytest.fixture(scope="module")
def thor_map():
    data = {"name": "slopes", "machine": "syre-thor", "duration": 0.01,
            "controller": {"mode": "speed", "angle": "encoder"}}
    sim = Simulation(scenario_from_dict(data, "slopes", warn=False))
    drv = lib.fs_sim_drive(sim._sim)
    return sim, drv.map   # the simulation kept alive: the map points into its drive


def _eval(m, i_d, i_q):
    p = lib.fs_fluxmap_eval(ffi.addressof(m), {"d": i_d, "q": i_q})
    L_dd, L_qq = ffi.new("float *"), ffi.new("float *")
    lib.fs_fluxmap_slopes(ffi.addressof(m), {"d": i_d, "q": i_q}, L_dd, L_qq)
    return p, L_dd[0], L_qq[0]


def test_the_slopes_do_not_step_at_any_line_where_the_maps_does(thor_map):
    _, m = thor_map
    t = m.t
    eps = 1e-3
    steps_map_q, steps_map_d = [], []
    for l in range(1, NQ - 1):                       # every interior q line, the last one too ...
        for across in (0.3, 3.5, 7.8):               # ... at three d positions across the cells
            i_q, i_d = l * t.di_q, t.i_d0 + across * t.di_d
            lo, hi = _eval(m, i_d, i_q - eps), _eval(m, i_d, i_q + eps)
            steps_map_q.append(abs(hi[0].L_qq - lo[0].L_qq) / lo[0].L_qq)
            assert abs(hi[2] - lo[2]) / lo[2] < 1e-3, (l, across)
    for k in range(1, ND - 1):                       # every interior d line
        for across in (0.4, 2.4, 9.6):
            i_d, i_q = t.i_d0 + k * t.di_d, across * t.di_q
            lo, hi = _eval(m, i_d - eps, i_q), _eval(m, i_d + eps, i_q)
            steps_map_d.append(abs(hi[0].L_dd - lo[0].L_dd) / lo[0].L_dd)
            assert abs(hi[1] - lo[1]) / lo[1] < 1e-3, (k, across)
    assert max(steps_map_q) > 0.1 and max(steps_map_d) > 0.01   # where the map's own slope steps


def test_a_cells_own_slope_stands_at_its_centre_and_the_edges_and_mirror_hold(thor_map):
    _, m = thor_map
    t = m.t
    for k, l in ((0, 0), (2, 5), (5, 7), (ND - 2, NQ - 2)):
        i_d, i_q = t.i_d0 + (k + 0.5) * t.di_d, (l + 0.5) * t.di_q
        p, L_dd, L_qq = _eval(m, i_d, i_q)
        assert L_dd == pytest.approx(p.L_dd, rel=1e-5) and L_qq == pytest.approx(p.L_qq, rel=1e-5)
    # below i_q = 0 the mirror image, whose cell has cell 0's slope: flat over cell 0's lower half (the
    # cell's own there), and continuous through i_q = 0
    i_d = t.i_d0 + 4.2 * t.di_d
    for b in (0.0, 0.2, 0.45):
        p, _, L_qq = _eval(m, i_d, b * t.di_q)
        assert L_qq == pytest.approx(p.L_qq, rel=1e-5)
    assert _eval(m, i_d, -1e-4)[2] == pytest.approx(_eval(m, i_d, 1e-4)[2], rel=1e-5)
    # beyond the grid's edges: the edge cell's slope goes on, as the map does
    top = (NQ - 1) * t.di_q
    for far in (1.0, 1.5):
        p, _, L_qq = _eval(m, i_d, far * top + 0.5 * t.di_q)
        assert L_qq == pytest.approx(p.L_qq, rel=1e-5)
    p, L_dd, _ = _eval(m, t.i_d0 - 2.0 * t.di_d, 3.5 * t.di_q)
    assert L_dd == pytest.approx(p.L_dd, rel=1e-5)
