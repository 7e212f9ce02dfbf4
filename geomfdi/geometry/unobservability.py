"""S*: the minimal unobservability subspace containing L (Hou, Wen & Chen 2011, Algorithm 2).

An *unobservability subspace* (UOS) of (C, A) is ``S = <Ker HC | A + DC>``, the largest
``(A + DC)``-invariant subspace in ``Ker HC`` for some output injection D and
measurement mixing H (Hou, Wen & Chen 2011, Definition 3).  The minimal one containing L is
(Hou, Wen & Chen 2011, eq. 15, with the typo "S* = Z_{k+1}" corrected to the limit)::

    Z_0 = R^n,    Z_k = W* + (A⁻¹ Z_{k-1}) ∩ Ker C,    stop when dim Z_k stops shrinking

with W* from :func:`geomfdi.min_conditioned_invariant`.  The residual generator of a
fault j decoupled from L exists iff ``Im L_j ⊄ S*`` (``docs/theory/geometric-approach.md``).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import as_bool, as_matrix
from geomfdi.errors import ShapeError
from geomfdi.geometry.conditioned_invariant import (
    InvariantSubspace,
    _as_subspace,
    _check_AC,
    _is_exact,
    friend,
    is_conditioned_invariant,
    min_conditioned_invariant,
)
from geomfdi.geometry.subspace import (
    _DGESDD,
    Subspace,
    _extend,
    _norm2,
    _svd_vt,
    extraction_noise,
    invariant_closure,
    kernel,
    split_kernel,
)
from geomfdi.tolerance import (
    CloseRankWarning,
    RankDecision,
    _decide,
    _record,
    _stage,
    decision_stage,
    get_rtol,
    record_decisions,
)

__all__ = [
    "min_unobservability_subspace",
    "measurement_map",
    "max_invariant_in",
    "unobservable_subspace",
    "is_unobservability_subspace",
]


@limit_blas_threads
def min_unobservability_subspace(
    A: Any, C: Any, L: Any, *, exact: bool = False
) -> InvariantSubspace:
    """S*: the minimal (C, A)-unobservability subspace containing Im L.

    Parameters
    ----------
    A : array_like, (n, n)
    C : array_like, (q, n)
    L : array_like (n, k) or Subspace
        Signatures to be made unobservable (faults to decouple, disturbances).
    exact : bool
        Exact rational arithmetic (sympy); automatic when any argument is a sympy
        Matrix.  See :func:`geomfdi.exact.min_unobservability_subspace`.

    Returns
    -------
    InvariantSubspace
        Orthonormal basis of S*; ``history`` holds ``dim Z_k``; ``S.W`` is W*.

    Notes
    -----
    Hou, Wen & Chen 2011, Algorithm 2 (eq. 15)::

        Z_0 = R^n,   Z_k = W* + (A⁻¹ Z_{k-1}) ∩ Ker C

    non-increasing, at most n steps.  The paper states ``S* = Z_{k+1}``; the limit
    ``Z_k = Z_{k+1}`` is meant.

    It is run on the orthogonal complements, which only grow, since
    ``(A⁻¹(Z) ∩ Ker C)^⊥ = Aᵀ Z^⊥ + Im Cᵀ`` and ``(W + V)^⊥ = W^⊥ ∩ V^⊥``::

        Y_0 = 0,   V_k = Im Cᵀ + Aᵀ Y_{k-1},   Y_k = W*^⊥ ∩ V_k,   Z_k = Y_k^⊥

    Only images are formed (no preimage of a nearly singular A).  V and Y increase, so
    their orthonormal bases are extended, never recomputed: a step maps only the new
    directions of Y by Aᵀ, projects them twice on ``V^⊥`` (rank decided on the
    un-normalised product against ``||A||``; ``Im Cᵀ`` against ``||C||``), and splits the
    part R of V outside ``W*^⊥`` (at most ``dim W*`` directions) plus the new ones against
    ``W*^⊥``.  A direction extracted from a strong cancellation (a weakly reached one, of
    norm ``σ ≪ ||A||``) carries a relative error ``4 ε ||A|| / σ``, which ``Aᵀ`` maps into
    a spurious new direction of that size: the next step's rank decision uses
    ``max(rtol, 4 ε ||A|| / σ)`` (:func:`geomfdi.geometry.subspace.extraction_noise`), so
    rounding cannot open a block that no output reaches.  With ``||A||`` computed once
    and one complement at the end (a complete QR of Y's basis) the cost is
    ``O(n³)`` flops whatever the number of steps (the recursion on Z itself costs
    ``O(n³)`` per step).

    References
    ----------
    Hou, Wen, Chen (2011), §3.2; Massoumnia (1986), "A geometric approach to the
    synthesis of failure detection filters", IEEE TAC 31(9).

    Examples
    --------
    >>> import geomfdi as gf
    >>> A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
    >>> C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]
    >>> S = gf.min_unobservability_subspace(A, C, [[1, 1], [0, 0], [3, 2]])
    >>> S.dim, S.history
    (2, [3, 2, 2])
    """
    if as_bool(exact, "exact") or _is_exact(A, C, L):
        from geomfdi.geometry import exact as _exact

        return _exact.min_unobservability_subspace(A, C, L)  # type: ignore[return-value]
    A, C = _check_AC(A, C)
    n = A.shape[0]
    with warnings.catch_warnings():  # W*'s decisions are reported once, with S*'s below
        warnings.simplefilter("ignore", CloseRankWarning)
        W = min_conditioned_invariant(A, C, L)
    nA, nC = _norm2(A) or 1.0, _norm2(C) or 1.0
    Wb = W.basis
    with record_decisions() as rec, decision_stage("S*"):
        # dual recursion on Y_k = Z_k^⊥ (increasing):  Y_k = W*^⊥ ∩ V_k,
        # V_k = Im Cᵀ + Aᵀ Y_{k-1};  V's basis is kept as Y ⊕ R (dim R ≤ dim W*)
        # the bases only grow: kept in preallocated arrays (no copy of V, Y per step)
        Vb, Yb = np.empty((n, n)), np.empty((n, n))
        nv = ny = 0
        R = np.zeros((n, 0))
        WbT, AT = Wb.T, A.T
        axes = _axes(Wb)
        if axes is not None and bool(np.all(axes[1] > 0)):
            axes = (axes[0], None)
        steps = _Steps(Wb, AT, nA, axes)
        new, noise = _extend(Vb[:, :0], C.T, nC, "Im Cᵀ (Ker C)", 0.0)
        history = [n]
        X = None  # [R, new] in a work array of the steps (after one of them)
        for _ in range(n + 1):
            if new.shape[1] == 1 and R.shape[1] and Wb.shape[1]:
                # one new direction (the common step): the operations of split_kernel,
                # _project_out and _extend written out, in the same order (same bits)
                X = np.concatenate((R, new), axis=1) if X is None else X
                ny, nv, R, new, X, noise = steps.step(X, Vb, Yb, nv, ny, noise, history)
                if new is None:
                    break
                continue
            steps.flush()
            X = None
            Y_new, R = split_kernel(np.concatenate((R, new), axis=1), WbT, 1.0, _SPLIT)
            Y_new = _project_out(Y_new, Wb)
            dv, dy = new.shape[1], Y_new.shape[1]
            Vb[:, nv : nv + dv], Yb[:, ny : ny + dy] = new, Y_new
            nv, ny = nv + dv, ny + dy
            history.append(n - ny)
            if not dy:
                break
            # directions extracted from a strong cancellation carry more rounding than ε:
            # the next step's floor rises accordingly (extraction_noise)
            new, noise = _extend(Vb[:, :nv], AT @ Y_new, nA, _STEP, noise)
        steps.flush()
        Y = Yb[:, :ny].copy()
    # S* = Y^⊥: the last columns of the complete Householder QR of Y (Y orthonormal: its
    # complement needs no SVD, whose full left factor costs several times the QR's)
    if ny and ny + Wb.shape[1] == n:  # Y = W*^⊥ (Y ⊥ W* by construction): S* = W*
        Z = Subspace.from_orthonormal(Wb)
    elif ny:
        Qf = np.linalg.qr(Y, mode="complete")[0]
        Z = Subspace.from_orthonormal(np.ascontiguousarray(Qf[:, ny:]))
    else:
        Z = Subspace.full(n)
    S = InvariantSubspace._wrap(Z, history, [*W.decisions, *rec], "min_unobservability_subspace")
    S.W = W
    return S


_SPLIT = "V ∩ W*^⊥"
_STEP = "Im Cᵀ + Aᵀ Z^⊥ (A⁻¹(Z) ∩ Ker C)"


class _Steps:
    """The steps of :func:`min_unobservability_subspace` with one new direction of V,
    written out: :func:`geomfdi.geometry.subspace.split_kernel` of ``[R, new]`` against
    ``W*ᵀ``, :func:`_project_out` and :func:`geomfdi.geometry.subspace.extend_basis` by
    ``Aᵀ`` of the new direction of Y, with the same operations on the same operands in the
    same order (hence the same rank decisions and bases bit for bit), without the per-call
    checks and dispatch of the general functions.

    ``[R, new]`` of the next step is written into one of two work arrays of its width
    (no concatenation), the in-place updates give the bits of the out-of-place ones, and
    the rank decisions (:func:`geomfdi.tolerance.rank_decision`'s threshold and gap) are
    recorded in order by :meth:`flush`, before any decision of the general path.
    ``axes``: W*'s basis is made of signed coordinate axes (:func:`_axes`; signs None: all
    +1), so that ``W*ᵀ X`` is a selection of rows and the projection off W* zeroes them,
    exactly as the products do.
    """

    def __init__(
        self,
        Wb: np.ndarray,
        AT: np.ndarray,
        nA: float,
        axes: tuple[np.ndarray, np.ndarray | None] | None,
    ) -> None:
        self.Wb, self.WbT, self.AT, self.nA = Wb, Wb.T, AT, float(nA)
        self.rows: slice | np.ndarray | None = None
        self.sgn: np.ndarray | None = None
        if axes is not None:
            rows, signs = axes
            lo = int(rows[0])
            run = bool(np.array_equal(rows, np.arange(lo, lo + rows.size)))
            self.rows = slice(lo, lo + rows.size) if run else rows  # a view, not a gather
            self.sgn = None if signs is None else signs[:, None]
        self.where = _stage()
        self.rtol = get_rtol(AT.shape[0])  # of the Aᵀ steps; the splits' below
        self.split_tol: dict[int, float] = {}
        self.pending: list[tuple[int, float, float, str]] = []
        self.work: dict[int, list[np.ndarray]] = {}

    def flush(self) -> None:
        """Record the pending decisions (:func:`geomfdi.tolerance.record_decisions`)."""
        if self.pending:
            w = self.where
            _record([RankDecision(r, t, g, what, w) for r, t, g, what in self.pending])
            self.pending.clear()

    def _next(self, k: int, X: np.ndarray) -> np.ndarray:
        """A work array ``(n, k)`` that is not X."""
        pair = self.work.get(k)
        if pair is None:
            pair = self.work[k] = [np.empty((X.shape[0], k)) for _ in range(2)]
        return pair[1] if pair[0] is X else pair[0]

    def step(
        self,
        X: np.ndarray,
        Vb: np.ndarray,
        Yb: np.ndarray,
        nv: int,
        ny: int,
        noise: float,
        history: list[int],
    ) -> tuple[int, int, np.ndarray, np.ndarray | None, np.ndarray | None, float]:
        """One step from ``X = [R, new]`` (C-contiguous): ``(ny, nv, R, new, X, noise)``,
        ``new`` None when Y stopped growing, ``X`` the next ``[R, new]`` when ``new`` is
        one direction (else None)."""
        n, k = X.shape
        rows, pending = self.rows, self.pending
        # + 0.0: a product has no negative zero (its sums start at +0)
        if rows is None:
            MX = self.WbT @ X
        elif self.sgn is None:
            MX = X[rows] + 0.0
        else:
            MX = X[rows] * self.sgn
            MX += 0.0
        _, s, Vt, info = _DGESDD(MX, compute_uv=1, full_matrices=1)  # as _svd_vt, its input
        sv = s.tolist()
        if info or not math.isfinite(sum(sv)):  # being finite by construction
            s, Vt = _svd_vt(MX)
            sv = s.tolist()
        tol = self.split_tol.get(k)
        if tol is None:  # rank_decision(s, 1.0, max(dim W*, k))'s threshold
            tol = self.split_tol[k] = get_rtol(max(MX.shape[0], k)) * 1.0
        r, gap = _decide(sv, tol, 1.0)
        pending.append((r, tol, gap, _SPLIT))
        Vb[:, nv] = X[:, k - 1]
        nv += 1
        if r != k - 1:  # Y gains none or several directions (the general path's QR)
            Y_new, R = X @ Vt[r:].T, X @ Vt[:r].T
            self.flush()
            Y_new = _project_out(Y_new, self.Wb)
            dy = Y_new.shape[1]
            Yb[:, ny : ny + dy] = Y_new
            ny += dy
            history.append(n - ny)
            if not dy:
                return ny, nv, R, None, None, noise
            new, noise = _extend(Vb[:, :nv], self.AT @ Y_new, self.nA, _STEP, noise)
            return ny, nv, R, new, None, noise
        Xn = self._next(k, X)
        Y_new = X @ Vt[r:].T
        np.matmul(X, Vt[:r].T, out=Xn[:, :r])
        if rows is None:
            Wb, WbT = self.Wb, self.WbT
            Y_new -= Wb @ (WbT @ Y_new)
            Y_new -= Wb @ (WbT @ Y_new)
        else:
            Y_new[rows] = 0.0
        y = Y_new.ravel()
        Y_new /= max(math.sqrt(y.dot(y)), 1e-300)  # the same correctly rounded root
        Yb[:, ny] = y
        ny += 1
        history.append(n - ny)
        B = Vb[:, :nv]
        BT = B.T
        P = self.AT @ Y_new
        P -= B @ (BT @ P)
        P -= B @ (BT @ P)
        p = P.ravel()
        nP = math.sqrt(p.dot(p))
        nA = self.nA
        tol = max(self.rtol, noise) * nA  # rank_decision([nP], nA, n, noise=noise)'s
        r2, gap = _decide([nP], tol, nA)
        pending.append((r2, tol, gap, _STEP))
        if r2:
            np.divide(P, nP if nP > 0 else 1.0, out=Xn[:, r:])
            return ny, nv, Xn[:, :r], Xn[:, r:], Xn, extraction_noise(nP, nA)
        return ny, nv, Xn[:, :r], Xn[:, r:r], None, 0.0


def _axes(W: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``(rows, signs)`` when every column of the orthonormal W is a signed coordinate
    axis (``W[:, j] = ± e_{rows[j]}``, e.g. W* of decoupled feedthrough made states),
    else None."""
    if not W.shape[1]:
        return None
    rows = np.argmax(np.abs(W), axis=0)
    cols = np.arange(W.shape[1])
    signs = W[rows, cols]
    if not np.all(np.abs(signs) == 1.0) or np.count_nonzero(W) != W.shape[1]:
        return None
    return rows, signs.copy()


