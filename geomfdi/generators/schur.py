"""Complex Schur form of a real matrix through its real Schur form.

``A = U T Uᴴ`` with T upper triangular: the real Schur form ``A = Z T_r Zᵀ`` (quasi upper
triangular, 1 × 1 and 2 × 2 diagonal blocks) with each 2 × 2 block of a complex pair
triangularised by one complex Givens rotation (the method of :func:`scipy.linalg.rsf2csf`).
Used by the transfer evaluations of :mod:`geomfdi.generators.gains` (every resolvent a
triangular solve).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["complex_schur"]


def _real_to_complex_schur(T: np.ndarray, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A real Schur pair ``A = Z T Zᵀ`` (T quasi upper triangular) to the complex one.

    Each 2 × 2 diagonal block is made triangular by one complex Givens rotation built from
    its eigenvalue (closed form), applied to the rows and columns of T it touches and to
    the columns of Z: the method of :func:`scipy.linalg.rsf2csf`.  A rotation acts on its
    own block's two rows and columns only and is built from that block alone, so the
    rotations of all blocks are formed and applied at once (``O(n)`` per block).
    """
    n = T.shape[0]
    T = T.astype(complex)
    Z = Z.astype(complex)
    if n < 2:
        return T, Z
    eps = np.finfo(float).eps
    dg = np.diag(T)
    sub = np.diag(T, -1)
    m = 1 + np.flatnonzero(np.abs(sub) > eps * (np.abs(dg[:-1]) + np.abs(dg[1:])))
    if m.size and np.any(np.diff(m) == 1):  # not quasi-triangular: block by block
        return _real_to_complex_schur_loop(T, Z)
    if m.size:
        i, k = m - 1, m
        a, b, d, sb = T[i, i], T[i, k], T[k, k], T[k, i]
        half = 0.5 * (a - d)
        root = np.sqrt(half * half + b * sb)
        root = np.where(root.imag < 0, -root, root)
        mu = half + root  # eigenvalue minus T[m, m] (the one with Im > 0 first)
        r = np.hypot(np.abs(mu), np.abs(sb))
        c, sn = mu / r, sb / r
        Ti, Tk = T[i].copy(), T[k].copy()  # rows: G = [[c̄, s], [−s, c]]
        T[i] = np.conj(c)[:, None] * Ti + sn[:, None] * Tk
        T[k] = -sn[:, None] * Ti + c[:, None] * Tk
        for M in (T, Z):  # columns: · Gᴴ = [[c, −s̄], [s̄, c̄]]
            Mi, Mk = M[:, i].copy(), M[:, k].copy()
            M[:, i] = Mi * c[None, :] + Mk * np.conj(sn)[None, :]
            M[:, k] = -Mi * np.conj(sn)[None, :] + Mk * np.conj(c)[None, :]
    idx = np.arange(1, n)
    T[idx, idx - 1] = 0.0
    return T, Z


def _real_to_complex_schur_loop(T: np.ndarray, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_real_to_complex_schur` block by block, bottom up (complex T and Z)."""
    n = T.shape[0]
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
