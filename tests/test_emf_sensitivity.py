"""bench/emf_sensitivity.py: what the back-EMF observer's angle shows of an
angle error through the map's q secant read in its own frame.

What could be wrong: the formula's signs or terms (the cross term L_qd, the
incremental against the secant inductance), which the check, the angle the
model's EMF points at with the frame turned, would then contradict; or a
sensitivity below 1 on a machine that does not saturate."""
from pathlib import Path

import numpy as np
import pytest

from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]
es = load_script(ROOT / "bench" / "emf_sensitivity.py", "bench_emf_sensitivity")


def _linear(L_d, L_q, psi_f):
    return lambda i_d, i_q: (psi_f + L_d * i_d, L_q * i_q)


def _saturating(L_d, L_q, psi_f, i_s, k_x):
    """q flux saturating in |i_q| and with -i_d (cross-saturation), smooth."""
    def psi(i_d, i_q):
        return psi_f + L_d * i_d, L_q * i_s * np.tanh(i_q / i_s) / (1.0 + k_x * i_d * i_d)
    return psi


@pytest.mark.parametrize("i_d, i_q", [(-10.0, 20.0), (-40.0, 60.0), (5.0, -30.0)])
def test_a_machine_that_does_not_saturate_shows_the_whole_error(i_d, i_q):
    psi = _linear(2e-3, 5e-3, 0.1)
    assert es.emf_sensitivity(psi, i_d, i_q, 1e-3) == pytest.approx(1.0, abs=1e-6)
    g = (es.emf_angle_error(psi, i_d, i_q, 1e-3) - es.emf_angle_error(psi, i_d, i_q, -1e-3)) / 2e-3
    assert g == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("i_d, i_q", [(-30.0, 40.0), (-80.0, 90.0), (-150.0, 120.0)])
def test_the_formula_is_the_turned_frames_angle_on_a_saturating_map(i_d, i_q):
    psi = _saturating(2e-3, 6e-3, 0.1, 60.0, 2e-5)
    g = es.emf_sensitivity(psi, i_d, i_q, 1e-3)
    g_check = (es.emf_angle_error(psi, i_d, i_q, 1e-4) - es.emf_angle_error(psi, i_d, i_q, -1e-4)) / 2e-4
    assert g == pytest.approx(g_check, rel=1e-3)
    assert g < 0.95   # the q axis saturated along a negative i_d hides part of the error


def test_the_prius_map_hides_most_of_an_error_at_its_current_limit():
    rows = es.rows("prius2004-mg2")
    g = [r["g"] for r in rows]
    assert all(abs(r["g"] - r["g_check"]) < 0.02 for r in rows)
    assert g == sorted(g, reverse=True)   # less of the error the more current
    assert 0.2 < g[-1] < 0.6
