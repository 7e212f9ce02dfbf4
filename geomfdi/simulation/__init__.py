"""Simulation of a plant with faults, noise and a residual bank.

* :mod:`~geomfdi.simulation.signals` -- sensor fault signals (gain, bias, stuck);
  :mod:`~geomfdi.simulation.input_faults` -- actuator and general additive fault signals;
  :mod:`~geomfdi.simulation.schedule` -- a fault list checked once against the plant.
* :mod:`~geomfdi.simulation.discretization`, :mod:`~geomfdi.simulation.recursion`,
  :mod:`~geomfdi.simulation.lifting`, :mod:`~geomfdi.simulation.lti` -- the loop-free LTI core;
  :mod:`~geomfdi.simulation.compiled_recursion` (many runs) and
  :mod:`~geomfdi.simulation.compiled_single` (one run) -- its compiled kernels.
* :mod:`~geomfdi.simulation.noise`, :mod:`~geomfdi.simulation.initial_state`,
  :mod:`~geomfdi.simulation.context` -- the inputs of a simulation;
  :mod:`~geomfdi.simulation.pcg64_normal` (numpy's normals, compiled) and
  :mod:`~geomfdi.simulation.counter_normal` (the counter generator) -- the noise draws.
* :mod:`~geomfdi.simulation.open_loop`, :mod:`~geomfdi.simulation.closed_loop` -- the engines,
  advanced in time chunks; :mod:`~geomfdi.simulation.streaming` -- chunk sizes, decisions
  and summaries accumulated chunk by chunk.
* :mod:`~geomfdi.simulation.simulate`, :mod:`~geomfdi.simulation.batch`,
  :mod:`~geomfdi.simulation.results` -- ``simulate``, ``simulate_batch`` and their results;
  :mod:`~geomfdi.simulation.result_memory` -- the returned arrays' memory, reused.
* :mod:`~geomfdi.simulation.calibration` -- thresholds from noise-only simulations.

Layer: above :mod:`geomfdi.generators`.  It may import :mod:`geomfdi.model`,
:mod:`geomfdi.generators`, :mod:`geomfdi.evaluation` and, inside functions,
:mod:`geomfdi.plotting`; never the synthesis.
"""

from geomfdi.simulation.batch import simulate_batch
from geomfdi.simulation.calibration import calibrate_threshold
from geomfdi.simulation.initial_state import InitialStateWarning, consistent_initial_state
from geomfdi.simulation.input_faults import (
    ActuatorBiasFault,
    ActuatorGainFault,
    ActuatorStuckFault,
    AdditiveFault,
    InputFaultSignal,
)
from geomfdi.simulation.lti import simulate_lti
from geomfdi.simulation.noise import Noise
from geomfdi.simulation.results import BatchResult, SimulationResult
from geomfdi.simulation.schedule import FaultSchedule, fault_schedule
from geomfdi.simulation.signals import (
    BiasFault,
    FaultSignal,
    GainFault,
    SensorFaultSignal,
    StuckFault,
    apply_faults,
)
from geomfdi.simulation.simulate import simulate

__all__ = [
    "simulate",
    "simulate_batch",
    "simulate_lti",
    "calibrate_threshold",
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
    "FaultSignal",
    "InputFaultSignal",
    "ActuatorGainFault",
    "ActuatorBiasFault",
    "ActuatorStuckFault",
    "AdditiveFault",
    "FaultSchedule",
    "fault_schedule",
]
