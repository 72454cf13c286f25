"""Property tests (hypothesis) of the float32 control primitives through cffi.

Transforms: Clarke / inverse Clarke and Park / inverse Park are inverse pairs,
Park keeps the magnitude, a balanced three-phase set maps to its phasor.
SVPWM: duties in [0, 1]; volt-second balance inside the hexagon (in particular
for |u| <= u_dc/sqrt3); beyond it the realised vector keeps the reference's
phase, lies on the hexagon and is no longer than the reference.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fullspeed._core import ffi, lib

SETTINGS = settings(deadline=None, max_examples=200)
SQRT3 = math.sqrt(3.0)
F32_EPS = float(np.finfo(np.float32).eps)


def f32(x: float) -> float:
    return float(np.float32(x))


def finite32(bound: float) -> st.SearchStrategy[float]:
    b = f32(bound)
    return st.floats(-b, b, allow_nan=False, allow_infinity=False, width=32)


angles = st.floats(-4 * math.pi, 4 * math.pi, allow_nan=False, width=64)
values = finite32(1e4)


def wrap(x: float) -> float:
    return (x + math.pi) % (2 * math.pi) - math.pi


def clarke(a, b, c):
    r = lib.fs_clarke(a, b, c)
    return r.alpha, r.beta


def inv_clarke(alpha, beta):
    out = ffi.new("float[3]")
    lib.fs_inv_clarke({"alpha": alpha, "beta": beta}, out)
    return list(out)


def park(alpha, beta, theta):
    r = lib.fs_park({"alpha": alpha, "beta": beta}, f32(math.cos(theta)), f32(math.sin(theta)))
    return r.d, r.q


def inv_park(d, q, theta):
    r = lib.fs_inv_park({"d": d, "q": q}, f32(math.cos(theta)), f32(math.sin(theta)))
    return r.alpha, r.beta


def svpwm(alpha, beta, u_dc):
    duty = ffi.new("float[3]", [-1.0, -1.0, -1.0])
    u_real = ffi.new("fs_ab *")
    over = lib.fs_svpwm({"alpha": alpha, "beta": beta}, u_dc, duty, u_real)
    realised = lib.fs_svpwm_voltage(duty, u_dc)
    return bool(over), list(duty), (u_real.alpha, u_real.beta), (realised.alpha, realised.beta)


def hexagon_radius(theta: float, u_dc: float) -> float:
    """Radius of the voltage hexagon (vertices at 0, 60, ... degrees) at angle theta."""
    phi = theta - math.pi / 6
    phi -= math.pi / 3 * math.floor(phi / (math.pi / 3) + 0.5)
    return u_dc / SQRT3 / math.cos(phi)


# --- transforms -----------------------------------------------------------

@SETTINGS
@given(values, values, values)
def test_clarke_then_inverse_gives_phases_without_zero_sequence(a, b, c):
    alpha, beta = clarke(a, b, c)
    back = inv_clarke(alpha, beta)
    z = (a + b + c) / 3.0
    tol = 8 * F32_EPS * max(abs(a), abs(b), abs(c)) + 1e-30
    for got, x in zip(back, (a, b, c)):
        assert got == pytest.approx(x - z, abs=tol)
    assert sum(back) == pytest.approx(0.0, abs=tol)


@SETTINGS
@given(values, values)
def test_inverse_clarke_then_clarke_is_identity(alpha, beta):
    a, b, c = inv_clarke(alpha, beta)
    alpha2, beta2 = clarke(a, b, c)
    tol = 8 * F32_EPS * max(abs(alpha), abs(beta)) + 1e-30
    assert alpha2 == pytest.approx(alpha, abs=tol)
    assert beta2 == pytest.approx(beta, abs=tol)


@SETTINGS
@given(values, values, angles)
def test_park_and_inverse_park_are_inverse(alpha, beta, theta):
    d, q = park(alpha, beta, theta)
    alpha2, beta2 = inv_park(d, q, theta)
    tol = 8 * F32_EPS * math.hypot(alpha, beta) + 1e-30
    assert alpha2 == pytest.approx(alpha, abs=tol)
    assert beta2 == pytest.approx(beta, abs=tol)
    d2, q2 = park(*inv_park(d, q, theta), theta)
    assert d2 == pytest.approx(d, abs=tol)
    assert q2 == pytest.approx(q, abs=tol)


@SETTINGS
@given(values, values, angles)
def test_park_preserves_magnitude_and_rotates_by_minus_theta(alpha, beta, theta):
    d, q = park(alpha, beta, theta)
    mag = math.hypot(alpha, beta)
    assert math.hypot(d, q) == pytest.approx(mag, rel=8 * F32_EPS, abs=1e-30)
    if mag > 1e-20:
        assert abs(wrap(math.atan2(q, d) - (math.atan2(beta, alpha) - theta))) < 1e-5


@SETTINGS
@given(st.floats(1e-3, 1e4), st.floats(-math.pi, math.pi))
def test_balanced_set_maps_to_its_phasor(amplitude, phi):
    a = amplitude * math.cos(phi)
    b = amplitude * math.cos(phi - 2 * math.pi / 3)
    c = amplitude * math.cos(phi + 2 * math.pi / 3)
    alpha, beta = clarke(a, b, c)
    assert math.hypot(alpha, beta) == pytest.approx(amplitude, rel=1e-5)
    assert abs(wrap(math.atan2(beta, alpha) - phi)) < 1e-5
    # and in a frame at the same angle it is a pure d-axis quantity
    d, q = park(alpha, beta, phi)
    assert d == pytest.approx(amplitude, rel=1e-5)
    assert abs(q) <= 1e-5 * amplitude


# --- SVPWM ----------------------------------------------------------------

u_dcs = st.floats(f32(1e-3), 1e5, allow_nan=False, width=32)


@SETTINGS
@given(finite32(1e30), finite32(1e30), u_dcs)
def test_svpwm_duties_in_unit_interval(alpha, beta, u_dc):
    over, duty, u_real, realised = svpwm(alpha, beta, u_dc)
    assert all(0.0 <= d <= 1.0 for d in duty), duty
    # the reported voltage is the one the duties realise
    tol = 1e-4 * math.hypot(*realised) + 1e-6 * u_dc
    assert u_real[0] == pytest.approx(realised[0], abs=tol)
    assert u_real[1] == pytest.approx(realised[1], abs=tol)
    # and it never exceeds the hexagon's largest radius, 2/3 u_dc
    assert math.hypot(*realised) <= 2.0 / 3.0 * u_dc * (1 + 1e-5)


@SETTINGS
@given(st.floats(0.0, 1.0), st.floats(-math.pi, math.pi), u_dcs)
def test_svpwm_volt_second_balance_in_linear_range(m, theta, u_dc):
    """|u| <= u_dc/sqrt3: the duties realise the reference exactly (float)."""
    mag = m * u_dc / SQRT3
    alpha, beta = f32(mag * math.cos(theta)), f32(mag * math.sin(theta))
    over, duty, u_real, realised = svpwm(alpha, beta, u_dc)
    assert all(0.0 <= d <= 1.0 for d in duty), duty
    tol = 1e-4 * math.hypot(alpha, beta) + 1e-6 * u_dc
    assert realised[0] == pytest.approx(alpha, abs=tol)
    assert realised[1] == pytest.approx(beta, abs=tol)
    if m < 0.99999:
        assert not over
    # min-max injection: the duties are centred
    assert max(duty) + min(duty) == pytest.approx(1.0, abs=1e-6)


@SETTINGS
@given(st.floats(0.0, 0.99999), st.floats(-math.pi, math.pi), u_dcs)
def test_svpwm_volt_second_balance_inside_hexagon(m, theta, u_dc):
    """Up to the hexagon itself (2/3 u_dc at the vertices) there is no error."""
    mag = m * hexagon_radius(theta, u_dc)
    alpha, beta = f32(mag * math.cos(theta)), f32(mag * math.sin(theta))
    over, duty, u_real, realised = svpwm(alpha, beta, u_dc)
    assert not over
    tol = 1e-4 * math.hypot(alpha, beta) + 1e-6 * u_dc
    assert realised[0] == pytest.approx(alpha, abs=tol)
    assert realised[1] == pytest.approx(beta, abs=tol)


@SETTINGS
@given(st.floats(1.0001, 1e6), st.floats(-math.pi, math.pi), u_dcs)
def test_svpwm_overmodulation_keeps_phase_and_does_not_grow(k, theta, u_dc):
    mag = k * hexagon_radius(theta, u_dc)
    alpha, beta = f32(mag * math.cos(theta)), f32(mag * math.sin(theta))
    over, duty, u_real, realised = svpwm(alpha, beta, u_dc)
    assert over
    assert all(0.0 <= d <= 1.0 for d in duty), duty
    ref_mag, real_mag = math.hypot(alpha, beta), math.hypot(*realised)
    assert abs(wrap(math.atan2(realised[1], realised[0]) - math.atan2(beta, alpha))) < 1e-4
    assert real_mag <= ref_mag * (1 + 1e-6)
    # on the hexagon: the pole voltages span exactly u_dc
    assert (max(duty) - min(duty)) == pytest.approx(1.0, abs=1e-5)
    assert real_mag == pytest.approx(hexagon_radius(math.atan2(beta, alpha), u_dc), rel=1e-4)


@pytest.mark.parametrize(
    "alpha, beta, u_dc",
    [(-3e38, 3e38, 600.0), (3e38, 3e38, 1.0), (3e38, 0.0, 600.0), (0.0, 0.0, 1e-45)],
)
def test_svpwm_extreme_finite_inputs(alpha, beta, u_dc):
    """No overflow to NaN for any finite reference or positive u_dc."""
    over, duty, u_real, realised = svpwm(alpha, beta, u_dc)
    assert all(0.0 <= d <= 1.0 for d in duty), duty
    if alpha or beta:
        assert over
        assert abs(wrap(math.atan2(realised[1], realised[0]) - math.atan2(beta, alpha))) < 1e-4
        assert (max(duty) - min(duty)) == pytest.approx(1.0, abs=1e-5)
