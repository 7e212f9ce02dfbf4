"""Result objects of the parity-space functions: diagnoses, capability figures, rates.

See the user guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._moved import renamed as _renamed
from geomfdi._validation import as_probability

__all__ = [
    "ParityDiagnosis",
    "ConfigurationCapability",
    "RateEstimate",
    "IsolationRates",
    "RateCurve",
    "QinNiuResult",
]


class ParityDiagnosis:
    """Per-sample outcome of :meth:`ParityFDI.diagnose`.

    Attributes
    ----------
    detected : ndarray of bool, shape (N,)
        The detection test rejected the no-fault hypothesis.
    faults : ndarray of int, shape (N, max_faults)
        Isolated sensors (fault hypotheses), ``-1`` padded.  Sequential modes list them in
        the order of isolation; ``"search"`` and ``"glr"`` list the isolated set sorted.
    statistic : ndarray, shape (N,)
        The first-stage detection statistic (``FD_GLT``, ``FD_OPT`` or ``max |d_i|``).
    threshold : float
        The first-stage threshold it was compared with.
    method, pfa, max_faults
        The options used.
    info : dict
        Method-specific details (for ``"sprt"``: Wald's boundaries, the calibrated
        rate's Monte-Carlo error...); empty for the per-sample tests.
    """

    def __init__(
        self,
        detected: np.ndarray,
        faults: np.ndarray,
        statistic: np.ndarray,
        threshold: float,
        method: str,
        pfa: float,
        unresolved: np.ndarray | None = None,
        info: dict | None = None,
    ) -> None:
        self.detected = detected
        self.faults = faults
        self.statistic = statistic
        self.threshold = float(threshold)
        self.method = method
        self.pfa = float(pfa)
        self._unresolved = unresolved
        self.info = {} if info is None else dict(info)

    @property
    def isolated(self) -> np.ndarray:
        """First isolated sensor per sample, ``-1`` when none, shape (N,)."""
        return self.faults[..., 0]

    @property
    def max_faults(self) -> int:
        """Number of columns of :attr:`faults`."""
        return int(self.faults.shape[-1])

    @property
    def n_faults(self) -> np.ndarray:
        """Number of isolated sensors per sample, shape (N,)."""
        return np.count_nonzero(self.faults >= 0, axis=-1)

    @property
    def unresolved(self) -> np.ndarray:
        """Detected samples whose alarm the diagnosis could not explain, shape (N,).

        True when a detection (at any stage) could not be followed by an unambiguous
        isolation, or when the residual was still inconsistent after the last test.
        """
        if self._unresolved is None:
            self._unresolved = self.detected & (self.faults[..., 0] < 0)
        return self._unresolved

    def __len__(self) -> int:
        return int(self.detected.shape[0])

    def __repr__(self) -> str:
        n = len(self)
        return (
            f"ParityDiagnosis(method={self.method!r}, N={n}, detected={int(self.detected.sum())}, "
            f"isolated={int((self.faults[..., 0] >= 0).sum())}, pfa={self.pfa:g})"
        )


@dataclass(frozen=True)
class ConfigurationCapability:
    """Isolation-capability figures of a sensor configuration.

    Attributes
    ----------
    w : ndarray, shape (k,)
        ``w_ii = ||V_i||^2`` (``diag W``; in general ``diag G^T G`` of the whitened fault
        signatures).  ``w_ii`` is the fraction of a fault on sensor ``i`` that reaches
        the parity space; ``0`` means undetectable (Zhang, Chen & Liu (2005), Lemma 1: ``0 <
        w_ii < 1``
        for a fully redundant configuration).
    parity_cos : ndarray, shape (k, k)
        Cosine between the fault signatures ``V_i`` and ``V_j`` in parity space.
    separation_deg : ndarray, shape (k, k)
        ``arccos |parity_cos|`` in degrees: 0 means the two faults are indistinguishable.
    axis_cos : ndarray, shape (m, m)
        Cosine between sensing axes (rows of ``H``).
    gdop : float
        ``sqrt(trace((H^T H)^{-1}))``: the noise gain of the least-squares estimate of
        ``x`` (white noise of unit variance).
    dof : int
        ``m - n``, the number of independent parity equations.
    detectable, isolable : ndarray of bool, shape (k,)
        A single fault is visible in parity space / distinguishable from every other.
    pair_identifiable : ndarray of bool, shape (k, k)
        The pair {i, j} spans a two-dimensional subspace that no other pair spans and that
        contains no other single-fault signature; diagonal False.  This is necessary, not
        sufficient, for isolating the pair: see ``pair_confusable``.
    pair_confusable : ndarray of bool, shape (k, k)
        Some faults on {i, j} (with particular sizes) give a parity vector that a
        disjoint pair {k, l} explains exactly: the spans of the two pairs share a
        direction.  With ``m - n <= 3`` every two 2-D spans share a line, so every pair
        is confusable (on the dodecahedron the equal-size faults of Qin & Niu's Tables
        3-4 lie on these lines); ``None`` when not computed (too many pairs).
    """

    w: np.ndarray
    parity_cos: np.ndarray
    separation_deg: np.ndarray
    axis_cos: np.ndarray
    gdop: float
    dof: int
    detectable: np.ndarray
    isolable: np.ndarray
    pair_identifiable: np.ndarray
    pair_confusable: np.ndarray | None = None

    @property
    def min_separation_deg(self) -> float:
        """Smallest angle between two fault signatures (degrees)."""
        k = self.separation_deg.shape[0]
        if k < 2:
            return float("nan")
        iu = np.triu_indices(k, 1)
        return float(self.separation_deg[iu].min())

    def summary(self) -> str:
        """A short text report."""
        k = self.w.shape[0]
        iu = np.triu_indices(k, 1)
        ax = np.degrees(np.arccos(np.clip(np.abs(self.axis_cos[iu]), 0, 1))) if k > 1 else []
        lines = [
            f"parity dof m-n = {self.dof}, GDOP = {self.gdop:.4g}",
            "w_ii = " + ", ".join(f"{v:.4g}" for v in self.w),
            f"detectable: {int(self.detectable.sum())}/{k}, "
            f"isolable: {int(self.isolable.sum())}/{k}",
        ]
        if k > 1:
            lines.append(
                f"parity separation: min {self.min_separation_deg:.2f} deg; axis angles: "
                f"min {np.min(ax):.2f} deg, max {np.max(ax):.2f} deg"
            )
            lines.append(
                f"pairs with a unique span (free sizes): "
                f"{int(self.pair_identifiable[iu].sum())}/{iu[0].size}"
            )
            if self.pair_confusable is not None:
                nc = int(self.pair_confusable[iu].sum())
                lines.append(
                    f"pairs confusable with a disjoint pair for some fault sizes: "
                    f"{nc}/{iu[0].size}" + (" (not isolable for those sizes)" if nc else "")
                )
        return "\n".join(lines)


@dataclass(frozen=True)
class RateEstimate:
    """A Monte-Carlo proportion ``count / n_runs`` with its sampling error."""

    count: int
    n_runs: int

    @property
    def rate(self) -> float:
        """The estimated probability."""
        return self.count / self.n_runs if self.n_runs else float("nan")

    @property
    def stderr(self) -> float:
        """Binomial standard error ``sqrt(r (1 - r) / n)``."""
        r = self.rate
        return math.sqrt(max(r * (1.0 - r), 0.0) / self.n_runs) if self.n_runs else float("nan")

    def ci(self, level: float = 0.95) -> tuple[float, float]:
        """Wilson score interval at confidence ``level``."""
        level = as_probability(level, "level")
        from scipy import stats

        z = float(stats.norm.isf((1.0 - level) / 2.0))
        n, r = self.n_runs, self.rate
        den = 1.0 + z * z / n
        mid = (r + z * z / (2 * n)) / den
        half = z * math.sqrt(r * (1 - r) / n + z * z / (4 * n * n)) / den
        return max(0.0, mid - half), min(1.0, mid + half)

    def __float__(self) -> float:
        return self.rate


@dataclass(frozen=True)
class IsolationRates:
    """Outcome of :func:`correct_isolation_rate`.

    Attributes
    ----------
    correct : RateEstimate
        Isolated set equals the true set of faulty sensors.
    detection : RateEstimate
        The detection test fired.
    partial : RateEstimate
        At least one sensor isolated and every isolated sensor is truly faulty (correct
        but possibly incomplete).
    """

    correct: RateEstimate
    detection: RateEstimate
    partial: RateEstimate

    @property
    def rate(self) -> float:
        """Correct-isolation rate."""
        return self.correct.rate


@dataclass(frozen=True)
class RateCurve:
    """Rates of one or more decision rules against the fault size.

    Attributes
    ----------
    sizes : ndarray
        Fault sizes (multiples of ``direction``).
    direction : ndarray
        Fault vector of unit size (entries per fault hypothesis).
    correct, detection : dict[str, ndarray]
        Correct-isolation and detection rates per method label.
    n_runs : int
    sigma : float
    pfa : float
    """

    sizes: np.ndarray
    direction: np.ndarray
    correct: dict[str, np.ndarray]
    detection: dict[str, np.ndarray]
    n_runs: int
    sigma: float
    pfa: float

    def plot(self, ax: Any = None) -> Any:
        """Plot the curves; see :func:`geomfdi.plotting.parity.plot_rates`."""
        from geomfdi.plotting.parity import plot_rates

        return plot_rates(self, ax=ax)


@dataclass(frozen=True)
class QinNiuResult:
    """Correct-isolation rates of the Qin & Niu (1999) experiment (see :func:`qin_niu_experiment`).

    Attributes
    ----------
    cases : list of dict
        One entry per fault case: ``kind`` (case family), ``faults`` (sensor -> size,
        0-based), ``rates`` (method label -> :class:`IsolationRates`) and
        ``alternatives`` (other sets of one or two sensors whose faults produce exactly
        the same noise-free parity vector: no parity test can tell them apart).
    methods : tuple of str
        Method labels in column order.
    sigma, pfa, n_runs
        Experiment settings.
    kinds : tuple of str
        Case families in table order.
    """

    cases: list[dict[str, Any]]
    methods: tuple[str, ...]
    sigma: float
    pfa: float
    n_runs: int
    kinds: tuple[str, ...] = field(default=())

    def summary(self) -> dict[str, dict[str, dict[str, float]]]:
        """Per family and method: ``mean``/``min`` exact-set rate, ``partial`` mean rate."""
        out: dict[str, dict[str, dict[str, float]]] = {}
        for kind in self.kinds:
            rows = [c for c in self.cases if c["kind"] == kind]
            out[kind] = {}
            for meth in self.methods:
                r = np.array([c["rates"][meth].correct.rate for c in rows])
                p = np.array([c["rates"][meth].partial.rate for c in rows])
                out[kind][meth] = {
                    "mean": float(r.mean()),
                    "min": float(r.min()),
                    "partial": float(p.mean()),
                }
        return out

    def n_ambiguous(self, kind: str) -> tuple[int, int]:
        """(cases with an exactly equivalent alternative, cases) in family ``kind``."""
        rows = [c for c in self.cases if c["kind"] == kind]
        return sum(bool(c["alternatives"]) for c in rows), len(rows)

    def table(self, detail: bool = False) -> str:
        """Text table: exact-set correct-isolation rate, mean over the family (min), and
        the partial rate (isolated sensors all faulty, possibly incomplete)."""
        w = 26
        head = f"{'case (sizes in deg/h)':44s}{'ambig.':>8s}" + "".join(
            f"{m[: w - 2]:>{w}s}" for m in self.methods
        )
        lines = [
            f"Qin & Niu (1999) experiment: dodecahedron, sigma = {self.sigma:g} deg/h, "
            f"pfa = {self.pfa:g}, {self.n_runs} runs per case",
            "cells: correct-isolation rate (exact set), mean over the family's cases "
            "(min) / partial",
            "ambig.: cases whose noise-free parity is explained exactly by another set",
            head,
            "-" * len(head),
        ]
        summ = self.summary()
        for kind in self.kinds:
            na, nc = self.n_ambiguous(kind)
            cells = "".join(
                f"{summ[kind][m]['mean']:>11.3f} ({summ[kind][m]['min']:.3f})"
                f" / {summ[kind][m]['partial']:.3f}"
                for m in self.methods
            )
            lines.append(f"{kind:44s}{f'{na}/{nc}':>8s}{cells}")
        if detail:
            lines.append("")
            lines.append("per case (sensors 1-based: size); exact-set rate per method")
            for c in self.cases:
                label = ", ".join(f"{i + 1}: {v:+g}" for i, v in c["faults"].items())
                alt = ";".join(
                    "(" + ",".join(str(i + 1) for i in sorted(a)) + ")" for a in c["alternatives"]
                )
                cells = "".join(f"{c['rates'][m].correct.rate:>{w}.4f}" for m in self.methods)
                lines.append(f"{c['kind'][:24]:24s} {label:20s}{alt:>8s}{cells}")
        return "\n".join(lines)

    def plot(self, ax: Any = None) -> Any:
        """Grouped bar chart of the mean correct-isolation rate per family and method.

        See :func:`geomfdi.plotting.parity.plot_qin_niu`.
        """
        from geomfdi.plotting.parity import plot_qin_niu

        return plot_qin_niu(self, ax=ax)


__getattr__ = _renamed(__name__)  # the old names of the Qin & Niu experiment, deprecated
