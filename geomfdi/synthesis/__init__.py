"""Residual-generator synthesis: from (A, B, C) and a fault list to a bank of generators.

* :mod:`~geomfdi.synthesis.transforms` -- sensor fault to pseudo-actuator fault transforms.
* :mod:`~geomfdi.synthesis.design` -- ``design_residual_generator``, ``design_bank``,
  ``design_sensor_bank``.
* :mod:`~geomfdi.synthesis.generator` -- :class:`ResidualGenerator`, :class:`ResidualBank`.
* :mod:`~geomfdi.synthesis.realization` -- minimal realisation of a delivered generator.
* :mod:`~geomfdi.synthesis.exact_design` -- the construction in exact arithmetic, over the
  rational functions of a parametric plant (``design_bank(..., exact=True)``), delivering
  :mod:`~geomfdi.synthesis.exact_generator` objects.
"""

from geomfdi.synthesis.design import design_bank, design_residual_generator, design_sensor_bank
from geomfdi.synthesis.exact_generator import (
    ExactResidualBank,
    ExactResidualGenerator,
    ExceptionalCondition,
)
from geomfdi.synthesis.generator import ResidualBank, ResidualGenerator
from geomfdi.synthesis.realization import minimal_realization, reachable_subspace
from geomfdi.synthesis.transforms import pseudo_actuator_model

__all__ = [
    "design_residual_generator",
    "design_bank",
    "design_sensor_bank",
    "ResidualGenerator",
    "ResidualBank",
    "ExactResidualGenerator",
    "ExactResidualBank",
    "ExceptionalCondition",
    "minimal_realization",
    "reachable_subspace",
    "pseudo_actuator_model",
]
