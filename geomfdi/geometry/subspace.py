"""Subspace algebra on orthonormal bases (``docs/theory/geometric-approach.md``).

Every subspace of R^n is stored as an orthonormal basis (n x k) obtained from an SVD.
Each operation is a small function, in the manner of the Basile–Marro toolbox
(``ima``, ``ker``, ``sums``, ``ints``, ``invt``), so that the invariant-subspace
algorithms in :mod:`geomfdi.geometry.conditioned_invariant` and
:mod:`geomfdi.geometry.unobservability` read like the recursions they implement.

All rank decisions go through :func:`geomfdi.tolerance.rank_decision`: a singular value
counts when it exceeds ``rtol * scale`` where ``scale`` is the norm of the operator that
produced the matrix (``||A||`` for ``A Z``, ``||C||`` for ``C Z``, 1 for stacks of
orthonormal bases).  Decisions are taken on the un-normalised product, never on a
re-orthonormalised one.
"""

from __future__ import annotations

import hashlib
from typing import Any

import numpy as np
import scipy.linalg
import scipy.linalg.lapack

from geomfdi._validation import as_int, as_matrix, as_positive
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.tolerance import rank_decision

__all__ = [
    "Subspace",
    "image",
    "kernel",
    "preimage",
    "apply",
    "intersect_kernel",
    "preimage_in_kernel",
    "principal_angles",
    "pinv",
    "extend_basis",
    "split_kernel",
    "invariant_closure",
]

#: Largest dimension of a space built from a bare size (an ``n x n`` basis of 8 GiB).
MAX_SPACE_DIM = 32_768


def _space_dim(n: Any) -> int:
    """``n`` of ``Subspace.full(n)`` / ``zero(n)``: an integer in ``0 .. MAX_SPACE_DIM``."""
    return as_int(n, "n", minimum=0, maximum=MAX_SPACE_DIM)


_NORM_MEMO: dict[tuple[Any, ...], float] = {}
"""Spectral norms of the last large matrices seen, keyed by shape, type and a digest of
their entries (a design takes the norm of the same data in several steps)."""

_NORM_MEMO_MIN, _NORM_MEMO_SIZE = 4096, 64


def _norm2(M: np.ndarray) -> float:
    """Spectral norm ``‖M‖₂`` (largest singular value); 0 for an empty M.  Large matrices
    are remembered by content (:data:`_NORM_MEMO`): the same entries give the same norm
    without a second SVD."""
    M = np.asarray(M)
    if M.ndim == 2 and min(M.shape) == 1:  # a row or a column: its Euclidean norm
        return float(np.linalg.norm(M))
    if M.size < _NORM_MEMO_MIN:
        return float(np.linalg.norm(M, 2)) if M.size else 0.0
    C = np.ascontiguousarray(M)
    key = (C.shape, C.dtype.str, hashlib.sha1(C.data, usedforsecurity=False).digest())
    val = _NORM_MEMO.get(key)
    if val is None:
        val = float(np.linalg.norm(C, 2))
        if len(_NORM_MEMO) >= _NORM_MEMO_SIZE:
            try:
                del _NORM_MEMO[next(iter(_NORM_MEMO))]
            except (KeyError, RuntimeError, StopIteration):  # another thread got there
                pass
        _NORM_MEMO[key] = val
    return val


def _range_basis(M: np.ndarray, scale: float, what: str) -> np.ndarray:
    """Orthonormal basis of Im M; rank decided against ``rtol * scale``."""
    n = M.shape[0]
    if M.size == 0:
        return np.zeros((n, 0))
    U, s, _ = np.linalg.svd(M, full_matrices=False)
    r = rank_decision(s, scale, n, what=what).rank
    return U[:, :r]


def _null_basis(M: np.ndarray, scale: float, what: str) -> np.ndarray:
    """Orthonormal basis of Ker M (columns); rank decided against ``rtol * scale``."""
    rows, cols = M.shape
    if cols == 0:
        return np.zeros((0, 0))
    if rows == 0:
        return np.eye(cols)
    _, s, Vt = np.linalg.svd(M, full_matrices=True)
    r = rank_decision(s, scale, max(rows, cols), what=what).rank
    return Vt[r:].T.conj()


