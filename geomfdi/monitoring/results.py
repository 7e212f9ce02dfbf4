"""Result records of the AR monitor: one streaming step, a whole run, the warning class.

See the user guide, *Theory: AR monitoring* (``docs/theory/ar-monitoring.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

if TYPE_CHECKING:  # pragma: no cover
    pass

__all__ = ["ARMonitorResult", "ARMonitorWarning", "ARStep"]


class ARMonitorWarning(UserWarning):
    """Some statistics are invalid: non-finite samples or rank-deficient regressors."""


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
        """Plot ``lambda`` against the threshold (see :func:`geomfdi.plot_ar_monitor`)."""
        from geomfdi.plotting.monitoring import plot_ar_monitor

        return plot_ar_monitor(self, **kwargs)
