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

import itertools
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from geomfdi.geometry.subspace import _norm2
from geomfdi.tolerance import RankDecision, _decide, _record, rank_decision

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
        if nu + 1 < 0:
            return (nu + 1) * q - int(sum(self.blocks[: nu + 1]))
        sums = self.__dict__.get("_sums")
        if sums is None or sums[0] != self.blocks:  # Σ_{j ≤ i} ρ_j, once per staircase
            sums = (list(self.blocks), [0, *itertools.accumulate(int(r) for r in self.blocks)])
            self.__dict__["_sums"] = sums
        acc = sums[1]
        return (nu + 1) * q - acc[min(nu + 1, len(acc) - 1)]

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
    ``Z`` are updated on the remaining coordinates by an orthogonal completion of those
    columns (Householder reflectors, applied without forming the ``n × n`` factor).  The
    loop stops at a block of rank 0 (the rest is unobservable) or when every coordinate is
    in the staircase.  A single output is reduced by the blocked Hessenberg reduction
    (:func:`_single_output`).
    """
    A = np.array(A, dtype=float, copy=True)
    C = np.array(C, dtype=float, copy=True)
    n = A.shape[0]
    Z = np.eye(n)
    blocks: list[int] = []
    gaps: list[float] = []
    scale = max(_norm2(A), _norm2(C), 1e-300)
    if C.shape[0] == 1 and n > 2:
        return _single_output(A, C, scale)
    start = 0
    X = C.T  # rows: remaining coordinates start:n
    while start < n and X.size:
        if X.shape[1] == 1:  # one column: its SVD is its norm and direction
            nx = float(np.linalg.norm(X))
            s, U1 = np.array([nx]), X / (nx if nx > 0 else 1.0)
        else:
            U1, s, _ = np.linalg.svd(X, full_matrices=False)
        dec = rank_decision(s, scale, n, what="observer staircase", warn=False)
        r = dec.rank
        if r == 0:
            break
        _rotate(A, C, Z, start, U1[:, :r])
        blocks.append(r)
        gaps.append(float(dec.gap))
        X = A[start : start + r, start + r :].T  # the new block's coupling to the rest
        start += r
    return Staircase(A, C, Z, blocks, gaps)


def _single_output(A: np.ndarray, C: np.ndarray, scale: float) -> Staircase:
    """The staircase of a single-output pair: every block has size 1 (or 0), so the
    staircase is the Hessenberg reduction of ``Aᵀ`` in coordinates whose first axis is
    ``Cᵀ``: one reflector ``H`` with ``H e_1 = ± Cᵀ/‖C‖``, then the blocked Householder
    reduction (LAPACK ``gehrd``) of ``H Aᵀ H``, which keeps ``e_1``.  The block sizes are
    the same rank decisions as the general loop's, on ``‖C‖`` and on the successive
    couplings (the sub-diagonal of the Hessenberg form), up to the first decided zero
    (the rest is unobservable)."""
    n = A.shape[0]
    Z = np.eye(n)
    blocks: list[int] = []
    gaps: list[float] = []
    nc = float(np.linalg.norm(C))
    dec = rank_decision(np.array([nc]), scale, n, what="observer staircase", warn=False)
    if dec.rank == 0:
        return Staircase(A, C, Z, blocks, gaps)
    At = np.array(A.T, copy=True)
    Cz = np.array(C, copy=True)
    _rotate(At.T, Cz, Z, 0, (C.T / nc))  # At.T is a view of At: A rotated in place
    Hs, Q = scipy.linalg.hessenberg(At, calc_q=True)
    Z = Z @ Q
    A = np.ascontiguousarray(Hs.T)
    C = Cz @ Q
    blocks.append(1)
    gaps.append(float(dec.gap))
    # the couplings' decisions, one value each (rank_decision's threshold and gap on
    # plain floats, recorded together)
    tol, sc, decs = dec.tol, float(scale) if scale > 0 else 1.0, []
    for v in np.abs(np.diag(Hs, -1)).tolist():
        rank, gap = _decide([v], tol, sc)
        decs.append(RankDecision(rank, tol, gap, "observer staircase", dec.where))
        if rank == 0:
            break
        blocks.append(1)
        gaps.append(gap)
    _record(decs, warn=False)
    return Staircase(A, C, Z, blocks, gaps)


def _rotate(A: np.ndarray, C: np.ndarray, Z: np.ndarray, start: int, U1: np.ndarray) -> None:
    """Change the coordinates ``start:`` by an orthogonal ``U`` whose first columns are
    ``U1`` (orthonormal) up to sign, in place on A (both sides), C and Z.

    ``U = H_1 … H_r`` is the product of the Householder reflectors of the QR
    factorisation of ``U1`` (``U e_j = ± U1 e_j``; any orthonormal completion serves the
    staircase), applied one reflector at a time without forming U: ``O(r n²)`` per
    block instead of the ``O(n³)`` of a dense ``n × n`` factor.
    """
    W = np.array(U1, dtype=float, copy=True)
    for j in range(W.shape[1]):
        x = W[j:, j]
        nx = float(np.linalg.norm(x))
        if nx == 0.0:
            continue
        v = x.copy()
        v[0] += nx if x[0] >= 0 else -nx  # v = x − α e_1, α = −sign(x_0) ‖x‖
        bv = (2.0 / float(v @ v)) * v
        o = start + j
        A[o:, :] -= np.outer(bv, v @ A[o:, :])
        A[:, o:] -= np.outer(A[:, o:] @ v, bv)
        if C.shape[0]:
            C[:, o:] -= np.outer(C[:, o:] @ v, bv)
        Z[:, o:] -= np.outer(Z[:, o:] @ v, bv)
        W[j:, j:] -= np.outer(bv, v @ W[j:, j:])
