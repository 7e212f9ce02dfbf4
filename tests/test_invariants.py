"""W* (Algorithm 1), S* (Algorithm 2), friends and the tolerance policy.

The reference facts come from the example of Hou, Wen & Chen (2011), §4.  The property-based tests
draw small integer systems with q < n (so Ker C is non-trivial) and check each result
against constructions that do not use the algorithm under test: exact Krylov spans in
sympy, ``scipy.linalg.orth`` / ``null_space`` iterations written here, and the defining
properties of conditioned invariants and unobservability subspaces.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.linalg
import sympy as sp
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import geomfdi as gf
from geomfdi.errors import DesignError, GeomFDIError
from geomfdi.geometry.unobservability import measurement_map

# --------------------------------------------------------------------------- helpers
RCOND = 1e-8  # threshold of the independent constructions below (not geomfdi's policy)


def max_angle(P: np.ndarray, Q: np.ndarray) -> float:
    """Largest principal angle between the spans of P and Q (same dimension required)."""
    assert P.shape[1] == Q.shape[1], (P.shape, Q.shape)
    if P.shape[1] == 0:
        return 0.0
    return float(np.max(scipy.linalg.subspace_angles(P, Q)))


def orth(M: np.ndarray) -> np.ndarray:
    return scipy.linalg.orth(M, rcond=RCOND) if M.size and np.any(M) else M[:, :0]


def inside(Q: np.ndarray, V: np.ndarray) -> bool:
    """span Q ⊆ span V, both orthonormal (residual of the projection)."""
    if Q.shape[1] == 0:
        return True
    R = Q - V @ (V.T @ Q) if V.shape[1] else Q
    return float(np.linalg.norm(R, 2)) < 1e-8


def own_reachable(F: np.ndarray, L: np.ndarray) -> np.ndarray:
    """<F | Im L>: V_0 = Im L, V_{k+1} = Im L + F V_k, with scipy's orth."""
    f = np.linalg.norm(F, 2) or 1.0
    Q0 = orth(L)
    Q = Q0
    for _ in range(F.shape[0] + 1):
        Qn = orth(np.hstack([Q0, F @ Q / f]))
        if Qn.shape[1] == Q.shape[1]:
            return Qn
        Q = Qn
    return Q


