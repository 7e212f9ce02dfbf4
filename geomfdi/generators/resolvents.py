"""Resolvents at many points shared by the checks of a generator on its plant.

Triangular solves ``(sI − T)⁻¹ X`` and ``L (sI − T)⁻¹`` on a complex Schur form at many
points (blocked back substitution), the complex Schur form of a real matrix, the
resolvents of an output-normal generator (:mod:`geomfdi.generators.output_normal`)
remembered by content, so that the rows of a bank sharing their evaluation points and
generator poles compute them once, and small helpers of the transfer measures of
:mod:`geomfdi.generators.gains` (squared moduli, spectral norms of stacked small
matrices, eigenvalues of block triangular matrices).  See the user guide, *Theory:
verification* (``docs/theory/verification.md``).
"""

from __future__ import annotations

import hashlib
from typing import Any

import numpy as np
import scipy.linalg

from geomfdi.generators.output_normal import column_resolvent, rows_resolvent

__all__ = ["complex_schur"]


def _tri_solve(T: np.ndarray, X: np.ndarray) -> np.ndarray:
    """``T⁻¹ X`` for upper-triangular T (LAPACK LU for small T: far cheaper per call than a
    threaded triangular BLAS solve at this size)."""
    if T.shape[0] <= 48:
        return np.linalg.solve(T, X)
    return scipy.linalg.solve_triangular(T, X, check_finite=False)


FEW_POINTS = 16
"""Point count up to which :func:`_tri_solve_many` solves point by point."""


