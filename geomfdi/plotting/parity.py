"""Figures of the parity-space functions: rate curves, the Qin & Niu (1999) experiment.

See the user guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from geomfdi._moved import renamed as _renamed

__all__ = ["plot_rates", "plot_qin_niu", "plot_roc"]

# What the figures read of the parity results (the results call these functions from
# their ``plot`` methods; this module does not import the results' modules back).


class RateCurveLike(Protocol):
    """The fields of a :class:`~geomfdi.parity.results.RateCurve` the figure reads."""

    sizes: np.ndarray
    correct: dict[str, np.ndarray]
    detection: dict[str, np.ndarray]
    n_runs: int
    sigma: float
    pfa: float


class QinNiuResultLike(Protocol):
    """The fields of a :class:`~geomfdi.parity.results.QinNiuResult` the figure reads."""

    methods: tuple[str, ...]
    kinds: tuple[str, ...]
    sigma: float

    def summary(self) -> dict[str, dict[str, dict[str, float]]]: ...


class RocCurveLike(Protocol):
    """The fields of a :class:`~geomfdi.parity.montecarlo.RocCurve` the figure reads."""

    pfa: np.ndarray
    pd: dict[str, np.ndarray]
    n_runs: int


def _figure_axes(ax: Any, figsize: tuple[float, float]) -> tuple[Any, Any]:
    """``(figure, axes)``: a new pyplot figure when ``ax`` is None, else ``ax``'s own."""
    if ax is not None:
        return ax.figure, ax
    import matplotlib.pyplot as plt

    return plt.subplots(figsize=figsize)


def plot_rates(curve: RateCurveLike, ax: Any = None) -> Any:
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


def plot_qin_niu(result: QinNiuResultLike, ax: Any = None) -> Any:
    """Grouped bar chart of the mean correct-isolation rate per family and method.

    Parameters
    ----------
    result : QinNiuResult
        From :func:`geomfdi.parity.qin_niu_experiment`.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _figure_axes(ax, (8.5, 4.5))
    summ = result.summary()
    x = np.arange(len(result.kinds))
    width = 0.8 / max(len(result.methods), 1)
    for j, meth in enumerate(result.methods):
        means = [summ[k][meth]["mean"] for k in result.kinds]
        mins = [summ[k][meth]["min"] for k in result.kinds]
        pos = x + (j - (len(result.methods) - 1) / 2) * width
        ax.bar(pos, means, width, label=meth)
        ax.plot(pos, mins, "k_", markersize=10)
    ax.set_xticks(x)
    ax.set_xticklabels([k.replace(", ", "\n", 1) for k in result.kinds], fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("correct-isolation rate (bar: mean, tick: min)")
    ax.set_title(f"Qin & Niu (1999) experiment, dodecahedron, sigma = {result.sigma:g} deg/h")
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    return fig


def plot_roc(curve: RocCurveLike, ax: Any = None) -> Any:
    """Detection rate against the realised false-alarm rate, one line per statistic.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _figure_axes(ax, (5.5, 4))
    for name, pd in curve.pd.items():
        ax.semilogx(curve.pfa, pd, "-", label=name)
    ax.set_xlabel("false-alarm rate")
    ax.set_ylabel("detection rate")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.set_title(f"ROC, {curve.n_runs} runs")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


__getattr__ = _renamed(__name__)  # the old names of the Qin & Niu experiment, deprecated