def own_max_invariant(F: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Largest F-invariant subspace in span K, as (min Fᵀ-invariant containing K^⊥)^⊥."""
    n = F.shape[0]
    Kp = scipy.linalg.null_space(K.T, rcond=RCOND) if K.shape[1] else np.eye(n)
    N = own_reachable(F.T, Kp) if Kp.shape[1] else Kp
    return scipy.linalg.null_space(N.T, rcond=RCOND) if N.shape[1] else np.eye(n)


def exact_span(M: sp.Matrix, n: int) -> gf.exact.ExactSubspace:
    return gf.exact.ExactSubspace(M, n)


def exact_reachable(F: sp.Matrix, L: sp.Matrix) -> gf.exact.ExactSubspace:
    """<F | Im L> = Im [L, F L, ..., F^{n-1} L] in exact arithmetic."""
    n = F.rows
    blocks, X = [], L
    for _ in range(n):
        blocks.append(X)
        X = F * X
    return exact_span(sp.Matrix.hstack(*blocks), n)


def numeric(E: gf.exact.ExactSubspace) -> gf.Subspace:
    return gf.Subspace(E.to_numeric()) if E.dim else gf.Subspace.zero(E.n)


def invariance_defect(F: np.ndarray, Q: np.ndarray) -> float:
    """||(I - Q Qᵀ) F Q|| / ||F||: zero iff span Q is F-invariant."""
    if Q.shape[1] == 0:
        return 0.0
    return float(np.linalg.norm(F @ Q - Q @ (Q.T @ F @ Q), 2) / (np.linalg.norm(F, 2) or 1.0))


def friend_defect(A: np.ndarray, D: np.ndarray, C: np.ndarray, Q: np.ndarray) -> float:
    """``||(I - Q Qᵀ)(A + D C) Q||`` relative to the data, ``||A|| + ||D|| ||C||``: zero iff
    span Q is ``(A + D C)``-invariant (``A + D C`` itself may cancel to rounding, where a
    defect relative to its own norm means nothing)."""
    F = A + D @ C
    scale = np.linalg.norm(A, 2) + np.linalg.norm(D, 2) * np.linalg.norm(C, 2)
    return invariance_defect(F, Q) * (np.linalg.norm(F, 2) or 1.0) / (scale or 1.0)


def random_orthogonal(n: int, rng: np.random.Generator) -> np.ndarray:
    Q, R = np.linalg.qr(rng.standard_normal((n, n)))
    return Q * np.sign(np.diag(R))


# ------------------------------------------------------------------------ strategies
@st.composite
def integer_systems(draw, max_n: int = 6):
    """(A, C, L) with integer entries, 2 <= n <= max_n, 1 <= q < n, 1-2 fault columns.

    A is sparse often enough that W* needs several steps; with probability 1/2 the first
    column of L lies in Ker C, which makes the iteration of Algorithm 1 non-trivial.
    """
    n = draw(st.integers(2, max_n))
    q = draw(st.integers(1, n - 1))
    k = draw(st.integers(1, 2))
    sparse = st.sampled_from([0, 0, 0, 1, -1, 2])
    dense = st.integers(-3, 3)
    A = draw(hnp.arrays(np.int64, (n, n), elements=draw(st.sampled_from([sparse, dense]))))
    C = draw(hnp.arrays(np.int64, (q, n), elements=st.integers(-2, 2)))
    if not C.any():
        C[0, draw(st.integers(0, n - 1))] = 1
    L = draw(hnp.arrays(np.int64, (n, k), elements=dense))
    if draw(st.booleans()):
        N = sp.Matrix(C.tolist()).nullspace()
        coef = draw(hnp.arrays(np.int64, len(N), elements=st.integers(-2, 2)))
        coef[0] = coef[0] or 1
        v = sum((int(c) * b for c, b in zip(coef, N, strict=True)), sp.zeros(n, 1))
        den = sp.ilcm(*[sp.fraction(x)[1] for x in v]) if any(v) else 1
        L[:, 0] = np.array([int(x * den) for x in v], dtype=np.int64)
    return A.astype(float), C.astype(float), L.astype(float)


# ------------------------------------------------------------------ Hou-Wen-Chen example
A001 = np.array([[1, 1, 1], [0, 1, 0], [2, 0, 1]], dtype=float)
C001 = np.array([[0, 1, 0], [0, 0, 1], [1, 0, 2]], dtype=float)


def seed001_signatures() -> tuple[np.ndarray, np.ndarray]:
    """f_i solving C f_i = e_i and L_i = -A f_i (Hou, Wen & Chen 2011, paper method)."""
    F = np.linalg.solve(C001, np.eye(3))
    return F, -A001 @ F


def test_seed001_signatures_match_reference(seed001):
    assert np.allclose(seed001.A, A001) and np.allclose(seed001.C, C001)
    F, L = seed001_signatures()
    assert np.allclose(F.T, [[0, 1, 0], [-2, 0, 1], [1, 0, 0]])
    assert np.allclose(L.T, [[-1, -1, 0], [1, 0, 3], [-1, 0, -2]])
    assert gf.kernel(C001).dim == 0


@pytest.mark.parametrize("j", [0, 1, 2])
def test_seed001_wstar_equals_sstar_equals_span_of_other_signatures(j):
    _, L = seed001_signatures()
    others = np.delete(L, j, axis=1)
    W = gf.min_conditioned_invariant(A001, C001, others)
    S = gf.min_unobservability_subspace(A001, C001, others)
    span_others = gf.Subspace(others)
    assert W == span_others and S == span_others and W == S
    assert W.dim == 2 and W.history == [2, 2] and W.steps == 1  # reached in one step
    assert S.history == [3, 2, 2]
    assert S.n - S.dim == 1  # quotient dimension (generator order)
    assert not S.contains(gf.Subspace(L[:, j]))  # the residual for fault j exists
    assert gf.is_unobservability_subspace(A001, C001, S)
    assert S.W == W
    # exact rational versions: same dimensions, histories and subspaces
    We = gf.exact.min_conditioned_invariant(A001, C001, others)
    Se = gf.exact.min_unobservability_subspace(A001, C001, others)
    assert (We.history, Se.history) == (W.history, S.history)
    assert We == Se and We == gf.exact.span(others)
    assert max_angle(Se.to_numeric(), S.basis) < 1e-12
    assert all(x.is_Rational for x in Se.basis)


def test_seed001_measurement_map():
    _, L = seed001_signatures()
    S = gf.min_unobservability_subspace(A001, C001, L[:, 1:])
    H = measurement_map(C001, S)
    assert H.shape == (1, 3)
    assert np.allclose(H @ H.T, 1.0)
    assert gf.kernel(H @ C001) == S + gf.kernel(C001)
    # p_1 ∝ (0, 1, 0) (the paper): the row H C annihilates S
    assert max_angle((H @ C001).T, np.array([[0.0], [1.0], [0.0]])) < 1e-12


# ---------------------------------------------------------------- W*: property tests
@given(integer_systems(), st.integers(0, 2**32 - 1))
def test_wstar_is_the_smallest_conditioned_invariant_containing_L(system, seed):
    A, C, L = system
    n, q = C.shape[1], C.shape[0]
    rng = np.random.default_rng(seed)
    W = gf.min_conditioned_invariant(A, C, L)
    S = gf.min_unobservability_subspace(A, C, L)
    # contains L, is (C, A)-invariant; iteration is non-decreasing and stops on a repeat
    assert W.contains(gf.Subspace(L))
    assert gf.is_conditioned_invariant(A, C, W)
    assert W.history == sorted(W.history) and W.history[-1] == W.history[-2] == W.dim
    assert len(W.history) <= n + 2
    # contained in every (C, A)-conditioned invariant containing L that we can build:
    As, Cs, Ls = (sp.Matrix(M.astype(int).tolist()) for M in (A, C, L))
    D1 = sp.Matrix(rng.integers(-2, 3, (n, q)).tolist())
    KerC = sp.Matrix.hstack(*Cs.nullspace())
    candidates = {
        "S*": S,
        "<A | L>": numeric(exact_reachable(As, Ls)),  # A-invariant
        "<A + D C | L>": numeric(exact_reachable(As + D1 * Cs, Ls)),  # (A + D C)-invariant
        "L + A Ker C": numeric(exact_span(sp.Matrix.hstack(Ls, As * KerC), n)),
    }
    for name, V in candidates.items():
        assert gf.is_conditioned_invariant(A, C, V), name
        assert V.contains(W), name
    # the same inclusions hold exactly
    We = gf.exact.min_conditioned_invariant(A, C, L)
    assert exact_reachable(As + D1 * Cs, Ls).contains(We)
    assert exact_span(sp.Matrix.hstack(Ls, As * KerC), n).contains(We)
    # minimality, independently: for any friend D of W*, <A + D C | L> = W*
    D = gf.friends(A, C, W).random(rng)
    R = own_reachable(A + D @ C, L)
    assert R.shape[1] == W.dim
    assert max_angle(R, W.basis) < 1e-7


@given(integer_systems(), st.integers(0, 2**32 - 1))
def test_wstar_is_not_a_conditioned_invariant_when_cut_down(system, seed):
    """Dropping any direction of W* outside Im L breaks (C, A)-invariance or L ⊆ W."""
    A, C, L = system
    W = gf.min_conditioned_invariant(A, C, L)
    Lsp = gf.Subspace(L)
    if W.dim == Lsp.dim:
        return
    rng = np.random.default_rng(seed)
    # a random hyperplane of W* that still contains Im L
    X = Lsp.complement()
    extra = (W & X).basis
    keep = extra @ scipy.linalg.null_space(rng.standard_normal((1, extra.shape[1])))
    V = Lsp + gf.Subspace.from_orthonormal(orth(keep)) if keep.size else Lsp
    assert V.dim == W.dim - 1 and V.contains(Lsp)
    assert not gf.is_conditioned_invariant(A, C, V)
    with pytest.raises(DesignError):
        gf.friend(A, C, V)


# ---------------------------------------------------------------- S*: property tests
@given(integer_systems(), st.integers(0, 2**32 - 1))
def test_sstar_is_an_unobservability_subspace_containing_wstar(system, seed):
    A, C, L = system
    n = A.shape[0]
    rng = np.random.default_rng(seed)
    W = gf.min_conditioned_invariant(A, C, L)
    S = gf.min_unobservability_subspace(A, C, L)
    assert S.contains(W) and S.contains(gf.Subspace(L)) and S.W == W
    assert S.history[0] == n and S.history == sorted(S.history, reverse=True)
    assert S.history[-1] == S.history[-2] == S.dim
    assert gf.is_unobservability_subspace(A, C, S)
    # Definition 3 independently: with a random friend D and K = S + Ker C = Ker(H C),
    # S is the largest (A + D C)-invariant subspace of K
    D = gf.friends(A, C, S).random(rng)
    F = A + D @ C
    assert invariance_defect(F, S.basis) < 1e-9
    K = orth(np.hstack([S.basis, scipy.linalg.null_space(C, rcond=RCOND)]))
    H = measurement_map(C, S)
    assert max_angle(K, gf.kernel(H @ C).basis if H.shape[0] else np.eye(n)) < 1e-8
    V = own_max_invariant(F, K)
    assert V.shape[1] == S.dim
    assert max_angle(V, S.basis) < 1e-7
    # W* is an unobservability subspace only when it equals S*
    assert gf.is_unobservability_subspace(A, C, W) == (W.dim == S.dim)
    # S* is the smallest UOS containing itself, and grows with L
    assert gf.min_unobservability_subspace(A, C, S).dim == S.dim
    bigger = gf.min_unobservability_subspace(A, C, np.hstack([L, rng.standard_normal((n, 1))]))
    assert bigger.contains(S)


@given(integer_systems())
def test_sstar_of_nothing_is_the_unobservable_subspace(system):
    A, C, _ = system
    n = A.shape[0]
    As, Cs = sp.Matrix(A.astype(int).tolist()), sp.Matrix(C.astype(int).tolist())
    O = sp.Matrix.vstack(*[Cs * As**i for i in range(n)])
    N = gf.exact.kernel(O)
    U = gf.unobservable_subspace(A, C)
    assert U.dim == N.dim
    if U.dim:
        assert max_angle(U.basis, N.to_numeric()) < 1e-9
    S0 = gf.min_unobservability_subspace(A, C, np.zeros((n, 0)))
    assert S0.dim == U.dim and S0 == U
    assert gf.min_conditioned_invariant(A, C, np.zeros((n, 0))).dim == 0


# ----------------------------------------------------------- numeric versus exact
@given(integer_systems(max_n=7))
def test_numeric_and_exact_agree(system):
    A, C, L = system
    W, S = gf.min_conditioned_invariant(A, C, L), gf.min_unobservability_subspace(A, C, L)
    We = gf.exact.min_conditioned_invariant(A, C, L)
    Se = gf.exact.min_unobservability_subspace(A, C, L)
    assert (W.dim, W.history) == (We.dim, We.history)
    assert (S.dim, S.history) == (Se.dim, Se.history)
    assert max_angle(W.basis, We.to_numeric()) < 1e-9
    assert max_angle(S.basis, Se.to_numeric()) < 1e-9
    # exact bases are rational and canonical: another spanning set gives the same basis
    assert all(x.is_Rational for x in Se.basis)
    n = A.shape[0]
    assert gf.exact.ExactSubspace(sp.Matrix.hstack(Se.basis * 3, Se.W.basis), n) == Se
    assert Se.W == We


def test_exact_switch_and_sympy_dispatch():
    _, L = seed001_signatures()
    Lr = sp.Matrix([[1, -1], [0, 0], [3, -2]])  # L_2, L_3 as exact columns
    assert np.allclose(np.array(Lr.tolist(), dtype=float), L[:, 1:])
    by_flag = gf.min_unobservability_subspace(A001, C001, L[:, 1:], exact=True)
    by_type = gf.min_unobservability_subspace(sp.Matrix(A001.astype(int)), C001, Lr)
    direct = gf.exact.min_unobservability_subspace(A001, C001, Lr)
    assert isinstance(by_flag, gf.exact.ExactSubspace)
    assert by_flag == by_type == direct
    assert by_flag.basis == sp.Matrix([[1, 0], [0, 0], [0, 1]])  # span{e1, e3}, rref
    W = gf.min_conditioned_invariant(A001, C001, Lr)
    assert isinstance(W, gf.exact.ExactSubspace) and W.history == [2, 2]


def test_exact_reads_decimals_exactly():
    M = gf.exact.to_rational([[0.1, 2], [1.5, -3]])
    assert M == sp.Matrix([[sp.Rational(1, 10), 2], [sp.Rational(3, 2), -3]])


# ------------------------------------------------------------------- invariances
scales = st.one_of(st.sampled_from([1e-6, 1e6]), st.floats(-6, 6).map(lambda e: 10.0**e))


@given(integer_systems(), scales, scales)
def test_results_unchanged_under_scaling(system, alpha, beta):
    A, C, L = system
    W0, S0 = gf.min_conditioned_invariant(A, C, L), gf.min_unobservability_subspace(A, C, L)
    W = gf.min_conditioned_invariant(alpha * A, beta * C, L)
    S = gf.min_unobservability_subspace(alpha * A, beta * C, L)
    assert (W.history, S.history) == (W0.history, S0.history)
    assert max_angle(W.basis, W0.basis) < 1e-9 and max_angle(S.basis, S0.basis) < 1e-9
    assert gf.is_unobservability_subspace(alpha * A, beta * C, S)


@given(integer_systems(), st.integers(0, 2**32 - 1))
def test_results_unchanged_under_orthogonal_change_of_coordinates(system, seed):
    A, C, L = system
    T = random_orthogonal(A.shape[0], np.random.default_rng(seed))
    W0, S0 = gf.min_conditioned_invariant(A, C, L), gf.min_unobservability_subspace(A, C, L)
    W = gf.min_conditioned_invariant(T.T @ A @ T, C @ T, T.T @ L)
    S = gf.min_unobservability_subspace(T.T @ A @ T, C @ T, T.T @ L)
    assert (W.history, S.history) == (W0.history, S0.history)
    assert max_angle(T @ W.basis, W0.basis) < 1e-9
    assert max_angle(T @ S.basis, S0.basis) < 1e-9


# -------------------------------------------------------------------------- friends
@given(integer_systems(), st.integers(0, 2**32 - 1))
@example(  # A + D C cancels to rounding: its defect counts against the data's norms
    (np.array([[2.0, 1, 1], [0, 0, 0], [0, 0, 0]]), np.array([[2.0, 1, 1]]), np.c_[[0.0, 1, 1]]),
    0,
)
def test_every_friend_keeps_the_subspace_invariant(system, seed):
    A, C, L = system
    q = C.shape[0]
    rng = np.random.default_rng(seed)
    for V in (gf.min_conditioned_invariant(A, C, L), gf.min_unobservability_subspace(A, C, L)):
        fs = gf.friends(A, C, V)
        rank_CV = gf.apply(C, V).dim
        assert fs.dim == V.dim * q + (V.n - V.dim) * (q - rank_CV)
        assert friend_defect(A, gf.friend(A, C, V), C, V.basis) < 1e-9
        for _ in range(3):
            D = fs.random(rng)
            assert D.shape == (V.n, q)
            assert friend_defect(A, D, C, V.basis) < 1e-9
            assert fs.contains(A, C, D)
        # moving D0 along Im(C V) towards V^⊥ breaks the invariance (when that is possible)
        if rank_CV and V.dim < V.n:
            u = gf.apply(C, V).basis[:, :1]
            D_bad = fs.D0 + 10 * fs.Q[:, :1] @ u.T
            assert friend_defect(A, D_bad, C, V.basis) > 1e-3
            assert not fs.contains(A, C, D_bad)


def test_friend_of_a_non_conditioned_invariant_raises():
    A = np.array([[0.0, 1.0], [1.0, 0.0]])
    C = np.array([[0.0, 1.0]])
    V = [[1.0], [0.0]]  # in Ker C, and A e1 = e2 leaves it
    assert not gf.is_conditioned_invariant(A, C, V)
    with pytest.raises(DesignError) as err:
        gf.friends(A, C, V)
    assert err.value.argument == "S"
    assert not gf.is_unobservability_subspace(A, C, V)


# --------------------------------------------------------- close rank decisions, rtol
def close_case(kept: float = 1e-11, dropped: float = 1e-13) -> tuple:
    """W* = span(e1, e2, e3) decided on a singular value ``kept`` next to ``dropped``.

    C = e4ᵀ, L = [e1, e2] ⊆ Ker C; A e1 = kept e3, A e2 = dropped e4, A e4 = e4.  The sum
    L + A L has singular values (1, 1, kept, dropped): rank 3 with gap kept / dropped.
    """
    A = np.zeros((4, 4))
    A[3, 3], A[2, 0], A[3, 1] = 1.0, kept, dropped
    return A, np.array([[0.0, 0.0, 0.0, 1.0]]), np.eye(4)[:, :2]


def test_close_rank_decision_warns_and_records_the_gap():
    A, C, L = close_case()
    with pytest.warns(gf.CloseRankWarning, match="min_conditioned_invariant"):
        W = gf.min_conditioned_invariant(A, C, L)
    assert W.dim == 3 and W.close
    assert 10 < W.min_gap < 1e3  # 1e-11 / 1e-13 = 100
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        S = gf.min_unobservability_subspace(A, C, L)
    close = [w for w in caught if issubclass(w.category, gf.CloseRankWarning)]
    assert len(close) == 1 and "min_unobservability_subspace" in str(close[0].message)
    assert S.min_gap <= W.min_gap


def test_well_separated_case_does_not_warn():
    A, C, L = close_case(kept=1.0, dropped=0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", gf.CloseRankWarning)
        W = gf.min_conditioned_invariant(A, C, L)
        S = gf.min_unobservability_subspace(A, C, L)
    assert W.dim == 3 and not W.close and W.min_gap > 1e10 and S.min_gap > 1e10


def test_tolerance_context_changes_the_decision_and_is_restored():
    A, C, L = close_case(kept=1e-9, dropped=0.0)
    assert gf.min_conditioned_invariant(A, C, L).dim == 3
    with gf.tolerance.tolerance(1e-7):
        assert gf.tolerance.get_rtol(4) == 1e-7
        W = gf.min_conditioned_invariant(A, C, L)
        assert W.dim == 2 and W.history == [2, 2]
    assert gf.tolerance.get_rtol(4) == gf.tolerance.default_rtol(4)
    assert gf.min_conditioned_invariant(A, C, L).dim == 3
    gf.set_rtol(1e-7)
    try:
        assert gf.min_unobservability_subspace(A, C, L).W.dim == 2
    finally:
        gf.set_rtol(None)
    assert gf.min_unobservability_subspace(A, C, L).W.dim == 3


@pytest.mark.parametrize("rtol", [0.0, 1.0, -1e-3, float("nan"), float("inf")])
def test_bad_rtol_is_rejected(rtol):
    with pytest.raises(GeomFDIError) as err:
        gf.set_rtol(rtol)
    assert err.value.argument == "rtol"
    assert gf.tolerance.get_rtol(3) == gf.tolerance.default_rtol(3)


def test_rank_decision_gap_definition():
    dec = gf.tolerance.rank_decision(np.array([2.0, 1e-3, 1e-20]), 2.0, 3, warn=False)
    assert dec.rank == 2 and np.isclose(dec.gap, 1e-3 / (2.0 * np.finfo(float).eps))
    dec = gf.tolerance.rank_decision(np.array([1.0, 1e-16]), 1.0, 3, warn=False)
    assert dec.rank == 1 and np.isclose(dec.gap, 1.0 / np.finfo(float).eps)
    with pytest.warns(gf.CloseRankWarning):
        dec = gf.tolerance.rank_decision(np.array([1.0, 1e-11, 1e-13]), 1.0, 3)
    assert dec.rank == 2 and dec.close and np.isclose(dec.gap, 100.0)


@settings(max_examples=20)
@given(integer_systems())
def test_integer_systems_take_well_separated_decisions(system):
    """Integer data never sits near the threshold: no warning, large gaps."""
    A, C, L = system
    with warnings.catch_warnings():
        warnings.simplefilter("error", gf.CloseRankWarning)
        S = gf.min_unobservability_subspace(A, C, L)
    assert S.min_gap > 1e6
