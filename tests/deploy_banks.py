"""Banks shared by the deployment tests (designed once per test session)."""

from __future__ import annotations

from functools import cache

import numpy as np

import geomfdi as gf

A = np.array([[1.0, 1, 1], [0, 1, 0], [2, 0, 1]])
B = np.array([[1.0, 0, 1], [0, 1, 1], [0, 1, 0]])
C = np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 2]])
DT = 0.01


@cache
def seed_bank() -> gf.ResidualBank:
    """The sensor-fault bank of the plant of Hou, Wen & Chen (2011), section 4."""
    return gf.design_sensor_bank(gf.Plant(A, B, C))


def sampled_bank() -> gf.ResidualBank:
    """The same bank sampled with a zero-order hold at ``DT`` (well conditioned)."""
    return seed_bank().discretize(DT)


def vector_row_bank() -> gf.ResidualBank:
    """A discrete bank (q = 2, m = 1) of a two-component row, a missing row and a scalar
    row."""
    rng = np.random.default_rng(4)
    g1 = gf.ResidualGenerator(
        np.diag([0.5, 0.8]), rng.normal(size=(2, 2)), rng.normal(size=(2, 1)),
        rng.normal(size=(2, 2)), rng.normal(size=(2, 2)), rng.normal(size=(2, 1)), dt=DT,
    )  # fmt: skip
    g2 = gf.ResidualGenerator(
        [[0.3]], [[1.0, -1.0]], [[0.5]], [[1.0]], [[0.0, 1.0]], [[0.0]], dt=DT
    )
    S = np.array([[1, 0], [0, 0], [1, 1]], dtype=bool)
    return gf.ResidualBank(
        [g1, None, g2], S, S, np.array([True, True]), ["ok", "missing", "ok"], [], DT
    )
