"""Small frozen records the AR monitor passes to its training, batch and streaming
functions (settings and learnt null model), so that those functions never import the
:class:`~geomfdi.monitoring.monitor.ARMonitor` object back.

See the user guide, *Theory: AR monitoring* (``docs/theory/ar-monitoring.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ARNull", "ARSettings", "ARTraining"]


@dataclass(frozen=True)
class ARSettings:
    """Settings of an AR monitor (see :class:`~geomfdi.monitoring.monitor.ARMonitor`)."""

    order: int
    window: int
    coefficient: int
    pfa: float
    threshold: float
    reset_after: int | None
    reset_keep: int
    prefill: bool
    refit_every: int


@dataclass(frozen=True)
class ARNull:
    """The learnt fault-free distribution of ``phi_c`` and the stored normal innovations."""

    mu: float
    delta: float
    normal: np.ndarray

    def statistic(self, coefficients: np.ndarray, coefficient: int) -> np.ndarray:
        """``((phi_c - mu) / delta)**2`` for coefficient vectors (..., order)."""
        phi = np.asarray(coefficients, dtype=float)
        return ((phi[..., coefficient] - self.mu) / self.delta) ** 2


@dataclass(frozen=True)
class ARTraining:
    """Outcome of :func:`~geomfdi.monitoring.training.fit`: ``mu``, ``delta`` of ``phi_c``,
    the AR coefficients of the training windows, the pooled fit and the default stored
    normal innovations (the last ``window - 1`` training samples)."""

    mu: float
    delta: float
    coefficients: np.ndarray
    model: np.ndarray
    normal: np.ndarray
