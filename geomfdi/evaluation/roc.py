"""ROC curves and detection-versus-fault-size curves from per-run scores.

A *score* is the maximum of a residual's (or the bank's) normalised statistic over a
window of one run.  Over a threshold ``c`` on the score:

* false-alarm probability ``FAR(c) = P(score_healthy > c)`` (per window, over fault-free
  windows),
* detection probability ``P_d(c) = P(score_fault > c)`` (per window, over faulty runs),

and the ROC is ``(FAR(c), P_d(c))`` for ``c`` over all observed scores; the area under it
(AUC) is the probability that a faulty score exceeds a healthy one.  Proportions come with
Wilson score intervals.  See the user guide, *Theory: residual evaluation*
(``docs/theory/evaluation.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi._validation import as_probability, as_real_array
from geomfdi.errors import GeomFDIError

__all__ = ["RocCurve", "roc_curve", "wilson_interval"]


@dataclass
class RocCurve:
    """``far[i]``, ``pd[i]`` at ``thresholds[i]`` (decreasing thresholds, increasing rates)."""

    thresholds: np.ndarray
    far: np.ndarray
    pd: np.ndarray
    label: str = ""

    @property
    def auc(self) -> float:
        """Area under the ROC (trapezoids, from (0, 0) to (1, 1))."""
        x = np.concatenate([[0.0], self.far, [1.0]])
        y = np.concatenate([[0.0], self.pd, [1.0]])
        return float(np.sum(np.diff(x) * 0.5 * (y[1:] + y[:-1])))

    def pd_at(self, far: float) -> float:
        """Largest ``P_d`` with ``FAR <= far`` on the curve."""
        far = float(far)
        ok = self.far <= far + 1e-15
        return float(self.pd[ok].max()) if ok.any() else 0.0


def roc_curve(healthy: Any, faulty: Any, label: str = "") -> RocCurve:
    """ROC from healthy and faulty scores (1-D arrays, any lengths).

    The thresholds are every distinct score (and ``+inf``); at threshold ``c`` a score
    alarms when it is ``> c``.
    """
    h = as_real_array(healthy, "healthy").ravel()
    f = as_real_array(faulty, "faulty").ravel()
    if h.size == 0 or f.size == 0:
        raise GeomFDIError("healthy, faulty: need at least one score each", argument="healthy")
    c = np.unique(np.concatenate([h, f]))[::-1]
    c = np.concatenate([[np.inf], c])
    hs, fs = np.sort(h), np.sort(f)
    far = 1.0 - np.searchsorted(hs, c, side="right") / h.size
    pd = 1.0 - np.searchsorted(fs, c, side="right") / f.size
    return RocCurve(c, far, pd, label)


def wilson_interval(successes: Any, trials: Any, confidence: float = 0.95) -> tuple[Any, Any]:
    """Wilson score interval of a binomial proportion (elementwise).

    ``(p + z²/2n ± z √(p(1−p)/n + z²/4n²)) / (1 + z²/n)`` with ``p = k/n`` and ``z`` the
    normal quantile of ``confidence`` (Wilson 1927); the lower bound is exactly 0 for
    ``k = 0`` and the upper bound exactly 1 for ``k = n``.  Scalars in, floats out.
    """
    from scipy.stats import norm

    conf = as_probability(confidence, "confidence")
    k = as_real_array(successes, "successes")
    n = as_real_array(trials, "trials")
    if np.any(n <= 0) or np.any(k < 0) or np.any(k > n):
        raise GeomFDIError(
            "successes, trials: need 0 <= successes <= trials, trials > 0", argument="trials"
        )
    z = norm.isf((1 - conf) / 2)
    p = k / n
    den = 1 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    # the bounds are exactly 0 at k = 0 and 1 at k = n (mid = half there); rounding in
    # mid - half would print as 3.5e-18
    lo = np.where(k == 0, 0.0, np.clip(mid - half, 0.0, 1.0))
    hi = np.where(k == n, 1.0, np.clip(mid + half, 0.0, 1.0))
    if lo.ndim == 0:
        return float(lo), float(hi)
    return lo, hi
