"""Pole placement by state feedback on the ordered real Schur form (no :mod:`scipy.signal`).

:func:`place_poles` returns ``K`` with ``eig(A − B K)`` the requested spectrum.  It is the
Schur method of Varga (IEEE TAC 26(2), 1981), one or two eigenvalues at a time, with
orthogonal transformations only:

1. ``A = Q T Qᵀ``, real Schur form; ``j`` eigenvalues are placed, in the leading ``j × j``
   block of ``T``, the others (still to move) below.
2. The trailing 1 × 1 or 2 × 2 block ``T₂₂`` of ``T`` (rows/columns ``k``) is moved by a
   feedback acting on its coordinates only, ``K ← K + F Q[:, k]ᵀ``: then
   ``T ← T − (Qᵀ B) F E_kᵀ`` changes the last columns of ``T`` only, so ``T`` stays
   quasi-triangular and ``T₂₂ ← T₂₂ − B₂ F`` (``B₂``: the last rows of ``Qᵀ B``).  The
   bottom rows of ``Qᵀ B`` are exactly the input directions seen by the trailing
   eigenvalues (their left invariant subspace is ``Im E_k``): ``B₂ = 0`` means an
   uncontrollable eigenvalue.

   * 1 × 1 block ``t``, pole ``p``: ``F = b₂ᵀ (t − p) / ‖b₂‖²`` (the minimum-norm gain).
   * 2 × 2 block, poles ``p₁, p₂`` (a complex pair, or two reals): with
     ``B₂ = U Σ Vᵀ``, either rank 2, ``F = V Σ⁻¹ Uᵀ (T₂₂ − X)`` for a target block ``X``
     in Schur form with the requested eigenvalues (its off-diagonal kept from ``T₂₂``),
     or the single-input solution along ``u₁``: ``F = v₁ g / σ₁`` with ``g`` from the
     linear conditions ``g u₁ = tr T₂₂ − (p₁ + p₂)`` and
     ``g adj(T₂₂) u₁ = det T₂₂ − p₁ p₂`` (trace and determinant of ``T₂₂ − u₁ g``).  Of
     the two the gain of smaller norm is taken.  The new block is brought back to real
     Schur form by one plane rotation (triangular for real poles, equal diagonal for a
     complex pair).
3. The placed block is moved up to position ``j`` by LAPACK's ``dtrexc`` (orthogonal
   swaps of adjacent blocks, which keep every eigenvalue), and step 2 repeats until every
   eigenvalue is placed.  A complex pair is placed on a 2 × 2 block of ``T`` with complex
   eigenvalues when one is left (moved to the bottom first), else on two real ones.

The gain is unique for a single input; for several inputs it is the Schur method's
choice (minimum norm per step), not the one of :func:`scipy.signal.place_poles`.  A pole
repeated more often than there are inputs gives a Jordan block (its computed eigenvalues
then scatter by ``ε^(1/multiplicity)``); callers check the computed spectrum.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg
from scipy.linalg.lapack import dtrexc

__all__ = ["place_poles"]

_EPS = np.finfo(float).eps


def _split_targets(poles: Any, n: int) -> tuple[list[float], list[complex]]:
    """Real poles and one member (positive imaginary part) of each complex pair."""
    arr = np.atleast_1d(np.asarray(poles, dtype=complex))
    if arr.ndim != 1 or arr.size != n:
        raise ValueError(f"expected {n} poles, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("the poles must be finite")
    is_real = np.abs(arr.imag) <= 1e-14 * np.maximum(1.0, np.abs(arr))
    upper = [complex(p) for p in arr[~is_real] if p.imag > 0]
    lower = np.sort_complex(arr[~is_real & (arr.imag < 0)].conj())
    if len(upper) != lower.size or not np.allclose(
        np.sort_complex(np.array(upper, dtype=complex)), lower, rtol=1e-12, atol=0
    ):
        raise ValueError("complex poles must come in conjugate pairs")
    return [float(p.real) for p in arr[is_real]], upper


def _blocks(T: np.ndarray, start: int) -> list[tuple[int, int]]:
    """``(first row, size)`` of the diagonal blocks of quasi-triangular ``T`` from ``start``."""
    n = T.shape[0]
    out, i = [], start
    while i < n:
        size = 2 if i + 1 < n and T[i + 1, i] != 0 else 1
        out.append((i, size))
        i += size
    return out


def _move(T: np.ndarray, Q: np.ndarray, first: int, last: int) -> tuple[np.ndarray, np.ndarray]:
    """The block at row ``first`` moved to the place of the block at row ``last`` (0-based),
    by ``dtrexc`` (the blocks in between move by one place)."""
    if first == last:
        return T, Q
    T, Q, info = dtrexc(T, Q, first + 1, last + 1)
    if info != 0:
        raise np.linalg.LinAlgError("the Schur form could not be reordered (ill-conditioned)")
    return T, Q


def _rotate(T: np.ndarray, Q: np.ndarray, c: float, s: float) -> None:
    """Plane rotation ``R = [[c, −s], [s, c]]`` of the last two coordinates, in place."""
    R = np.array([[c, -s], [s, c]])
    T[-2:, :] = R.T @ T[-2:, :]
    T[:, -2:] = T[:, -2:] @ R
    Q[:, -2:] = Q[:, -2:] @ R


def _target_block(S: np.ndarray, p1: complex, p2: complex) -> np.ndarray:
    """A 2 × 2 real Schur block with eigenvalues ``p1, p2`` close to ``S`` in shape."""
    if p1.imag == 0:  # two real poles: upper triangular, S's coupling kept
        return np.array([[p1.real, S[0, 1]], [0.0, p2.real]])
    sigma, omega = p1.real, abs(p1.imag)
    beta = S[0, 1] if abs(S[0, 1]) >= omega else omega
    return np.array([[sigma, beta], [-(omega**2) / beta, sigma]])


def _gain_2x2(S: np.ndarray, B2: np.ndarray, p1: complex, p2: complex, tol: float) -> np.ndarray:
    """``F`` (m × 2) with ``eig(S − B2 F) = {p1, p2}`` (module Notes, step 2)."""
    U, sv, Vt = np.linalg.svd(B2, full_matrices=False)
    if sv[0] <= tol:
        raise np.linalg.LinAlgError("uncontrollable eigenvalues")
    candidates = []
    if sv.size > 1 and sv[1] > tol:  # rank 2: any target block
        X = _target_block(S, p1, p2)
        candidates.append(Vt[:2].T @ ((U.T @ (S - X)) / sv[:2, None]))
    u = U[:, 0]
    adj = np.array([[S[1, 1], -S[0, 1]], [-S[1, 0], S[0, 0]]])
    W = np.vstack([u, adj @ u])
    rhs = np.array([np.trace(S) - (p1 + p2).real, np.linalg.det(S) - (p1 * p2).real])
    if abs(np.linalg.det(W)) > 1e-14 * max(np.linalg.norm(W) ** 2, 1e-300):
        g = np.linalg.solve(W, rhs)
        candidates.append(np.outer(Vt[0], g) / sv[0])
    if not candidates:
        raise np.linalg.LinAlgError("uncontrollable eigenvalues")
    return min(candidates, key=np.linalg.norm)


def _standardize(T: np.ndarray, Q: np.ndarray, p1: complex) -> None:
    """The trailing 2 × 2 block of ``T`` in real Schur form, by one rotation (in place)."""
    X = T[-2:, -2:]
    if p1.imag != 0:  # equal diagonal, off-diagonals of opposite signs
        two_theta = np.arctan2(X[0, 0] - X[1, 1], -(X[0, 1] + X[1, 0]))
        _rotate(T, Q, np.cos(two_theta / 2), np.sin(two_theta / 2))
        X = T[-2:, -2:]
        X[0, 0] = X[1, 1] = (X[0, 0] + X[1, 1]) / 2
        if not X[0, 1] * X[1, 0] < 0:
            raise np.linalg.LinAlgError("a complex pair could not be placed (ill-conditioned)")
        return
    lam = np.linalg.eigvals(X)
    mu = float(lam[np.argmin(np.abs(lam - p1))].real)
    Y = X - mu * np.eye(2)
    row = Y[np.argmax(np.linalg.norm(Y, axis=1))]
    v = np.array([-row[1], row[0]])  # a null vector of Y: an eigenvector for mu
    nv = np.hypot(v[0], v[1])
    c, s = (1.0, 0.0) if nv == 0 else (v[0] / nv, v[1] / nv)
    _rotate(T, Q, c, s)
    T[-1, -2] = 0.0


def place_poles(A: Any, B: Any, poles: Any) -> np.ndarray:
    """State feedback ``K`` with ``eig(A − B K) = poles`` by the Schur method (module Notes).

    Parameters
    ----------
    A : array_like, (n, n), real
    B : array_like, (n, m), real
    poles : array_like, (n,)
        Closed under complex conjugation; repeated poles are allowed.

    Returns
    -------
    ndarray, (m, n)
        The real gain.

    Raises
    ------
    ValueError
        Wrong number of poles, or not closed under conjugation.
    numpy.linalg.LinAlgError
        An eigenvalue of ``A`` is uncontrollable from ``B``, or a reordering failed.

    Examples
    --------
    >>> import numpy as np
    >>> A = np.array([[0.0, 1.0], [2.0, -1.0]]); B = np.array([[0.0], [1.0]])
    >>> K = place_poles(A, B, [-1 + 1j, -1 - 1j])
    >>> np.round(np.sort_complex(np.linalg.eigvals(A - B @ K)), 12).tolist()
    [(-1-1j), (-1+1j)]
    """
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    n = A.shape[0]
    m = B.shape[1]
    reals, pairs = _split_targets(poles, n)
    K = np.zeros((m, n))
    if n == 0:
        return K
    T, Q = scipy.linalg.schur(A, output="real")
    tol = 100 * n * _EPS * max(np.linalg.norm(B, 2), 1e-300)
    j = 0
    while j < n:
        blocks = _blocks(T, j)
        if pairs:
            cplx = [b for b in blocks if b[1] == 2]
            if cplx:  # a complex pair on a complex block, moved to the bottom
                T, Q = _move(T, Q, cplx[-1][0], n - 1)
            p = pairs.pop(0)
            targets = (p, p.conjugate())
        elif blocks[-1][1] == 1:
            targets = (complex(reals.pop(0)),)
        else:
            targets = (complex(reals.pop(0)), complex(reals.pop(0)))
        size = len(targets)
        Bt = Q[:, n - size :].T @ B
        if size == 1:
            b = Bt[0]
            nb2 = float(b @ b)
            if np.sqrt(nb2) <= tol:
                raise np.linalg.LinAlgError(
                    f"the eigenvalue {T[-1, -1]:.6g} is uncontrollable (unobservable)"
                )
            F = (b * ((T[-1, -1] - targets[0].real) / nb2))[:, None]
        else:
            F = _gain_2x2(T[-2:, -2:], Bt, targets[0], targets[1], tol)
        T[:, n - size :] -= (Q.T @ B) @ F
        K += F @ Q[:, n - size :].T
        if size == 2:
            _standardize(T, Q, targets[0])
            if targets[0].imag == 0:  # two 1 × 1 blocks, moved up one after the other
                T, Q = _move(T, Q, n - 2, j)
                T, Q = _move(T, Q, n - 1, j + 1)
            else:
                T, Q = _move(T, Q, n - 2, j)
        else:
            T, Q = _move(T, Q, n - 1, j)
        j += size
    return K