def _project_out(Y: np.ndarray, W: np.ndarray) -> np.ndarray:
    """``Y`` (orthonormal, in ``W^⊥`` up to the dropped singular values of ``Wᵀ Y``) made
    exactly orthogonal to ``W`` and re-orthonormalised (twice-projected Gram–Schmidt)."""
    if not Y.shape[1] or not W.shape[1]:
        return Y
    Y = Y - W @ (W.T @ Y)
    Y = Y - W @ (W.T @ Y)
    if Y.shape[1] == 1:
        y = Y.ravel()
        return Y / max(float(np.sqrt(y.dot(y))), 1e-300)  # numpy.linalg.norm's formula
    q, _ = np.linalg.qr(Y)
    return q


def measurement_map(C: Any, S: Any) -> np.ndarray:
    """H with ``Ker(H C) = Ker C + S``: rows = orthonormal basis of ``Im C ⊖ C S``.

    (Hou, Wen & Chen 2011, step 3.4 (2)①).  May have zero rows (then no residual exists).
    """
    C = as_matrix(C, "C", vector_as="row")
    S = _as_subspace(S, C.shape[1], "S")
    scale = _norm2(C)
    ImC = Subspace(C, scale=scale)
    CS = Subspace(C @ S.basis, scale=scale) if S.dim else Subspace.zero(C.shape[0])
    H = (ImC & CS.complement()).basis.T
    return H


