"""The numpy first-order filter of the simulator (geomfdi.simulation.recursion)."""

from __future__ import annotations

import numpy as np
import pytest

from geomfdi.simulation import recursion
from geomfdi.simulation.recursion import first_order_filter, recursion_inplace


def _loop(lam, x):
    """The recursion sample by sample, in plain Python (one pole, or one per row)."""
    x = np.asarray(x)
    per_row = np.ndim(lam) > 0
    y = np.zeros(x.shape, dtype=np.result_type(lam, x, 1.0))
    for idx in np.ndindex(x.shape[:-1]):
        pole = lam[idx[0]] if per_row else lam
        acc = 0.0
        for k in range(x.shape[-1]):
            acc = pole * acc + x[idx + (k,)]
            y[idx + (k,)] = acc
    return y


POLES = [0.0, 0.5, -0.9, 0.999, 1.0, -1.0, 1.001, 0.3 + 0.5j, 0.99j, -0.7 - 0.7j]
SHAPES = [(1,), (7,), (16,), (17,), (33,), (2, 300), (2, 3, 257), (1, 4097)]


@pytest.mark.parametrize("lam", POLES)
def test_equals_the_plain_loop(lam):
    rng = np.random.default_rng(abs(hash(lam)) % 1000)
    for shape in SHAPES:
        x = rng.standard_normal(shape)
        if isinstance(lam, complex):
            x = x + 1j * rng.standard_normal(shape)
        y, ref = first_order_filter(lam, x), _loop(lam, x)
        assert y.shape == ref.shape and y.dtype == ref.dtype
        np.testing.assert_allclose(y, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize("block", [1, 2, 5, 16, 64])
def test_block_lengths_and_levels(block):
    """Every block length (several levels of block ends) gives the same record."""
    rng = np.random.default_rng(block)
    x = rng.standard_normal((3, 5000))
    np.testing.assert_allclose(first_order_filter(0.97, x, block), _loop(0.97, x), atol=1e-11)


def test_equals_lfilter():
    import scipy.signal

    rng = np.random.default_rng(0)
    x = rng.standard_normal((4, 50_001))
    for lam in (0.2, -0.95, 0.9999):
        ref = scipy.signal.lfilter([1.0], [1.0, -lam], x, axis=-1)
        np.testing.assert_allclose(first_order_filter(lam, x), ref, rtol=0, atol=1e-12 * 1e3)
        rel = np.abs(first_order_filter(lam, x) - ref).max() / np.abs(ref).max()
        assert rel < 1e-12


def test_one_pole_per_row():
    rng = np.random.default_rng(1)
    lam = np.array([0.1, -0.5, 0.9, 0.0])
    x = rng.standard_normal((4, 2, 1000))
    np.testing.assert_allclose(first_order_filter(lam, x), _loop(lam, x), atol=1e-12)
    lamc = np.array([0.5 + 0.5j, 0.2, -0.9j])
    xc = rng.standard_normal((3, 1, 700)) + 0j
    np.testing.assert_allclose(first_order_filter(lamc, xc), _loop(lamc, xc), atol=1e-12)


def test_small_poles_give_no_subnormal_numbers():
    """Tiny powers are dropped (they would be subnormal): the record is unchanged."""
    x = np.random.default_rng(2).standard_normal((1, 20_000))
    y = first_order_filter(1e-3, x)
    np.testing.assert_allclose(y, _loop(1e-3, x), rtol=1e-13, atol=1e-15)


def test_empty_records():
    assert first_order_filter(0.5, np.zeros((3, 0))).shape == (3, 0)
    assert first_order_filter(0.5, np.zeros((0, 5))).shape == (0, 5)


def _reference_recursion(T, G):
    """z[k] = T z[k-1] + G[:, :, k] from rest, sample by sample."""
    n, R, N = G.shape
    Z = np.zeros(G.shape, dtype=np.result_type(T, G))
    z = np.zeros((n, R), dtype=Z.dtype)
    for k in range(N):
        z = T @ z + G[:, :, k]
        Z[:, :, k] = z
    return Z


@pytest.mark.parametrize("N", [2, 15, 1001, 20_000])
def test_recursion_inplace_diagonal_and_coupled(N):
    """The diagonal path (every state at once) and the back-substitution of a coupled
    triangular T (numpy or lfilter by size) equal the plain update."""
    rng = np.random.default_rng(N)
    G = rng.standard_normal((4, 1, N))
    D = np.diag([0.9, -0.5, 0.2, 0.99])
    np.testing.assert_allclose(
        recursion_inplace(D, G.copy(), np.arange(1, 5)), _reference_recursion(D, G), atol=1e-10
    )
    T = np.triu(rng.standard_normal((4, 4)) * 0.2, 1) + np.diag([0.9, -0.5, 0.2, 0.95])
    np.testing.assert_allclose(
        recursion_inplace(T, G.copy()), _reference_recursion(T, G), atol=1e-9
    )
    Tc = T + 1j * np.triu(rng.standard_normal((4, 4)) * 0.1, 1)
    np.testing.assert_allclose(
        recursion_inplace(Tc, G.astype(complex)), _reference_recursion(Tc, G), atol=1e-9
    )


def test_growing_records_use_lfilter(monkeypatch):
    """|lam|^N beyond the range of the powers: the compiled filter, same record."""
    calls = []
    real = recursion._lfilter
    monkeypatch.setattr(recursion, "_lfilter", lambda lam, x: calls.append(1) or real(lam, x))
    x = np.zeros((1, 2000))
    x[0, -5] = 1.0
    y = recursion._filter_state(1.5, x)
    assert calls and np.isfinite(y).all() and y[0, -1] == pytest.approx(1.5**4)