class Subspace:
    """A subspace of R^n, the span of the columns of ``M``.

    Parameters
    ----------
    M : array_like, (n, k)
        Spanning vectors as columns (``k`` may be 0: the zero subspace).  A 1-D array is
        read as one column.
    scale : float, optional
        Norm of the data that produced ``M`` for the rank decision (default ``||M||_2``).

    Attributes
    ----------
    basis : ndarray, (n, dim)
        Orthonormal basis.
    dim, n : int
        Dimension and ambient dimension.

    Notes
    -----
    Operators: ``S + T`` (sum), ``S & T`` (intersection), ``S == T`` (equality),
    ``S <= T`` (inclusion, same as ``T.contains(S)``).

    Examples
    --------
    >>> import geomfdi as gf
    >>> S = gf.Subspace([[1, 0], [0, 1], [0, 0]])
    >>> T = gf.Subspace([[0], [1], [1]])
    >>> (S + T).dim, (S & T).dim
    (3, 0)
    """

    def __init__(self, M: Any, *, scale: float | None = None) -> None:
        arr = as_matrix(M, "M", allow_empty=True, vector_as="column")
        if arr.shape[0] == 0:
            raise ShapeError("M: the ambient dimension must be at least 1", argument="M")
        sc = _norm2(arr) if scale is None else as_positive(scale, "scale", strict=False)
        self.basis = _range_basis(arr, sc, "Subspace")
        self.n = arr.shape[0]

    # ------------------------------------------------------------ builders
    @classmethod
    def from_orthonormal(cls, Q: np.ndarray) -> Subspace:
        """Wrap an (already orthonormal) basis without any rank decision.

        ``Q`` must be a finite real ``(n, k)`` matrix with ``k <= n`` (checked; its
        orthonormality is the caller's promise)."""
        ready = (
            isinstance(Q, np.ndarray)
            and Q.dtype == np.float64
            and Q.ndim == 2
            and bool(np.isfinite(Q).all())
        )
        arr = Q if ready else as_matrix(Q, "Q", allow_empty=True)
        if arr.shape[1] > arr.shape[0]:
            raise ShapeError(
                f"Q: an orthonormal basis has at most as many columns as rows, got shape "
                f"{arr.shape}",
                argument="Q",
            )
        obj = cls.__new__(cls)
        obj.basis = arr
        obj.n = arr.shape[0]
        return obj

    @classmethod
    def full(cls, n: int) -> Subspace:
        """The whole space R^n."""
        return cls.from_orthonormal(np.eye(_space_dim(n)))

    @classmethod
    def zero(cls, n: int) -> Subspace:
        """The zero subspace of R^n."""
        return cls.from_orthonormal(np.zeros((_space_dim(n), 0)))

    # --------------------------------------------------------------- sizes
    @property
    def dim(self) -> int:
        return self.basis.shape[1]

    @property
    def codim(self) -> int:
        return self.n - self.dim

    # ----------------------------------------------------------- operations
    def _check_same(self, other: Subspace, op: str) -> None:
        if not isinstance(other, Subspace):
            raise GeomFDIError(
                f"other: {op} expects a Subspace, got {type(other).__name__}", argument="other"
            )
        if other.n != self.n:
            raise ShapeError(
                f"other: {op} of subspaces of R^{self.n} and R^{other.n}", argument="other"
            )

    def __add__(self, other: Subspace) -> Subspace:
        """Sum ``S + T`` = Im [Q_S, Q_T]."""
        self._check_same(other, "sum")
        return Subspace(np.hstack([self.basis, other.basis]), scale=1.0)

    def __and__(self, other: Subspace) -> Subspace:
        """Intersection ``S & T`` = Q_S · null([Q_S, -Q_T])."""
        self._check_same(other, "intersection")
        if self.dim == 0 or other.dim == 0:
            return Subspace.zero(self.n)
        N = _null_basis(np.hstack([self.basis, -other.basis]), 1.0, "intersection")
        return Subspace(self.basis @ N[: self.dim], scale=1.0)

    def contains(self, other: Subspace | Any) -> bool:
        """Inclusion test ``other ⊆ self``: ``(I - Q Qᵀ) Q_other`` has rank 0."""
        if not isinstance(other, Subspace):
            other = _to_subspace(other, "other")
        self._check_same(other, "contains")
        if other.dim == 0:
            return True
        R = other.basis - self.basis @ (self.basis.T @ other.basis)
        s = np.linalg.svd(R, compute_uv=False)
        return rank_decision(s, 1.0, self.n, what="inclusion").rank == 0

    def __le__(self, other: Subspace) -> bool:
        return other.contains(self)

    def __ge__(self, other: Subspace) -> bool:
        return self.contains(other)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Subspace) or other.n != self.n:
            return NotImplemented if not isinstance(other, Subspace) else False
        return self.dim == other.dim and self.contains(other)

    __hash__ = None  # type: ignore[assignment]

    def complement(self) -> Subspace:
        """Orthogonal complement S^⊥."""
        if self.dim == 0:
            return Subspace.full(self.n)
        U, _, _ = np.linalg.svd(self.basis, full_matrices=True)
        return Subspace.from_orthonormal(U[:, self.dim :])

    def projector(self) -> np.ndarray:
        """Orthogonal projector ``Q Qᵀ`` onto S."""
        return self.basis @ self.basis.T

    def angles(self, other: Subspace) -> np.ndarray:
        """Principal angles (radians, descending) between S and ``other``."""
        return principal_angles(self, other)

    def __repr__(self) -> str:
        return f"Subspace(dim={self.dim}, n={self.n})"


