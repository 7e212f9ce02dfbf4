"""Plotting helpers (matplotlib): residual traces, structure matrices, PNG export."""

from geomfdi.plotting.residuals import plot_residuals, plot_result, plot_structure, save_png

__all__ = ["plot_residuals", "plot_result", "plot_structure", "save_png"]
