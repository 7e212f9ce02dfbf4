"""AR-model innovation monitoring (sliding-window AR fits with a chi-square test) and
baselines on the same innovations (chi-square, CUSUM, GLR of the mean, joint T^2).

* :mod:`~geomfdi.monitoring.monitor` -- :class:`ARMonitor`;
* :mod:`~geomfdi.monitoring.training`, :mod:`~geomfdi.monitoring.batch`,
  :mod:`~geomfdi.monitoring.streaming` -- its training, batch and streaming functions
  (they take the monitor's settings and null model as frozen records, never the object);
* :mod:`~geomfdi.monitoring.baselines` -- innovation tests and alarm latching;
* :mod:`~geomfdi.monitoring.kalman` -- innovations of a Kalman filter in the loop;
* :mod:`~geomfdi.monitoring.innovations` -- synthetic innovation sequences;
* the figure in :mod:`geomfdi.plotting.monitoring`.

See the user guide, *Theory: AR monitoring* (``docs/theory/ar-monitoring.md``).

Layer: a side branch on innovations as arrays.  It may import the base modules,
:mod:`geomfdi.simulation` (Kalman-filter innovations of a plant) and, inside functions,
:mod:`geomfdi.plotting`.
"""

from geomfdi.monitoring.baselines import (
    BaselineResult,
    coefficient_t2,
    innovation_chi2,
    innovation_cusum,
    innovation_glr,
    latch_alarms,
)
from geomfdi.monitoring.innovations import innovation_fault, synthetic_innovations
from geomfdi.monitoring.kalman import KalmanInnovations, kalman_innovations
from geomfdi.monitoring.monitor import ARMonitor
from geomfdi.monitoring.results import ARMonitorResult, ARMonitorWarning, ARStep
from geomfdi.plotting.monitoring import plot_ar_monitor

__all__ = [
    "ARMonitor",
    "ARMonitorResult",
    "ARMonitorWarning",
    "ARStep",
    "plot_ar_monitor",
    "innovation_fault",
    "synthetic_innovations",
    "BaselineResult",
    "innovation_chi2",
    "innovation_cusum",
    "innovation_glr",
    "coefficient_t2",
    "latch_alarms",
    "KalmanInnovations",
    "kalman_innovations",
]
