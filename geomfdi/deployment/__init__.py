"""Deployment of residual banks: evaluation on recorded and live data, save/load, code.

``evaluate`` (recorded data), ``Monitor`` (sample by sample), ``discretize_bank``
(``bank.discretize``), ``save_bank`` / ``load_bank`` / ``save_monitor`` /
``load_monitor`` (versioned JSON) and the ``codegen`` module (C99 and Python).  See the
user guide, *Theory: residual evaluation* (``docs/theory/evaluation.md``).

Layer: above simulation and evaluation.  It may import :mod:`geomfdi.model`,
:mod:`geomfdi.generators` (the bank types and file format), :mod:`geomfdi.simulation`,
:mod:`geomfdi.evaluation` and, inside functions, :mod:`geomfdi.plotting`; never the
synthesis (a bank is designed elsewhere and handed over).
"""

from geomfdi.deployment.monitor import Monitor, MonitorOutput, MonitorStep
from geomfdi.deployment.persistence import load_bank, load_monitor, save_bank, save_monitor
from geomfdi.deployment.recorded import AlarmEpisode, EvaluationResult, evaluate
from geomfdi.evaluation.persistence import Persistence
from geomfdi.generators.discretize import discretize_bank

__all__ = [
    "AlarmEpisode",
    "EvaluationResult",
    "Monitor",
    "MonitorOutput",
    "MonitorStep",
    "Persistence",
    "discretize_bank",
    "evaluate",
    "load_bank",
    "load_monitor",
    "save_bank",
    "save_monitor",
]
