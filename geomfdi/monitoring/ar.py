"""AR-model innovation monitor with a chi-square test and a reset strategy (seed 003).

The monitor fits an AR(n) model by least squares to a sliding window of the last ``m``
innovations, and tests one coefficient ``phi_c`` against its fault-free distribution
learnt from normal data (math.md §8):

    lambda_t = ((phi_c(t) - mu) / delta)**2  ~  chi2(1),   alarm when lambda_t > T,

with ``T = chi2.isf(pfa, 1)`` (``pfa = 1e-4`` gives ``T = 15.1367``).  The window's
normal equations are updated by adding the newest regression row and removing the
oldest one (O(n^2) per sample) in the streaming API, and computed for every window at
once from blockwise cumulative sums of lagged products in the batch API.
"""

from __future__ import annotations

import math
import numbers
import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from geomfdi._validation import (
    as_bool,
    as_index,
    as_int,
    as_probability,
    as_real_array,
    check_nonempty,
)
from geomfdi.errors import ComplexInputError, GeomFDIError, RankDeficientError, ShapeError
from geomfdi.tolerance import get_rtol

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["ARMonitor", "ARMonitorResult", "ARMonitorWarning", "ARStep", "plot_ar_monitor"]

#: Least number of outputs per block of the blockwise cumulative sums (and >= 4 windows).
_BLOCK = 64
#: Windows of at most this many regression rows are summed directly.
_DIRECT_MAX = 16
#: A sliding sum is recomputed from the window when the data it was differenced from
#: exceed the window's own sum of squares this many times (bounds cancellation error).
_RISK = 64.0
#: Largest number of epochs computed in one vectorised pass (bounds memory).
_CHUNK_MAX = 1 << 16


class ARMonitorWarning(UserWarning):
    """Some statistics are invalid: non-finite samples or rank-deficient regressors."""


# --------------------------------------------------------------------------------------
# vectorised kernels
# --------------------------------------------------------------------------------------


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


def _as_stream(value: Any, name: str) -> np.ndarray:
    """Real float array of 1 or 2 dimensions; non-finite entries are allowed (reported)."""
    arr = as_real_array(value, name, allow_nonfinite=True)
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim not in (1, 2) or arr.shape[-1] == 0:
        raise ShapeError(
            f"{name}: expected a 1-D stream or a 2-D array of streams (rows), got shape "
            f"{arr.shape}",
            argument=name,
        )
    return arr


# --------------------------------------------------------------------------------------
# results
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ARStep:
    """Outcome of one streaming update (:meth:`ARMonitor.update`).

    Attributes
    ----------
    epoch : int
        0-based index of the sample since the last :meth:`ARMonitor.reset`.
    statistic : float
        ``lambda``; NaN when ``valid`` is False.
    alarm : bool
        ``statistic > threshold``.
    valid : bool
        A statistic was computed (full window, finite samples, full-rank regressors).
    coefficients : ndarray, (n,)
        ``(phi_1, ..., phi_n)`` of the current window (NaN when invalid).
    restarted : bool
        The window was restarted from the stored normal data after this epoch.
    nonfinite, singular : bool
        Why the statistic is invalid (window holds a non-finite sample; rank-deficient
        regressor matrix).  Both False during the warm-up.
    """

    epoch: int
    statistic: float
    alarm: bool
    valid: bool
    coefficients: np.ndarray
    restarted: bool
    nonfinite: bool
    singular: bool


