"""Plotting helpers (matplotlib): residual traces, structure matrices, curves, PNG export.

Layer: beside io, on result objects.  It may import matplotlib inside functions and the
subpackages whose results it draws (generators, evaluation, parity, diagnosability,
monitoring); the result objects import it only inside their ``plot`` methods.
"""

from geomfdi.plotting.curves import plot_confusion, plot_detection, plot_roc
from geomfdi.plotting.residuals import plot_residuals, plot_result, plot_structure, save_png

__all__ = [
    "plot_residuals",
    "plot_result",
    "plot_structure",
    "save_png",
    "plot_roc",
    "plot_detection",
    "plot_confusion",
]
