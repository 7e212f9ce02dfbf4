"""Chunked decisions and summaries of a long record: memory proportional to the chunk.

:func:`~geomfdi.simulate` and :func:`~geomfdi.simulate_batch` advance the time axis in
chunks (:mod:`geomfdi.simulation.open_loop`); the decisions on each chunk and the
per-run summaries are computed here, incrementally, with what they need of the past
carried from chunk to chunk:

* :func:`chunk_plan`: runs and samples per chunk from the memory budget
  ``gf.limits.get_limits().chunk_memory``;
* :class:`DecisionStream`: alarms and isolation decisions of consecutive chunks, equal
  to those of the whole record (a moving-RMS statistic and the k-of-n counts look back
  a bounded number of samples, the pattern held over an alarm episode depends on the
  episode's start: that history and the episode state are carried);
* :class:`RunSummary`: peaks, detection and isolation events and false-alarm counts of
  each run, accumulated chunk by chunk (what ``store="summary"`` keeps), equal to
  :func:`geomfdi.evaluation.decision.detection_events` and
  :func:`geomfdi.evaluation.metrics.false_alarms` on the whole record.

See the user guide, *Theory: evaluation* (``docs/theory/evaluation.md``), for the
decision rules themselves.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from geomfdi.evaluation.decision import MULTIPLE, FaultEvent, Isolation, Threshold, isolate
from geomfdi.evaluation.metrics import FalseAlarms
from geomfdi.evaluation.persistence import (
    Persistence,
    decisions,
    every_pattern,
    held_pattern_carry,
    k_of_n,
    pattern_codes,
    pattern_decisions,
    settle,
)
from geomfdi.limits import get_limits
from geomfdi.simulation.signals import first_active
from geomfdi.simulation.workspace import Workspace, thread_workspace

__all__ = [
    "DecisionStream",
    "RunSummary",
    "Workspace",
    "chunk_plan",
    "thread_workspace",
    "time_chunks",
]

#: The fewest samples of a time chunk (each chunk costs a fixed Python overhead).
MIN_CHUNK = 16
#: The fewest samples per run of a chunk that holds several runs cut in time.
MIN_RUN_SAMPLES = 1024


def chunk_plan(
    N: int,
    runs: int,
    width: float,
    *,
    runs_per_chunk: int | None = None,
    min_runs: int = 1,
) -> tuple[int, int]:
    """Runs and samples per chunk so that one chunk's arrays fit the memory budget.

    Parameters
    ----------
    N : int
        Samples of the record.
    runs : int
        Runs to simulate.
    width : float
        Bytes of working memory per run and sample (every signal, noise draw and
        decision array that lives while a chunk is processed).
    runs_per_chunk : int, optional
        Runs per chunk fixed by the caller (``simulate_batch(chunk_size=...)``).
    min_runs : int
        Runs per chunk wanted at least (when ``runs`` allows, and each run keeps
        :data:`MIN_RUN_SAMPLES` samples or more per chunk): the compiled batch
        recursion vectorises over the runs of a chunk, so long records are cut in time
        rather than simulated one run at a time.

    Returns
    -------
    (runs_per_chunk, samples_per_chunk)
        With ``budget = gf.limits.get_limits().chunk_memory``, ``runs_per_chunk *
        samples_per_chunk * width <= budget`` (at least one run and
        :data:`MIN_CHUNK` samples): whole records of several runs when they fit,
        otherwise ``min_runs`` runs (or the given number) and the time axis cut.
    """
    budget = float(get_limits().chunk_memory)
    cells = max(int(budget // max(width, 1.0)), 1)  # run-samples per chunk
    if runs_per_chunk is None:
        wanted = min(int(min_runs), cells // MIN_RUN_SAMPLES)
        runs_per_chunk = max(1, min(runs, max(cells // max(N, 1), wanted)))
    L = max(MIN_CHUNK, cells // runs_per_chunk)
    return int(runs_per_chunk), int(min(L, N))


def time_chunks(N: int, L: int) -> list[tuple[int, int, int]]:
    """Chunks ``(s, e, e1)`` of a record of ``N`` samples: the chunk decides the samples
    ``s .. e-1`` and is simulated on ``s .. e1-1`` (``e1 = e + 1`` except at the end:
    the right end of the last interval, which is the first sample of the next chunk)."""
    out = []
    s = 0
    while s < N:
        e = min(s + L, N)
        if N - e < MIN_CHUNK // 2:  # no sliver of a chunk at the end
            e = N
        out.append((s, e, min(e + 1, N)))
        s = e
    return out


class DecisionStream:
    """Alarms and isolation of consecutive chunks of residuals, as on the whole record.

    The decisions (:func:`geomfdi.evaluation.persistence.decisions`) are computed stage
    by stage, each stage with what it needs of the past carried from the previous chunk:

    1. raw alarms: a moving-RMS statistic reads the last ``window - 1`` residual samples;
    2. confirmed alarms (k-of-n): the last ``n - 1`` raw alarms;
    3. the pattern held over the alarm episode (``latch``): the episode state, i.e. the
       residuals alarmed in the current episode and how long ago the last alarm was
       (:func:`~geomfdi.evaluation.persistence.held_pattern_carry`);
    4. per-sample decisions on the pattern (with ``MULTIPLE``): nothing;
    5. settled decisions (k-of-n on the decision): the last ``n - 1`` per-sample
       decisions.

    Memory is the chunk plus ``O(window + n)`` samples of history and the episode state,
    whatever the record's length.

    Parameters
    ----------
    threshold : Threshold or None
    structure : ndarray of bool
    rule : Persistence or None
    """

    def __init__(
        self,
        threshold: Threshold | None,
        structure: np.ndarray,
        rule: Persistence | None,
        workspace: Workspace | None = None,
    ) -> None:
        self.threshold, self.structure = threshold, np.asarray(structure, dtype=bool)
        self.rule = None if rule is None or rule.trivial else rule
        self.workspace = Workspace() if workspace is None else workspace
        # per-sample isolation is a function of the alarm pattern: with few rows, a table
        # of every pattern's decision (isolate on the 2**n_rows patterns) read by code
        n = self.structure.shape[0]
        self._table: np.ndarray | None = None
        if threshold is not None and self.rule is None and n <= _TABLE_ROWS:
            self._table = isolate(every_pattern(n), self.structure).isolated
        rms = threshold is not None and threshold.statistic == "rms" and threshold.window > 1
        self._res_look = threshold.window - 1 if rms else 0  # type: ignore[union-attr]
        self._res: np.ndarray | None = None  # last residuals (RMS window)
        self._raw: np.ndarray | None = None  # last raw alarms (k-of-n confirmation)
        self._held: tuple[np.ndarray, ...] | None = None  # episode state
        self._dec: np.ndarray | None = None  # last per-sample decisions (settling)
        self._table_i64: np.ndarray | None = None  # the table for the compiled pass

    def _alarms(
        self,
        res: np.ndarray,
        absolute: np.ndarray | None,
        peaks: np.ndarray | None,
        out: np.ndarray | None,
    ) -> tuple[np.ndarray | None, Threshold | None]:
        """Stage 1, the raw alarms of the chunk (``None`` without a threshold)."""
        thr = self.threshold
        if thr is None:
            return None, None
        if self._res_look:
            ext, h = _with_tail(self._res, res)
            self._res = _tail(ext, self._res_look)
            return thr.alarms(ext)[..., h:], thr
        if absolute is not None and peaks is not None and np.all(peaks <= _FINITE_SUM):
            # |r| > v is (r > v) | (r < -v); every |r| is finite and so is their sum (the
            # check of Threshold.alarms cannot fail)
            return np.greater(absolute, thr.values[:, None], out=out), thr
        return thr.alarms(res), thr

    def step(
        self,
        res: np.ndarray,
        *,
        absolute: np.ndarray | None = None,
        peaks: np.ndarray | None = None,
        out: np.ndarray | None = None,
    ) -> tuple[np.ndarray, Isolation]:
        """Decisions of the next chunk ``res`` (R, n_rows, L): alarms (R, n_rows, L) and
        the isolation of its samples.

        ``absolute`` (``|res|``) and ``peaks`` (its maximum over the chunk, (R, n_rows)),
        when given, spare the statistic's pass for the ``"abs"`` statistic; ``out``
        (bool, (R, n_rows, L)) then receives the raw alarms.
        """
        rule, S = self.rule, self.structure
        al, thr = self._alarms(res, absolute, peaks, out)
        if thr is None:
            return decisions(res, None, S, None)
        if rule is None:
            return al, isolate(al, S)
        # 2. confirmation
        k, n = rule.k, rule.n
        if n > 1:
            ext, h = _with_tail(self._raw, al)
            self._raw = _tail(ext, n - 1)
            al = k_of_n(ext, k, n)[..., h:]
        # 3. held pattern
        if rule.latch:
            pattern, self._held = held_pattern_carry(al, rule.reset, self._held)
        else:
            pattern = al
        # 4. per-sample decisions, 5. settling
        iso = pattern_decisions(pattern, S)
        if k == 1 and n == 1:
            return al, iso
        ext, h = _with_tail(self._dec, iso.isolated)
        self._dec = _tail(ext, n - 1)
        settled = settle(ext, k, n, S.shape[1])[..., h:]
        return al, Isolation(settled, iso.candidates, iso.suspects)

    def decide(
        self,
        res: np.ndarray,
        *,
        absolute: np.ndarray | None = None,
        peaks: np.ndarray | None = None,
        out: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """:meth:`step`'s alarms, isolation decisions (R, L) and suspects (``None``
        when no decision can be ``MULTIPLE``: per-sample decisions, no rule).

        Without a rule (and with at most :data:`_TABLE_ROWS` rows) the decision of each
        sample is read from the table of the alarm patterns (bit ``i`` of a sample's
        code: row ``i`` alarms): :func:`~geomfdi.evaluation.decision.isolate` of the
        same pattern, without its passes over the chunk per fault and row.
        """
        if self._table is None:
            al, iso = self.step(res, absolute=absolute, peaks=peaks, out=out)
            return al, iso.isolated, iso.suspects
        al, _ = self._alarms(res, absolute, peaks, out)
        R, n, L = al.shape
        dt = np.uint8 if n <= 8 else np.uint16  # as pattern_codes chooses (n <= _TABLE_ROWS)
        code = self.workspace.get("pattern code", (R, L), dt)
        bit = self.workspace.get("pattern bit", (R, L), dt)
        return al, self._table[pattern_codes(al, out=code, scratch=bit)], None

    def decide_compiled(
        self,
        res: np.ndarray,
        alarms: np.ndarray,
        isolated: np.ndarray,
        any_alarm: np.ndarray,
    ) -> np.ndarray | None:
        """:meth:`decide` on the table of alarm patterns in one compiled pass
        (:func:`geomfdi.simulation.compiled_decisions.table_decisions`): writes the
        alarms, the decisions (R, L) and whether any row alarms (R, L) into the given
        arrays and returns the chunk's peaks ``max |res|`` (R, n_rows).  ``None`` (nothing
        usable written) without the table (a persistence rule, a moving-RMS statistic,
        more than :data:`_TABLE_ROWS` rows) or when the kernel declines."""
        if self._table is None or self._res_look or self.threshold is None:
            return None
        from geomfdi.simulation.compiled_decisions import table_decisions

        table = self._table_i64
        if table is None:
            table = self._table_i64 = np.ascontiguousarray(self._table, dtype=np.int64)
        return table_decisions(res, self.threshold.values, table, alarms, isolated, any_alarm)


#: Most residual rows whose per-sample isolation is a table of the alarm patterns.
_TABLE_ROWS = 16
#: Residual magnitudes below which a chunk's sum cannot overflow (so holds no nan).
_FINITE_SUM = 1e300


def _with_tail(tail: np.ndarray | None, x: np.ndarray) -> tuple[np.ndarray, int]:
    """``x`` with the carried samples ``tail`` before it (time on the last axis), and
    how many they are."""
    if tail is None or tail.shape[-1] == 0:
        return x, 0
    return np.concatenate([tail, x], axis=-1), tail.shape[-1]


def _tail(x: np.ndarray, h: int) -> np.ndarray:
    """The last ``h`` samples of ``x`` (a copy: the chunk is not kept alive)."""
    return np.array(x[..., max(x.shape[-1] - h, 0) :])


def _rows(x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``x[mask]``, or ``x`` itself (no copy) when the mask selects every row."""
    return x if mask.all() else x[mask]