# ------------------------------------------------------------ free functions
def _to_subspace(value: Any, name: str) -> Subspace:
    """``value`` if it is a Subspace, else the span of its columns (errors name ``name``)."""
    if isinstance(value, Subspace):
        return value
    arr = as_matrix(value, name, allow_empty=True, vector_as="column")
    if arr.shape[0] == 0:
        raise ShapeError(f"{name}: the ambient dimension must be at least 1", argument=name)
    return Subspace(arr)


def image(M: Any) -> Subspace:
    """``Im M``, the column space of ``M``."""
    return Subspace(M)


def kernel(M: Any) -> Subspace:
    """``Ker M`` = {x : M x = 0}; rank decided against ``rtol * ||M||``."""
    arr = as_matrix(M, "M", allow_empty=True, vector_as="row")
    if arr.shape[1] == 0:
        raise ShapeError("M: must have at least one column", argument="M")
    return Subspace.from_orthonormal(_null_basis(arr, _norm2(arr), "kernel"))


def apply(A: Any, S: Subspace) -> Subspace:
    """``A S`` = Im(A Q_S), rank decided on the un-normalised product against ``||A||``."""
    S = _to_subspace(S, "S")
    A = as_matrix(A, "A", cols=S.n, allow_empty=True)
    if A.shape[0] == 0:
        raise ShapeError(f"A: must have at least one row, got shape {A.shape}", argument="A")
    return Subspace(A @ S.basis, scale=_norm2(A))


def preimage(A: Any, S: Subspace) -> Subspace:
    """``A⁻¹ S`` = {x : A x ∈ S} = Ker(Q_⊥ᵀ A) (A need not be invertible)."""
    arr = as_matrix(A, "A", allow_empty=True)
    S = _to_subspace(S, "S")
    if arr.shape[1] == 0:
        raise ShapeError(f"A: must have at least one column, got shape {arr.shape}", argument="A")
    if arr.shape[0] != S.n:
        raise ShapeError(
            f"A: expected {S.n} rows to map into R^{S.n}, got shape {arr.shape}", argument="A"
        )
    Qp = S.complement().basis
    return Subspace.from_orthonormal(_null_basis(Qp.T @ arr, _norm2(arr), "preimage"))


