"""Evaluation curves: ROC (P_d versus false-alarm probability), P_d / delay versus size,
and the isolation confusion matrix.

Figures are built with :class:`matplotlib.figure.Figure` directly (no pyplot); save them
with :func:`geomfdi.save_png`.  See the user guide, *Theory: residual evaluation*
(``docs/theory/evaluation.md``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError
from geomfdi.plotting._text import plain, plain_all

__all__ = ["plot_roc", "plot_detection", "plot_confusion"]


def _figure(figsize: tuple[float, float]) -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def plot_roc(
    curves: Any,
    *,
    title: str | None = None,
    log_far: bool = True,
    figsize: tuple[float, float] = (5.5, 4.5),
    ax: Any = None,
) -> Any:
    """ROC curves: ``P_d`` against the false-alarm probability.

    Parameters
    ----------
    curves : sequence of geomfdi.evaluation.roc.RocCurve, or geomfdi.parity.RocCurve
        Campaign curves (:func:`geomfdi.roc_curve`, one step line each, labelled with its
        AUC); a parity-space Monte-Carlo curve (:func:`geomfdi.parity.roc_curves`) is drawn
        by :func:`geomfdi.plotting.parity.plot_roc` (``ax`` is passed on, the other
        options do not apply).
    title : str, optional
    log_far : bool
        Logarithmic false-alarm axis (rates of 1e-3 .. 1e-1 are the interesting part);
        zero rates are drawn at half the smallest non-zero one.
    figsize : (float, float)
    ax : matplotlib Axes, optional
        Only for a parity-space curve.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if hasattr(curves, "pfa") and isinstance(getattr(curves, "pd", None), Mapping):
        from geomfdi.plotting.parity import plot_roc as plot_parity_roc

        return plot_parity_roc(curves, ax=ax)
    if ax is not None:
        raise GeomFDIError(
            "ax: only a parity-space ROC curve is drawn on given axes", argument="ax"
        )
    curves = list(curves)
    if not curves:
        raise GeomFDIError("curves: nothing to plot", argument="curves")
    fig = _figure(figsize)
    ax = fig.add_subplot()
    floor = min((c.far[c.far > 0].min() for c in curves if np.any(c.far > 0)), default=1e-3)
    for c in curves:
        x = np.where(c.far > 0, c.far, floor / 2) if log_far else c.far
        ax.step(x, c.pd, where="post", label=f"{plain(c.label)} (AUC {c.auc:.3f})")
    if log_far:
        ax.set_xscale("log")
    ax.set_xlabel("false-alarm probability per window")
    ax.set_ylabel("detection probability $P_d$")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small", loc="lower right")
    if title:
        ax.set_title(plain(title), fontsize="medium")
    return fig


def plot_detection(
    curves: Mapping[str, Any],
    *,
    title: str | None = None,
    figsize: tuple[float, float] = (6.5, 5.0),
) -> Any:
    """``P_d`` (with Wilson 95 % bounds) and median detection delay versus fault size.

    Parameters
    ----------
    curves : mapping label -> DataFrame
        As returned by :meth:`geomfdi.CampaignResult.detection_curve` (index: size;
        columns ``pd, pd_low, pd_high, delay_median``).
    """
    if not curves:
        raise GeomFDIError("curves: nothing to plot", argument="curves")
    fig = _figure(figsize)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for label, df in curves.items():
        size = np.asarray(df.index, dtype=float)
        line = ax1.plot(size, df["pd"], marker="o", label=plain(label))[0]
        ax1.fill_between(size, df["pd_low"], df["pd_high"], color=line.get_color(), alpha=0.2)
        ax2.plot(size, df["delay_median"], marker="o", color=line.get_color(), label=plain(label))
    ax1.set_ylabel("$P_d$")
    ax1.set_ylim(-0.02, 1.02)
    ax1.grid(True, alpha=0.3)
    ax1.legend(fontsize="small")
    ax2.set_xlabel("fault size")
    ax2.set_ylabel("median delay [s]")
    ax2.grid(True, alpha=0.3)
    if title:
        ax1.set_title(plain(title), fontsize="medium")
    return fig


def plot_confusion(
    confusion: Any,
    *,
    title: str | None = None,
    figsize: tuple[float, float] | None = None,
    cmap: str = "Blues",
    ax: Any = None,
) -> Any:
    """An isolation confusion matrix: row fractions as colours, counts as text.

    Parameters
    ----------
    confusion : pandas.DataFrame or array_like of int
        Counts, rows = true fault, columns = decision (e.g.
        :meth:`geomfdi.CampaignResult.confusion`); an array gets numbered labels.
    title : str, optional
    figsize : (float, float), optional
    cmap : str
        Matplotlib colour map of the row fractions.
    ax : matplotlib Axes, optional
        Draw into it (its figure is returned).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if hasattr(confusion, "to_numpy") and hasattr(confusion, "index"):
        counts = np.asarray(confusion.to_numpy(), dtype=float)
        rows = [str(r) for r in confusion.index]
        cols = [str(c) for c in confusion.columns]
    else:
        counts = np.asarray(confusion, dtype=float)
        if counts.ndim != 2:
            raise GeomFDIError("confusion: expected a 2-D table of counts", argument="confusion")
        rows = [str(i) for i in range(counts.shape[0])]
        cols = [str(j) for j in range(counts.shape[1])]
    if counts.size == 0 or np.any(counts < 0) or not np.all(np.isfinite(counts)):
        raise GeomFDIError(
            "confusion: expected a non-empty table of counts >= 0", argument="confusion"
        )
    total = counts.sum(axis=1, keepdims=True)
    frac = counts / np.where(total > 0, total, 1.0)
    if ax is None:
        size = figsize or (1.2 + 0.9 * len(cols), 1.0 + 0.6 * len(rows))
        fig = _figure(size)
        ax = fig.subplots()
    else:
        fig = ax.figure
    im = ax.imshow(frac, cmap=cmap, vmin=0.0, vmax=1.0, aspect="auto")
    for i in range(counts.shape[0]):
        for j in range(counts.shape[1]):
            ax.text(
                j,
                i,
                f"{int(counts[i, j])}",
                ha="center",
                va="center",
                color="white" if frac[i, j] > 0.6 else "black",
                fontsize=8,
            )
    ax.set_xticks(range(len(cols)), plain_all(cols), rotation=30, ha="right")
    ax.set_yticks(range(len(rows)), plain_all(rows))
    ax.set_xlabel("isolated")
    ax.set_ylabel("true fault")
    fig.colorbar(im, ax=ax, label="fraction of the row's runs")
    if title:
        ax.set_title(plain(title))
    return fig
