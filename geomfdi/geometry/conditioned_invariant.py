"""W*: the minimal (C, A)-conditioned invariant containing L (Hou, Wen & Chen 2011, Algorithm 1).

A subspace W is (C, A)-*conditioned invariant* when ``A (W ∩ Ker C) ⊆ W``; equivalently
there is an output injection D (a *friend* of W) with ``(A + D C) W ⊆ W``.  The
intersection of all conditioned invariants containing L is again one, W*, computed by
(Hou, Wen & Chen 2011, eq. 14)::

    Z_0 = L,    Z_k = L + A (Z_{k-1} ∩ Ker C),    stop when dim Z_k stops growing.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import as_bool, as_matrix, as_real_array
from geomfdi.errors import ShapeError
from geomfdi.geometry.subspace import (
    Subspace,
    _norm2,
    extend_basis,
    intersect_kernel,
    pinv,
    split_kernel,
)
from geomfdi.tolerance import (
    GAP_WARN,
    CloseRankWarning,
    RankDecision,
    decision_stage,
    rank_decision,
    record_decisions,
)

__all__ = [
    "InvariantSubspace",
    "min_conditioned_invariant",
    "is_conditioned_invariant",
    "friend",
    "friends",
    "FriendSet",
]


class InvariantSubspace(Subspace):
    """A subspace computed by an iteration, with the record of how it was reached.

    Attributes
    ----------
    history : list of int
        ``dim Z_k`` for k = 0, 1, ... (the last two entries are equal: convergence).
    steps : int
        Number of iterations until the dimension stopped changing.
    min_gap : float
        Smallest singular-value gap among the rank decisions behind the result
        (``inf`` if none was taken).  Below :data:`geomfdi.tolerance.GAP_WARN` the
        result may depend on the tolerance and a :class:`CloseRankWarning` was issued.
    decisions : list of RankDecision
        Every rank decision taken.
    """

    history: list[int]
    decisions: list[RankDecision]

    @classmethod
    def _wrap(
        cls, S: Subspace, history: list[int], decisions: list[RankDecision], what: str
    ) -> InvariantSubspace:
        obj = cls.from_orthonormal(S.basis)
        obj.history = history
        obj.decisions = list(decisions)
        if obj.close:
            warnings.warn(
                f"{what}: a rank decision was close (smallest singular-value gap "
                f"{obj.min_gap:.3g} < {GAP_WARN:g}); dimensions {history} may change with "
                "the tolerance",
                CloseRankWarning,
                stacklevel=3,
            )
        return obj

    @property
    def steps(self) -> int:
        return len(self.history) - 1

    @property
    def min_gap(self) -> float:
        return min((d.gap for d in self.decisions), default=float("inf"))

    @property
    def close(self) -> bool:
        return self.min_gap < GAP_WARN

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(dim={self.dim}, n={self.n}, history={self.history}, "
            f"min_gap={self.min_gap:.3g})"
        )


def _is_exact(*args: Any) -> bool:
    """True when an argument is a sympy matrix (sympy is imported only to check one)."""
    if not any(type(a).__module__.split(".")[0] == "sympy" for a in args):
        return False
    import sympy

    return any(isinstance(a, sympy.MatrixBase) for a in args)


def _check_AC(A: Any, C: Any) -> tuple[np.ndarray, np.ndarray]:
    A = as_matrix(A, "A", square=True)
    C = as_matrix(C, "C", cols=A.shape[0], vector_as="row")
    return A, C


def _as_subspace(L: Any, n: int, name: str = "L") -> Subspace:
    if isinstance(L, Subspace):
        if L.n != n:
            raise ShapeError(f"{name}: subspace of R^{L.n}, expected R^{n}", argument=name)
        return L
    arr = as_matrix(L, name, rows=n, allow_empty=True, vector_as="column")
    return Subspace(arr)


@limit_blas_threads
def min_conditioned_invariant(A: Any, C: Any, L: Any, *, exact: bool = False) -> InvariantSubspace:
    """W* = inf W(A, C, L): the minimal (C, A)-conditioned invariant containing Im L.

    Parameters
    ----------
    A : array_like, (n, n)
    C : array_like, (q, n)
    L : array_like (n, k) or Subspace
        Fault signature(s); ``k = 0`` is allowed (then W* = 0).
    exact : bool
        Run in exact rational arithmetic (sympy); also chosen automatically when any
        argument is a sympy Matrix.  See :func:`geomfdi.exact.min_conditioned_invariant`.

    Returns
    -------
    InvariantSubspace
        Orthonormal basis of W*, with ``history`` (dimension per step) and ``min_gap``.

    Notes
    -----
    Hou, Wen & Chen 2011, Algorithm 1 (eq. 14)::

        Z_0 = L,   Z_k = L + A (Z_{k-1} ∩ Ker C)

    The sequence is non-decreasing and converges in at most n steps.  Since
    ``Z_{k-1} ∩ Ker C`` grows with k, ``Z_k = Z_{k-1} + A K_k`` where ``K_k`` spans the
    directions of ``Z_{k-1} ∩ Ker C`` new at step k: the basis of Z is kept as
    ``(Z ∩ Ker C) ⊕ R`` and only R (at most ``rank C`` directions plus the new ones) is
    split against Ker C (``R null(C R)``, rank decided against ``||C||``); only the new
    directions are mapped by A and appended after two projections on ``Z^⊥``, the rank
    decided on the un-normalised product against ``||A||``.  ``||A||`` is computed once;
    the whole recursion costs ``O(n² dim W*)`` flops (no re-orthogonalisation of the
    basis, no n × n factorisation).

    References
    ----------
    Hou, Wen, Chen (2011), §3.2; Basile & Marro (1992), *Controlled and Conditioned
    Invariants in Linear System Theory*, Algorithm 4.1-2.

    Examples
    --------
    >>> import geomfdi as gf
    >>> A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
    >>> C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]
    >>> W = gf.min_conditioned_invariant(A, C, [[1, 1], [0, 0], [3, 2]])
    >>> W.dim, W.history
    (2, [2, 2])
    """
    if as_bool(exact, "exact") or _is_exact(A, C, L):
        from geomfdi.geometry import exact as _exact

        return _exact.min_conditioned_invariant(A, C, L)  # type: ignore[return-value]
    A, C = _check_AC(A, C)
    n = A.shape[0]
    nA, nC = _norm2(A) or 1.0, _norm2(C) or 1.0
    with record_decisions() as rec, decision_stage("W*"):
        Z = _as_subspace(L, n).basis  # orthonormal basis of Z_k, extended step by step
        R = Z  # the part of Z not yet split against Ker C (Z = (Z ∩ Ker C) ⊕ R)
        history = [Z.shape[1]]
        for _ in range(n + 1):
            K_new, R = split_kernel(R, C, nC, "Z ∩ Ker C")
            new = extend_basis(Z, A @ K_new, nA, "L + A (Z ∩ Ker C)")
            Z, R = np.hstack([Z, new]), np.hstack([R, new])
            history.append(Z.shape[1])
            if not new.shape[1]:
                break
    return InvariantSubspace._wrap(
        Subspace.from_orthonormal(Z), history, rec, "min_conditioned_invariant"
    )


def is_conditioned_invariant(A: Any, C: Any, W: Any) -> bool:
    """True when ``A (W ∩ Ker C) ⊆ W`` (Definition 2 of Hou, Wen & Chen 2011)."""
    A, C = _check_AC(A, C)
    W = _as_subspace(W, A.shape[0], "W")
    return _maps_into(A, intersect_kernel(W, C).basis, W.basis, "A (W ∩ Ker C) ⊆ W")


def _maps_into(M: np.ndarray, X: np.ndarray, Y: np.ndarray, what: str) -> bool:
    """``M Im X ⊆ Im Y`` (X, Y orthonormal), decided on the un-normalised residual
    ``(I − Y Yᵀ) M X`` against ``rtol ||M||`` (not on a re-orthonormalised image, whose
    rounding-level directions would be blown up to unit size)."""
    if X.shape[1] == 0:
        return True
    R = M @ X
    R = R - Y @ (Y.T @ R)
    s = np.linalg.svd(R, compute_uv=False)
    return rank_decision(s, _norm2(M), M.shape[0], what=what).rank == 0


def friend(A: Any, C: Any, S: Any) -> np.ndarray:
    """One output injection D0 with ``(A + D0 C) S ⊆ S`` (Hou, Wen & Chen 2011, §3.4).

    ``D0 = −Q Qᵀ A S (C S)⁺`` with Q an orthonormal basis of S^⊥; it exists iff S is
    (C, A)-conditioned invariant (then ``Qᵀ (A + D0 C) S = Qᵀ A S (I − (CS)⁺ CS) = 0``).

    Raises
    ------
    GeomFDIError
        If S is not conditioned invariant (no friend exists).
    """
    from geomfdi.errors import DesignError

    A, C = _check_AC(A, C)
    S = _as_subspace(S, A.shape[0], "S")
    if not is_conditioned_invariant(A, C, S):
        raise DesignError(
            "S: not (C, A)-conditioned invariant, so no output injection D with "
            "(A + D C) S ⊆ S exists",
            argument="S",
        )
    Q = S.complement().basis
    Sb = S.basis
    CS = C @ Sb
    return -Q @ (Q.T @ A @ Sb @ pinv(CS, float(np.linalg.norm(C, 2)), what="(C S)⁺"))


def _as_block(value: Any, name: str, shape: tuple[int, int]) -> np.ndarray:
    """A real array of ``shape`` (any array with as many entries is reshaped)."""
    arr = as_real_array(value, name)
    if arr.size != shape[0] * shape[1]:
        raise ShapeError(f"{name}: expected shape {shape}, got shape {arr.shape}", argument=name)
    return arr.reshape(shape)


@dataclass(frozen=True)
class FriendSet:
    """All output injections D with ``(A + D C) S ⊆ S``: an affine set.

    ``D = D0 + S X + Q Y Zᵀ`` with X (dim S x q) and Y (codim S x (q − rank CS))
    arbitrary, Q a basis of S^⊥ and Z an orthonormal basis of (Im CS)^⊥ in R^q.

    Attributes
    ----------
    D0 : ndarray (n, q)
        Particular friend (:func:`friend`).
    S, Q, Z : ndarray
        Bases used in the parametrisation.
    """

    D0: np.ndarray
    S: np.ndarray
    Q: np.ndarray
    Z: np.ndarray

    @property
    def dim(self) -> int:
        """Dimension of the affine set (number of free parameters)."""
        return self.S.shape[1] * self.D0.shape[1] + self.Q.shape[1] * self.Z.shape[1]

    def member(self, X: Any, Y: Any) -> np.ndarray:
        """The friend ``D0 + S X + Q Y Zᵀ``."""
        X = _as_block(X, "X", (self.S.shape[1], self.D0.shape[1]))
        Y = _as_block(Y, "Y", (self.Q.shape[1], self.Z.shape[1]))
        return self.D0 + self.S @ X + self.Q @ Y @ self.Z.T

    def random(self, rng: np.random.Generator | int | None = None) -> np.ndarray:
        """A random member (standard normal parameters)."""
        rng = np.random.default_rng(rng)
        X = rng.standard_normal((self.S.shape[1], self.D0.shape[1]))
        Y = rng.standard_normal((self.Q.shape[1], self.Z.shape[1]))
        return self.member(X, Y)

    def contains(self, A: Any, C: Any, D: Any) -> bool:
        """True when ``(A + D C) S ⊆ S``."""
        A, C = _check_AC(A, C)
        D = as_matrix(D, "D", rows=A.shape[0], cols=C.shape[0])
        return _maps_into(A + D @ C, self.S, self.S, "(A + D C) S ⊆ S")


def friends(A: Any, C: Any, S: Any) -> FriendSet:
    """The set of friends of a conditioned invariant S (see :class:`FriendSet`)."""
    A, C = _check_AC(A, C)
    S = _as_subspace(S, A.shape[0], "S")
    D0 = friend(A, C, S)
    Q = S.complement().basis
    CS = (
        Subspace(C @ S.basis, scale=float(np.linalg.norm(C, 2)))
        if S.dim
        else Subspace.zero(C.shape[0])
    )
    Z = CS.complement().basis
    return FriendSet(D0=D0, S=S.basis, Q=Q, Z=Z)
