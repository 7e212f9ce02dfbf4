"""The per-sample step and the chunked update of an online monitor.

State of a monitor (all in preallocated arrays, updated in place):

* ``v = [xi; z]``: the fused generator state ``xi`` followed by the current sample
  ``z = [y; u]``, so that one product ``Phi v`` with ``Phi = [[A, B], [C, D]]`` gives the
  next state and the residual components (:mod:`geomfdi.deployment.program`);
* ``pending``: the initial-state rule still to apply (start, or after a missing sample);
* ``history`` / ``packed``: the raw alarms of the last ``n`` samples and their per-row
  sums, for the k-of-n count of :mod:`geomfdi.deployment.decide`;
* ``held``, ``quiet``: the pattern held over the current alarm episode (a bit code, row
  ``i`` is bit ``i``) and the samples since its last confirmed alarm;
* ``decisions``: the pattern decisions of the last ``n - 1`` samples (settling).

:func:`make_step` builds the one-sample update as a closure over these arrays (no
attribute look-ups, no allocation but the returned copies); :func:`make_feed` likewise
the chunk update, which runs a whole chunk with the loop-free recursion and leaves the
same state behind, so any mix of steps and chunks gives the same residuals (to
rounding) and the same decisions.  See the user guide, *Theory: residual evaluation*
(``docs/theory/evaluation.md``).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from geomfdi.deployment.decide import (
    PatternTable,
    confirm,
    decision_code,
    held_chunk,
    settle,
    settle_one,
)
from geomfdi.deployment.program import SAMPLE_LIMIT, Program, initial_state, run_program
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.evaluation.decision import NO_ALARM, isolate
from geomfdi.evaluation.persistence import Persistence

__all__ = ["MonitorStep", "MonitorOutput", "MonitorState", "make_step", "make_feed"]


class MonitorStep(NamedTuple):
    """Outcome of one :meth:`Monitor.step`: residual per bank row, confirmed alarms, and
    the isolation decision (fault index, or ``-1`` / ``-2`` / ``-3`` / ``-4``; ``None``
    when isolation is off)."""

    residuals: np.ndarray
    alarms: np.ndarray
    isolated: int | None


@dataclass
class MonitorOutput:
    """Outcome of :meth:`Monitor.feed` on ``L`` samples.

    Attributes
    ----------
    residuals : ndarray, (n_residuals, L)
    raw_alarms, alarms : ndarray of bool, (n_residuals, L)
    isolated : ndarray of int (L,) or None
    masked : ndarray of bool, (L,)
    """

    residuals: np.ndarray
    raw_alarms: np.ndarray
    alarms: np.ndarray
    isolated: np.ndarray | None
    masked: np.ndarray


class MonitorState:
    """The mutable state of a monitor (module docstring).

    ``xi`` (generator state), ``last`` (the last sample ``z``), ``pending`` (start-up
    rule still to apply), ``history`` (the raw alarm patterns of the last ``n`` samples,
    oldest first, each packed into an int with ``width`` bits per row) and ``packed``
    (their per-row sums, packed the same way), ``held`` (bit code of the held pattern,
    0 outside an episode), ``quiet`` (samples since the episode's last confirmed alarm),
    ``decisions`` (pattern decisions of the last ``n - 1`` samples, oldest first),
    ``samples`` (samples seen).
    """

    def __init__(self, program: Program, persistence: Persistence, pending: Any) -> None:
        self.rows = program.n_rows
        self.width = persistence.n.bit_length()
        # packed patterns fit an int64 (vectorised packing) when the bits do
        self._shifts = (
            np.arange(self.rows, dtype=np.int64) * self.width
            if self.width * self.rows <= 62
            else None
        )
        self.xi = np.zeros(program.nw)
        self.last = np.zeros(program.nz)
        self.pending = pending
        self.history: deque[int] = deque([0] * persistence.n)
        self.packed = 0
        self.held = 0
        self.quiet = 0
        self.decisions: deque[int] = deque([NO_ALARM] * (persistence.n - 1))
        self.samples = 0

    def held_rows(self) -> np.ndarray:
        """The held pattern as a bool per row."""
        return np.array([(self.held >> i) & 1 for i in range(self.rows)], dtype=bool)

    def set_held(self, rows: Any) -> None:
        """Set the held pattern from a bool per row."""
        self.held = code_of(rows)

    def pack(self, bits: Any) -> int:
        """One alarm pattern (bool per row) as an int, ``width`` bits per row."""
        w = self.width
        return sum(1 << (w * i) for i, b in enumerate(bits) if b)

    def counts(self, packed: int) -> np.ndarray:
        """Per-row counts from a packed int."""
        mask = (1 << self.width) - 1
        return np.array([(packed >> (self.width * i)) & mask for i in range(self.rows)])

    def ordered_ring(self) -> np.ndarray:
        """The raw alarms of the last ``n`` samples, oldest first (``(n, rows)`` bool)."""
        if self._shifts is not None:
            codes = np.array(self.history, dtype=np.int64)
            return ((codes[:, None] >> self._shifts) & 1).astype(bool)
        return np.array([self.counts(p) for p in self.history], dtype=bool).reshape(
            len(self.history), self.rows
        )

    def set_ring(self, ordered: np.ndarray) -> None:
        """Set the raw alarms of the last ``n`` samples (``(n, rows)`` bool, oldest first)."""
        if self._shifts is not None:
            codes = (ordered.astype(np.int64) << self._shifts).sum(axis=1).tolist()
            self.history = deque(codes)
        else:
            self.history = deque(self.pack(row) for row in ordered)
        self.packed = sum(self.history)


def code_of(bits: Any) -> int:
    """The bit code of a pattern (row ``i`` is bit ``i``)."""
    return sum(1 << i for i, b in enumerate(np.asarray(bits).tolist()) if b)


def _signal(value: Any, size: int, name: str) -> None:
    if value is None:
        if size:
            raise ShapeError(f"{name}: expected {size} values, got None", argument=name)
        return
    try:
        shape = f"shape {np.shape(value)}"
        ok = np.ndim(value) == 1 and len(value) == size
    except (TypeError, ValueError):  # ragged or not a sequence
        shape, ok = f"a ragged or unreadable {type(value).__name__}", False
    if not ok:
        raise ShapeError(f"{name}: expected {size} values, got {shape}", argument=name)


def _real_sample(y: Any, u: Any, m: int, nw: int) -> np.ndarray:
    """``[xi-slot; y; u]`` for a sample that is not already real floats: booleans and
    integers are read as numbers, complex values and text are refused (named)."""
    from geomfdi._validation import as_real_array

    parts = [np.zeros(nw)]
    for name, value in (("y", y), ("u", u if m else [])):
        try:
            parts.append(as_real_array(value, name, allow_nonfinite=True).reshape(-1))
        except GeomFDIError:
            raise
        except (TypeError, ValueError, OverflowError) as exc:
            raise ShapeError(f"{name}: cannot read the sample ({exc})", argument=name) from exc
    return np.concatenate(parts)


def _read_only(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def make_step(
    program: Program,
    state: MonitorState,
    thresholds: np.ndarray | None,
    persistence: Persistence,
    isolation: bool,
    restart: str,
) -> Any:
    """The one-sample update ``step(y, u) -> MonitorStep`` over ``state``.

    One fused product per sample: ``res = Phi [xi; z]`` with rows ``[A B]`` (next
    state), ``[C D]`` and ``[-C -D]`` (the residual rows and their negatives, so that
    ``|r| > threshold`` is one comparison).  A sample is missing when an entry of ``z``
    is not finite or beyond :data:`~geomfdi.deployment.program.SAMPLE_LIMIT` in
    magnitude, or when ``Phi v`` overflows (``(Phi v) . 0`` is ``nan``); the state is then
    not advanced and the start-up rule is pending.  The raw alarm pattern, its k-of-n counts
    and the pattern decision are looked up in caches keyed by the packed pattern; the
    held pattern and the settling of decisions (:mod:`geomfdi.deployment.decide`) are
    integer operations on bit codes.
    """
    nw, q, m, nz = program.nw, program.q, program.m, program.nz
    rows = program.n_rows
    fast = all(s is None or s[1] - s[0] == 1 for s in program.rows)
    if fast:  # one residual row per bank row (zero rows for missing generators)
        Cr = np.zeros((rows, nw))
        Dr = np.zeros((rows, nz))
        for i, s in enumerate(program.rows):
            if s is not None:
                Cr[i], Dr[i] = program.C[s[0]], program.D[s[0]]
        Phi = np.block([[program.A, program.B], [Cr, Dr], [-Cr, -Dr]])
    else:
        Phi = np.block([[program.A, program.B], [program.C, program.D]])
    Phi = np.ascontiguousarray(Phi)
    n_out = Phi.shape[0]
    thr = np.full(rows, np.inf) if thresholds is None else thresholds
    thr2 = np.concatenate([thr, thr])
    k, n = persistence.k, persistence.n
    latch, reset = persistence.latch, persistence.reset
    multiple = not persistence.trivial
    settling = n > 1 and isolation
    structure = program.structure
    # raw pattern -> (packed counts, raw alarms, bit code); packed counts -> (confirmed
    # alarms, bit code); pattern code -> pattern decision
    raw_cache: dict[bytes, tuple[int, np.ndarray, int]] = {}
    conf_cache: dict[int, tuple[np.ndarray, int]] = {}
    dec_cache: dict[int, int] = {}
    nan_rows = np.full(rows, np.nan)
    concatenate, isfinite, abs_, float64 = np.concatenate, math.isfinite, np.abs, np.float64
    limit = SAMPLE_LIMIT
    zeros_out = np.zeros(n_out)
    empty = np.zeros(0)
    row_bits = [1 << i for i in range(rows)]

    def pattern_decision(code: int) -> int:
        dec = dec_cache.get(code)
        if dec is None:
            bits = np.array([code & b != 0 for b in row_bits], dtype=bool)
            dec = dec_cache[code] = decision_code(bits, structure, multiple)
        return dec

    def raw_entry(key: bytes, raw: np.ndarray) -> tuple[int, np.ndarray, int]:
        entry = raw_cache[key] = (state.pack(raw), _read_only(raw), code_of(raw))
        return entry

    def confirmed(entry: tuple[int, np.ndarray, int]) -> tuple[np.ndarray, int | None]:
        if n == 1:
            state.history[0] = state.packed = entry[0]
            conf, code = entry[1], entry[2]
        else:
            hist = state.history
            hist.append(entry[0])
            packed = state.packed = state.packed + entry[0] - hist.popleft()
            got = conf_cache.get(packed)
            if got is None:
                c = _read_only(state.counts(packed) >= k)
                got = conf_cache[packed] = (c, code_of(c))
            conf, code = got
        if latch:
            if code:
                state.held |= code
                state.quiet = 0
            elif state.held and reset is not None:
                state.quiet += 1
                if state.quiet >= reset:
                    state.held = state.quiet = 0
            code = state.held
        if not isolation:
            return conf, None
        dec = pattern_decision(code)
        if settling:
            hist_d = state.decisions
            out = settle_one(dec, hist_d, k)
            hist_d.append(dec)
            hist_d.popleft()
            return conf, out
        return conf, dec

    zero_entry = (0, _read_only(np.zeros(rows, dtype=bool)), 0)

    def step(y: Any, u: Any = None) -> MonitorStep:
        if not hasattr(y, "__len__") or len(y) != q:
            _signal(y, q, "y")
        if m and (not hasattr(u, "__len__") or len(u) != m):
            _signal(u, m, "u")
        try:
            v = concatenate((state.xi, y, u if m else empty))
        except (ValueError, TypeError) as exc:
            raise ShapeError(f"y, u: cannot read the sample ({exc})", argument="y") from exc
        if v.dtype != float64:
            v = _real_sample(y, u, m, nw)
        state.samples += 1
        z = v[nw:]
        # missing: an entry not finite or out of range (max of a nan is nan)
        if not abs_(z).max(initial=0.0) <= limit:
            return missing()
        if state.pending is not None:
            v[:nw] = initial_state(program, state.pending, z)
            state.pending = None
        res = Phi.dot(v)
        if not isfinite(res.dot(zeros_out)):  # an overflow (x * 0 is nan for inf / nan)
            return missing()
        state.last = z
        state.xi = res[:nw]
        if fast:
            r = res[nw : nw + rows]
            key = (res[nw:n_out] > thr2).tobytes()
            entry = raw_cache.get(key)
            if entry is None:
                raw = res[nw:n_out] > thr2
                entry = raw_entry(key, raw[:rows] | raw[rows:])
        else:
            r = program.row_values(res[nw:n_out, None])[:, 0]
            raw = np.abs(r) > thr
            key = raw.tobytes()
            entry = raw_cache.get(key) or raw_entry(key, raw)
        conf, code = confirmed(entry)
        return MonitorStep(r, conf, code)

    def missing() -> MonitorStep:
        """A missing sample: flagged, state not advanced, restart at the next one."""
        state.pending = restart
        conf, code = confirmed(zero_entry)
        return MonitorStep(nan_rows.copy(), conf, code)

    if _may_overflow(program, Phi):  # an unstable or huge bank: overflow is expected
        plain = step

        def step(y: Any, u: Any = None) -> MonitorStep:
            with np.errstate(over="ignore", invalid="ignore"):
                return plain(y, u)

    return step


def _may_overflow(program: Program, Phi: np.ndarray) -> bool:
    """Whether the update of a valid sample can overflow: an unstable bank (spectral
    radius of ``A`` at least 1), or products beyond ``1e250`` for samples and states
    at :data:`~geomfdi.deployment.program.SAMPLE_LIMIT`."""
    if not Phi.size:
        return False
    if np.abs(Phi).sum(axis=1).max() > 1e100:
        return True
    return bool(program.nw and np.abs(np.linalg.eigvals(program.A)).max() >= 1.0)


def chunks(Y: Any, U: Any, q: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    """A block of readings ``(q, L)`` and inputs ``(m, L)`` (``U=None``: no inputs)."""
    Y = _chunk(Y, q, "Y")
    L = Y.shape[1]
    if U is None:
        if m:
            raise ShapeError(f"U: the bank reads {m} inputs; pass U", argument="U")
        U = np.zeros((0, L))
    return Y, _chunk(U, m, "U", L)


def _chunk(value: Any, rows: int, name: str, L: int | None = None) -> np.ndarray:
    """A ``(rows, L)`` float array (non-finite entries allowed: missing samples)."""
    if not (isinstance(value, np.ndarray) and value.dtype == np.float64):
        from geomfdi._validation import as_real_array

        value = as_real_array(value, name, allow_nonfinite=True)
    if value.ndim != 2 or value.shape[0] != rows or (L is not None and value.shape[1] != L):
        cols = "L" if L is None else str(L)
        raise ShapeError(
            f"{name}: expected ({rows}, {cols}), got shape {value.shape}", argument=name
        )
    return value


def make_feed(
    program: Program,
    state: MonitorState,
    thresholds: np.ndarray | None,
    persistence: Persistence,
    isolation: bool,
    restart: str,
) -> Any:
    """The chunk update ``feed(Y, U) -> MonitorOutput`` over ``state``.

    Runs ``L`` samples (``Y`` (q, L), ``U`` (m, L)) with the loop-free recursion of
    :func:`~geomfdi.deployment.program.run_program`, then the threshold, the k-of-n
    count over the ring of the previous raw alarms, the held pattern continued from
    the state (:func:`~geomfdi.deployment.decide.held_chunk`), the pattern decisions
    looked up by bit code (:class:`~geomfdi.deployment.decide.PatternTable`) and their
    settling after the previous ones, and leaves the same state behind as ``L`` calls
    of the step would.
    """
    q, m, nz = program.q, program.m, program.nz
    rows = program.n_rows
    k, n = persistence.k, persistence.n
    latch, reset = persistence.latch, persistence.reset
    multiple = not persistence.trivial
    settling = n > 1 and isolation
    thr = None if thresholds is None else thresholds[:, None]
    scalar = program.scalar_rows
    structure = program.structure
    table = PatternTable.of(structure, multiple) if rows <= PatternTable.MAX_ROWS else None
    plain = Persistence(1, 1, latch=False)  # the pattern decisions of step 3, with -4

    def decisions(pattern: np.ndarray) -> np.ndarray:
        if table is not None:
            return table.decide(pattern)
        if multiple:  # too many rows for a bit code
            return plain.isolation(pattern, structure).isolated
        return isolate(pattern, structure).isolated

    def feed(Y: Any, U: Any = None) -> MonitorOutput:
        Y, U = chunks(Y, U, q, m)
        L = Y.shape[1]
        Zt = np.empty((L, nz))  # sample-major: the layout of the lifted recursion
        Zt[:, :q] = Y.T
        Zt[:, q:] = U.T
        comp, valid, xi, pending = run_program(program, Zt.T, state.xi, state.pending, restart)
        every = bool(valid.all())
        state.xi = xi
        if every and L:
            state.last = Zt[L - 1].copy()
        elif valid.any():
            state.last = Zt[np.flatnonzero(valid)[-1]].copy()
        state.pending = pending
        state.samples += L
        residuals = comp if scalar else program.row_values(comp)
        if not every:
            residuals[:, ~valid] = np.nan
        if thr is None:
            raw = np.zeros(residuals.shape, dtype=bool)
        else:
            raw = (residuals > thr) | (residuals < -thr)
        ordered = state.ordered_ring()
        alarms = confirm(raw, persistence, ordered[1:].T)
        if L >= n:
            state.set_ring(raw[:, L - n :].T)
        else:
            state.set_ring(np.concatenate([ordered[L:], raw.T], axis=0))
        pattern = alarms
        if latch:
            pattern, held, state.quiet = held_chunk(alarms, reset, state.held_rows(), state.quiet)
            state.set_held(held)
        isolated = None
        if isolation:
            isolated = decisions(pattern)
            if settling:
                past = np.array(state.decisions, dtype=np.int64)
                out = settle(isolated, past, k, n)
                tail = np.concatenate([past, isolated])[isolated.size :]
                state.decisions = deque(tail.tolist())
                isolated = out
        return MonitorOutput(residuals, raw, alarms, isolated, ~valid)

    return feed
