"""Test models shipped with geomfdi.

* :mod:`~geomfdi.data.aircraft` -- a 32-state linearised aircraft model (synthetic, with
  realistic structure) with 8 faults and 3 gust disturbances: ``gf.aircraft_model()``.
* :mod:`~geomfdi.data.three_tank` -- the three-tank laboratory system: nonlinear model
  (Torricelli flows), operating points and the linearised plant with pump, leak and level-sensor
  faults: ``gf.three_tank_model()``.

Layer: beside the model.  It may import :mod:`geomfdi.model` and the base modules only.
"""

from geomfdi.data.aircraft import aircraft_model
from geomfdi.data.three_tank import three_tank_model

__all__ = ["aircraft_model", "three_tank_model"]
