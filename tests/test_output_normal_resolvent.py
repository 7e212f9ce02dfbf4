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
    # at a few points every block is taken at once (a cumulative all-pass product)
    few = rows_resolvent(Lam, h, starts, pts[:3])
    assert np.allclose(few, rows[:3], rtol=1e-12, atol=1e-14)


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


def test_quotient_by_an_invariant_subspace_takes_the_reordered_plant_schur_form():
    rng = np.random.default_rng(8)
    n, m = 20, 2
    # A with an invariant subspace S_p of dimension m (block upper triangular in the
    # coordinates [S_p, S_p^⊥]), seen in random orthogonal coordinates
    B = rng.standard_normal((n, n))
    B[m:, :m] = 0.0
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    A = V @ B @ V.T
    T, U = complex_schur(A)
    P = V[:, m:].T  # orthonormal rows spanning S_p^⊥
    A0 = P @ A @ P.T
    got = _schur_from_plant(A0, P, (T, U))
    assert got is not None
    T0, W = got
    k = n - m
    assert np.allclose(np.tril(T0, -1), 0)
    assert np.allclose(W.conj().T @ W, np.eye(k), atol=1e-12)
    assert np.allclose(W @ T0 @ W.conj().T, A0, atol=1e-12)
    # the quotient's eigenvalues are the plant's Schur values, bit for bit
    assert set(np.diag(T0).tolist()) <= set(np.diag(T).tolist())
    # a subspace that is not invariant is refused (the quotient is not A modulo it)
    W2, _ = np.linalg.qr(rng.standard_normal((n, n)))
    P2 = W2[:, m:].T
    assert _schur_from_plant(P2 @ A @ P2.T, P2, (T, U)) is None


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


def test_output_normal_generator_checked_without_its_schur_form():
    import warnings

    import geomfdi as gf
    from geomfdi.generators.gains import Composite, PlantFactor

    p = gf.mass_spring_chain(8, sensors=3, forces=(2, 7), zeta=0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gf.CloseRankWarning)
        g = gf.design_sensor_bank(p).generators[0]
    factor = PlantFactor(p)
    comp = Composite(g, p, factor)
    assert comp.on_blocks is not None  # an output-normal row
    assert "TF" not in comp.__dict__  # no Schur form of F taken for its checks
    lam = np.linalg.eigvals(g.F)
    own = comp.eig[p.n :]
    assert own.size == lam.size
    dist = np.abs(own[:, None] - lam[None, :])
    assert np.max(np.min(dist, axis=1)) < 1e-9 and np.max(np.min(dist, axis=0)) < 1e-9
    for s in (0.3j, 1.0 + 2.0j):
        Gy, Gu = comp.generator_tf(s)
        R = g.M @ np.linalg.inv(s * np.eye(g.order) - g.F)
        assert np.allclose(Gy, -R @ g.E - g.H, rtol=1e-9, atol=1e-12)
        assert np.allclose(Gu, R @ g.G + g.K, rtol=1e-9, atol=1e-12)
    # the Schur factors are still there on demand, and give the same transfer
    assert comp.TF.shape == g.F.shape
    T = comp.MUF @ np.linalg.solve(0.3j * np.eye(g.order) - comp.TF, comp.UFEG)
    assert np.allclose(T[:, : p.q] - g.H, comp.generator_tf(0.3j)[0], rtol=1e-9, atol=1e-12)
    # a second composite of the same row on the same plant: the same points and gains
    comp2 = Composite(g, p, factor)
    np.testing.assert_array_equal(comp2.points, comp.points)
    np.testing.assert_array_equal(
        comp2.generator_tf_many(comp2.points), comp.generator_tf_many(comp.points)
    )


def test_memo_keeps_results_within_its_byte_budget():
    from geomfdi.generators.resolvents import _Memo

    memo = _Memo(64, nbytes=1000)
    made = []

    def make(v):
        return lambda: made.append(v) or np.full(50, float(v))  # 400 bytes

    for k in (1, 2, 3):  # the third exceeds 1000 bytes: the oldest goes
        memo.get(bytes([k]), make(k))
    assert list(memo.data) == [bytes([2]), bytes([3])]
    assert memo.get(bytes([2]), make(-2))[0] == 2.0 and made == [1, 2, 3]  # a hit
    big = memo.get(b"big", lambda: np.zeros(1000))  # over the budget alone: kept alone
    assert list(memo.data) == [b"big"] and memo.get(b"big", make(-1)) is big
    few = _Memo(2, nbytes=1 << 30)
    for k in (1, 2, 3):
        few.get(bytes([k]), make(k))
    assert list(few.data) == [bytes([2]), bytes([3])]  # and at most `size` results


def test_bank_rows_compute_each_shared_resolvent_once(monkeypatch):
    """The 200-state chain's sensor bank alternates between generator pole sets (orders
    200, 198, 134): every remembered resolvent of its checks (output-normal rows and
    columns, plant solves) is computed once per content (no result evicted before a
    later row needs it)."""
    import warnings
    from collections import Counter

    import geomfdi as gf
    import geomfdi.generators.resolvents as res

    made = Counter()
    get = res._Memo.get

    def counted(self, key, make):
        return get(self, key, lambda: made.update([key]) or make())

    monkeypatch.setattr(res._Memo, "get", counted)
    p = gf.mass_spring_chain(100, sensors=10, forces=(33, 99), zeta=0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gf.CloseRankWarning)
        bank = gf.design_sensor_bank(p)
    assert len({g.order for g in bank.generators}) >= 3
    assert len(made) >= 10
    assert max(made.values()) == 1
