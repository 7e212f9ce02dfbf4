"""Subspace algebra (geomfdi.geometry.subspace) against independent constructions.

Every operation is compared with a construction that does not go through geomfdi:
``scipy.linalg.orth`` / ``null_space``, exact ranks from sympy, dimension formulas,
orthogonality and the defining property of the result.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import sympy as sp
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError

TOL = 1e-10


def rank_k(rows: int, cols: int, r: int, rng: np.random.Generator) -> np.ndarray:
    """A random rows x cols matrix of rank exactly r (generic factors)."""
    return rng.standard_normal((rows, r)) @ rng.standard_normal((r, cols))


def proj(Q: np.ndarray) -> np.ndarray:
    return Q @ Q.T


def same_span(Q1: np.ndarray, Q2: np.ndarray) -> bool:
    """Orthonormal bases Q1, Q2 span the same subspace (projectors agree)."""
    return Q1.shape[1] == Q2.shape[1] and np.linalg.norm(proj(Q1) - proj(Q2)) < 1e-9


int_matrices = st.integers(1, 6).flatmap(
    lambda r: st.integers(1, 6).flatmap(
        lambda c: hnp.arrays(np.int64, (r, c), elements=st.integers(-3, 3))
    )
)


# ----------------------------------------------------------------- Subspace / image
@pytest.mark.parametrize(("rows", "cols", "r"), [(5, 3, 3), (5, 4, 2), (6, 8, 4), (4, 2, 0)])
def test_image_matches_scipy_orth(rows, cols, r):
    rng = np.random.default_rng(rows * 100 + cols * 10 + r)
    M = rank_k(rows, cols, r, rng)
    S = gf.image(M)
    assert S.n == rows and S.dim == r
    assert np.allclose(S.basis.T @ S.basis, np.eye(r), atol=TOL)
    assert same_span(S.basis, scipy.linalg.orth(M) if r else np.zeros((rows, 0)))
    # every column of M lies in S, and S has no direction outside Im M
    assert np.linalg.norm(M - proj(S.basis) @ M) <= 1e-9 * np.linalg.norm(M)


@given(int_matrices)
def test_dimension_is_exact_rank_on_integer_matrices(M):
    exact_rank = sp.Matrix(M.tolist()).rank()
    assert gf.Subspace(M).dim == exact_rank
    assert gf.kernel(M).dim == M.shape[1] - exact_rank


def test_vector_is_one_column_and_zero_columns_allowed():
    S = gf.Subspace([1.0, 2.0, 2.0])
    assert (S.n, S.dim) == (3, 1)
    assert np.allclose(np.abs(S.basis[:, 0]), [1 / 3, 2 / 3, 2 / 3])
    Z = gf.Subspace(np.zeros((4, 0)))
    assert (Z.n, Z.dim, Z.codim) == (4, 0, 4)
    assert gf.Subspace(np.zeros((4, 2))).dim == 0


def test_rank_decision_is_relative_to_the_data_norm():
    rng = np.random.default_rng(1)
    M = rank_k(6, 4, 2, rng)
    for c in (1e-12, 1.0, 1e12):
        assert gf.Subspace(c * M).dim == 2
    # a component far below rtol * ||M|| does not count, one far above does
    U, _, Vt = np.linalg.svd(rng.standard_normal((6, 4)), full_matrices=False)
    assert gf.Subspace(U @ np.diag([1, 1, 1e-15, 0]) @ Vt).dim == 2
    assert gf.Subspace(U @ np.diag([1, 1, 1e-8, 0]) @ Vt).dim == 3


def test_full_and_zero_builders():
    F, Z = gf.Subspace.full(3), gf.Subspace.zero(3)
    assert F.dim == 3 and Z.dim == 0
    assert F.contains(gf.Subspace([[1], [2], [3]])) and not Z.contains(gf.Subspace([1, 0, 0]))
    assert F.complement() == Z and Z.complement() == F


# --------------------------------------------------------------------------- kernel
@pytest.mark.parametrize(("rows", "cols", "r"), [(2, 5, 2), (4, 4, 3), (6, 3, 3), (3, 5, 0)])
def test_kernel_matches_scipy_null_space(rows, cols, r):
    rng = np.random.default_rng(7 + rows + 3 * cols + 11 * r)
    M = rank_k(rows, cols, r, rng)
    K = gf.kernel(M)
    assert K.n == cols and K.dim == cols - r
    assert np.linalg.norm(M @ K.basis) < 1e-9 * max(np.linalg.norm(M), 1)
    assert same_span(K.basis, scipy.linalg.null_space(M, rcond=1e-10))
    # Ker M is the orthogonal complement of the row space
    assert K == gf.image(M.T).complement()


def test_kernel_of_a_row_vector():
    K = gf.kernel([1.0, 1.0, 0.0])
    assert K.dim == 2
    assert K == gf.Subspace([[1, 0], [-1, 0], [0, 1]])


def test_kernel_of_zero_rows_is_everything():
    assert gf.kernel(np.zeros((0, 3))) == gf.Subspace.full(3)


# ------------------------------------------------------------------------- preimage
@pytest.mark.parametrize(
    ("m", "n", "rA", "k"), [(4, 4, 4, 2), (5, 4, 2, 2), (3, 5, 3, 1), (4, 6, 2, 0)]
)
def test_preimage_defining_property_and_dimension(m, n, rA, k):
    rng = np.random.default_rng(m * 1000 + n * 100 + rA * 10 + k)
    A = rank_k(m, n, rA, rng)
    # S meets Im A in a known way: one direction of Im A plus k - 1 generic ones
    if k == 0:
        S = gf.Subspace.zero(m)
    else:
        in_image = A @ rng.standard_normal((n, 1))
        S = gf.Subspace(np.hstack([in_image, rng.standard_normal((m, k - 1))]))
    P = gf.preimage(A, S)
    # A x in S for every basis vector x of A^-1 S
    assert S.contains(gf.apply(A, P))
    assert np.linalg.norm(S.complement().basis.T @ A @ P.basis) < 1e-9 * np.linalg.norm(A, 2)
    # dim A^-1 S = dim Ker A + dim(S ∩ Im A)
    assert P.dim == gf.kernel(A).dim + (S & gf.image(A)).dim
    assert P.contains(gf.kernel(A))
    # maximality: no direction of P^⊥ maps into S (Q_S⊥ᵀ A restricted to P^⊥ is injective)
    Pc = P.complement().basis
    if Pc.shape[1]:
        Sc = S.complement().basis
        s = np.linalg.svd(Sc.T @ A @ Pc, compute_uv=False)
        assert s.size == Pc.shape[1] and s.min() > 1e-8 * np.linalg.norm(A, 2)


def test_preimage_under_invertible_map_is_the_image_of_the_inverse():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((5, 5)) + 5 * np.eye(5)
    S = gf.Subspace(rng.standard_normal((5, 2)))
    assert gf.preimage(A, S) == gf.image(np.linalg.solve(A, S.basis))


def test_preimage_of_whole_space_and_of_zero():
    A = np.array([[1.0, 2.0, 0.0], [0.0, 0.0, 0.0]])
    assert gf.preimage(A, gf.Subspace.full(2)) == gf.Subspace.full(3)
    assert gf.preimage(A, gf.Subspace.zero(2)) == gf.kernel(A)
    assert gf.preimage(A, np.array([[0.0], [1.0]])) == gf.kernel(A)  # array S accepted


def test_apply_is_image_of_product():
    rng = np.random.default_rng(5)
    A = rank_k(5, 5, 3, rng)
    S = gf.Subspace(rng.standard_normal((5, 4)))
    assert gf.apply(A, S) == gf.image(A @ S.basis)
    assert gf.apply(A, S).dim == 3
    assert gf.apply(A, gf.kernel(A)).dim == 0


# ------------------------------------------------------------------- sum / intersection
@pytest.mark.parametrize(
    ("n", "c", "a", "b"), [(6, 1, 2, 2), (7, 2, 1, 3), (5, 0, 2, 2), (5, 2, 0, 0)]
)
def test_sum_and_intersection_dimension_formula(n, c, a, b):
    rng = np.random.default_rng(n + 10 * c + 100 * a + 1000 * b)
    X = rng.standard_normal((n, c))  # common part
    S = gf.Subspace(np.hstack([X, rng.standard_normal((n, a))]))
    T = gf.Subspace(np.hstack([X, rng.standard_normal((n, b))]))
    U, V = S + T, S & T
    assert U.dim + V.dim == S.dim + T.dim
    assert U.dim == min(n, c + a + b)
    assert U == gf.image(np.hstack([S.basis, T.basis]))
    assert S <= U and T <= U and V <= S and V <= T
    if c + a + b <= n:
        assert V == (gf.Subspace(X) if c else gf.Subspace.zero(n))


@given(int_matrices, st.data())
def test_sum_intersection_formula_on_integer_subspaces(M, data):
    N = data.draw(
        hnp.arrays(
            np.int64, (M.shape[0], data.draw(st.integers(1, 4))), elements=st.integers(-2, 2)
        )
    )
    S, T = gf.Subspace(M), gf.Subspace(N)
    r_sum = sp.Matrix(np.hstack([M, N]).tolist()).rank()
    assert (S + T).dim == r_sum
    assert (S & T).dim == S.dim + T.dim - r_sum
    I = S & T
    assert S.contains(I) and T.contains(I)


def test_intersection_with_zero_and_self():
    S = gf.Subspace([[1, 0], [0, 1], [0, 0]])
    assert (S & gf.Subspace.zero(3)).dim == 0
    assert (S & S) == S
    assert (S + gf.Subspace.zero(3)) == S


# ------------------------------------------------------------------------ complement
@pytest.mark.parametrize("k", [0, 1, 3, 5])
def test_complement_is_orthogonal_and_complementary(k):
    rng = np.random.default_rng(k)
    S = gf.Subspace(rng.standard_normal((5, k)))
    Sc = S.complement()
    assert Sc.dim == 5 - k
    assert np.linalg.norm(S.basis.T @ Sc.basis) < 1e-12
    assert np.allclose(Sc.basis.T @ Sc.basis, np.eye(5 - k), atol=1e-12)
    assert (S + Sc) == gf.Subspace.full(5)
    assert (S & Sc).dim == 0
    assert Sc.complement() == S
    assert np.allclose(S.projector() + Sc.projector(), np.eye(5), atol=1e-12)


# ---------------------------------------------------------------- inclusion / equality
def test_inclusion_and_equality():
    S = gf.Subspace([[1, 0], [0, 1], [0, 0], [0, 0]])
    T = gf.Subspace([[1, 1], [1, -1], [0, 0], [0, 0]])  # same span, other vectors
    U = gf.Subspace([[1], [1], [1], [0]])
    assert S == T and T == S
    assert S.contains(T) and S >= T and S <= T
    assert not S.contains(U) and not (U <= S)
    assert (S + U).contains(U) and (S + U) >= S
    assert S != U and S != gf.Subspace([[1, 0], [0, 0], [0, 1], [0, 0]])  # same dim, other span
    assert S.contains([[2], [3], [0], [0]]) and not S.contains([0, 0, 0, 1])
    assert S != gf.Subspace([[1], [0], [0]])  # other ambient dimension
    assert (S == "S") is False


def test_inclusion_rejects_tilted_vectors_beyond_rounding():
    S = gf.Subspace([[1], [0]])
    assert S.contains(gf.Subspace([[1], [1e-14]]))  # rounding-size tilt
    assert not S.contains(gf.Subspace([[1], [1e-9]]))  # genuine tilt


# ----------------------------------------------------------------- principal angles
def test_principal_angles_match_svd_of_basis_products():
    rng = np.random.default_rng(11)
    S = gf.Subspace(rng.standard_normal((6, 3)))
    T = gf.Subspace(rng.standard_normal((6, 2)))
    ang = gf.principal_angles(S, T)
    cosines = np.linalg.svd(S.basis.T @ T.basis, compute_uv=False)
    assert ang.shape == (2,)
    assert np.allclose(np.sort(ang), np.sort(np.arccos(np.clip(cosines, -1, 1))), atol=1e-10)
    assert np.all(np.diff(ang) <= 0)  # descending
    assert np.allclose(S.angles(T), ang)


def test_principal_angles_known_values():
    e1, d = gf.Subspace([1, 0, 0]), gf.Subspace([1, 1, 0])
    assert np.allclose(gf.principal_angles(e1, d), [np.pi / 4])
    assert np.allclose(gf.principal_angles(e1, gf.Subspace([0, 0, 1])), [np.pi / 2])
    P = gf.Subspace([[1, 0], [0, 1], [0, 0]])
    assert np.allclose(gf.principal_angles(P, d), [0.0], atol=1e-12)  # nested
    assert gf.principal_angles(P, gf.Subspace.zero(3)).size == 0


def test_operations_reject_mismatched_ambient_dimensions():
    S, T = gf.Subspace.full(3), gf.Subspace.full(4)
    for op in (
        lambda: S + T,
        lambda: S & T,
        lambda: S.contains(T),
        lambda: gf.principal_angles(S, T),
    ):
        with pytest.raises(ShapeError):
            op()
    with pytest.raises(GeomFDIError):
        S + np.eye(3)
