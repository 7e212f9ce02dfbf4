"""Parity-space fault detection and isolation for redundant sensors (seeds 000 and 004).

Measurement model (math.md §6)::

    Z = H x + D f + F eps,      eps ~ N(0, sigma^2 I),

with ``H`` (m x n) of full column rank and m > n; by default ``D = F = I`` (additive
sensor faults, equal-precision independent sensors).  A parity matrix ``V``
((m - n) x m, ``V H = 0``, ``V V^T = I``) removes the unknown ``x``: ``p = V Z``.

The module provides

* :class:`ParityFDI`: the generalised likelihood test (GLT: detection ``FD``, isolation
  ``FI(i)``), the optimal parity-vector test (OPT, in the general form of seed 000
  eq. 6-9 and with ``D = F = I``, Theorem 3), the corrected OPT detection function
  (eq. 23, Theorem 4), the two-fault statistics ``D+/-_ij`` and the search procedure of
  seed 004, the two-fault and k-fault generalised likelihood ratio (GLR), the reduced
  configuration after isolating a sensor, and isolation-capability figures;
* thresholds (:func:`chi2_threshold`, :func:`normal_threshold`) and the Theorem 1 bound
  (:func:`opt_false_alarm_bound`);
* configurations (:func:`dodecahedron`, :func:`cone`, :func:`tetrahedron`);
* Monte-Carlo helpers (:func:`simulate`, :func:`false_alarm_rate`,
  :func:`correct_isolation_rate`, :func:`rates_vs_fault_size`,
  :func:`seed004_experiment`) and a plot (:func:`plot_rates`).

Everything is vectorised over samples: ``Z`` has shape (N, m), one row per sample.

References
----------
.. [000] Zhang Lingxia, Chen Ming, Liu Cuiping, "Is OPT better than GLT in fault
   diagnosis of redundant sensor system?", Journal of Northwestern Polytechnical
   University 23(2), 2005 (seed 000).
.. [004] Qin Yongyuan, Niu Huifang, "Soft fault detection and isolation to ensure the
   entire attitude measuring of a strapdown inertial navigation system", Journal of
   Astronautics, 1999 (seed 004).
.. [PS] J. E. Potter, M. C. Suman, "Thresholdless redundancy management with arrays of
   skewed instruments", AGARDograph 224, 1977.
.. [JZ] H. Jin, H. Y. Zhang, "Optimal parity vector sensitive to designated sensor
   fault", IEEE Trans. Aerospace and Electronic Systems 35(4), 1999.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import linalg as sla
from scipy import optimize, stats

from geomfdi._validation import (
    as_choice,
    as_int,
    as_int_array,
    as_matrix,
    as_positive,
    as_probability,
    as_real_array,
    as_sequence_of,
    as_vector,
)
from geomfdi.errors import DesignError, GeomFDIError, NonFiniteError, RankDeficientError, ShapeError
from geomfdi.parity.configs import MAGIC_HALF_ANGLE, axis_cosines, cone, dodecahedron, tetrahedron
from geomfdi.tolerance import get_rtol, rank_decision

__all__ = [
    "ParityFDI",
    "ParityDiagnosis",
    "ConfigurationCapability",
    "RateEstimate",
    "IsolationRates",
    "RateCurve",
    "Seed004Result",
    "METHODS",
    "chi2_threshold",
    "normal_threshold",
    "opt_false_alarm_bound",
    "dodecahedron",
    "cone",
    "tetrahedron",
    "MAGIC_HALF_ANGLE",
    "simulate",
    "false_alarm_rate",
    "correct_isolation_rate",
    "rates_vs_fault_size",
    "seed004_experiment",
    "plot_rates",
]

METHODS = ("glt", "opt", "opt-uncorrected", "search", "glr")
"""Decision rules accepted by :meth:`ParityFDI.diagnose`."""

# Rows per block in diagnose: the block product (statistics x m) @ (m x rows) is kept at
# <= 2**19 multiply-adds, small enough for the cache and below OpenBLAS's threshold for
# threading a GEMM (threading such thin products only adds synchronisation, and stalls
# badly on a loaded machine).
_CHUNK_FLOPS = 1 << 19
# Leading block of W used by the Potter-Suman construction must have its smallest singular
# value above this, otherwise the columns are pivoted (conditioning guard, not a rank
# decision: a nearly dependent leading block would make the QR span inaccurate).
_POTTER_MIN_SV = 1e-6
_MAX_LABEL_BITS = 20  # argmax-by-bit-packing is used for up to 2**20 fault hypotheses


# --------------------------------------------------------------------------------------
# thresholds
# --------------------------------------------------------------------------------------
def chi2_threshold(pfa: float, dof: int) -> float:
    """Detection threshold ``T`` with ``P(chi2(dof) >= T) = pfa``.

    Parameters
    ----------
    pfa : float
        False-alarm rate, in (0, 1).
    dof : int
        Degrees of freedom (``m - n`` for the GLT detection function ``FD``).

    Returns
    -------
    float
        The ``1 - pfa`` quantile of ``chi2(dof)``.

    References
    ----------
    Seed 000, eq. 2-3: ``FD_GLT ~ chi2(m - n)`` without fault.

    Examples
    --------
    >>> round(chi2_threshold(1e-4, 1), 4)
    15.1367
    """
    pfa = as_probability(pfa, "pfa")
    dof = as_int(dof, "dof", minimum=1)
    return float(stats.chi2.isf(pfa, dof))


def _figure_axes(ax: Any, figsize: tuple[float, float]) -> tuple[Any, Any]:
    """``(figure, axes)``: a new pyplot figure when ``ax`` is None, else ``ax``'s own."""
    if ax is not None:
        return ax.figure, ax
    import matplotlib.pyplot as plt

    return plt.subplots(figsize=figsize)


def normal_threshold(pfa: float) -> float:
    """OPT threshold ``u_{1 - pfa/2}`` (two-sided standard normal quantile).

    References
    ----------
    Seed 000, §1.2, decision step (1).

    Examples
    --------
    >>> round(normal_threshold(0.05), 3)
    1.96
    """
    pfa = as_probability(pfa, "pfa")
    return float(stats.norm.isf(pfa / 2.0))


def opt_false_alarm_bound(pfa: float, s: int) -> float:
    """Theorem 1 lower bound ``1 - (1 - pfa)^s`` on the uncorrected OPT false-alarm rate.

    Parameters
    ----------
    pfa : float
        Nominal false-alarm rate ``alpha`` used for ``u_{1 - alpha/2}``.
    s : int
        Number of independent parity residuals, ``m - n``.

    Notes
    -----
    Seed 000's proof takes ``s`` of the standardised OPT residuals ``d_i`` to be
    mutually independent, which holds only when ``s`` of the optimal parity vectors are
    orthogonal (e.g. not for the dodecahedron, where every pair has ``|cos| = 1/sqrt 5``).
    The inequality is nevertheless observed on every configuration the test suite draws
    (it becomes an equality when ``s`` residuals are orthogonal and the others duplicate
    them); when ``s`` residuals are correlated, Sidak's inequality only gives the reverse
    bound for that subset, so the statement is checked numerically, not proven here.

    Examples
    --------
    >>> round(opt_false_alarm_bound(0.05, 3), 6)
    0.142625
    """
    pfa = as_probability(pfa, "pfa")
    s = as_int(s, "s", minimum=1)
    return 1.0 - (1.0 - pfa) ** s


# --------------------------------------------------------------------------------------
# result objects
# --------------------------------------------------------------------------------------
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
    ) -> None:
        self.detected = detected
        self.faults = faults
        self.statistic = statistic
        self.threshold = float(threshold)
        self.method = method
        self.pfa = float(pfa)
        self._unresolved = unresolved

    @property
    def isolated(self) -> np.ndarray:
        """First isolated sensor per sample, ``-1`` when none, shape (N,)."""
        return self.faults[:, 0]

    @property
    def max_faults(self) -> int:
        """Number of columns of :attr:`faults`."""
        return int(self.faults.shape[1])

    @property
    def n_faults(self) -> np.ndarray:
        """Number of isolated sensors per sample, shape (N,)."""
        return np.count_nonzero(self.faults >= 0, axis=1)

    @property
    def unresolved(self) -> np.ndarray:
        """Detected samples whose alarm the diagnosis could not explain, shape (N,).

        True when a detection (at any stage) could not be followed by an unambiguous
        isolation, or when the residual was still inconsistent after the last test.
        """
        if self._unresolved is None:
            self._unresolved = self.detected & (self.faults[:, 0] < 0)
        return self._unresolved

    def __len__(self) -> int:
        return int(self.detected.shape[0])

    def __repr__(self) -> str:
        n = len(self)
        return (
            f"ParityDiagnosis(method={self.method!r}, N={n}, detected={int(self.detected.sum())}, "
            f"isolated={int((self.faults[:, 0] >= 0).sum())}, pfa={self.pfa:g})"
        )


