"""Parity-space FDI for redundant sensors (GLT, optimal parity vectors, two-fault isolation).

* :mod:`~geomfdi.parity.model` -- :class:`ParityFDI`, the model object; it passes its
  frozen ``ParityData`` record (built in ``parity._construction``) to the functions below,
  which never import the object;
* :mod:`~geomfdi.parity.diagnosis` -- detection and isolation by any rule;
* :mod:`~geomfdi.parity.glt`, :mod:`~geomfdi.parity.opt`, :mod:`~geomfdi.parity.multiple`
  -- the statistics; :mod:`~geomfdi.parity.decision` -- per-sample decisions;
* :mod:`~geomfdi.parity.capability` -- isolation capability of a configuration;
* :mod:`~geomfdi.parity.montecarlo`, :mod:`~geomfdi.parity.dodecahedron_experiment` --
  Monte-Carlo rates (the dodecahedron experiment of Qin & Niu 1999);
* :mod:`~geomfdi.parity.configs` -- sensor configurations (dodecahedron, cones, ...);
* figures in :mod:`geomfdi.plotting.parity`.

See the user guide, *Theory: parity space* (``docs/theory/parity-space.md``).

Layer: a side branch on measurements as arrays.  It may import the base modules and,
inside functions, :mod:`geomfdi.plotting`.
"""

from geomfdi._moved import renamed as _renamed
from geomfdi.parity.configs import (
    MAGIC_HALF_ANGLE,
    axis_cosines,
    cone,
    dodecahedron,
    from_angles,
    from_direction_cosines,
    misalignment_fault,
    scale_factor_fault,
    tetrahedron,
)
from geomfdi.parity.decision import METHODS
from geomfdi.parity.dodecahedron_experiment import qin_niu_experiment
from geomfdi.parity.estimation import FaultEstimate, StateEstimate, estimate_faults, estimate_state
from geomfdi.parity.model import ParityFDI
from geomfdi.parity.montecarlo import (
    RocCurve,
    correct_isolation_rate,
    false_alarm_rate,
    rates_vs_fault_size,
    roc_curves,
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
from geomfdi.parity.sequential import (
    SEQUENTIAL_METHODS,
    calibrate_sequential,
    cusum_statistic,
    window_sprt_statistic,
    windowed_statistic,
)
from geomfdi.parity.sprt import (
    SprtCalibration,
    calibrate_sprt,
    sprt_statistic,
    wald_boundaries,
    wald_rate,
)
from geomfdi.parity.thresholds import chi2_threshold, normal_threshold, opt_false_alarm_bound
from geomfdi.plotting.parity import plot_qin_niu, plot_rates, plot_roc

__all__ = [
    "ParityFDI",
    "ParityDiagnosis",
    "ConfigurationCapability",
    "RateEstimate",
    "IsolationRates",
    "RateCurve",
    "QinNiuResult",
    "chi2_threshold",
    "normal_threshold",
    "opt_false_alarm_bound",
    "simulate",
    "false_alarm_rate",
    "correct_isolation_rate",
    "rates_vs_fault_size",
    "plot_rates",
    "plot_qin_niu",
    "METHODS",
    "SEQUENTIAL_METHODS",
    "windowed_statistic",
    "cusum_statistic",
    "sprt_statistic",
    "window_sprt_statistic",
    "calibrate_sprt",
    "SprtCalibration",
    "wald_boundaries",
    "wald_rate",
    "calibrate_sequential",
    "FaultEstimate",
    "StateEstimate",
    "estimate_faults",
    "estimate_state",
    "qin_niu_experiment",
    "dodecahedron",
    "cone",
    "tetrahedron",
    "axis_cosines",
    "MAGIC_HALF_ANGLE",
    "from_direction_cosines",
    "from_angles",
    "scale_factor_fault",
    "misalignment_fault",
    "RocCurve",
    "roc_curves",
    "plot_roc",
]

__getattr__ = _renamed(__name__)  # the old names of the Qin & Niu experiment, deprecated
