"""Plots: residual traces with thresholds and fault onsets, structure matrices, PNG export.

Every function returns a :class:`matplotlib.figure.Figure` and imports matplotlib only
when called, so ``import geomfdi`` stays light and works without a display (the
figures are created with :class:`~matplotlib.figure.Figure` directly, not through
pyplot, so no GUI backend is touched and nothing leaks into pyplot's figure list).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi._validation import as_bool_array, as_choice, as_positive, as_real_array, as_sequence_of
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.limits import check_allocation
from geomfdi.plotting._text import plain, plain_all

__all__ = ["plot_residuals", "plot_result", "plot_structure", "save_png"]


def _figure(figsize: tuple[float, float]) -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def plot_residuals(
    t: Any,
    residuals: Any,
    *,
    threshold: Any = None,
    onsets: Sequence[float] = (),
    labels: Sequence[str] | None = None,
    alarms: Any = None,
    title: str | None = None,
    statistic: str = "abs",
    norms: Sequence[bool] | None = None,
    figsize: tuple[float, float] | None = None,
) -> Any:
    """Residual traces, one axis per residual, with thresholds and fault onsets.

    Parameters
    ----------
    t : array_like, (N,)
    residuals : array_like, (n_residuals, N)
    threshold : float, (n_residuals,) or Threshold, optional
        Drawn as ``+-threshold`` (dashed) for the ``"abs"`` statistic, or as a line over
        the statistic's trace for ``"rms"``.
    onsets : sequence of float
        Fault onset times (vertical dotted lines).
    labels : sequence of str, optional
        Axis labels (default ``r[k]``).
    alarms : array_like of bool, (n_residuals, N), optional
        Shaded where a residual alarms.
    title : str, optional
    statistic : str
        Used when ``threshold`` is a plain number/vector.
    norms : sequence of bool, optional
        Rows that are the Euclidean norm of a vector residual (never negative): their
        threshold is drawn as ``+threshold`` only.  Default: no row.
    figsize : (float, float), optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    from geomfdi.evaluation.decision import STATISTICS, Threshold

    statistic = as_choice(statistic, "statistic", STATISTICS)
    t = as_real_array(t, "t")
    if t.ndim != 1:
        raise ShapeError(f"t: must be a 1-D time vector, got shape {t.shape}", argument="t")
    r = as_real_array(residuals, "residuals")
    if r.ndim == 1:
        r = r[None]
    if r.ndim != 2 or r.shape[1] != t.shape[0]:
        raise ShapeError(
            f"residuals: expected (n_residuals, {t.shape[0]}), got {r.shape}", argument="residuals"
        )
    nres = r.shape[0]
    labels = (
        as_sequence_of(labels, "labels", object)
        if labels is not None
        else [f"r[{k}]" for k in range(nres)]
    )
    if len(labels) != nres:
        raise ShapeError(f"labels: expected {nres} labels, got {len(labels)}", argument="labels")
    labels = plain_all(labels)  # names are plain text, never mathtext
    is_norm = [False] * nres if norms is None else [bool(b) for b in norms]
    if len(is_norm) != nres:
        raise ShapeError(f"norms: expected {nres} flags, got {len(is_norm)}", argument="norms")
    thr_obj = None
    if isinstance(threshold, Threshold):
        thr_obj = threshold
        thr = threshold.values
    elif threshold is not None:
        thr_in = as_real_array(threshold, "threshold")
        if thr_in.ndim > 1 or thr_in.size not in (1, nres):
            raise ShapeError(
                f"threshold: expected a number or {nres} values, got shape {thr_in.shape}",
                argument="threshold",
            )
        thr = np.broadcast_to(thr_in, (nres,))
        thr_obj = Threshold(np.asarray(thr, dtype=float), statistic=statistic)
    else:
        thr = None
    fig = _figure(figsize or (8.0, 1.9 * nres + 0.8))
    axes = fig.subplots(nres, 1, sharex=True, squeeze=False)[:, 0]
    stat = thr_obj.statistic_of(r) if thr_obj is not None and thr_obj.statistic != "abs" else None
    for k, ax in enumerate(axes):
        ax.plot(t, r[k], lw=1.0, color="C0", label=labels[k])
        if stat is not None:
            ax.plot(t, stat[k], lw=0.8, color="C2", label=f"{thr_obj.statistic} statistic")
        if thr is not None and np.isfinite(thr[k]):
            ax.axhline(thr[k], color="C3", ls="--", lw=0.9, label="threshold")
            if stat is None and not is_norm[k]:
                ax.axhline(-thr[k], color="C3", ls="--", lw=0.9)
        for j, on in enumerate(onsets):
            ax.axvline(on, color="0.3", ls=":", lw=1.0, label="fault onset" if j == 0 else None)
        if alarms is not None:
            a = np.asarray(alarms, dtype=bool)[k]
            if a.any():
                lo, hi = ax.get_ylim()
                ax.fill_between(t, lo, hi, where=a, color="C3", alpha=0.12, step="post", lw=0)
                ax.set_ylim(lo, hi)
        ax.set_ylabel(labels[k])
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper left", fontsize="small", ncols=3)
    axes[-1].set_xlabel("t [s]")
    if title:
        fig.suptitle(plain(title))
    return fig


