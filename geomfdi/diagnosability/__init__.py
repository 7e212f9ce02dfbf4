"""Quantitative diagnosability: KL-divergence, directional-similarity and probability indices.

* :mod:`~geomfdi.diagnosability.model` -- :class:`WindowModel`, the window model object;
* :mod:`~geomfdi.diagnosability.stacking` -- stacked window, ``N_H``, whitened fault maps
  (the functions take the model's frozen ``WindowData`` record, never the object);
* :mod:`~geomfdi.diagnosability.indices` -- the indices of one fault or pair;
* :mod:`~geomfdi.diagnosability.tables` -- the paper-like tables;
* :mod:`~geomfdi.diagnosability.applicability` -- Theorems 1-2 of Li, Wang & Liu (2015);
* :mod:`~geomfdi.diagnosability.bank` -- diagnosability of a designed residual bank;
* figures in :mod:`geomfdi.plotting.diagnosability`.

See the user guide, *Theory: diagnosability* (``docs/theory/diagnosability.md``).

Layer: a side branch on the model.  It may import :mod:`geomfdi.model`, the base
modules and, inside functions, :mod:`geomfdi.plotting`.
"""

from geomfdi.diagnosability.bank import (
    BankDiagnosability,
    StructuredIsolability,
    bank_diagnosability,
    bank_structured_isolability,
    bank_window_sweep,
)
from geomfdi.diagnosability.model import WindowModel
from geomfdi.diagnosability.results import (
    ApplicabilityReport,
    DiagnosabilityTable,
    FaultApplicability,
    StackedWindow,
)
from geomfdi.diagnosability.tables import diagnosability_table

__all__ = [
    "WindowModel",
    "StackedWindow",
    "DiagnosabilityTable",
    "FaultApplicability",
    "ApplicabilityReport",
    "diagnosability_table",
    "plot_isolability",
    "BankDiagnosability",
    "bank_diagnosability",
    "bank_window_sweep",
    "StructuredIsolability",
    "bank_structured_isolability",
]


def __getattr__(name: str):
    # the figure lives in the plotting layer, loaded on first use (no cycle with it)
    if name == "plot_isolability":
        from geomfdi.plotting.diagnosability import plot_isolability

        return plot_isolability
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