def _pick(x: np.ndarray, loc: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The rows ``loc[mask]`` of ``x`` (a span's run), ``x`` itself when those are all of
    its rows in order (one span per run, every span selected: no copy)."""
    rows = loc[mask]
    if rows.size == x.shape[0] and (rows == np.arange(rows.size)).all():
        return x
    return x[rows]


def _within(hit: np.ndarray, inside: np.ndarray | None, mask: np.ndarray) -> np.ndarray:
    """``hit`` restricted to the samples of its spans (``inside[mask]``; ``None``: every
    span covers the chunk)."""
    return hit if inside is None else hit & _rows(inside, mask)


class RunSummary:
    """Peaks, fault events and false alarms of runs, accumulated chunk by chunk.

    Parameters
    ----------
    t : ndarray, (N,)
    faults : list of list
        The fault signals of each run (in the user's order).
    columns : list of list of int or None
        Structure column of each fault (see
        :func:`geomfdi.simulation.schedule.structure_columns`).
    n_rows : int
        Residual rows.
    window : float or None
        Detection window (seconds); ``None``: to the end of the run.

    Notes
    -----
    Per fault, the samples that count are ``ks .. ke-1`` (first active sample to the
    end of the detection window); per chunk only their overlap with the chunk is read.
    The healthy part of a run is the samples before its first onset; a false-alarm event
    is a rising edge of "some residual alarms" there (the value at the end of the
    previous chunk is carried).
    """

    def __init__(
        self,
        t: np.ndarray,
        faults: Sequence[Sequence[Any]],
        columns: Sequence[Sequence[int | None]],
        n_rows: int,
        window: float | None,
    ) -> None:
        N = t.shape[0]
        self.t = t
        self.runs = len(faults)
        self.peak = np.zeros((self.runs, n_rows))
        # per run: [(fault, column, ks, ke, window_end)], onset-sorted by the user's order
        self.spans: list[list[tuple[Any, int | None, int, int, float | None]]] = []
        for fl, cols in zip(faults, columns, strict=True):
            spans = []
            for f, j in zip(fl, cols, strict=True):
                ks = first_active(f, t)
                if ks is None:
                    continue
                if window is None:
                    ke, wend = N, None
                else:
                    wend = float(t[ks]) + float(window)
                    tol = 1e-9 * max(1.0, abs(wend))
                    ke = int(np.searchsorted(t, wend + tol, side="right"))
                spans.append((f, j, ks, ke, wend))
            self.spans.append(spans)
        self.healthy = np.array(
            [min((sp[2] for sp in spans), default=N) for spans in self.spans], dtype=int
        )
        self.fa_samples = np.zeros(self.runs, dtype=int)
        self.fa_alarms = np.zeros(self.runs, dtype=int)
        self.fa_edges = np.zeros(self.runs, dtype=int)
        self._prev = np.zeros(self.runs, dtype=bool)
        # the spans of every run, flat (run by run): run, samples ks .. ke-1, column
        flat = [(r, sp[1], sp[2], sp[3]) for r, spans in enumerate(self.spans) for sp in spans]
        self._first = np.cumsum([0] + [len(sp) for sp in self.spans])
        S = len(flat)
        self._run = np.array([x[0] for x in flat], dtype=np.intp)
        self._col = np.array([-1 if x[1] is None else x[1] for x in flat], dtype=int)
        self._ks = np.array([x[2] for x in flat], dtype=int)
        self._ke = np.array([x[3] for x in flat], dtype=int)
        # event state per span: first detection / isolation sample (-1: none yet), first
        # decision (with ``_decided``), its hypothesis, the rows that alarmed
        self._det = np.full(S, -1)
        self._iso = np.full(S, -1)
        self._dec = np.zeros(S, dtype=int)
        self._decided = np.zeros(S, dtype=bool)
        self._hyp: list[tuple[int, ...]] = [()] * S
        self._rows = np.zeros((S, n_rows), dtype=bool)

    def update(
        self,
        s: int,
        res: np.ndarray,
        alarms: np.ndarray | None,
        isolated: np.ndarray | None,
        r0: int = 0,
        suspects: np.ndarray | None = None,
        peaks: np.ndarray | None = None,
        any_alarm: np.ndarray | None = None,
    ) -> None:
        """Add the chunk of samples ``s .. s+L-1`` of the runs ``r0 .. r0+R-1``:
        residuals and alarms (R, n_rows, L), isolation decisions (R, L) and their
        suspects (R, n_faults, L), which give the hypothesis of a ``MULTIPLE``
        decision.  ``alarms=None``: no alarm and no decision (no threshold).
        ``peaks``: ``max |res|`` over the chunk (R, n_rows), when the caller has it;
        ``any_alarm``: ``alarms.any(axis=-2)`` (R, L), likewise.

        Vectorised over the runs and their faults (the samples of each run's healthy
        part and of each fault's span are masks of the chunk).
        """
        R, L = res.shape[0], res.shape[-1]
        e = s + L
        pk = self.peak[r0 : r0 + R]
        np.maximum(pk, np.max(np.abs(res), axis=-1) if peaks is None else peaks, out=pk)
        # false alarms before the first onset
        n_h = np.clip(self.healthy[r0 : r0 + R] - s, 0, L)  # healthy samples in the chunk
        self.fa_samples[r0 : r0 + R] += n_h
        if alarms is None:
            self._prev[r0 : r0 + R] &= n_h == 0
            return
        idx = np.arange(L)
        a = alarms.any(axis=-2) if any_alarm is None else any_alarm
        if n_h.any():  # (else no run is healthy in the chunk: nothing changes)
            h = a if n_h.min() == L else a & (idx < n_h[:, None])
            self.fa_alarms[r0 : r0 + R] += np.count_nonzero(h, axis=-1)
            rise = np.count_nonzero(h[:, 1:] & ~h[:, :-1], axis=-1)
            rise += h[:, 0] & ~self._prev[r0 : r0 + R]
            self.fa_edges[r0 : r0 + R] += rise
            self._prev[r0 : r0 + R] = np.where(
                n_h > 0, h[np.arange(R), np.maximum(n_h - 1, 0)], self._prev[r0 : r0 + R]
            )
        # the spans of these runs that overlap the chunk
        sp = np.arange(self._first[r0], self._first[r0 + R])
        lo, hi = np.maximum(self._ks[sp], s), np.minimum(self._ke[sp], e)
        sp, lo, hi = sp[lo < hi], lo[lo < hi], hi[lo < hi]
        if not sp.size:
            return
        loc = self._run[sp] - r0
        # (spans, L): the chunk's samples in each span; None when every span covers it
        full = lo.max() == s and hi.min() == e
        inside = None if full else (idx >= (lo - s)[:, None]) & (idx < (hi - s)[:, None])
        # only what is still open is read: the first detection, isolation and decision
        # of each span, the rows that have not alarmed in it yet
        det = self._det[sp] < 0
        if det.any():
            hit = _within(_pick(a, loc, det), inside, det)
            new = hit.any(axis=-1)
            self._det[sp[det][new]] = s + np.argmax(hit[new], axis=-1)
        col = self._col[sp]
        iso_open, dec_open = (self._iso[sp] < 0) & (col >= 0), ~self._decided[sp]
        use = iso_open | dec_open
        if use.any():
            spu, iso = sp[use], _pick(isolated, loc, use)
            insu = None if inside is None else inside[use]
            io, do = iso_open[use], dec_open[use]
            if io.any():
                hit = _within(_rows(iso, io) == col[use][io, None], insu, io)
                new = hit.any(axis=-1)
                self._iso[spu[io][new]] = s + np.argmax(hit[new], axis=-1)
            if do.any():
                isd = _rows(iso, do)
                made = _within((isd >= 0) | (isd == MULTIPLE), insu, do)
                new = made.any(axis=-1)
                if new.any():
                    k = np.argmax(made[new], axis=-1)
                    dec = isd[new, k]
                    target = spu[do][new]
                    self._dec[target] = dec
                    self._decided[target] = True
                    if suspects is not None:  # the hypothesis of each new MULTIPLE decision
                        multi = dec == MULTIPLE
                        for i, kk in zip(target[multi], k[multi], strict=True):
                            sus = suspects[self._run[i] - r0, :, kk]
                            self._hyp[i] = tuple(int(f) for f in np.flatnonzero(sus))
        si, ri = np.nonzero(~self._rows[sp])
        if si.size:
            hit = alarms[loc[si], ri]
            if inside is not None:
                hit &= inside[si]
            self._rows[sp[si], ri] |= hit.any(axis=-1)

    def events(self, r: int) -> list[FaultEvent]:
        """The fault events of run ``r`` (as :func:`detection_events` gives them)."""
        out = []
        t = self.t
        for i, (f, j, ks, _, wend) in enumerate(self.spans[r], start=self._first[r]):
            onset = float(t[ks])
            kd, ki = int(self._det[i]), int(self._iso[i])
            det = None if kd < 0 else float(t[kd])
            iso_t = None if ki < 0 else float(t[ki])
            out.append(
                FaultEvent(
                    f,
                    j,
                    onset,
                    det,
                    None if det is None else det - onset,
                    iso_t,
                    None if iso_t is None else iso_t - onset,
                    tuple(int(x) for x in np.flatnonzero(self._rows[i])),
                    int(self._dec[i]) if self._decided[i] else None,
                    wend,
                    self._hyp[i],
                )
            )
        return out

    def false_alarms(self, r: int) -> FalseAlarms:
        """False alarms of run ``r`` before its first onset."""
        return FalseAlarms(int(self.fa_samples[r]), int(self.fa_alarms[r]), int(self.fa_edges[r]))
