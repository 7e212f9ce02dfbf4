"""Residual evaluation and decisions: thresholds, alarms, isolation, detection events."""

from geomfdi.evaluation.decision import FaultEvent, Threshold, calibrate_threshold, isolate

__all__ = ["Threshold", "FaultEvent", "isolate", "calibrate_threshold"]
