"""The plant of Hou, Wen & Chen (2011), section 4, and residual generators built by hand
from the paper's rows (shared by the simulation tests)."""

from __future__ import annotations

import numpy as np

import geomfdi as gf

A = np.array([[1.0, 1, 1], [0, 1, 0], [2, 0, 1]])
B = np.array([[1.0, 0, 1], [0, 1, 1], [0, 1, 0]])
C = np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 2]])
K_FB = np.array([[5, -1.5, 3], [2, 0, 2], [-2, 2.5, -2]])
X0 = np.array([0.5, -0.3, 0.2])
P_PAPER = np.array([[0.0, 1, 0], [-2, 2, 1], [-3, 3, 1]])


def v_ext(t):
    return np.vstack([np.sin(0.5 * t), np.cos(0.3 * t), 0.2 * np.ones_like(t)])


def hand_generator(plant, P, f=-2.0, **meta):
    """The generator of the rows ``P`` (k, 3) with ``F = f I``, ``M = I`` on ``plant`` (C
    invertible): ``E = (F P - P A) C^-1``, ``H = P C^-1``, so that ``F P = P A + E C`` and
    ``M P = H C`` hold by construction."""
    k = P.shape[0]
    F = f * np.eye(k)
    Ci = np.linalg.inv(plant.C)
    return gf.ResidualGenerator(
        F,
        (F @ P - P @ plant.A) @ Ci,
        P @ plant.B,
        np.eye(k),
        P @ Ci,
        np.zeros((k, plant.m)),
        dt=plant.dt,
        **meta,
    )


def leaky_bank(gens, **meta):
    """The sensor-fault bank of three paper generators: r1 isolates fault 0, r2 and r3
    see every fault (the reference structure)."""
    S = np.array([[1, 0, 0], [1, 1, 1], [1, 1, 1]], dtype=bool)
    return gf.ResidualBank(
        gens,
        np.eye(3, dtype=bool),
        S,
        np.array([True, False, False]),
        ["ok"] * 3,
        [gf.SensorFault(i) for i in range(3)],
        **meta,
    )
