"""The synthesis benchmark runs (tiny sizes) and reports consistent numbers."""

from __future__ import annotations

import numpy as np
from script_loader import load_script


def _load():
    return load_script("benchmarks/bench_synthesis.py")


def test_block_plant_family_is_well_posed():
    bench = _load()
    rng = np.random.default_rng(3)
    p = bench.block_plant(12, 3, rng)
    assert (p.n, p.q, p.m) == (12, 3, 2)
    # hidden structure: the orthogonal change of coordinates keeps the spectrum of the
    # blocks (random around -2) and of the unseen part
    assert np.all(np.linalg.eigvals(p.A).real < 0)


def test_benchmark_quick_flag(capsys):
    bench = _load()
    res = bench.main(["--quick"])
    out = capsys.readouterr().out
    assert "ratio" in out and "symbolic" in out and "largest leakage seen" in out
    assert len(res["design"]) == 4 and len(res["symbolic"]) == 2 and len(res["dense"]) == 1
    for _n, q, td, ts, delivered, order, leak in res["design"]:
        assert td > 0 and ts > 0
        assert delivered == q and 1 <= order <= 4  # the block family is well posed
        assert leak < 1e-8
    assert res["leakage"] < 1e-8
    assert all(row[5] for row in res["symbolic"])  # verify_symbolic proved the zeros
