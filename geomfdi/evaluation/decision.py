"""Decision logic: thresholds, alarms, isolation from the structure matrix, delays.

A residual ``r_j`` raises an alarm at sample ``k`` when its *test statistic* exceeds the
residual's threshold::

    alarm[j, k] = s_j[k] > threshold_j

with the statistic ``s = |r|`` (``statistic="abs"``, the paper's rule ``|r| > epsilon``)
or the causal moving root mean square over the last ``window`` samples
(``statistic="rms"``, which trades detection delay for a lower noise level).

Isolation compares the alarm pattern of a sample (one boolean per residual) with the
columns of the *achieved* structure matrix of the bank (rows: residuals, columns:
faults; the fault signature matrix of Hou, Wen & Chen 2011; see the user guide,
*Theory: evaluation*, ``docs/theory/evaluation.md``): fault ``j`` is a **candidate**
when its column equals the pattern.  Per sample the decision is

* the fault index when exactly one fault is a candidate,
* :data:`NO_ALARM` (-1) when no residual alarms,
* :data:`UNEXPLAINED` (-2) when the pattern matches no column (several faults at once,
  or a false alarm on some residual),
* :data:`AMBIGUOUS` (-3) when several faults share the matching column (they are not
  isolable from each other).

For several simultaneous faults, :func:`isolate` also returns **suspects**: faults with
a non-zero column contained in the alarm pattern (every residual that should react to
them does).  A pattern that matches no column but is the union (element-wise OR) of the
columns of its suspects is explained by several faults at once;
:func:`fault_hypotheses` lists the smallest such sets.  The decisions under a
persistence rule (:mod:`geomfdi.evaluation.persistence`) report it as :data:`MULTIPLE`
(-4).
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._validation import (
    as_bool_array,
    as_choice,
    as_int,
    as_positive,
    as_probability,
    as_real_array,
    as_vector,
    check_finite,
)
from geomfdi.errors import GeomFDIError, ShapeError

__all__ = [
    "NO_ALARM",
    "UNEXPLAINED",
    "AMBIGUOUS",
    "MULTIPLE",
    "STATISTICS",
    "Threshold",
    "as_threshold",
    "decision_statistic",
    "isolate",
    "fault_hypotheses",
    "Isolation",
    "FaultEvent",
    "detection_events",
]

NO_ALARM = -1
UNEXPLAINED = -2
AMBIGUOUS = -3
MULTIPLE = -4
STATISTICS = ("abs", "rms")


def decision_statistic(residuals: Any, statistic: str = "abs", window: int = 1) -> np.ndarray:
    """The decision statistic of residual signals, time on the last axis.

    Parameters
    ----------
    residuals : array_like, (..., N)
    statistic : {"abs", "rms"}
        ``"abs"``: ``|r[k]|``.  ``"rms"``: ``sqrt(mean(r[k-window+1 .. k]^2))``, causal;
        the first ``window - 1`` samples average over the samples available.
    window : int
        Window length in samples for ``"rms"`` (ignored for ``"abs"``).

    Returns
    -------
    ndarray, same shape as ``residuals``
    """
    r = np.asarray(residuals, dtype=float)
    statistic = as_choice(statistic, "statistic", STATISTICS)
    if statistic == "abs" or window == 1:
        return np.abs(r)
    window = as_int(window, "window", minimum=1)
    sq = r * r
    c = np.cumsum(sq, axis=-1)
    out = c.copy()
    out[..., window:] = c[..., window:] - c[..., :-window]
    count = np.minimum(np.arange(1, r.shape[-1] + 1), window)
    # cumulative-sum differences can dip below zero by rounding on a flat stretch
    return np.sqrt(np.maximum(out, 0.0) / count)


@dataclass(frozen=True)
class Threshold:
    """Per-residual thresholds on a test statistic.

    Attributes
    ----------
    values : ndarray, (n_residuals,)
        ``+inf`` disables a residual (used for rows whose generator is missing).
    statistic : {"abs", "rms"}
        See :func:`decision_statistic`.
    window : int
        Window (samples) of the ``"rms"`` statistic.
    false_alarm_rate : float or None
        The per-sample false-alarm rate the thresholds were calibrated for, if any.
    source : str
        How the values were obtained (``"fixed"``, ``"calibrated ..."``).
    """

    values: np.ndarray
    statistic: str = "abs"
    window: int = 1
    false_alarm_rate: float | None = None
    source: str = "fixed"
    info: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        values = np.atleast_1d(as_real_array(self.values, "values", allow_nonfinite=True))
        if values.ndim != 1 or values.size == 0:
            raise ShapeError(
                f"values: expected a non-empty vector, got {values.shape}", argument="values"
            )
        if np.any(np.isnan(values)) or np.any(values < 0):
            raise GeomFDIError("values: thresholds must be >= 0 (+inf disables)", argument="values")
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "statistic", as_choice(self.statistic, "statistic", STATISTICS))
        object.__setattr__(self, "window", as_int(self.window, "window", minimum=1))
        if self.false_alarm_rate is not None:
            as_probability(self.false_alarm_rate, "false_alarm_rate")

    def statistic_of(self, residuals: Any) -> np.ndarray:
        """The test statistic of ``residuals`` (``(..., n_residuals, N)``)."""
        return decision_statistic(residuals, self.statistic, self.window)

    def alarms(self, residuals: Any) -> np.ndarray:
        """Boolean alarms, same shape as ``residuals`` (``(..., n_residuals, N)``)."""
        if isinstance(residuals, np.ndarray) and residuals.dtype == np.float64:
            r = residuals  # hot path: no copy; a nan makes the sum nan
            if np.isnan(r.sum()):
                check_finite(r, "residuals")
        else:
            r = as_real_array(residuals, "residuals")
        if r.ndim < 2:
            raise ShapeError(
                f"residuals: expected (..., n_residuals, N), got shape {r.shape}",
                argument="residuals",
            )
        if r.shape[-2] != self.values.shape[0]:
            raise ShapeError(
                f"residuals: {r.shape[-2]} rows, the threshold has {self.values.shape[0]}",
                argument="residuals",
            )
        v = self.values[:, None]
        if self.statistic == "abs" or self.window == 1:
            return (r > v) | (r < -v)  # |r| > v without a float temporary
        return self.statistic_of(r) > v

    @classmethod
    def from_residuals(
        cls,
        residuals: Any,
        false_alarm_rate: float,
        *,
        statistic: str = "abs",
        window: int = 1,
        per: str = "residual",
        skip: int = 0,
    ) -> Threshold:
        """Thresholds from noise-only residuals at a chosen false-alarm rate.

        Parameters
        ----------
        residuals : array_like, (n_residuals, N) or (runs, n_residuals, N)
            Residuals of fault-free runs (noise only).
        false_alarm_rate : float
            Target probability ``alpha`` that a healthy sample raises an alarm.
        statistic, window
            See :func:`decision_statistic`.
        per : {"residual", "any"}
            ``"residual"``: each residual alarms with rate ``alpha``.  ``"any"``: the
            rate of "some residual alarms" is at most ``alpha``, by the Bonferroni split
            ``alpha / n`` over the ``n`` monitored residuals (conservative when the
            residuals are correlated).
        skip : int
            Leading samples to ignore (a transient at the start of the calibration run).

        Returns
        -------
        Threshold
            ``values[j]`` = empirical ``1 - alpha_j`` quantile of the statistic of
            residual ``j`` over all samples and runs (numpy's default linear
            interpolation).  Rows that are identically zero get ``+inf``.

        Notes
        -----
        An empirical quantile needs many more than ``1 / alpha`` samples to be accurate;
        fewer than ``1 / alpha`` is refused.  The quantile is taken over dependent
        samples (residuals are coloured), so the realised rate has a larger spread than
        the binomial one; calibrate on several runs for small ``alpha``.
        """
        alpha = as_probability(false_alarm_rate, "false_alarm_rate")
        r = as_real_array(residuals, "residuals")
        if r.ndim == 2:
            r = r[None]
        if r.ndim != 3:
            raise ShapeError(
                f"residuals: expected (n_residuals, N) or (runs, n_residuals, N), got {r.shape}",
                argument="residuals",
            )
        skip = as_int(skip, "skip", minimum=0)
        per = as_choice(per, "per", ("residual", "any"))
        statistic = as_choice(statistic, "statistic", STATISTICS)
        window = as_int(window, "window", minimum=1)
        s = decision_statistic(r, statistic, window)[..., skip:]
        nres = s.shape[1]
        samples = s.shape[0] * s.shape[2]
        live = np.array([np.any(s[:, j] != 0) for j in range(nres)])
        n_live = max(int(live.sum()), 1)
        a = alpha / n_live if per == "any" else alpha
        if samples * a < 1:
            raise GeomFDIError(
                f"false_alarm_rate: {alpha:g} needs at least {int(np.ceil(1 / a))} noise samples "
                f"per residual, got {samples}",
                argument="false_alarm_rate",
            )
        values = np.full(nres, np.inf)
        for j in np.flatnonzero(live):
            values[j] = float(np.quantile(s[:, j].ravel(), 1.0 - a))
        return cls(
            values,
            statistic=statistic,
            window=int(window),
            false_alarm_rate=alpha,
            source=f"calibrated on {samples} noise-only samples per residual ({per})",
            info={"per": per, "samples": samples, "alpha_per_residual": a},
        )


def as_threshold(threshold: Any, n_residuals: int, present: Sequence[int] | None = None) -> Any:
    """Convert ``threshold`` (None, number, per-residual vector or :class:`Threshold`).

    Rows not in ``present`` (missing generators) get ``+inf``.
    """
    if threshold is None:
        return None
    if isinstance(threshold, Threshold):
        if threshold.values.shape != (n_residuals,):
            raise ShapeError(
                f"threshold: has {threshold.values.shape[0]} values, the bank has "
                f"{n_residuals} residuals",
                argument="threshold",
            )
        return threshold
    if isinstance(threshold, numbers.Real) and not isinstance(threshold, bool):
        values = np.full(n_residuals, as_positive(threshold, "threshold"))
    else:
        values = as_vector(threshold, "threshold", length=n_residuals).copy()
    if np.any(values <= 0) or np.any(~np.isfinite(values)):
        raise GeomFDIError(
            f"threshold: values must be finite and > 0, got {values.tolist()}",
            argument="threshold",
        )
    if present is not None:
        missing = np.setdiff1d(np.arange(n_residuals), np.asarray(present, dtype=int))
        values[missing] = np.inf
    return Threshold(values)


@dataclass
class Isolation:
    """Per-sample isolation decisions (see the module docstring).

    Attributes
    ----------
    isolated : ndarray of int, (..., N)
        Fault index, or ``NO_ALARM`` / ``UNEXPLAINED`` / ``AMBIGUOUS`` (and ``MULTIPLE``
        from the decisions under a persistence rule).
    candidates : ndarray of bool, (..., n_faults, N)
        Faults whose structure column equals the alarm pattern.
    suspects : ndarray of bool, (..., n_faults, N)
        Faults with a non-zero column contained in the alarm pattern.
    """

    isolated: np.ndarray
    candidates: np.ndarray
    suspects: np.ndarray


def isolate(alarms: Any, structure: Any) -> Isolation:
    """Isolation decisions from alarms and the achieved structure matrix.

    Parameters
    ----------
    alarms : array_like of bool, (..., n_residuals, N)
    structure : array_like of bool, (n_residuals, n_faults)
        Achieved structure (rows of missing generators all False).

    Returns
    -------
    Isolation

    Examples
    --------
    >>> import numpy as np
    >>> from geomfdi.evaluation.decision import isolate
    >>> S = np.eye(3, dtype=bool)
    >>> a = np.array([[0, 1, 0, 1], [0, 0, 0, 1], [0, 0, 0, 0]], dtype=bool)
    >>> isolate(a, S).isolated.tolist()
    [-1, 0, -1, -2]
    """
    a = as_bool_array(alarms, "alarms")
    S = as_bool_array(structure, "structure")
    if S.ndim != 2:
        raise ShapeError(f"structure: must be 2-D, got shape {S.shape}", argument="structure")
    if S.ndim != 2 or a.ndim < 2 or a.shape[-2] != S.shape[0]:
        raise ShapeError(
            f"alarms: expected (..., {S.shape[0]}, N) for a structure of shape {S.shape}, got "
            f"{a.shape}",
            argument="alarms",
        )
    nf = S.shape[1]
    lead = a.shape[:-2]
    N = a.shape[-1]
    # candidate j: the alarm pattern equals column j; suspect j: every residual of column
    # j alarms.  Accumulated residual by residual in place (no (n_residuals, N) temporaries)
    cand = np.ones((*lead, nf, N), dtype=bool)
    sus = np.zeros((*lead, nf, N), dtype=bool)
    for j in range(nf):
        c, s = cand[..., j, :], sus[..., j, :]
        if S[:, j].any():
            s[...] = True
        for r in range(S.shape[0]):
            ar = a[..., r, :]
            if S[r, j]:
                np.logical_and(c, ar, out=c)
                np.logical_and(s, ar, out=s)
            else:
                np.less(ar, c, out=c)  # c and not ar
    any_alarm = a.any(axis=-2)
    n_cand = np.add.reduce(cand, axis=-2, dtype=np.int32)
    iso = np.full((*lead, N), UNEXPLAINED, dtype=int)
    np.copyto(iso, AMBIGUOUS, where=n_cand > 1)
    single = n_cand == 1
    for j in range(nf):
        np.copyto(iso, j, where=cand[..., j, :] & single)
    np.copyto(iso, NO_ALARM, where=~any_alarm)
    cand &= any_alarm[..., None, :]
    return Isolation(iso, cand, sus)


def fault_hypotheses(
    pattern: Any, structure: Any, *, max_faults: int | None = None
) -> list[tuple[int, ...]]:
    """The smallest sets of faults whose joint signature is the alarm pattern.

    Under the usual assumption that simultaneous faults do not cancel in a residual, the
    signature of a set of faults is the element-wise OR of their structure columns.  A
    hypothesis is a set ``J`` with ``OR_{j in J} S[:, j] == pattern``; only minimal ones
    (no proper subset is a hypothesis) are returned, smallest first.

    Parameters
    ----------
    pattern : array_like of bool, (n_residuals,)
    structure : array_like of bool, (n_residuals, n_faults)
    max_faults : int, optional
        Largest set size searched (default: every suspect).

    Returns
    -------
    list of tuple of int
        Empty when no set of faults explains the pattern (or the pattern is all False).

    Examples
    --------
    >>> import numpy as np
    >>> from geomfdi.evaluation.decision import fault_hypotheses
    >>> S = np.array([[1, 0, 1], [0, 1, 1]], dtype=bool)
    >>> fault_hypotheses([True, True], S)
    [(2,), (0, 1)]
    """
    from itertools import combinations

    p = as_bool_array(pattern, "pattern")
    S = as_bool_array(structure, "structure")
    if S.ndim != 2:
        raise ShapeError(
            f"structure: expected (n_residuals, n_faults), got shape {S.shape}",
            argument="structure",
        )
    if p.shape != (S.shape[0],):
        raise ShapeError(
            f"pattern: expected ({S.shape[0]},) for a structure of shape {S.shape}, got {p.shape}",
            argument="pattern",
        )
    if not p.any():
        return []
    # suspects: non-zero columns inside the pattern
    sus = [j for j in range(S.shape[1]) if S[:, j].any() and not np.any(S[:, j] & ~p)]
    top = len(sus) if max_faults is None else min(len(sus), as_int(max_faults, "max_faults"))
    found: list[tuple[int, ...]] = []
    for size in range(1, top + 1):
        for combo in combinations(sus, size):
            if any(set(f) <= set(combo) for f in found):
                continue
            if np.array_equal(S[:, list(combo)].any(axis=1), p):
                found.append(combo)
    return found


@dataclass(frozen=True)
class FaultEvent:
    """Detection and isolation of one simulated fault.

    Attributes
    ----------
    fault : object
        The fault signal (``GainFault`` ...).
    index : int or None
        Column of the bank's structure matrix that models this fault (the design fault
        on the same sensor), or ``None`` when the bank has none.
    onset : float
        First sample time with the fault active.
    detection_time, detection_delay : float or None
        First sample at or after the onset where any residual alarms; ``None``: never.
    isolation_time, isolation_delay : float or None
        First sample at or after the onset where the isolation decision equals
        ``index``; ``None``: never (or ``index`` is ``None``).
    residuals : tuple of int
        Residuals that alarm at some sample at or after the onset.
    decided : int or None
        The first isolation decision in the detection window: a fault index, or
        :data:`MULTIPLE` (several faults at once); ``None``: no decision.
    window_end : float or None
        End of the detection window (``None``: the end of the run).
    hypothesis : tuple of int
        With a ``MULTIPLE`` decision: the suspects at that sample (faults whose
        signatures are inside the alarm pattern, and whose union is the pattern).

    Only alarms and decisions at or after the onset and before ``window_end`` count: an
    alarm before the onset is a false alarm, not a detection.
    """

    fault: Any
    index: int | None
    onset: float
    detection_time: float | None
    detection_delay: float | None
    isolation_time: float | None
    isolation_delay: float | None
    residuals: tuple[int, ...]
    decided: int | None = None
    window_end: float | None = None
    hypothesis: tuple[int, ...] = ()

    @property
    def detected(self) -> bool:
        return self.detection_time is not None

    @property
    def isolated(self) -> bool:
        return self.isolation_time is not None

    @property
    def outcome(self) -> str:
        """``"correct"``, ``"wrong"`` (the first decision named another fault),
        ``"multiple"`` (the first decision was several faults at once) or ``"none"``."""
        if self.decided is None:
            return "none"
        if self.decided == MULTIPLE:
            return "multiple"
        return "correct" if self.decided == self.index else "wrong"


def detection_events(
    t: np.ndarray,
    alarms: np.ndarray,
    isolated: np.ndarray,
    faults: Sequence[Any],
    indices: Sequence[int | None],
    *,
    window: float | None = None,
    suspects: np.ndarray | None = None,
) -> list[FaultEvent]:
    """Detection and isolation times of each fault signal (one run).

    Parameters
    ----------
    t : ndarray, (N,)
    alarms : ndarray of bool, (n_residuals, N)
    isolated : ndarray of int, (N,)
    faults : sequence of fault signals (with ``.mask(t)``)
    indices : sequence of int or None
        Structure column of each fault signal.
    window : float, optional
        Detection window (seconds after the onset); ``None``: to the end of the run.
    suspects : ndarray of bool, (n_faults, N), optional
        Suspects of the decisions (:class:`Isolation`); gives the hypothesis of a
        ``MULTIPLE`` decision.

    Returns
    -------
    list of FaultEvent
        One per fault whose onset lies on the grid (faults starting after the end are
        skipped).
    """
    any_alarm = alarms.any(axis=0)
    N = t.shape[0]
    out = []
    for f, j in zip(faults, indices, strict=True):
        m = f.mask(t)
        if not m.any():
            continue
        ks = int(np.argmax(m))
        onset = float(t[ks])
        if window is None:
            ke, wend = N, None
        else:
            wend = onset + float(window)
            ke = int(np.searchsorted(t, wend + 1e-9 * max(1.0, abs(wend)), side="right"))
        hits = np.flatnonzero(any_alarm[ks:ke])
        det = float(t[ks + hits[0]]) if hits.size else None
        iso_t = None
        if j is not None:
            ih = np.flatnonzero(isolated[ks:ke] == j)
            iso_t = float(t[ks + ih[0]]) if ih.size else None
        seg = isolated[ks:ke]
        dh = np.flatnonzero((seg >= 0) | (seg == MULTIPLE))
        decided = int(seg[dh[0]]) if dh.size else None
        hyp: tuple[int, ...] = ()
        if decided == MULTIPLE and suspects is not None:
            hyp = tuple(int(f) for f in np.flatnonzero(suspects[:, ks + dh[0]]))
        rows = tuple(int(r) for r in np.flatnonzero(alarms[:, ks:ke].any(axis=1)))
        out.append(
            FaultEvent(
                f,
                j,
                onset,
                det,
                None if det is None else det - onset,
                iso_t,
                None if iso_t is None else iso_t - onset,
                rows,
                decided,
                wend,
                hyp,
            )
        )
    return out
