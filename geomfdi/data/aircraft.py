"""A 32-state linearised aircraft test model: 8 faults, 3 gust disturbances.

**This is a synthetic model with realistic structure, not a published data set.**  Its
rigid-body part has the form and the orders of magnitude of the stability derivatives of
a fighter-class aircraft in cruise (body axes, small-perturbation equations as in
textbooks on flight dynamics); the numbers are chosen, not identified.  It is meant as
a real-size, badly scaled test case for residual synthesis: mixed units (ft, ft/s, rad,
lbf), entries from 1e-4 to 1e5, fast actuators and sensors next to slow phugoid and
spiral modes.

States (n = 32, in this order):

* rigid body, longitudinal: ``u`` [ft/s], ``alpha`` [rad], ``q`` [rad/s], ``theta`` [rad];
* rigid body, lateral: ``beta`` [rad], ``p``, ``r`` [rad/s], ``phi`` [rad];
* engine: spool ``s`` [–], thrust ``T`` [lbf] (``T' = (25000 s − T) / 0.5``);
* actuators: elevator (2nd order, 40 rad/s, ζ = 0.7: ``de``, ``de_dot``), left and
  right aileron (1st order, 20 rad/s), rudder (2nd order, 30 rad/s, ζ = 0.6: ``dr``,
  ``dr_dot``), canard (1st order, 25 rad/s), throttle servo (1st order, 5 rad/s);
* gusts (Dryden-type shaping filters at V = 800 ft/s, scale 1750 ft): ``ug``, ``wg``
  (two first-order stages ``w1 → wg``), ``vg``;
* sensor dynamics (first-order lags, 40 … 200 rad/s): angle-of-attack vane, sideslip
  vane, pitch / roll / yaw rate gyros, normal and lateral accelerometers [g], pitot
  airspeed, pitch and roll attitude.

Aerodynamic forces act on the air-relative motion ``u − ug``, ``alpha − wg / V``,
``beta − vg / V``; the vanes and the pitot read air-relative quantities.

Inputs (m = 6): elevator, left aileron, right aileron, rudder, throttle, canard
commands.  Outputs (q = 14): the ten sensor-lag states, GPS ground speed ``u``, an
engine thrust sensor ``T`` [lbf], elevator and rudder position.  Disturbances
(``Bd``, 3 columns): unit white-noise inputs of the three gust filters.

Faults (8): additive faults on the elevator, left-aileron and rudder commands
(:class:`~geomfdi.model.faults.ActuatorFault` on those columns of B), a thrust loss
(a fault entering the thrust state), and sensor faults on the angle-of-attack vane,
the pitch-rate gyro, the roll-rate gyro and the pitot airspeed.
"""

from __future__ import annotations

import numpy as np

from geomfdi.model.faults import ActuatorFault, Fault, SensorFault
from geomfdi.model.plant import Plant

__all__ = ["aircraft_model", "AIRCRAFT_STATES", "AIRCRAFT_OUTPUTS", "AIRCRAFT_FAULTS"]

AIRCRAFT_STATES = (
    "u", "alpha", "q", "theta", "beta", "p", "r", "phi", "spool", "T",
    "de", "de_dot", "daL", "daR", "dr", "dr_dot", "dcan", "dth",
    "ug", "w1", "wg", "vg",
    "alpha_m", "beta_m", "q_m", "p_m", "r_m", "nz_m", "ny_m", "V_m", "theta_m", "phi_m",
)  # fmt: skip
AIRCRAFT_OUTPUTS = (
    "alpha vane", "beta vane", "q gyro", "p gyro", "r gyro", "nz", "ny", "pitot",
    "theta", "phi", "GPS speed", "thrust", "elevator position", "rudder position",
)  # fmt: skip
AIRCRAFT_FAULTS = (
    "elevator", "left aileron", "rudder", "thrust loss",
    "alpha vane", "q gyro", "p gyro", "pitot",
)  # fmt: skip