def max_invariant_in(A: Any, K: Subspace, *, scale: float | None = None) -> Subspace:
    """Largest A-invariant subspace contained in K, ``<K | A> = ∩_k A⁻ᵏ K``.

    Computed by the dual recursion (Basile–Marro ``mainco``)::

        V_0 = K^⊥,   V_{k+1} = K^⊥ + Aᵀ V_k,   <K | A> = V_∞^⊥

    since ``(A⁻¹ V)^⊥ = Aᵀ V^⊥``.  Only images are formed, each step on the directions
    the previous one added (:func:`geomfdi.geometry.subspace.invariant_closure`,
    ``O(n³)`` in all), and each sum is rank-decided on the un-normalised product
    ``Aᵀ Q / ||A||`` projected off the current subspace.  The primal
    recursion ``V_{k+1} = K ∩ A⁻¹ V_k`` amplifies rounding by ``1 / σ_min`` of the
    restricted map and loses invariant directions when A is nearly singular.

    ``scale`` (default ``||A||``) is the norm of the data that produced A: Aᵀ is divided
    by it before the rank decisions, so that an A that is itself rounding of a larger
    computation (e.g. a quotient map ``Qᵀ F Q`` of an F with ``||F||`` = 5 that vanishes in
    exact arithmetic) is not blown up to unit size.
    """
    A = as_matrix(A, "A", square=True)
    n = A.shape[0]
    if not isinstance(K, Subspace) or K.n != n:
        raise ShapeError(f"K: expected a Subspace of R^{n}", argument="K")
    if K.dim in (0, n):
        return K
    Kp = K.complement().basis
    At = A.T / ((_norm2(A) if scale is None else max(float(scale), _norm2(A))) or 1.0)
    V = Subspace.from_orthonormal(invariant_closure(At, Kp, what="invariant subspace"))
    return V.complement()


