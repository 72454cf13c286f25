"""The switching inverter's segments that the simulator integrates as one
stretch (fs_inverter_same_voltage): a dead time whose diode holds the leg on
the rail it then switches to has the next segment's voltage, and only then."""
import itertools

import pytest

from fullspeed._core import ffi, lib


def inverter(**kw):
    return ffi.new("fs_inverter_config *", {"kind": lib.FS_INV_SWITCHING, "u_dc": 300.0, "T_pwm": 1e-4,
                                            "t_dead": 2e-6, "phases": 3, **kw})


def voltage(inv, state, i_ph):
    out = ffi.new("double[4]")
    lib.fs_inverter_voltage(inv, state, i_ph, out, out + 1, out + 2, out + 3)
    return tuple(out)


@pytest.mark.parametrize("half", [0, 1])
def test_a_span_is_one_voltage_and_ends_where_the_voltage_changes(half):
    """Every sign of the three currents: the segments of a span have the
    first one's voltage at those currents (the later ones at any currents:
    they have no leg in dead time), and the segment after a span has another
    voltage or a leg in dead time. Half 0 switches low to high: a leg in
    dead time with a current into the inverter (< 0) sits on the upper rail,
    where it goes, so the span is 2; half 1 the other way round."""
    inv = inverter()
    seg = ffi.new("fs_inv_segments *")
    lib.fs_inverter_segments(inv, ffi.new("double[3]", [0.3, 0.5, 0.8]), half, seg)
    assert seg.n == 7   # three edges, each with its dead time
    spans = set()
    for signs in itertools.product((-1.0, 1.0), repeat=3):
        i_ph = ffi.new("double[3]", [5.0 * s for s in signs])
        n = 0
        while n < seg.n:
            span = lib.fs_inverter_same_voltage(inv, seg, n, i_ph)
            assert 1 <= span <= seg.n - n
            v = voltage(inv, seg.state[n], i_ph)
            for j in range(1, span):
                assert all(seg.state[n + j][k] >= 0 for k in range(3))
                assert voltage(inv, seg.state[n + j], ffi.new("double[3]", [-5.0 * s for s in signs])) == v
            if n + span < seg.n:
                nxt = seg.state[n + span]
                assert any(nxt[k] < 0 for k in range(3)) or voltage(inv, nxt, i_ph) != v
            dead = [k for k in range(3) if seg.state[n][k] < 0]
            if dead:
                k = dead[0]
                goes_to = 1 if half == 0 else 0
                held = 1 if signs[k] < 0 else 0
                assert (span == 2) == (held == goes_to)
                spans.add(span)
            n += span
    assert spans == {1, 2}


def test_drops_keep_every_segment_apart():
    """With on-state drops a segment's voltage depends on the currents at
    its start: no span is longer than one segment."""
    for kw in ({"u_on": 1.0}, {"r_on": 0.01}):
        inv = inverter(**kw)
        seg = ffi.new("fs_inv_segments *")
        lib.fs_inverter_segments(inv, ffi.new("double[3]", [0.3, 0.5, 0.8]), 0, seg)
        i_ph = ffi.new("double[3]", [-5.0, -5.0, 10.0])
        assert all(lib.fs_inverter_same_voltage(inv, seg, n, i_ph) == 1 for n in range(seg.n))
