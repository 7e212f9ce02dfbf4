"""Persistence rules: an alarm, or an isolation decision, only when it holds k of n samples.

A threshold crossing of one sample is often noise, and with several simultaneous faults
residuals crossing zero together can match one column of the structure matrix for a
sample or two (a coincidental isolation).  A **k-of-n** rule keeps an alarm at sample
``j`` only when the raw alarm was on for at least ``k`` of the samples ``j-n+1 .. j``;
``k = n`` is a minimum duration.  Isolation is then decided from the persistent alarm
pattern, and a decision for fault ``f`` is kept only when it too held for ``k`` of the
last ``n`` samples.  See the user guide, *Theory: evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi._validation import as_int
from geomfdi.errors import GeomFDIError
from geomfdi.evaluation.decision import NO_ALARM, UNEXPLAINED, Isolation, Threshold, isolate

__all__ = ["Persistence", "as_persistence", "decisions", "k_of_n"]


def k_of_n(flags: Any, k: int, n: int) -> np.ndarray:
    """``out[..., j] = sum(flags[..., j-n+1 : j+1]) >= k`` (time on the last axis).

    The first ``n - 1`` samples count the samples available (a rule cannot fire before
    ``k`` samples were seen).
    """
    f = np.asarray(flags, dtype=bool)
    if k == 1 and n == 1:
        return f.copy()
    c = np.cumsum(f, axis=-1, dtype=np.int32)
    win = c.copy()
    win[..., n:] -= c[..., :-n]
    return win >= k


@dataclass(frozen=True)
class Persistence:
    """A k-of-n persistence rule for alarms and isolation decisions.

    Attributes
    ----------
    k, n : int
        An alarm (decision) holds at sample ``j`` when the raw one held for at least ``k``
        of the ``n`` samples ending at ``j``; ``1 <= k <= n``.  ``Persistence(1, 1)`` is
        no persistence.

    Examples
    --------
    >>> import numpy as np
    >>> from geomfdi.evaluation.persistence import Persistence
    >>> Persistence(2, 3).apply(np.array([[1, 0, 1, 0, 0, 1, 1]], dtype=bool)).astype(int).tolist()
    [[0, 0, 1, 0, 0, 0, 1]]
    """

    k: int = 1
    n: int = 1

    def __post_init__(self) -> None:
        k = as_int(self.k, "persistence.k", minimum=1)
        n = as_int(self.n, "persistence.n", minimum=1)
        if k > n:
            raise GeomFDIError(
                f"persistence: k={k} of n={n} samples needs k <= n", argument="persistence"
            )
        object.__setattr__(self, "k", k)
        object.__setattr__(self, "n", n)

    @classmethod
    def from_duration(cls, duration: float, dt: float) -> Persistence:
        """A minimum duration: ``k = n = ceil(duration / dt)`` samples (at least 1)."""
        if isinstance(duration, bool) or not isinstance(duration, numbers.Real):
            raise GeomFDIError("duration: must be a number of seconds", argument="duration")
        if not (math.isfinite(duration) and duration >= 0):
            raise GeomFDIError(f"duration: must be >= 0, got {duration}", argument="duration")
        if not (isinstance(dt, numbers.Real) and math.isfinite(dt) and dt > 0):
            raise GeomFDIError(f"dt: must be > 0, got {dt}", argument="dt")
        m = max(1, math.ceil(duration / dt - 1e-9))
        return cls(m, m)

    @property
    def trivial(self) -> bool:
        return self.k == 1 and self.n == 1

    def apply(self, alarms: Any) -> np.ndarray:
        """Persistent alarms, same shape as ``alarms`` (time on the last axis)."""
        return k_of_n(alarms, self.k, self.n)

    def isolation(self, alarms: Any, structure: Any) -> Isolation:
        """Isolation decided from the persistent alarm pattern, kept when it persists.

        ``alarms`` are the (already persistent) alarms; a fault index stays the decision
        at sample ``j`` when the per-sample decision was that fault for ``k`` of the last
        ``n`` samples and is it at ``j``; otherwise the sample is ``UNEXPLAINED`` (an alarm
        without a settled pattern) or ``NO_ALARM``.
        """
        iso = isolate(alarms, structure)
        if self.trivial:
            return iso
        raw = iso.isolated
        out = np.where(raw == NO_ALARM, NO_ALARM, UNEXPLAINED)
        nf = np.asarray(structure).shape[1]
        for j in range(nf):
            hit = raw == j
            if hit.any():
                out[hit & k_of_n(hit, self.k, self.n)] = j
        return Isolation(out, iso.candidates, iso.suspects)


def as_persistence(value: Any) -> Persistence | None:
    """``None``, ``n`` (minimum duration of ``n`` samples), ``(k, n)`` or a Persistence."""
    if value is None or isinstance(value, Persistence):
        return value
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return Persistence(int(value), int(value))
    if isinstance(value, tuple | list) and len(value) == 2:
        return Persistence(value[0], value[1])
    raise GeomFDIError(
        f"persistence: expected None, an int, (k, n) or a Persistence, got {value!r}",
        argument="persistence",
    )


def decisions(
    residuals: np.ndarray,
    threshold: Threshold | None,
    structure: Any,
    persistence: Persistence | None = None,
) -> tuple[np.ndarray, Isolation]:
    """Alarms and isolation of residuals ``(..., n_residuals, N)`` under a rule.

    No threshold: no alarm.  With a persistence rule the alarms are the persistent ones
    and isolation is :meth:`Persistence.isolation`.
    """
    if threshold is None:
        alarms = np.zeros(np.shape(residuals), dtype=bool)
    else:
        alarms = threshold.alarms(residuals)
    if persistence is None or persistence.trivial:
        return alarms, isolate(alarms, structure)
    alarms = persistence.apply(alarms)
    return alarms, persistence.isolation(alarms, structure)
