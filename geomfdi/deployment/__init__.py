"""Deployment of residual banks: evaluation on recorded and live data, save/load, code.

``evaluate`` (recorded data), ``Monitor`` (sample by sample), ``discretize_bank``,
``save_bank`` / ``load_bank`` / ``load_monitor`` (versioned JSON) and the ``codegen``
module (C99 and Python).
"""

from geomfdi.deployment.decide import Persistence
from geomfdi.deployment.recorded import AlarmEpisode, EvaluationResult, evaluate

__all__ = ["AlarmEpisode", "EvaluationResult", "Persistence", "evaluate"]