@dataclass(frozen=True)
class ConfigurationCapability:
    """Isolation-capability figures of a sensor configuration.

    Attributes
    ----------
    w : ndarray, shape (k,)
        ``w_ii = ||V_i||^2`` (``diag W``; in general ``diag G^T G`` of the whitened fault
        signatures).  ``w_ii`` is the fraction of a fault on sensor ``i`` that reaches
        the parity space; ``0`` means undetectable (seed 000, Lemma 1: ``0 < w_ii < 1``
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
        The pair {i, j} spans a two-dimensional subspace that no other pair spans (the
        two-fault GLR can single it out); diagonal False.
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
                f"identifiable pairs: {int(self.pair_identifiable[iu].sum())}/{iu[0].size}"
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
        """Plot the curves; see :func:`plot_rates`."""
        return plot_rates(self, ax=ax)


@dataclass(frozen=True)
class Seed004Result:
    """Correct-isolation rates of the seed 004 experiment (see :func:`seed004_experiment`).

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
            f"seed 004 experiment: dodecahedron, sigma = {self.sigma:g} deg/h, "
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

        Returns
        -------
        matplotlib.figure.Figure
        """
        fig, ax = _figure_axes(ax, (8.5, 4.5))
        summ = self.summary()
        x = np.arange(len(self.kinds))
        width = 0.8 / max(len(self.methods), 1)
        for j, meth in enumerate(self.methods):
            means = [summ[k][meth]["mean"] for k in self.kinds]
            mins = [summ[k][meth]["min"] for k in self.kinds]
            pos = x + (j - (len(self.methods) - 1) / 2) * width
            ax.bar(pos, means, width, label=meth)
            ax.plot(pos, mins, "k_", markersize=10)
        ax.set_xticks(x)
        ax.set_xticklabels([k.replace(", ", "\n", 1) for k in self.kinds], fontsize=8)
        ax.set_ylim(0, 1.05)
        ax.set_ylabel("correct-isolation rate (bar: mean, tick: min)")
        ax.set_title(f"Seed 004 experiment, dodecahedron, sigma = {self.sigma:g} deg/h")
        ax.legend(fontsize=8, loc="upper right")
        fig.tight_layout()
        return fig


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------
def _potter_suman(W: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormalise the first ``s`` columns (= rows) of the projector ``W``.

    Returns ``V`` ((s, m), rows orthonormal, ``V^T V = W``) and the sensor order used.
    ``V[:, order[:s]]`` is upper triangular with a positive diagonal: the explicit
    Potter-Suman form.  If the first ``s`` columns are (nearly) dependent, QR with
    column pivoting chooses the columns instead.
    """
    m = W.shape[0]
    lead = W[:, :s]
    if np.linalg.svd(lead, compute_uv=False)[-1] > _POTTER_MIN_SV:
        Q, R = np.linalg.qr(lead)
        order = np.arange(m)
    else:
        Qf, Rf, order = sla.qr(W, pivoting=True)
        Q, R = Qf[:, :s], Rf[:s, :s]
    signs = np.sign(np.diag(R))
    signs[signs == 0] = 1.0
    return (Q * signs).T.copy(), np.asarray(order)


def _as_rng(rng: Any) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or isinstance(rng, int | np.integer | np.random.SeedSequence):
        return np.random.default_rng(rng)
    raise GeomFDIError(
        f"rng: expected a numpy Generator, an integer seed or None, got {type(rng).__name__}",
        argument="rng",
    )


def _raise_nonfinite_block(block: np.ndarray, offset: int, name: str) -> None:
    finite = np.isfinite(block)
    if finite.all():
        raise GeomFDIError(
            f"{name}: entries too large, the statistics overflow (rows {offset}.."
            f"{offset + block.shape[0] - 1})",
            argument=name,
        )
    r, c = np.argwhere(~finite)[0]
    raise NonFiniteError(
        f"{name}: entries must be finite, found {block[r, c]} at index ({offset + r}, {c})",
        argument=name,
    )


def _guarded(fn: Any) -> Any:
    """Run ``fn`` with overflow warnings off and reject non-finite float outputs.

    The inputs were checked finite; a non-finite statistic can then only come from an
    overflow (readings beyond ~1e150), which is reported instead of returned.
    """

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with np.errstate(over="ignore", invalid="ignore"):
            out = fn(*args, **kwargs)
        items = out if isinstance(out, tuple) else (out,)
        for item in items:
            if isinstance(item, np.ndarray) and item.dtype.kind == "f":
                if not np.isfinite(item).all():
                    raise GeomFDIError(
                        "Z: entries too large, the statistics overflow", argument="Z"
                    )
        return out

    return wrapper