@dataclass(frozen=True)
class ARMonitorResult:
    """Per-epoch output of :meth:`ARMonitor.run`.

    Arrays have the stream's shape ``(L,)`` (or ``(B, L)`` for a batch of streams);
    ``coefficients`` has one more trailing axis of length ``order``.

    Attributes
    ----------
    statistic : ndarray
        ``lambda_t = ((phi_c(t) - mu) / delta)**2``; NaN exactly where ``valid`` is False.
    alarm : ndarray of bool
        ``statistic > threshold`` (False where invalid).
    valid : ndarray of bool
        A statistic exists: the window is full (not in the warm-up), holds only finite
        samples and its regressor matrix has full column rank.
    coefficients : ndarray, (..., L, order)
        AR coefficients of each epoch's window (NaN where invalid).
    restarted : ndarray of bool
        True at the epochs after which the reset strategy restarted the window.
    nonfinite : ndarray of bool
        The epoch's window contains a non-finite sample.
    singular : ndarray of bool
        The epoch's regressor matrix is rank deficient (tolerance policy).
    threshold : float
        ``chi2.isf(pfa, 1)``.
    info : dict
        The monitor's settings and training values (``mu``, ``delta``, ``order``,
        ``window``, ``coefficient``, ``pfa``, ``reset_after``, ``reset_keep``,
        ``prefill``) and the number of ``restarts``.
    """

    statistic: np.ndarray
    alarm: np.ndarray
    valid: np.ndarray
    coefficients: np.ndarray
    restarted: np.ndarray
    nonfinite: np.ndarray
    singular: np.ndarray
    threshold: float
    info: dict = field(default_factory=dict)

    @property
    def first_alarm(self) -> int | np.ndarray | None:
        """Epoch of the first alarm (``None`` if none); per row for a batch (-1: none)."""
        if self.alarm.ndim == 1:
            hits = np.flatnonzero(self.alarm)
            return int(hits[0]) if hits.size else None
        any_ = self.alarm.any(axis=-1)
        return np.where(any_, self.alarm.argmax(axis=-1), -1)

    def plot(self, **kwargs: Any) -> Figure:
        """Plot ``lambda`` against the threshold (see :func:`plot_ar_monitor`)."""
        return plot_ar_monitor(self, **kwargs)


# --------------------------------------------------------------------------------------
# the monitor
# --------------------------------------------------------------------------------------


