"""Former home of the parity-space code, kept so that ``geomfdi.parity.fdi`` imports work.

The implementation is split by concept: :mod:`~geomfdi.parity.model` (the
:class:`ParityFDI` object), :mod:`~geomfdi.parity.glt`, :mod:`~geomfdi.parity.opt`,
:mod:`~geomfdi.parity.multiple`, :mod:`~geomfdi.parity.decision`,
:mod:`~geomfdi.parity.montecarlo`, :mod:`~geomfdi.parity.dodecahedron_experiment`,
:mod:`~geomfdi.parity.results`, :mod:`~geomfdi.parity.thresholds`, and the figures in
:mod:`geomfdi.plotting.parity`.
"""

from geomfdi._moved import renamed as _renamed
from geomfdi.parity.configs import MAGIC_HALF_ANGLE, cone, dodecahedron, tetrahedron
from geomfdi.parity.decision import METHODS
from geomfdi.parity.dodecahedron_experiment import qin_niu_experiment
from geomfdi.parity.model import ParityFDI
from geomfdi.parity.montecarlo import (
    correct_isolation_rate,
    false_alarm_rate,
    rates_vs_fault_size,
    simulate,
)
from geomfdi.parity.results import (
    ConfigurationCapability,
    IsolationRates,
    ParityDiagnosis,
    QinNiuResult,
    RateCurve,
    RateEstimate,
)
from geomfdi.parity.thresholds import chi2_threshold, normal_threshold, opt_false_alarm_bound
from geomfdi.plotting.parity import plot_rates

__all__ = [
    "ParityFDI",
    "ParityDiagnosis",
    "ConfigurationCapability",
    "RateEstimate",
    "IsolationRates",
    "RateCurve",
    "QinNiuResult",
    "METHODS",
    "chi2_threshold",
    "normal_threshold",
    "opt_false_alarm_bound",
    "dodecahedron",
    "cone",
    "tetrahedron",
    "MAGIC_HALF_ANGLE",
    "simulate",
    "false_alarm_rate",
    "correct_isolation_rate",
    "rates_vs_fault_size",
    "qin_niu_experiment",
    "plot_rates",
]

__getattr__ = _renamed(__name__)  # the old names of the Qin & Niu experiment, deprecated
