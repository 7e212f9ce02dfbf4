"""Per-sample decisions of a deployed bank: threshold, k-of-n persistence, isolation.

At sample ``k`` residual ``i`` has a *raw* alarm ``a_i[k] = |r_i[k]| > threshold_i``
(never on a missing sample, never on a row whose generator is missing).  The
*confirmed* alarm is the k-of-n rule::

    alarm_i[k] = sum_{j = k-n+1}^{k} a_i[j] >= k_req

(samples before the start count as no alarm).  ``k_req = n = d`` is a minimum duration
of ``d`` consecutive samples; ``k_req = n = 1`` is no persistence.  The counts are
integers, so the rule is exact and the same in numpy, in the :class:`geomfdi.Monitor`
ring buffer and in the generated C and Python code.

Isolation compares the confirmed alarm pattern with the columns of the bank's achieved
structure exactly as :func:`geomfdi.isolate` does: the fault index when exactly one
column equals the pattern, ``-1`` (no alarm), ``-2`` (unexplained: no column matches)
or ``-3`` (ambiguous: several equal columns match).  See the user guide, *Theory:
residual evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi._validation import as_int
from geomfdi.errors import GeomFDIError
from geomfdi.evaluation.decision import AMBIGUOUS, NO_ALARM, UNEXPLAINED, Threshold, as_threshold

__all__ = [
    "PatternTable",
    "Persistence",
    "as_persistence",
    "confirm",
    "decision_code",
    "threshold_values",
]


@dataclass(frozen=True)
class Persistence:
    """k-of-n persistence: an alarm is confirmed when ``k`` of the last ``n`` samples
    raised a raw alarm (module docstring).

    Attributes
    ----------
    k, n : int
        ``1 <= k <= n``.
    """

    k: int = 1
    n: int = 1

    def __post_init__(self) -> None:
        k = as_int(self.k, "persistence.k", minimum=1)
        n = as_int(self.n, "persistence.n", minimum=1)
        if k > n:
            raise GeomFDIError(f"persistence: k = {k} exceeds n = {n}", argument="persistence")
        object.__setattr__(self, "k", k)
        object.__setattr__(self, "n", n)

    @classmethod
    def duration(cls, samples: int) -> Persistence:
        """``samples`` consecutive raw alarms (a minimum duration)."""
        d = as_int(samples, "samples", minimum=1)
        return cls(d, d)


def as_persistence(value: Any) -> Persistence:
    """``None`` (no persistence), an int ``d`` (``d`` consecutive samples), a pair
    ``(k, n)`` or a :class:`Persistence`."""
    if value is None:
        return Persistence(1, 1)
    if isinstance(value, Persistence):
        return value
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return Persistence.duration(int(value))
    if isinstance(value, tuple | list) and len(value) == 2:
        return Persistence(value[0], value[1])
    raise GeomFDIError(
        f"persistence: expected None, an int, a pair (k, n) or Persistence, got {value!r}",
        argument="persistence",
    )


def threshold_values(threshold: Any, n_rows: int, present: list[int]) -> np.ndarray | None:
    """Per-row thresholds on ``|r|`` (``+inf`` for missing rows), or ``None``.

    Only the ``"abs"`` statistic is a per-sample rule; a :class:`Threshold` on the moving
    RMS is refused here (it needs the whole record: use :func:`geomfdi.evaluate`).
    """
    thr = as_threshold(threshold, n_rows, present)
    if thr is None:
        return None
    if isinstance(thr, Threshold) and thr.statistic != "abs" and thr.window != 1:
        raise GeomFDIError(
            "threshold: online decisions use |r| > threshold; a moving-RMS Threshold "
            "is only available in geomfdi.evaluate",
            argument="threshold",
        )
    values = np.array(thr.values, dtype=float)
    mask = np.ones(n_rows, dtype=bool)
    mask[present] = False
    values[mask] = np.inf
    return values


_SHIFTED_SUMS = 16  # longest window summed by shifted byte additions (counts <= 16)


def confirm(raw: np.ndarray, persistence: Persistence, history: np.ndarray) -> np.ndarray:
    """Confirmed alarms of ``raw`` (``(R, L)`` bool) under k-of-n persistence.

    ``history`` (``(R, n-1)``, oldest first) holds the raw alarms of the ``n - 1``
    samples before ``raw``.  Exact integer moving sums: ``n`` shifted byte sums for a
    short window, differences of a cumulative sum for a long one.
    """
    k, n = persistence.k, persistence.n
    if n == 1:
        return raw.copy()
    if n <= _SHIFTED_SUMS:
        L = raw.shape[1]
        ext = np.concatenate([history, raw], axis=1).astype(bool, copy=False).view(np.uint8)
        counts = ext[:, n - 1 :].copy()
        for j in range(1, n):
            counts += ext[:, n - 1 - j : n - 1 - j + L]
        return counts >= k
    ext = np.concatenate([history.astype(np.int64), raw.astype(np.int64)], axis=1)
    cs = np.zeros((ext.shape[0], ext.shape[1] + 1), dtype=np.int64)
    np.cumsum(ext, axis=1, out=cs[:, 1:])
    counts = cs[:, n:] - cs[:, : cs.shape[1] - n]
    return counts >= k


def decision_code(pattern: np.ndarray, structure: np.ndarray) -> int:
    """Isolation decision for one confirmed alarm pattern (rules of :func:`isolate`)."""
    if not pattern.any():
        return NO_ALARM
    match = np.flatnonzero(np.all(structure == pattern[:, None], axis=0))
    if match.size == 1:
        return int(match[0])
    return AMBIGUOUS if match.size > 1 else UNEXPLAINED


@dataclass(frozen=True)
class PatternTable:
    """Isolation decisions looked up by the bit code of the alarm pattern.

    Row ``i`` of a pattern is bit ``i`` of its code; the codes of the structure's columns
    are sorted once, so the decision of every sample of a chunk is one binary search:
    the column index when exactly one column has the sample's code, ``-3`` when several
    do, ``-2`` when none does, ``-1`` for code 0 (the rules of :func:`geomfdi.isolate`).

    Attributes
    ----------
    bits : ndarray of int64, (rows,)
        ``2**i``.
    codes : ndarray of int64
        The distinct codes of the structure's columns, sorted.
    decisions : ndarray of int64
        The decision for each of ``codes``.
    """

    bits: np.ndarray
    codes: np.ndarray
    decisions: np.ndarray

    MAX_ROWS = 62  # codes are int64

    @classmethod
    def of(cls, structure: np.ndarray) -> PatternTable:
        """The table of a structure matrix (``(rows, n_faults)`` bool, rows <= 62)."""
        S = np.asarray(structure, dtype=bool)
        if S.shape[0] > cls.MAX_ROWS:
            raise GeomFDIError(
                f"structure: at most {cls.MAX_ROWS} rows for pattern codes, got {S.shape[0]}",
                argument="structure",
            )
        bits = np.left_shift(1, np.arange(S.shape[0], dtype=np.int64))
        codes, first, count = np.unique(
            bits @ S.astype(np.int64), return_index=True, return_counts=True
        )
        return cls(bits, codes, np.where(count > 1, AMBIGUOUS, first).astype(np.int64))

    def decide(self, alarms: np.ndarray) -> np.ndarray:
        """Decisions ``(L,)`` for confirmed alarms ``(rows, L)``."""
        codes = self.bits @ alarms
        if self.codes.size:
            at = np.minimum(np.searchsorted(self.codes, codes), self.codes.size - 1)
            out = np.where(self.codes[at] == codes, self.decisions[at], UNEXPLAINED)
        else:
            out = np.full(codes.shape, UNEXPLAINED, dtype=np.int64)
        out[codes == 0] = NO_ALARM
        return out
