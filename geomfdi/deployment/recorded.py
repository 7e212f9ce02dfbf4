"""Residual evaluation on recorded data: :func:`evaluate`.

A designed bank is run on logged measurements ``y`` and known inputs ``u`` sampled on a
uniform grid.  The recursion is the fused sampled form of the bank
(:mod:`geomfdi.deployment.program`: exact first-order-hold sampling of a continuous
bank, as :func:`geomfdi.simulate` and :func:`control.forced_response` do; a discrete
bank as it is), solved without a per-sample Python loop by the same LTI core as
:func:`geomfdi.simulate`.  Decisions (threshold, the persistence rule
:class:`geomfdi.Persistence`, isolation on the achieved structure) are those of
:func:`geomfdi.simulate` for the same residuals (:mod:`geomfdi.deployment.decide`).

*Start-up.*  ``initial="steady"`` starts every generator at the fixed point for the
first sample held constant (``xi0 = (I - A)^-1 B z[0]``): on healthy data in steady
state there is no start-up transient, otherwise the transient decays with the
generators' poles.  ``"zero"`` starts at ``w = 0`` (a transient of the size of the
healthy output, decaying with the same poles); an explicit vector gives the generator
states (all existing generators stacked in row order).

*Missing samples.*  A sample with a ``y`` or ``u`` entry that is not finite or beyond
``1e150`` in magnitude (:data:`~geomfdi.deployment.program.SAMPLE_LIMIT`) is *masked*: its
residuals are ``nan``, it never alarms, and the recursion is not run through it; the
next valid sample restarts the generators (``"steady"``, or ``"zero"`` when
``initial="zero"``).  The masked windows are listed in ``result.gaps``.

See the user guide, *Theory: residual evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

import functools
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import as_positive, as_real_array
from geomfdi.deployment.decide import as_persistence
from geomfdi.deployment.program import (
    as_bank,
    build_program,
    check_initial,
    restart_rule,
    run_program,
)
from geomfdi.errors import GeomFDIError, ShapeError, TimeGridError
from geomfdi.evaluation.decision import (
    MULTIPLE,
    FaultEvent,
    Threshold,
    as_threshold,
    detection_events,
    isolate,
)
from geomfdi.evaluation.persistence import Persistence
from geomfdi.model.signals import bank_signals

__all__ = [
    "evaluate",
    "EvaluationResult",
    "AlarmEpisode",
    "check_time",
    "channel_columns",
    "settling_time",
]

_TIME_RTOL = 1e-6


def check_time(t: Any, N: int | None = None, name: str = "t") -> tuple[np.ndarray, float]:
    """Validate a uniform, strictly increasing, finite time vector; return it and its step.

    Raises :class:`~geomfdi.errors.TimeGridError` naming the first offending sample
    (non-finite, not increasing, or a step differing from the mean step by more than a
    relative ``1e-6``) and :class:`~geomfdi.errors.ShapeError` when its length is not ``N``.
    """
    t = as_real_array(t, name, allow_nonfinite=True)
    if t.ndim != 1:
        raise ShapeError(f"{name}: must be 1-D, got shape {t.shape}", argument=name)
    if N is not None and t.size != N:
        raise ShapeError(f"{name}: has {t.size} samples, the data have {N}", argument=name)
    if t.size < 2:
        raise TimeGridError(f"{name}: needs at least 2 samples, got {t.size}", argument=name)
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise TimeGridError(f"{name}: non-finite time at sample {bad[0]}", argument=name)
    d = np.diff(t)
    back = np.flatnonzero(d <= 0)
    if back.size:
        k = int(back[0])
        raise TimeGridError(
            f"{name}: not strictly increasing (t[{k + 1}] = {t[k + 1]!r} <= t[{k}] = {t[k]!r})",
            argument=name,
        )
    step = (t[-1] - t[0]) / (t.size - 1)
    dev = np.abs(d - step)
    worst = int(np.argmax(dev))
    if dev[worst] > _TIME_RTOL * step:
        raise TimeGridError(
            f"{name}: not uniformly spaced (step {d[worst]!r} between samples {worst} and "
            f"{worst + 1}, mean step {step!r}); resample the record first",
            argument=name,
        )
    return t, float(step)


def channel_columns(columns: Sequence[str], prefix: str) -> list[str]:
    """Column names ``y0, y1, ...`` (also ``y[0]``, ``y_0``) in channel order."""
    pat = re.compile(rf"^{prefix}(?:\[(\d+)\]|_?(\d+))$")
    found = {}
    for c in columns:
        mt = pat.match(str(c).strip())
        if mt:
            found[int(mt.group(1) or mt.group(2))] = c
    if found and sorted(found) != list(range(len(found))):
        raise ShapeError(
            f"columns: the {prefix} channels {sorted(found)} are not numbered 0..{len(found) - 1}",
            argument="columns",
        )
    return [found[i] for i in sorted(found)]


def _from_frame(
    df: Any, outputs: Sequence[str] | None, inputs: Sequence[str] | None, time: str | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    cols = list(df.columns)
    outputs = list(outputs) if outputs is not None else channel_columns(cols, "y")
    inputs = list(inputs) if inputs is not None else channel_columns(cols, "u")
    if not outputs:
        raise ShapeError(
            "y: the DataFrame has no output columns (name them y0, y1, ... or pass outputs=)",
            argument="y",
        )
    missing = [c for c in [*outputs, *inputs] if c not in df.columns]
    if missing:
        raise ShapeError(f"columns: not in the DataFrame: {missing}", argument="columns")
    if time is None:
        time = next((c for c in ("t", "time") if c in df.columns), None)
    t = None
    if time is not None:
        if time not in df.columns:
            raise ShapeError(f"time: column {time!r} is not in the DataFrame", argument="time")
        t = df[time].to_numpy(dtype=float)
    y = df[outputs].to_numpy(dtype=float).T
    u = df[inputs].to_numpy(dtype=float).T if inputs else np.zeros((0, y.shape[1]))
    return y, u, t


def _named_columns(
    columns: Sequence[str],
    sig: dict[str, Any],
    outputs: Sequence[str] | None,
    inputs: Sequence[str] | None,
) -> tuple[Sequence[str] | None, Sequence[str] | None]:
    """The bank's signal names as the columns to read, when the frame has them all."""
    cols = {str(c) for c in columns}
    if outputs is None and sig["named"] and set(sig["outputs"]) <= cols:
        outputs = list(sig["outputs"])
    if inputs is None and sig["named"] and set(sig["inputs"]) <= cols:
        inputs = list(sig["inputs"])
    return outputs, inputs


