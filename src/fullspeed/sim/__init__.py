"""Running scenarios: the C core's configuration (config), the chunked
runner and its Result (runner), the metrics of a run (metrics) and its
figures (plots).

`fullspeed.sim.simulate` and `fullspeed.sim.Result` are the public API;
the names the runner's users reach for are here too.
"""
from .._core import ffi, lib
from .config import build_config
from .runner import CHANNELS, STOP_REASONS, UNITS, Result, Simulation, simulate

__all__ = ["CHANNELS", "STOP_REASONS", "UNITS", "Result", "Simulation", "build_config", "ffi", "lib", "simulate"]
