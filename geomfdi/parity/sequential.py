"""Windowed and sequential parity tests over time: moving-average GLT, CUSUM and SPRT.

Rows of ``Z`` are consecutive samples of one stream (``(N, m)``) or of independent
streams (``(R, N, m)``).  Per-sample tests see a bias of a fraction of ``sigma`` as noise;
accumulating the parity vector over time makes it visible:

* ``"windowed"``: ``FD_w(t) = ||sum_{tau in W_t} q_tau||^2 / (n_t sigma^2)`` over the last
  ``n_t = min(t + 1, window)`` samples, ``chi2(m - n)`` without fault at every epoch, so the
  per-epoch false-alarm rate is exactly ``pfa``; isolation by ``argmax FI`` of the mean.
* ``"cusum"``: per fault hypothesis ``i`` and sign, the log-likelihood-ratio increment of a
  fault of size ``shift * sigma`` on ``i``, ``l_t = +/- nu_i e_i(t) - nu_i^2 / 2`` with
  ``e_i = a_i / sqrt(w_ii)`` and ``nu_i = shift sqrt(w_ii)``, accumulated by Page's CUSUM
  over the last ``window`` samples (window-limited CUSUM, Lai 1998:
  ``S_t = max_{t - window < tau <= t} sum_{tau..t} l``); statistic
  ``max_{i,+/-} S_t``.
* ``"sprt"``: Wald's sequential probability ratio test of every hypothesis on the same
  increments, cumulative from the last restart, with the boundaries ``A`` and
  ``B = log(beta / (1 - alpha))``, restarted after accepting "no fault" and after every
  alarm (repeated testing); in :mod:`~geomfdi.parity.sprt`, ``A`` calibrated for the
  per-epoch rate ``pfa`` by simulation;
* ``"sprt-window"``: the window-limited variant, the same recursion run over the last
  ``window`` samples only, with no upper boundary (alarm when the ratio at ``t`` is
  above the threshold).

``"cusum"`` and ``"sprt-window"`` depend on the last ``window`` samples only, so without
fault the statistic has the same law at every epoch from ``window - 1`` on.  Its threshold
has no closed form: :func:`calibrate_sequential` draws independent noise-only blocks of
``window`` samples of the same model and takes the ``1 - pfa`` quantile (a binomial
estimate of the per-epoch rate); the result is cached on the
:class:`~geomfdi.parity.model.ParityFDI`.
See the user guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from geomfdi._validation import as_int, as_positive, as_probability
from geomfdi.errors import GeomFDIError
from geomfdi.parity import sprt as _sprt
from geomfdi.parity._increments import _llr, _series, _standardised
from geomfdi.parity._input import _as_rng
from geomfdi.parity._records import ParityData, as_data
from geomfdi.parity.results import ParityDiagnosis
from geomfdi.parity.thresholds import chi2_threshold

if TYPE_CHECKING:
    from geomfdi.parity._records import HasParityData

__all__ = [
    "SEQUENTIAL_METHODS",
    "windowed_statistic",
    "cusum_statistic",
    "window_sprt_statistic",
    "calibrate_sequential",
    "diagnose_sequential",
]

SEQUENTIAL_METHODS = ("windowed", "cusum", "sprt", "sprt-window")
"""Time-series rules accepted by :meth:`ParityFDI.diagnose`."""


def windowed_statistic(
    pf: ParityData | HasParityData, Z: Any, window: int
) -> tuple[np.ndarray, np.ndarray]:
    """Moving-average GLT ``FD_w`` and the isolation functions of the window mean.

    Parameters
    ----------
    pf : ParityFDI
    Z : array_like, (N, m) or (R, N, m)
        Consecutive samples.
    window : int
        Number of samples averaged (``>= 1``; 1 is the per-sample GLT).

    Returns
    -------
    fd : ndarray, (R, N)
        ``||S_t||^2 / n_t`` with ``S_t`` the sum of the whitened parity vectors
        ``q / sigma`` over the last ``n_t = min(t + 1, window)`` samples; ``chi2(m - n)``
        at every epoch without fault.
    fi : ndarray, (R, N, k)
        ``FI_i = E_i(t)^2 / n_t``, ``E`` the windowed sum of ``e_i``.
    """
    pf = as_data(pf)
    window = as_int(window, "window", minimum=1)
    X = _series(pf, Z)
    P = X @ (pf.T.T / pf.sigma)
    E = _standardised(pf, X)
    n_t = np.minimum(np.arange(1, X.shape[1] + 1), window).astype(float)
    Ps, Es = _moving_sum(P, window), _moving_sum(E, window)
    fd = np.einsum("rts,rts->rt", Ps, Ps) / n_t
    fi = Es**2 / n_t[:, None]
    return fd, fi


def _moving_sum(X: np.ndarray, w: int) -> np.ndarray:
    """Sum of the last ``min(t + 1, w)`` rows along axis 1 (cumulative sums)."""
    C = np.cumsum(X, axis=1)
    out = C.copy()
    if w < X.shape[1]:
        out[:, w:] -= C[:, :-w]
    return out


def cusum_statistic(
    pf: ParityData | HasParityData, Z: Any, shift: float = 0.5, window: int = 100
) -> tuple[np.ndarray, np.ndarray]:
    """Window-limited CUSUM per fault hypothesis and sign.

    Parameters
    ----------
    shift : float
        Design fault size in units of ``sigma`` (the bias the test is tuned to).
    window : int
        Memory: change times in the last ``window`` samples are considered.

    Returns
    -------
    stat : ndarray, (R, N)
        ``max_{i, +/-} S_t`` with ``S_t = C_{t+1} - min_{t+1-window <= j <= t+1} C_j``,
        ``C`` the cumulative sum of the increments (``C_0 = 0``): Page's CUSUM restricted
        to the window, without a loop over time.
    best : ndarray of int, (R, N)
        The hypothesis attaining it.
    """
    pf = as_data(pf)
    from scipy.ndimage import minimum_filter1d

    shift = as_positive(shift, "shift")
    window = as_int(window, "window", minimum=1)
    X = _series(pf, Z)
    inc = _llr(pf, X, shift)
    R, N, K = inc.shape
    C = np.zeros((R, N + 1 + window, K))
    C[:, :window] = np.inf  # before the stream: not a change time
    np.cumsum(inc, axis=1, out=C[:, window + 1 :])
    # trailing minimum over window + 1 entries (van Herk / Gil-Werman, O(N))
    low = minimum_filter1d(C, window + 1, axis=1, origin=window // 2)
    S = C[:, window + 1 :] - low[:, window + 1 :]
    j = np.argmax(S, axis=-1)
    return np.take_along_axis(S, j[..., None], axis=-1)[..., 0], j % pf.k


def window_sprt_statistic(
    pf: ParityData | HasParityData, Z: Any, shift: float = 0.5, beta: float = 0.1, window: int = 100
) -> tuple[np.ndarray, np.ndarray]:
    """Window-limited restart SPRT: the log-likelihood ratio over the last ``window`` samples.

    For each epoch ``t`` the test starts at ``t - window + 1`` with ratio 0, adds the
    increments ``l`` and restarts at 0 whenever the ratio falls to ``log beta`` (it
    accepts "no fault"; ``beta`` is Wald's missed-detection probability of one cycle).
    Unlike Wald's repeated SPRT (:mod:`~geomfdi.parity.sprt`, method ``"sprt"``) it has no
    upper boundary and no restart after an alarm: its finite memory gives the statistic
    the same law at every epoch, so a plain quantile sets its threshold (method
    ``"sprt-window"``).

    Returns
    -------
    stat, best : ndarray, (R, N)
        ``max_{i, +/-}`` of the ratio at ``t`` and the hypothesis attaining it.
    """
    pf = as_data(pf)
    shift = as_positive(shift, "shift")
    beta = as_probability(beta, "beta")
    window = as_int(window, "window", minimum=1)
    X = _series(pf, Z)
    inc = _llr(pf, X, shift)
    R, N, K = inc.shape
    padded = np.concatenate([np.zeros((R, window - 1, K)), inc], axis=1)
    lower = math.log(beta)
    S = np.zeros((R, N, K))
    for lag in range(window):  # vectorised over epochs: one pass per position in the window
        S += padded[:, lag : lag + N]
        S[S <= lower] = 0.0
    j = np.argmax(S, axis=-1)
    return np.take_along_axis(S, j[..., None], axis=-1)[..., 0], j % pf.k


def _stat(pf: ParityData, Z: Any, method: str, opts: dict) -> tuple[np.ndarray, np.ndarray]:
    if method == "cusum":
        return cusum_statistic(pf, Z, opts["shift"], opts["window"])
    return window_sprt_statistic(pf, Z, opts["shift"], opts["beta"], opts["window"])


def calibrate_sequential(
    pf: ParityData | HasParityData,
    method: str,
    pfa: float,
    *,
    shift: float = 0.5,
    beta: float = 0.1,
    window: int = 100,
    n_blocks: int | None = None,
    rng: Any = 0,
) -> float:
    """Threshold of the window-limited CUSUM or SPRT with per-epoch false-alarm rate ``pfa``.

    ``method`` is ``"cusum"`` or ``"sprt-window"``; Wald's repeated SPRT (``"sprt"``) is
    calibrated by :func:`geomfdi.parity.sprt.calibrate_sprt`.

    Draws ``n_blocks`` (default ``min(100000, 2e7 / window)``, bounding the work)
    independent noise-only blocks of ``window`` samples of the model;
    the statistic at the last epoch of each block has the law of the statistic at any
    epoch ``t >= window - 1`` of a fault-free stream.  Returns the ``1 - pfa`` quantile:
    the realised rate has the binomial standard error ``sqrt(pfa (1 - pfa) / n_blocks)``.

    Returns
    -------
    float
        The threshold ``h``: ``P(stat_t > h) = pfa`` without fault.
    """
    pf = as_data(pf)
    if method not in ("cusum", "sprt-window"):
        raise GeomFDIError(f"method: 'cusum' or 'sprt-window', got {method!r}", argument="method")
    pfa = as_probability(pfa, "pfa")
    window = as_int(window, "window", minimum=1)
    if n_blocks is None:
        n_blocks = max(1000, min(100_000, 20_000_000 // window))
    n_blocks = as_int(n_blocks, "n_blocks", minimum=1)
    gen = _as_rng(rng)
    opts = {
        "shift": as_positive(shift, "shift"),
        "beta": as_probability(beta, "beta"),
        "window": as_int(window, "window", minimum=1),
    }
    q = pf.m if pf.F is None else pf.F.shape[1]
    chunk = max(1, (1 << 22) // (opts["window"] * q))
    pool = []
    for start in range(0, n_blocks, chunk):
        r = min(chunk, n_blocks - start)
        Z = gen.standard_normal((r, opts["window"], q)) * pf.sigma
        if pf.F is not None:
            Z = Z @ pf.F.T
        pool.append(_last_epoch(pf, Z, method, opts))
    return float(np.quantile(np.concatenate(pool), 1.0 - pfa))


def _last_epoch(pf: ParityData, Z: np.ndarray, method: str, opts: dict) -> np.ndarray:
    """The statistic at the last epoch of each stream of ``Z`` (R, window, m)."""
    inc = _llr(pf, Z, opts["shift"])
    if method == "cusum":
        C = np.cumsum(inc, axis=1)
        return (C[:, -1] - np.minimum(C.min(axis=1), 0.0)).max(axis=-1)
    S = np.zeros(inc.shape[::2])
    lower = math.log(opts["beta"])
    for t in range(inc.shape[1]):
        S += inc[:, t]
        S[S <= lower] = 0.0
    return S.max(axis=-1)


def diagnose_sequential(
    pf: ParityData | HasParityData,
    Z: Any,
    pfa: float,
    method: str,
    *,
    window: int = 100,
    shift: float = 0.5,
    beta: float = 0.1,
    threshold: float | None = None,
) -> ParityDiagnosis:
    """Per-epoch detection and isolation on a time series; see :meth:`ParityFDI.diagnose`.

    Returns
    -------
    ParityDiagnosis
        Arrays of shape ``(N,)`` for one stream or ``(R, N)`` for a batch (``faults``
        ``(..., 1)``); ``threshold`` is exact (windowed) or calibrated (cusum, sprt).
    """
    pf = as_data(pf)
    pfa = as_probability(pfa, "pfa")
    info: dict = {}
    if method == "windowed":
        fd, fi = windowed_statistic(pf, Z, window)
        thr = chi2_threshold(pfa, pf.s) if threshold is None else float(threshold)
        stat, best = fd, np.argmax(fi, axis=-1)
        det = stat >= thr
    elif method in ("cusum", "sprt-window"):
        opts = {
            "shift": as_positive(shift, "shift"),
            "beta": as_probability(beta, "beta"),
            "window": as_int(window, "window", minimum=1),
        }
        if threshold is None:
            key = (method, pfa, opts["shift"], opts["beta"], opts["window"])
            if key not in pf.sequential_thresholds:
                pf.sequential_thresholds[key] = calibrate_sequential(
                    pf, method, pfa, shift=opts["shift"], beta=opts["beta"], window=opts["window"]
                )
            thr = pf.sequential_thresholds[key]
        else:
            thr = float(threshold)
        stat, best = _stat(pf, Z, method, opts)
        det = stat > thr
    elif method == "sprt":
        shift = as_positive(shift, "shift")
        beta = as_probability(beta, "beta")
        if threshold is None:
            key = (method, pfa, shift, beta)
            if key not in pf.sequential_thresholds:
                pf.sequential_thresholds[key] = _sprt.calibrate_sprt(
                    pf, pfa, shift=shift, beta=beta
                )
            cal = pf.sequential_thresholds[key]
            thr, info = cal.upper, cal.as_dict()
        else:
            thr = float(as_positive(threshold, "threshold"))
            info = {"upper": thr, "lower": _sprt._lower_for(thr, beta)}
        stat, det, best = _sprt.sprt_statistic(pf, Z, thr, shift=shift, beta=beta)
    else:
        raise GeomFDIError(
            f"method: expected one of {', '.join(SEQUENTIAL_METHODS)}, got {method!r}",
            argument="method",
        )
    iso = np.where(det, pf.lut[best], -1)
    one = np.ndim(Z) == 2
    if one:
        det, iso, stat = det[0], iso[0], stat[0]
    return ParityDiagnosis(det, iso[..., None], stat, thr, method, pfa, info=info)
