"""AR-model innovation monitoring (sliding-window AR fits with a chi-square test)."""

from geomfdi.monitoring.ar import (
    ARMonitor,
    ARMonitorResult,
    ARMonitorWarning,
    ARStep,
    plot_ar_monitor,
)
from geomfdi.monitoring.innovations import innovation_fault, synthetic_innovations

__all__ = [
    "ARMonitor",
    "ARMonitorResult",
    "ARMonitorWarning",
    "ARStep",
    "plot_ar_monitor",
    "innovation_fault",
    "synthetic_innovations",
]