def plot_result(result: Any, *, title: str | None = None, **kwargs: Any) -> Any:
    """:func:`plot_residuals` for a :class:`~geomfdi.simulation.SimulationResult`."""
    return plot_residuals(
        result.t,
        result.residuals,
        threshold=result.threshold,
        onsets=sorted(set(result.onsets)),
        labels=result.residual_labels,
        alarms=result.alarms if result.threshold is not None else None,
        title=title,
        norms=result.norm_rows(),
        **kwargs,
    )


def plot_structure(
    structure: Any,
    requested: Any = None,
    *,
    fault_labels: Sequence[str] | None = None,
    residual_labels: Sequence[str] | None = None,
    title: str | None = None,
) -> Any:
    """Picture of a structure matrix: faults (rows) x residuals (columns).

    Parameters
    ----------
    structure : array_like of bool (n_residuals, n_faults), or a ResidualBank
        The achieved structure (a bank supplies its ``structure``, ``requested`` and
        labels).
    requested : array_like of bool, optional
        The requested structure; drawn as a second panel, and cells where achieved and
        requested differ are outlined in red in the achieved panel.
    fault_labels, residual_labels : sequence of str, optional
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.patches import Rectangle

    from geomfdi.generators.generator import ResidualBank

    if isinstance(structure, ResidualBank):
        bank = structure
        structure = bank.structure
        requested = bank.requested if requested is None else requested
        if fault_labels is None:
            fault_labels = [getattr(f, "name", f"fault {j}") for j, f in enumerate(bank.faults)]
    S = as_bool_array(structure, "structure")
    if S.ndim != 2:
        raise ShapeError(f"structure: must be 2-D, got shape {S.shape}", argument="structure")
    S = S.astype(bool)
    nres, nf = S.shape
    fault_labels = (
        as_sequence_of(fault_labels, "fault_labels", object)
        if fault_labels is not None
        else [f"f{j}" for j in range(nf)]
    )
    residual_labels = (
        as_sequence_of(residual_labels, "residual_labels", object)
        if residual_labels is not None
        else [f"r[{k}]" for k in range(nres)]
    )
    if len(fault_labels) != nf or len(residual_labels) != nres:
        raise ShapeError(
            f"fault_labels, residual_labels: expected {nf} and {nres} labels",
            argument="fault_labels",
        )
    panels = [("achieved", S)]
    if requested is not None:
        Rq = as_bool_array(requested, "requested")
        if Rq.shape != S.shape:
            raise ShapeError(
                f"requested: expected shape {S.shape}, got {Rq.shape}", argument="requested"
            )
        panels = [("requested", Rq), ("achieved", S)]
    else:
        Rq = None
    w = 1.2 + 0.6 * nres
    fig = _figure((w * len(panels) + 0.5, 1.0 + 0.5 * nf))
    axes = fig.subplots(1, len(panels), squeeze=False)[0]
    for ax, (name, M) in zip(axes, panels, strict=True):
        ax.imshow(M.T, cmap="Greys", vmin=0, vmax=1.6, aspect="equal")
        for j in range(nf):
            for k in range(nres):
                ax.text(
                    k,
                    j,
                    "1" if M[k, j] else "0",
                    ha="center",
                    va="center",
                    color="white" if M[k, j] else "black",
                )
                if name == "achieved" and Rq is not None and Rq[k, j] != M[k, j]:
                    ax.add_patch(Rectangle((k - 0.5, j - 0.5), 1, 1, fill=False, ec="red", lw=2))
        ax.set_xticks(range(nres), plain_all(residual_labels))
        ax.set_yticks(range(nf), plain_all(fault_labels))
        ax.set_title(name)
        ax.set_xlabel("residual")
    axes[0].set_ylabel("fault")
    if title:
        fig.suptitle(plain(title))
    return fig


def save_png(fig: Any, path: str | Path, *, dpi: int = 120) -> Path:
    """Write ``fig`` as a PNG (parent directories created); returns the path.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : str or Path
        ``.png`` is appended when the name has no suffix.
    dpi : int
    """
    from matplotlib.figure import Figure

    if not isinstance(fig, Figure):
        raise GeomFDIError(
            f"fig: expected a matplotlib Figure, got {type(fig).__name__}", argument="fig"
        )
    dpi = as_positive(dpi, "dpi")
    width, height = fig.get_size_inches() * dpi
    check_allocation(int(width) * int(height), itemsize=4, argument="dpi", what="PNG image")
    p = Path(path)
    if p.suffix == "":
        p = p.with_suffix(".png")
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=dpi, format="png")
    return p
