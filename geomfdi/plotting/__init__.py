"""Plotting helpers (matplotlib): residual traces, structure matrices, curves, PNG export."""

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
