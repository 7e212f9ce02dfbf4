"""Persistence rules: alarms confirmed k of n samples, isolation from a held pattern.

A threshold crossing of one sample is often noise, and with several simultaneous faults
the residuals cross their thresholds in and out at different times, so that a
*momentary* alarm pattern can equal one column of the structure matrix while several
faults are present (a coincidental isolation).  A rule here has three parts:

1. **Confirmation** (k-of-n): the alarm of residual ``i`` holds at sample ``j`` when its
   raw alarm was on for at least ``k`` of the samples ``j-n+1 .. j``; ``k = n`` is a
   minimum duration.
2. **Memory** (``latch``): within an alarm *episode* the pattern is the set of residuals
   confirmed at some sample since the episode began.  A residual that drops below its
   threshold does not exonerate its faults: the effect of a gain fault passes through
   zero with the signal it multiplies, yet the fault is still there.  An episode starts
   at the first confirmed alarm and ends after ``reset`` samples without any confirmed
   alarm (``reset=None``: at the end of the record).
3. **Settling**: a decision (a fault, or several faults) is kept only when the decision
   on the held pattern was the same for ``k`` of the last ``n`` samples.

Isolation is thus decided only from a held pattern that matches a fault signature; a
pattern that matches no single column but is the union of the columns of its suspects is
the decision :data:`~geomfdi.evaluation.decision.MULTIPLE` (the suspects name the
faults).  ``latch=False`` gives the memoryless rule (confirmation and settling only).
See the user guide, *Theory: evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi._validation import as_bool, as_int
from geomfdi.errors import GeomFDIError
from geomfdi.evaluation.decision import (
    AMBIGUOUS,
    MULTIPLE,
    NO_ALARM,
    UNEXPLAINED,
    Isolation,
    Threshold,
    isolate,
)

__all__ = [
    "Persistence",
    "as_persistence",
    "decisions",
    "held_pattern",
    "held_pattern_carry",
    "k_of_n",
    "every_pattern",
    "pattern_codes",
    "pattern_decisions",
    "pattern_table",
    "settle",
]


#: Windows up to which :func:`k_of_n` and :func:`settle` count by adding shifted copies;
#: longer ones by a cumulative count.
SHIFT_WINDOW = 8


def k_of_n(flags: Any, k: int, n: int) -> np.ndarray:
    """``out[..., j] = sum(flags[..., j-n+1 : j+1]) >= k`` (time on the last axis).

    The first ``n - 1`` samples count the samples available (a rule cannot fire before
    ``k`` samples were seen).
    """
    f = np.asarray(flags, dtype=bool)
    if k == 1 and n == 1:
        return f.copy()
    if n <= SHIFT_WINDOW:  # a short window: n - 1 shifted byte additions
        c = f.astype(np.uint8)
        for d in range(1, min(n, f.shape[-1])):
            c[..., d:] += f[..., :-d]
        return c >= k
    c = np.cumsum(f, axis=-1, dtype=np.int32)
    win = c.copy()
    win[..., n:] -= c[..., :-n]
    return win >= k


def held_pattern(alarms: Any, reset: int | None = None) -> np.ndarray:
    """The alarm pattern held over each alarm episode (time on the last axis).

    ``out[..., i, j]`` is True when residual ``i`` alarmed at some sample of the episode
    containing ``j``, up to ``j``.  An episode starts at a sample with an alarm (on any
    residual) and ends after ``reset`` consecutive samples without one; ``reset=None``:
    never (the pattern only grows to the end of the record).

    Parameters
    ----------
    alarms : array_like of bool, (..., n_residuals, N)
        Confirmed alarms.
    reset : int, optional

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([[1, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 1]], dtype=bool)
    >>> held_pattern(a).astype(int).tolist()
    [[1, 1, 1, 1, 1, 1], [0, 0, 1, 1, 1, 1]]
    >>> held_pattern(a, reset=2).astype(int).tolist()
    [[1, 1, 1, 1, 0, 0], [0, 0, 1, 1, 0, 1]]
    """
    return held_pattern_carry(alarms, reset)[0]


#: "No such sample yet" in the episode state of :func:`held_pattern_carry`.
_NEVER = np.iinfo(np.int64).min // 4

#: Largest confirmation window ``n`` (and ``k``) of a rule, in samples: a monitor keeps
#: the last ``n`` alarm patterns and decisions (and generated C code a static ring of
#: them), so a window of ``10**9`` samples would need gigabytes before the first one.
MAX_WINDOW = 1_000_000


def held_pattern_carry(
    alarms: Any, reset: int | None = None, state: tuple[np.ndarray, ...] | None = None
) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
    """:func:`held_pattern` of a record given in consecutive pieces.

    ``state`` (``None`` at the start of the record) is what the pattern after the
    previous piece depends on, returned for the next piece: with ``reset=None`` the
    residuals held so far ``(..., n_residuals)``; otherwise the last sample with an
    alarm on any residual ``(...)``, the last one of each residual ``(..., n_residuals)``
    and the start of the current episode ``(...)``, as indices relative to the start of
    the next piece.  The pieces' patterns, concatenated, equal the pattern of the
    whole record.
    """
    a = np.asarray(alarms, dtype=bool)
    if a.ndim < 2:
        raise GeomFDIError(
            f"alarms: expected (..., n_residuals, N), got shape {a.shape}", argument="alarms"
        )
    lead, N = a.shape[:-1], a.shape[-1]
    if reset is None:
        # held from the first alarm on (argmax stops at the first True)
        out = np.zeros(a.shape, dtype=bool)
        if N:
            first = np.argmax(a, axis=-1)[..., None]
            out = (np.arange(N) >= first) & np.take_along_axis(a, first, axis=-1)
        if state is not None:
            out |= state[0][..., None]
        held = out[..., -1].copy() if N else (np.zeros(lead, bool) if state is None else state[0])
        return out, (held,)
    reset = as_int(reset, "reset", minimum=1)
    idx = np.arange(N)
    if state is None:
        state = (
            np.full(lead[:-1], _NEVER, dtype=np.int64),
            np.full(lead, _NEVER, dtype=np.int64),
            np.full(lead[:-1], _NEVER, dtype=np.int64),
        )
    last0, res0, ep0 = state
    # last sample with an alarm (any residual / each residual), carried from the past
    anyal = a.any(axis=-2)
    last_any = np.maximum.accumulate(np.where(anyal, idx, last0[..., None]), axis=-1)
    last_res = np.maximum.accumulate(np.where(a, idx, res0[..., None]), axis=-1)
    # an episode starts at an alarm sample preceded by >= reset quiet samples (or none)
    prev_last = np.concatenate([last0[..., None], last_any[..., :-1]], axis=-1)
    start = anyal & ((prev_last == _NEVER) | (idx - prev_last - 1 >= reset))
    ep_start = np.maximum.accumulate(np.where(start, idx, ep0[..., None]), axis=-1)
    active = (ep_start > _NEVER) & (idx - last_any < reset)
    out = active[..., None, :] & (last_res >= ep_start[..., None, :])
    if N == 0:
        return out, state
    shift = lambda x: np.where(x == _NEVER, _NEVER, x - N)  # noqa: E731
    return out, (shift(last_any[..., -1]), shift(last_res[..., -1]), shift(ep_start[..., -1]))


#: Residuals up to which the distinct patterns are found by a table of all ``2**n_res``
#: codes (a counting pass); above, by sorting the codes (``numpy.unique``).
TABLE_RESIDUALS = 20


def pattern_codes(
    pattern: np.ndarray, out: np.ndarray | None = None, scratch: np.ndarray | None = None
) -> np.ndarray:
    """Each sample's alarm pattern ``(..., n_res, N)`` as an integer ``sum_i a_i 2**i``
    ``(..., N)`` (``n_res <= 62``): bytes up to 8 residuals, 16 bits up to 16, else 64.

    ``out`` and ``scratch`` (that dtype, shape ``(..., N)``), when given, receive the codes
    and the shifted rows: no array is allocated (a chunk loop reuses them).
    """
    nres = pattern.shape[-2]
    dtype = np.uint8 if nres <= 8 else np.uint16 if nres <= 16 else np.int64
    shape = pattern.shape[:-2] + pattern.shape[-1:]
    codes = np.empty(shape, dtype=dtype) if out is None else out
    bit = np.empty(shape, dtype=dtype) if scratch is None else scratch
    codes[...] = pattern[..., 0, :]
    for r in range(1, nres):
        bit[...] = pattern[..., r, :]
        bit <<= r
        codes |= bit
    return codes


def every_pattern(nres: int) -> np.ndarray:
    """The ``2**nres`` alarm patterns ``(nres, 2**nres)``, column ``c`` the pattern of code
    ``c`` (:func:`pattern_codes`)."""
    return ((np.arange(1 << nres)[None, :] >> np.arange(nres)[:, None]) & 1).astype(bool)


def pattern_table(pattern: Any, structure: Any) -> tuple[np.ndarray, Isolation] | None:
    """The distinct alarm patterns of ``pattern (..., n_res, N)``, each decided once.

    Returns ``(index, table)``: ``index (..., N)`` gives each sample's row of ``table``,
    the :func:`pattern_decisions` of the distinct patterns in increasing order of their
    codes (:func:`pattern_codes`): ``isolated (U,)``, ``candidates`` and ``suspects``
    ``(n_faults, U)``.  Up to 8 residuals the table holds every pattern and the index is
    the code itself; ``None`` for more than 62 residuals (no integer code).
    """
    pattern = np.asarray(pattern, dtype=bool)
    nres = pattern.shape[-2]
    if not 0 < nres <= 62:
        return None
    codes = pattern_codes(pattern)
    if nres <= 8:  # a byte per sample: every pattern decided, the code is the index
        return codes, _decide_patterns(every_pattern(nres), structure)
    elif nres <= TABLE_RESIDUALS:  # the codes met, from one counting pass
        uniq = np.flatnonzero(np.bincount(codes.ravel(), minlength=1 << nres))
        lut = np.zeros(1 << nres, dtype=np.intp)
        lut[uniq] = np.arange(uniq.size)
        index = lut[codes]
    else:
        uniq, inv = np.unique(codes.ravel(), return_inverse=True)
        index = inv.reshape(codes.shape)
    few = ((uniq[None, :].astype(np.int64) >> np.arange(nres)[:, None]) & 1).astype(bool)
    return index, _decide_patterns(few, structure)


def pattern_decisions(pattern: Any, structure: Any) -> Isolation:
    """Per-sample decisions on an alarm pattern, with :data:`MULTIPLE`.

    As :func:`geomfdi.isolate`, except that an ``UNEXPLAINED`` pattern that is the union
    of the columns of its suspects is decided ``MULTIPLE`` (the suspects' columns are
    inside the pattern by definition).  A long record holds few distinct patterns: each
    is decided once (:func:`pattern_table`) and the decisions are gathered back per
    sample.
    """
    pattern = np.asarray(pattern, dtype=bool)
    nres = pattern.shape[-2] if pattern.ndim >= 2 else 0
    if pattern.ndim >= 2 and 0 < nres <= 62 and pattern[..., 0, :].size > 256:
        index, small = pattern_table(pattern, structure)  # type: ignore[misc]

        def back(x: np.ndarray) -> np.ndarray:  # (n_faults, U) -> (..., n_faults, N)
            return np.moveaxis(x[:, index], 0, -2)

        return Isolation(small.isolated[index], back(small.candidates), back(small.suspects))
    return _decide_patterns(pattern, structure)


def _decide_patterns(pattern: np.ndarray, structure: Any) -> Isolation:
    """:func:`pattern_decisions` sample by sample."""
    iso = isolate(pattern, structure)
    S = np.asarray(structure, dtype=bool)
    raw = iso.isolated.copy()
    unexplained = raw == UNEXPLAINED
    if unexplained.any():
        # residuals covered by the columns of the suspects; MULTIPLE when they cover
        # the whole pattern
        covered = np.zeros(pattern.shape, dtype=bool)
        for j in range(S.shape[1]):
            col = S[:, j]
            if col.any():
                covered |= iso.suspects[..., j : j + 1, :] & col[:, None]
        whole = ~np.any(pattern & ~covered, axis=-2)
        raw[unexplained & whole] = MULTIPLE
    return Isolation(raw, iso.candidates, iso.suspects)


def settle(raw: np.ndarray, k: int, n: int, n_faults: int) -> np.ndarray:
    """Settled decisions: a fault index or ``MULTIPLE`` is kept at sample ``j`` when it
    was the per-sample decision ``raw`` for ``k`` of the last ``n`` samples and is it at
    ``j`` (otherwise ``UNEXPLAINED``); ``NO_ALARM`` and ``AMBIGUOUS`` are kept."""
    raw = np.asarray(raw)
    out = np.where(raw == NO_ALARM, NO_ALARM, UNEXPLAINED)
    out[raw == AMBIGUOUS] = AMBIGUOUS
    if n <= SHIFT_WINDOW:
        # count[j] = #{d < n : raw[j - d] == raw[j]} (the samples available at first)
        count = np.ones(raw.shape, dtype=np.int32)
        for d in range(1, min(n, raw.shape[-1])):
            count[..., d:] += raw[..., d:] == raw[..., :-d]
        keep = (count >= k) & ((raw >= 0) & (raw < n_faults) | (raw == MULTIPLE))
        np.copyto(out, raw, where=keep)
        return out
    for code in (*range(n_faults), MULTIPLE):
        hit = raw == code
        if hit.any():
            out[hit & k_of_n(hit, k, n)] = code
    return out


@dataclass(frozen=True)
class Persistence:
    """A decision rule: k-of-n confirmation, episode memory, settled decisions.

    Attributes
    ----------
    k, n : int
        An alarm (decision) holds at sample ``j`` when the raw one held for at least ``k``
        of the ``n`` samples ending at ``j``; ``1 <= k <= n <= MAX_WINDOW`` (``10**6``).
    latch : bool, default True
        Decide from the pattern held over the alarm episode (module docstring);
        ``False``: from the momentary pattern of confirmed alarms.
    reset : int, optional
        Samples without any confirmed alarm that end an episode (``None``: the episode
        lasts to the end of the record, the diagnosis of a permanent fault is not
        withdrawn).

    ``Persistence(1, 1, latch=False)`` is no rule at all (per-sample decisions).

    Examples
    --------
    >>> import numpy as np
    >>> from geomfdi.evaluation.persistence import Persistence
    >>> Persistence(2, 3).apply(np.array([[1, 0, 1, 0, 0, 1, 1]], dtype=bool)).astype(int).tolist()
    [[0, 0, 1, 0, 0, 0, 1]]
    """

    k: int = 1
    n: int = 1
    latch: bool = True
    reset: int | None = None

    def __post_init__(self) -> None:
        k = as_int(self.k, "persistence.k", minimum=1, maximum=MAX_WINDOW)
        n = as_int(self.n, "persistence.n", minimum=1, maximum=MAX_WINDOW)
        if k > n:
            raise GeomFDIError(
                f"persistence: k={k} of n={n} samples needs k <= n", argument="persistence"
            )
        object.__setattr__(self, "k", k)
        object.__setattr__(self, "n", n)
        object.__setattr__(self, "latch", as_bool(self.latch, "persistence.latch"))
        if self.reset is not None:
            reset = as_int(self.reset, "persistence.reset", minimum=1, maximum=2**31 - 1)
            object.__setattr__(self, "reset", reset)

    @classmethod
    def from_duration(cls, duration: float, dt: float, **kwargs: Any) -> Persistence:
        """A minimum duration: ``k = n = ceil(duration / dt)`` samples (at least 1)."""
        if isinstance(duration, bool) or not isinstance(duration, numbers.Real):
            raise GeomFDIError("duration: must be a number of seconds", argument="duration")
        if not (math.isfinite(duration) and duration >= 0):
            raise GeomFDIError(f"duration: must be >= 0, got {duration}", argument="duration")
        if not (isinstance(dt, numbers.Real) and math.isfinite(dt) and dt > 0):
            raise GeomFDIError(f"dt: must be > 0, got {dt}", argument="dt")
        m = max(1, math.ceil(duration / dt - 1e-9))
        return cls(m, m, **kwargs)

    @property
    def trivial(self) -> bool:
        """No rule: per-sample alarms and decisions."""
        return self.k == 1 and self.n == 1 and not self.latch

    def apply(self, alarms: Any) -> np.ndarray:
        """Confirmed alarms, same shape as ``alarms`` (time on the last axis)."""
        return k_of_n(alarms, self.k, self.n)

    def isolation(self, alarms: Any, structure: Any) -> Isolation:
        """Isolation decisions from confirmed alarms ``(..., n_residuals, N)``.

        The pattern is the held one (:func:`held_pattern`, with ``latch``) or the
        momentary one.  Per sample, the pattern's decision is a fault index (one column
        equals it), :data:`MULTIPLE` (no column equals it, the union of its suspects'
        columns does), ``AMBIGUOUS``, ``UNEXPLAINED`` or ``NO_ALARM``; a fault index or
        ``MULTIPLE`` is kept at sample ``j`` when it was the decision for ``k`` of the
        last ``n`` samples and is it at ``j`` (otherwise ``UNEXPLAINED``).  Candidates
        and suspects refer to the pattern decided on.
        """
        a = np.asarray(alarms, dtype=bool)
        pattern = held_pattern(a, self.reset) if self.latch else a
        iso = pattern_decisions(pattern, structure)
        if self.k == 1 and self.n == 1:
            return iso
        n_faults = np.shape(structure)[1]
        return Isolation(
            settle(iso.isolated, self.k, self.n, n_faults), iso.candidates, iso.suspects
        )


def as_persistence(value: Any) -> Persistence | None:
    """``None``, ``n`` (minimum duration of ``n`` samples), ``(k, n)`` or a Persistence.

    An int or a pair gives the default memory (``latch=True``, no reset).
    """
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

    No threshold: no alarm.  With a persistence rule the alarms are the confirmed ones
    and isolation is :meth:`Persistence.isolation`; without one (or a trivial rule) both
    are per sample (:func:`geomfdi.isolate`).
    """
    if threshold is None:
        # no alarm anywhere: every decision is NO_ALARM (nothing to compute)
        shape = np.shape(residuals)
        S = np.asarray(structure, dtype=bool)
        lead, N = shape[:-2], shape[-1]
        none = np.zeros((*lead, S.shape[1], N), dtype=bool)
        iso = Isolation(np.full((*lead, N), NO_ALARM, dtype=int), none, none.copy())
        return np.zeros(shape, dtype=bool), iso
    alarms = threshold.alarms(residuals)
    if persistence is None or persistence.trivial:
        return alarms, isolate(alarms, structure)
    alarms = persistence.apply(alarms)
    return alarms, persistence.isolation(alarms, structure)
