"""geomfdi: model-based fault detection and isolation.

Geometric residual-generator synthesis (minimal conditioned-invariant and
unobservability subspaces), simulation of sensor faults, parity-space FDI for redundant
sensors, quantitative diagnosability indices and AR-model innovation monitoring.

Use as ``import geomfdi as gf``. The package follows the data path of a design::

    geomfdi.model          plants and faults
    geomfdi.geometry       subspaces, W*, S* (numeric and exact)
    geomfdi.synthesis      transforms, construction, generators and banks
    geomfdi.verification   numeric and symbolic proofs on the physical plant
    geomfdi.simulation     fault signals, LTI core, closed loop
    geomfdi.evaluation     thresholds, alarms, isolation
    geomfdi.parity         redundant sensors (parity space)
    geomfdi.diagnosability KL and directional indices
    geomfdi.monitoring     AR-model innovation monitoring
    geomfdi.io             model files and the command line
    geomfdi.plotting       figures

Public names are loaded on first use (``gf.design_bank`` imports the synthesis
subpackage, not the simulator), so ``import geomfdi`` stays cheap.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

# public name -> module that defines it
_NAMES: dict[str, str] = {}


def _register(module: str, *names: str) -> None:
    for name in names:
        _NAMES[name] = module


_register("geomfdi.model.faults", "ActuatorFault", "Fault", "SensorFault")
_register("geomfdi.model.plant", "Plant")
_register("geomfdi.tolerance", "CloseRankWarning", "set_rtol")
_register(
    "geomfdi.geometry.conditioned_invariant",
    "FriendSet",
    "InvariantSubspace",
    "friend",
    "friends",
    "is_conditioned_invariant",
    "min_conditioned_invariant",
)
_register(
    "geomfdi.geometry.subspace",
    "Subspace",
    "apply",
    "image",
    "kernel",
    "preimage",
    "principal_angles",
)
_register(
    "geomfdi.geometry.unobservability",
    "is_unobservability_subspace",
    "measurement_map",
    "min_unobservability_subspace",
    "unobservable_subspace",
)
_register("geomfdi.synthesis.realization", "minimal_realization", "reachable_subspace")
_register(
    "geomfdi.synthesis.design", "design_bank", "design_residual_generator", "design_sensor_bank"
)
_register("geomfdi.synthesis.generator", "ResidualBank", "ResidualGenerator")
_register("geomfdi.synthesis.transforms", "pseudo_actuator_model")
_register("geomfdi.verification.numeric", "VerificationReport", "verify")
_register("geomfdi.verification.symbolic", "SymbolicReport", "verify_symbolic")
_register(
    "geomfdi.evaluation.decision", "FaultEvent", "Threshold", "calibrate_threshold", "isolate"
)
_register(
    "geomfdi.simulation.signals",
    "BiasFault",
    "GainFault",
    "SensorFaultSignal",
    "StuckFault",
    "apply_faults",
)
_register("geomfdi.simulation.lti", "simulate_lti")
_register("geomfdi.plotting.residuals", "plot_residuals", "plot_structure", "save_png")
_register(
    "geomfdi.simulation.simulate",
    "BatchResult",
    "InitialStateWarning",
    "Noise",
    "SimulationResult",
    "simulate",
    "simulate_batch",
)
_register("geomfdi.parity.fdi", "ParityDiagnosis", "ParityFDI")
_register(
    "geomfdi.diagnosability.window",
    "ApplicabilityReport",
    "DiagnosabilityTable",
    "FaultApplicability",
    "StackedWindow",
    "WindowModel",
    "diagnosability_table",
    "plot_isolability",
)
_register(
    "geomfdi.monitoring.ar",
    "ARMonitor",
    "ARMonitorResult",
    "ARMonitorWarning",
    "ARStep",
    "plot_ar_monitor",
)
_register("geomfdi.monitoring.innovations", "innovation_fault", "synthetic_innovations")

# public modules (``gf.parity.dodecahedron()``, ``gf.exact.kernel(...)``); the old flat
# names stay as aliases of the modules that now hold them.
_MODULES: dict[str, str] = {
    "errors": "geomfdi.errors",
    "tolerance": "geomfdi.tolerance",
    "limits": "geomfdi.limits",
    "exact": "geomfdi.geometry.exact",
    "decision": "geomfdi.evaluation.decision",
    "lti_sim": "geomfdi.simulation.lti",
    "plotting": "geomfdi.plotting",
    "parity": "geomfdi.parity",
    "model": "geomfdi.model",
    "geometry": "geomfdi.geometry",
    "synthesis": "geomfdi.synthesis",
    "verification": "geomfdi.verification",
    "simulation": "geomfdi.simulation",
    "evaluation": "geomfdi.evaluation",
    "diagnosability": "geomfdi.diagnosability",
    "monitoring": "geomfdi.monitoring",
    "io": "geomfdi.io",
    # the flat module names of earlier releases
    "plant": "geomfdi.model.plant",
    "faults": "geomfdi.model.faults",
    "subspace": "geomfdi.geometry.subspace",
    "conditioned_invariant": "geomfdi.geometry.conditioned_invariant",
    "unobservability": "geomfdi.geometry.unobservability",
    "transforms": "geomfdi.synthesis.transforms",
    "generator": "geomfdi.synthesis.generator",
    "realization": "geomfdi.synthesis.realization",
    "fault_signals": "geomfdi.simulation.signals",
    "parity_configs": "geomfdi.parity.configs",
    "armonitor": "geomfdi.monitoring.ar",
    "innovations": "geomfdi.monitoring.innovations",
    "modelfile": "geomfdi.io.modelfile",
    "expressions": "geomfdi.io.expressions",
    "cli": "geomfdi.io.cli",
}

__all__ = sorted([*_NAMES, *_MODULES, "__version__"])


def __getattr__(name: str) -> Any:
    if name in _NAMES:
        value = getattr(importlib.import_module(_NAMES[name]), name)
    elif name in _MODULES:
        value = importlib.import_module(_MODULES[name])
    else:
        raise AttributeError(f"module 'geomfdi' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return __all__


if TYPE_CHECKING:  # static analysers and IDEs see every public name
    from geomfdi import errors, limits, tolerance  # noqa: F401
    from geomfdi.diagnosability.window import (  # noqa: F401
        ApplicabilityReport,
        DiagnosabilityTable,
        FaultApplicability,
        StackedWindow,
        WindowModel,
        diagnosability_table,
        plot_isolability,
    )
    from geomfdi.evaluation.decision import (  # noqa: F401
        FaultEvent,
        Threshold,
        calibrate_threshold,
        isolate,
    )
    from geomfdi.geometry.conditioned_invariant import (  # noqa: F401
        FriendSet,
        InvariantSubspace,
        friend,
        friends,
        is_conditioned_invariant,
        min_conditioned_invariant,
    )
    from geomfdi.geometry.subspace import (  # noqa: F401
        Subspace,
        apply,
        image,
        kernel,
        preimage,
        principal_angles,
    )
    from geomfdi.geometry.unobservability import (  # noqa: F401
        is_unobservability_subspace,
        measurement_map,
        min_unobservability_subspace,
        unobservable_subspace,
    )
    from geomfdi.model.faults import ActuatorFault, Fault, SensorFault  # noqa: F401
    from geomfdi.model.plant import Plant  # noqa: F401
    from geomfdi.monitoring.ar import (  # noqa: F401
        ARMonitor,
        ARMonitorResult,
        ARMonitorWarning,
        ARStep,
        plot_ar_monitor,
    )
    from geomfdi.monitoring.innovations import innovation_fault, synthetic_innovations  # noqa: F401
    from geomfdi.parity.fdi import ParityDiagnosis, ParityFDI  # noqa: F401
    from geomfdi.plotting.residuals import plot_residuals, plot_structure, save_png  # noqa: F401
    from geomfdi.simulation.lti import simulate_lti  # noqa: F401
    from geomfdi.simulation.signals import (  # noqa: F401
        BiasFault,
        GainFault,
        SensorFaultSignal,
        StuckFault,
        apply_faults,
    )
    from geomfdi.simulation.simulate import (  # noqa: F401
        BatchResult,
        InitialStateWarning,
        Noise,
        SimulationResult,
        simulate,
        simulate_batch,
    )
    from geomfdi.synthesis.design import (  # noqa: F401
        design_bank,
        design_residual_generator,
        design_sensor_bank,
    )
    from geomfdi.synthesis.generator import ResidualBank, ResidualGenerator  # noqa: F401
    from geomfdi.synthesis.realization import minimal_realization, reachable_subspace  # noqa: F401
    from geomfdi.synthesis.transforms import pseudo_actuator_model  # noqa: F401
    from geomfdi.verification.numeric import VerificationReport, verify  # noqa: F401
    from geomfdi.verification.symbolic import SymbolicReport, verify_symbolic  # noqa: F401
