"""Residual evaluation and decisions: thresholds, alarms, isolation, detection events."""

from geomfdi.evaluation.decision import FaultEvent, Threshold, isolate

__all__ = ["Threshold", "FaultEvent", "isolate"]
