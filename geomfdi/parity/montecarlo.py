"""Monte-Carlo rates of the parity-space decisions (false alarms, correct isolation).

See the user guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from geomfdi._validation import as_int, as_probability, as_vector
from geomfdi.errors import GeomFDIError
from geomfdi.parity._input import _as_rng
from geomfdi.parity._records import ParityData, as_data
from geomfdi.parity.diagnosis import diagnose
from geomfdi.parity.glt import detection_statistic
from geomfdi.parity.opt import opt_detection_statistic, opt_statistics
from geomfdi.parity.results import IsolationRates, RateCurve, RateEstimate

if TYPE_CHECKING:
    from geomfdi.parity._records import HasParityData

__all__ = [
    "simulate",
    "false_alarm_rate",
    "correct_isolation_rate",
    "rates_vs_fault_size",
    "RocCurve",
    "roc_curves",
]


def _fault_vector(pf: ParityData, fault: Any) -> np.ndarray:
    if fault is None:
        return np.zeros(pf.k)
    return as_vector(fault, "fault", length=pf.k)


def simulate(
    pf: ParityData | HasParityData,
    n_runs: int,
    rng: Any = None,
    *,
    fault: Any = None,
    x: Any = None,
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
    pf = as_data(pf)
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
    return X @ pf.H.T + noise + pf.Dm @ f


def _mc_counts(
    pf: ParityData,
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
        res = diagnose(pf, Z, pfa, method=method, max_faults=max_faults)
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
    pf: ParityData | HasParityData,
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
        (Zhang, Chen & Liu (2005), Theorem 1).
    """
    pf = as_data(pf)
    pfa = as_probability(pfa, "pfa")
    n_runs = as_int(n_runs, "n_runs", minimum=1)
    chunk = as_int(chunk, "chunk", minimum=1)
    rng = _as_rng(rng)
    det_n, _, _ = _mc_counts(pf, np.zeros(pf.k), pfa, n_runs, rng, method, None, chunk)
    return RateEstimate(det_n, n_runs)


def correct_isolation_rate(
    pf: ParityData | HasParityData,
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
    pf = as_data(pf)
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
    pf: ParityData | HasParityData,
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
    pf = as_data(pf)
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


@dataclass(frozen=True)
class RocCurve:
    """Receiver operating characteristics of detection statistics (:func:`roc_curves`).

    Attributes
    ----------
    pfa : ndarray
        Empirical false-alarm rates (from the noise-only samples) at which ``pd`` is given.
    pd : dict[str, ndarray]
        Detection rate per statistic at the threshold giving that false-alarm rate.
    fault : ndarray
        The fault vector of the faulty samples.
    n_runs : int
    """

    pfa: np.ndarray
    pd: dict[str, np.ndarray]
    fault: np.ndarray
    n_runs: int

    def plot(self, ax: Any = None) -> Any:
        """Plot the curves; see :func:`geomfdi.plotting.parity.plot_roc`."""
        from geomfdi.plotting.parity import plot_roc

        return plot_roc(self, ax=ax)


ROC_STATISTICS = ("glt", "opt", "max-d")


def roc_curves(
    pf: ParityData | HasParityData,
    fault: Any,
    n_runs: int,
    rng: Any = None,
    *,
    pfa: Any = None,
    statistics: Sequence[str] = ROC_STATISTICS,
) -> RocCurve:
    """Monte-Carlo ROC curves of the GLT, corrected OPT and ``max |d_i|`` detection tests.

    Parameters
    ----------
    pf : ParityFDI
    fault : array_like, (k,)
        Fault sizes of the faulty samples.
    n_runs : int
        Noise-only and faulty samples drawn (each).
    rng : numpy Generator, int seed or None
    pfa : array_like, optional
        False-alarm rates of the curve (default 40 values, log-spaced from ``10 / n_runs``
        to 0.5).
    statistics : sequence of {"glt", "opt", "max-d"}

    Returns
    -------
    RocCurve
        For each statistic the threshold is the ``1 - pfa`` quantile of its noise-only
        values, so the curves compare the tests at equal realised false-alarm rates
        (where the uncorrected OPT rule's nominal rate is wrong, Zhang, Chen & Liu 2005,
        Theorem 1).
    """
    pf = as_data(pf)
    f = _fault_vector(pf, fault)
    n_runs = as_int(n_runs, "n_runs", minimum=10)
    gen = _as_rng(rng)
    grid = (
        np.geomspace(10.0 / n_runs, 0.5, 40)
        if pfa is None
        else np.clip(as_vector(pfa, "pfa"), 1.0 / n_runs, 1.0)
    )
    Z0 = simulate(pf, n_runs, gen)
    Z1 = simulate(pf, n_runs, gen, fault=f)
    fns = {
        "glt": lambda Z: detection_statistic(pf, Z),
        "opt": lambda Z: opt_detection_statistic(pf, Z),
        "max-d": lambda Z: np.abs(opt_statistics(pf, Z)).max(axis=1),
    }
    pd = {}
    for name in statistics:
        if name not in fns:
            raise GeomFDIError(
                f"statistics: expected names from {ROC_STATISTICS}, got {name!r}",
                argument="statistics",
            )
        s0, s1 = fns[name](Z0), np.sort(fns[name](Z1))
        thr = np.quantile(s0, 1.0 - grid)
        pd[name] = 1.0 - np.searchsorted(s1, thr, side="right") / n_runs
    return RocCurve(grid, pd, f, n_runs)
