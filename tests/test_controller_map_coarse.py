"""The controller's flux table from a map coarser along i_q than its grid
(design.magnetics.controller_map, _coarse_q): a map identified on the
sweeps' i_max / 8 against the controller's i_max / 16.

What could be wrong: the monotone cubic not being PCHIP (scipy's), a map's
own points moved, the incremental L_q read off the table no nearer the
truth than bilinear (whose slope jumps at each point of the map), a map as
fine as the grid (the catalog's) read otherwise than before."""
import numpy as np
import pytest
from scipy.interpolate import PchipInterpolator

from fullspeed.design.magnetics import _controller_grid, controller_map, pchip
from fullspeed.model.fluxmap import interp

I_MAX = 270.7


def _prius_like(step_q: float) -> dict:
    """psi_d = psi_f + L_d i_d with a little cross term, psi_q saturating as
    the 2004 Prius MG2's catalog map (L_q 6.15 mH falling as 1 / (1 + |i| / 190 A))."""
    i_d = np.linspace(-1.25 * I_MAX, 1.25 * I_MAX, 11)
    n = int(round(2.5 * I_MAX / step_q))
    i_q = np.linspace(-1.25 * I_MAX, 1.25 * I_MAX, n + 1)
    D, Q = np.meshgrid(i_d, i_q, indexing="ij")
    return {"model": "fluxmap", "i_d": i_d, "i_q": i_q, "psi_d": 0.1607 + 2.26e-3 * D - 1e-7 * Q * Q,
            "psi_q": 6.15e-3 * Q / (1.0 + np.abs(Q) / 190.0)}


def _table(cm: dict):
    nd, nq = _controller_grid(I_MAX)[0].size, _controller_grid(I_MAX)[1].size
    s = cm["psi_scale"]
    return np.array(cm["psi_d"]).reshape(nd, nq) * s, np.array(cm["psi_q"]).reshape(nd, nq) * s


def test_pchip_is_scipys():
    rng = np.random.default_rng(5)
    for _ in range(50):
        y, h, x0 = np.cumsum(rng.normal(size=rng.integers(3, 20))), rng.uniform(0.1, 30.0), rng.normal()
        xs = x0 + h * np.arange(y.size)
        xq = rng.uniform(xs[0], xs[-1], 40)
        assert np.allclose(pchip(x0, h, y, xq), PchipInterpolator(xs, y)(xq), rtol=0, atol=1e-10)


def test_a_coarse_map_is_read_on_the_cubic_and_its_L_q_is_nearer_the_truth():
    coarse = _prius_like(I_MAX / 8)   # the identification's sweeps
    i_d, i_q, D, Q = _controller_grid(I_MAX)
    _, psi_q = _table(controller_map(coarse, I_MAX))
    true_q = 6.15e-3 * Q / (1.0 + np.abs(Q) / 190.0)
    bilinear = interp(coarse, "psi_q", D, Q)
    # the map's own points (every other column of the controller's) as they were, to the table's counts
    scale = controller_map(coarse, I_MAX)["psi_scale"]
    assert np.allclose(psi_q[:, ::2], bilinear[:, ::2], atol=scale)
    assert (np.diff(psi_q, axis=1) > 0).all()
    k = np.argmin(np.abs(i_d + 90.0))   # a row near the Prius's loaded point
    L_true, L_cubic, L_bil = (np.diff(t[k]) / np.diff(i_q) for t in (true_q, psi_q, bilinear))
    err_cubic, err_bil = np.sqrt(np.mean((L_cubic - L_true) ** 2)), np.sqrt(np.mean((L_bil - L_true) ** 2))
    assert err_cubic < 0.5 * err_bil, (err_cubic, err_bil)


def test_a_map_as_fine_as_the_grid_is_read_bilinear_as_before():
    fine = _prius_like(I_MAX / 32)
    _, _, D, Q = _controller_grid(I_MAX)
    psi_d, psi_q = _table(controller_map(fine, I_MAX))
    scale = controller_map(fine, I_MAX)["psi_scale"]
    assert np.allclose(psi_q, interp(fine, "psi_q", D, Q), atol=0.51 * scale)
    assert np.allclose(psi_d, interp(fine, "psi_d", D, Q), atol=0.51 * scale)
