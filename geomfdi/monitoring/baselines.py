"""Baselines on the same innovations as the AR monitor, and alarm latching.

* :func:`innovation_chi2` -- the normalised innovation squared, ``(x_t / sigma)^2``
  against ``chi2_{1-pfa}(1)``: the textbook innovation test;
* :func:`innovation_cusum` -- two-sided CUSUM of ``x / sigma`` tuned to a mean shift of
  ``shift * sigma``, limited to the last ``window`` samples;
* :func:`innovation_glr` -- generalised likelihood ratio of a mean jump at an unknown time
  in the last ``window`` samples, ``max_k (sum of the last k x / sigma)^2 / k``;
* :func:`coefficient_t2` -- Hotelling's joint ``T^2`` of all AR coefficients
  ``(phi_1 ... phi_n)`` of an :class:`~geomfdi.monitoring.monitor.ARMonitor` run;
* :func:`latch_alarms` -- keep an alarm raised for ``hold`` epochs (or for good), the
  simple alternative to the reset strategy for a persistent indication.

The CUSUM and GLR depend on the last ``window`` samples only; their thresholds are the
``1 - pfa`` quantiles of the statistic on independent noise-only blocks (Monte-Carlo,
binomial error ``sqrt(pfa (1 - pfa) / n_blocks)`` on the per-epoch rate).  See the user
guide, *Theory: AR monitoring* (``docs/theory/ar-monitoring.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from geomfdi._validation import as_int, as_positive, as_probability, as_real_array
from geomfdi.errors import GeomFDIError, ShapeError

if TYPE_CHECKING:
    from geomfdi.monitoring.monitor import ARMonitor
    from geomfdi.monitoring.results import ARMonitorResult

__all__ = [
    "BaselineResult",
    "innovation_chi2",
    "innovation_cusum",
    "innovation_glr",
    "coefficient_t2",
    "latch_alarms",
]


@dataclass(frozen=True)
class BaselineResult:
    """Per-epoch statistic, alarms and threshold of a baseline test.

    Attributes
    ----------
    statistic : ndarray, (L,) or (B, L)
    alarm : ndarray of bool
        ``statistic > threshold``.
    threshold : float
    pfa : float
        Per-epoch false-alarm rate the threshold was computed (or calibrated) for.
    method : str
    info : dict
        Options (``sigma``, ``shift``, ``window``...).
    """

    statistic: np.ndarray
    alarm: np.ndarray
    threshold: float
    pfa: float
    method: str
    info: dict = field(default_factory=dict)


def _stream(x: Any) -> np.ndarray:
    arr = as_real_array(x, "x")
    if arr.ndim not in (1, 2) or arr.shape[-1] == 0:
        raise ShapeError(
            f"x: expected a 1-D stream or a 2-D array of streams, got shape {arr.shape}",
            argument="x",
        )
    return arr


def innovation_chi2(x: Any, sigma: float, pfa: float = 1e-4) -> BaselineResult:
    """Normalised innovation squared ``(x_t / sigma)^2`` against ``chi2_{1-pfa}(1)``.

    Exact per-epoch false-alarm rate ``pfa`` for ``N(0, sigma^2)`` innovations.

    Examples
    --------
    >>> import geomfdi as gf
    >>> x = gf.synthetic_innovations(300, fault="step", size=5, start=200, rng=0)
    >>> res = gf.monitoring.baselines.innovation_chi2(x, sigma=6.0)
    >>> round(res.threshold, 4), bool(res.alarm[:200].any()), float(res.alarm[200:].mean()) > 0.5
    (15.1367, False, True)
    """
    from scipy import stats

    X = _stream(x)
    sigma = as_positive(sigma, "sigma")
    pfa = as_probability(pfa, "pfa")
    thr = float(stats.chi2.isf(pfa, 1))
    stat = (X / sigma) ** 2
    return BaselineResult(stat, stat > thr, thr, pfa, "chi2", {"sigma": sigma})


def _cusum_last(z: np.ndarray, shift: float) -> np.ndarray:
    inc = np.stack([shift * z, -shift * z], axis=-1) - 0.5 * shift**2
    C = np.cumsum(inc, axis=-2)
    return (C[..., -1, :] - np.minimum(C.min(axis=-2), 0.0)).max(axis=-1)


def _cusum(z: np.ndarray, shift: float, window: int) -> np.ndarray:
    from scipy.ndimage import minimum_filter1d

    inc = np.stack([shift * z, -shift * z], axis=-1) - 0.5 * shift**2  # (B, L, 2)
    B, L, _ = inc.shape
    C = np.zeros((B, L + 1 + window, 2))
    C[:, :window] = np.inf
    np.cumsum(inc, axis=1, out=C[:, window + 1 :])
    low = minimum_filter1d(C, window + 1, axis=1, origin=window // 2)
    return (C[:, window + 1 :] - low[:, window + 1 :]).max(axis=-1)


def _glr(z: np.ndarray, window: int) -> np.ndarray:
    """``max_{1<=k<=min(window, t+1)} (sum of the last k z)^2 / k`` for every epoch."""
    B, L = z.shape
    C = np.concatenate([np.zeros((B, 1)), np.cumsum(z, axis=1)], axis=1)
    out = np.zeros((B, L))
    for k in range(1, min(window, L) + 1):  # one vectorised pass per lag
        S = C[:, k:] - C[:, :-k]  # sums of k samples ending at epochs k-1 .. L-1
        np.maximum(out[:, k - 1 :], S * S / k, out=out[:, k - 1 :])
    return out


def _glr_last(z: np.ndarray) -> np.ndarray:
    """:func:`_glr` at the last epoch of each block (all lags of the block)."""
    S = np.cumsum(z[:, ::-1], axis=1)
    return (S * S / np.arange(1, z.shape[1] + 1)).max(axis=1)


def _calibrate(fn: Any, window: int, pfa: float, n_blocks: int, rng: Any) -> float:
    gen = np.random.default_rng(rng)
    chunk = max(1, (1 << 21) // window)
    pool = []
    for start in range(0, n_blocks, chunk):
        r = min(chunk, n_blocks - start)
        pool.append(fn(gen.standard_normal((r, window))))
    return float(np.quantile(np.concatenate(pool), 1.0 - pfa))


def innovation_cusum(
    x: Any,
    sigma: float,
    pfa: float = 1e-4,
    *,
    shift: float = 1.0,
    window: int = 60,
    threshold: float | None = None,
    n_blocks: int = 200_000,
    rng: Any = 0,
) -> BaselineResult:
    """Two-sided window-limited CUSUM of ``x / sigma`` for a mean shift ``shift * sigma``.

    ``S_t = max over change times in the last window of sum (+/- shift z - shift^2 / 2)``;
    the threshold is calibrated for the per-epoch rate ``pfa`` unless given.
    """
    X = _stream(x)
    sigma = as_positive(sigma, "sigma")
    pfa = as_probability(pfa, "pfa")
    shift = as_positive(shift, "shift")
    window = as_int(window, "window", minimum=1)
    if threshold is None:
        thr = _calibrate(lambda z: _cusum_last(z, shift), window, pfa, n_blocks, rng)
    else:
        thr = float(as_positive(threshold, "threshold"))
    Z = np.atleast_2d(X) / sigma
    stat = _cusum(Z, shift, window).reshape(X.shape)
    info = {"sigma": sigma, "shift": shift, "window": window}
    return BaselineResult(stat, stat > thr, thr, pfa, "cusum", info)


def innovation_glr(
    x: Any,
    sigma: float,
    pfa: float = 1e-4,
    *,
    window: int = 60,
    threshold: float | None = None,
    n_blocks: int = 200_000,
    rng: Any = 0,
) -> BaselineResult:
    """GLR of a jump of the innovation mean at an unknown time in the last ``window``.

    ``g_t = max_{1 <= k <= window} (sum_{tau=t-k+1}^{t} x_tau / sigma)^2 / k``; the
    threshold is calibrated for the per-epoch rate ``pfa`` unless given.
    """
    X = _stream(x)
    sigma = as_positive(sigma, "sigma")
    pfa = as_probability(pfa, "pfa")
    window = as_int(window, "window", minimum=1)
    if threshold is None:
        thr = _calibrate(_glr_last, window, pfa, n_blocks, rng)
    else:
        thr = float(as_positive(threshold, "threshold"))
    stat = _glr(np.atleast_2d(X) / sigma, window).reshape(X.shape)
    return BaselineResult(stat, stat > thr, thr, pfa, "glr", {"sigma": sigma, "window": window})


def coefficient_t2(
    monitor: ARMonitor, result: ARMonitorResult, pfa: float = 1e-4
) -> BaselineResult:
    """Hotelling's ``T^2`` of all AR coefficients against their training distribution.

    ``T^2 = (phi - mean)^T S^{-1} (phi - mean)`` with the mean and covariance ``S`` of the
    ``N`` training windows' coefficients; for a new window of the same law
    ``T^2 (N - n) N / (n (N - 1) (N + 1)) ~ F(n, N - n)``, which sets the threshold.
    Invalid epochs of ``result`` get NaN and no alarm.
    """
    from scipy import stats

    pfa = as_probability(pfa, "pfa")
    if monitor.training_coefficients is None:
        raise GeomFDIError("monitor: train it with fit() first", argument="monitor")
    P = monitor.training_coefficients
    N, n = P.shape
    if N <= n + 1:
        raise GeomFDIError(
            f"monitor: T^2 needs more than {n + 1} training windows, got {N}", argument="monitor"
        )
    mean = P.mean(axis=0)
    S = np.cov(P.T).reshape(n, n)
    d = np.asarray(result.coefficients) - mean
    with np.errstate(invalid="ignore"):
        t2 = np.einsum("...i,ij,...j->...", d, np.linalg.inv(S), d)
    thr = float(n * (N - 1) * (N + 1) / (N * (N - n)) * stats.f.isf(pfa, n, N - n))
    t2 = np.where(result.valid, t2, np.nan)
    return BaselineResult(t2, result.valid & (np.nan_to_num(t2) > thr), thr, pfa, "t2")


def latch_alarms(alarm: Any, hold: int | None = None) -> np.ndarray:
    """Alarms held for ``hold`` epochs after each raised alarm (``None``: for good).

    Parameters
    ----------
    alarm : array_like of bool, (L,) or (B, L)
    hold : int, optional
        Epochs an alarm stays on after the last raw alarm (0: unchanged).

    Returns
    -------
    ndarray of bool
        Latched alarms.  Latching keeps a persistent fault indicated after the AR
        statistic has died out, at the price of also holding false alarms and alarms of
        faults that have ended.
    """
    a = np.asarray(alarm)
    if a.dtype != bool:
        raise GeomFDIError("alarm: expected a boolean array", argument="alarm")
    if hold is None:
        return np.logical_or.accumulate(a, axis=-1)
    hold = as_int(hold, "hold", minimum=0)
    idx = np.arange(a.shape[-1])
    last = np.maximum.accumulate(np.where(a, idx, -(hold + 1)), axis=-1)
    return idx - last <= hold