def aircraft_model() -> tuple[Plant, list[ActuatorFault | Fault | SensorFault]]:
    """The 32-state aircraft test model and its 8 faults (module docstring).

    Returns
    -------
    plant : Plant
        Continuous time, n = 32, m = 6, q = 14, three gust disturbances (``Bd``).
    faults : list
        Elevator, left-aileron, rudder actuator faults; thrust loss; sensor faults on the
        alpha vane, q gyro, p gyro and pitot (names in :data:`AIRCRAFT_FAULTS`).

    Examples
    --------
    >>> import geomfdi as gf
    >>> plant, faults = gf.aircraft_model()
    >>> plant.n, plant.m, plant.q, plant.nd, len(faults)
    (32, 6, 14, 3, 8)
    """
    ix = {name: i for i, name in enumerate(AIRCRAFT_STATES)}
    n = len(AIRCRAFT_STATES)
    A = np.zeros((n, n))
    B = np.zeros((n, 6))
    Bd = np.zeros((n, 3))
    V, g, mass = 800.0, 32.17, 1000.0

    def row(state: str, **coef: float) -> None:
        for name, value in coef.items():
            A[ix[state], ix[name]] += value

    # air-relative aerodynamic terms: x_a = x − gust
    def aero(state: str, du: float = 0.0, da: float = 0.0, db: float = 0.0) -> None:
        row(state, u=du, ug=-du, alpha=da, wg=-da / V, beta=db, vg=-db / V)

    # longitudinal rigid body
    aero("u", du=-0.015, da=15.0)
    row("u", theta=-g, T=1.0 / mass, de=-4.0)
    aero("alpha", du=-1.2e-4, da=-1.2)
    row("alpha", q=1.0, de=-0.15, dcan=0.05, daL=-0.04, daR=-0.04)
    aero("q", du=2e-5, da=-5.0)
    row("q", q=-1.5, de=-20.0, dcan=8.0, daL=-1.5, daR=-1.5)
    row("theta", q=1.0)
    # lateral rigid body
    aero("beta", db=-0.3)
    row("beta", p=0.05, r=-1.0, phi=g / V, dr=0.04)
    aero("p", db=-30.0)
    row("p", p=-3.0, r=0.6, daL=-25.0, daR=25.0, dr=5.0)
    aero("r", db=6.0)
    row("r", p=-0.03, r=-0.4, daL=-1.0, daR=1.0, dr=-4.0)
    row("phi", p=1.0, r=0.05)
    # engine
    row("spool", spool=-1.0, dth=1.0)
    row("T", T=-2.0, spool=2.0 * 25000.0)
    # actuators (commands: elevator, aileron L, aileron R, rudder, throttle, canard)
    row("de", de_dot=1.0)
    row("de_dot", de=-1600.0, de_dot=-2 * 0.7 * 40.0)
    B[ix["de_dot"], 0] = 1600.0
    row("daL", daL=-20.0)
    B[ix["daL"], 1] = 20.0
    row("daR", daR=-20.0)
    B[ix["daR"], 2] = 20.0
    row("dr", dr_dot=1.0)
    row("dr_dot", dr=-900.0, dr_dot=-2 * 0.6 * 30.0)
    B[ix["dr_dot"], 3] = 900.0
    row("dth", dth=-5.0)
    B[ix["dth"], 4] = 5.0
    row("dcan", dcan=-25.0)
    B[ix["dcan"], 5] = 25.0
    # Dryden-type gust filters (V / L = 800 / 1750), unit white noise in
    a, sig = V / 1750.0, 3.0
    b = sig * np.sqrt(2 * a / np.pi)
    row("ug", ug=-a)
    Bd[ix["ug"], 0] = b
    row("w1", w1=-a)
    Bd[ix["w1"], 1] = b
    row("wg", wg=-a, w1=a)
    row("vg", vg=-a)
    Bd[ix["vg"], 2] = b

    # sensor lags: x_m' = w_s (x_measured − x_m)
    def lag(state: str, w: float, **meas: float) -> None:
        row(state, **{state: -w})
        for name, value in meas.items():
            A[ix[state], ix[name]] += w * value

    lag("alpha_m", 50.0, alpha=1.0, wg=-1.0 / V)
    lag("beta_m", 50.0, beta=1.0, vg=-1.0 / V)
    lag("q_m", 200.0, q=1.0)
    lag("p_m", 200.0, p=1.0)
    lag("r_m", 200.0, r=1.0)
    # nz = (V / g)(alpha' − q) and ny = (V / g)(beta' + r − (g / V) phi): rows of A
    nz = (V / g) * (A[ix["alpha"]] - np.eye(n)[ix["q"]])
    ny = (V / g) * (A[ix["beta"]] + np.eye(n)[ix["r"]] - (g / V) * np.eye(n)[ix["phi"]])
    row("nz_m", nz_m=-100.0)
    A[ix["nz_m"]] += 100.0 * nz
    row("ny_m", ny_m=-100.0)
    A[ix["ny_m"]] += 100.0 * ny
    lag("V_m", 40.0, u=1.0, ug=-1.0)
    lag("theta_m", 100.0, theta=1.0)
    lag("phi_m", 100.0, phi=1.0)
    # outputs
    names = ["alpha_m", "beta_m", "q_m", "p_m", "r_m", "nz_m", "ny_m", "V_m", "theta_m", "phi_m"]
    names += ["u", "T", "de", "dr"]
    C = np.zeros((len(names), n))
    C[np.arange(len(names)), [ix[x] for x in names]] = 1.0
    plant = Plant(A, B, C, Bd=Bd)
    thrust = np.zeros((n, 1))
    thrust[ix["T"], 0] = 2.0 * 2500.0  # a loss of 10 % of the spool's thrust gain
    nm = AIRCRAFT_FAULTS
    faults: list[ActuatorFault | Fault | SensorFault] = [
        ActuatorFault(B[:, 0], name=nm[0]),
        ActuatorFault(B[:, 1], name=nm[1]),
        ActuatorFault(B[:, 3], name=nm[2]),
        Fault(thrust, np.zeros((len(names), 1)), name=nm[3]),
        SensorFault(0, name=nm[4]),
        SensorFault(2, name=nm[5]),
        SensorFault(3, name=nm[6]),
        SensorFault(7, name=nm[7]),
    ]
    return plant, faults
