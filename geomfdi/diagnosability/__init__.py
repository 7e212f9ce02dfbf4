"""Quantitative diagnosability: KL-divergence and directional-similarity indices."""

from geomfdi.diagnosability.window import (
    ApplicabilityReport,
    DiagnosabilityTable,
    FaultApplicability,
    StackedWindow,
    WindowModel,
    diagnosability_table,
    plot_isolability,
)

__all__ = [
    "WindowModel",
    "StackedWindow",
    "DiagnosabilityTable",
    "FaultApplicability",
    "ApplicabilityReport",
    "diagnosability_table",
    "plot_isolability",
]
