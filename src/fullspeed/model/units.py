"""Unit conversions at the edges: the one place where rpm, hertz and degrees
meet the SI units used everywhere else (rad/s, rad)."""
from __future__ import annotations

import math

import numpy as np

RPM_TO_RAD_S = 2.0 * math.pi / 60.0


def rpm_to_rad_s(n_rpm):
    """Mechanical speed in rpm -> rad/s."""
    if isinstance(n_rpm, (float, int)):   # a number, as most callers pass: without np.ndim's dispatch (about
        return float(n_rpm) * RPM_TO_RAD_S   # 1 us a call, 12 in a simulation's configuration), the same value
    return np.asarray(n_rpm, dtype=float) * RPM_TO_RAD_S if np.ndim(n_rpm) else float(n_rpm) * RPM_TO_RAD_S


def rad_s_to_rpm(w_m):
    """Mechanical speed in rad/s -> rpm."""
    return np.asarray(w_m, dtype=float) / RPM_TO_RAD_S if np.ndim(w_m) else float(w_m) / RPM_TO_RAD_S


def hz_to_rad_s(f):
    return 2.0 * math.pi * f


def rad_to_deg(x):
    return np.degrees(x)


def deg_to_rad(x):
    return np.radians(x)


def wrap_pi(x):
    """Wrap angles to (-pi, pi]."""
    y = np.mod(np.asarray(x, dtype=float) + math.pi, 2.0 * math.pi) - math.pi
    y = np.where(y <= -math.pi, y + 2.0 * math.pi, y)
    return y if np.ndim(x) else float(y)