def unobservable_subspace(A: Any, C: Any) -> Subspace:
    """The unobservable subspace of (C, A): the largest A-invariant subspace in Ker C."""
    A, C = _check_AC(A, C)
    return max_invariant_in(A, kernel(C))


def is_unobservability_subspace(A: Any, C: Any, S: Any) -> bool:
    """True when S is a (C, A)-unobservability subspace.

    Checked from Definition 3 of Hou, Wen & Chen 2011 directly: S must be conditioned invariant;
    with a friend D0 and H from :func:`measurement_map`, S must equal the largest
    ``(A + D0 C)``-invariant subspace in ``Ker(H C)``.

    Notes
    -----
    S is ``(A + D0 C)``-invariant and contained in ``Ker(H C) = S + Ker C``, hence in the
    largest such invariant subspace; equality holds iff the quotient pair
    ``(Qᵀ (A + D0 C) Q, H C Q)`` (Q an orthonormal basis of S^⊥) is observable, which is
    decided on dimensions (rank decisions with a large gap), not by comparing two
    computed bases whose rounding grows with the conditioning of ``A + D0 C``.  By
    duality with controllability subspaces (Wonham 1985, Thm 5.5) the test does not
    depend on the friend chosen.

    The check takes its own rank decisions on ``A + D0 C``: when that matrix has
    eigenvalues spread over many decades (e.g. columns of A scaled by 1e-6), the largest
    invariant subspace can be over-estimated and a true unobservability subspace
    reported as not one.  :func:`min_unobservability_subspace` is not affected.
    """
    A, C = _check_AC(A, C)
    S = _as_subspace(S, A.shape[0], "S")
    if not is_conditioned_invariant(A, C, S):
        return False
    D0 = friend(A, C, S)
    H = measurement_map(C, S)
    n = A.shape[0]
    if S.dim == n:
        return True
    if not H.shape[0]:  # Ker HC = R^n: only R^n itself is the largest invariant in it
        return False
    # the largest invariant subspace in Ker HC, modulo S, is the unobservable subspace of
    # the quotient (Qᵀ (A + D0 C) Q, H C Q), Q a basis of S^⊥: S is the largest iff the
    # quotient is observable (S is factored out exactly instead of having to survive
    # the rounding of the recursion)
    Q = S.complement().basis
    Ab = Q.T @ (A + D0 @ C) @ Q
    Cb = H @ C @ Q
    return max_invariant_in(Ab, kernel(Cb), scale=_norm2(A + D0 @ C)).dim == 0
