"""Per-sample decisions of a deployed bank under the library's persistence rule.

The rule is :class:`geomfdi.Persistence` (``k``, ``n``, ``latch``, ``reset``; see
:mod:`geomfdi.evaluation.persistence`), the same for :func:`geomfdi.simulate`,
:func:`geomfdi.evaluate`, :class:`geomfdi.Monitor` and the generated C and Python code.
At sample ``j`` residual ``i`` has a *raw* alarm ``a_i[j] = |r_i[j]| > threshold_i``
(never on a missing sample, never on a row whose generator is missing), and

1. the *confirmed* alarm is the k-of-n count ``sum_{l=j-n+1}^{j} a_i[l] >= k`` (samples
   before the start count as no alarm);
2. the *pattern* decided on is, with ``latch``, the set of residuals confirmed at some
   sample of the current alarm episode (an episode starts at a confirmed alarm and ends
   after ``reset`` samples without one), else the confirmed alarms of the sample;
3. the pattern's decision is the structure column equal to it (``-3`` when several
   are, ``-1`` for no alarm), :data:`~geomfdi.evaluation.decision.MULTIPLE` (``-4``)
   when no column is but the union of the columns inside it is, else ``-2``;
4. a fault index or ``-4`` is kept when it was the pattern's decision for ``k`` of the
   last ``n`` samples (else ``-2``).

Without a rule (``None``, or the trivial ``Persistence(1, 1, latch=False)``) steps 2-4
are the per-sample :func:`geomfdi.isolate` (no ``-4``).  Every count is an integer, so
the rule is exact and the same in numpy, in the monitor's state machine and in the
generated code.  The online state of the rule is the raw alarms of the last ``n - 1``
samples (step 1), the held pattern and the number of quiet samples since the last
confirmed alarm of the episode (step 2), and the pattern decisions of the last
``n - 1`` samples (step 4).  See the user guide, *Theory: residual evaluation*
(``docs/theory/evaluation.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError
from geomfdi.evaluation.decision import (
    AMBIGUOUS,
    MULTIPLE,
    NO_ALARM,
    UNEXPLAINED,
    Threshold,
    as_threshold,
)
from geomfdi.evaluation.persistence import Persistence, k_of_n
from geomfdi.evaluation.persistence import as_persistence as _as_rule

__all__ = [
    "NO_RULE",
    "PatternTable",
    "as_persistence",
    "confirm",
    "decision_code",
    "held_chunk",
    "settle",
    "settle_one",
    "threshold_values",
]

NO_RULE = Persistence(1, 1, latch=False)
"""No persistence: per-sample alarms and decisions."""


def as_persistence(value: Any) -> Persistence:
    """``None`` (no rule: :data:`NO_RULE`), an int ``d`` (``d`` consecutive samples), a
    pair ``(k, n)`` or a :class:`~geomfdi.Persistence` (an int or a pair latch the
    pattern over the episode, without reset, as in :func:`geomfdi.simulate`)."""
    rule = _as_rule(value)
    return NO_RULE if rule is None else rule


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
    """Confirmed alarms of ``raw`` (``(R, L)`` bool) under the k-of-n count (step 1).

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


def held_chunk(
    alarms: np.ndarray, reset: int | None, held: np.ndarray, quiet: int
) -> tuple[np.ndarray, np.ndarray, int]:
    """The held patterns of a chunk of confirmed alarms (step 2), from a state.

    Parameters
    ----------
    alarms : ndarray of bool, (R, L)
        Confirmed alarms of the chunk.
    reset : int or None
        Quiet samples that end an episode (``None``: never).
    held : ndarray of bool, (R,)
        The held pattern before the chunk (all False: no episode).
    quiet : int
        Samples since the episode's last confirmed alarm (``< reset``; 0 without an
        episode).

    Returns
    -------
    pattern : ndarray of bool, (R, L)
        :func:`geomfdi.evaluation.persistence.held_pattern` of the record continued by
        this chunk: the state stands for one virtual sample alarming on ``held``,
        ``quiet + 1`` samples before the chunk, which starts the same episode.
    held, quiet
        The state after the chunk.
    """
    R, L = alarms.shape
    if L == 0:
        return np.zeros((R, 0), dtype=bool), held.copy(), quiet
    if not alarms.any():  # a quiet chunk: the held pattern until the episode ends
        pattern = np.zeros((R, L), dtype=bool)
        if not held.any():
            return pattern, held.copy(), 0
        if reset is None:
            pattern[:] = held[:, None]
            return pattern, held.copy(), 0
        stay = min(L, reset - quiet - 1)  # samples before the reset-th quiet one
        pattern[:, :stay] = held[:, None]
        if stay == L:
            return pattern, held.copy(), quiet + L
        return pattern, np.zeros(R, dtype=bool), 0
    if reset is None:
        pattern = np.logical_or.accumulate(alarms, axis=1)
        pattern |= held[:, None]
        return pattern, pattern[:, -1].copy(), 0
    idx = np.arange(L)
    active0 = bool(held.any())
    before = -(quiet + 1) if active0 else -(reset + 1)  # last alarm before the chunk
    never = -(reset + 2)  # before every episode start
    anyal = alarms.any(axis=0)
    last_any = np.maximum.accumulate(np.where(anyal, idx, before))
    prev = np.empty(L, dtype=last_any.dtype)
    prev[0] = before
    prev[1:] = last_any[:-1]
    start = anyal & (idx - prev - 1 >= reset)
    active = idx - last_any < reset
    if not start.any():  # one episode, continued from the state (an alarm exists)
        pattern = np.logical_or.accumulate(alarms, axis=1)
        pattern |= held[:, None]
        pattern &= active
    else:
        last_res = np.maximum.accumulate(
            np.where(alarms, idx, np.where(held, before, never)[:, None]), axis=1
        )
        ep_start = np.maximum.accumulate(np.where(start, idx, before if active0 else never))
        pattern = active & (last_res >= ep_start)
    end = pattern[:, -1].copy()
    return pattern, end, int(L - 1 - last_any[-1]) if end.any() else 0


