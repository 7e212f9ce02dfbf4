"""A small sensor-fault campaign shared by the executor and lost-worker tests."""

from __future__ import annotations

import numpy as np

import geomfdi as gf

PLANT = gf.Plant([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 1.0]])
BANK = gf.design_sensor_bank(PLANT)
T = np.linspace(0.0, 2.0, 201)


def small_campaign(faults: object, block_size: int) -> gf.Campaign:
    """Bias on sensor 0 (sizes 0, 0.5, 1), 8 runs of 30 % test data each."""
    sc = gf.Scenario("bias on sensor 0", faults, sizes=[0.0, 0.5, 1.0], onsets=[1.0])
    return gf.Campaign(
        PLANT,
        BANK,
        [sc],
        gf.Noise(measurement=0.05, seed=3),
        t=T,
        runs=8,
        test=0.3,
        block_size=block_size,
        persistence=(1, 2),
    )
