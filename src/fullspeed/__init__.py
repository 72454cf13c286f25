"""fullspeed: wide-speed-range sensorless PMSM drives.

Portable C controllers, a fast simulator of what the hardware does, and the
reproduction of three papers (yang2022, zou2021, yu2022).

The package is in layers, each a sub-package importing only those below it
(tests/test_layers.py keeps it so):

1. model      units, errors, files, the schema, machines and flux maps,
              scenarios as validated data; nothing that designs or runs
2. design     what is formed from a machine before a run: the design rules,
              the designed machine and scenario, the checks, the report
3. sim        the C core's configuration, the runner and its Result,
              metrics, figures (`fullspeed.sim.simulate`)
4. workflows  built on runs: the journal and sweeps, calibration,
              identification, export, the loss-of-lock campaign
5. reproduce  the claims, the registry the papers' measurements fill,
              the papers, the report
6. cli        the command line (with this package's root: the top)
"""
__version__ = "0.1.0"


def __getattr__(name):
    # fullspeed.load_sweep without importing the simulator (the C core, NumPy,
    # matplotlib) at `import fullspeed`, which every layer's module runs first
    if name == "load_sweep":
        from .workflows.sweep import load_sweep
        return load_sweep
    raise AttributeError(f"module 'fullspeed' has no attribute {name!r}")
