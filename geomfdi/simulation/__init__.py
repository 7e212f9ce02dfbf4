"""Simulation of a plant with faults, noise and a residual bank.

* :mod:`~geomfdi.simulation.signals` -- sensor fault signals (gain, bias, stuck).
* :mod:`~geomfdi.simulation.lti` -- the loop-free LTI simulation core.
* :mod:`~geomfdi.simulation.simulate` -- ``simulate`` and ``simulate_batch``.
"""

from geomfdi.simulation.lti import simulate_lti
from geomfdi.simulation.signals import (
    BiasFault,
    GainFault,
    SensorFaultSignal,
    StuckFault,
    apply_faults,
)
from geomfdi.simulation.simulate import (
    BatchResult,
    InitialStateWarning,
    Noise,
    SimulationResult,
    consistent_initial_state,
    simulate,
    simulate_batch,
)

__all__ = [
    "simulate",
    "simulate_batch",
    "simulate_lti",
    "SimulationResult",
    "BatchResult",
    "Noise",
    "InitialStateWarning",
    "consistent_initial_state",
    "GainFault",
    "BiasFault",
    "StuckFault",
    "SensorFaultSignal",
    "apply_faults",
]
