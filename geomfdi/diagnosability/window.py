"""Former home of the window-model code, kept so that ``geomfdi.diagnosability.window``
imports work; the implementation is split by concept (see :mod:`geomfdi.diagnosability`).

Examples
--------
Model (23) of Li, Wang & Liu (2015), Table 1, first row:

>>> import geomfdi as gf
>>> dm = gf.WindowModel([[1, 1], [-1, 1]], [[0], [1]], [[1, 0], [1, 0]],
...                     Bf=[[0, 0, 0, 0], [1, 1, 0, 0]], Df=[[0, 0, 1, 0], [0, 0, 0, 1]],
...                     Bw=[[0], [1]], Qw=0.1, Rv=[1, 0.5])
>>> round(dm.kl_detectability(0, [1, 1, 1]), 4), round(dm.kl_isolability(0, 2, [1, 1, 1]), 4)
(0.1613, 0.1087)
"""

from geomfdi.diagnosability.model import WindowModel
from geomfdi.diagnosability.results import (
    ApplicabilityReport,
    DiagnosabilityTable,
    FaultApplicability,
    StackedWindow,
)
from geomfdi.diagnosability.tables import diagnosability_table
from geomfdi.plotting.diagnosability import plot_isolability

__all__ = [
    "WindowModel",
    "StackedWindow",
    "DiagnosabilityTable",
    "FaultApplicability",
    "ApplicabilityReport",
    "diagnosability_table",
    "plot_isolability",
]
