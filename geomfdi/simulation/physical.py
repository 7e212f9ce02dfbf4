"""Fault signals on a physical plant: output names and the operating point.

A plant linearised at an operating point works on deviations ``y = y_phys − y_op``; its
sensor faults are stated on the physical reading (user guide, *Physical plants*,
``docs/guide/physical-plants.md``)::

    y_phys,meas = eta(t) y_phys + lambda(t)
    =>  y_meas = eta(t) y + lambda(t) + (eta(t) − 1) y_op        (deviation form)

so a 10 % gain loss is ``GainFault(sensor, start=..., gain=0.9)`` and acts on the whole
reading, as a real sensor's does, not on the deviation alone; a stuck sensor's ``value``
is a physical reading (``value − y_op`` in deviations).  Actuator gain and stuck faults
likewise act on the physical input ``u_op + u``.  Bias faults are the same in both forms.
Sensors and actuators may be named by the plant's output and input names.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any

import numpy as np

from geomfdi.simulation.input_faults import ActuatorGainFault, ActuatorStuckFault
from geomfdi.simulation.signals import GainFault, SensorFaultSignal, StuckFault, _evaluate

__all__ = ["deviation_faults"]


def _shifted_bias(f: Any, y_op: float) -> Any:
    """``lambda + (eta − 1) y_op`` (a number, or a function of t if either is one)."""
    gain, bias = f.gain, f.bias
    if not callable(gain) and not callable(bias):
        return float(bias) + (float(gain) - 1.0) * y_op

    def shifted(t: np.ndarray) -> np.ndarray:
        return _evaluate(bias, t, "bias") + (_evaluate(gain, t, "gain") - 1.0) * y_op

    return shifted


def _actuator(f: Any, plant: Any, u_op: Any, k: int) -> Any:
    """An actuator gain or stuck fault on the physical input ``u_op + u``."""
    g = f
    if isinstance(f.actuator, str):
        g = copy.copy(f)
        g.actuator = plant.input_index(f.actuator, f"faults[{k}].actuator")
    op = 0.0 if u_op is None or g.actuator >= len(u_op) else float(u_op[g.actuator])
    if op == 0.0:
        return g
    if isinstance(g, ActuatorGainFault):
        return ActuatorGainFault(
            g.actuator, start=g.start, end=g.end, gain=g.gain, bias=_shifted_bias(g, op)
        )
    if g.value is None:
        return g
    return ActuatorStuckFault(g.actuator, start=g.start, end=g.end, value=float(g.value) - op)


def deviation_faults(faults: Sequence[Any], plant: Any) -> list[Any]:
    """``faults`` with output names resolved to indices and sensor faults in the
    deviation form of ``plant``'s operating point (module docstring).

    Faults that need no change are returned as they are (the same objects).
    """
    y_op = getattr(plant, "y_op", None)
    u_op = getattr(plant, "u_op", None)
    out = []
    for k, f in enumerate(faults):
        if isinstance(f, ActuatorGainFault | ActuatorStuckFault):
            out.append(_actuator(f, plant, u_op, k))
            continue
        if not isinstance(f, SensorFaultSignal):
            out.append(f)
            continue
        g = f
        if isinstance(f.sensor, str):
            g = copy.copy(f)
            g.sensor = plant.output_index(f.sensor, f"faults[{k}].sensor")
        op = 0.0 if y_op is None or g.sensor >= len(y_op) else float(y_op[g.sensor])
        if op != 0.0 and isinstance(g, GainFault):
            g = GainFault(
                g.sensor, start=g.start, end=g.end, gain=g.gain, bias=_shifted_bias(g, op)
            )
        elif op != 0.0 and isinstance(g, StuckFault) and g.value is not None:
            g = StuckFault(g.sensor, start=g.start, end=g.end, value=float(g.value) - op)
        out.append(g)
    return out
