"""The memory promise of geomfdi.limits: a simulation holds its returned arrays plus
about ``chunk_memory`` (and a few bytes per sample), whatever the record's length."""

from __future__ import annotations

import tracemalloc

import numpy as np
from hwc_bank import K_FB, A, B, C

import geomfdi as gf
from geomfdi.limits import OVERHEAD_PER_SAMPLE

PLANT = gf.Plant(A, B, C)
BANK = gf.design_sensor_bank(PLANT)
BUDGET = 8 * 2**20


def _overhead(N: int) -> float:
    t = np.arange(N) * 0.001
    noise = gf.Noise(measurement=0.01, seed=1)
    with gf.limits.limits(chunk_memory=BUDGET):
        tracemalloc.start()
        try:
            res = gf.simulate(PLANT, BANK, t, controller=K_FB, noise=noise, threshold=0.1)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    out = sum(v.nbytes for v in vars(res).values() if isinstance(v, np.ndarray))
    return peak - out


def test_simulation_memory_is_the_output_plus_the_chunk_budget() -> None:
    gf.simulate(PLANT, BANK, np.linspace(0, 1, 11), controller=K_FB)  # (imports, caches)
    small, large = _overhead(100_000), _overhead(400_000)
    per_sample = (large - small) / 300_000
    assert per_sample <= OVERHEAD_PER_SAMPLE, (small, large)
    assert large <= 2 * BUDGET + OVERHEAD_PER_SAMPLE * 400_000, (small, large)
