"""Parity-space FDI for redundant sensors (GLT, optimal parity vectors, two-fault isolation).

* :mod:`~geomfdi.parity.fdi` -- :class:`ParityFDI` and the Monte-Carlo rates.
* :mod:`~geomfdi.parity.configs` -- sensor configurations (dodecahedron, cones, ...).
"""

from geomfdi.parity.configs import MAGIC_HALF_ANGLE, axis_cosines, cone, dodecahedron, tetrahedron
from geomfdi.parity.fdi import (
    ConfigurationCapability,
    IsolationRates,
    ParityDiagnosis,
    ParityFDI,
    RateCurve,
    RateEstimate,
    Seed004Result,
    chi2_threshold,
    correct_isolation_rate,
    false_alarm_rate,
    normal_threshold,
    opt_false_alarm_bound,
    plot_rates,
    rates_vs_fault_size,
    seed004_experiment,
    simulate,
)

__all__ = [
    "ParityFDI",
    "ParityDiagnosis",
    "ConfigurationCapability",
    "RateEstimate",
    "IsolationRates",
    "RateCurve",
    "Seed004Result",
    "chi2_threshold",
    "normal_threshold",
    "opt_false_alarm_bound",
    "simulate",
    "false_alarm_rate",
    "correct_isolation_rate",
    "rates_vs_fault_size",
    "plot_rates",
    "seed004_experiment",
    "dodecahedron",
    "cone",
    "tetrahedron",
    "axis_cosines",
    "MAGIC_HALF_ANGLE",
]
