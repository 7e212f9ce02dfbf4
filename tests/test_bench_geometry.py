"""The geometry benchmark runs (tiny sizes) and reports consistent numbers."""

from __future__ import annotations

import numpy as np
from script_loader import load_script


def load_bench():
    return load_script("benchmarks/bench_geometry.py")


def test_benchmark_main_with_tiny_sizes(capsys):
    bench = load_bench()
    rows = bench.main(["--sizes", "6", "9", "15", "--repeat", "1"])
    out = capsys.readouterr().out
    assert [r["n"] for r in rows] == [6, 9, 15]
    for r in rows:
        assert r["q"] == max(1, round(r["n"] / 3))
        assert r["t_svd"] > 0 and r["t_w"] > 0 and r["t_s"] > 0
        # L has a column in Ker C, so W* takes at least two steps; W* ⊆ S*
        assert r["w_steps"] >= 2 and 2 <= r["w_dim"] <= r["s_dim"] <= r["n"]
        assert r["s_steps"] >= 1 and r["min_gap"] > 1e3 and r["warnings"] == 0
        assert f"\n{r['n']:>5} {r['q']:>4} " in out
    assert "growth exponent" in out and "S*:" in out


def test_growth_exponent_recovers_a_power_law():
    bench = load_bench()
    ns = [10, 20, 50, 100]
    assert np.isclose(bench.growth_exponent(ns, [2e-6 * n**3 for n in ns]), 3.0)
    assert np.isnan(bench.growth_exponent([10], [1.0]))


def test_quick_mode_sizes():
    bench = load_bench()
    assert max(bench.QUICK_SIZES) == 50 and max(bench.FULL_SIZES) == 400
    A, C, L = bench.random_system(30, np.random.default_rng(0), columns=1)
    assert A.shape == (30, 30) and C.shape == (10, 30) and L.shape == (30, 1)
    assert np.linalg.norm(C @ L) < 1e-10 * np.linalg.norm(L)
