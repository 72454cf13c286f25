"""fullspeed: wide-speed-range sensorless PMSM drives.

Portable C controllers, a fast simulator of what the hardware does, and the
reproduction of three papers (yang2022, zou2021, yu2022).
"""
__version__ = "0.1.0"


def __getattr__(name):
    # fullspeed.load_sweep without importing the simulator at `import fullspeed`
    if name == "load_sweep":
        from .sweep import load_sweep
        return load_sweep
    raise AttributeError(f"module 'fullspeed' has no attribute {name!r}")