def _tri_solve_many(T: np.ndarray, pts: np.ndarray, X: np.ndarray) -> np.ndarray:
    """``(s_p I − T)⁻¹ X`` for upper-triangular T at every point: shape ``(P, n, c)``.

    Small T: one batched LU solve; at most ``FEW_POINTS`` points: one triangular solve
    each.  Otherwise blocked back substitution over all points
    and columns at once: the coupling of a block of rows to the rows already solved is
    one matrix product (``T[a:b, b:] @ Y[b:]``), the rows inside the block are solved one
    by one on the small block (the same ``O(P n² c)`` work as P triangular solves, at
    matrix-product speed and without a call per point); points are taken in groups so
    that the work array stays below ~32 MB.
    """
    n, c, P = T.shape[0], X.shape[1], pts.size
    if n == 0 or P == 0:
        return np.zeros((P, n, c), dtype=complex)
    if n <= 48:
        M = pts[:, None, None] * np.eye(n) - T[None, :, :]
        return np.linalg.solve(M, np.broadcast_to(X, (P, n, c)).astype(complex))
    out = np.empty((P, n, c), dtype=complex)
    if P <= FEW_POINTS:  # a LAPACK triangular solve per point: no row loop to amortise
        idx = np.arange(n)
        M = -np.asarray(T, dtype=complex)  # one work matrix: only its diagonal changes
        d = M[idx, idx].copy()
        for p, sp in enumerate(pts):
            M[idx, idx] = d + sp
            out[p] = scipy.linalg.solve_triangular(M, X, check_finite=False)
        return out
    step = max(1, int(2_000_000 // max(n * c, 1)))
    d = np.diag(T)
    T = np.asarray(T, dtype=complex)
    nb = 32
    for a0 in range(0, P, step):
        s = pts[a0 : a0 + step]
        m = s.size
        W = 1.0 / (s[None, :] - d[:, None])  # 1/(s − t_ii), (n, m c)
        W = np.repeat(W, c, axis=1) if c > 1 else W
        Y = np.empty((n, m * c), dtype=complex)
        for b in range(n, 0, -nb):
            a = max(0, b - nb)
            R = np.broadcast_to(X[a:b, None, :], (b - a, m, c)).reshape(b - a, m * c)
            R = R + T[a:b, b:] @ Y[b:] if b < n else R.astype(complex)
            Y[b - 1] = R[b - 1 - a] * W[b - 1]
            for i in range(b - 2, a - 1, -1):  # Y[i] = (R[i − a] + T[i, i+1:b] Y[i+1:b]) W[i]
                acc = T[i, i + 1 : b] @ Y[i + 1 : b]
                acc += R[i - a]
                np.multiply(acc, W[i], out=Y[i])
        out[a0 : a0 + step] = Y.reshape(n, m, c).transpose(1, 0, 2)
    return out


def _tri_solve_rows_many(T: np.ndarray, pts: np.ndarray, L: np.ndarray) -> np.ndarray:
    """``L (s_p I − T)⁻¹`` for upper-triangular T at every point: shape ``(P, r, n)``.

    Transposed and index-reversed, ``J Tᵀ J`` is upper triangular again: one call of
    :func:`_tri_solve_many` with the r rows of L as its columns (``O(P n² r)``: a scalar
    residual's transfer costs one column, however many inputs it reads).
    """
    Tr = np.ascontiguousarray(T.T[::-1, ::-1])
    X = _tri_solve_many(Tr, pts, np.ascontiguousarray(L.T[::-1, :]))  # (P, n, r)
    return X[:, ::-1, :].transpose(0, 2, 1)


def _real_to_complex_schur(T: np.ndarray, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A real Schur pair ``A = Z T Zᵀ`` (T quasi upper triangular) to the complex one.

    Each 2 × 2 diagonal block is made triangular by one complex Givens rotation built from
    its eigenvalue (closed form), applied to the rows and columns of T it touches and to
    the columns of Z: the method of :func:`scipy.linalg.rsf2csf`, ``O(n)`` per block.
    """
    n = T.shape[0]
    T = T.astype(complex)
    Z = Z.astype(complex)
    eps = np.finfo(float).eps
    for m in range(n - 1, 0, -1):
        sub = T[m, m - 1]
        if abs(sub) > eps * (abs(T[m - 1, m - 1]) + abs(T[m, m])):
            a, b, d = T[m - 1, m - 1], T[m - 1, m], T[m, m]
            half = 0.5 * (a - d)
            root = np.sqrt(complex(half * half + b * sub))
            if root.imag < 0:
                root = -root
            mu = half + root  # eigenvalue minus T[m, m] (the one with Im > 0 first)
            r = np.hypot(abs(mu), abs(sub))
            c, sn = mu / r, sub / r
            G = np.array([[np.conj(c), sn], [-sn, c]])
            T[m - 1 : m + 1, m - 1 :] = G @ T[m - 1 : m + 1, m - 1 :]
            Gh = G.conj().T
            T[: m + 1, m - 1 : m + 1] = T[: m + 1, m - 1 : m + 1] @ Gh
            Z[:, m - 1 : m + 1] = Z[:, m - 1 : m + 1] @ Gh
        T[m, m - 1] = 0.0
    return T, Z


def complex_schur(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Complex Schur form ``A = U T Uᴴ`` (T upper triangular) of a real matrix.

    Through the real Schur form and the rotation of its 2 × 2 blocks of complex pairs
    (:func:`_real_to_complex_schur`): the same backward-stable factorisation as the
    complex QR algorithm at a fraction of its cost.  A quasi upper-triangular A (1 × 1
    and 2 × 2 diagonal blocks, e.g. a generator realised in an output-normal basis) is
    already in real Schur form: only its 2 × 2 blocks are rotated, in ``O(n²)``.
    """
    A = np.asarray(A, dtype=float)
    n = A.shape[0]
    if n == 0:
        return np.zeros((0, 0), complex), np.zeros((0, 0), complex)
    sub = np.diag(A, -1) != 0
    if np.any(np.tril(A, -2)) or np.any(sub[1:] & sub[:-1]):
        T, Z = scipy.linalg.schur(A, output="real")
    else:
        T, Z = A, np.eye(n)
    return _real_to_complex_schur(T, Z)


def _digest(*arrays: np.ndarray) -> bytes:
    """Content key of a few arrays (shape, type and a hash of the entries)."""
    h = hashlib.sha1(usedforsecurity=False)  # a content key (SHA-1: hardware-fast)
    for a in arrays:
        c = np.ascontiguousarray(a)
        h.update(repr((c.shape, c.dtype.str)).encode())
        h.update(c.data)
    return h.digest()


MEMO_BYTES = 1 << 25
"""Bytes of results a :class:`_Memo` keeps at most (32 MiB)."""


class _Memo:
    """The last results of a pure function of arrays, keyed by their content: rows of a
    bank that share their evaluation points and generator poles (a sensor bank whose
    quotients are the plant in rotated coordinates) compute the shared resolvents once,
    bit for bit the same values.

    At most ``size`` results and ``nbytes`` bytes are kept (the most recent result
    always): the rows of a bank alternate between a few pole sets, each with several
    point sets, so the budget is in bytes rather than in a few entries."""

    def __init__(self, size: int, nbytes: int = MEMO_BYTES) -> None:
        self.size, self.nbytes = size, nbytes
        self.data: dict[bytes, np.ndarray] = {}

    def get(self, key: bytes, make: Any) -> np.ndarray:
        hit = self.data.pop(key, None)
        if hit is None:
            hit = make()
        self.data[key] = hit  # most recent last
        while len(self.data) > 1 and (
            len(self.data) > self.size
            or sum(v.nbytes for v in list(self.data.values())) > self.nbytes
        ):
            try:
                del self.data[next(iter(self.data))]
            except (KeyError, RuntimeError, StopIteration):  # another thread got there
                break
        return hit


def _on_key(F: np.ndarray, h: np.ndarray, starts: np.ndarray) -> bytes:
    """Content key of an output-normal ``(F, h)`` (its structure verified exactly by
    :func:`~geomfdi.generators.output_normal.output_normal_blocks`): F is fixed by h, its
    block layout and its three central diagonals (every entry above the blocks is
    ``−h_i h_j``), ``O(k)`` data to hash instead of ``O(k²)``."""
    return _digest(h, starts, np.diagonal(F), np.diagonal(F, 1), np.diagonal(F, -1))


def _on_rows(
    F: np.ndarray, h: np.ndarray, starts: np.ndarray, pts: np.ndarray, fkey: bytes, memo: _Memo
) -> np.ndarray:
    """:func:`~geomfdi.generators.output_normal.rows_resolvent`, remembered by content in
    ``memo`` (``fkey``: :func:`_on_key` of ``(F, h)``)."""
    key = b"rows" + fkey + _digest(pts)
    return memo.get(key, lambda: rows_resolvent(F, h, starts, pts))


def _on_column(
    F: np.ndarray,
    h: np.ndarray,
    starts: np.ndarray,
    pts: np.ndarray,
    w: np.ndarray,
    fkey: bytes,
    memo: _Memo,
) -> np.ndarray:
    """:func:`~geomfdi.generators.output_normal.column_resolvent`, remembered by content
    in ``memo`` (``fkey``: :func:`_on_key` of ``(F, h)``)."""
    key = b"col" + fkey + _digest(pts, w)
    return memo.get(key, lambda: column_resolvent(F, h, starts, pts, w))


def _abs2_sum(X: np.ndarray) -> np.ndarray:
    """``Σ_i |X[p, i, j]|²`` of a complex ``(P, n, c)`` array, shape ``(P, c)``, on its real
    and imaginary parts (no complex modulus)."""
    Xf = np.ascontiguousarray(X).view(np.float64)
    s = np.einsum("pij,pij->pj", Xf, Xf)
    return s[:, 0::2] + s[:, 1::2]


def _spectral_norms(X: np.ndarray) -> np.ndarray:
    """``‖X[p]‖₂`` of a stack of ``(r, w)`` complex matrices (a channel of w columns): the
    square root of the largest eigenvalue of the ``w × w`` Gram matrices (the largest
    singular value is perfectly conditioned in them)."""
    G = np.conj(np.swapaxes(X, 1, 2)) @ X
    lam = np.linalg.eigvalsh(G)[:, -1]
    return np.sqrt(np.maximum(lam, 0.0))


def _block_eigenvalues(F: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Eigenvalues of a block upper-triangular F with 1 × 1 and 2 × 2 diagonal blocks
    starting at ``starts`` (closed form per block: ``tr/2 ± √((tr/2)² − det)``)."""
    k = F.shape[0]
    ends = np.append(starts[1:], k)
    one, two = starts[ends - starts == 1], starts[ends - starts == 2]
    a, b, c, d = F[two, two], F[two, two + 1], F[two + 1, two], F[two + 1, two + 1]
    half = 0.5 * (a - d)
    root = np.sqrt((half * half + b * c).astype(complex))
    mid = 0.5 * (a + d)
    return np.concatenate([F[one, one].astype(complex), mid + root, mid - root])
