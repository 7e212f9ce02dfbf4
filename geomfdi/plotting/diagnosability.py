"""Figures of the diagnosability indices: the isolability heat map.

See the user guide, *Theory: diagnosability* (``docs/theory/diagnosability.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi._validation import as_bool
from geomfdi.diagnosability.results import DiagnosabilityTable
from geomfdi.errors import GeomFDIError
from geomfdi.plotting._text import plain, plain_all

__all__ = ["plot_isolability"]


def plot_isolability(
    table: DiagnosabilityTable,
    *,
    ax: Any = None,
    cmap: str = "viridis",
    annotate: bool = True,
    title: str | None = None,
) -> Any:
    """Heat map of the isolability block ``FI(f_i, f_j)`` of a table.

    Parameters
    ----------
    table : DiagnosabilityTable
    ax : matplotlib Axes, optional
        Draw into it (default: a new figure).
    cmap : str
        Colour map.
    annotate : bool
        Write each value in its cell.
    title : str, optional
        Default: the method and its options.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not isinstance(table, DiagnosabilityTable):
        raise GeomFDIError(
            f"table: expected a DiagnosabilityTable, got {type(table).__name__}",
            argument="table",
        )
    import matplotlib
    import matplotlib.pyplot as plt

    annotate = as_bool(annotate, "annotate")
    try:
        cmap = matplotlib.colormaps[cmap] if isinstance(cmap, str) else cmap
        if not isinstance(cmap, matplotlib.colors.Colormap):
            raise TypeError(type(cmap).__name__)
    except (KeyError, TypeError) as exc:
        raise GeomFDIError(
            f"cmap: must be a matplotlib colormap or its name, got {cmap!r:.40}", argument="cmap"
        ) from exc

    fi = table.isolability
    p = fi.shape[0]
    if ax is None:
        fig, ax = plt.subplots(figsize=(1.2 * p + 2.5, 1.0 * p + 1.8))
    else:
        fig = ax.figure
    top = float(np.max(fi)) if fi.size else 0.0
    im = ax.imshow(fi, cmap=cmap, vmin=0.0, vmax=top if top > 0 else 1.0)
    fig.colorbar(im, ax=ax, label="FI(row, column)")
    ax.set_xticks(range(p), labels=plain_all(table.fault_names))
    ax.set_yticks(range(p), labels=plain_all(table.fault_names))
    ax.set_xlabel("isolated from")
    ax.set_ylabel("fault present")
    if annotate:
        for (r, c), v in np.ndenumerate(fi):
            color = "black" if top > 0 and v > 0.6 * top else "white"
            ax.text(c, r, f"{v:.4g}", ha="center", va="center", color=color, fontsize=9)
    if title is None:
        extra = ", ".join(f"{k}={v}" for k, v in table.options.items() if k != "nullspace")
        title = f"isolability ({table.method}{', ' + extra if extra else ''})"
    ax.set_title(plain(title))
    return fig
