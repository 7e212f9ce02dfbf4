"""Residual-generator synthesis: from (A, B, C) and a fault list to a bank of generators.

The front end (:mod:`~geomfdi.synthesis.design`: ``design_residual_generator``,
``design_bank``, ``design_sensor_bank``; rows built by :mod:`~geomfdi.synthesis.build` and
:mod:`~geomfdi.synthesis.multirow`; the full-quotient observer of
:mod:`~geomfdi.synthesis.construction`; the rank decisions of a design in
:mod:`~geomfdi.synthesis.rank_decisions`) sits on the sensor-fault to pseudo-actuator
transforms (:mod:`~geomfdi.synthesis.sensor_transforms`) and two design subpackages:
:mod:`geomfdi.synthesis.least_order` (the default least-order rows: quotient, degree search
and certificate, parity spaces, realisations) and :mod:`geomfdi.synthesis.exact` (the exact
sympy design).  Approximate synthesis (noise, the fault-to-noise gap) belongs in
``geomfdi.synthesis.approximate`` and the analysis of achievable specifications (structures
and least orders before a design) in ``geomfdi.synthesis.specification``.  The objects it
delivers (:class:`ResidualGenerator`, :class:`ResidualBank` and their exact counterparts)
are in the lower layer :mod:`geomfdi.generators`.  Synthesis may import
:mod:`geomfdi.model`, :mod:`geomfdi.geometry` and :mod:`geomfdi.generators`, never
verification, simulation, evaluation, deployment or io.
"""

from typing import Any

from geomfdi.generators.exact import (
    ExactResidualBank,
    ExactResidualGenerator,
    ExceptionalCondition,
)
from geomfdi.generators.generator import ResidualBank, ResidualGenerator
from geomfdi.generators.realization import minimal_realization, reachable_subspace
from geomfdi.synthesis.design import design_bank, design_residual_generator, design_sensor_bank
from geomfdi.synthesis.sensor_transforms import pseudo_actuator_model

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


def __getattr__(name: str) -> Any:
    # old submodules (``geomfdi.synthesis.generator``) as attributes: imported through
    # their deprecated alias (geomfdi._moved)
    import importlib

    from geomfdi._moved import MOVED

    if f"{__name__}.{name}" in MOVED:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