def intersect_kernel(S: Subspace, C: np.ndarray) -> Subspace:
    """``S ∩ Ker C`` = Q_S · null(C Q_S), rank decided against ``||C||``."""
    if S.dim == 0:
        return S
    N = _null_basis(C @ S.basis, _norm2(C), "S ∩ Ker C")
    return Subspace.from_orthonormal(S.basis @ N) if N.shape[1] else Subspace.zero(S.n)


def preimage_in_kernel(A: np.ndarray, S: Subspace, C: np.ndarray) -> Subspace:
    """``A⁻¹(S) ∩ Ker C`` = null([Q_⊥ᵀ A / ||A||; C / ||C||]) ."""
    n = A.shape[0]
    Qp = S.complement().basis
    na, nc = _norm2(A) or 1.0, _norm2(C) or 1.0
    stacked = np.vstack([Qp.T @ A / na, C / nc])
    return Subspace.from_orthonormal(_null_basis(stacked, 1.0, "A⁻¹(S) ∩ Ker C").reshape(n, -1))


def extend_basis(
    B: np.ndarray, X: np.ndarray, scale: float, what: str, *, noise: float = 0.0
) -> np.ndarray:
    """Orthonormal columns completing ``Im B`` to ``Im B + Im X`` (B orthonormal).

    ``X`` is projected on ``(Im B)^⊥`` twice (classical Gram–Schmidt with
    reorthogonalisation); the rank of the projection is decided against
    ``max(rtol, noise) * scale`` (``scale``: the norm of the data that produced X, e.g.
    ``‖A‖`` for ``X = A Q``; ``noise``: see :func:`extraction_noise`), on the
    un-normalised product.  Cost ``O(n · (dim B + cols X) · cols X)``: an increasing
    sequence of subspaces is built without re-orthogonalising its basis.
    """
    return _extend(B, X, scale, what, noise)[0]


def _extend(
    B: np.ndarray, X: np.ndarray, scale: float, what: str, noise: float
) -> tuple[np.ndarray, float]:
    """:func:`extend_basis` and the relative noise of the new directions (below)."""
    n = X.shape[0]
    if X.shape[1] == 0:
        return np.zeros((n, 0)), 0.0
    P = X
    if B.shape[1]:
        P = P - B @ (B.T @ P)
        P = P - B @ (B.T @ P)
    if P.shape[1] == 1:  # one column: its SVD is its norm and direction
        p = P.ravel()
        nP = float(np.sqrt(p.dot(p)))  # numpy.linalg.norm's own formula, without its dispatch
        U, s = P / (nP if nP > 0 else 1.0), np.array([nP])
    else:
        U, s, _ = np.linalg.svd(P, full_matrices=False)
    r = rank_decision(s, scale, n, what=what, noise=noise).rank
    return U[:, :r], extraction_noise(s[r - 1] if r else 0.0, scale)


def extraction_noise(kept: float, scale: float) -> float:
    """Relative error of unit directions extracted from a projection of norm ``kept``.

    A projection ``P = (I − B Bᵀ) X`` carries an absolute error ``≈ 4 ε scale`` (two
    projections of data of size ``scale``); normalising a column of size ``kept`` turns it
    into a relative error ``4 ε scale / kept``.  Mapped by the next step (``Aᵀ u``) this
    error reappears at ``4 ε scale / kept`` relative to ``‖A‖``: a weakly reached direction
    (``kept ≪ scale``) raises the rounding floor of the step after it.  0 when nothing was
    kept.
    """
    if kept <= 0:
        return 0.0
    return 4.0 * _EPS64 * float(scale) / float(kept)


_EPS64 = float(np.finfo(float).eps)

_DGESDD = scipy.linalg.lapack.get_lapack_funcs("gesdd", dtype=np.float64)


