"""fullspeed: wide-speed-range sensorless PMSM drives.

Portable C controllers, a fast simulator of what the hardware does, and the
reproduction of three papers (yang2022, zou2021, yu2022).
"""
__version__ = "0.1.0"
