"""Figures of the AR monitor: the statistic against its threshold.

See the user guide, *Theory: AR monitoring* (``docs/theory/ar-monitoring.md``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from geomfdi._validation import as_bool, as_real_array
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.plotting._text import plain

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["plot_ar_monitor"]


class ARMonitorResultLike(Protocol):
    """What the figure reads of an :class:`~geomfdi.monitoring.results.ARMonitorResult`
    (the result calls this function from its ``plot`` method; this module does not import
    the result's module back)."""

    statistic: np.ndarray
    alarm: np.ndarray
    valid: np.ndarray
    restarted: np.ndarray
    threshold: float


def plot_ar_monitor(
    result: ARMonitorResultLike,
    *,
    time: Any = None,
    row: int = 0,
    ax: Axes | None = None,
    title: str | None = None,
    label: str | None = None,
    logy: bool = True,
) -> Figure:
    """Plot the statistic ``lambda_t`` against the threshold (paper, Figs. 7 and 8).

    Parameters
    ----------
    result : ARMonitorResult
        Output of :meth:`ARMonitor.run`.
    time : array_like, optional
        Epoch times (default: sample index).
    row : int
        Which stream of a batch result to plot.
    ax : matplotlib Axes, optional
        Draw into these axes (default: a new figure).
    title, label : str, optional
        Axes title and the statistic's legend label.
    logy : bool
        Logarithmic ``lambda`` axis.

    Returns
    -------
    matplotlib.figure.Figure
        Statistic, threshold line, alarms (red dots), restarts of the reset strategy
        (vertical ticks) and invalid epochs (grey band).
    """
    import matplotlib.pyplot as plt

    logy = as_bool(logy, "logy")

    if type(result).__name__ != "ARMonitorResult":
        raise GeomFDIError("result: expected an ARMonitorResult", argument="result")
    sel = (lambda a: a) if result.statistic.ndim == 1 else (lambda a: a[row])
    lam, alarm, valid, rst = (
        sel(result.statistic),
        sel(result.alarm),
        sel(result.valid),
        sel(result.restarted),
    )
    t = np.arange(lam.size) if time is None else as_real_array(time, "time").reshape(-1)
    if t.size != lam.size:
        raise ShapeError(f"time: expected {lam.size} values, got {t.size}", argument="time")
    if ax is None:
        fig, ax = plt.subplots(figsize=(8, 3.5), layout="constrained")
    else:
        fig = ax.figure
    shown = np.where(valid, np.maximum(lam, 1e-6) if logy else lam, np.nan)
    ax.plot(t, shown, lw=0.9, label=plain(label) if label else r"$\lambda_t$")
    ax.axhline(result.threshold, color="k", ls="--", lw=0.9, label=f"T = {result.threshold:.4g}")
    if np.any(alarm):
        ax.plot(t[alarm], shown[alarm], "r.", ms=3, label="alarm")
    if np.any(rst):
        for tr in t[rst]:
            ax.axvline(tr, color="tab:orange", lw=0.5, alpha=0.6)
        ax.plot([], [], color="tab:orange", lw=0.5, label="restart")
    if np.any(~valid):
        ax.fill_between(
            t, 0, 1, where=~valid, color="0.85", transform=ax.get_xaxis_transform(), lw=0
        )
    if logy:
        ax.set_yscale("log")
    ax.set_xlabel("epoch" if time is None else "time")
    ax.set_ylabel(r"$\lambda$")
    if title:
        ax.set_title(plain(title))
    ax.legend(loc="upper right", fontsize=8)
    return fig
