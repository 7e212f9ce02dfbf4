"""The three-tank system (the laboratory benchmark of the DTS200 kind), nonlinear and linearised.

Three cylindrical tanks of cross-section ``area`` in a row, T1 – T3 – T2, connected at the
bottom by pipes of cross-section ``pipe_area``; pump 1 fills T1, pump 2 fills T2, and T2
drains to the reservoir.  Torricelli's law gives the flows (outflow coefficients ``az``)::

    q13 = az13 Sn sgn(h1 − h3) √(2 g |h1 − h3|)
    q32 = az32 Sn sgn(h3 − h2) √(2 g |h3 − h2|)
    q20 = az20 Sn √(2 g h2)

    area h1' = Q1 − q13
    area h2' = Q2 + q32 − q20
    area h3' = q13 − q32 − q_leak

with levels ``h`` in m, pump flows ``Q`` in m³/s (at most ``q_max``) and a leak ``q_leak``
(m³/s) out of tank 3.  The three levels are measured.

The linear model holds for deviations ``x = h − h_op``, ``u = Q − Q_op``, ``y = h − h_op``
around a steady state with ``h1 > h3 > h2 > 0``.  Its faults: additive flow losses of the two
pumps (actuator faults on the columns of B), the leak (``Bf = −e3 / area``, the fault signal is
the leak flow in m³/s) and additive faults of the three level sensors (m).  The pump and leak
faults are of size ~1e-5 m³/s and the sensor faults ~1e-2 m: a badly scaled model on purpose.

References
----------
Amira GmbH, *DTS200 laboratory setup three-tank-system*, Duisburg, 1994 (parameters).
S. X. Ding, *Model-based Fault Diagnosis Techniques*, 2nd ed., Springer 2013, §3.7.3.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError
from geomfdi.model.faults import ActuatorFault, Fault, SensorFault
from geomfdi.model.plant import Plant

__all__ = [
    "ThreeTankParameters",
    "three_tank_rhs",
    "three_tank_operating_point",
    "three_tank_model",
    "three_tank_system",
    "THREE_TANK_STATES",
    "THREE_TANK_INPUTS",
    "THREE_TANK_OUTPUTS",
    "THREE_TANK_FAULTS",
]

THREE_TANK_STATES = ("h1", "h2", "h3")
THREE_TANK_INPUTS = ("Q1", "Q2")
THREE_TANK_OUTPUTS = ("level 1", "level 2", "level 3")
THREE_TANK_FAULTS = ("pump 1", "pump 2", "leak 3", "level 1", "level 2", "level 3")


@dataclass(frozen=True)
class ThreeTankParameters:
    """Physical parameters (SI units) of the three-tank system; defaults of the DTS200."""

    area: float = 0.0154  # tank cross-section, m²
    pipe_area: float = 5e-5  # connecting pipe and outlet cross-section, m²
    az13: float = 0.5  # outflow coefficient T1 → T3
    az32: float = 0.5  # outflow coefficient T3 → T2
    az20: float = 0.6  # outflow coefficient T2 → reservoir
    g: float = 9.81  # m/s²
    q_max: float = 1e-4  # largest pump flow, m³/s


def _flows(h: np.ndarray, p: ThreeTankParameters) -> tuple[np.ndarray, ...]:
    h1, h2, h3 = h[0], h[1], h[2]
    k = p.pipe_area * np.sqrt(2.0 * p.g)
    q13 = p.az13 * k * np.sign(h1 - h3) * np.sqrt(np.abs(h1 - h3))
    q32 = p.az32 * k * np.sign(h3 - h2) * np.sqrt(np.abs(h3 - h2))
    q20 = p.az20 * k * np.sqrt(np.maximum(h2, 0.0))
    return q13, q32, q20


def three_tank_rhs(
    h: np.ndarray,
    Q: np.ndarray,
    leak: float | np.ndarray = 0.0,
    params: ThreeTankParameters | None = None,
) -> np.ndarray:
    """Level derivatives ``h'`` of the nonlinear model (module docstring).

    Parameters
    ----------
    h : array_like, (3,) or (3, N)
        Levels h1, h2, h3 in m (columns: several points at once).
    Q : array_like, (2,) or (2, N)
        Pump flows in m³/s.
    leak : float or array_like
        Leak flow out of tank 3 in m³/s.
    params : ThreeTankParameters, optional

    Returns
    -------
    ndarray, same shape as ``h``
    """
    p = params or ThreeTankParameters()
    h = np.asarray(h, dtype=float)
    Q = np.asarray(Q, dtype=float)
    q13, q32, q20 = _flows(h, p)
    return (
        np.stack([Q[0] - q13, Q[1] + q32 - q20, q13 - q32 - np.asarray(leak, dtype=float)]) / p.area
    )


def three_tank_operating_point(
    levels: tuple[float, float, float] = (0.5, 0.3, 0.4),
    params: ThreeTankParameters | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The steady state at ``levels = (h1, h2, h3)`` and the pump flows that hold it.

    Steady state without leak: ``Q1 = q13 = q32`` and ``Q2 = q20 − q32``, which needs
    ``h1 − h3 = (az32 / az13)² (h3 − h2)``; the given ``h1`` is replaced by that value when it
    differs (the levels of T2 and T3 fix the state).

    Raises
    ------
    GeomFDIError
        Unless ``h3 > h2 > 0`` and both pump flows lie in ``[0, q_max]``.
    """
    p = params or ThreeTankParameters()
    _, h2, h3 = (float(v) for v in levels)
    if not (h3 > h2 > 0.0):
        raise GeomFDIError(f"levels: expected h3 > h2 > 0, got {levels!r}", argument="levels")
    h1 = h3 + (p.az32 / p.az13) ** 2 * (h3 - h2)
    h = np.array([h1, h2, h3])
    q13, q32, q20 = _flows(h, p)
    Q = np.array([q13, q20 - q32])
    if np.any(Q < 0) or np.any(Q > p.q_max):
        raise GeomFDIError(
            f"levels: the pump flows {Q.tolist()} m³/s needed there are outside [0, {p.q_max}]",
            argument="levels",
        )
    return h, Q


