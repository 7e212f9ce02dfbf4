"""Orthogonal observer staircase (observer block-Hessenberg form) of a pair (A, C).

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``).

An orthogonal ``Z`` brings ``(A, C)`` to the form (the dual of the controllability
staircase of ``(Aᵀ, Cᵀ)``, Varga 2017, Section 10.4)::

    Zᵀ A Z = [[A11 A12  0  …   0   0 ],      C Z = [C1 0 … 0 | 0]
              [A21 A22 A23 …   0   0 ],
              [ …               …     ],
              [Ap1 Ap2  …     App  0 ],
              [ *   *   …      *   Ao]]

with ``C1`` (``q × ρ_1``) and every super-diagonal block ``A_{j, j+1}``
(``ρ_j × ρ_{j+1}``) of full column rank, ``ρ_1 ≥ ρ_2 ≥ … ≥ ρ_p``; ``Ao`` is the
unobservable part.  Each block size is one rank decision on a small block (an SVD of
the current block, through :func:`geomfdi.tolerance.rank_decision`); no power of A is
formed.  ``Σ ρ_j`` is the dimension of the observable subspace; the
observability indices are ``κ_i = #{j : ρ_j ≥ i}`` (``i = 1 … ρ_1``), and the
degree-ν parity space ``{v : [v_0 … v_ν] [C; CA; …; CA^ν] = 0}`` has dimension

    (ν + 1) q − Σ_{j ≤ ν + 1} ρ_j .
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from geomfdi.geometry.subspace import _norm2
from geomfdi.tolerance import rank_decision

__all__ = ["Staircase", "observer_staircase"]


@dataclass
class Staircase:
    """Result of :func:`observer_staircase`.

    Attributes
    ----------
    A, C : ndarray
        ``Zᵀ A Z`` and ``C Z`` in staircase form.
    Z : ndarray
        The orthogonal transformation.
    blocks : list of int
        ``ρ_1 ≥ ρ_2 ≥ …``: the staircase block sizes.
    gaps : list of float
        The singular-value gap of each rank decision.
    """

    A: np.ndarray
    C: np.ndarray
    Z: np.ndarray
    blocks: list[int]
    gaps: list[float] = field(default_factory=list)

    @property
    def n_observable(self) -> int:
        """Dimension of the observable subspace, ``Σ ρ_j``."""
        return int(sum(self.blocks))

    @property
    def indices(self) -> list[int]:
        """Observability indices ``κ_1 ≤ … ≤ κ_{ρ_1}`` (``κ_i = #{j : ρ_j ≥ ρ_1 + 1 − i}``)."""
        if not self.blocks:
            return []
        top = self.blocks[0]
        return sorted(sum(1 for r in self.blocks if r >= i) for i in range(1, top + 1))

    def parity_dim(self, nu: int) -> int:
        """Dimension of the degree-ν parity space: ``(ν + 1) q − Σ_{j ≤ ν+1} ρ_j``."""
        q = self.C.shape[0]
        return (nu + 1) * q - int(sum(self.blocks[: nu + 1]))

    @property
    def max_index(self) -> int:
        """Largest observability index (``0`` without observable states)."""
        return len(self.blocks)


def observer_staircase(A: np.ndarray, C: np.ndarray) -> Staircase:
    """Orthogonal observer staircase form of ``(A, C)`` (module Notes).

    Parameters
    ----------
    A : ndarray, shape (n, n)
    C : ndarray, shape (q, n)

    Returns
    -------
    Staircase
        Every block size is decided by :func:`geomfdi.tolerance.rank_decision` on the
        singular values of one block, relative to ``max(‖A‖, ‖C‖)`` (the data's scale);
        the gaps are recorded.

    Notes
    -----
    Step j takes the SVD ``X_j = U Σ Vᵀ`` of ``X_1 = Cᵀ`` and, afterwards, of
    ``X_j = A[b_{j−1}, rest]ᵀ`` (the coupling of the previous block to the coordinates not
    yet in the staircase), with ``U`` acting on those remaining coordinates.  The first
    ``ρ_j`` columns of ``U`` (``ρ_j`` the decided rank) become block j; ``A``, ``C`` and
    ``Z`` are updated by ``U`` on the remaining coordinates.  The loop stops at a block of
    rank 0 (the rest is unobservable) or when every coordinate is in the staircase.
    """
    A = np.array(A, dtype=float, copy=True)
    C = np.array(C, dtype=float, copy=True)
    n = A.shape[0]
    Z = np.eye(n)
    blocks: list[int] = []
    gaps: list[float] = []
    scale = max(_norm2(A), _norm2(C), 1e-300)
    start = 0
    X = C.T  # rows: remaining coordinates start:n
    while start < n and X.size:
        U, s, _ = np.linalg.svd(X, full_matrices=True)
        dec = rank_decision(s, scale, n, what="observer staircase", warn=False)
        r = dec.rank
        if r == 0:
            break
        A[start:, :] = U.T @ A[start:, :]
        A[:, start:] = A[:, start:] @ U
        C[:, start:] = C[:, start:] @ U
        Z[:, start:] = Z[:, start:] @ U
        blocks.append(r)
        gaps.append(float(dec.gap))
        X = A[start : start + r, start + r :].T  # the new block's coupling to the rest
        start += r
    return Staircase(A, C, Z, blocks, gaps)
