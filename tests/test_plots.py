"""The run figure: the voltage against its limit, and the figure itself."""
import numpy as np

from fullspeed.sim.metrics import window_mask
from fullspeed.sim.plots import modulation_index, plot_run
from fullspeed.sim import simulate


def test_modulation_index_is_at_the_limit_in_flux_weakening_and_low_at_standstill(tmp_path):
    """beyond-full-range: flux weakening holds the voltage at the linear limit
    at 4400 rpm (index about 1), the injection at standstill needs little."""
    res = simulate("beyond-full-range")
    mi, t = modulation_index(res), res["t"]
    top = window_mask(t, 3.2, 3.5)
    assert 0.97 < float(np.median(mi[top])) < 1.1
    assert float(np.median(mi[window_mask(t, 0.2, 0.5)])) < 0.3
    path = plot_run(res, tmp_path / "run.png")
    assert path.stat().st_size > 50_000
