"""Training the AR monitor: AR fits of normal windows, ``mu`` and ``delta`` of ``phi_c``.

See the user guide, *Theory: AR monitoring* (``docs/theory/ar-monitoring.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi._validation import as_int, as_real_array, check_nonempty
from geomfdi.errors import GeomFDIError, RankDeficientError, ShapeError
from geomfdi.monitoring._kernels import _gram_map, _normal_equations, _rows_fit, _solve
from geomfdi.monitoring._records import ARTraining

__all__ = ["window_coefficients", "fit", "pooled_fit"]


def pooled_fit(training: np.ndarray, order: int) -> np.ndarray:
    """One AR(order) least-squares fit of all training data (the fitted null model).

    For ``(N, L)`` windows the normal equations of every window are summed (the windows
    are not joined: no regression row spans two windows); a 1-D sequence is fitted as a
    whole.  ``phi = (sum_w R_w^T R_w)^{-1} sum_w R_w^T y_w`` with ``R_w`` the regressor
    rows ``(X_{j-1}, ..., X_{j-n})`` and ``y_w`` the targets ``X_j`` of window ``w``.

    Returns
    -------
    ndarray, (order,)
        ``(phi_1, ..., phi_n)`` of the pooled fit.
    """
    from numpy.lib.stride_tricks import sliding_window_view

    w = np.atleast_2d(training)
    R = sliding_window_view(w, order, axis=1)[:, :-1, ::-1]  # (N, L - n, n)
    y = w[:, order:]
    A = np.einsum("wji,wjk->ik", R, R)
    b = np.einsum("wji,wj->i", R, y)
    return np.linalg.solve(A, b)


def window_coefficients(order: int, windows: Any) -> np.ndarray:
    """AR(order) least-squares coefficients of each row of ``windows``.

    Parameters
    ----------
    order : int
        AR order ``n``.
    windows : array_like, (N, L) or (L,)
        Finite samples; each row is one window (``L >= 2 * order``, any length).

    Returns
    -------
    ndarray, (N, order) or (order,)
        ``(phi_1, ..., phi_n)`` per row; NaN rows for rank-deficient windows.
    """
    w = as_real_array(windows, "windows")
    one = w.ndim == 1
    if one:
        w = w[None, :]
    if w.ndim != 2:
        raise ShapeError(f"windows: expected 1-D or 2-D, got shape {w.shape}", argument="windows")
    if w.shape[1] < 2 * order:
        raise GeomFDIError(
            f"windows: AR({order}) needs rows of at least {2 * order} samples, got {w.shape[1]}",
            argument="windows",
        )
    phi, _ = _rows_fit(w, order)
    return phi[0] if one else phi


def fit(order: int, window: int, coefficient: int, training: Any, *, step: int = 1) -> ARTraining:
    """Learn ``mu`` and ``delta`` of ``phi_c`` from fault-free innovations.

    Parameters
    ----------
    order, window, coefficient : int
        AR order ``n``, window length ``m`` and the 0-based index ``c`` of the tested
        coefficient.
    training : array_like, (N, window) or (L,)
        ``N >= 2`` normal windows (rows), or one long normal sequence whose windows
        (every ``step``-th one) are used.  Must be finite.
    step : int
        Spacing of the windows taken from a 1-D sequence (1: all sliding windows;
        ``window``: non-overlapping, independent windows as in the paper).

    Returns
    -------
    ARTraining
        ``mu``, ``delta`` (sample mean and standard deviation of ``phi_c`` over the
        windows), the coefficients of the windows, the pooled fit (:func:`pooled_fit`) and
        the last ``window - 1`` training samples (the default stored normal innovations).
    """
    m, n = window, order
    tr = as_real_array(training, "training")
    check_nonempty(tr, "training")
    step = as_int(step, "step", minimum=1)
    if tr.ndim == 2:
        if tr.shape[1] != m:
            raise ShapeError(
                f"training: expected windows of {m} samples (columns), got shape {tr.shape}",
                argument="training",
            )
        if tr.shape[0] < 2:
            raise GeomFDIError(
                f"training: at least 2 windows are needed to estimate delta, got {tr.shape[0]}",
                argument="training",
            )
        phi, sing = _rows_fit(tr, n)
        last = tr[-1]
    elif tr.ndim == 1:
        if tr.shape[0] < m:
            raise GeomFDIError(
                f"training: a sequence of at least {m} samples (one window) is needed, "
                f"got {tr.shape[0]}",
                argument="training",
            )
        gram, _ = _normal_equations(tr, n, m)
        phi, sing = _solve(_gram_map(gram, lambda a: a[..., ::step]), n)
        last = tr
    else:
        raise ShapeError(
            f"training: expected (N, window) windows or a 1-D sequence, got shape {tr.shape}",
            argument="training",
        )
    if phi.shape[0] < 2:
        raise GeomFDIError(
            f"training: at least 2 windows are needed to estimate delta, got {phi.shape[0]}",
            argument="training",
        )
    if np.any(sing):
        raise RankDeficientError(
            f"training: {int(sing.sum())} of {sing.size} windows have rank-deficient "
            f"AR({n}) regressors (first: {int(np.argmax(sing))})",
            argument="training",
        )
    c = phi[:, coefficient]
    mu = float(np.mean(c))
    delta = float(np.std(c, ddof=1))
    if not delta > 0:
        raise GeomFDIError(
            f"training: phi_{coefficient + 1} does not vary over the training windows",
            argument="training",
        )
    return ARTraining(mu, delta, phi, pooled_fit(tr, n), last[-(m - 1) :])
