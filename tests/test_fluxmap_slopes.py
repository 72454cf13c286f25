"""The current loops' incremental inductances (fs_fluxmap_slopes): continuous
across the lines of the controller's grid, where the bilinear map's own
slope steps from one cell's to the next. On SyR-e's THOR's FEA map L_qq
steps by a quarter at i_q = 11 A; a loop whose gains took that step each
time the measured current crossed the line chattered from sample to sample
at the voltage limit (fs_current_ctrl.h).

What could be wrong: the slopes stepping at a line all the same (a
neighbour's cell misread, a stride wrong), the cell's own slope not kept at
its centre, the mirror image below i_q = 0 or the grid's edges read past
the table."""
import numpy as np
import pytest

from fullspeed._core import ffi, lib
from fullspeed.design.scenario import scenario_from_dict
from fullspeed.sim import Simulation


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


def test_the_slopes_do_not_step_at_a_line_where_the_maps_does(thor_map):
    _, m = thor_map
    t = m.t
    eps = 1e-3
    worst_q = worst_d = None
    for l in range(1, lib.FS_FLUXMAP_NQ - 2):          # the q lines inside the grid, at a loaded d current
        i_q = l * t.di_q
        i_d = t.i_d0 + 3.3 * t.di_d
        lo, hi = _eval(m, i_d, i_q - eps), _eval(m, i_d, i_q + eps)
        step_map = abs(hi[0].L_qq - lo[0].L_qq) / lo[0].L_qq
        step_cc = abs(hi[2] - lo[2]) / lo[2]
        if worst_q is None or step_map > worst_q[0]:
            worst_q = (step_map, step_cc, i_q)
    for k in range(1, lib.FS_FLUXMAP_ND - 2):          # the d lines, at a q current inside a cell
        i_d = t.i_d0 + k * t.di_d
        i_q = 2.4 * t.di_q
        lo, hi = _eval(m, i_d - eps, i_q), _eval(m, i_d + eps, i_q)
        step_map = abs(hi[0].L_dd - lo[0].L_dd) / lo[0].L_dd
        step_cc = abs(hi[1] - lo[1]) / lo[1]
        if worst_d is None or step_map > worst_d[0]:
            worst_d = (step_map, step_cc, i_d)
    assert worst_q[0] > 0.1, worst_q         # the map's own slope steps by more than a tenth somewhere ...
    assert worst_q[1] < 1e-3, worst_q        # ... where the loops' does not
    assert worst_d[0] > 0.01, worst_d
    assert worst_d[1] < 1e-3, worst_d


def test_a_cells_own_slope_stands_at_its_centre_and_the_edges_and_mirror_hold(thor_map):
    _, m = thor_map
    t = m.t
    for k, l in ((0, 0), (2, 5), (5, 7), (lib.FS_FLUXMAP_ND - 2, lib.FS_FLUXMAP_NQ - 2)):
        i_d, i_q = t.i_d0 + (k + 0.5) * t.di_d, (l + 0.5) * t.di_q
        p, L_dd, L_qq = _eval(m, i_d, i_q)
        assert L_dd == pytest.approx(p.L_dd, rel=1e-5) and L_qq == pytest.approx(p.L_qq, rel=1e-5)
    # below i_q = 0 the mirror image: the same slopes
    for i_q in (0.3 * t.di_q, 1.7 * t.di_q):
        _, L_dd_p, L_qq_p = _eval(m, t.i_d0 + 4.2 * t.di_d, i_q)
        _, L_dd_n, L_qq_n = _eval(m, t.i_d0 + 4.2 * t.di_d, -i_q)
        assert (L_dd_n, L_qq_n) == (L_dd_p, L_qq_p)
    # beyond the grid's edges: the edge cell's slope goes on, as the map does
    top = (lib.FS_FLUXMAP_NQ - 1) * t.di_q
    for far in (1.0, 1.5):
        p, _, L_qq = _eval(m, t.i_d0 + 4.2 * t.di_d, far * top + 0.5 * t.di_q)
        assert L_qq == pytest.approx(p.L_qq, rel=1e-5)
    p, L_dd, _ = _eval(m, t.i_d0 - 2.0 * t.di_d, 3.5 * t.di_q)
    assert L_dd == pytest.approx(p.L_dd, rel=1e-5)
