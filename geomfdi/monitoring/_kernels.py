"""Vectorised kernels of the AR monitor: sliding normal equations and batched solves.

Every entry of the window's normal equations ``A = R^T R``, ``b = R^T y`` is a moving sum
of one of ``n + 1`` lagged products ``X_i X_{i+d}``; they are computed for all windows at
once by blockwise cumulative sums and the ``n x n`` systems solved in one batched call.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from geomfdi.tolerance import get_rtol

__all__: list[str] = []

#: Least number of outputs per block of the blockwise cumulative sums (and >= 4 windows).
_BLOCK = 64
#: Windows of at most this many regression rows are summed directly.
_DIRECT_MAX = 16
#: A sliding sum is recomputed from the window when the data it was differenced from
#: exceed the window's own sum of squares this many times (bounds cancellation error).
_RISK = 64.0


def _moving_sums(q: np.ndarray, w: int) -> np.ndarray:
    """Moving sums of ``w`` consecutive entries, ``(..., R, L) -> (..., R, L-w+1)``.

    ``q[..., 0, :]`` must be non-negative (the squares ``z_i^2``) and bound the others
    (``|z_i z_{i+d}| <= (z_i^2 + z_{i+d}^2) / 2``); it serves as the error reference.

    Cumulative sums restart every ``K = max(4 w, 64)`` outputs: each sum is the
    difference of two partial sums of at most ``K + w - 1`` terms of its own block, so
    however long the stream its rounding error is ``O(eps P)``, with ``P`` the block's
    partial sum of squares up to the window's end.  (A global cumsum would lose
    ``log10(L / w)`` digits and carry a large fault's magnitude into every later
    window.)  For stationary data ``P`` is at most ``(K + w) / w`` times the window's
    own sum of squares; where it exceeds ``_RISK`` times that sum (e.g. just after a
    huge outlier has left the window), the window is summed directly, so every sum has
    a relative error ``O(eps _RISK)`` at worst.  Windows of ``w <= 16`` terms, and rows
    with at most 16 windows, are summed directly.
    """
    L = q.shape[-1]
    nout = L - w + 1
    if nout <= 0:
        return np.zeros((*q.shape[:-1], 0))
    if nout <= 16:  # a few windows per row (training windows): direct sums
        return np.stack([q[..., s : s + w].sum(axis=-1) for s in range(nout)], axis=-1)
    if w <= _DIRECT_MAX:  # short windows: direct sums, O(L w)
        return sliding_window_view(q, w, axis=-1).sum(axis=-1)
    R = q.shape[-2]
    K = min(max(_BLOCK, 4 * w), nout)
    nb = -(-nout // K)
    seg = K + w - 1
    pad = nb * K + w - 1 - L
    qp = np.concatenate([q, np.zeros((*q.shape[:-1], pad))], axis=-1) if pad > 0 else q
    blocks = sliding_window_view(qp, seg, axis=-1)[..., ::K, :]  # (..., R, nb, seg), a view
    c = np.empty((*q.shape[:-1], nb, seg + 1))
    c[..., 0] = 0.0
    np.cumsum(blocks, axis=-1, out=c[..., 1:])
    out = c[..., w : w + K] - c[..., :K]  # (..., R, nb, K)
    # partial sums of squares up to the end of each window (and its R - 1 shifts)
    reach = c[..., 0, :, :][..., np.minimum(np.arange(K) + w + R - 1, seg)]
    risky = reach > _RISK * out[..., 0, :, :]
    out = out.reshape(*q.shape[:-1], nb * K)[..., :nout]
    risky = risky.reshape(*risky.shape[:-2], nb * K)[..., :nout]
    if np.any(risky):
        where = np.nonzero(risky)  # (batch indices..., window start)
        cols = where[-1][:, None] + np.arange(w)
        qT = np.moveaxis(q, -2, 0)  # (R, ..., L)
        oT = np.moveaxis(out, -2, 0)  # view: writes go into out
        rows = tuple(i[:, None] for i in where[:-1])
        oT[(slice(None), *where)] = qT[(slice(None), *rows, cols)].sum(axis=-1)
    return out


#: Normal equations of many windows: ``A[i][j]`` (``j <= i``, the lower triangle) and
#: ``b[i]`` are arrays over the windows (last axis), often views into the moving sums.
Gram = tuple[list[list[np.ndarray]], list[np.ndarray]]


def _normal_equations(z: np.ndarray, n: int, m: int) -> tuple[Gram, np.ndarray]:
    """Normal equations of the AR(n) least-squares fit of every length-``m`` window of z.

    For the window ``z[s : s+m]`` the regression rows are ``j = s+n, ..., s+m-1`` with
    target ``z[j]`` and regressors ``(z[j-1], ..., z[j-n])``; so
    ``A[k, l] = sum_j z[j-k] z[j-l]`` and ``b[k] = sum_j z[j] z[j-k]`` (``k, l = 1..n``).
    Both are sums over ``m - n`` consecutive entries of a lagged product
    ``q_d[i] = z[i] z[i+d]`` (``d = |k - l|`` or ``k``), so ``n + 1`` moving sums give
    every entry of every window: ``A[k, l](s) = M_{|k-l|}[s + n - max(k, l)]``,
    ``b[k](s) = M_k[s + n - k]``.

    Parameters
    ----------
    z : ndarray, (..., Lz)
        Samples; non-finite entries are treated as zeros here and flagged in ``bad``.

    Returns
    -------
    (A, b) : Gram
        ``A[i][j]`` (``j <= i``) and ``b[i]`` of shape ``(..., nw)``, one window per
        entry of the last axis (``nw = Lz - m + 1``; window ``s`` ends at
        ``z[s + m - 1]``).
    bad : ndarray of bool, (..., nw)
        Windows containing a non-finite sample.
    """
    Lz = z.shape[-1]
    nw = Lz - m + 1
    finite = np.isfinite(z)
    zz = np.where(finite, z, 0.0)
    q = np.zeros((*z.shape[:-1], n + 1, Lz))
    q[..., 0, :] = zz * zz
    for d in range(1, n + 1):
        q[..., d, : Lz - d] = zz[..., : Lz - d] * zz[..., d:]
    ms = _moving_sums(q, m - n)  # (..., n+1, nw + n)
    # 0-based i >= j: lag i - j, offset n - 1 - i (= n - max(k, l) with k, l 1-based)
    A = [[ms[..., i - j, n - 1 - i : n - 1 - i + nw] for j in range(i + 1)] for i in range(n)]
    b = [ms[..., i + 1, n - 1 - i : n - 1 - i + nw] for i in range(n)]
    nbad = np.zeros((*z.shape[:-1], Lz + 1), dtype=np.int64)
    np.cumsum(~finite, axis=-1, out=nbad[..., 1:])
    bad = (nbad[..., m:] - nbad[..., :nw]) > 0
    return (A, b), bad


def _gram_map(gram: Gram, f) -> Gram:
    """Apply ``f`` to every array of a :data:`Gram` (e.g. select windows)."""
    A, b = gram
    return [[f(a) for a in row] for row in A], [f(v) for v in b]


def _dense_gram(A: np.ndarray, b: np.ndarray) -> Gram:
    """:data:`Gram` views of dense ``A`` (..., n, n, N) and ``b`` (..., n, N)."""
    n = b.shape[-2]
    return [[A[..., i, j, :] for j in range(i + 1)] for i in range(n)], [
        b[..., i, :] for i in range(n)
    ]


def _singular(A: list[list[np.ndarray]], n: int) -> np.ndarray:
    """Rank decision of the regressor Gram matrices ``A = R^T R`` (lower triangles).

    A window counts as rank deficient when ``lambda_min(A) <= rtol * ||A||_2`` with
    ``rtol`` the package tolerance (:func:`geomfdi.tolerance.get_rtol`), i.e. when the
    regressor matrix ``R`` has a singular value below ``sqrt(rtol) ||R||_2``.  A
    Gershgorin lower bound on ``lambda_min`` and ``trace(A) >= ||A||_2`` certify most
    windows full rank cheaply, then a successful Cholesky factorisation of
    ``A - rtol trace(A) I`` certifies the rest; eigenvalues are computed only if that
    fails for some window.
    """
    rtol = get_rtol(n)
    trace = sum(A[i][i] for i in range(n))
    radius = [np.zeros(()) for _ in range(n)]
    for i in range(n):
        for j in range(i):
            a = np.abs(A[i][j])
            radius[i] = radius[i] + a
            radius[j] = radius[j] + a
    gersh = np.minimum.reduce([A[i][i] - radius[i] for i in range(n)])
    sure = gersh > rtol * trace
    out = np.zeros(trace.shape, dtype=bool)
    todo = ~sure
    if np.any(todo):
        At = np.empty((int(todo.sum()), n, n))
        for i in range(n):
            for j in range(i + 1):
                At[:, i, j] = At[:, j, i] = A[i][j][todo]
        shift = (rtol * trace[todo])[:, None, None] * np.eye(n)
        try:
            np.linalg.cholesky(At - shift)
        except np.linalg.LinAlgError:
            lam = np.linalg.eigvalsh(At)
            out[todo] = ~(lam[:, 0] > rtol * np.maximum(lam[:, -1], 0.0)) | (lam[:, -1] <= 0)
    return out


def _solve(gram: Gram, n: int, skip: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares coefficients from the normal equations, vectorised over windows.

    Returns ``phi`` (..., N, n), NaN where ``A`` is rank deficient (``sing``) or
    ``skip`` is set; ``sing`` (..., N) is False where ``skip`` is set.  The symmetric
    positive definite systems are solved by a Cholesky factorisation written out over
    the ``n x n`` entries, each step one array operation over all windows.
    """
    A, b = gram
    sing = _singular(A, n)
    if skip is not None:
        sing &= ~skip
        dead = sing | skip
    else:
        dead = sing
    if np.any(dead):  # factor the identity there instead (result discarded)
        A = [[np.where(dead, float(i == j), A[i][j]) for j in range(i + 1)] for i in range(n)]
        b = [np.where(dead, 0.0, v) for v in b]
    Lf: list[list[np.ndarray]] = [[np.empty(0)] * n for _ in range(n)]
    for j in range(n):
        s = A[j][j] - sum((Lf[j][k] ** 2 for k in range(j)), np.zeros(()))
        Lf[j][j] = np.sqrt(s)
        for i in range(j + 1, n):
            t = A[i][j] - sum((Lf[i][k] * Lf[j][k] for k in range(j)), np.zeros(()))
            Lf[i][j] = t / Lf[j][j]
    y: list[np.ndarray] = []
    for i in range(n):
        y.append((b[i] - sum((Lf[i][k] * y[k] for k in range(i)), np.zeros(()))) / Lf[i][i])
    x: list[np.ndarray] = [np.empty(0)] * n
    for i in reversed(range(n)):
        t = y[i] - sum((Lf[k][i] * x[k] for k in range(i + 1, n)), np.zeros(()))
        x[i] = t / Lf[i][i]
    phi = np.stack(x, axis=-1)
    phi[dead] = np.nan
    return phi, sing


def _gram(window: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Exact normal equations of one ordered window (O(m n^2))."""
    m = window.shape[0]
    R = np.stack([window[n - k : m - k] for k in range(1, n + 1)], axis=1)
    y = window[n:]
    return R.T @ R, R.T @ y


def _rows_fit(w: np.ndarray, n: int, rows: int = 8192) -> tuple[np.ndarray, np.ndarray]:
    """AR(n) fit of each row of ``w`` (N, L) as one window; chunks of ``rows`` rows."""
    phi = np.empty((w.shape[0], n))
    sing = np.empty(w.shape[0], dtype=bool)
    for i in range(0, w.shape[0], rows):
        gram, _ = _normal_equations(w[i : i + rows], n, w.shape[1])
        phi[i : i + rows], sing[i : i + rows] = _solve(_gram_map(gram, lambda a: a[..., 0]), n)
    return phi, sing


def _run_lengths(alarm: np.ndarray, carry: int) -> np.ndarray:
    """Length of the run of consecutive ``True`` ending at each index (``carry`` before)."""
    idx = np.arange(alarm.shape[-1])
    last_false = np.maximum.accumulate(np.where(alarm, -1 - carry, idx))
    return idx - last_false
