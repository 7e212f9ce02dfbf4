"""Pole placement by the Schur method (geomfdi.synthesis.least_order.placement)."""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.synthesis.least_order.placement import place_poles


def _miss(A, B, K, poles):
    """Largest relative distance of a requested pole to the computed spectrum."""
    lam = np.linalg.eigvals(A - B @ K)
    return max(float(np.min(np.abs(lam - p))) / max(1.0, abs(p)) for p in poles)


def _spectrum_matches(A, B, K, poles, tol):
    lam = np.sort_complex(np.linalg.eigvals(A - B @ K))
    np.testing.assert_allclose(lam, np.sort_complex(np.asarray(poles, complex)), atol=tol)


def _random_poles(rng, n):
    poles: list[complex] = []
    while len(poles) < n:
        if n - len(poles) >= 2 and rng.random() < 0.4:
            c = complex(-0.2 - 3 * rng.random(), 0.2 + 2 * rng.random())
            poles += [c, c.conjugate()]
        else:
            poles.append(complex(-0.2 - 3 * rng.random()))
    return poles


@pytest.mark.parametrize("m", [1, 2, 3])
def test_random_pairs_hit_the_poles(m):
    """Random plants up to order 7: every miss within the design check's 1e-4 (close
    poles through one input are intrinsically ill-conditioned), typically at rounding."""
    rng = np.random.default_rng(10 + m)
    misses = []
    for _ in range(200):
        n = int(rng.integers(1, 8))
        A = rng.standard_normal((n, n))
        B = rng.standard_normal((n, m))
        poles = _random_poles(rng, n)
        K = place_poles(A, B, poles)
        assert K.shape == (m, n) and K.dtype == float
        misses.append(_miss(A, B, K, poles))
    assert max(misses) < 1e-4 and np.median(misses) < 1e-11


def test_single_input_gain_is_the_unique_one():
    """One input: the gain is unique; Ackermann's formula gives it independently."""
    A = np.array([[1.0, 1.0, 1.0], [0.0, 1.0, 0.0], [2.0, 0.0, 1.0]])
    b = np.array([[1.0], [1.0], [1.0]])
    poles = [-1.0, -2 + 1j, -2 - 1j]
    K = place_poles(A, b, poles)
    ctrb = np.hstack([b, A @ b, A @ A @ b])
    coeffs = np.real(np.poly(poles))
    pA = sum(c * np.linalg.matrix_power(A, 3 - i) for i, c in enumerate(coeffs))
    ack = np.array([[0.0, 0.0, 1.0]]) @ np.linalg.solve(ctrb, pA)
    np.testing.assert_allclose(K, ack, rtol=1e-10, atol=1e-12)


def test_complex_pairs_on_real_and_complex_blocks():
    # a rotation (complex eigenvalues) and a real spectrum, each with complex and real targets
    rot = np.array([[0.0, 2.0, 0.0], [-2.0, 0.0, 0.0], [0.0, 0.0, 3.0]])
    diag = np.diag([1.0, 2.0, 3.0])
    B = np.array([[1.0], [1.0], [1.0]])
    for A in (rot, diag):
        for poles in ([-1, -2, -3], [-1 + 2j, -1 - 2j, -4], [-0.5, -3 + 1j, -3 - 1j]):
            K = place_poles(A, B, poles)
            _spectrum_matches(A, B, K, poles, 1e-9)
    A = np.zeros((4, 4))
    A[:2, :2] = [[0.0, 1.0], [-1.0, 0.0]]
    A[2:, 2:] = [[0.5, 3.0], [-3.0, 0.5]]
    B = np.ones((4, 2))
    B[0, 1] = -1.0
    B[3, 0] = 2.0
    for poles in (
        [-1, -2, -3, -4],
        [-1 + 1j, -1 - 1j, -2 + 3j, -2 - 3j],
        [-1, -2, -1j - 3, 1j - 3],
    ):
        _spectrum_matches(A, B, place_poles(A, B, poles), poles, 1e-9)


def test_repeated_poles():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((4, 4))
    # two inputs: a double pole needs no Jordan block
    B = rng.standard_normal((4, 2))
    _spectrum_matches(A, B, place_poles(A, B, [-1, -1, -2, -2]), [-1, -1, -2, -2], 1e-6)
    # one input: a Jordan block, its eigenvalues scatter by about sqrt(eps)
    b = rng.standard_normal((4, 1))
    assert _miss(A, b, place_poles(A, b, [-1, -1, -3, -3]), [-1, -1, -3, -3]) < 1e-6
    # a repeated complex pair through two inputs
    P = [-1 + 1j, -1 - 1j, -1 + 1j, -1 - 1j]
    assert _miss(A, B, place_poles(A, B, P), P) < 1e-6


def test_multi_input_discrete_poles():
    rng = np.random.default_rng(8)
    A = rng.standard_normal((6, 6))
    B = rng.standard_normal((6, 3))
    poles = [0.1, 0.2 + 0.1j, 0.2 - 0.1j, -0.3, 0.0, 0.5]
    _spectrum_matches(A, B, place_poles(A, B, poles), poles, 1e-8)


def test_errors():
    A = np.diag([1.0, 2.0])
    with pytest.raises(np.linalg.LinAlgError, match="uncontrollable"):
        place_poles(A, np.array([[1.0], [0.0]]), [-1, -2])
    with pytest.raises(ValueError, match="expected 2 poles"):
        place_poles(A, np.ones((2, 1)), [-1])
    with pytest.raises(ValueError, match="conjugate"):
        place_poles(A, np.ones((2, 1)), [-1 + 1j, -2 - 1j])
    assert place_poles(np.zeros((0, 0)), np.zeros((0, 2)), []).shape == (2, 0)


def test_design_with_requested_poles_hits_them():
    """The full-quotient construction with user poles, several outputs per row."""
    A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
    B = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]
    C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]
    plant = gf.Plant(A, B, C)
    faults = [gf.SensorFault(i) for i in range(3)]
    g = gf.design_residual_generator(plant, faults, 1, poles=[-1, -2 + 1j, -2 - 1j], method="full")
    F = g.info["construction"]["F"]
    np.testing.assert_allclose(
        np.sort_complex(np.linalg.eigvals(F)), np.sort_complex([-1, -2 - 1j, -2 + 1j]), atol=1e-8
    )
    assert gf.verify(g, plant).ok
