"""Residual evaluation and decisions: thresholds, alarms, isolation, persistence, metrics."""

from geomfdi.evaluation.decision import FaultEvent, Threshold, isolate
from geomfdi.evaluation.metrics import DetectionMetrics
from geomfdi.evaluation.persistence import Persistence

__all__ = ["Threshold", "FaultEvent", "isolate", "Persistence", "DetectionMetrics"]
