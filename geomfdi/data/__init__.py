"""Test models shipped with geomfdi.

* :mod:`~geomfdi.data.aircraft` -- a 32-state linearised aircraft model (synthetic, with
  realistic structure) with 8 faults and 3 gust disturbances: ``gf.aircraft_model()``.
"""

from geomfdi.data.aircraft import aircraft_model

__all__ = ["aircraft_model"]