def decision_code(pattern: np.ndarray, structure: np.ndarray, multiple: bool = False) -> int:
    """The decision for one pattern (step 3; ``multiple=False``: :func:`geomfdi.isolate`)."""
    if not pattern.any():
        return NO_ALARM
    match = np.flatnonzero(np.all(structure == pattern[:, None], axis=0))
    if match.size == 1:
        return int(match[0])
    if match.size > 1:
        return AMBIGUOUS
    if multiple:
        inside = structure.any(axis=0) & ~np.any(structure & ~pattern[:, None], axis=0)
        if np.array_equal(structure[:, inside].any(axis=1), pattern):
            return MULTIPLE
    return UNEXPLAINED


def settle_one(code: int, history: Any, k: int) -> int:
    """Step 4 for one sample: ``history`` holds the previous ``n - 1`` pattern decisions."""
    if code >= 0 or code == MULTIPLE:
        return code if history.count(code) + 1 >= k else UNEXPLAINED
    return code


def settle(codes: np.ndarray, history: np.ndarray, k: int, n: int) -> np.ndarray:
    """Step 4 for a chunk of pattern decisions ``codes`` (``(L,)``) after the ``n - 1``
    decisions in ``history`` (oldest first), vectorised per decision value."""
    kept = (codes >= 0) | (codes == MULTIPLE)
    if k == 1 or not kept.any():  # the sample itself is one of the k
        return codes.copy()
    out = np.where(kept, UNEXPLAINED, codes)
    ext = np.concatenate([history, codes])
    L = codes.size
    if n <= _SHIFTED_SUMS:  # count the equal decisions in the window by shifts
        count = np.ones(L, dtype=np.int8)
        for d in range(1, n):
            count += ext[n - 1 - d : n - 1 - d + L] == codes
        np.copyto(out, codes, where=kept & (count >= k))
        return out
    for code in np.unique(codes[kept]).tolist():
        hit = ext == code
        ok = k_of_n(hit, k, n)[n - 1 :] & hit[n - 1 :]
        out[ok] = code
    return out


@dataclass(frozen=True)
class PatternTable:
    """Pattern decisions (step 3) looked up by the bit code of the pattern.

    Row ``i`` of a pattern is bit ``i`` of its code; the codes of the structure's columns
    are sorted once, so the decision of every sample of a chunk is one binary search:
    the column index when exactly one column has the sample's code, ``-3`` when several
    do, ``-1`` for code 0, else ``-2``, or ``-4`` (``multiple``) when the OR of the
    codes of the columns inside the pattern is the pattern's code.

    Attributes
    ----------
    bits : ndarray of int64, (rows,)
        ``2**i``.
    codes : ndarray of int64
        The distinct codes of the structure's columns, sorted.
    decisions : ndarray of int64
        The decision for each of ``codes``.
    columns : ndarray of int64
        The distinct non-zero column codes (for ``-4``).
    multiple : bool
    """

    bits: np.ndarray
    codes: np.ndarray
    decisions: np.ndarray
    columns: np.ndarray
    multiple: bool = False

    MAX_ROWS = 62  # codes are int64

    @classmethod
    def of(cls, structure: np.ndarray, multiple: bool = False) -> PatternTable:
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
        dec = np.where(count > 1, AMBIGUOUS, first).astype(np.int64)
        return cls(bits, codes, dec, codes[codes != 0], bool(multiple))

    def decide_codes(self, codes: np.ndarray) -> np.ndarray:
        """Decisions ``(L,)`` for pattern codes ``(L,)``."""
        if self.codes.size:
            at = np.minimum(np.searchsorted(self.codes, codes), self.codes.size - 1)
            out = np.where(self.codes[at] == codes, self.decisions[at], UNEXPLAINED)
        else:
            out = np.full(codes.shape, UNEXPLAINED, dtype=np.int64)
        out[codes == 0] = NO_ALARM
        if self.multiple and self.columns.size:
            unexplained = np.flatnonzero(out == UNEXPLAINED)
            if unexplained.size:  # decided once per run of equal patterns (held ones)
                c = codes[unexplained]
                starts = np.flatnonzero(np.concatenate(([True], c[1:] != c[:-1])))
                first = c[starts]
                inside = (self.columns & ~first[:, None]) == 0
                union = np.bitwise_or.reduce(np.where(inside, self.columns, 0), axis=1)
                multi = np.repeat(union == first, np.diff(np.append(starts, c.size)))
                out[unexplained[multi]] = MULTIPLE
        return out

    def decide(self, alarms: np.ndarray) -> np.ndarray:
        """Decisions ``(L,)`` for patterns ``(rows, L)``."""
        return self.decide_codes(self.bits @ alarms)
