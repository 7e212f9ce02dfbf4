"""Residual evaluation tests: windowed chi-square (RMS), CUSUM and GLR, with thresholds.

Every test turns residual rows ``r`` (``(..., n_residuals, N)``, time last, as stored by
:func:`geomfdi.simulate_batch`) into a statistic of the same shape and alarms where the
statistic exceeds a per-residual threshold.  All of them are vectorised over runs and
time (cumulative sums and running minima; the GLR loops over the lags of its window, not
over samples).

* **Windowed chi-square** ``S[k] = sum_{j=k-L+1..k} ||r[j]||^2`` (RMS: ``sqrt(S/L)``).
  With the residual noise model (:mod:`geomfdi.evaluation.covariance`) the stacked window
  ``R ~ N(0, Sigma_W)`` (block Toeplitz of the autocovariance) and ``S = R^T R`` is a
  weighted sum of chi-square(1) variables with the eigenvalues of ``Sigma_W`` as weights.
  Its upper quantile is computed *exactly* by Imhof's (1961) inversion formula
  (``method="imhof"``, numerical quadrature) or approximated by Satterthwaite's
  ``g * chi2(h)`` with matched mean and variance (``method="satterthwaite"``).
* **CUSUM** for a step in the mean of a scalar residual, two-sided, on the residual scaled
  by its noise standard deviation ``x = r / sigma``:
  ``g+[k] = max(0, g+[k-1] + x[k] - nu)``, ``g-[k] = max(0, g-[k-1] - x[k] - nu)``,
  computed without a loop by Lindley's identity ``g[k] = S[k] - min(0, min_{j<=k} S[j])``
  with ``S`` the cumulative sum of ``x - nu``.
* **GLR** for a step of unknown size and onset within the last ``L`` samples:
  ``g[k] = max_{1<=m<=L} (sum_{j=k-m+1..k} r[j])^2 / (2 V_m)`` with ``V_m`` the exact
  variance of a sum of ``m`` consecutive noise samples (from the autocovariance); each term
  is chi-square(1)/2 under no fault.

False-alarm rates: the chi-square threshold has an exact per-window false-alarm
probability; for CUSUM, Siegmund's approximation of the average run length holds for white
residuals (:func:`cusum_arl`); for GLR a Bonferroni bound over the window
(:func:`glr_threshold_bound`).  For correlated residuals CUSUM and GLR thresholds are
**calibrated** on noise-only runs (:func:`calibrate_max`).

See the user guide, *Theory: residual evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._validation import (
    as_bool,
    as_float,
    as_int,
    as_positive,
    as_probability,
    as_real_array,
    check_finite,
)
from geomfdi.errors import GeomFDIError, ShapeError

__all__ = [
    "windowed_sum_of_squares",
    "window_covariance",
    "weighted_chi2_sf",
    "chi2_window_threshold",
    "cusum",
    "cusum_arl",
    "glr",
    "sum_variances",
    "glr_threshold_bound",
    "calibrate_max",
    "AbsTest",
    "ChiSquareTest",
    "CusumTest",
    "GLRTest",
]


def _rows(residuals: Any, copy: bool = True) -> np.ndarray:
    """Residuals ``(..., n_residuals, N)`` checked (finite reals); ``copy=False``: a
    float64 array is checked in place (for a statistic that does not modify it)."""
    if not copy and isinstance(residuals, np.ndarray) and residuals.dtype == np.float64:
        check_finite(residuals, "residuals")
        r = residuals
    else:
        r = as_real_array(residuals, "residuals")
    if r.ndim < 2:
        raise ShapeError(
            f"residuals: expected (..., n_residuals, N), got shape {r.shape}", argument="residuals"
        )
    return r


def _per_row(values: Any, n: int, name: str) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    if v.ndim == 0:
        v = np.full(n, float(v))
    if v.shape != (n,):
        raise ShapeError(f"{name}: expected {n} values, got shape {v.shape}", argument=name)
    return v


# ====================================================================== chi-square
def windowed_sum_of_squares(residuals: Any, window: int) -> np.ndarray:
    """``S[k] = sum_{j=max(0,k-L+1)..k} r[j]^2`` along the last axis (partial sums at first).

    Computed from one cumulative sum (vectorised over all leading axes).  Before the first
    full window the sum covers the available samples (never more often above a
    full-window threshold than a full window).
    """
    r = as_real_array(residuals, "residuals")
    if r.ndim == 0:
        raise ShapeError("residuals: expected samples along the last axis, got a scalar",
                         argument="residuals")  # fmt: skip
    return _sum_of_squares(r, as_int(window, "window", minimum=1))


def _sum_of_squares(r: np.ndarray, L: int) -> np.ndarray:
    """:func:`windowed_sum_of_squares` of a checked float array (a new array)."""
    c = r * r
    np.cumsum(c, axis=-1, out=c)
    if L >= r.shape[-1]:
        np.maximum(c, 0.0, out=c)
        return c
    out = np.empty_like(c)
    out[..., :L] = c[..., :L]
    np.subtract(c[..., L:], c[..., :-L], out=out[..., L:])
    np.maximum(out, 0.0, out=out)  # rounding of the difference of two cumulative sums
    return out


def window_covariance(autocov: Any, window: int) -> np.ndarray:
    """Covariance of the stacked window ``[r[k-L+1]; ...; r[k]]``: block Toeplitz (Lp, Lp).

    ``autocov`` is ``(>= L, p, p)`` with ``autocov[tau] = E[r[k+tau] r[k]^T]``.
    """
    g = as_real_array(autocov, "autocov")
    L = as_int(window, "window", minimum=1)
    if g.ndim != 3 or g.shape[0] < L or g.shape[1] != g.shape[2]:
        raise ShapeError(
            f"autocov: expected ({L}, p, p) or longer, got {g.shape}", argument="autocov"
        )
    p = g.shape[1]
    idx = np.arange(L)
    lag = idx[:, None] - idx[None, :]  # i - j
    blocks = np.where(
        (lag >= 0)[:, :, None, None], g[np.abs(lag)], np.swapaxes(g[np.abs(lag)], -1, -2)
    )
    return blocks.transpose(0, 2, 1, 3).reshape(L * p, L * p)


def weighted_chi2_sf(x: Any, weights: Any) -> Any:
    """``P(sum_j w_j z_j^2 > x)`` for independent standard normal ``z_j`` (Imhof 1961).

    Imhof's formula ``1/2 + (1/pi) int_0^inf sin(theta(u)) / (u rho(u)) du`` with
    ``theta(u) = phi(u) - x u / 2``, ``phi(u) = sum_j atan(w_j u) / 2`` and
    ``rho(u) = prod_j (1 + w_j^2 u^2)^(1/4)`` (weights scaled to a maximum of 1).  On
    ``[0, U]`` (``U = 8``) composite 16-point Gauss-Legendre quadrature on panels shorter
    than a quarter of the oscillation period ``4 pi / x``; on ``[U, inf)`` the smooth factors
    ``sin(phi)/(u rho)`` and ``cos(phi)/(u rho)`` are integrated against ``cos(x u/2)`` and
    ``sin(x u/2)`` by QUADPACK's Fourier-integral rule (:func:`scipy.integrate.quad` with
    ``weight="cos"/"sin"``).  Absolute accuracy about 1e-10.
    """
    from scipy.integrate import quad

    w = as_real_array(weights, "weights").ravel()
    if np.any(w < 0):
        raise GeomFDIError("weights: must be >= 0", argument="weights")
    w = w[w > 1e-14 * max(w.max(initial=0.0), 1e-300)]
    if w.size == 0:
        raise GeomFDIError("weights: all zero", argument="weights")
    scale = w.max()
    w = w / scale
    xs = np.atleast_1d(as_real_array(x, "x")) / scale
    nodes, gw = np.polynomial.legendre.leggauss(16)
    U = 8.0

    def phi_env(u: Any) -> tuple[Any, Any]:
        wu = np.multiply.outer(u, w)
        phi = 0.5 * np.arctan(wu).sum(axis=-1)
        env = np.exp(-0.25 * np.log1p(wu * wu).sum(axis=-1)) / u
        return phi, env

    out = np.empty(xs.shape)
    for i, xx in enumerate(xs):
        if xx <= 0:
            out[i] = 1.0
            continue
        width = min(0.25, np.pi / xx)
        edges = np.linspace(0.0, U, int(np.ceil(U / width)) + 1)
        half = 0.5 * np.diff(edges)
        u = ((0.5 * (edges[:-1] + edges[1:]))[:, None] + half[:, None] * nodes[None, :]).ravel()
        phi, env = phi_env(u)
        f = np.sin(phi - 0.5 * xx * u) * env
        head = np.sum(f.reshape(-1, nodes.size) * gw[None, :] * half[:, None])
        # sin(phi - x u/2) = sin(phi) cos(x u/2) - cos(phi) sin(x u/2); shift u = U + s
        c0, s0 = np.cos(0.5 * xx * U), np.sin(0.5 * xx * U)

        def part(fn: Any, kind: str, om: float = 0.5 * xx) -> float:
            return quad(fn, 0.0, np.inf, weight=kind, wvar=om, limlst=200)[0]

        def a(s: float) -> float:
            p, e = phi_env(U + s)
            return float(np.sin(p) * e)

        def b(s: float) -> float:
            p, e = phi_env(U + s)
            return float(np.cos(p) * e)

        # cos(x(U+s)/2) = c0 cos - s0 sin ; sin(x(U+s)/2) = s0 cos + c0 sin
        Ac, As = part(a, "cos"), part(a, "sin")
        Bc, Bs = part(b, "cos"), part(b, "sin")
        tail = (c0 * Ac - s0 * As) - (s0 * Bc + c0 * Bs)
        out[i] = min(max(0.5 + (head + tail) / np.pi, 0.0), 1.0)
    return out if np.ndim(x) else float(out[0])


def chi2_window_threshold(
    autocov: Any, window: int, false_alarm_rate: float, method: str = "imhof"
) -> float:
    """Threshold ``h`` on the windowed sum of squares with ``P(S > h) = false_alarm_rate``.

    Parameters
    ----------
    autocov : (>= window, p, p)
        Residual autocovariance (:meth:`ResidualNoiseModel.autocovariance`).
    window : int
    false_alarm_rate : float
        Per-window probability.
    method : {"imhof", "satterthwaite"}
        Exact quantile of the weighted chi-square (eigenvalues of the window covariance,
        Imhof's formula and a root search), or Satterthwaite's ``g chi2(h)`` with
        ``g = sum w^2 / sum w``, ``h = (sum w)^2 / sum w^2``.
    """
    from scipy.optimize import brentq
    from scipy.stats import chi2

    alpha = as_probability(false_alarm_rate, "false_alarm_rate")
    lam = np.linalg.eigvalsh(window_covariance(autocov, window))
    lam = np.clip(lam, 0.0, None)
    s1, s2 = lam.sum(), np.sum(lam * lam)
    if s1 <= 0:
        raise GeomFDIError("autocov: the residual has no noise", argument="autocov")
    g, h = s2 / s1, s1 * s1 / s2
    approx = float(g * chi2.isf(alpha, h))
    if method == "satterthwaite":
        return approx
    if method != "imhof":
        raise GeomFDIError(
            f"method: must be 'imhof' or 'satterthwaite', got {method!r}", argument="method"
        )
    lo, hi = 0.5 * approx, 2.0 * approx
    while weighted_chi2_sf(lo, lam) < alpha:
        lo *= 0.5
    while weighted_chi2_sf(hi, lam) > alpha:
        hi *= 2.0
    return float(brentq(lambda x: weighted_chi2_sf(x, lam) - alpha, lo, hi, xtol=1e-12 * hi))


# ========================================================================= CUSUM
def cusum(x: Any, drift: float, two_sided: bool = True) -> np.ndarray:
    """CUSUM of ``x`` (last axis is time) for an upward (and downward) mean step.

    ``g[k] = max(0, g[k-1] + x[k] - drift)``, ``g[-1] = 0``, computed as
    ``S[k] - min(0, min_{j<=k} S[j])`` with ``S = cumsum(x - drift)`` (Lindley).  Two-sided:
    the larger of the statistics of ``x`` and ``-x``.
    """
    a = as_real_array(x, "x")
    nu = as_positive(drift, "drift", strict=False)
    two_sided = as_bool(two_sided, "two_sided")

    def one(z: np.ndarray) -> np.ndarray:
        S = np.cumsum(z - nu, axis=-1)
        low = np.minimum.accumulate(np.minimum(S, 0.0), axis=-1)
        return np.maximum(S - low, 0.0)

    return np.maximum(one(a), one(-a)) if two_sided else one(a)


def cusum_arl(threshold: float, drift: float, shift: float = 0.0) -> float:
    """Average run length of a one-sided CUSUM on white unit-variance Gaussian data.

    Siegmund's (1985) approximation with mean ``mu = shift - drift`` and the corrected
    threshold ``b = h + 1.166``: ``ARL = (exp(-2 mu b) + 2 mu b - 1) / (2 mu^2)`` (``b^2``
    when ``mu = 0``).  ``shift = 0`` gives the mean time between false alarms; a two-sided
    CUSUM has about half of it.
    """
    h = as_positive(threshold, "threshold", strict=False)
    mu = as_float(shift, "shift") - as_positive(drift, "drift", strict=False)
    b = h + 1.166
    if abs(mu) < 1e-12:
        return b * b
    if -2 * mu * b > 700:  # exp overflows: no float holds the run length
        raise GeomFDIError(
            f"threshold, drift: a run length beyond 1e300 samples (threshold {h:g}, drift "
            f"{mu - as_float(shift, 'shift'):g}); the data are unit-variance",
            argument="threshold",
        )
    return float((math.exp(-2 * mu * b) + 2 * mu * b - 1) / (2 * mu * mu))


# =========================================================================== GLR
def sum_variances(autocov: Any, window: int) -> np.ndarray:
    """``V_m = Var(sum of m consecutive samples) = m g0 + 2 sum_{tau<m} (m - tau) g_tau``.

    For a scalar residual (``autocov`` of shape ``(>= L,)`` or ``(>= L, 1, 1)``), m = 1..L.
    """
    g = as_real_array(autocov, "autocov")
    if g.ndim == 3:
        if g.shape[1:] != (1, 1):
            raise ShapeError("autocov: the GLR needs a scalar residual", argument="autocov")
        g = g[:, 0, 0]
    L = as_int(window, "window", minimum=1)
    if g.ndim != 1 or g.shape[0] < L:
        raise ShapeError(f"autocov: expected at least {L} lags", argument="autocov")
    m = np.arange(1, L + 1)
    tau = np.arange(L)
    w = np.clip(m[:, None] - tau[None, :], 0, None).astype(float)  # (m - tau)_+
    w[:, 1:] *= 2.0
    return w @ g[:L]


def glr(residuals: Any, variances: Any) -> np.ndarray:
    """Windowed GLR for a mean step: ``max_m (sum of the last m samples)^2 / (2 V_m)``.

    ``variances`` is ``(L,)`` (one residual) or ``(n_residuals, L)`` for ``(..., n, N)``
    residuals; ``L`` is the window.  A loop over the ``L`` lags, vectorised over time and
    runs; the sums come from one cumulative sum.
    """
    r = as_real_array(residuals, "residuals")
    V = as_real_array(variances, "variances")
    if r.ndim == 0:
        raise ShapeError("residuals: expected samples along the last axis, got a scalar",
                         argument="residuals")  # fmt: skip
    if V.ndim not in (1, 2) or V.shape[-1] == 0:
        raise ShapeError(
            f"variances: expected (L,) or (n_residuals, L), got shape {V.shape}",
            argument="variances",
        )
    if V.ndim == 2 and (r.ndim < 2 or r.shape[-2] != V.shape[0]):
        raise ShapeError(
            f"variances: {V.shape[0]} rows for residuals of shape {r.shape}",
            argument="variances",
        )
    if np.any(V <= 0):
        raise GeomFDIError("variances: must be > 0", argument="variances")
    L = V.shape[-1]
    N = r.shape[-1]
    c = np.concatenate([np.zeros((*r.shape[:-1], 1)), np.cumsum(r, axis=-1)], axis=-1)
    out = np.zeros(r.shape)
    for m in range(1, min(L, N) + 1):
        s = c[..., m:] - c[..., :-m]  # sums of m samples ending at k = m-1 .. N-1
        v = V[..., m - 1]
        if V.ndim == 2:
            v = v[:, None]
        np.maximum(out[..., m - 1 :], s * s / (2.0 * v), out=out[..., m - 1 :])
    return out


def glr_threshold_bound(false_alarm_rate: float, window: int) -> float:
    """Threshold with per-sample false-alarm probability at most ``false_alarm_rate``.

    Bonferroni over the ``L`` terms, each ``chi2(1)/2``: ``h = chi2.isf(alpha / L, 1) / 2``.
    """
    from scipy.stats import chi2

    alpha = as_probability(false_alarm_rate, "false_alarm_rate")
    L = as_int(window, "window", minimum=1)
    return float(chi2.isf(alpha / L, 1) / 2.0)


# =================================================================== calibration
def calibrate_max(statistic: Any, false_alarm_rate: float) -> np.ndarray:
    """Per-residual threshold exceeded by the run maximum in a fraction ``alpha`` of runs.

    ``statistic`` is ``(runs, n_residuals, N)`` from noise-only runs (over the horizon whose
    false-alarm probability is wanted); the threshold is the empirical
    ``(1 - alpha)`` quantile of ``max_k statistic`` (linear interpolation), so at least
    ``1 / alpha`` runs are needed.
    """
    s = as_real_array(statistic, "statistic")
    alpha = as_probability(false_alarm_rate, "false_alarm_rate")
    if s.ndim != 3:
        raise ShapeError("statistic: expected (runs, n_residuals, N)", argument="statistic")
    if s.shape[0] * alpha < 1.0:
        raise GeomFDIError(
            f"statistic: {s.shape[0]} runs cannot calibrate a rate of {alpha:g} "
            f"(need >= {int(np.ceil(1 / alpha))})",
            argument="statistic",
        )
    return np.quantile(s.max(axis=-1), 1.0 - alpha, axis=0)


# ========================================================================= tests
@dataclass
class ChiSquareTest:
    """Windowed chi-square test with analytic thresholds (module docstring).

    Attributes
    ----------
    window : int
    thresholds : ndarray, (n_residuals,)
        On the windowed sum of squares; ``inf`` for missing rows.
    false_alarm_rate : float
        Per-window false-alarm probability the thresholds were computed for.
    method : str
    """

    window: int
    thresholds: np.ndarray
    false_alarm_rate: float = float("nan")
    method: str = "imhof"
    name: str = "chi2"

    @classmethod
    def design(
        cls,
        models: list[Any],
        window: int,
        false_alarm_rate: float,
        method: str = "imhof",
    ) -> ChiSquareTest:
        """Thresholds from residual noise models (:func:`residual_noise_models`)."""
        L = as_int(window, "window", minimum=1)
        thr = np.array(
            [
                np.inf
                if m is None
                else chi2_window_threshold(m.autocovariance(L), L, false_alarm_rate, method)
                for m in models
            ]
        )
        return cls(L, thr, float(false_alarm_rate), method)

    @property
    def rms_thresholds(self) -> np.ndarray:
        """The same thresholds on the windowed RMS ``sqrt(S / L)``."""
        return np.sqrt(self.thresholds / self.window)

    def statistic(self, residuals: Any) -> np.ndarray:
        return _sum_of_squares(_rows(residuals, copy=False), self.window)

    def alarms(self, residuals: Any) -> np.ndarray:
        s = self.statistic(residuals)
        return s > _per_row(self.thresholds, s.shape[-2], "thresholds")[:, None]


@dataclass
class CusumTest:
    """Two-sided CUSUM on ``r / sigma`` with drift ``nu`` (module docstring).

    Attributes
    ----------
    sigma : ndarray, (n_residuals,)
        Noise standard deviation per residual (scalar residuals).
    drift : float
        ``nu`` in units of sigma (half the step to detect, in sigma, is the classical
        choice).
    thresholds : ndarray, (n_residuals,)
    """

    sigma: np.ndarray
    drift: float
    thresholds: np.ndarray = field(default_factory=lambda: np.array([]))
    name: str = "cusum"

    @classmethod
    def design(cls, models: list[Any], drift: float, arl: float) -> CusumTest:
        """``sigma`` from the noise models, thresholds for a mean time between false alarms.

        The threshold solves ``cusum_arl(h, drift) / 2 = arl`` (two-sided, Siegmund): exact
        in the limit for **white** residuals only; calibrate (:meth:`calibrated`) for
        correlated ones.
        """
        from scipy.optimize import brentq

        nu = as_positive(drift, "drift")
        target = as_positive(arl, "arl")
        sig = []
        for k, m in enumerate(models):
            if m is not None and m.n_outputs != 1:
                raise GeomFDIError(
                    f"models[{k}]: the CUSUM mean test needs scalar residuals", argument="models"
                )
            sig.append(1.0 if m is None else np.sqrt(m.autocovariance(1)[0, 0, 0]))
        f = lambda h: cusum_arl(h, nu) / 2.0 - target  # noqa: E731
        hi = 1.0
        while f(hi) < 0:
            hi *= 2.0
        h = brentq(f, 0.0, hi) if f(0.0) < 0 else 0.0
        thr = np.array([np.inf if m is None else h for m in models])
        return cls(np.array(sig), nu, thr)

    def statistic(self, residuals: Any) -> np.ndarray:
        r = _rows(residuals)
        sig = _per_row(self.sigma, r.shape[-2], "sigma")
        return cusum(r / sig[:, None], self.drift)

    def alarms(self, residuals: Any) -> np.ndarray:
        s = self.statistic(residuals)
        return s > _per_row(self.thresholds, s.shape[-2], "thresholds")[:, None]

    def calibrated(self, noise_runs: Any, false_alarm_rate: float) -> CusumTest:
        """Thresholds from noise-only residuals ``(runs, n, N)`` (:func:`calibrate_max`)."""
        return CusumTest(
            self.sigma, self.drift, calibrate_max(self.statistic(noise_runs), false_alarm_rate)
        )


@dataclass
class GLRTest:
    """Windowed GLR for a mean step with the exact sum variances (module docstring).

    Attributes
    ----------
    variances : ndarray, (n_residuals, L)
        ``V_m`` per residual (:func:`sum_variances`).
    thresholds : ndarray, (n_residuals,)
    """

    variances: np.ndarray
    thresholds: np.ndarray
    name: str = "glr"

    @classmethod
    def design(cls, models: list[Any], window: int, false_alarm_rate: float) -> GLRTest:
        """Bonferroni thresholds (:func:`glr_threshold_bound`) from scalar noise models."""
        L = as_int(window, "window", minimum=1)
        V = []
        for k, m in enumerate(models):
            if m is None:
                V.append(np.ones(L))
                continue
            if m.n_outputs != 1:
                raise GeomFDIError(
                    f"models[{k}]: the GLR mean test needs scalar residuals", argument="models"
                )
            V.append(sum_variances(m.autocovariance(L), L))
        h = glr_threshold_bound(false_alarm_rate, L)
        thr = np.array([np.inf if m is None else h for m in models])
        return cls(np.array(V), thr)

    @property
    def window(self) -> int:
        return int(self.variances.shape[-1])

    def statistic(self, residuals: Any) -> np.ndarray:
        r = _rows(residuals)
        if r.shape[-2] != self.variances.shape[0]:
            raise ShapeError(
                f"residuals: expected {self.variances.shape[0]} rows", argument="residuals"
            )
        return glr(r, self.variances)

    def alarms(self, residuals: Any) -> np.ndarray:
        s = self.statistic(residuals)
        return s > _per_row(self.thresholds, s.shape[-2], "thresholds")[:, None]

    def calibrated(self, noise_runs: Any, false_alarm_rate: float) -> GLRTest:
        """Thresholds from noise-only residuals ``(runs, n, N)`` (:func:`calibrate_max`)."""
        return GLRTest(self.variances, calibrate_max(self.statistic(noise_runs), false_alarm_rate))


@dataclass
class AbsTest:
    """The fixed threshold on ``|r|`` (the classical rule ``|r| > epsilon``).

    Attributes
    ----------
    thresholds : ndarray, (n_residuals,)
    """

    thresholds: np.ndarray
    name: str = "abs"

    def statistic(self, residuals: Any) -> np.ndarray:
        return np.abs(_rows(residuals))

    def alarms(self, residuals: Any) -> np.ndarray:
        s = self.statistic(residuals)
        return s > _per_row(self.thresholds, s.shape[-2], "thresholds")[:, None]
