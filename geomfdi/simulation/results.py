"""Results of :func:`~geomfdi.simulate` and :func:`~geomfdi.simulate_batch`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._validation import as_float, as_int
from geomfdi.errors import GeomFDIError
from geomfdi.evaluation.decision import (
    FaultEvent,
    Threshold,
    isolate,
)
from geomfdi.evaluation.metrics import (
    DetectionMetrics,
    FalseAlarms,
    detection_metrics,
    false_alarms,
)
from geomfdi.evaluation.persistence import Persistence
from geomfdi.simulation.signals import FaultSignal


# ================================================================== results
@dataclass
class SimulationResult:
    """Outcome of :func:`simulate`.

    Attributes
    ----------
    t : ndarray, (N,)
    x : ndarray, (n, N)
        Plant state.
    y : ndarray, (q, N)
        Faulty measured output (what the bank and an output-feedback controller saw).
    y_healthy : ndarray, (q, N)
        Healthy reading ``C x + D u + Dd d + v`` (noise included, no sensor fault).
    u : ndarray, (m, N)
        Applied input (including the controller's action).
    residuals : ndarray, (n_residuals, N)
        One row per bank row (aligned with ``bank.generators``); zeros for missing
        generators; the norm of the components for vector residuals.
    residual_vectors : list of ndarray or None
        Per bank row, the residual components (n_outputs, N).
    alarms : ndarray of bool, (n_residuals, N)
        All False when no threshold is given.
    isolated : ndarray of int, (N,)
        Isolation decision per sample (see :mod:`geomfdi.evaluation.decision`).
    candidates, suspects : ndarray of bool, (n_faults, N)
    threshold : Threshold or None
    events : list of FaultEvent
        Detection/isolation delay per simulated fault.
    faults : list
        The simulated fault signals.
    structure : ndarray of bool
        Achieved structure used for isolation (residuals x design faults).
    xc : ndarray or None
        Controller state (output feedback).
    w : list of ndarray or None
        Generator states per bank row (with ``keep_states=True`` or output feedback).
    info : dict
        ``mode``, ``hold``, ``init_mismatch`` per generator, ``segments``,
        ``stepped_samples``, ``channels``.
    """

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    y_healthy: np.ndarray
    u: np.ndarray
    residuals: np.ndarray
    residual_vectors: list[np.ndarray | None]
    alarms: np.ndarray
    isolated: np.ndarray
    candidates: np.ndarray
    suspects: np.ndarray
    threshold: Threshold | None
    events: list[FaultEvent]
    faults: list[FaultSignal]
    structure: np.ndarray
    requested: np.ndarray | None
    fault_labels: list[str]
    residual_labels: list[str]
    xc: np.ndarray | None = None
    w: list[np.ndarray | None] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)
    vector_rows: list[bool] = field(default_factory=list)
    persistence: Persistence | None = None

    @property
    def onsets(self) -> list[float]:
        """Onset time of each simulated fault that starts on the grid."""
        return [ev.onset for ev in self.events]

    def to_frame(self, *, physical: bool = True) -> Any:
        """The recorded signals as a pandas DataFrame: ``t``, then the outputs and inputs
        in columns named after the plant's signals (``y0, ..., u0, ...`` by default).

        ``physical=True`` adds the plant's operating point (``y_op + y``, ``u_op + u``):
        the values a logger records, which :func:`geomfdi.evaluate`, the Monitor and the
        generated code read back by name.  Write it with ``frame.to_csv(path,
        index=False)``.
        """
        import pandas as pd

        sig = self.info.get("signals") or {}
        q, m = self.y.shape[0], self.u.shape[0]
        outs = sig.get("outputs") or [f"y{i}" for i in range(q)]
        ins = sig.get("inputs") or [f"u{j}" for j in range(m)]
        y, u = self.y, self.u
        if physical:
            y = y + np.asarray(sig.get("y_op") or np.zeros(q))[:, None]
            u = u + np.asarray(sig.get("u_op") or np.zeros(m))[:, None]
        cols = {"t": self.t, **dict(zip(outs, y, strict=True)), **dict(zip(ins, u, strict=True))}
        return pd.DataFrame(cols)

    def max_abs(self, start: float | None = None, stop: float | None = None) -> np.ndarray:
        """``max |r|`` per residual over ``start <= t <= stop`` (bounds optional)."""
        start = as_float(start, "start", allow_none=True)
        stop = as_float(stop, "stop", allow_none=True)
        sel = np.ones(self.t.shape, dtype=bool)
        if start is not None:
            sel &= self.t >= start - 1e-9 * max(1.0, abs(start))
        if stop is not None:
            sel &= self.t <= stop + 1e-9 * max(1.0, abs(stop))
        if not sel.any():
            raise GeomFDIError("start, stop: the window holds no sample", argument="start")
        return np.max(np.abs(self.residuals[:, sel]), axis=1)

    def norm_rows(self) -> list[bool]:
        """Per residual row: True when it is the norm of a vector residual (never < 0)."""
        if self.vector_rows:
            return list(self.vector_rows)
        return [rv is not None and rv.shape[0] > 1 for rv in self.residual_vectors]

    def _false_alarms(self) -> FalseAlarms:
        k = np.searchsorted(self.t, min(self.onsets) - 1e-12) if self.onsets else self.t.size
        return false_alarms(self.alarms, int(k))

    def false_alarm_rate(self, per: str = "sample") -> float | None:
        """False alarms before the first onset (``None`` without threshold or healthy part).

        Parameters
        ----------
        per : {"sample", "hour"}
            ``"sample"``: fraction of the healthy samples where some residual alarms;
            ``"hour"``: false-alarm events (rising edges) per hour of healthy time.
        """
        if per not in ("sample", "hour"):
            raise GeomFDIError(f"per: must be 'sample' or 'hour', got {per!r}", argument="per")
        fa = self._false_alarms()
        if self.threshold is None or fa.samples == 0:
            return None
        if per == "sample":
            return fa.alarm_samples / fa.samples
        return fa.events / (fa.samples * float(self.t[1] - self.t[0]) / 3600.0)

    def metrics(self) -> DetectionMetrics:
        """Detection metrics of this run (see :mod:`geomfdi.evaluation.metrics`)."""
        return detection_metrics(
            [self.events],
            [self._false_alarms()],
            float(self.t[1] - self.t[0]),
            self.structure.shape[1],
            labels=self.fault_labels,
        )

    def summary_rows(self) -> list[dict[str, Any]]:
        """One dict per simulated fault: onset, detection and isolation times/delays."""
        rows = []
        for ev in self.events:
            rows.append(
                {
                    "fault": ev.fault.label(),
                    "sensor": getattr(ev.fault, "sensor", None),
                    "actuator": getattr(ev.fault, "actuator", None),
                    "structure_column": ev.index,
                    "onset": ev.onset,
                    "detected_at": ev.detection_time,
                    "detection_delay": ev.detection_delay,
                    "isolated_at": ev.isolation_time,
                    "isolation_delay": ev.isolation_delay,
                    "isolation": ev.outcome,
                    "alarming_residuals": [self.residual_labels[r] for r in ev.residuals],
                }
            )
        return rows

    def summary(self) -> str:
        """A plain-text report: residual peaks, thresholds, detection and isolation."""
        return _summary_text(self)

    def plot(self, **kwargs: Any) -> Any:
        """Residual traces with thresholds and fault onsets (a matplotlib Figure)."""
        from geomfdi.plotting.residuals import plot_result

        return plot_result(self, **kwargs)


def _fmt(x: float | None, unit: str = " s") -> str:
    return "-" if x is None else f"{x:.4g}{unit}"


def _summary_text(res: SimulationResult) -> str:
    lines = [
        f"simulation: {res.t.size} samples, t = {res.t[0]:g} .. {res.t[-1]:g} s, "
        f"mode {res.info.get('mode')}"
    ]
    first = min(res.onsets) if res.onsets else None
    lines.append("residual   max|r| before first onset   max|r| after   threshold")
    before = (
        res.max_abs(stop=res.t[max(np.searchsorted(res.t, first - 1e-12) - 1, 0)])
        if first is not None and first > res.t[0]
        else None
    )
    after = res.max_abs(start=first) if first is not None else res.max_abs()
    for k, lab in enumerate(res.residual_labels):
        thr = "-" if res.threshold is None else f"{res.threshold.values[k]:.4g}"
        b = "-" if before is None else f"{before[k]:.4g}"
        lines.append(f"{lab:<10} {b:>26} {after[k]:>14.4g} {thr:>11}")
    if res.events:
        lines.append("fault                                   onset    detected   isolated")
        for ev in res.events:
            lines.append(
                f"{ev.fault.label()[:38]:<38} {ev.onset:>7.4g} {_fmt(ev.detection_delay):>10} "
                f"{_fmt(ev.isolation_delay):>10}"
            )
    far = res.false_alarm_rate()
    if far is not None:
        lines.append(f"false-alarm rate before the first onset: {far:.4g}")
    return "\n".join(lines)


@dataclass
class BatchResult:
    """Outcome of :func:`simulate_batch` (leading axis: runs).

    Attributes
    ----------
    t : ndarray, (N,)
    runs : int
    residuals : ndarray, (runs, n_residuals, N) or None
        Stored unless ``store="summary"``.
    alarms : ndarray of bool, (runs, n_residuals, N) or None
    isolated : ndarray of int, (runs, N) or None
    x, y, u, y_healthy : ndarray or None
        Stored with ``store="all"``.
    peak : ndarray, (runs, n_residuals)
        ``max |r|`` over each run.
    events : list of list of FaultEvent
    false_alarm_counts, healthy_samples, false_alarm_events : ndarray, (runs,)
        Number of samples before each run's first onset with some alarm, of samples
        before the first onset, and of false-alarm events (rising edges) there (see
        :meth:`false_alarm_rate`).
    persistence : Persistence or None
        The persistence rule of the alarms and decisions.

    Every rate is a method (``false_alarm_rate(per=...)``, ``detection_rate(which)``,
    ``missed_detection_rate(which)``, ``metrics(which)``).
    fault_lists : list of list
    seeds : list
    threshold : Threshold or None
    """

    t: np.ndarray
    runs: int
    residuals: np.ndarray | None
    alarms: np.ndarray | None
    isolated: np.ndarray | None
    x: np.ndarray | None
    y: np.ndarray | None
    u: np.ndarray | None
    y_healthy: np.ndarray | None
    peak: np.ndarray
    events: list[list[FaultEvent]]
    false_alarm_counts: np.ndarray
    healthy_samples: np.ndarray
    fault_lists: list[list[FaultSignal]]
    seeds: list[Any]
    threshold: Threshold | None
    structure: np.ndarray
    requested: np.ndarray | None
    fault_labels: list[str]
    residual_labels: list[str]
    info: dict[str, Any] = field(default_factory=dict)
    vector_rows: list[bool] = field(default_factory=list)
    persistence: Persistence | None = None
    false_alarm_events: np.ndarray | None = None

    def _false_alarms(self) -> list[FalseAlarms]:
        ev = (
            self.false_alarm_events
            if self.false_alarm_events is not None
            else np.zeros(self.runs, dtype=int)
        )
        return [
            FalseAlarms(int(h), int(c), int(e))
            for h, c, e in zip(self.healthy_samples, self.false_alarm_counts, ev, strict=True)
        ]

    def metrics(self, which: int | None = None) -> DetectionMetrics:
        """Aggregated detection metrics (:mod:`geomfdi.evaluation.metrics`).

        ``which``: count only the ``which``-th fault of each run's list (default: all).
        """
        if which is not None:
            which = as_int(which, "which", minimum=0)
        return detection_metrics(
            self.events,
            self._false_alarms(),
            float(self.t[1] - self.t[0]),
            self.structure.shape[1],
            which=which,
            labels=self.fault_labels,
        )

    def false_alarm_rate(self, per: str = "sample") -> float | None:
        """False-alarm rate over the runs' fault-free parts (``None`` without data).

        Parameters
        ----------
        per : {"sample", "run", "hour"}
            Pooled fraction of healthy samples with some alarm; fraction of runs with a
            false alarm; false-alarm events per hour of healthy time.
        """
        if per not in ("sample", "run", "hour"):
            raise GeomFDIError(
                f"per: must be 'sample', 'run' or 'hour', got {per!r}", argument="per"
            )
        if self.threshold is None:
            return None
        m = self.metrics()
        return {"sample": m.far_per_sample, "run": m.far_per_run, "hour": m.far_per_hour}[per]

    def detection_rate(self, which: int = 0) -> float:
        """Fraction of runs whose ``which``-th fault (in its list) was detected in its window."""
        which = as_int(which, "which", minimum=0)
        ev = [e[which] for e in self.events if len(e) > which]
        if not ev:
            raise GeomFDIError(f"which: no run has a fault number {which}", argument="which")
        return float(np.mean([x.detected for x in ev]))

    def missed_detection_rate(self, which: int = 0) -> float:
        """``1 - detection_rate(which)``."""
        return 1.0 - self.detection_rate(which)

    def detection_delays(self, which: int = 0) -> np.ndarray:
        """Detection delays of the ``which``-th fault over the runs that detected it."""
        which = as_int(which, "which", minimum=0)
        return np.array(
            [e[which].detection_delay for e in self.events if len(e) > which and e[which].detected]
        )

    def run(self, i: int) -> SimulationResult:
        """Run ``i`` as a :class:`SimulationResult` (needs ``store="all"``)."""
        i = as_int(i, "i", minimum=0)
        if self.x is None or self.residuals is None:
            raise GeomFDIError("i: single runs need simulate_batch(..., store='all')", argument="i")
        if i >= self.runs:
            raise GeomFDIError(f"i: only {self.runs} runs", argument="i")
        if self.persistence is not None:
            iso = self.persistence.isolation(self.alarms[i], self.structure)
        else:
            iso = isolate(self.alarms[i], self.structure)
        return SimulationResult(
            self.t,
            self.x[i],
            self.y[i],
            self.y_healthy[i],
            self.u[i],
            self.residuals[i],
            [None] * self.residuals.shape[1],
            self.alarms[i],
            iso.isolated,
            iso.candidates,
            iso.suspects,
            self.threshold,
            self.events[i],
            self.fault_lists[i],
            self.structure,
            self.requested,
            self.fault_labels,
            self.residual_labels,
            info=dict(self.info),
            vector_rows=list(self.vector_rows),
            persistence=self.persistence,
        )

    def summary(self) -> str:
        """Plain-text Monte-Carlo summary."""
        lines = [f"batch: {self.runs} runs x {self.t.size} samples"]
        pk = self.peak
        for k, lab in enumerate(self.residual_labels):
            lines.append(
                f"{lab:<10} max|r| median {np.median(pk[:, k]):.4g}, max {np.max(pk[:, k]):.4g}"
            )
        nmax = max((len(e) for e in self.events), default=0)
        for j in range(nmax):
            rate = self.detection_rate(j)
            d = self.detection_delays(j)
            md = f"{np.median(d):.4g} s" if d.size else "-"
            lines.append(f"fault #{j}: detected in {rate:.1%} of runs, median delay {md}")
        far = self.false_alarm_rate()
        if far is not None:
            lines.append(f"false-alarm rate (fault-free samples): {far:.4g}")
        return "\n".join(lines)