def three_tank_model(
    levels: tuple[float, float, float] = (0.5, 0.3, 0.4),
    params: ThreeTankParameters | None = None,
) -> tuple[Plant, list[Fault]]:
    """The three-tank system linearised at ``levels`` (deviation variables) and its 6 faults.

    Returns
    -------
    plant : Plant
        ``n = 3`` (h1, h2, h3), ``m = 2`` (Q1, Q2), ``q = 3`` (the levels), continuous time.
    faults : list of Fault
        Pump 1 and pump 2 flow losses, the tank-3 leak and the three level-sensor faults
        (names in :data:`THREE_TANK_FAULTS`).

    Notes
    -----
    With ``c = az Sn g / √(2 g Δh)`` the slope of each Torricelli flow at the operating point,
    ``area x' = [[−c13, 0, c13], [0, −c32 − c20, c32], [c13, c32, −c13 − c32]] x + u``.

    Examples
    --------
    >>> from geomfdi.data.three_tank import three_tank_model
    >>> plant, faults = three_tank_model()
    >>> plant.n, plant.m, plant.q, [f.name for f in faults][:3]
    (3, 2, 3, ['pump 1', 'pump 2', 'leak 3'])
    """
    p = params or ThreeTankParameters()
    h, _ = three_tank_operating_point(levels, p)
    k = p.pipe_area * p.g / np.sqrt(2.0 * p.g)
    c13 = p.az13 * k / np.sqrt(h[0] - h[2])
    c32 = p.az32 * k / np.sqrt(h[2] - h[1])
    c20 = p.az20 * k / np.sqrt(h[1])
    A = np.array([[-c13, 0.0, c13], [0.0, -c32 - c20, c32], [c13, c32, -c13 - c32]]) / p.area
    B = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]) / p.area
    plant = Plant(A, B, np.eye(3))
    faults: list[Fault] = [
        ActuatorFault(B[:, 0], name=THREE_TANK_FAULTS[0]),
        ActuatorFault(B[:, 1], name=THREE_TANK_FAULTS[1]),
        ActuatorFault(np.array([0.0, 0.0, -1.0 / p.area]), name=THREE_TANK_FAULTS[2]),
        *(SensorFault(i, name=THREE_TANK_FAULTS[3 + i]) for i in range(3)),
    ]
    return plant, faults


def _tank_update(t: float, x: np.ndarray, u: np.ndarray, params: dict) -> np.ndarray:
    p = params.get("tank") or ThreeTankParameters()
    return three_tank_rhs(x, u[:2], u[2], params=p)


def _tank_output(t: float, x: np.ndarray, u: np.ndarray, params: dict) -> np.ndarray:
    return np.asarray(x, dtype=float)


def three_tank_system(params: ThreeTankParameters | None = None) -> Any:
    """The nonlinear three-tank system as a python-control ``NonlinearIOSystem``.

    States ``h1, h2, h3`` (m), inputs ``Q1, Q2`` (pump flows, m³/s) and ``leak`` (the leak
    flow out of tank 3, m³/s; zero when healthy), outputs the three levels (names in
    :data:`THREE_TANK_OUTPUTS`).  Its functions are module-level (the system pickles, so
    a campaign may ship it to workers; or rebuild it from this factory).

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> from geomfdi.data.three_tank import three_tank_operating_point, three_tank_system
    >>> h, Q = three_tank_operating_point()
    >>> plant = gf.Plant.linearize(three_tank_system(), h, [*Q, 0.0])
    >>> plant.inputs, plant.outputs[0], bool(np.allclose(plant.y_op, h))
    (('Q1', 'Q2', 'leak'), 'level 1', True)
    """
    import control

    p = params or ThreeTankParameters()
    return control.nlsys(
        _tank_update,
        _tank_output,
        inputs=[*THREE_TANK_INPUTS, "leak"],
        outputs=list(THREE_TANK_OUTPUTS),
        states=list(THREE_TANK_STATES),
        params={"tank": p},
        name="three_tank",
    )
