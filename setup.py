# The C core is compiled by cffi (API mode) as fullspeed._core; see
# src/fullspeed/_build.py. Everything else is in pyproject.toml.
from setuptools import setup

setup(cffi_modules=["src/fullspeed/_build.py:ffibuilder"])
