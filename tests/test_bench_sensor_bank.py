"""The sensor-bank benchmark runs (a small chain) and reports consistent numbers."""

from __future__ import annotations

import numpy as np
from script_loader import load_script


def test_two_force_chain_is_the_stated_plant():
    bench = load_script("benchmarks/bench_sensor_bank.py")
    p = bench.chain2(12, 4)
    assert (p.n, p.q, p.m) == (24, 4, 2)
    lam = np.linalg.eigvals(p.A)
    assert np.all(lam.real < 0) and np.max(lam.real) > -0.05  # lightly damped


def test_sensor_bank_table_verifies_every_row(capsys):
    bench = load_script("benchmarks/bench_sensor_bank.py")
    res = bench.table(8, 3, 1, profile=False)
    out = capsys.readouterr().out
    assert "SVDs" in out and "gf.verify ok=True" in out
    assert res["verified"] and len(res["orders"]) == 3
    assert all(o is not None and 1 <= o <= 16 for o in res["orders"])
    assert res["ratio"] > 0 and res["cpu_ratio"] > 0
