"""Linear-algebra helpers of the window model: covariances, Toeplitz maps, null spaces."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from geomfdi._validation import as_matrix, as_real_array
from geomfdi.errors import GeomFDIError, RankDeficientError, ShapeError
from geomfdi.tolerance import get_rtol, rank_decision

__all__: list[str] = []


def _as_covariance(value: Any, name: str, size: int) -> np.ndarray:
    """A symmetric positive semidefinite ``size x size`` covariance.

    A scalar means ``value * I``, a vector of length ``size`` the diagonal (the paper
    gives variances ``N(0, sigma^2)``), a matrix is used as it is.
    """
    arr = as_real_array(value, name)
    if arr.ndim == 0:
        cov = float(arr) * np.eye(size)
    elif arr.ndim == 1 or (arr.ndim == 2 and size > 1 and 1 in arr.shape):
        vec = arr.reshape(-1)
        if vec.size != size:
            raise ShapeError(
                f"{name}: expected {size} variances (or a {size}x{size} matrix), "
                f"got shape {arr.shape}",
                argument=name,
            )
        cov = np.diag(vec)
    elif arr.ndim == 2:
        if arr.shape != (size, size):
            raise ShapeError(
                f"{name}: expected a {size}x{size} covariance, got shape {arr.shape}",
                argument=name,
            )
        cov = arr
    else:
        raise ShapeError(
            f"{name}: must be a scalar, vector or matrix, got shape {arr.shape}", argument=name
        )
    scale = float(np.max(np.abs(cov))) if cov.size else 0.0
    tol = get_rtol(max(size, 1)) * max(scale, np.finfo(float).tiny)
    if np.max(np.abs(cov - cov.T), initial=0.0) > tol:
        raise GeomFDIError(f"{name}: a covariance must be symmetric", argument=name)
    cov = 0.5 * (cov + cov.T)
    if size:
        lam_min = float(np.linalg.eigvalsh(cov)[0])
        if lam_min < -tol:
            raise GeomFDIError(
                f"{name}: covariance is not positive semidefinite "
                f"(smallest eigenvalue {lam_min:.3g})",
                argument=name,
            )
    return cov


def _as_channel(value: Any, name: str, rows: int, cols: int | None = None) -> np.ndarray:
    """A signature matrix with ``rows`` rows; a 1-D input is a column (a row if ``rows = 1``)."""
    return as_matrix(value, name, rows=rows, cols=cols, vector_as="row" if rows == 1 else "column")


def _times_kron(X: np.ndarray, K: np.ndarray) -> np.ndarray:
    """``X @ kron(I_s, K)`` without forming the Kronecker product."""
    rows = X.shape[0]
    s = X.shape[1] // K.shape[0]
    return (X.reshape(rows, s, K.shape[0]) @ K).reshape(rows, s * K.shape[1])


def _block_toeplitz(markov: np.ndarray) -> np.ndarray:
    """Lower block-Toeplitz matrix with block ``markov[j]`` on block sub-diagonal ``j``.

    ``markov`` has shape ``(s, r, c)``; the result is ``(s r, s c)`` with block
    ``(k, t) = markov[k - t]`` for ``k >= t`` and zero above the diagonal.
    """
    s, r, c = markov.shape
    out = np.zeros((s, r, s, c))
    for j in range(s):
        k = np.arange(j, s)
        out[k, :, k - j, :] = markov[j]
    return out.reshape(s * r, s * c)


def _left_null_rows(X: np.ndarray, what: str) -> tuple[np.ndarray, int]:
    """Orthonormal rows spanning the left null space of ``X`` (by a full SVD)."""
    U, sv, _ = np.linalg.svd(X, full_matrices=True)
    scale = float(sv[0]) if sv.size else 0.0
    rank = rank_decision(sv, scale, X.shape[0], what=what).rank
    return U[:, rank:].T.copy(), rank


def _sym_inv_sqrt(M: np.ndarray, what: str) -> np.ndarray:
    """``M^(-1/2)`` of a symmetric positive definite matrix (eigen-decomposition)."""
    w, V = np.linalg.eigh(0.5 * (M + M.T))
    scale = float(w[-1]) if w.size else 0.0
    dec = rank_decision(w[::-1].clip(min=0.0), scale, M.shape[0], what=what, warn=False)
    if dec.rank < M.shape[0]:
        raise RankDeficientError(
            f"Rv: the projected noise covariance N_H E Sigma_e E^T N_H^T ({what}) is singular "
            f"(rank {dec.rank} < {M.shape[0]}): some parity directions carry no noise, so the "
            "indices would be infinite; give Qw/Rv (and Bw/Dv) that excite every residual",
            argument="Rv",
        )
    return (V / np.sqrt(w)) @ V.T


def _rref(X: np.ndarray, tol: float) -> np.ndarray:
    """Reduced row echelon form with partial pivoting; entries below ``tol`` are zero."""
    R = np.array(X, dtype=float)
    rows, cols = R.shape
    r = 0
    for c in range(cols):
        if r == rows:
            break
        piv = r + int(np.argmax(np.abs(R[r:, c])))
        if abs(R[piv, c]) <= tol:
            R[r:, c] = 0.0
            continue
        R[[r, piv]] = R[[piv, r]]
        R[r] /= R[r, c]
        others = np.arange(rows) != r
        R[others] -= np.outer(R[others, c], R[r])
        R[others, c] = 0.0
        r += 1
    R[np.abs(R) <= tol] = 0.0
    return R


def _chi2_power(dof: int, noncentrality: float, alpha: float) -> float:
    """``P(chi2_dof(lambda) > chi2_{dof, 1-alpha})``; ``alpha`` when ``dof = 0``."""
    if dof == 0 or noncentrality <= 0.0:  # no test, or the null distribution itself
        return alpha
    from scipy import stats

    if not math.isfinite(noncentrality):
        return 1.0
    if noncentrality < 1e-12:
        # the power is alpha + O(lambda); scipy's series loses those digits below ~1e-12
        return alpha
    thr = float(stats.chi2.isf(alpha, dof))
    with np.errstate(all="ignore"):
        power = float(stats.ncx2.sf(thr, dof, noncentrality))
    if not math.isfinite(power):
        # scipy's noncentral chi-square fails for very large noncentralities; there the
        # statistic is normal to many digits: mean dof + lambda, variance 2 (dof + 2 lambda)
        z = (thr - dof - noncentrality) / math.sqrt(2.0 * (dof + 2.0 * noncentrality))
        power = float(stats.norm.sf(z))
    return min(max(power, alpha), 1.0)  # the power of a level-alpha test is >= alpha
