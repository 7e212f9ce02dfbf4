"""The parity benchmark, example script and docstring examples run and say what they should."""

from __future__ import annotations

import doctest
import importlib.util
from pathlib import Path

import pytest

import geomfdi as gf

ROOT = Path(__file__).resolve().parents[1]


def _load(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_benchmark_quick_mode(capsys):
    bench = _load(ROOT / "benchmarks" / "bench_parity.py", "bench_parity")
    res = bench.main(["--quick", "--n", "20000", "--loop-n", "300", "--repeat", "1"])
    out = capsys.readouterr().out
    assert "Z.sum()" in out and "per-sample loop (timed on 300, extrapolated)" in out
    assert set(res) == {"faulty (20 sigma on sensor 2)", "fault-free", "construction"}
    construction = res.pop("construction")
    assert "ParityFDI construction" in out and all(t > 0 for t in construction.values())
    for r in res.values():
        assert r["agree"] == 1.0  # vectorised and per-sample results coincide
        assert r["t_loop"] > r["t_vec"] > 0
    assert res["faulty (20 sigma on sensor 2)"]["detected"] == 1.0


@pytest.mark.slow
def test_example_reproduces_the_seed_004_experiment(tmp_path, capsys):
    ex = _load(ROOT / "examples" / "parity_dodecahedron.py", "parity_dodecahedron")
    out = ex.main(["--out", str(tmp_path), "--runs", "300", "--sigma", "0.0005", "--seed", "1"])
    text = capsys.readouterr().out
    assert (tmp_path / "parity_dodecahedron_rates.png").stat().st_size > 10_000
    assert (tmp_path / "parity_dodecahedron_fault_size.png").stat().st_size > 10_000
    drift = out["drift"]  # detection delays of a slow drift, same stream and pfa
    assert drift["windowed GLT (100)"] is not None and drift["CUSUM (shift 0.5, 100)"] is not None
    assert (
        drift["per-sample GLT"] is None or drift["per-sample GLT"] > 3 * drift["windowed GLT (100)"]
    )
    assert "two-fault GLR" in text and "paper search (Qin-Niu)" in text
    glt, opt, bound = out["false_alarms"][0.05]
    assert abs(glt - 0.05) < 4 * (0.05 * 0.95 / 1500) ** 0.5 and opt > bound
    summ = out["experiments"][0.0005].summary()
    assert summ["single fault, +/-0.01"]["two-fault GLR"]["mean"] > 0.97


@pytest.mark.parametrize(
    "module",
    [
        gf.parity.model,
        gf.parity.thresholds,
        gf.parity.capability,
        gf.parity.configs,
        gf.parity.estimation,
    ],
)
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0
