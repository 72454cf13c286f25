"""fs_hfi_restart (fs_hfi.h): the injection resuming at speed keeps the
carriers per unit gain through the reset, so that its fade-in adds them to
the cleared filters as it goes instead of leaving the filters a third of
the carrier behind at the ramp's end; fs_hfi_reset clears them."""
import math

import numpy as np

from fullspeed._core import ffi, lib

Ts, w_h = 1e-4, 2 * math.pi * 1000.0


def _hfi():
    cfg = ffi.new("fs_hfi_config *", {"Ts": Ts, "delay": 1.0, "u_h": 10.0, "w_h": w_h, "L_d": 0.036, "L_q": 0.051})
    cfg.obs.J, cfg.obs.pole_pairs = 0.015, 3
    h = ffi.new("fs_hfi *")
    assert lib.fs_hfi_init(h, cfg) == lib.FS_OK
    return h


def _run_carrier(h, n, gains=None, L=0.04):
    """n steps on an isotropic R-less load of inductance L driven by the
    injection's own voltage (the carrier's current only), the gain per step
    given or 1; returns the filters' positive-sequence states."""
    i = np.zeros(2)
    states = []
    for k in range(n):
        if gains is not None:
            h.gain = gains[k]
        lib.fs_hfi_step(h, {"alpha": float(i[0]), "beta": float(i[1])}, 0.0)
        i = i + Ts / L * np.array([h.u.alpha, h.u.beta])
        states.append(complex(h.filt.srff_p.lp.d, h.filt.srff_p.lp.q))
    return np.asarray(states)


def test_restart_keeps_the_carriers_per_unit_gain_and_fades_in_on_them():
    h = _hfi()
    lib.fs_hfi_reset(h, 0.0, 0.0)
    h.k_settle = 0
    full = _run_carrier(h, 3000)[-1]          # the positive carrier's state at gain 1
    n = h.n_settle
    _run_carrier(h, n, gains=np.linspace(1.0, 0.0, n + 1)[1:])   # faded out: the units taken as it left 1
    unit = complex(h.unit_p.d, h.unit_p.q)
    assert abs(unit - full) < 0.05 * abs(full)
    lib.fs_hfi_restart(h, 0.3, 10.0)
    assert (h.gain, h.gain_prev) == (0.0, 0.0)
    assert complex(h.unit_p.d, h.unit_p.q) == unit and h.obs.theta_hat == np.float32(0.3)
    assert complex(h.filt.srff_p.lp.d, h.filt.srff_p.lp.q) == 0j   # the filters cleared
    kept = _run_carrier(h, n, gains=np.linspace(0.0, 1.0, n + 1)[1:])[-1]
    lib.fs_hfi_reset(h, 0.3, 10.0)
    assert complex(h.unit_p.d, h.unit_p.q) == 0j                   # reset clears them
    h.gain = h.gain_prev = 0.0
    cleared = _run_carrier(h, n, gains=np.linspace(0.0, 1.0, n + 1)[1:])[-1]
    # at the fade's end: on the whole carrier with the units kept, a third of it behind without
    assert abs(kept - full) < 0.1 * abs(full)
    assert abs(cleared - full) > 0.2 * abs(full)