def _svd_vt(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values and the full right factor ``Vᵀ`` of a small real matrix.

    LAPACK ``dgesdd`` called directly: the recursions of the invariant subspaces take one
    such SVD per step on a few columns, where the call overhead of ``numpy.linalg.svd``
    (``full_matrices=True``) is several times the arithmetic.
    """
    if X.size and X.dtype == np.float64 and np.isfinite(X).all():
        _, s, vt, info = _DGESDD(X, compute_uv=1, full_matrices=1)
        if info == 0:
            return s, vt
    _, s, vt = np.linalg.svd(X, full_matrices=True)
    return s, vt


def split_kernel(
    R: np.ndarray, M: np.ndarray, scale: float, what: str
) -> tuple[np.ndarray, np.ndarray]:
    """Split ``Im R`` (R orthonormal) into ``Im R ∩ Ker M`` and its complement in ``Im R``.

    With the SVD ``M R = U Σ Vᵀ`` (rank decided against ``rtol * scale``), returns
    ``(R V_0, R V_1)``: orthonormal bases of the null part and of the rest.  Used by the
    invariant-subspace recursions on the few directions that changed in a step.
    """
    n, k = R.shape
    if k == 0:
        return np.zeros((n, 0)), np.zeros((n, 0))
    if M.shape[0] == 0:
        return R, np.zeros((n, 0))
    s, Vt = _svd_vt(M @ R)
    r = rank_decision(s, scale, max(M.shape[0], k), what=what).rank
    return R @ Vt[r:].T, R @ Vt[:r].T


def principal_angles(S: Subspace, T: Subspace) -> np.ndarray:
    """Principal angles between two subspaces (``scipy.linalg.subspace_angles``).

    Returns ``min(dim S, dim T)`` angles in radians, in descending order (empty when
    either subspace is zero).  Array arguments are read as spanning columns.

    Examples
    --------
    >>> import geomfdi as gf
    >>> S = gf.Subspace([[1], [0]])
    >>> T = gf.Subspace([[1], [1]])
    >>> round(float(gf.principal_angles(S, T)[0]), 6)  # pi / 4
    0.785398
    """
    S = _to_subspace(S, "S")
    T = _to_subspace(T, "T")
    if S.n != T.n:
        raise ShapeError(f"T: subspace of R^{T.n}, expected R^{S.n} (as S)", argument="T")
    if S.dim == 0 or T.dim == 0:
        return np.zeros(0)
    return scipy.linalg.subspace_angles(S.basis, T.basis)


def pinv(M: np.ndarray, scale: float | None = None, *, what: str = "pseudo-inverse") -> np.ndarray:
    """Moore–Penrose pseudo-inverse with the rank decided by the tolerance policy.

    Singular values at or below ``rtol * scale`` (default ``scale = ||M||``) are treated
    as zero, as everywhere else in geomfdi.
    """
    rows, cols = M.shape
    if M.size == 0:
        return np.zeros((cols, rows))
    U, s, Vt = np.linalg.svd(M, full_matrices=False)
    r = rank_decision(s, _norm2(M) if scale is None else scale, max(rows, cols), what=what).rank
    return (Vt[:r].T / s[:r]) @ U[:, :r].T


def invariant_closure(M: np.ndarray, Q0: np.ndarray, *, what: str) -> np.ndarray:
    """Orthonormal basis of the smallest ``M``-invariant subspace containing ``Im Q0``.

    The Krylov recursion ``V_0 = Im Q0``, ``V_{k+1} = Im Q0 + M V_k`` carried out on the
    new directions only: since ``V_k ⊇ V_{k−1}``, ``V_{k+1} = V_k + M N_k`` with ``N_k`` the
    directions added at step ``k``.  ``M N_k`` is projected off ``V_k`` (two Gram–Schmidt
    passes) and the rank of the remainder is decided against 1 (the caller scales ``M`` to
    unit norm, so the decision is on the un-normalised product).  Each step costs
    ``O(n k b)`` for ``b`` new directions, the whole recursion ``O(n³)``.

    ``Q0`` must have orthonormal columns.
    """
    V = Q0
    new = Q0
    n = M.shape[0]
    while new.shape[1] and V.shape[1] < n:
        W = M @ new
        for _ in range(2):
            W = W - V @ (V.T @ W)
        new = _range_basis(W, 1.0, what)
        if new.shape[1]:
            new = new - V @ (V.T @ new)  # keep the union orthonormal to rounding
            new, _ = np.linalg.qr(new)
            V = np.hstack([V, new])
    return V
