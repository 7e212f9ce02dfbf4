"""Plant models and fault descriptions: the input of every design.

* :mod:`~geomfdi.model.plant` -- :class:`Plant` (A, B, C, D, disturbances, sampling period).
* :mod:`~geomfdi.model.faults` -- :class:`SensorFault`, :class:`ActuatorFault`, :class:`Fault`.

Layer: the bottom (after the base modules).  It may import :mod:`geomfdi.geometry`
and :mod:`geomfdi.generators` only inside functions (parametric plants substitute their
parameters with the helpers there).
"""

from geomfdi.model.faults import ActuatorFault, Fault, SensorFault, fault_matrices
from geomfdi.model.plant import Plant

__all__ = ["Plant", "SensorFault", "ActuatorFault", "Fault", "fault_matrices"]
