"""The approximate-synthesis benchmark runs (tiny sizes) and reports consistent numbers."""

from __future__ import annotations

import numpy as np
from script_loader import load_script

import geomfdi as gf


def _load():
    return load_script("benchmarks/bench_approximate.py")


def test_benchmark_small_sizes(capsys):
    bench = _load()
    res = bench.main(["--sizes", "10"])
    assert "ratio" in capsys.readouterr().out
    (row,) = res["time"]
    assert row["n"] == 10 and row["time"] > 0 and row["svd"] > 0
    # the reported gap is the one gf.fault_to_noise_gap measures
    p, faults = bench.noisy_plant(10, 10)
    g = gf.design_residual_generator(p, faults, [0, 1])
    assert np.isclose(gf.fault_to_noise_gap(g, p, faults).gap[0], row["gap"], rtol=1e-2)
