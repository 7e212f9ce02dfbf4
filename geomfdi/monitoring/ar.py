"""Former home of the AR monitor, kept so that ``geomfdi.monitoring.ar`` imports work.

The implementation is split by concept: :mod:`~geomfdi.monitoring.monitor` (the
:class:`ARMonitor` object), :mod:`~geomfdi.monitoring.training`,
:mod:`~geomfdi.monitoring.batch`, :mod:`~geomfdi.monitoring.streaming`,
:mod:`~geomfdi.monitoring.results`, and the figure in :mod:`geomfdi.plotting.monitoring`.
"""

from geomfdi.monitoring._kernels import _moving_sums
from geomfdi.monitoring.monitor import ARMonitor
from geomfdi.monitoring.results import ARMonitorResult, ARMonitorWarning, ARStep
from geomfdi.plotting.monitoring import plot_ar_monitor

__all__ = ["ARMonitor", "ARMonitorResult", "ARMonitorWarning", "ARStep", "plot_ar_monitor"]
__all__ += ["_moving_sums"]  # used by the tests of the kernels
