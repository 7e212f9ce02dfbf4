"""Test models shipped with geomfdi.

* :mod:`~geomfdi.data.aircraft` -- a 32-state linearised aircraft model (synthetic, with
  realistic structure) with 8 faults and 3 gust disturbances: ``gf.aircraft_model()``.
* :mod:`~geomfdi.data.three_tank` -- the three-tank laboratory system: nonlinear model
  (Torricelli flows), operating points and the linearised plant with pump, leak and level-sensor
  faults: ``gf.three_tank_model()``.
* :mod:`~geomfdi.data.flight_actuators` -- the flight-actuator case study of Varga (2017),
  chapter 8 (data of FaultDetectionTools.jl, MIT licence): ``gf.flight_actuator_case_study()``.
* :mod:`~geomfdi.data.mass_spring_chain` -- a lightly damped mass-spring chain of any
  length, position sensors and force inputs where asked: ``gf.mass_spring_chain(N, ...)``.

Layer: beside the model.  It may import :mod:`geomfdi.model` and the base modules only.
"""

from geomfdi.data.aircraft import aircraft_model
from geomfdi.data.flight_actuators import flight_actuator_case_study
from geomfdi.data.mass_spring_chain import mass_spring_chain
from geomfdi.data.three_tank import three_tank_model

__all__ = [
    "aircraft_model",
    "flight_actuator_case_study",
    "mass_spring_chain",
    "three_tank_model",
]
