"""Detection metrics per run and over many runs: FAR, MDR, delays, isolation, confusion.

Definitions (``alarm`` is the persistent any-residual alarm; the *healthy part* of a run
is the samples before its first fault onset):

* **FAR per sample**: healthy samples with an alarm / healthy samples (pooled).
* **FAR per run**: runs with at least one alarm in their healthy part / runs with a
  healthy part.
* **FAR per hour**: false-alarm *events* (rising edges of the alarm in the healthy part,
  one at the first sample when it starts raised) / healthy time in hours.
* **P_d** (detection rate) and **MDR** ``= 1 - P_d``: fraction of fault events with an
  alarm in the detection window ``[onset, onset + window]``; an alarm before the onset
  never counts.
* **Delays**: detection and isolation delays of the detected (isolated) events: mean and
  percentiles.
* **Isolation outcome** of an event: the first isolation decision in the window is its
  own structure column (correct), another fault (wrong), several faults at once
  (multiple), or there is none (none).
* **Confusion matrix** ``C[i, j]``: events of fault ``i`` whose first decision was fault
  ``j``; the last two columns count the events decided "multiple" and those without a
  decision.

See the user guide, *Theory: evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError
from geomfdi.evaluation.decision import MULTIPLE, FaultEvent

__all__ = ["FalseAlarms", "DetectionMetrics", "false_alarms", "detection_metrics"]

PERCENTILES = (50.0, 90.0, 95.0)


@dataclass(frozen=True)
class FalseAlarms:
    """False alarms of one run's healthy part.

    Attributes
    ----------
    samples : int
        Healthy samples (before the first onset).
    alarm_samples : int
        Healthy samples with an alarm.
    events : int
        Rising edges of the alarm in the healthy part.
    """

    samples: int
    alarm_samples: int
    events: int


def false_alarms(alarms: Any, healthy: int) -> FalseAlarms:
    """False alarms of one run: ``alarms`` (n_residuals, N) or (N,), first ``healthy`` samples."""
    a = np.asarray(alarms, dtype=bool)
    if a.ndim == 2:
        a = a.any(axis=0)
    a = a[:healthy]
    edges = int(a[0]) + int(np.count_nonzero(a[1:] & ~a[:-1])) if a.size else 0
    return FalseAlarms(int(a.size), int(np.count_nonzero(a)), edges)


def _stats(x: np.ndarray) -> dict[str, float | None]:
    if x.size == 0:
        return {"mean": None, **{f"p{p:g}": None for p in PERCENTILES}}
    out: dict[str, float | None] = {"mean": float(np.mean(x))}
    for p in PERCENTILES:
        out[f"p{p:g}"] = float(np.percentile(x, p))
    return out


@dataclass(frozen=True)
class DetectionMetrics:
    """Aggregated detection metrics (see the module docstring for the definitions).

    Attributes
    ----------
    runs : int
    events : int
        Fault events counted (one per simulated fault that starts on the grid).
    detection_rate, missed_detection_rate : float or None
        ``None`` without events.
    far_per_sample, far_per_run, far_per_hour : float or None
        ``None`` without healthy samples.
    detection_delay, isolation_delay : dict
        ``mean``, ``p50``, ``p90``, ``p95`` (seconds; ``None`` without data).
    isolation : dict
        Fractions of events with a ``correct``, ``wrong``, ``multiple`` and ``none``
        isolation outcome.
    confusion : ndarray of int, (n_faults, n_faults + 2)
        Rows: the true structure column; columns: the first decision (a fault), then
        ``multiple``, then ``none``.
    labels : list of str
        Fault labels of the confusion rows.
    """

    runs: int
    events: int
    detection_rate: float | None
    missed_detection_rate: float | None
    far_per_sample: float | None
    far_per_run: float | None
    far_per_hour: float | None
    detection_delay: dict[str, float | None]
    isolation_delay: dict[str, float | None]
    isolation: dict[str, float | None]
    confusion: np.ndarray
    labels: list[str] = field(default_factory=list)

    def summary(self) -> str:
        """Plain-text table of the metrics."""

        def f(x: float | None, unit: str = "") -> str:
            return "-" if x is None else f"{x:.4g}{unit}"

        dd, di, iso = self.detection_delay, self.isolation_delay, self.isolation
        lines = [
            f"runs {self.runs}, fault events {self.events}",
            f"P_d {f(self.detection_rate)}   MDR {f(self.missed_detection_rate)}",
            f"FAR {f(self.far_per_sample)} per sample, {f(self.far_per_run)} per run, "
            f"{f(self.far_per_hour)} per hour",
            f"detection delay mean {f(dd['mean'], ' s')}, p50 {f(dd['p50'], ' s')}, "
            f"p95 {f(dd['p95'], ' s')}",
            f"isolation delay mean {f(di['mean'], ' s')}, p50 {f(di['p50'], ' s')}, "
            f"p95 {f(di['p95'], ' s')}",
            f"isolation correct {f(iso['correct'])}, wrong {f(iso['wrong'])}, "
            f"multiple {f(iso['multiple'])}, none {f(iso['none'])}",
        ]
        return "\n".join(lines)


def detection_metrics(
    events: Sequence[Sequence[FaultEvent]],
    false: Sequence[FalseAlarms],
    dt: float,
    n_faults: int,
    *,
    which: int | None = None,
    labels: Sequence[str] | None = None,
) -> DetectionMetrics:
    """Aggregate per-run events and false alarms into :class:`DetectionMetrics`.

    Parameters
    ----------
    events : sequence (runs) of sequences of FaultEvent
    false : sequence (runs) of FalseAlarms
    dt : float
        Sampling step (seconds), for the FAR per hour.
    n_faults : int
        Columns of the structure matrix (rows of the confusion matrix).
    which : int, optional
        Count only the ``which``-th fault of each run's list (default: every event).
    labels : sequence of str, optional
    """
    if len(events) != len(false):
        raise GeomFDIError("events: one list per run, as many as false-alarm records")
    evs = [e for run in events for pos, e in enumerate(run) if which is None or pos == which]
    if which is not None and not evs and any(events):
        raise GeomFDIError(f"which: no run has a fault number {which}", argument="which")
    det = np.array([e.detected for e in evs], dtype=bool)
    pd = float(det.mean()) if evs else None
    healthy = np.array([fa.samples for fa in false])
    with_part = healthy > 0
    tot = int(healthy.sum())
    far_s = float(sum(fa.alarm_samples for fa in false) / tot) if tot else None
    far_r = (
        float(np.mean([fa.alarm_samples > 0 for fa, w in zip(false, with_part, strict=True) if w]))
        if with_part.any()
        else None
    )
    far_h = float(sum(fa.events for fa in false) / (tot * dt / 3600.0)) if tot else None
    dd = np.array([e.detection_delay for e in evs if e.detected])
    di = np.array([e.isolation_delay for e in evs if e.isolated])
    outcomes = [e.outcome for e in evs]
    iso = {
        k: (outcomes.count(k) / len(outcomes) if outcomes else None)
        for k in ("correct", "wrong", "multiple", "none")
    }
    C = np.zeros((n_faults, n_faults + 2), dtype=int)
    for e in evs:
        if e.index is None or e.index >= n_faults:
            continue
        if e.decided is None:
            col = n_faults + 1
        elif e.decided == MULTIPLE:
            col = n_faults
        else:
            col = e.decided
        C[e.index, col] += 1
    return DetectionMetrics(
        runs=len(events),
        events=len(evs),
        detection_rate=pd,
        missed_detection_rate=None if pd is None else 1.0 - pd,
        far_per_sample=far_s,
        far_per_run=far_r,
        far_per_hour=far_h,
        detection_delay=_stats(dd),
        isolation_delay=_stats(di),
        isolation=iso,
        confusion=C,
        labels=list(labels) if labels is not None else [f"fault {j}" for j in range(n_faults)],
    )