# --------------------------------------------------------------------------------------
# the parity-space FDI object
# --------------------------------------------------------------------------------------
class ParityFDI:
    """Parity-space FDI for ``Z = H x + D f + F eps``, ``eps ~ N(0, sigma^2 I)``.

    Parameters
    ----------
    H : array_like, shape (m, n)
        Measurement (installation) matrix, full column rank, ``m > n``.
    sigma : float
        Noise standard deviation (> 0).
    D : array_like, shape (m, k), optional
        Fault input matrix; column ``i`` is the signature of fault ``i``.  Default
        ``I_m``: fault ``i`` is an additive fault on sensor ``i``.
    F : array_like, shape (m, q), optional
        Noise input matrix (default ``I_m``).  ``V F F^T V^T`` must be nonsingular.
    basis : {"potter", "svd"} or array_like, shape (m - n, m)
        Parity matrix: ``"potter"`` (default) orthonormalises the leading rows of ``W``
        (Potter-Suman); ``"svd"`` takes the left singular vectors of ``H`` beyond its
        rank; an array is used as given after checking ``V H = 0`` and ``V V^T = I``.
        All choices give identical statistics.
    chunk_size : int, optional
        Rows processed at a time by :meth:`diagnose` (cache blocking); default: the power
        of two keeping a block product near ``2**19`` multiply-adds (8192 for m = 6).
    sensors : array_like of int, optional
        Labels of the sensors (default ``0..m-1``); :meth:`reduced` passes the original
        indices.

    Attributes
    ----------
    H, sigma, D, F : ndarray / float
        The model (``D``, ``F`` are ``None`` for the identity).
    V : ndarray, shape (m - n, m)
        Parity matrix, ``V H = 0``, ``V V^T = I``, ``V^T V = W``.
    W : ndarray, shape (m, m)
        ``I - H (H^T H)^{-1} H^T`` (computed from an orthonormal basis of range H).
    m, n, s, k : int
        Sensors, unknowns, parity dimension ``m - n``, fault hypotheses.
    sensors : ndarray of int
        Labels of the sensors (their indices in the configuration this one was reduced
        from; ``0..m-1`` for a new configuration).
    potter_order : ndarray of int or None
        Sensor order of the Potter-Suman construction (identity unless pivoted).

    Notes
    -----
    *GLT* (seed 000 eq. 2-5; Daly et al.).  With noise whitened in parity space,
    ``q = L^{-1} p``, ``L L^T = V F F^T V^T`` (``q = p`` when ``F = I``), and fault
    signatures ``G = L^{-1} V D``::

        FD    = ||q||^2 / sigma^2                         ~ chi2(m - n) without fault
        FI(i) = (q^T G_i)^2 / (sigma^2 G_i^T G_i)         = (Z^T W_i)^2 / (sigma^2 w_ii)

    ``FI(i)`` is the likelihood-ratio gain of the hypothesis "fault i" (its maximum over
    the fault size); the isolated sensor is ``argmax_i FI(i)``.  A sensor with
    ``G_i = 0`` (not redundant) has ``FI(i) = 0``: no fault on it can be seen.

    *OPT* (seed 000 eq. 6-9, Jin-Zhang).  See :meth:`opt_vectors`; with ``D = F = I``
    ``v_i = W_i / ||W_i||`` (Theorem 3) and ``d_i^2 = FI(i)`` (Theorem 2).

    *Corrected OPT* (eq. 23).  ``FD_OPT = sum_k (v_0k^T Z / sigma)^2`` over an
    orthonormal (in the noise metric ``F F^T``) basis ``v_0k`` of the span of the
    optimal parity vectors; ``FD_OPT = FD_GLT`` (Theorem 4), also when ``F != I``.

    *Two faults* (seed 004 eq. 8-16, formulas reconstructed because the OCR lost
    them).  For the hypotheses ``f (e_i + e_j)`` and ``f (e_i - e_j)`` the maximum
    likelihood estimate of ``f`` gives ``D+/-_ij = ((V_i +/- V_j)^T p)^2 /
    (sigma^2 ||V_i +/- V_j||^2)``; the two-fault GLR for the pair ``S`` with free sizes
    is ``p^T V_S (V_S^T V_S)^{-1} V_S^T p / sigma^2``; for ``||V_i|| = ||V_j||`` it
    equals ``D+_ij + D-_ij``.

    *Reduced configuration.*  Removing the sensors ``S`` from ``H`` gives the
    detection function ``FD_reduced = FD - GLR_S`` (profiling the fault sizes out of
    the likelihood is the same as discarding the readings).  This identity drives the
    vectorised seed-004 search and the k-fault GLR tests, and is checked against
    :meth:`reduced` in the tests.

    References
    ----------
    Seed 000 (Zhang-Chen-Liu 2005), eq. 1-26; seed 004 (Qin-Niu 1999), eq. 1-16;
    Potter-Suman 1977; Jin-Zhang 1999.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=0.01)
    >>> Z = np.zeros((2, 6)); Z[1, 4] = 0.2          # sample 1: fault on sensor 4
    >>> res = pf.diagnose(Z, pfa=1e-3)
    >>> res.detected.tolist(), res.isolated.tolist()
    ([False, True], [-1, 4])
    """

    def __init__(
        self,
        H: Any,
        sigma: float = 1.0,
        *,
        D: Any = None,
        F: Any = None,
        basis: Any = "potter",
        chunk_size: int | None = None,
        sensors: Any = None,
    ) -> None:
        H = as_matrix(H, "H", vector_as="column")
        m, n = H.shape
        if m <= n:
            raise ShapeError(
                f"H: a parity space needs more sensors than unknowns (m > n), got shape {H.shape}",
                argument="H",
            )
        sv = np.linalg.svd(H, compute_uv=False)
        dec = rank_decision(sv, float(sv[0]), m, what="H: full column rank")
        if dec.rank < n:
            raise RankDeficientError(
                f"H: must have full column rank {n}, numerical rank is {dec.rank} "
                f"(singular values {np.array2string(sv, precision=3)})",
                argument="H",
            )
        self.H = H
        self.m, self.n = m, n
        self.s = m - n
        self.sigma = as_positive(sigma, "sigma")
        if chunk_size is None:
            per_row = (m + self.s) * m  # (k + m - n) statistics per row, k = m by default
            chunk_size = 1 << max(10, min(16, (_CHUNK_FLOPS // per_row).bit_length() - 1))
        self.chunk_size = as_int(chunk_size, "chunk_size", minimum=1)
        if sensors is None:
            self.sensors = np.arange(m)
        else:
            self.sensors = as_int_array(sensors, "sensors").reshape(-1)
            if np.unique(self.sensors).size != self.sensors.size:
                raise GeomFDIError("sensors: labels must be distinct", argument="sensors")
            if self.sensors.shape != (m,):
                raise ShapeError(f"sensors: expected {m} labels", argument="sensors")

        Qh = np.linalg.qr(H)[0]
        W = np.eye(m) - Qh @ Qh.T
        self.W = (W + W.T) / 2.0

        self.potter_order: np.ndarray | None = None
        if isinstance(basis, str):
            if basis == "potter":
                V, self.potter_order = _potter_suman(self.W, self.s)
            elif basis == "svd":
                U = np.linalg.svd(H, full_matrices=True)[0]
                V = U[:, n:].T.copy()
            else:
                raise GeomFDIError(
                    f"basis: expected 'potter', 'svd' or an (m-n) x m matrix, got {basis!r}",
                    argument="basis",
                )
            self.basis = basis
        else:
            V = as_matrix(basis, "basis", rows=self.s, cols=m)
            tol = 1e-8
            err_h = np.linalg.norm(V @ H, 2) / max(np.linalg.norm(H, 2), 1.0)
            err_o = np.linalg.norm(V @ V.T - np.eye(self.s), 2)
            if err_h > tol or err_o > tol:
                raise DesignError(
                    f"basis: must satisfy V H = 0 and V V^T = I (errors {err_h:.2g}, {err_o:.2g})",
                    argument="basis",
                )
            self.basis = "given"
        self.V = V

        # noise model: whitening of the parity vector
        if F is None:
            self.F = None
            self._Sigma = None
            T = V.copy()
        else:
            Fm = as_matrix(F, "F", rows=m, vector_as="column")
            self.F = Fm
            self._Sigma = Fm @ Fm.T
            Sp = V @ self._Sigma @ V.T
            Sp = (Sp + Sp.T) / 2.0
            ev = np.clip(np.linalg.eigvalsh(Sp)[::-1], 0.0, None)
            fnorm = float(np.linalg.norm(Fm, 2))
            d2 = rank_decision(np.sqrt(ev), fnorm, m, what="F: noise in parity space")
            if d2.rank < self.s:
                raise DesignError(
                    "F: the noise must reach every parity direction (V F F^T V^T is "
                    f"singular, rank {d2.rank} < {self.s})",
                    argument="F",
                )
            L = np.linalg.cholesky(Sp)
            T = sla.solve_triangular(L, V, lower=True)
        self._T = T  # whitened parity map, q = T Z

        # fault model
        if D is None:
            self.D = None
            Dm = np.eye(m)
        else:
            Dm = as_matrix(D, "D", rows=m, vector_as="column")
            self.D = Dm
        self._Dm = Dm
        self.k = Dm.shape[1]
        G = T @ Dm
        self._G = G
        self._Omega = G.T @ G
        self._scaleG = max(float(np.linalg.norm(T, 2) * np.linalg.norm(Dm, 2)), 1e-300)
        gnorm = np.linalg.norm(G, axis=0)
        tolG = get_rtol(m) * self._scaleG
        self.detectable = gnorm > tolG
        w = np.where(self.detectable, np.diag(self._Omega), 0.0)
        self._w = w
        self._Bn = np.zeros((m, self.k))  # Z @ _Bn = sqrt(FI) with sign
        self._Bn[:, self.detectable] = (T.T @ G[:, self.detectable]) / (
            self.sigma * np.sqrt(w[self.detectable])
        )
        self._B = (T.T @ G) / self.sigma  # Z @ _B = a, a_i = q^T G_i / sigma
        self._subset_cache: dict[int, dict[str, np.ndarray]] = {}
        self._reduced_cache: dict[tuple[int, ...], ParityFDI] = {}
        self._opt: dict[str, np.ndarray] | None = None
        self.isolable = self.detectable & ~self._subset_info(1)["ambiguous"]
        self._lut = np.where(self.isolable, np.arange(self.k), -1).astype(np.intp)

    # ---------------------------------------------------------------- basic properties
    @property
    def w(self) -> np.ndarray:
        """``w_ii`` (diag ``W`` for ``D = F = I``; in general ``||G_i||^2``), shape (k,)."""
        return self._w.copy()

    @property
    def fault_signatures(self) -> np.ndarray:
        """Whitened parity-space fault signatures ``G = L^{-1} V D``, shape (m - n, k)."""
        return self._G.copy()

    def __repr__(self) -> str:
        extra = "" if self.D is None and self.F is None else ", general D/F"
        return (
            f"ParityFDI(m={self.m}, n={self.n}, sigma={self.sigma:g}, basis={self.basis!r}{extra})"
        )

    # ---------------------------------------------------------------- input handling
    def _samples(self, Z: Any, *, check: bool = True) -> np.ndarray:
        """``Z`` as a float64 (N, m) array; a 1-D vector is one sample."""
        if isinstance(Z, np.ndarray) and Z.dtype == np.float64:
            arr = Z
        else:
            arr = as_real_array(Z, "Z")
            check = False  # as_real_array checked finiteness
        if arr.ndim == 1:
            arr = arr.reshape(1, -1)
        if arr.ndim != 2 or arr.shape[1] != self.m:
            raise ShapeError(
                f"Z: expected {self.m} columns (one per sensor) as an (N, {self.m}) array or "
                f"a length-{self.m} vector, got shape {np.shape(Z)}",
                argument="Z",
            )
        if check:
            step = 1 << 16
            for start in range(0, arr.shape[0], step):
                block = arr[start : start + step]
                if not np.isfinite(block).all():
                    _raise_nonfinite_block(block, start, "Z")
        return arr

    def _a(self, Z: np.ndarray) -> np.ndarray:
        """``a_i = q^T G_i / sigma`` (``= Z^T W_i / sigma`` for ``D = F = I``), (N, k)."""
        return Z @ self._B

    def _fd(self, Z: np.ndarray) -> np.ndarray:
        P = Z @ self._T.T
        return np.einsum("ij,ij->i", P, P) / self.sigma**2

    @staticmethod
    def _check_fd(fd: np.ndarray) -> None:
        # every GLR statistic is bounded by FD: a finite FD means finite statistics
        if not np.isfinite(fd).all():
            raise GeomFDIError("Z: entries too large, the statistics overflow", argument="Z")

    def _fi_from_a(self, a: np.ndarray) -> np.ndarray:
        out = np.zeros_like(a)
        det = self.detectable
        out[:, det] = a[:, det] ** 2 / self._w[det]
        return out

    # ---------------------------------------------------------------- GLT
    @_guarded
    def parity(self, Z: Any) -> np.ndarray:
        """Parity vectors ``p = V Z``, shape (N, m - n) (seed 000, §1.1)."""
        Z = self._samples(Z)
        return Z @ self.V.T

    @_guarded
    def detection_statistic(self, Z: Any) -> np.ndarray:
        """GLT detection function ``FD = p^T p / sigma^2`` (whitened if ``F != I``).

        Parameters
        ----------
        Z : array_like, shape (N, m) or (m,)
            Measurements, one sample per row.

        Returns
        -------
        ndarray, shape (N,)
            ``FD ~ chi2(m - n)`` without fault.

        References
        ----------
        Seed 000, eq. 2; seed 004, eq. 5.
        """
        return self._fd(self._samples(Z))

    @_guarded
    def isolation_statistics(self, Z: Any) -> np.ndarray:
        """GLT isolation functions ``FI(i) = (p^T V_i)^2 / (sigma^2 V_i^T V_i)``, (N, k).

        References
        ----------
        Seed 000, eq. 4 (scaled by ``1/sigma^2`` as in its eq. 22); seed 004, eq. 7.
        """
        Z = self._samples(Z)
        return self._fi_from_a(self._a(Z))

    def detection_threshold(self, pfa: float, dof: int | None = None) -> float:
        """``chi2`` threshold for the detection function (``dof`` default ``m - n``)."""
        return chi2_threshold(pfa, self.s if dof is None else dof)

    # ---------------------------------------------------------------- OPT
    def _opt_data(self) -> dict[str, np.ndarray]:
        if self._opt is not None:
            return self._opt
        V, Dm = self.V, self._Dm
        Sigma = np.eye(self.m) if self._Sigma is None else self._Sigma
        U = V @ Dm  # u_i = V D e_i
        M0 = V @ (Sigma + Dm @ Dm.T) @ V.T
        vecs = np.zeros((self.m, self.k))
        perf = np.zeros(self.k)
        for i in np.flatnonzero(self.detectable):
            ui = U[:, i]
            Mi = M0 - np.outer(ui, ui)  # V (F F^T + sum_{j != i} D e_j e_j^T D^T) V^T
            ci = sla.solve((Mi + Mi.T) / 2.0, ui, assume_a="pos")
            perf[i] = float(ui @ ci)
            v = V.T @ ci
            v /= np.linalg.norm(v)
            if v @ Dm[:, i] < 0:
                v = -v
            vecs[:, i] = v
        noise = np.sqrt(np.einsum("ji,jk,ki->i", vecs, Sigma, vecs))
        dmat = np.zeros_like(vecs)
        ok = self.detectable
        dmat[:, ok] = vecs[:, ok] / (self.sigma * noise[ok])
        # corrected OPT: noise-orthonormal basis of span{v_i} (Gram-Schmidt with pivoting)
        if ok.any():
            Qv, Rv, _ = sla.qr(vecs[:, ok], pivoting=True, mode="economic")
            dr = rank_decision(
                np.abs(np.diag(Rv)), 1.0, self.m, what="span of the optimal parity vectors"
            )
            Bv = Qv[:, : dr.rank]
            C = Bv.T @ Sigma @ Bv
            Lc = np.linalg.cholesky((C + C.T) / 2.0)
            Ubasis = sla.solve_triangular(Lc, Bv.T, lower=True).T
        else:
            Ubasis = np.zeros((self.m, 0))
        self._opt = {"vectors": vecs, "perf": perf, "dmat": dmat, "U": Ubasis}
        return self._opt

    @property
    def opt_vectors(self) -> np.ndarray:
        """Unit optimal parity vectors ``v_i`` as columns, shape (m, k).

        Notes
        -----
        Seed 000 eq. 7 maximises, over ``v = V^T c`` (so that ``v^T H = 0``),

        ``S_i(c) = (c^T u_i)^2 / (c^T M_i c)``,   ``u_i = V D e_i``,
        ``M_i = V (F F^T + sum_{j != i} D e_j e_j^T D^T) V^T``.

        This is a generalised Rayleigh quotient whose numerator has rank one: the
        generalised eigenproblem ``u_i u_i^T c = lambda M_i c`` has the single nonzero
        eigenvalue ``lambda = u_i^T M_i^{-1} u_i`` with eigenvector ``c_i = M_i^{-1} u_i``
        (Cauchy-Schwarz in the ``M_i`` inner product), so ``v_i = V^T M_i^{-1} u_i``
        (eq. 8), normalised and signed so that ``v_i^T D e_i > 0``.  ``M_i`` is
        positive definite because ``V F F^T V^T`` is.  By Sherman-Morrison
        ``M_i^{-1} u_i`` is proportional to ``M_0^{-1} u_i`` with
        ``M_0 = V (F F^T + D D^T) V^T``.  With ``D = F = I``: ``M_0 = 2 I`` and
        ``v_i = W_i / sqrt(w_ii)`` (Theorem 3).  An undetectable fault (``u_i = 0``) gets
        the zero vector.
        """
        return self._opt_data()["vectors"].copy()

    @property
    def opt_performance(self) -> np.ndarray:
        """The maximised index ``S_i = u_i^T M_i^{-1} u_i`` of seed 000 eq. 7, shape (k,)."""
        return self._opt_data()["perf"].copy()

    @_guarded
    def opt_statistics(self, Z: Any) -> np.ndarray:
        """Standardised optimal parity residuals ``d_i = v_i^T Z / (sigma ||v_i^T F||)``.

        Returns
        -------
        ndarray, shape (N, k)
            ``d_i ~ N(0, 1)`` without fault; ``d_i^2 = FI(i)`` when ``D = F = I``
            (Theorem 2).

        References
        ----------
        Seed 000, eq. 9 and Theorem 2.
        """
        Z = self._samples(Z)
        return Z @ self._opt_data()["dmat"]

    @_guarded
    def opt_detection_statistic(self, Z: Any) -> np.ndarray:
        """Corrected OPT detection function ``FD_OPT = sum_k (v_0k^T Z / sigma)^2``, (N,).

        Notes
        -----
        The ``v_0k`` are an orthonormal basis (in the noise metric ``F F^T``, so that the
        terms are independent by seed 000's Lemma 3) of the span of the optimal parity
        vectors, obtained by Gram-Schmidt with column pivoting (QR).  Its dimension
        :attr:`opt_dof` is ``m - n`` whenever the vectors span the parity space (always
        for ``D = I``), and then ``FD_OPT = FD_GLT`` (Theorem 4).

        References
        ----------
        Seed 000, eq. 23, 25-26.
        """
        Z = self._samples(Z)
        P = Z @ self._opt_data()["U"]
        return np.einsum("ij,ij->i", P, P) / self.sigma**2

    @property
    def opt_dof(self) -> int:
        """Degrees of freedom of :meth:`opt_detection_statistic`."""
        return int(self._opt_data()["U"].shape[1])

    # ---------------------------------------------------------------- two and k faults
    def _subset_info(self, kk: int) -> dict[str, np.ndarray]:
        """Rank, ambiguity and ``(G_S^T G_S)^+`` for every ``kk``-subset of faults."""
        if kk in self._subset_cache:
            return self._subset_cache[kk]
        G, k, s = self._G, self.k, self.s
        subsets = np.array(list(itertools.combinations(range(k), kk)), dtype=np.intp)
        if subsets.size == 0:
            subsets = subsets.reshape(0, kk)
        C = subsets.shape[0]
        tol_n = self.m
        GS = G[:, subsets].transpose(1, 0, 2)  # (C, s, kk)
        _, S, Vt = np.linalg.svd(GS, full_matrices=False)
        rank = np.array(
            [rank_decision(S[c], self._scaleG, tol_n, warn=False).rank for c in range(C)],
            dtype=np.intp,
        )
        pinv = np.zeros((C, kk, kk))
        for c in range(C):
            r = rank[c]
            if r:
                Vr = Vt[c, :r, :]
                pinv[c] = Vr.T @ (Vr / S[c, :r, None] ** 2)
        valid = rank == kk
        ambiguous = np.zeros(C, dtype=bool)
        # S is ambiguous when a detectable fault j outside S lies in span(G_S): swapping
        # j for a member of S then gives another subset with the same span
        for c in np.flatnonzero(valid):
            others = np.setdiff1d(np.flatnonzero(self.detectable), subsets[c])
            if others.size == 0:
                continue
            stack = np.concatenate(
                [
                    np.broadcast_to(G[:, subsets[c]], (others.size, s, kk)),
                    G[:, others].T[:, :, None],
                ],
                axis=2,
            )
            sv = np.linalg.svd(stack, compute_uv=False)
            ranks = [rank_decision(x, self._scaleG, tol_n, warn=False).rank for x in sv]
            ambiguous[c] = min(ranks) <= kk
        info = {
            "subsets": subsets,
            "rank": rank,
            "valid": valid,
            "ambiguous": ambiguous,
            "pinv": pinv,
        }
        self._subset_cache[kk] = info
        return info

    def _pairs_from_a(self, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        G = self._G
        plus_dir = G[:, :, None] + G[:, None, :]
        minus_dir = G[:, :, None] - G[:, None, :]
        den_p = np.einsum("sij,sij->ij", plus_dir, plus_dir)
        den_m = np.einsum("sij,sij->ij", minus_dir, minus_dir)
        tol2 = (get_rtol(self.m) * self._scaleG) ** 2
        inv_p = np.where(den_p > tol2, 1.0 / np.where(den_p > tol2, den_p, 1.0), 0.0)
        inv_m = np.where(den_m > tol2, 1.0 / np.where(den_m > tol2, den_m, 1.0), 0.0)
        np.fill_diagonal(inv_p, 0.0)
        np.fill_diagonal(inv_m, 0.0)
        plus = (a[:, :, None] + a[:, None, :]) ** 2 * inv_p
        minus = (a[:, :, None] - a[:, None, :]) ** 2 * inv_m
        return plus, minus

    @_guarded
    def pair_statistics(self, Z: Any) -> tuple[np.ndarray, np.ndarray]:
        """Seed 004's two-fault isolation functions ``(D+, D-)``, each (N, k, k).

        ``D+/-_ij = ((V_i +/- V_j)^T p)^2 / (sigma^2 ||V_i +/- V_j||^2)`` is the
        likelihood-ratio gain of the hypothesis "sensors i and j carry faults of equal
        size and equal (+) or opposite (-) sign".

        Returns
        -------
        plus, minus : ndarray, shape (N, k, k)
            Symmetric; the diagonal (``i = j`` is not a pair) and pairs whose direction
            ``V_i +/- V_j`` vanishes are 0.

        Notes
        -----
        The formulas of seed 004 eq. 11-16 were lost in the OCR; they are rebuilt from
        its text: ``p = V eps + f (V_i + V_j)`` (eq. 11), the likelihood is a parabola in
        ``f`` maximised at ``f = (V_i + V_j)^T p / ||V_i + V_j||^2`` (eq. 13), and the
        maximal density is largest when ``D+_ij`` is (eq. 14-15); eq. 16 likewise with
        ``V_i - V_j``.

        References
        ----------
        Seed 004, eq. 8-16; math.md §6.
        """
        Z = self._samples(Z)
        return self._pairs_from_a(self._a(Z))

    def _glr2_from_a(self, a: np.ndarray, fi: np.ndarray) -> np.ndarray:
        info = self._subset_info(2)
        N, k = a.shape
        out = np.zeros((N, k, k))
        idx = np.arange(k)
        out[:, idx, idx] = fi
        for c, (i, j) in enumerate(info["subsets"]):
            if info["valid"][c]:
                P = info["pinv"][c]
                ai, aj = a[:, i], a[:, j]
                val = P[0, 0] * ai * ai + 2.0 * P[0, 1] * ai * aj + P[1, 1] * aj * aj
            else:  # parallel or zero signatures: the span is (at most) one of them
                val = np.maximum(fi[:, i], fi[:, j])
            out[:, i, j] = val
            out[:, j, i] = val
        return out

    @_guarded
    def two_fault_glr(self, Z: Any) -> np.ndarray:
        """Two-fault GLR ``p^T V_S (V_S^T V_S)^{-1} V_S^T p / sigma^2`` for every pair.

        Returns
        -------
        ndarray, shape (N, k, k)
            Symmetric; entry ``(i, j)`` is the likelihood-ratio gain of "faults of any
            sizes on i and j"; the diagonal holds the single-fault ``FI(i)``.  For
            ``||V_i|| = ||V_j||`` the entry equals ``D+_ij + D-_ij``.

        Notes
        -----
        With ``a_i = p^T V_i / sigma`` and ``w_ij = V_i^T V_j``, the entry is
        ``(w_jj a_i^2 - 2 w_ij a_i a_j + w_ii a_j^2) / (w_ii w_jj - w_ij^2)``; a pair
        with parallel signatures spans one direction and gets ``max(FI(i), FI(j))``.

        References
        ----------
        Generalised likelihood ratio for the two-fault hypothesis ``H_ij`` of seed 004
        eq. 8 with both sizes free; math.md §6.
        """
        Z = self._samples(Z)
        a = self._a(Z)
        return self._glr2_from_a(a, self._fi_from_a(a))

    @_guarded
    def glr_statistics(self, Z: Any, n_faults: int) -> tuple[np.ndarray, np.ndarray]:
        """k-fault GLR ``p^T V_S (V_S^T V_S)^+ V_S^T p / sigma^2`` for every k-subset ``S``.

        Parameters
        ----------
        Z : array_like, shape (N, m) or (m,)
        n_faults : int
            Subset size ``k >= 1`` (keep it small: there are ``C(m, k)`` subsets).

        Returns
        -------
        stats : ndarray, shape (N, C)
            GLR of each subset (pseudo-inverse for subsets whose signatures are
            dependent).
        subsets : ndarray of int, shape (C, k)
            The subsets, in lexicographic order.
        """
        kk = as_int(n_faults, "n_faults", minimum=1)
        if kk > self.k:
            raise GeomFDIError(
                f"n_faults: at most {self.k} fault hypotheses exist, got {kk}",
                argument="n_faults",
            )
        Z = self._samples(Z)
        a = self._a(Z)
        info = self._subset_info(kk)
        out = np.empty((a.shape[0], info["subsets"].shape[0]))
        for c, S in enumerate(info["subsets"]):
            aS = a[:, S]
            out[:, c] = np.einsum("ni,ij,nj->n", aS, info["pinv"][c], aS)
        return out, info["subsets"].copy()

    # ---------------------------------------------------------------- configurations
    def reduced(self, remove: int | Sequence[int]) -> ParityFDI:
        """The configuration without the sensors ``remove`` (re-detection after isolation).

        Parameters
        ----------
        remove : int or sequence of int
            Sensor indices of *this* configuration (0-based).

        Returns
        -------
        ParityFDI
            ``H`` (and ``F``) without those rows, same ``sigma`` and basis kind;
            :attr:`sensors` keeps the original labels.

        Raises
        ------
        DesignError
            ``D`` is not the identity, or no redundancy would remain (``m - r <= n``).
        RankDeficientError
            The remaining rows do not determine ``x``.
        """
        if self.D is not None:
            raise DesignError(
                "remove: a reduced configuration needs D = I (faults are sensor faults)",
                argument="remove",
            )
        if isinstance(remove, int | np.integer):
            rem = [as_int(remove, "remove")]
        else:
            rem = [int(as_int(r, "remove")) for r in as_sequence_of(remove, "remove", object)]
        for r in rem:
            if not 0 <= r < self.m:
                raise GeomFDIError(
                    f"remove: index {r} out of range 0..{self.m - 1}", argument="remove"
                )
        key = tuple(sorted(set(rem)))
        if key in self._reduced_cache:
            return self._reduced_cache[key]
        keep = np.setdiff1d(np.arange(self.m), key)
        if keep.size <= self.n:
            raise DesignError(
                f"remove: removing {len(key)} sensor(s) leaves {keep.size} <= n = {self.n}: "
                "no redundancy left",
                argument="remove",
            )
        basis = self.basis if self.basis in ("potter", "svd") else "potter"
        red = ParityFDI(
            self.H[keep],
            self.sigma,
            F=None if self.F is None else self.F[keep],
            basis=basis,
            chunk_size=None,
            sensors=self.sensors[keep],
        )
        self._reduced_cache[key] = red
        return red

    def capability(self) -> ConfigurationCapability:
        """Isolation-capability figures (``w_ii``, angles, GDOP, identifiable pairs).

        Returns
        -------
        ConfigurationCapability
            See its attributes; ``.summary()`` gives a text report.

        References
        ----------
        Seed 000, Lemmas 1-2 (``0 < w_ii < 1``, ``V_i^T V_j = w_ij``).

        Examples
        --------
        >>> import geomfdi as gf
        >>> cap = gf.ParityFDI(gf.parity.dodecahedron()).capability()
        >>> [round(float(x), 6) for x in cap.w[:2]], cap.isolable.all()
        ([0.5, 0.5], np.True_)
        """
        Om = self._Omega
        w = self._w
        k = self.k
        with np.errstate(invalid="ignore", divide="ignore"):
            den = np.sqrt(np.outer(w, w))
            cos = np.where(den > 0, Om / np.where(den > 0, den, 1.0), 0.0)
        cos = np.clip(cos, -1.0, 1.0)
        sep = np.degrees(np.arccos(np.abs(cos)))
        np.fill_diagonal(sep, 0.0)
        pair_id = np.zeros((k, k), dtype=bool)
        if k >= 2:
            info = self._subset_info(2)
            ok = info["valid"] & ~info["ambiguous"]
            S = info["subsets"]
            pair_id[S[:, 0], S[:, 1]] = ok
            pair_id[S[:, 1], S[:, 0]] = ok
        HtH = self.H.T @ self.H
        gdop = float(np.sqrt(np.trace(np.linalg.inv(HtH))))
        return ConfigurationCapability(
            w=w.copy(),
            parity_cos=cos,
            separation_deg=sep,
            axis_cos=axis_cosines(self.H),
            gdop=gdop,
            dof=self.s,
            detectable=self.detectable.copy(),
            isolable=self.isolable.copy(),
            pair_identifiable=pair_id,
        )

    def min_detectable_fault(self, pfa: float, pd: float = 0.9) -> np.ndarray:
        """Smallest single-fault size detected with probability ``pd`` at rate ``pfa``.

        A fault ``f`` on hypothesis ``i`` makes ``FD`` noncentral ``chi2(m - n, lambda)``
        with ``lambda = f^2 w_ii / sigma^2``; the returned size solves
        ``P(chi2(m - n, lambda) >= T) = pd``.  Undetectable faults get ``inf``.

        Parameters
        ----------
        pfa : float
            False-alarm rate fixing the threshold ``T = chi2_{1-pfa}(m - n)``.
        pd : float
            Required detection probability.

        Returns
        -------
        ndarray, shape (k,)
            Fault sizes, in the units of ``Z``.
        """
        pfa = as_probability(pfa, "pfa")
        pd = as_probability(pd, "pd")
        T = chi2_threshold(pfa, self.s)
        if pd <= pfa:
            lam = 0.0
        else:
            lam = optimize.brentq(lambda x: stats.ncx2.sf(T, self.s, x) - pd, 1e-12, 1e6)
        out = np.full(self.k, np.inf)
        det = self.detectable
        out[det] = self.sigma * np.sqrt(lam / self._w[det])
        return out

    # ---------------------------------------------------------------- decisions
    def _kernel(
        self, Z: np.ndarray, Mdet: np.ndarray, Miso: np.ndarray, mode: str, threshold: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Chunked detection + isolation: statistic, detected, isolated (lut applied)."""
        N = Z.shape[0]
        r, k = Mdet.shape[1], Miso.shape[1]
        MT = np.ascontiguousarray(np.concatenate([Mdet, Miso], axis=1).T)
        stat = np.empty(N)
        det = np.empty(N, dtype=bool)
        iso = np.empty(N, dtype=np.intp)
        bits = max(1, (k - 1).bit_length())
        use_bits = bits <= _MAX_LABEL_BITS
        low = np.int64((1 << bits) - 1)
        labels = np.arange(k, dtype=np.int64)[:, None]
        lut_ext = np.append(self._lut, -1).astype(np.intp)
        # finiteness: checked on the statistic when every sensor feeds it (an inf/nan
        # reading makes it non-finite), otherwise on the raw chunk
        covered = np.any(Mdet != 0, axis=1) if mode == "chi2" else np.zeros(self.m, bool)
        raw_check = not covered.all()
        c = self.chunk_size
        for start in range(0, N, c):
            stop = min(start + c, N)
            zc = Z[start:stop]
            if raw_check and not np.isfinite(zc).all():
                _raise_nonfinite_block(zc, start, "Z")
            Y = MT @ zc.T
            Yi = Y[r:]
            st = stat[start:stop]
            dc = det[start:stop]
            if mode == "chi2":
                Yd = Y[:r]
                np.multiply(Yd, Yd, out=Yd)
                if r:
                    np.sum(Yd, axis=0, out=st)
                else:
                    st[:] = 0.0
                np.greater_equal(st, threshold, out=dc)
            np.abs(Yi, out=Yi)
            if mode == "max":
                np.max(Yi, axis=0, out=st)
                np.greater(st, threshold, out=dc)
            if not np.isfinite(st).all():
                _raise_nonfinite_block(zc, start, "Z")
            if use_bits:
                # |y| >= 0 as float64 is ordered like its int64 bit pattern: pack the
                # hypothesis index into the lowest mantissa bits and take one max.  Two
                # statistics equal to ~1e-15 relative precision tie-break to the larger
                # index; otherwise this is argmax |y_i|.
                Yv = Yi.view(np.int64)
                Yv &= ~low
                Yv |= labels
                idx = np.max(Yv, axis=0)
                idx &= low
            else:
                idx = np.argmax(Yi, axis=0)
            np.take(lut_ext, np.where(dc, idx, k), out=iso[start:stop])
        return stat, det, iso

    def _single(self, Z: np.ndarray, pfa: float, method: str) -> ParityDiagnosis:
        """One detection + isolation stage (glt, opt, opt-uncorrected)."""
        if method == "glt":
            thr = chi2_threshold(pfa, self.s)
            stat, det, iso = self._kernel(Z, self._T.T / self.sigma, self._Bn, "chi2", thr)
        elif method == "opt":
            od = self._opt_data()
            if od["U"].shape[1] == 0:
                raise DesignError("method: no fault reaches the parity space", argument="D")
            thr = chi2_threshold(pfa, od["U"].shape[1])
            stat, det, iso = self._kernel(Z, od["U"] / self.sigma, od["dmat"], "chi2", thr)
        else:  # opt-uncorrected
            thr = normal_threshold(pfa)
            stat, det, iso = self._kernel(
                Z, np.zeros((self.m, 0)), self._opt_data()["dmat"], "max", thr
            )
        return ParityDiagnosis(det, iso[:, None], stat, thr, method, pfa)

    @_guarded
    def diagnose(
        self,
        Z: Any,
        pfa: float = 0.01,
        *,
        method: str = "glt",
        max_faults: int | None = None,
    ) -> ParityDiagnosis:
        """Detect and isolate faults in every sample.

        Parameters
        ----------
        Z : array_like, shape (N, m) or (m,)
            Measurements.
        pfa : float
            False-alarm rate of every detection test, in (0, 1).
        method : {"glt", "opt", "opt-uncorrected", "search", "glr"}
            * ``"glt"`` (default): ``FD >= chi2_{1-pfa}(m - n)``, isolate
              ``argmax FI(i)`` (seed 000 eq. 3, 5).
            * ``"opt"``: corrected OPT, ``FD_OPT >= chi2_{1-pfa}`` and ``argmax |d_i|``
              (identical to ``"glt"`` when ``D = F = I``: Theorems 2 and 4).
            * ``"opt-uncorrected"``: the OPT rule of seed 000 §1.2:
              ``max |d_i| > u_{1-pfa/2}``; its false-alarm rate exceeds ``pfa``
              (Theorem 1).  ``statistic`` is ``max |d_i|``.
            * ``"search"``: the two-fault search of seed 004 (Figure 1, reconstructed,
              see Notes).
            * ``"glr"``: k-fault GLR with sequential consistency tests (see Notes).
        max_faults : int, optional
            Width of :attr:`ParityDiagnosis.faults`.  For ``glt``/``opt``/
            ``opt-uncorrected`` (default 1) a value > 1 switches on *sequential*
            diagnosis: after isolating sensor ``i`` the samples are re-diagnosed on
            :meth:`reduced` ``(i)`` with the same rule, as long as redundancy remains.
            ``search`` handles at most 2 (default 2); ``glr`` at most ``m - n - 1``
            (default ``min(2, m - n - 1)``, at least 1).

        Returns
        -------
        ParityDiagnosis
            ``.detected`` (N,) bool, ``.isolated`` (N,) sensor or -1, ``.faults``,
            ``.unresolved``, ``.statistic``, ``.threshold``.

        Notes
        -----
        A detected sample whose isolated hypothesis is not distinguishable from another
        (parallel signatures, e.g. any sensor of the tetrahedron) is reported with
        ``isolated = -1`` and ``unresolved = True``.

        *Search* (seed 004 §3-§5 and its Figure 1, whose flowchart is not in the
        text; reconstruction).  With ``FD_S = FD - GLR_S`` the detection function of the
        configuration without the sensors ``S`` (re-detection after removal):

        1. ``FD < chi2_{1-pfa}(m-n)``: no fault.
        2. ``k = argmax_j D_j`` (the single-fault function).  If
           ``FD_{k} < chi2_{1-pfa}(m-n-1)`` the alarm is explained: fault on ``k``
           (one fault, or two of very different sizes whose small one is not
           detectable, Table 2).
        3. Otherwise two faults are present.  Candidate pairs are tried in turn and the
           first with ``FD_{ij} < chi2_{1-pfa}(m-n-2)`` is isolated ("sequentially
           isolating the indicated groups finds the actual faulty gyros", §5):
           first ``(k, k2)`` with ``k2`` the single-fault isolation ``D_j`` on the
           configuration without ``k`` (faults of very different sizes are analysed as
           single faults, §3), then the pairs indicated by ``max D+_ij`` and
           ``max D-_ij`` (faults of similar size, eq. 15-16), the larger maximum first.
        4. If no candidate passes, the sample is detected but unresolved.

        Step 3 needs ``m - n >= 3`` (one parity equation must remain to test a pair).

        *GLR* (the principled alternative).  For ``k = 1, 2, ...``: take the
        ``k``-subset ``S`` maximising ``GLR_S`` among identifiable subsets and accept it
        when ``FD - GLR_S < chi2_{1-pfa}(m-n-k)``.  It tests the same residual as the
        search but picks the maximum-likelihood candidate instead of the ``D+/-``
        indications.

        References
        ----------
        Seed 000 §1-§5; seed 004 §2-§5; math.md §6.
        """
        pfa = as_probability(pfa, "pfa")
        method = as_choice(method, "method", METHODS)
        if max_faults is not None:
            max_faults = as_int(max_faults, "max_faults", minimum=1, maximum=self.m)
        Zs = self._samples(Z, check=method in ("search", "glr"))
        if method == "search":
            mf = 2 if max_faults is None else as_int(max_faults, "max_faults", minimum=1)
            if mf > 2:
                raise GeomFDIError(
                    f"max_faults: the seed-004 search isolates at most 2 faults, got {mf}",
                    argument="max_faults",
                )
            return self._search(Zs, pfa, mf)
        if method == "glr":
            if max_faults is None:
                mf = max(1, min(2, self.s - 1))
            else:
                mf = as_int(max_faults, "max_faults", minimum=1)
                if mf > max(1, self.s - 1):
                    raise GeomFDIError(
                        f"max_faults: the GLR can test at most m - n - 1 = {self.s - 1} "
                        f"faults, got {mf}",
                        argument="max_faults",
                    )
            return self._glr(Zs, pfa, mf)
        mf = 1 if max_faults is None else as_int(max_faults, "max_faults", minimum=1)
        if mf > 1 and self.D is not None:
            raise GeomFDIError(
                "max_faults: sequential diagnosis needs D = I (sensor faults)",
                argument="max_faults",
            )
        first = self._single(Zs, pfa, method)
        if mf == 1:
            return first
        return self._sequential(Zs, pfa, method, mf, first)

    def _sequential(
        self, Z: np.ndarray, pfa: float, method: str, mf: int, first: ParityDiagnosis
    ) -> ParityDiagnosis:
        N = Z.shape[0]
        faults = np.full((N, mf), -1, dtype=np.intp)
        faults[:, 0] = first.isolated
        unresolved = first.unresolved.copy()
        iso = first.isolated
        for i in np.unique(iso[iso >= 0]):
            try:
                red = self.reduced(int(i))
            except (DesignError, RankDeficientError):
                continue  # no redundancy left: the search stops here
            rows = np.flatnonzero(iso == i)
            keep = np.setdiff1d(np.arange(self.m), [i])
            sub_first = red._single(Z[np.ix_(rows, keep)], pfa, method)
            sub = (
                sub_first
                if mf == 2
                else red._sequential(Z[np.ix_(rows, keep)], pfa, method, mf - 1, sub_first)
            )
            f = sub.faults
            faults[rows, 1:] = np.where(f >= 0, keep[np.maximum(f, 0)], -1)
            unresolved[rows] |= sub.unresolved
        return ParityDiagnosis(
            first.detected, faults, first.statistic, first.threshold, method, pfa, unresolved
        )

    def _detect(
        self, Z: np.ndarray, pfa: float
    ) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
        """Projections ``a``, the detection statistic ``FD``, its threshold and the
        detections: the start of every multiple-fault search."""
        a = self._a(Z)
        FD = self._fd(Z)
        self._check_fd(FD)
        T0 = chi2_threshold(pfa, self.s)
        return a, FD, T0, FD >= T0

    def _search(self, Z: np.ndarray, pfa: float, mf: int) -> ParityDiagnosis:
        N, s = Z.shape[0], self.s
        a, FD, T0, det = self._detect(Z, pfa)
        FI = self._fi_from_a(a)
        k1 = np.argmax(FI, axis=1)
        faults = np.full((N, mf), -1, dtype=np.intp)
        unresolved = np.zeros(N, dtype=bool)
        if s >= 2:
            R1 = FD - FI[np.arange(N), k1]
            ok1 = R1 < chi2_threshold(pfa, s - 1)
        else:
            ok1 = np.ones(N, dtype=bool)  # no parity left to test: single fault assumed
        single = det & ok1
        faults[single, 0] = self._lut[k1[single]]
        unresolved |= single & (faults[:, 0] < 0)
        pend = np.flatnonzero(det & ~ok1)
        if mf >= 2 and s >= 3 and pend.size:
            ap, fdp, fip, k1p = a[pend], FD[pend], FI[pend], k1[pend]
            n_p = pend.size
            ar = np.arange(n_p)
            plus, minus = self._pairs_from_a(ap)
            glr = self._glr2_from_a(ap, fip)
            iu, ju = np.triu_indices(self.k, 1)
            Pv, Mv = plus[:, iu, ju], minus[:, iu, ju]
            bp, bm = np.argmax(Pv, axis=1), np.argmax(Mv, axis=1)
            plus_first = Pv[ar, bp] >= Mv[ar, bm]
            c1 = np.where(plus_first, bp, bm)
            c2 = np.where(plus_first, bm, bp)
            row = glr[ar, k1p, :].copy()
            row[ar, k1p] = -np.inf
            k2 = np.argmax(row, axis=1)
            cands = [
                (np.minimum(k1p, k2), np.maximum(k1p, k2)),
                (iu[c1], ju[c1]),
                (iu[c2], ju[c2]),
            ]
            T2 = chi2_threshold(pfa, s - 2)
            info = self._subset_info(2)
            pair_ok = np.zeros((self.k, self.k), dtype=bool)
            S = info["subsets"]
            pair_ok[S[:, 0], S[:, 1]] = info["valid"] & ~info["ambiguous"]
            accepted = np.zeros(n_p, dtype=bool)
            chosen = np.full((n_p, 2), -1, dtype=np.intp)
            for ci, cj in cands:
                ok = ~accepted & (fdp - glr[ar, ci, cj] < T2)
                chosen[ok, 0], chosen[ok, 1] = ci[ok], cj[ok]
                accepted |= ok
            good = accepted & pair_ok[np.maximum(chosen[:, 0], 0), np.maximum(chosen[:, 1], 0)]
            faults[pend[good], :2] = chosen[good]
            unresolved[pend[~good]] = True
        else:
            unresolved[pend] = True
        return ParityDiagnosis(det, faults, FD, T0, "search", pfa, unresolved)

    def _glr(self, Z: np.ndarray, pfa: float, mf: int) -> ParityDiagnosis:
        N, s = Z.shape[0], self.s
        a, FD, T0, det = self._detect(Z, pfa)
        faults = np.full((N, mf), -1, dtype=np.intp)
        unresolved = np.zeros(N, dtype=bool)
        pend = det.copy()
        for kk in range(1, min(mf, s - 1) + 1):
            idx = np.flatnonzero(pend)
            if idx.size == 0:
                break
            info = self._subset_info(kk)
            ai = a[idx]
            best = np.full(idx.size, -np.inf)
            arg = np.zeros(idx.size, dtype=np.intp)
            for c in np.flatnonzero(info["valid"]):
                S = info["subsets"][c]
                aS = ai[:, S]
                val = np.einsum("ni,ij,nj->n", aS, info["pinv"][c], aS)
                better = val > best
                best[better] = val[better]
                arg[better] = c
            if not np.isfinite(best).any():
                break
            ok = FD[idx] - best < chi2_threshold(pfa, s - kk)
            acc = idx[ok]
            amb = info["ambiguous"][arg[ok]]
            faults[acc[~amb], :kk] = info["subsets"][arg[ok][~amb]]
            unresolved[acc[amb]] = True
            pend[acc] = False
        unresolved |= pend
        return ParityDiagnosis(det, faults, FD, T0, "glr", pfa, unresolved)


# --------------------------------------------------------------------------------------
# Monte Carlo
# --------------------------------------------------------------------------------------
def _fault_vector(pf: ParityFDI, fault: Any) -> np.ndarray:
    if fault is None:
        return np.zeros(pf.k)
    return as_vector(fault, "fault", length=pf.k)


def simulate(
    pf: ParityFDI, n_runs: int, rng: Any = None, *, fault: Any = None, x: Any = None
) -> np.ndarray:
    """Draw ``n_runs`` samples ``Z = H x + D f + sigma F eps``, shape (n_runs, m).

    Parameters
    ----------
    pf : ParityFDI
        The model.
    n_runs : int
        Number of samples.
    rng : numpy Generator, int seed or None
    fault : array_like, shape (k,), optional
        Fault sizes per hypothesis (default no fault).
    x : array_like, shape (n,), optional
        True state (default: standard normal per sample; the parity statistics do not
        depend on it).

    Returns
    -------
    Z : ndarray, shape (n_runs, m)
    """
    n_runs = as_int(n_runs, "n_runs", minimum=0)
    rng = _as_rng(rng)
    f = _fault_vector(pf, fault)
    if x is None:
        X = rng.standard_normal((n_runs, pf.n))
    else:
        X = np.broadcast_to(as_vector(x, "x", length=pf.n), (n_runs, pf.n))
    q = pf.m if pf.F is None else pf.F.shape[1]
    E = rng.standard_normal((n_runs, q)) * pf.sigma
    noise = E if pf.F is None else E @ pf.F.T
    return X @ pf.H.T + noise + pf._Dm @ f


def _mc_counts(
    pf: ParityFDI,
    fault: np.ndarray,
    pfa: float,
    n_runs: int,
    rng: np.random.Generator,
    method: str,
    max_faults: int | None,
    chunk: int,
) -> tuple[int, int, int]:
    truth = np.flatnonzero(fault)
    det_n = cor_n = part_n = 0
    for start in range(0, n_runs, chunk):
        n = min(chunk, n_runs - start)
        Z = simulate(pf, n, rng, fault=fault)
        res = pf.diagnose(Z, pfa, method=method, max_faults=max_faults)
        F = res.faults
        det_n += int(res.detected.sum())
        nf = res.n_faults
        valid = np.isin(F, truth) | (F < 0)
        all_true = valid.all(axis=1)
        part_n += int(np.count_nonzero(all_true & (nf > 0)))
        if truth.size:
            has_all = np.ones(n, dtype=bool)
            for t in truth:
                has_all &= (F == t).any(axis=1)
            cor_n += int(np.count_nonzero(has_all & all_true & (nf == truth.size)))
        else:
            cor_n += int(np.count_nonzero(~res.detected))
    return det_n, cor_n, part_n


def false_alarm_rate(
    pf: ParityFDI,
    pfa: float,
    n_runs: int,
    rng: Any = None,
    *,
    method: str = "glt",
    chunk: int = 1 << 17,
) -> RateEstimate:
    """Monte-Carlo false-alarm rate of a decision rule (no fault, ``n_runs`` samples).

    Parameters
    ----------
    pf : ParityFDI
    pfa : float
        Nominal false-alarm rate used for the thresholds.
    n_runs : int
        Number of fault-free samples.
    rng : numpy Generator, int seed or None
    method : str
        A method of :meth:`ParityFDI.diagnose`.
    chunk : int
        Samples drawn per batch (bounds memory).

    Returns
    -------
    RateEstimate
        Fraction of samples where the detection test fired.  For ``"glt"`` it matches
        ``pfa``; for ``"opt-uncorrected"`` it is at least ``1 - (1 - pfa)^(m-n)``
        (seed 000, Theorem 1).
    """
    pfa = as_probability(pfa, "pfa")
    n_runs = as_int(n_runs, "n_runs", minimum=1)
    chunk = as_int(chunk, "chunk", minimum=1)
    rng = _as_rng(rng)
    det_n, _, _ = _mc_counts(pf, np.zeros(pf.k), pfa, n_runs, rng, method, None, chunk)
    return RateEstimate(det_n, n_runs)


def correct_isolation_rate(
    pf: ParityFDI,
    fault: Any,
    pfa: float,
    n_runs: int,
    rng: Any = None,
    *,
    method: str = "glt",
    max_faults: int | None = None,
    chunk: int = 1 << 16,
) -> IsolationRates:
    """Monte-Carlo correct-isolation rate for a given fault vector.

    Parameters
    ----------
    pf : ParityFDI
    fault : array_like, shape (k,)
        Fault sizes; the nonzero entries are the true faulty set.
    pfa : float
        False-alarm rate of the detection tests.
    n_runs : int
        Number of samples.
    rng : numpy Generator, int seed or None
    method, max_faults
        Passed to :meth:`ParityFDI.diagnose`.
    chunk : int
        Samples per batch.

    Returns
    -------
    IsolationRates
        ``correct`` (isolated set == true set), ``detection``, ``partial``.
    """
    f = _fault_vector(pf, fault)
    pfa = as_probability(pfa, "pfa")
    n_runs = as_int(n_runs, "n_runs", minimum=1)
    chunk = as_int(chunk, "chunk", minimum=1)
    rng = _as_rng(rng)
    det_n, cor_n, part_n = _mc_counts(pf, f, pfa, n_runs, rng, method, max_faults, chunk)
    return IsolationRates(
        RateEstimate(cor_n, n_runs), RateEstimate(det_n, n_runs), RateEstimate(part_n, n_runs)
    )


def _method_spec(spec: Any) -> tuple[str, str, int | None]:
    """``"glt"`` or ``("label", "method", max_faults)`` -> (label, method, max_faults)."""
    if isinstance(spec, str):
        return spec, spec, None
    try:
        label, method, mf = spec
    except (TypeError, ValueError) as exc:
        raise GeomFDIError(
            f"methods: each entry is a method name or (label, method, max_faults), got {spec!r}",
            argument="methods",
        ) from exc
    return str(label), str(method), mf


def rates_vs_fault_size(
    pf: ParityFDI,
    direction: Any,
    sizes: Any,
    pfa: float,
    n_runs: int,
    rng: Any = None,
    *,
    methods: Sequence[Any] = ("glt",),
) -> RateCurve:
    """Detection and correct-isolation rates for faults ``size * direction``.

    Parameters
    ----------
    pf : ParityFDI
    direction : array_like, shape (k,)
        Fault vector of unit size (e.g. ``e_i`` for sensor i, or ``e_i + e_j``).
    sizes : array_like
        Multipliers of ``direction``.
    pfa, n_runs, rng
        As in :func:`correct_isolation_rate`.
    methods : sequence
        Method names, or ``(label, method, max_faults)`` tuples.

    Returns
    -------
    RateCurve
    """
    d = _fault_vector(pf, direction)
    sz = as_vector(sizes, "sizes")
    rng = _as_rng(rng)
    specs = [_method_spec(m) for m in methods]
    correct = {lab: np.empty(sz.size) for lab, _, _ in specs}
    detection = {lab: np.empty(sz.size) for lab, _, _ in specs}
    for j, size in enumerate(sz):
        for lab, meth, mf in specs:
            r = correct_isolation_rate(pf, size * d, pfa, n_runs, rng, method=meth, max_faults=mf)
            correct[lab][j] = r.correct.rate
            detection[lab][j] = r.detection.rate
    return RateCurve(sz, d, correct, detection, int(n_runs), pf.sigma, float(pfa))


def plot_rates(curve: RateCurve, ax: Any = None) -> Any:
    """Plot correct-isolation (solid) and detection (dashed) rates against fault size.

    The correct-isolation curve omits size 0, where "correct" means "no alarm"; the
    detection curve starts there at the false-alarm rate.

    Parameters
    ----------
    curve : RateCurve
        From :func:`rates_vs_fault_size`.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _figure_axes(ax, (6.5, 4))
    nonzero = curve.sizes != 0  # at size 0 "correct" means "no alarm": not drawn
    for j, lab in enumerate(curve.correct):
        color = f"C{j}"
        ax.plot(
            curve.sizes[nonzero],
            curve.correct[lab][nonzero],
            "-o",
            color=color,
            ms=3,
            label=f"{lab}: correct isolation",
        )
        ax.plot(curve.sizes, curve.detection[lab], "--", color=color, label=f"{lab}: detection")
    ax.set_xlabel(f"fault size (noise sigma = {curve.sigma:g})")
    ax.set_ylabel("rate")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.set_title(f"Monte-Carlo rates, {curve.n_runs} runs per point, pfa = {curve.pfa:g}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


SEED004_KINDS = (
    "single fault, +/-0.01",
    "two faults, very different (0.05, 0.005)",
    "two faults, equal, same sign (0.1, 0.1)",
    "two faults, equal, opposite sign (0.1, -0.1)",
)

SEED004_METHODS = (
    ("paper search (seed 004)", "search", 2),
    ("two-fault GLR", "glr", 2),
    ("sequential GLT", "glt", 2),
)


def _equivalent(pf: ParityFDI, f: np.ndarray) -> list[frozenset[int]]:
    """Other sets of one or two faults explaining the noise-free parity of ``f`` exactly."""
    truth = frozenset(np.flatnonzero(f).tolist())
    fd = pf.detection_statistic(f)[0]
    alts: list[frozenset[int]] = []
    for kk in (1, 2):
        stats_, subsets = pf.glr_statistics(f, kk)
        valid = pf._subset_info(kk)["valid"]
        for c in np.flatnonzero(valid & (fd - stats_[0] <= 1e-9 * fd)):
            S = frozenset(subsets[c].tolist())
            if not (S >= truth or any(a <= S for a in alts)):
                alts.append(S)
    return alts


def seed004_experiment(
    sigma: float = 0.001,
    n_runs: int = 20000,
    rng: Any = None,
    *,
    pfa: float = 1e-3,
    methods: Sequence[Any] = SEED004_METHODS,
) -> Seed004Result:
    """Reproduce seed 004's dodecahedron experiment as correct-isolation rates.

    Six gyros on the dodecahedron (:func:`dodecahedron`, the paper's numbering), white
    noise ``sigma`` (deg/h), and the fault cases of the paper's tables (deg/h):

    * Table 1: one fault of ``+0.01`` or ``-0.01`` on each gyro (12 cases);
    * Table 2: ``0.05`` on gyro i and ``0.005`` on gyro j > i (15 cases);
    * Table 3: ``0.1`` on gyros i and j (15 cases);
    * Table 4: ``0.1`` on gyro i and ``-0.1`` on gyro j > i (15 cases).

    Parameters
    ----------
    sigma : float
        Noise standard deviation in deg/h (the paper does not state its value).
    n_runs : int
        Monte-Carlo samples per case and method.
    rng : numpy Generator, int seed or None
    pfa : float
        False-alarm rate of each detection test.
    methods : sequence
        ``(label, method, max_faults)`` tuples for :meth:`ParityFDI.diagnose`; default:
        the paper's search, the two-fault GLR and sequential GLT.

    Returns
    -------
    Seed004Result
        ``.table()`` prints the rates; ``.plot()`` draws them.

    Notes
    -----
    The paper's tables list the gyros indicated by the maxima of ``D_j``, ``D+_ij`` and
    ``D-_ij`` over a simulation run, not rates; this experiment turns the same cases
    into correct-isolation probabilities (isolated set equal to the true faulty set).
    With faults of very different sizes the paper only isolates the large one; the
    exact-set rate counts that as a failure, :attr:`IsolationRates.partial` does not.
    """
    sigma = as_positive(sigma, "sigma")
    n_runs = as_int(n_runs, "n_runs", minimum=1)
    rng = _as_rng(rng)
    specs = [_method_spec(m) for m in methods]
    pf = ParityFDI(dodecahedron(), sigma)
    m = pf.m
    cases: list[tuple[str, dict[int, float]]] = []
    for j in range(m):
        for sgn in (1.0, -1.0):
            cases.append((SEED004_KINDS[0], {j: 0.01 * sgn}))
    for i, j in itertools.combinations(range(m), 2):
        cases.append((SEED004_KINDS[1], {i: 0.05, j: 0.005}))
    for i, j in itertools.combinations(range(m), 2):
        cases.append((SEED004_KINDS[2], {i: 0.1, j: 0.1}))
    for i, j in itertools.combinations(range(m), 2):
        cases.append((SEED004_KINDS[3], {i: 0.1, j: -0.1}))
    out = []
    for kind, fdict in cases:
        f = np.zeros(m)
        for i, v in fdict.items():
            f[i] = v
        rates = {
            lab: correct_isolation_rate(pf, f, pfa, n_runs, rng, method=meth, max_faults=mf)
            for lab, meth, mf in specs
        }
        out.append(
            {"kind": kind, "faults": fdict, "rates": rates, "alternatives": _equivalent(pf, f)}
        )
    return Seed004Result(
        out, tuple(lab for lab, _, _ in specs), sigma, float(pfa), n_runs, SEED004_KINDS
    )