class ARMonitor:
    """AR-model parameter-change detector for innovation sequences (seed 003).

    Parameters
    ----------
    order : int
        AR order ``n`` (paper: 5).
    window : int
        Window length ``m`` in samples (paper: 60); ``m - n`` regression equations, so
        ``window >= 2 * order`` is required.
    coefficient : int
        0-based index ``c`` of the tested coefficient ``phi_{c+1}`` (paper: ``phi_1``).
    pfa : float
        False-alarm probability of the chi-square(1) test.
    reset_after : int or None
        Reset strategy: restart the window from the stored normal innovations after this
        many consecutive alarms (paper: 10).  ``None`` disables it.
    reset_keep : int
        Number of the most recent (faulty) samples kept in the restarted window (see
        Notes; 0 is the literal "restart from the stored normal data").
    prefill : bool
        Start every stream (and :meth:`reset`) with the window holding the stored normal
        innovations, so that a statistic exists from the first sample (the paper's
        "pre-stored innovations").  If False, the first ``m - 1`` epochs are a warm-up
        with invalid statistics.
    refit_every : int, optional
        Streaming API: recompute the normal equations exactly from the window every this
        many updates (default ``window``), which bounds the drift of the rank-1 updates.

    Attributes
    ----------
    mu, delta : float
        Mean and standard deviation of ``phi_c`` over the training windows.
    threshold : float
        ``chi2.isf(pfa, 1)``.
    normal : ndarray, (window - 1,)
        Stored normal innovations used by ``prefill`` and the reset strategy.
    training_coefficients : ndarray, (N, order)
        AR coefficients of the training windows.

    Notes
    -----
    **Model.**  ``X_t = sum_{k=1}^{n} phi_k X_{t-k} + e_t`` without intercept, fitted by
    ordinary least squares to the ``m - n`` equations ``t = s+n, ..., s+m-1`` of the
    window ``X_s, ..., X_{s+m-1}`` (the paper's model; innovations of a consistent
    filter are zero-mean).  No intercept is deliberate: a bias fault then shows as a
    change of the coefficients, which is what the test detects; with an intercept a
    window entirely covered by a step would look normal in both cases, but a step in
    the last few samples would be partly absorbed by the intercept.

    **Test.**  ``lambda = ((phi_c - mu) / delta)**2`` is compared with
    ``T = chi2.isf(pfa, 1)``: the paper's "lambda_k = phi_k - mu 2".  The chi-square(1)
    law is an approximation (``phi_c`` is only asymptotically normal, and ``mu``,
    ``delta`` are estimates).  For ``n = 5, m = 60`` on Gaussian innovations the
    realised false-alarm rate per independent window is 0.050 at ``pfa = 0.05`` and
    0.011 at 0.01, but about 1.8e-4 at 1e-4: the least-squares coefficient has heavier
    tails than the normal law.  The paper assumes independent training
    windows; overlapping windows of one long normal sequence give consistent ``mu``
    and ``delta`` too.  Statistics of overlapping windows are strongly correlated, so
    alarms come in bursts.

    **Power.**  A bias fault in the last samples pulls ``phi_1`` towards +1.  With the
    paper's innovations (``mu = -0.31``, ``delta = 0.15``) a 5-sigma step moves
    ``phi_1`` by 5 to 6 ``delta`` and is detected within a few samples; on white
    innovations (``mu = 0``) the same step moves it by only about 3.5 ``delta``, and at
    ``pfa = 1e-4`` it is missed in about one stream out of five.

    **Sliding normal equations.**  Streaming: ``A = R^T R`` and ``b = R^T y`` are
    updated by ``+ r r^T - r_old r_old^T`` (O(n^2)) and solved (O(n^3), n small);
    every ``refit_every`` updates and whenever the window changes otherwise (warm-up,
    non-finite sample leaving, restart) they are recomputed from the window.  Batch:
    every entry of ``A`` and ``b`` is a moving sum of one of ``n + 1`` lagged products
    ``X_i X_{i+d}``, computed for all windows at once by blockwise cumulative sums, and
    the ``n x n`` systems are solved in one batched call.  Both agree with a
    from-scratch least-squares fit of each window to rounding: cancellation in the
    differences is bounded (blockwise restarts; exact re-summation or refit where
    data much larger than the current window have just left it), and what remains is
    the conditioning of the normal equations, ``kappa(R)^2`` (about 1e2 for
    innovations; a bias fault of 1000 sigma filling the window raises it to about
    1e7, and the agreement with ``lstsq`` to 1e-8).

    **Rank.**  A window whose Gram matrix has ``lambda_min <= rtol ||A||`` (package
    tolerance policy) gives no statistic (``singular``), e.g. a window of zeros.

    **Non-finite samples.**  A NaN or inf sample invalidates the ``m`` statistics whose
    windows contain it (``nonfinite``; an :class:`ARMonitorWarning` is issued); it never
    enters the sums of later windows, and the fit resumes as soon as it has left the
    window.  Invalid epochs do not alarm and break a run of consecutive alarms.

    **Reset strategy (exact semantics).**  Let ``k = reset_after`` and
    ``r = reset_keep``.  A counter counts consecutive valid alarms.  When it reaches
    ``k`` at epoch ``t`` (the alarm at ``t`` is reported), the window is restarted:
    its last ``m - 1`` samples become ``normal[r:]`` followed by ``X_{t-r+1}, ..., X_t``,
    so the window of epoch ``t + 1`` is ``(normal[r:], X_{t-r+1..t}, X_{t+1})``; the
    counter restarts at 0 and ``restarted[t]`` is set.  All other faulty samples are
    dropped.  The stored normal data are *not* refreshed while monitoring (a slowly
    growing, undetected fault could otherwise enter them); change them with
    :meth:`set_normal`.  While a fault persists, each restart puts the faulty samples
    back at the end of an otherwise normal window, where the test is most sensitive,
    so the alarm keeps being raised instead of dying out when the fault fills the
    window (paper, Fig. 7 vs. Fig. 8); with ``r = 0`` the first epoch after a restart
    has only one faulty sample and may not alarm, so the alarm has short gaps.  A
    fault that never raises ``k`` consecutive alarms never triggers a restart.
    When the fault ends, its samples leave the window at the next restart (at most
    ``k`` epochs later while the alarm holds; in simulations with ``k = 10`` the alarm
    stops within 11 epochs in 9 cases out of 10) or, at the latest, after ``m``
    epochs; without the reset strategy the faulty samples keep ``lambda`` high until
    they leave the window.  The paper's own device, a stored buffer of 58
    normal samples followed by one fixed "fault datum", is the case ``r = 1`` with the
    datum replaced by the actual last sample.

    References
    ----------
    Seed 003: Jin T., Ding D., Cong L., "AR-model parameter based fault detection for
    navigation systems" (Beihang University): AR(5) on 60-sample windows of GPS
    pseudorange innovations, chi-square(1) test of phi_1, Pfa = 1e-4 -> T = 15.1367,
    reset after 10 consecutive alarms.  math.md §8.

    Examples
    --------
    >>> import geomfdi as gf
    >>> mon = gf.ARMonitor(order=5, window=60, reset_after=None)
    >>> _ = mon.fit(gf.synthetic_innovations(60, ar=[-0.3], n_series=500, rng=0))
    >>> round(mon.threshold, 4)
    15.1367
    >>> x = gf.synthetic_innovations(300, ar=[-0.3], fault="step", size=5, start=200, rng=0)
    >>> out = mon.run(x)
    >>> out.statistic.shape, out.first_alarm
    ((300,), 203)
    """

    def __init__(
        self,
        order: int = 5,
        window: int = 60,
        coefficient: int = 0,
        pfa: float = 1e-4,
        reset_after: int | None = 10,
        *,
        reset_keep: int = 1,
        prefill: bool = False,
        refit_every: int | None = None,
    ) -> None:
        self.order = as_int(order, "order", minimum=1)
        self.window = as_int(window, "window", minimum=2)
        if self.order >= self.window:
            raise GeomFDIError(
                f"order: must be smaller than window = {self.window}, got {self.order}",
                argument="order",
            )
        if self.window < 2 * self.order:
            raise GeomFDIError(
                f"order: AR({self.order}) needs a window of at least {2 * self.order} samples "
                f"(window - order >= order equations), got window = {self.window}",
                argument="order",
            )
        self.coefficient = as_index(coefficient, "coefficient", self.order)
        self.pfa = as_probability(pfa, "pfa")
        if reset_after is None:
            self.reset_after: int | None = None
        else:
            self.reset_after = as_int(reset_after, "reset_after", minimum=1)
        self.reset_keep = as_int(reset_keep, "reset_keep", minimum=0)
        if self.reset_keep > self.window - 1:
            raise GeomFDIError(
                f"reset_keep: must be <= window - 1 = {self.window - 1}, got {self.reset_keep}",
                argument="reset_keep",
            )
        if not isinstance(prefill, bool | np.bool_):
            raise GeomFDIError(
                f"prefill: must be True or False, got {prefill!r}", argument="prefill"
            )
        self.prefill = bool(prefill)
        self.refit_every = (
            self.window if refit_every is None else as_int(refit_every, "refit_every", minimum=1)
        )
        from scipy.stats import chi2

        self.threshold = float(chi2.isf(self.pfa, 1))
        self.mu: float | None = None
        self.delta: float | None = None
        self.normal: np.ndarray | None = None
        self.training_coefficients: np.ndarray | None = None
        self.last: ARStep | None = None
        self._state_ready = False

    def __repr__(self) -> str:
        trained = (
            f"mu={self.mu:.4g}, delta={self.delta:.4g}" if self.mu is not None else "untrained"
        )
        return (
            f"ARMonitor(order={self.order}, window={self.window}, coefficient="
            f"{self.coefficient}, pfa={self.pfa:g}, reset_after={self.reset_after}; {trained})"
        )

    # ---------------------------------------------------------------- training
    def window_coefficients(self, windows: Any) -> np.ndarray:
        """AR(order) least-squares coefficients of each row of ``windows``.

        Parameters
        ----------
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
            raise ShapeError(
                f"windows: expected 1-D or 2-D, got shape {w.shape}", argument="windows"
            )
        if w.shape[1] < 2 * self.order:
            raise GeomFDIError(
                f"windows: AR({self.order}) needs rows of at least {2 * self.order} samples, "
                f"got {w.shape[1]}",
                argument="windows",
            )
        phi, _ = _rows_fit(w, self.order)
        return phi[0] if one else phi

    def fit(self, training: Any, *, step: int = 1, normal: Any = None) -> ARMonitor:
        """Learn ``mu`` and ``delta`` of ``phi_c`` from fault-free innovations.

        Parameters
        ----------
        training : array_like, (N, window) or (L,)
            ``N >= 2`` normal windows (rows), or one long normal sequence whose windows
            (every ``step``-th one) are used.  Must be finite.
        step : int
            Spacing of the windows taken from a 1-D sequence (1: all sliding windows;
            ``window``: non-overlapping, independent windows as in the paper).
        normal : array_like, (window - 1,), optional
            Normal innovations stored for ``prefill`` and the reset strategy (default: the
            last ``window - 1`` training samples).

        Returns
        -------
        ARMonitor
            ``self``, trained.
        """
        m, n = self.window, self.order
        tr = as_real_array(training, "training")
        check_nonempty(tr, "training")
        step = as_int(step, "step", minimum=1)
        if tr.ndim == 2:
            if tr.shape[1] != m:
                raise ShapeError(
                    f"training: expected windows of {m} samples (columns), got shape {tr.shape}",
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
        c = phi[:, self.coefficient]
        mu = float(np.mean(c))
        delta = float(np.std(c, ddof=1))
        if not delta > 0:
            raise GeomFDIError(
                f"training: phi_{self.coefficient + 1} does not vary over the training windows",
                argument="training",
            )
        self.mu, self.delta = mu, delta
        self.training_coefficients = phi
        self.set_normal(last[-(m - 1) :] if normal is None else normal)
        return self

    def set_normal(self, normal: Any) -> None:
        """Replace the stored normal innovations (``window - 1`` finite samples)."""
        v = as_real_array(normal, "normal").reshape(-1)
        if v.shape[0] != self.window - 1:
            raise ShapeError(
                f"normal: expected {self.window - 1} samples (window - 1), got {v.shape[0]}",
                argument="normal",
            )
        self.normal = v.copy()
        self._state_ready = False

    def _require_fit(self) -> None:
        if self.mu is None or self.delta is None or self.normal is None:
            raise GeomFDIError(
                "training: the monitor is not trained; call fit(training) first",
                argument="training",
            )

    def statistic_of(self, coefficients: Any) -> np.ndarray:
        """``((phi_c - mu) / delta)**2`` for coefficient vectors (..., order)."""
        self._require_fit()
        phi = np.asarray(coefficients, dtype=float)
        return ((phi[..., self.coefficient] - self.mu) / self.delta) ** 2

    # ---------------------------------------------------------------- batch
    def run(self, stream: Any) -> ARMonitorResult:
        """Monitor a whole stream (or a batch of streams) from a fresh state.

        Parameters
        ----------
        stream : array_like, (L,) or (B, L)
            Innovations; non-finite samples are allowed and reported (see Notes of
            :class:`ARMonitor`).  Rows of a 2-D array are independent streams.

        Returns
        -------
        ARMonitorResult
            Equal, to rounding, to feeding the samples one by one to :meth:`update`
            after :meth:`reset`.

        Notes
        -----
        Without the reset strategy all epochs are computed in vectorised passes of up to
        65536 epochs (rows of a batch together).  With it, the stream is processed in
        vectorised chunks that start small after each restart and double while no
        restart occurs; only the restart decisions are sequential.
        """
        self._require_fit()
        x = _as_stream(stream, "stream")
        one = x.ndim == 1
        X = x[None, :] if one else x
        B, L = X.shape
        n = self.order
        stat = np.full((B, L), np.nan)
        phi = np.full((B, L, n), np.nan)
        valid = np.zeros((B, L), dtype=bool)
        nonfin = np.zeros((B, L), dtype=bool)
        sing = np.zeros((B, L), dtype=bool)
        restarted = np.zeros((B, L), dtype=bool)
        outs = (stat, phi, valid, nonfin, sing, restarted)
        if self.reset_after is None:
            self._run_rows(X, outs, slice(None))
        else:
            for i in range(B):
                self._run_rows(X[i : i + 1], outs, slice(i, i + 1))
        alarm = valid & (np.where(valid, stat, 0.0) > self.threshold)
        bad_in = ~np.isfinite(X)
        if np.any(bad_in) or np.any(sing):
            msg = []
            if np.any(bad_in):
                first = np.argwhere(bad_in)[0]
                msg.append(
                    f"{int(bad_in.sum())} non-finite sample(s) (first at index "
                    f"{tuple(int(i) for i in first) if not one else int(first[1])}) "
                    f"invalidate {int(nonfin.sum())} statistic(s) (see .nonfinite)"
                )
            if np.any(sing):
                msg.append(
                    f"{int(sing.sum())} window(s) with rank-deficient regressors (see .singular)"
                )
            warnings.warn("stream: " + "; ".join(msg), ARMonitorWarning, stacklevel=2)
        if one:
            stat, phi, valid, nonfin, sing, restarted, alarm = (
                a[0] for a in (stat, phi, valid, nonfin, sing, restarted, alarm)
            )
        return ARMonitorResult(
            statistic=stat,
            alarm=alarm,
            valid=valid,
            coefficients=phi,
            restarted=restarted,
            nonfinite=nonfin,
            singular=sing,
            threshold=self.threshold,
            info={
                "mu": self.mu,
                "delta": self.delta,
                "order": n,
                "window": self.window,
                "coefficient": self.coefficient,
                "pfa": self.pfa,
                "reset_after": self.reset_after,
                "reset_keep": self.reset_keep,
                "prefill": self.prefill,
                "restarts": int(restarted.sum()),
            },
        )

    def _segment(
        self, hist: np.ndarray, xs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
        """Coefficients for the epochs of ``xs`` given the ``hist`` samples before them.

        Returns ``phi (B, c', n)``, ``nonfinite``, ``singular`` (B, c') for the epochs
        ``c - c' .. c - 1`` of the segment whose window is full, and ``c - c'``.
        """
        m, n = self.window, self.order
        z = np.concatenate([hist, xs], axis=-1)
        h, c = hist.shape[-1], xs.shape[-1]
        first = max(m - 1 - h, 0)
        if h + c < m:
            empty = np.zeros((xs.shape[0], 0))
            return np.zeros((*empty.shape, n)), empty.astype(bool), empty.astype(bool), c
        gram, bad = _normal_equations(z, n, m)
        phi, sing = _solve(gram, n, skip=bad)
        return phi, bad, sing, first

    def _run_rows(self, X: np.ndarray, outs: tuple, rows: slice) -> None:
        stat, phi_o, valid, nonfin, sing_o, restarted = outs
        m, k, r = self.window, self.reset_after, self.reset_keep
        B, L = X.shape
        normal = np.broadcast_to(self.normal, (B, m - 1))
        hist = normal.copy() if self.prefill else np.zeros((B, 0))
        c_min = max(4 * (k or 1), 64)
        size = max(_CHUNK_MAX // B, 4 * m) if k is None else c_min  # bounds the memory
        counter = 0
        t = 0
        while t < L:
            c = min(size, L - t)
            xs = X[:, t : t + c]
            phi, bad, sing, first = self._segment(hist, xs)
            lam = self.statistic_of(phi)
            ok = ~bad & ~sing
            alarm = ok & (np.where(ok, lam, 0.0) > self.threshold)
            hit = None
            if k is not None:
                full_alarm = np.zeros(c, dtype=bool)
                full_alarm[first:] = alarm[0]
                runs = _run_lengths(full_alarm, counter)
                hits = np.flatnonzero(runs >= k)
                if hits.size:
                    hit = int(hits[0])
                else:
                    counter = int(runs[-1])
            used = c if hit is None else hit + 1
            nf = max(used - first, 0)
            sl = slice(t + first, t + used)
            stat[rows, sl] = np.where(ok, lam, np.nan)[:, :nf]
            phi_o[rows, sl] = phi[:, :nf]
            valid[rows, sl] = ok[:, :nf]
            nonfin[rows, sl] = bad[:, :nf]
            sing_o[rows, sl] = sing[:, :nf]
            z = np.concatenate([hist, xs[:, :used]], axis=-1)
            if hit is None:
                hist = z[:, -(m - 1) :]
                size = min(2 * size, max(_CHUNK_MAX // B, 4 * m))
            else:
                restarted[rows, t + hit] = True
                kept = z[:, z.shape[1] - r :] if r else z[:, :0]
                hist = np.concatenate([normal[:, r:], kept], axis=-1)
                counter = 0
                size = c_min
            t += used

    # ---------------------------------------------------------------- streaming
    def reset(self) -> None:
        """Start a new stream: empty window (or the stored normal data if ``prefill``)."""
        self._require_fit()
        m, n = self.window, self.order
        self._ring = np.zeros(m + 1)
        self._head = 0  # next write position
        self._fill = 0  # samples in the window (<= m)
        self._nbad = 0
        self._dirty = True
        self._since_refit = 0
        self._removed = 0.0
        self._counter = 0
        self._epoch = 0
        self._was_singular = False
        self._lags = np.arange(n + 1)
        self._rtol = get_rtol(n)
        self._nan_phi = np.full(n, np.nan)
        self._nan_phi.flags.writeable = False
        self._A = np.zeros((n, n))
        self._b = np.zeros(n)
        self.last = None
        if self.prefill:
            self._load(self.normal)
        self._state_ready = True

    def _load(self, samples: np.ndarray) -> None:
        m = self.window
        self._ring[:] = 0.0
        self._ring[: m - 1] = samples
        self._head = m - 1
        self._fill = m - 1
        self._nbad = int(np.count_nonzero(~np.isfinite(samples)))
        self._dirty = True

    def _window(self) -> np.ndarray:
        R = self.window + 1
        return self._ring[(self._head - self._fill + np.arange(self._fill)) % R]

    def update(self, x: float) -> tuple[float, bool]:
        """Process one sample; return ``(statistic, alarm)``.

        ``statistic`` is NaN when no statistic exists (warm-up, non-finite sample in the
        window, rank-deficient regressors); the full outcome is in :attr:`last`
        (:class:`ARStep`).  A non-finite ``x`` is accepted and reported with an
        :class:`ARMonitorWarning`.  The first call after :meth:`fit` or
        :meth:`set_normal` starts a new stream (as :meth:`reset`).
        """
        if isinstance(x, bool | np.bool_) or not isinstance(x, numbers.Real | np.floating):
            try:
                arr = np.asarray(x)
            except (TypeError, ValueError, OverflowError) as exc:
                raise GeomFDIError(
                    f"x: must be one real number, got {x!r:.40}", argument="x"
                ) from exc
            if np.iscomplexobj(arr):
                raise ComplexInputError(f"x: must be real, got {x!r}", argument="x")
            if arr.shape not in ((), (1,)) or arr.dtype.kind not in "iuf":
                raise GeomFDIError(f"x: must be one real number, got {x!r}", argument="x")
            x = arr.reshape(-1)[0]
        try:
            v = float(x)
        except OverflowError as exc:
            raise GeomFDIError("x: a number too large for float64", argument="x") from exc
        if not self._state_ready:
            self.reset()
        m, n = self.window, self.order
        R = m + 1
        was_full = self._fill == m
        self._ring[self._head] = v
        self._head = (self._head + 1) % R
        if was_full:
            dropped = self._ring[self._head]  # X_{t-m}, just left the window
            self._nbad -= 0 if math.isfinite(dropped) else 1
        else:
            self._fill += 1
        if not math.isfinite(v):
            self._nbad += 1
            warnings.warn(
                f"x: non-finite sample {v} at epoch {self._epoch}; the statistics of the next "
                f"{m} epochs are invalid",
                ARMonitorWarning,
                stacklevel=2,
            )
        phi = self._nan_phi
        nonfinite = singular = False
        if self._fill < m:
            self._dirty = True
        elif self._nbad > 0:
            nonfinite = True
            self._dirty = True
        else:
            if self._dirty or self._since_refit >= self.refit_every:
                self._A, self._b = _gram(self._window(), n)
                self._dirty = False
                self._since_refit = 0
                self._removed = 0.0
            else:
                new = self._ring[(self._head - 1 - self._lags) % R]  # X_t .. X_{t-n}
                old = self._ring[(self._head + self._lags) % R]  # X_{t-m} .. X_{t-m+n}
                r_new, y_new = new[1:], new[0]
                r_old, y_old = old[n - 1 :: -1], old[n]
                self._A += r_new[:, None] * r_new - r_old[:, None] * r_old
                self._b += r_new * y_new - r_old * y_old
                self._since_refit += 1
                self._removed += y_old * y_old + r_old @ r_old
                if self._removed > _RISK * self._A.trace():
                    # rows much larger than the window were removed: refit exactly
                    self._A, self._b = _gram(self._window(), n)
                    self._since_refit = 0
                    self._removed = 0.0
            A = self._A
            d = A.diagonal()
            # cheap Gershgorin certificate first; the full rank decision otherwise
            if (2.0 * d - np.abs(A).sum(axis=1)).min() > self._rtol * d.sum():
                singular = False
            else:
                singular = bool(_singular(_dense_gram(A[..., None], A[:, :1])[0], n)[0])
            if not singular:
                phi = np.linalg.solve(A, self._b)
        valid = not (nonfinite or singular or self._fill < m)
        lam = float(((phi[self.coefficient] - self.mu) / self.delta) ** 2) if valid else math.nan
        alarm = bool(valid and lam > self.threshold)
        if singular and not self._was_singular:
            warnings.warn(
                f"x: window ending at epoch {self._epoch} has rank-deficient regressors; "
                "no statistic until it has full rank again",
                ARMonitorWarning,
                stacklevel=2,
            )
        self._was_singular = singular
        restarted = False
        self._counter = self._counter + 1 if alarm else 0
        if self.reset_after is not None and self._counter >= self.reset_after:
            r = self.reset_keep
            w = self._window()
            kept = w[w.size - r :] if r else w[:0]
            self._load(np.concatenate([self.normal[r:], kept]))
            self._counter = 0
            restarted = True
        self.last = ARStep(
            epoch=self._epoch,
            statistic=lam,
            alarm=alarm,
            valid=valid,
            coefficients=phi,
            restarted=restarted,
            nonfinite=nonfinite,
            singular=singular,
        )
        self._epoch += 1
        return lam, alarm


# --------------------------------------------------------------------------------------
# plotting
# --------------------------------------------------------------------------------------


def plot_ar_monitor(
    result: ARMonitorResult,
    *,
    time: Any = None,
    row: int = 0,
    ax: Axes | None = None,
    title: str | None = None,
    label: str | None = None,
    logy: bool = True,
) -> Figure:
    """Plot the statistic ``lambda_t`` against the threshold (paper, Figs. 7 and 8).

    Parameters
    ----------
    result : ARMonitorResult
        Output of :meth:`ARMonitor.run`.
    time : array_like, optional
        Epoch times (default: sample index).
    row : int
        Which stream of a batch result to plot.
    ax : matplotlib Axes, optional
        Draw into these axes (default: a new figure).
    title, label : str, optional
        Axes title and the statistic's legend label.
    logy : bool
        Logarithmic ``lambda`` axis.

    Returns
    -------
    matplotlib.figure.Figure
        Statistic, threshold line, alarms (red dots), restarts of the reset strategy
        (vertical ticks) and invalid epochs (grey band).
    """
    import matplotlib.pyplot as plt

    logy = as_bool(logy, "logy")
    if not isinstance(result, ARMonitorResult):
        raise GeomFDIError("result: expected an ARMonitorResult", argument="result")
    sel = (lambda a: a) if result.statistic.ndim == 1 else (lambda a: a[row])
    lam, alarm, valid, rst = (
        sel(result.statistic),
        sel(result.alarm),
        sel(result.valid),
        sel(result.restarted),
    )
    t = np.arange(lam.size) if time is None else as_real_array(time, "time").reshape(-1)
    if t.size != lam.size:
        raise ShapeError(f"time: expected {lam.size} values, got {t.size}", argument="time")
    if ax is None:
        fig, ax = plt.subplots(figsize=(8, 3.5), layout="constrained")
    else:
        fig = ax.figure
    shown = np.where(valid, np.maximum(lam, 1e-6) if logy else lam, np.nan)
    ax.plot(t, shown, lw=0.9, label=label or r"$\lambda_t$")
    ax.axhline(result.threshold, color="k", ls="--", lw=0.9, label=f"T = {result.threshold:.4g}")
    if np.any(alarm):
        ax.plot(t[alarm], shown[alarm], "r.", ms=3, label="alarm")
    if np.any(rst):
        for tr in t[rst]:
            ax.axvline(tr, color="tab:orange", lw=0.5, alpha=0.6)
        ax.plot([], [], color="tab:orange", lw=0.5, label="restart")
    if np.any(~valid):
        ax.fill_between(
            t, 0, 1, where=~valid, color="0.85", transform=ax.get_xaxis_transform(), lw=0
        )
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel("epoch" if time is None else "time")
    ax.set_ylabel(r"$\lambda$")
    if title:
        ax.set_title(title)
    ax.legend(loc="upper right", fontsize=8)
    return fig
