"""The simulation's truth about loss of lock (metrics.true_loss_at): what the
campaigns hold the drive's own flags against."""
import numpy as np
import pytest

from fullspeed.sim.metrics import true_loss_at

T = np.arange(0.0, 0.2, 1e-4)


def trace(err, stage=6):
    return {"t": T, "theta_err": np.asarray(err, float), "stage": np.full_like(T, stage)}


def test_on_track_is_never_lost():
    assert true_loss_at(trace(np.full_like(T, 1.5))) is None   # 86 deg: inside the 90 deg band


def test_lost_after_20_ms_net_off_track():
    err = np.where(T >= 0.05, -3.0, 0.0)
    assert true_loss_at(trace(err)) == pytest.approx(0.0699, abs=1.5e-4)


def test_time_back_on_track_counts_down():
    # 15 ms off, 15 ms on: never 20 ms net; 15 ms off, 5 ms on: 10 ms net gained a cycle
    assert true_loss_at(trace(np.where((T % 0.03) < 0.015, 3.0, 0.0))) is None
    lost = true_loss_at(trace(np.where((T % 0.02) < 0.015, 3.0, 0.0)))
    assert lost is not None and 0.024 < lost < 0.04


def test_an_estimate_slipping_round_and_round_is_lost():
    """Half its time beyond 90 deg, a quarter within 45: a loss, although it
    is as long on one side of 90 deg as on the other."""
    err = (2 * np.pi * 50.0 * T + np.pi) % (2 * np.pi) - np.pi     # slips at 50 Hz
    lost = true_loss_at(trace(err))
    assert lost is not None and lost < 0.1
    # the same swing within +-80 deg is not
    assert true_loss_at(trace(np.radians(80.0) * np.sin(2 * np.pi * 50.0 * T))) is None


@pytest.mark.parametrize("stage", [2, 3, 8])   # polarity, I/f start, recovery
def test_stages_without_an_estimate_in_the_loop_do_not_count(stage):
    assert true_loss_at(trace(np.full_like(T, 3.0), stage)) is None
