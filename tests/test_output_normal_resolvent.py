"""Fast resolvents shared by the rows of a bank: output-normal generators and quotient
Schur forms taken from the plant's."""

import numpy as np

from geomfdi.generators.gains import complex_schur
from geomfdi.generators.output_normal import (
    column_resolvent,
    output_normal_blocks,
    rows_resolvent,
)
from geomfdi.synthesis.least_order.quotient import _schur_from_plant
from geomfdi.synthesis.least_order.rational_basis import output_normal_basis


def _poles(rng: np.random.Generator) -> np.ndarray:
    pairs = -rng.uniform(0.05, 2.0, 4) + 1j * rng.uniform(0.1, 5.0, 4)
    return np.concatenate([pairs, pairs.conj(), -rng.uniform(0.1, 3.0, 3)])


def test_output_normal_resolvents_match_dense_solves():
    rng = np.random.default_rng(3)
    Lam, h = output_normal_basis(_poles(rng), 0.0)
    starts = output_normal_blocks(Lam, h[None, :])
    assert starts is not None
    k = Lam.shape[0]
    pts = 1j * rng.uniform(-6, 6, 9) + rng.uniform(-0.5, 0.5, 9)
    w = rng.standard_normal(k)
    rows = rows_resolvent(Lam, h, starts, pts)
    cols = column_resolvent(Lam, h, starts, pts, w)
    for i, s in enumerate(pts):
        Rs = np.linalg.inv(s * np.eye(k) - Lam)
        assert np.allclose(rows[i], h @ Rs, rtol=1e-10, atol=1e-12)
        assert np.allclose(cols[i], Rs @ w, rtol=1e-10, atol=1e-12)


def test_output_normal_structure_is_recognised_exactly():
    rng = np.random.default_rng(4)
    Lam, h = output_normal_basis(_poles(rng), 0.0)
    M = h[None, :]
    bumped = Lam.copy()
    assert bumped[0, -2] != 0
    bumped[0, -2] *= 1 + 1e-15  # one entry above the blocks off by rounding: not the form
    assert output_normal_blocks(bumped, M) is None
    assert output_normal_blocks(Lam, 2.0 * M) is None  # M must be the h of F
    assert output_normal_blocks(Lam, np.vstack([M, M])) is None  # one output only
    assert output_normal_blocks(rng.standard_normal((5, 5)), rng.standard_normal((1, 5))) is None


def test_quotient_schur_from_the_plant_is_a_schur_form_or_refused():
    rng = np.random.default_rng(5)
    n = 12
    A = rng.standard_normal((n, n))
    T, U = complex_schur(A)
    P, _ = np.linalg.qr(rng.standard_normal((n, n)))
    A0 = P @ A @ P.T
    T0, W = _schur_from_plant(A0, P, (T, U))
    assert np.allclose(W @ T0 @ W.conj().T, A0, atol=1e-12)
    assert np.allclose(W.conj().T @ W, np.eye(n), atol=1e-12)
    # a quotient that is not A in rotated coordinates (an injection changed it) is refused
    assert _schur_from_plant(A0 + 1e-6 * rng.standard_normal((n, n)), P, (T, U)) is None
    # so is one of lower order, or a P with rows that are not orthonormal
    assert _schur_from_plant(A0[:-1, :-1], P[:-1], (T, U)) is None
    assert _schur_from_plant(A0, 1.001 * P, (T, U)) is None


def test_triangular_resolvents_at_few_and_many_points_solve_the_system():
    from geomfdi.generators.gains import FEW_POINTS, _tri_solve_many

    rng = np.random.default_rng(6)
    n = 90
    T, _ = complex_schur(rng.standard_normal((n, n)))
    X = rng.standard_normal((n, 2))
    for P in (1, FEW_POINTS, FEW_POINTS + 1, 3 * FEW_POINTS):
        pts = rng.standard_normal(P) + 1j * rng.standard_normal(P)
        Y = _tri_solve_many(T, pts, X)
        assert Y.shape == (P, n, 2)
        for i in range(P):
            res = (pts[i] * np.eye(n) - T) @ Y[i] - X
            assert np.linalg.norm(res) <= 1e-10 * np.linalg.norm(X)