def _channels(value: Any, name: str, rows: int, what: str) -> np.ndarray:
    """``value`` as a ``(rows, N)`` array (a 1-D array for a single channel)."""
    a = as_real_array(value, name, allow_nonfinite=True)
    if a.ndim == 1 and rows == 1:
        a = a[None]
    if a.ndim != 2 or a.shape[0] != rows:
        raise ShapeError(
            f"{name}: expected ({rows}, N) for the bank's {rows} {what}, got {a.shape}",
            argument=name,
        )
    return a


def _signals(y: Any, u: Any, q: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    y = _channels(y, "y", q, "outputs")
    N = y.shape[1]
    if u is None:
        if m:
            raise ShapeError(f"u: the bank reads {m} inputs; pass u ({m}, N)", argument="u")
        return y, np.zeros((0, N))
    u = _channels(u, "u", m, "inputs")
    if u.shape[1] != N:
        raise ShapeError(f"u: has {u.shape[1]} samples, y has {N}", argument="u")
    return y, u


@dataclass(frozen=True)
class AlarmEpisode:
    """A maximal run of samples where some residual's confirmed alarm is on.

    Attributes
    ----------
    start, stop : float
        Times of the first and last alarming samples.
    residuals : tuple of int
        Bank rows that alarm during the episode.
    fault : int or None
        The *settled* isolation decision of the episode: the decision (a structure column,
        or :data:`~geomfdi.evaluation.decision.MULTIPLE` for several faults) held on most
        of the episode's decided samples, the later one on a tie; ``None``: no decision.
    isolated_at : float or None
        When the settled decision was first reached.
    share : float
        Fraction of the episode's decided samples that hold the settled decision.
    first_fault, first_isolated_at : int or None, float or None
        The first decision of the episode and its time (a start-up transient may
        point at another fault before the pattern settles).
    """

    start: float
    stop: float
    residuals: tuple[int, ...]
    fault: int | None
    isolated_at: float | None
    share: float = 0.0
    first_fault: int | None = None
    first_isolated_at: float | None = None


def _settled(starts: np.ndarray, stops: np.ndarray, isolated: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per episode: (found, settled decision, its first sample, share, first decision's
    sample), grouping the decided samples by (episode, decision) without a sample loop."""
    n_ep = starts.size
    hits = np.flatnonzero((isolated >= 0) | (isolated == MULTIPLE))
    ep = np.searchsorted(starts, hits, side="right") - 1
    keep = (ep >= 0) & (hits < stops[np.maximum(ep, 0)])
    hits, ep = hits[keep], ep[keep]
    found = np.zeros(n_ep, dtype=bool)
    found[ep] = True
    dec = np.zeros(n_ep, dtype=np.int64)
    at = starts.copy()
    share = np.zeros(n_ep)
    first = starts.copy()
    if hits.size == 0:
        return found, dec, at, share, first
    first[ep[::-1]] = hits[::-1]  # the earliest decided sample of each episode
    code = isolated[hits].astype(np.int64) - MULTIPLE  # >= 0
    key = ep * (int(code.max()) + 1) + code
    order = np.argsort(key, kind="stable")  # samples stay in time order within a group
    k_sorted = key[order]
    grp_start = np.flatnonzero(np.r_[True, k_sorted[1:] != k_sorted[:-1]])
    grp_stop = np.r_[grp_start[1:], k_sorted.size]
    g_ep = ep[order][grp_start]
    g_count = grp_stop - grp_start
    g_first = hits[order][grp_start]
    g_last = hits[order][grp_stop - 1]
    # the largest group per episode, the later one (by its last sample) on a tie
    best = np.lexsort((g_last, g_count, g_ep))
    last_of_ep = best[np.r_[g_ep[best][1:] != g_ep[best][:-1], True]]
    e = g_ep[last_of_ep]
    dec[e] = code[order][grp_start][last_of_ep] + MULTIPLE
    at[e] = g_first[last_of_ep]
    share[e] = g_count[last_of_ep] / np.bincount(ep, minlength=n_ep)[e]
    return found, dec, at, share, first


def alarm_episodes(t: np.ndarray, alarms: np.ndarray, isolated: np.ndarray) -> list[AlarmEpisode]:
    """Alarm episodes of one record (see :class:`AlarmEpisode`), without a Python loop
    over samples (one object per episode)."""
    on = alarms.any(axis=0).astype(np.int8)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], on, [0]))))
    starts, stops = edges[::2], edges[1::2]
    if starts.size == 0:
        return []
    # rows alarming in each episode: OR over [start_i, start_{i+1}) (zeros between episodes)
    ep, row = np.nonzero(np.logical_or.reduceat(alarms, starts, axis=1).T)
    cuts = np.searchsorted(ep, np.arange(starts.size + 1)).tolist()
    row_list = row.tolist()
    rows = [tuple(row_list[cuts[i] : cuts[i + 1]]) for i in range(starts.size)]
    found, dec, at, share, first = _settled(starts, stops, np.asarray(isolated))
    ts, te = t[starts].tolist(), t[stops - 1].tolist()
    ta, tf = t[at].tolist(), t[first].tolist()
    dec_l, share_l, first_l = dec.tolist(), share.tolist(), isolated[first].tolist()
    return [
        AlarmEpisode(
            ts[i],
            te[i],
            rows[i],
            int(dec_l[i]) if found[i] else None,
            ta[i] if found[i] else None,
            float(share_l[i]),
            int(first_l[i]) if found[i] else None,
            tf[i] if found[i] else None,
        )
        for i in range(starts.size)
    ]


@dataclass
class EvaluationResult:
    """Outcome of :func:`evaluate`.

    Attributes
    ----------
    t : ndarray, (N,)
    residuals : ndarray, (n_residuals, N)
        One row per bank row (the norm for a generator with several components; zero for
        missing generators); ``nan`` on masked samples.
    components : ndarray, (n_components, N)
        The components of every existing generator, stacked in row order.
    masked : ndarray of bool, (N,)
        Samples with a non-finite ``y`` or ``u`` (module docstring).
    gaps : list of (float, float)
        First and last time of every masked window.
    raw_alarms, alarms : ndarray of bool, (n_residuals, N)
        Threshold crossings, and the alarms confirmed by the persistence rule (all False
        without a threshold).
    isolated : ndarray of int, (N,)
    candidates, suspects : ndarray of bool, (n_faults, N)
        Isolation under the persistence rule (:meth:`geomfdi.Persistence.isolation`: on
        the pattern held over the alarm episode, ``MULTIPLE`` for several faults);
        without a rule per sample on the confirmed alarms (:func:`geomfdi.isolate`).
    events : list of FaultEvent
        Detection/isolation of the fault signals passed as ``faults`` (as in
        :func:`geomfdi.simulate`); empty otherwise.
    episodes : list of AlarmEpisode
        The alarm episodes (:func:`alarm_episodes`), built on first access.
    threshold : Threshold or None
    persistence : Persistence
        The rule (``Persistence(1, 1, latch=False)``: none).
    structure : ndarray of bool
    fault_labels, residual_labels : list of str
    info : dict
        ``dt``, ``hold``, ``initial``, ``restart``, final generator state ``xi``.
    """

    t: np.ndarray
    residuals: np.ndarray
    components: np.ndarray
    masked: np.ndarray
    gaps: list[tuple[float, float]]
    raw_alarms: np.ndarray
    alarms: np.ndarray
    isolated: np.ndarray
    candidates: np.ndarray
    suspects: np.ndarray
    events: list[FaultEvent]
    threshold: Threshold | None
    persistence: Persistence
    structure: np.ndarray
    fault_labels: list[str]
    residual_labels: list[str]
    info: dict[str, Any] = field(default_factory=dict)

    @functools.cached_property
    def episodes(self) -> list[AlarmEpisode]:
        return alarm_episodes(self.t, self.alarms, self.isolated)

    @property
    def first_alarm(self) -> float | None:
        """Time of the first confirmed alarm (``None``: none)."""
        hit = np.flatnonzero(self.alarms.any(axis=0))
        return float(self.t[hit[0]]) if hit.size else None

    def plot(self, **kwargs: Any) -> Any:
        """Residual traces with thresholds and confirmed alarms (a matplotlib Figure);
        masked samples are drawn at zero."""
        from geomfdi.plotting.residuals import plot_residuals

        kwargs.setdefault("alarms", self.alarms)
        return plot_residuals(
            self.t,
            np.nan_to_num(self.residuals, nan=0.0),
            threshold=self.threshold,
            labels=self.residual_labels,
            **kwargs,
        )


def _gaps(t: np.ndarray, masked: np.ndarray) -> list[tuple[float, float]]:
    edges = np.flatnonzero(np.diff(np.concatenate(([0], masked.astype(np.int8), [0]))))
    return [(float(t[s]), float(t[e - 1])) for s, e in zip(edges[::2], edges[1::2], strict=True)]


def _fault_label(f: Any) -> str:
    return str(getattr(f, "name", None) or f)


def raw_alarms(residuals: np.ndarray, thr: Threshold | None) -> np.ndarray:
    """Threshold crossings of ``residuals`` (``(n_rows, N)``); a masked (``nan``) sample
    never alarms."""
    if thr is None:
        return np.zeros(residuals.shape, dtype=bool)
    if thr.statistic == "abs" or thr.window == 1:
        v = thr.values[:, None]
        return (residuals > v) | (residuals < -v)  # nan never alarms
    s = thr.statistic_of(np.nan_to_num(residuals, nan=0.0))
    return (s > thr.values[:, None]) & np.isfinite(residuals)


@limit_blas_threads
def evaluate(
    bank: Any,
    y: Any,
    u: Any = None,
    t: Any = None,
    *,
    dt: float | None = None,
    threshold: Any = None,
    persistence: Any = None,
    initial: Any = "steady",
    faults: Sequence[Any] = (),
    detection_window: float | None = None,
    outputs: Sequence[str] | None = None,
    inputs: Sequence[str] | None = None,
    time: str | None = None,
    settle: float | str = 0.0,
) -> EvaluationResult:
    """Run a residual bank on recorded data and decide on alarms and isolation.

    Parameters
    ----------
    bank : ResidualBank or ResidualGenerator
        Continuous (sampled with a first-order hold at the grid step) or discrete (its
        ``dt`` must equal the grid step).
    y : array_like (q, N), or pandas.DataFrame
        Measured outputs.  A DataFrame holds every signal in named columns: the bank's
        signal names (the plant's ``outputs`` and ``inputs``) when the frame has them,
        else outputs ``y0, y1, ...`` (or ``y[0]``, ``y_0``), inputs ``u0, ...``; time
        ``t`` / ``time``; unless ``outputs``, ``inputs``, ``time`` name them.
        Physical values: a bank designed on a plant with an operating point subtracts
        ``y_op`` and ``u_op`` itself (``bank.info["signals"]``).
    u : array_like (m, N), optional
        Known inputs (required when the bank reads inputs).
    t : array_like (N,), optional
        Uniform, strictly increasing sample times.  Either ``t`` or ``dt``.
    dt : float, optional
        Sampling period when ``t`` is not given (times ``k dt``).
    threshold : None, float, (n_residuals,) or Threshold
        Decision thresholds on ``|r|`` (or a :class:`Threshold`, also on the moving RMS).
    persistence : None, int, (k, n) or Persistence
        The decision rule, as in :func:`geomfdi.simulate` (:class:`geomfdi.Persistence`:
        k-of-n confirmation, isolation from the pattern held over the alarm episode,
        settled decisions, ``MULTIPLE`` for several faults; an int ``d``: ``d``
        consecutive samples).  ``None``: per-sample alarms and isolation.
    initial : {"steady", "zero"} or array_like (nw,)
        Generator state at the first sample (module docstring).
    faults : sequence of fault signals, optional
        Known fault signals (``GainFault`` ...) to time detection and isolation as
        :func:`geomfdi.simulate` does (``result.events``).
    detection_window : float, optional
        Seconds after each fault's onset in which its alarms and decisions count, as in
        :func:`geomfdi.simulate` (``None``: to the end of the record).
    settle : float or "auto"
        Seconds from the first sample during which no decision is taken (no raw alarm,
        nothing enters the persistence rule): the generators' start-up transient
        (module docstring) passes first.  ``"auto"``: :data:`SETTLE_TIME_CONSTANTS`
        time constants of the slowest generator pole (:func:`settling_time`).  Default
        0: decisions from the first sample, as :class:`geomfdi.Monitor` takes them.

    Returns
    -------
    EvaluationResult

    Raises
    ------
    TimeGridError
        Non-finite, non-increasing or non-uniform time; a grid step that differs from a
        discrete bank's ``dt``.
    ShapeError
        Mismatched lengths or channel counts.

    Notes
    -----
    Recursion ``xi[k+1] = A xi[k] + B z[k]``, ``c[k] = C xi[k] + D z[k]`` with
    ``z = [y; u]`` (:mod:`geomfdi.deployment.program`), solved over the whole record by
    the loop-free LTI core; decisions ``|r_i| > threshold_i`` (or the threshold's
    statistic), the persistence rule and isolation on the achieved structure by the
    functions :func:`geomfdi.simulate` uses (:mod:`geomfdi.deployment.decide`).  Runs with
    the BLAS limited to :func:`geomfdi.get_blas_threads` threads (one by default).  See
    the user guide, *Theory: residual evaluation* (``docs/theory/evaluation.md``).

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> g = gf.ResidualGenerator([[0.5]], [[-0.5]], [[0.0]], [[1.0]], [[1.0]], [[0.0]], dt=0.1)
    >>> y = np.ones((1, 50)); y[0, 30:] += 1.0
    >>> res = gf.evaluate(g, y, np.zeros((1, 50)), dt=0.1, threshold=0.4)
    >>> res.first_alarm, bool(np.all(res.residuals[0, :30] == 0))
    (3.0, True)
    """
    bank = as_bank(bank)
    sig = bank_signals(bank)
    if _is_frame(y):
        if u is not None:
            raise GeomFDIError("u: give the inputs as columns of the DataFrame", argument="u")
        outputs, inputs = _named_columns(y.columns, sig, outputs, inputs)
        y, u, t_frame = _from_frame(y, outputs, inputs, time)
        if t is None:
            t = t_frame
    gens = [g for g in bank.generators if g is not None]
    if not gens:
        raise GeomFDIError("bank: no residual generator exists in this bank", argument="bank")
    y, u = _signals(y, u, gens[0].q, gens[0].m)
    if np.any(sig["z_op"] != 0):  # physical values: the bank works on deviations
        y = y - sig["y_op"][:, None]
        u = u - sig["u_op"][:, None]
    N = y.shape[1]
    if t is not None:
        t, step = check_time(t, N)
    elif dt is not None:
        step = as_positive(dt, "dt")
        if N < 1:
            raise ShapeError("y: no samples", argument="y")
        t = np.arange(N) * step
    else:
        raise GeomFDIError("t: give the sample times t or the sampling period dt", argument="t")
    if bank.dt > 0 and abs(step - bank.dt) > _TIME_RTOL * bank.dt:
        raise TimeGridError(
            f"t: the grid step {step!r} differs from the discrete bank's dt = {bank.dt!r}",
            argument="t",
        )
    program = build_program(bank, None if bank.dt > 0 else step)
    initial = check_initial(initial, program)
    restart = restart_rule(program, initial)
    Zt = np.empty((N, program.nz))  # sample-major: the layout of the lifted recursion
    Zt[:, : program.q] = y.T
    Zt[:, program.q :] = u.T
    comp, valid, xi, _ = run_program(program, Zt.T, np.zeros(program.nw), initial, restart)
    residuals = program.row_values(comp)
    residuals[:, ~valid] = np.nan
    thr = as_threshold(threshold, program.n_rows, program.present)
    pers = as_persistence(persistence)
    raw = raw_alarms(residuals, thr)
    settle_s = settling_time(bank, step) if settle == "auto" else settle
    if isinstance(settle_s, bool) or not isinstance(settle_s, int | float):
        raise GeomFDIError(f"settle: seconds or 'auto', got {settle!r:.40}", argument="settle")
    settle_s = as_positive(settle_s, "settle", strict=False)
    raw[:, t < t[0] + settle_s - _TIME_RTOL * step] = False  # no decision while settling
    if pers.trivial:
        alarms, iso = raw, isolate(raw, program.structure)
    else:
        alarms = pers.apply(raw)
        iso = pers.isolation(alarms, program.structure)
    fl = list(faults)
    events: list[FaultEvent] = []
    if fl:
        from geomfdi.simulation.context import detection_window_of
        from geomfdi.simulation.signals import validate_faults

        window = detection_window_of(detection_window)
        fl = validate_faults(fl, program.q)
        events = detection_events(
            t,
            alarms,
            iso.isolated,
            fl,
            _fault_indices(bank, fl),
            window=window,
            suspects=iso.suspects,
        )
    return EvaluationResult(
        t=t,
        residuals=residuals,
        components=comp,
        masked=~valid,
        gaps=_gaps(t, ~valid),
        raw_alarms=raw,
        alarms=alarms,
        isolated=iso.isolated,
        candidates=iso.candidates,
        suspects=iso.suspects,
        events=events,
        threshold=thr,
        persistence=pers,
        structure=program.structure,
        fault_labels=[_fault_label(f) for f in bank.faults],
        residual_labels=[f"r[{k}]" for k in range(program.n_rows)],
        info={
            "dt": step,
            "hold": program.hold,
            "initial": initial if isinstance(initial, str) else "explicit",
            "restart": restart,
            "xi": xi,
            "settle": settle_s,
        },
    )


SETTLE_TIME_CONSTANTS = 7.0
"""Time constants of the slowest generator pole in ``settle="auto"`` (a start-up
transient falls to ``exp(-7)``, about 0.1 %, of its size)."""


def settling_time(bank: Any, dt: float) -> float:
    """:data:`SETTLE_TIME_CONSTANTS` time constants of the slowest pole of ``bank``'s
    generators: ``tau = -1 / max Re(p)`` (continuous) or ``-dt / ln max |p|``
    (discrete); 0 for static generators.

    Raises
    ------
    GeomFDIError
        A generator pole that is not stable (no transient ever settles).
    """
    tau = 0.0
    for g in as_bank(bank).generators:
        if g is None or not g.order:
            continue
        p = np.asarray(g.poles)
        if bank.dt > 0:
            r = float(np.max(np.abs(p)))
            if r >= 1.0:
                raise GeomFDIError("settle: a generator pole is not stable", argument="settle")
            tau = max(tau, -dt / np.log(r) if r > 0 else 0.0)
        else:
            a = float(np.max(p.real))
            if a >= 0.0:
                raise GeomFDIError("settle: a generator pole is not stable", argument="settle")
            tau = max(tau, -1.0 / a)
    return SETTLE_TIME_CONSTANTS * tau


def _fault_indices(bank: Any, signals: Sequence[Any]) -> list[int | None]:
    from geomfdi.model.faults import SensorFault

    out: list[int | None] = []
    for f in signals:
        j = None
        for idx, df in enumerate(bank.faults):
            if isinstance(df, SensorFault) and df.i == f.sensor:
                j = idx
                break
        out.append(j)
    return out


def _is_frame(obj: Any) -> bool:
    mod = type(obj).__module__
    return mod.startswith("pandas") and hasattr(obj, "columns")
