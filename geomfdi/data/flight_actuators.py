"""Monitoring of flight actuators: the case study of Varga (2017), chapter 8 (case study 1).

The data are those of the case study as distributed with Varga's FaultDetectionTools.jl
(MIT licence; example ``CS1_1``, data ``cs1data``), converted to numpy and nothing else
changed (``cs1_aircraft.npz``, shipped with geomfdi).

* 11 linearised models of a civil aircraft (10 states, 25 inputs = 22 actuator commands
  and 3 wind inputs, 10 outputs) for variations of mass and centre of gravity; index 6 is
  the nominal one.
* 22 first-order actuator models (diagonal ``A, B, C, D``).
* The design plant: the nominal aircraft in series with the actuators, 32 states,
  22 control inputs, 3 wind disturbances (decoupled), 10 outputs.
* 8 additive actuator faults on the primary actuator commands (``fault_inputs``: their
  control indices, 0-based), the 6 × 8 structure of the case study (1 = the residual
  sees the fault) and the case study's output-feedback gain ``K`` (22 × 10).

The design is open loop, as in the book (the model has unstable modes near 0).  The least
orders of the six rows of the structure are 7, 7, 7, 6, 5, 4, and the fault-detection
residual (one residual seeing all 8 faults) has least order 5 (:data:`LEAST_ORDERS`,
:data:`FAULT_DETECTION_ORDER`).  See the user guide, *Synthesis* (``docs/guide/synthesis.md``)
and *Data* (``docs/reference/data.md``).

References
----------
A. Varga, *Solving Fault Diagnosis Problems: Linear Synthesis Techniques*, Springer, 2017,
chapter 8 (case study 1).  A. Varga, FaultDetectionTools.jl (MIT licence).
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources

import numpy as np

from geomfdi.model.faults import ActuatorFault
from geomfdi.model.plant import Plant

__all__ = [
    "flight_actuator_case_study",
    "FlightActuatorCaseStudy",
    "LEAST_ORDERS",
    "FAULT_DETECTION_ORDER",
    "NOMINAL",
]

LEAST_ORDERS = (7, 7, 7, 6, 5, 4)
"""Least orders of the scalar residuals of the six rows of the case study's structure."""

FAULT_DETECTION_ORDER = 5
"""Least order of the fault-detection residual (one residual seeing all 8 faults)."""

NOMINAL = 6
"""Index of the nominal model among the 11 linearised aircraft models."""

_FILE = "cs1_aircraft.npz"


@dataclass(frozen=True)
class FlightActuatorCaseStudy:
    """The flight-actuator case study (module docstring).

    Attributes
    ----------
    plant : Plant
        Nominal aircraft in series with the actuators: n = 32, m = 22, q = 10, three wind
        disturbances (``Bd``, ``Dd``).
    faults : list of ActuatorFault
        The 8 actuator faults (columns ``Bf``), named after their control input.
    structure : ndarray of bool, (6, 8)
        The case study's specification (True: the residual sees the fault).
    fault_detection : ndarray of bool, (1, 8)
        One residual seeing every fault.
    fault_inputs : ndarray of int, (8,)
        Control-input index (0-based) of each fault.
    models : list of Plant
        The 11 linearised aircraft models alone (10 states, 25 inputs as ``B``: 22
        commands then 3 winds, 10 outputs); ``models[NOMINAL]`` is the nominal one.
    actuators : tuple of ndarray
        ``(A, B, C, D)`` of the 22 first-order actuators (diagonal).
    K : ndarray, (22, 10)
        The case study's output-feedback gain.
    least_orders : tuple of int
        :data:`LEAST_ORDERS`.
    fault_detection_order : int
        :data:`FAULT_DETECTION_ORDER`.
    """

    plant: Plant
    faults: list[ActuatorFault]
    structure: np.ndarray
    fault_detection: np.ndarray
    fault_inputs: np.ndarray
    models: list[Plant]
    actuators: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    K: np.ndarray
    least_orders: tuple[int, ...] = LEAST_ORDERS
    fault_detection_order: int = FAULT_DETECTION_ORDER


def flight_actuator_case_study() -> FlightActuatorCaseStudy:
    """Load the flight-actuator case study of Varga (2017), chapter 8 (module docstring).

    Returns
    -------
    FlightActuatorCaseStudy

    Examples
    --------
    >>> import geomfdi as gf
    >>> cs = gf.flight_actuator_case_study()
    >>> cs.plant.n, cs.plant.m, cs.plant.q, cs.plant.nd, len(cs.faults)
    (32, 22, 10, 3, 8)
    >>> cs.structure.astype(int).tolist()[5], cs.least_orders
    ([0, 0, 0, 0, 0, 0, 0, 1], (7, 7, 7, 6, 5, 4))
    """
    with resources.files("geomfdi.data").joinpath(_FILE).open("rb") as fh:
        d = dict(np.load(fh))
    plant = Plant(d["A"], d["Bu"], d["C"], Bd=d["Bd"], Dd=d["Dd"])
    inputs = d["fault_inputs"].astype(int)
    faults = [ActuatorFault(d["Bf"][:, j], name=f"actuator {int(i)}") for j, i in enumerate(inputs)]
    models = [
        Plant(d["aircraft_A"][k], d["aircraft_B"][k], d["aircraft_C"][k], d["aircraft_D"][k])
        for k in range(d["aircraft_A"].shape[0])
    ]
    return FlightActuatorCaseStudy(
        plant=plant,
        faults=faults,
        structure=d["structure"].astype(bool),
        fault_detection=np.ones((1, inputs.size), dtype=bool),
        fault_inputs=inputs,
        models=models,
        actuators=(d["actuator_A"], d["actuator_B"], d["actuator_C"], d["actuator_D"]),
        K=d["K"],
    )
