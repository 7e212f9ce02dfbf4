"""Residual evaluation and decisions: thresholds, alarms, isolation, tests, metrics, curves.

* :mod:`~geomfdi.evaluation.decision` -- fixed thresholds, alarms, isolation.
* :mod:`~geomfdi.evaluation.persistence` -- k-of-n confirmation, held patterns, decisions.
* :mod:`~geomfdi.evaluation.metrics` -- FAR, MDR, delays, isolation outcomes.
* :mod:`~geomfdi.evaluation.covariance` -- residual noise covariance (Stein equation).
* :mod:`~geomfdi.evaluation.gap_threshold` -- thresholds from the fault-to-noise gap.
* :mod:`~geomfdi.evaluation.statistics` -- windowed chi-square, CUSUM, GLR tests.
* :mod:`~geomfdi.evaluation.roc` -- ROC curves and binomial intervals.

Layer: beside simulation, on residuals as arrays.  It may import :mod:`geomfdi.model`
and the base modules; never generators, synthesis or simulation.
"""

from geomfdi.evaluation.covariance import (
    ResidualNoiseModel,
    residual_noise_model,
    residual_noise_models,
)
from geomfdi.evaluation.decision import FaultEvent, Threshold, fault_hypotheses, isolate
from geomfdi.evaluation.gap_threshold import GapThreshold, gap_threshold
from geomfdi.evaluation.metrics import DetectionMetrics
from geomfdi.evaluation.persistence import Persistence
from geomfdi.evaluation.roc import RocCurve, roc_curve, wilson_interval
from geomfdi.evaluation.statistics import (
    AbsTest,
    ChiSquareTest,
    CusumTest,
    GLRTest,
    calibrate_max,
    chi2_window_threshold,
    cusum,
    cusum_arl,
    glr,
    glr_threshold_bound,
    sum_variances,
    weighted_chi2_sf,
    window_covariance,
    windowed_sum_of_squares,
)

__all__ = [
    "Threshold",
    "FaultEvent",
    "isolate",
    "fault_hypotheses",
    "Persistence",
    "DetectionMetrics",
    "GapThreshold",
    "gap_threshold",
    "ResidualNoiseModel",
    "residual_noise_model",
    "residual_noise_models",
    "AbsTest",
    "ChiSquareTest",
    "CusumTest",
    "GLRTest",
    "calibrate_max",
    "chi2_window_threshold",
    "cusum",
    "cusum_arl",
    "glr",
    "glr_threshold_bound",
    "sum_variances",
    "weighted_chi2_sf",
    "window_covariance",
    "windowed_sum_of_squares",
    "RocCurve",
    "roc_curve",
    "wilson_interval",
]
