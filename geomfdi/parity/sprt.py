"""Wald's sequential probability ratio test on the parity vector, repeated with restarts.

For each fault hypothesis (sensor ``i``, sign ``+/-``) the cumulative log-likelihood ratio
of a bias of ``shift * sigma`` on sensor ``i`` against no fault,

    S_t = S_{t-1} + l_t,        l_t = +/- nu_i e_i(t) - nu_i^2 / 2,   S_{-1} = 0,

(``e_i`` the standardised isolation residual, ``nu_i = shift sqrt(w_ii)``) is compared
with Wald's boundaries

    A = log((1 - beta) / alpha),        B = log(beta / (1 - alpha)):

``S_t <= B`` accepts "no fault on this hypothesis" and that hypothesis restarts from 0;
``max_hypotheses S_t >= A`` raises an alarm (isolating the hypothesis attaining the
maximum) and every hypothesis of the stream restarts from 0 -- repeated testing, the
standard sequential detection form (with ``B = 0^-`` it is Page's CUSUM).  The restarts
make the fault-free alarm sequence a renewal process: the per-epoch false-alarm rate is
``1 / ARL_0``, the inverse of the mean time between false alarms.

Wald's approximations (no overshoot) for one hypothesis give the probability that a cycle
ends in an alarm, ``P_A = (1 - e^B) / (e^A - e^B)``, the mean cycle length
``E_0 N = (P_A A + (1 - P_A) B) / (-nu^2 / 2)`` and the rate ``P_A / E_0 N``
(:func:`wald_rate`); the overshoot of the boundaries and the union over the ``2k``
correlated hypotheses make it only a guide.  The threshold ``A`` for a requested
per-epoch rate is therefore calibrated (:func:`calibrate_sprt`) by simulating fault-free
streams of the model and searching ``A`` with common random numbers.  See the user
guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from geomfdi._validation import as_int, as_positive, as_probability
from geomfdi.errors import GeomFDIError
from geomfdi.parity._increments import _llr, _series
from geomfdi.parity._input import _as_rng
from geomfdi.parity._records import ParityData, as_data

if TYPE_CHECKING:
    from geomfdi.parity._records import HasParityData

__all__ = ["wald_boundaries", "wald_rate", "sprt_run", "calibrate_sprt", "SprtCalibration"]

#: Epochs dropped at the start of each calibration stream (the renewal density settles).
_BURN_IN = 50


def wald_boundaries(alpha: float, beta: float) -> tuple[float, float]:
    """Wald's SPRT boundaries ``A = log((1 - beta) / alpha)``, ``B = log(beta / (1 - alpha))``.

    Parameters
    ----------
    alpha, beta : float
        Per-cycle probabilities of a false alarm and of a missed detection
        (``alpha + beta < 1``).
    """
    alpha = as_probability(alpha, "alpha")
    beta = as_probability(beta, "beta")
    if alpha + beta >= 1.0:
        raise GeomFDIError(f"beta: alpha + beta must be < 1, got {alpha + beta:g}", argument="beta")
    return math.log((1.0 - beta) / alpha), math.log(beta / (1.0 - alpha))


def wald_rate(upper: float, lower: float, nu: float) -> float:
    """Wald's approximate per-epoch false-alarm rate of one repeated SPRT.

    ``P_A = (1 - e^B) / (e^A - e^B)`` (from ``E_0 exp(S_N) = 1``),
    ``E_0 N = (P_A A + (1 - P_A) B) / (-nu^2 / 2)`` (Wald's identity) and the renewal rate
    ``P_A / E_0 N``; exact up to the overshoot of the boundaries, which makes the true
    ``P_A`` smaller and ``E_0 N`` larger.
    """
    upper, lower, nu = float(upper), float(lower), float(nu)
    if not (lower < 0.0 < upper) or not nu > 0:
        raise GeomFDIError("upper, lower: need lower < 0 < upper and nu > 0", argument="upper")
    pa = (1.0 - math.exp(lower)) / (math.exp(upper) - math.exp(lower))
    en = (pa * upper + (1.0 - pa) * lower) / (-0.5 * nu * nu)
    return pa / en


def sprt_run(
    increments: np.ndarray, upper: float, lower: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the repeated SPRT on log-likelihood-ratio increments ``(R, N, K)``.

    One pass over time, vectorised over streams and hypotheses (the restarts make the
    recursion sequential).

    Returns
    -------
    stat : ndarray, (R, N)
        ``max_k S_t`` before any restart at ``t``.
    alarm : ndarray of bool, (R, N)
        ``stat >= upper``; after it every hypothesis of the stream restarts at 0.
    best : ndarray of int, (R, N)
        Hypothesis attaining ``stat``.
    """
    R, N, K = increments.shape
    S = np.zeros((R, K))
    stat = np.empty((R, N))
    best = np.empty((R, N), dtype=np.intp)
    rows = np.arange(R)
    for t in range(N):
        S += increments[:, t]
        j = S.argmax(axis=1)
        v = S[rows, j]
        stat[:, t], best[:, t] = v, j
        S[v >= upper] = 0.0
        S[S <= lower] = 0.0
    return stat, stat >= upper, best


@dataclass(frozen=True)
class SprtCalibration:
    """Threshold ``A`` of the repeated SPRT for a per-epoch false-alarm rate.

    Attributes
    ----------
    upper : float
        Calibrated ``A``.
    lower : float
        Wald's ``B = log(beta / (1 - alpha_A))`` with ``alpha_A = (1 - beta) e^{-A}``, the
        per-cycle false-alarm probability Wald's formula assigns to ``A``.
    rate : float
        Realised per-epoch alarm rate on the calibration streams.
    rate_se : float
        Its Monte-Carlo standard error ``sqrt(rate / n_epochs)`` (alarms of a renewal
        process with rare events are nearly Poisson).
    n_epochs : int
        Fault-free epochs simulated (after a burn-in of 50 per stream).
    wald_rate : float
        Wald's approximation of the rate for one hypothesis times the number of
        hypotheses (a guide: overshoot and correlation are ignored).
    """

    upper: float
    lower: float
    rate: float
    rate_se: float
    n_epochs: int
    wald_rate: float

    def as_dict(self) -> dict:
        """The fields as a dict (for :attr:`ParityDiagnosis.info`)."""
        return asdict(self)

    def __repr__(self) -> str:
        return (
            f"SprtCalibration(A={self.upper:.4g}, B={self.lower:.4g}, rate={self.rate:.3g} "
            f"+/- {self.rate_se:.2g}, n_epochs={self.n_epochs})"
        )


def _lower_for(upper: float, beta: float) -> float:
    alpha = (1.0 - beta) * math.exp(-upper)
    return math.log(beta / (1.0 - alpha))


def calibrate_sprt(
    pf: ParityData | HasParityData,
    pfa: float,
    *,
    shift: float = 0.5,
    beta: float = 0.1,
    n_epochs: int | None = None,
    stream_length: int = 500,
    rng: Any = 0,
) -> SprtCalibration:
    """Calibrate Wald's upper boundary ``A`` for a per-epoch false-alarm rate ``pfa``.

    Simulates ``n_epochs`` fault-free epochs (default ``max(4e5, 400 / pfa)``, at most
    ``4e6``) in streams of ``stream_length`` samples, discarding the first 50 epochs of
    each, and searches ``A`` (the lower boundary following Wald's formula for the
    ``alpha`` that ``A`` implies) with the same random numbers until the realised rate
    is within a third of its Monte-Carlo error of ``pfa`` (secant steps on the log-rate,
    which falls about like ``e^{-A}``, starting from Wald's approximation).

    Returns
    -------
    SprtCalibration
    """
    pf = as_data(pf)
    pfa = as_probability(pfa, "pfa")
    shift = as_positive(shift, "shift")
    beta = as_probability(beta, "beta")
    stream_length = as_int(stream_length, "stream_length", minimum=_BURN_IN + 1)
    if n_epochs is None:
        n_epochs = int(min(4e6, max(4e5, 400 / pfa)))
    n_epochs = as_int(n_epochs, "n_epochs", minimum=1000)
    used = stream_length - _BURN_IN
    n_streams = -(-n_epochs // used)
    seed = int(_as_rng(rng).integers(2**63))
    q = pf.m if pf.F is None else pf.F.shape[1]
    chunk = max(1, (1 << 21) // (stream_length * q))

    def rate(upper: float) -> float:
        gen = np.random.default_rng(seed)  # common random numbers for every A
        lower = _lower_for(upper, beta)
        alarms = 0
        for start in range(0, n_streams, chunk):
            r = min(chunk, n_streams - start)
            Z = gen.standard_normal((r, stream_length, q)) * pf.sigma
            if pf.F is not None:
                Z = Z @ pf.F.T
            _, alarm, _ = sprt_run(_llr(pf, Z, shift), upper, lower)
            alarms += int(alarm[:, _BURN_IN:].sum())
        return alarms / (n_streams * used)

    nu = shift * float(np.sqrt(np.max(np.where(pf.detectable, pf.w, 0.0))))
    K = 2 * int(np.count_nonzero(pf.detectable))
    total = n_streams * used
    if nu <= 0:
        raise GeomFDIError("pf: no sensor fault is detectable in the parity space", argument="pf")

    def wald(upper: float) -> float:
        return K * wald_rate(upper, _lower_for(upper, beta), nu)

    # start from Wald's approximation (rate ~ e^{-A}), then secant steps on log(rate)
    # with a bracket kept as a safeguard; stop when the rate is within a third of its
    # Monte-Carlo error of pfa or the bracket is 1e-3 A wide.
    lo, hi = 1e-3, 50.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if wald(mid) > pfa else (lo, mid)
    tried: dict[float, float] = {}
    x = 0.5 * (lo + hi)
    lo, hi = 0.0, math.inf
    for _ in range(30):
        r = tried[x] = rate(x)
        if r > pfa:
            lo = max(lo, x)
        else:
            hi = min(hi, x)
        if abs(r - pfa) <= math.sqrt(pfa / total) / 3 or hi - lo < 1e-3 * x:
            break
        pts = sorted(tried.items())
        below = [(a, v) for a, v in pts if v > 0]
        if len(below) >= 2:  # secant on log(rate) through the two closest points
            (a1, v1), (a2, v2) = sorted(below, key=lambda av: abs(math.log(av[1] / pfa)))[:2]
            slope = (math.log(v2) - math.log(v1)) / (a2 - a1) if a2 != a1 else -1.0
            nxt = a1 + (math.log(pfa) - math.log(v1)) / slope if slope < 0 else a1 + 1.0
        else:
            nxt = x + (math.log(r / pfa) if r > 0 else -1.0)
        if not lo < nxt < hi:  # outside the bracket: bisect it (or step out of it)
            nxt = 0.5 * (lo + hi) if math.isfinite(hi) and lo > 0 else (2 * x if r > pfa else x / 2)
        x = nxt
    best = min(tried, key=lambda a: abs(tried[a] - pfa))
    r = tried[best]
    lower = _lower_for(best, beta)
    return SprtCalibration(
        float(best), lower, float(r), math.sqrt(max(r, 1.0 / total) / total), total, wald(best)
    )


def sprt_statistic(
    pf: ParityData | HasParityData, Z: Any, upper: float, *, shift: float = 0.5, beta: float = 0.1
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Repeated Wald SPRT of every fault hypothesis on a time series of readings.

    Parameters
    ----------
    Z : array_like, (N, m) or (R, N, m)
        Consecutive samples (rows).
    upper : float
        Upper boundary ``A`` (e.g. from :func:`calibrate_sprt` or :func:`wald_boundaries`);
        the lower one is Wald's ``B`` for ``alpha = (1 - beta) e^{-A}``.

    Returns
    -------
    stat, alarm, best : ndarray, (R, N)
        See :func:`sprt_run`; ``best`` is the sensor index (sign dropped).
    """
    pf = as_data(pf)
    shift = as_positive(shift, "shift")
    beta = as_probability(beta, "beta")
    upper = as_positive(upper, "threshold")
    X = _series(pf, Z)
    stat, alarm, best = sprt_run(_llr(pf, X, shift), upper, _lower_for(upper, beta))
    return stat, alarm, best % pf.k
