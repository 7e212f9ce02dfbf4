"""Baselines on the same innovations as the AR monitor, and alarm latching.

* :func:`innovation_chi2` -- the normalised innovation squared, ``(x_t / sigma)^2``
  against ``chi2_{1-pfa}(1)``: the textbook innovation test;
* :func:`innovation_cusum` -- two-sided CUSUM of ``x / sigma`` tuned to a mean shift of
  ``shift * sigma``, limited to the last ``window`` samples;
* :func:`innovation_glr` -- generalised likelihood ratio of a mean jump at an unknown time
  in the last ``window`` samples, ``max_k (sum of the last k x / sigma)^2 / k``;
* :func:`coefficient_t2` -- Hotelling's joint ``T^2`` of all AR coefficients
  ``(phi_1 ... phi_n)`` of an :class:`~geomfdi.monitoring.monitor.ARMonitor` run, its
  threshold calibrated by a parametric bootstrap from the fitted null model;
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


def _t2_of(P: np.ndarray, mean: np.ndarray, S_inv: np.ndarray) -> np.ndarray:
    d = P - mean
    with np.errstate(invalid="ignore"):
        return np.einsum("...i,ij,...j->...", d, S_inv, d)


def _t2_bootstrap(
    monitor: ARMonitor, mean: np.ndarray, S_inv: np.ndarray, n_draws: int, rng: Any
) -> np.ndarray:
    """``T^2`` of ``n_draws`` windows simulated from the fitted null model (finite ones)."""
    from geomfdi.monitoring._kernels import _rows_fit
    from geomfdi.monitoring.innovations import synthetic_innovations

    phi0 = monitor.training_model
    if phi0 is None:
        raise GeomFDIError("monitor: train it with fit() first", argument="monitor")
    gen = np.random.default_rng(rng)
    chunk = 50_000
    pool = []
    try:
        for start in range(0, n_draws, chunk):
            r = min(chunk, n_draws - start)
            W = synthetic_innovations(monitor.window, sigma=1.0, ar=phi0, n_series=r, rng=gen)
            phi, _ = _rows_fit(W, monitor.order)
            t2 = _t2_of(phi, mean, S_inv)
            pool.append(t2[np.isfinite(t2)])
    except GeomFDIError as exc:  # a non-stationary pooled fit cannot be simulated
        raise GeomFDIError(
            f"monitor: the pooled AR fit of the training data cannot serve as null model ({exc})",
            argument="monitor",
        ) from exc
    return np.concatenate(pool)


def coefficient_t2(
    monitor: ARMonitor,
    result: ARMonitorResult,
    pfa: float = 1e-4,
    *,
    null: str = "bootstrap",
    n_draws: int | None = None,
    rng: int | None = 0,
) -> BaselineResult:
    """Hotelling's ``T^2`` of all AR coefficients against their training distribution.

    ``T^2 = (phi - mean)^T S^{-1} (phi - mean)`` with the mean and covariance ``S`` of the
    ``N`` training windows' least-squares coefficients ``(phi_1 ... phi_n)``.

    Parameters
    ----------
    monitor : ARMonitor
        Trained monitor (its training coefficients and pooled fit are used).
    result : ARMonitorResult
        A run of ``monitor``; its per-epoch coefficients are tested.
    pfa : float
        Per-epoch false-alarm rate the threshold is set for.
    null : {"bootstrap", "hotelling"}
        How the threshold is obtained (see Notes).  ``"bootstrap"`` (default): the
        ``1 - pfa`` quantile of ``T^2`` over ``n_draws`` windows simulated from the fitted
        null model.  ``"hotelling"``: Hotelling's law of a new observation,
        ``T^2 N (N - n) / (n (N - 1) (N + 1)) ~ F(n, N - n)``, which assumes Gaussian
        coefficient vectors and is optimistic here.
    n_draws : int, optional
        Number of simulated windows (default ``max(100_000, 50 / pfa)``).
    rng : int, optional
        Seed of the simulation (default 0); the simulated ``T^2`` sample is cached on the
        monitor per ``(n_draws, rng)`` until it is trained again (``None``: fresh
        entropy, not cached).

    Returns
    -------
    BaselineResult
        ``info`` holds ``null``, ``n_draws``, ``rng`` and ``calibration_se =
        sqrt(pfa (1 - pfa) / n_draws)``, the Monte-Carlo standard error of the rate the
        bootstrap threshold realises (0 for ``"hotelling"``).  Invalid epochs of
        ``result`` get NaN and no alarm.

    Notes
    -----
    The window estimate ``phi_hat`` has, given the window's regressors ``R``, covariance
    ``sigma^2 (R^T R)^{-1}``: it changes from window to window, so ``phi_hat`` is a scale
    mixture of normals with heavier tails than the Gaussian law behind Hotelling's ``F``
    distribution, and the least-squares estimate is biased by ``O(1 / m)``.  For AR(5) on
    60-sample windows of AR(1) innovations (``a = -0.3``) and ``N = 2000`` training
    windows, the ``F`` threshold realises about 0.017 at ``pfa = 0.01`` and 0.004 at
    ``0.001`` (10^5 fresh windows); no closed form accounts for the mixture, so the
    default calibrates the threshold by a parametric bootstrap: windows of the stationary
    Gaussian AR process with the coefficients of one least-squares fit pooled over all
    training data (:attr:`ARMonitor.training_model`; the coefficients do not depend on
    the innovations' scale, so its variance is not needed) are fitted like the monitored
    ones and their ``T^2`` computed against the *same* training mean and covariance.
    The threshold is therefore calibrated conditionally on the training set, whose own
    estimation error (a few per cent on ``S`` for ``N = 2000``) would otherwise move the
    realised rate by more than the binomial error of a 10^4-sample check.  The residual
    error is the Monte-Carlo one (``calibration_se``) plus the pooled fit's error, which
    is of order ``1 / sqrt(N (m - n))`` on the coefficients.  Overlapping windows give
    serially correlated statistics; that changes the burst structure of the alarms, not
    the per-epoch rate.  See the user guide, *Theory: AR monitoring*
    (``docs/theory/ar-monitoring.md``).
    """
    from scipy import stats

    pfa = as_probability(pfa, "pfa")
    if null not in ("bootstrap", "hotelling"):
        raise GeomFDIError(
            f"null: expected 'bootstrap' or 'hotelling', got {null!r}", argument="null"
        )
    if monitor.training_coefficients is None:
        raise GeomFDIError("monitor: train it with fit() first", argument="monitor")
    P = monitor.training_coefficients
    N, n = P.shape
    if N <= n + 1:
        raise GeomFDIError(
            f"monitor: T^2 needs more than {n + 1} training windows, got {N}", argument="monitor"
        )
    mean = P.mean(axis=0)
    S_inv = np.linalg.inv(np.cov(P.T).reshape(n, n))
    t2 = _t2_of(np.asarray(result.coefficients), mean, S_inv)
    if null == "hotelling":
        thr = float(n * (N - 1) * (N + 1) / (N * (N - n)) * stats.f.isf(pfa, n, N - n))
        info: dict = {"null": null, "n_draws": 0, "rng": None, "calibration_se": 0.0}
    else:
        draws = (
            max(100_000, int(np.ceil(50 / pfa)))
            if n_draws is None
            else as_int(n_draws, "n_draws", minimum=1000)
        )
        if rng is not None and not isinstance(rng, int | np.integer):
            raise GeomFDIError(f"rng: expected an integer seed, got {rng!r}", argument="rng")
        key = (draws, None if rng is None else int(rng))
        sample = monitor._t2_null.get(key) if rng is not None else None
        if sample is None:
            sample = _t2_bootstrap(monitor, mean, S_inv, draws, rng)
            if rng is not None:
                monitor._t2_null[key] = sample
        thr = float(np.quantile(sample, 1.0 - pfa))
        se = float(np.sqrt(pfa * (1 - pfa) / draws))
        info = {"null": null, "n_draws": draws, "rng": rng, "calibration_se": se}
    t2 = np.where(result.valid, t2, np.nan)
    return BaselineResult(t2, result.valid & (np.nan_to_num(t2) > thr), thr, pfa, "t2", info)


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
    try:
        a = np.asarray(alarm) if not isinstance(alarm, bool | np.bool_) else None
    except ValueError:  # ragged
        a = None
    if a is None or a.dtype != bool or a.ndim not in (1, 2):
        raise GeomFDIError("alarm: expected a boolean array (L,) or (B, L)", argument="alarm")
    if hold is None:
        return np.logical_or.accumulate(a, axis=-1)
    hold = as_int(hold, "hold", minimum=0)
    idx = np.arange(a.shape[-1])
    last = np.maximum.accumulate(np.where(a, idx, -(hold + 1)), axis=-1)
    return idx - last <= hold
