"""The diagnosability benchmark and example scripts run (tiny sizes) and report the tables."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _load(relpath: str):
    path = ROOT / relpath
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_benchmark_quick_mode(capsys):
    bench = _load("benchmarks/bench_diagnosability.py")
    rows = bench.main(["--quick"])
    out = capsys.readouterr().out
    assert [r["n"] for r in rows] == list(bench.QUICK_SIZES)
    for r in rows:
        assert r["structured"] > 0 and r["direct"] > 0
        assert r["diff"] < 1e-8  # both null-space paths give the same tables
    assert "ratio" in out and "largest n under 10 s, structured" in out
    # the budget skips the direct path once its predicted time is too large
    rows = bench.run([3, 8], budget=0.0)
    assert rows[0]["direct"] is not None and rows[1]["direct"] is None


def test_satellite_example(tmp_path, capsys):
    ex = _load("examples/diagnosability_satellite.py")
    tables = ex.main(["--out", str(tmp_path)])
    assert (tmp_path / "diagnosability_satellite_isolability.png").stat().st_size > 1000
    t3 = tables["Table 3 directional cosine=signed"]
    t4 = tables["Table 4 directional cosine=signed"]
    np.testing.assert_allclose(t3.values, [[0.7148, 0, 0], [0.7148, 0, 0]], atol=5e-5)
    np.testing.assert_allclose(t4.values, [[0.9300, 0, 0.25], [1.0, 0.25, 0]], atol=5e-5)
    assert "Theorem 2 (more than one output, m = 1): fails" in capsys.readouterr().out


def test_model23_example(tmp_path):
    ex = _load("examples/diagnosability_model23.py")
    tables = ex.main(["--out", str(tmp_path)])
    assert abs(tables["Table 1 (KL)"].values[3, 0] - 299 / 279) < 1e-12
    assert len(list(tmp_path.glob("diagnosability_model23_*.png"))) == 2


def test_bank_example_prints_joint_and_structured_tables(capsys):
    ex = _load("examples/diagnosability_bank_hou_wen_chen.py")
    out = ex.main(["--window", "20"])
    text = capsys.readouterr().out
    assert "structured KL indices" in text and "raw outputs" in text
    s = out["structured"]
    off = ~np.eye(3, dtype=bool)
    assert (s["exact"].fi[off] > 0).all()
    assert (s["paper"].fi[1:, :][off[1:, :]] == 0).all() and (s["paper"].fi[0, 1:] > 0).all()
    assert (
        out["joint"]["paper"].model.residual_dim == out["joint"]["raw outputs"].model.residual_dim
    )
