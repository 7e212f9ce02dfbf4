"""geomfdi: model-based fault detection and isolation.

Geometric residual-generator synthesis (minimal conditioned-invariant and
unobservability subspaces), simulation of sensor faults, parity-space FDI for redundant
sensors, quantitative diagnosability indices and AR-model innovation monitoring.

Use as ``import geomfdi as gf``. The package follows the data path of a design::

    geomfdi.model          plants and faults
    geomfdi.geometry       subspaces, W*, S* (numeric and exact)
    geomfdi.generators     residual generators and banks, bank files, sampling; H∞ norm and
                           H₋ index of a system
    geomfdi.synthesis      design front end, least-order rows, exact and approximate design
    geomfdi.verification   numeric and symbolic proofs on the physical plant; the
                           fault-to-noise gap
    geomfdi.simulation     fault signals, LTI core, closed loop
    geomfdi.evaluation     thresholds, alarms, isolation
    geomfdi.deployment     recorded and live evaluation, generated code
    geomfdi.campaign       Monte-Carlo campaigns
    geomfdi.parity         redundant sensors (parity space)
    geomfdi.diagnosability KL and directional indices
    geomfdi.monitoring     AR-model innovation monitoring
    geomfdi.io             model files and the command line
    geomfdi.data           test models (a 32-state aircraft)
    geomfdi.plotting       figures

The layers and what each may import: ``docs/architecture.md``.

Public names are loaded on first use (``gf.design_bank`` imports the synthesis
subpackage, not the simulator), so ``import geomfdi`` stays cheap.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from geomfdi._moved import install as _moved_install

__version__ = "0.1.0"

# old module paths (``geomfdi.synthesis.generator``, ...) import with a DeprecationWarning
_moved_install()

# public name -> module that defines it
_NAMES: dict[str, str] = {}


def _register(module: str, *names: str) -> None:
    for name in names:
        _NAMES[name] = module


_register("geomfdi._threads", "get_blas_threads", "set_blas_threads")
_register("geomfdi.campaign.executors", "local_dask_client")
_register("geomfdi.campaign.result", "CampaignResult")
_register("geomfdi.campaign.runner", "Campaign")
_register("geomfdi.campaign.spec", "Scenario", "Uncertainty")
_register("geomfdi.data.aircraft", "aircraft_model")
_register("geomfdi.data.flight_actuators", "flight_actuator_case_study", "FlightActuatorCaseStudy")
_register("geomfdi.data.mass_spring_chain", "mass_spring_chain")
_register("geomfdi.data.three_tank", "three_tank_model")
_register("geomfdi.deployment.monitor", "Monitor")
_register("geomfdi.deployment.persistence", "load_bank", "load_monitor")
_register("geomfdi.deployment.recorded", "evaluate")
_register(
    "geomfdi.diagnosability.bank",
    "BankDiagnosability",
    "StructuredIsolability",
    "bank_diagnosability",
    "bank_structured_isolability",
    "bank_window_sweep",
)
_register("geomfdi.diagnosability.model", "WindowModel")
_register(
    "geomfdi.diagnosability.results",
    "ApplicabilityReport",
    "DiagnosabilityTable",
    "FaultApplicability",
    "StackedWindow",
)
_register("geomfdi.diagnosability.tables", "diagnosability_table")
_register("geomfdi.errors", "IsolabilityWarning", "BackendFallbackWarning")
_register(
    "geomfdi.evaluation.covariance",
    "ResidualNoiseModel",
    "residual_noise_model",
    "residual_noise_models",
)
_register("geomfdi.evaluation.decision", "FaultEvent", "Threshold", "isolate", "fault_hypotheses")
_register("geomfdi.evaluation.gap_threshold", "GapThreshold", "gap_threshold")
_register("geomfdi.evaluation.metrics", "DetectionMetrics")
_register("geomfdi.evaluation.persistence", "Persistence")
_register("geomfdi.evaluation.roc", "roc_curve", "wilson_interval")
_register(
    "geomfdi.evaluation.statistics",
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
)
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
_register("geomfdi.model.faults", "ActuatorFault", "Fault", "SensorFault")
_register("geomfdi.model.plant", "Plant")
_register(
    "geomfdi.monitoring.baselines",
    "BaselineResult",
    "coefficient_t2",
    "innovation_chi2",
    "innovation_cusum",
    "innovation_glr",
    "latch_alarms",
)
_register("geomfdi.monitoring.innovations", "innovation_fault", "synthetic_innovations")
_register("geomfdi.monitoring.kalman", "KalmanInnovations", "kalman_innovations")
_register("geomfdi.monitoring.monitor", "ARMonitor")
_register("geomfdi.monitoring.results", "ARMonitorResult", "ARMonitorWarning", "ARStep")
_register("geomfdi.parity.estimation", "FaultEstimate", "StateEstimate")
_register("geomfdi.parity.model", "ParityFDI")
_register("geomfdi.parity.montecarlo", "RocCurve")
_register("geomfdi.parity.results", "ParityDiagnosis")
_register("geomfdi.plotting.curves", "plot_confusion", "plot_detection", "plot_roc")
_register("geomfdi.plotting.diagnosability", "plot_isolability")
_register("geomfdi.plotting.monitoring", "plot_ar_monitor")
_register("geomfdi.plotting.residuals", "plot_residuals", "plot_structure", "save_png")
_register("geomfdi.simulation.batch", "simulate_batch")
_register("geomfdi.simulation.calibration", "calibrate_threshold")
_register("geomfdi.simulation.initial_state", "InitialStateWarning")
_register("geomfdi.simulation.nonlinear", "DivergenceWarning")
_register(
    "geomfdi.simulation.input_faults",
    "ActuatorBiasFault",
    "ActuatorGainFault",
    "ActuatorStuckFault",
    "AdditiveFault",
)
_register("geomfdi.simulation.lti", "simulate_lti")
_register("geomfdi.simulation.noise", "Noise")
_register("geomfdi.simulation.results", "BatchResult", "SimulationResult")
_register(
    "geomfdi.simulation.signals",
    "BiasFault",
    "FaultSignal",
    "GainFault",
    "SensorFaultSignal",
    "StuckFault",
    "apply_faults",
)
_register("geomfdi.simulation.simulate", "simulate")
_register("geomfdi.synthesis.approximate.estimation", "design_fault_estimator")
_register(
    "geomfdi.synthesis.design", "design_bank", "design_residual_generator", "design_sensor_bank"
)
_register(
    "geomfdi.generators.exact",
    "ExactResidualBank",
    "ExactResidualGenerator",
    "ExceptionalCondition",
)
_register("geomfdi.generators.generator", "ResidualBank", "ResidualGenerator")
_register(
    "geomfdi.generators.norms",
    "HinfNorm",
    "HminusIndex",
    "UnstableSystemError",
    "hinf_norm",
    "hminus_index",
    "peak_gain",
)
_register("geomfdi.generators.realization", "minimal_realization", "reachable_subspace")
_register("geomfdi.synthesis.sensor_transforms", "pseudo_actuator_model")
_register(
    "geomfdi.synthesis.specification.isolability",
    "IsolabilityReport",
    "isolability_analysis",
)
_register("geomfdi.synthesis.specification.orders", "structure_orders")
_register(
    "geomfdi.synthesis.specification.signatures",
    "AchievableSignatures",
    "achievable_signatures",
    "achievable_structures",
)
_register("geomfdi.tolerance", "CloseRankWarning", "set_rtol")
_register("geomfdi.verification.gap", "FaultToNoiseGap", "fault_to_noise_gap")
_register("geomfdi.verification.numeric", "VerificationReport", "verify")
_register("geomfdi.verification.symbolic", "SymbolicReport", "verify_symbolic")

# public modules (``gf.parity.dodecahedron()``, ``gf.exact.kernel(...)``); the old flat
# names stay as aliases of the modules that now hold them.
_MODULES: dict[str, str] = {
    "errors": "geomfdi.errors",
    "tolerance": "geomfdi.tolerance",
    "exact": "geomfdi.geometry.exact",
    "decision": "geomfdi.evaluation.decision",
    "lti_sim": "geomfdi.simulation.lti",
    "plotting": "geomfdi.plotting",
    "parity": "geomfdi.parity",
    "model": "geomfdi.model",
    "geometry": "geomfdi.geometry",
    "synthesis": "geomfdi.synthesis",
    "generators": "geomfdi.generators",
    "data": "geomfdi.data",
    "verification": "geomfdi.verification",
    "simulation": "geomfdi.simulation",
    "evaluation": "geomfdi.evaluation",
    "diagnosability": "geomfdi.diagnosability",
    "monitoring": "geomfdi.monitoring",
    "io": "geomfdi.io",
    "plant": "geomfdi.model.plant",
    "faults": "geomfdi.model.faults",
    "subspace": "geomfdi.geometry.subspace",
    "conditioned_invariant": "geomfdi.geometry.conditioned_invariant",
    "unobservability": "geomfdi.geometry.unobservability",
    "transforms": "geomfdi.synthesis.sensor_transforms",
    "generator": "geomfdi.generators.generator",
    "realization": "geomfdi.generators.realization",
    "fault_signals": "geomfdi.simulation.signals",
    "parity_configs": "geomfdi.parity.configs",
    "armonitor": "geomfdi.monitoring.ar",
    "innovations": "geomfdi.monitoring.innovations",
    "modelfile": "geomfdi.io.modelfile",
    "expressions": "geomfdi.io.expressions",
    "cli": "geomfdi.io.cli",
    "campaign": "geomfdi.campaign",
    "codegen": "geomfdi.deployment.codegen",
    "deployment": "geomfdi.deployment",
    "limits": "geomfdi.limits",
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
    from geomfdi import errors, tolerance  # noqa: F401
    from geomfdi._threads import get_blas_threads, set_blas_threads  # noqa: F401
    from geomfdi.campaign.executors import local_dask_client  # noqa: F401
    from geomfdi.campaign.result import CampaignResult  # noqa: F401
    from geomfdi.campaign.runner import Campaign  # noqa: F401
    from geomfdi.campaign.spec import Scenario, Uncertainty  # noqa: F401
    from geomfdi.data.aircraft import aircraft_model  # noqa: F401
    from geomfdi.data.flight_actuators import (  # noqa: F401
        FlightActuatorCaseStudy,
        flight_actuator_case_study,
    )
    from geomfdi.data.mass_spring_chain import mass_spring_chain  # noqa: F401
    from geomfdi.data.three_tank import three_tank_model  # noqa: F401
    from geomfdi.deployment.monitor import Monitor  # noqa: F401
    from geomfdi.deployment.persistence import load_bank, load_monitor  # noqa: F401
    from geomfdi.deployment.recorded import evaluate  # noqa: F401
    from geomfdi.diagnosability.bank import (  # noqa: F401
        BankDiagnosability,
        StructuredIsolability,
        bank_diagnosability,
        bank_structured_isolability,
        bank_window_sweep,
    )
    from geomfdi.diagnosability.model import WindowModel  # noqa: F401
    from geomfdi.diagnosability.results import (
        ApplicabilityReport,
        DiagnosabilityTable,
        FaultApplicability,
        StackedWindow,
    )  # noqa: F401
    from geomfdi.diagnosability.tables import diagnosability_table  # noqa: F401
    from geomfdi.errors import BackendFallbackWarning, IsolabilityWarning  # noqa: F401
    from geomfdi.evaluation.covariance import (
        ResidualNoiseModel,
        residual_noise_model,
        residual_noise_models,
    )  # noqa: F401
    from geomfdi.evaluation.decision import (  # noqa: F401
        FaultEvent,
        Threshold,
        fault_hypotheses,
        isolate,
    )
    from geomfdi.evaluation.gap_threshold import GapThreshold, gap_threshold  # noqa: F401
    from geomfdi.evaluation.metrics import DetectionMetrics  # noqa: F401
    from geomfdi.evaluation.persistence import Persistence  # noqa: F401
    from geomfdi.evaluation.roc import roc_curve, wilson_interval  # noqa: F401
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
    )  # noqa: F401
    from geomfdi.geometry.conditioned_invariant import (
        FriendSet,
        InvariantSubspace,
        friend,
        friends,
        is_conditioned_invariant,
        min_conditioned_invariant,
    )  # noqa: F401
    from geomfdi.geometry.subspace import Subspace, apply, image, kernel, preimage, principal_angles  # noqa: F401
    from geomfdi.geometry.unobservability import (
        is_unobservability_subspace,
        measurement_map,
        min_unobservability_subspace,
        unobservable_subspace,
    )  # noqa: F401
    from geomfdi.model.faults import ActuatorFault, Fault, SensorFault  # noqa: F401
    from geomfdi.model.plant import Plant  # noqa: F401
    from geomfdi.monitoring.baselines import (
        BaselineResult,
        coefficient_t2,
        innovation_chi2,
        innovation_cusum,
        innovation_glr,
        latch_alarms,
    )  # noqa: F401
    from geomfdi.monitoring.innovations import innovation_fault, synthetic_innovations  # noqa: F401
    from geomfdi.monitoring.kalman import KalmanInnovations, kalman_innovations  # noqa: F401
    from geomfdi.monitoring.monitor import ARMonitor  # noqa: F401
    from geomfdi.monitoring.results import ARMonitorResult, ARMonitorWarning, ARStep  # noqa: F401
    from geomfdi.parity.estimation import FaultEstimate, StateEstimate  # noqa: F401
    from geomfdi.parity.model import ParityFDI  # noqa: F401
    from geomfdi.parity.montecarlo import RocCurve  # noqa: F401
    from geomfdi.parity.results import ParityDiagnosis  # noqa: F401
    from geomfdi.plotting.curves import plot_confusion, plot_detection, plot_roc  # noqa: F401
    from geomfdi.plotting.diagnosability import plot_isolability  # noqa: F401
    from geomfdi.plotting.monitoring import plot_ar_monitor  # noqa: F401
    from geomfdi.plotting.residuals import plot_residuals, plot_structure, save_png  # noqa: F401
    from geomfdi.simulation.batch import simulate_batch  # noqa: F401
    from geomfdi.simulation.calibration import calibrate_threshold  # noqa: F401
    from geomfdi.simulation.initial_state import InitialStateWarning
    from geomfdi.simulation.nonlinear import DivergenceWarning  # noqa: F401
    from geomfdi.simulation.input_faults import (
        ActuatorBiasFault,
        ActuatorGainFault,
        ActuatorStuckFault,
        AdditiveFault,
    )  # noqa: F401
    from geomfdi.simulation.lti import simulate_lti  # noqa: F401
    from geomfdi.simulation.noise import Noise  # noqa: F401
    from geomfdi.simulation.results import BatchResult, SimulationResult  # noqa: F401
    from geomfdi.simulation.signals import (
        BiasFault,
        FaultSignal,
        GainFault,
        SensorFaultSignal,
        StuckFault,
        apply_faults,
    )  # noqa: F401
    from geomfdi.simulation.simulate import simulate  # noqa: F401
    from geomfdi.synthesis.approximate.estimation import design_fault_estimator  # noqa: F401
    from geomfdi.synthesis.design import design_bank, design_residual_generator, design_sensor_bank  # noqa: F401
    from geomfdi.generators.exact import (
        ExactResidualBank,
        ExactResidualGenerator,
        ExceptionalCondition,
    )  # noqa: F401
    from geomfdi.generators.generator import ResidualBank, ResidualGenerator  # noqa: F401
    from geomfdi.generators.norms import (  # noqa: F401
        HinfNorm,
        HminusIndex,
        UnstableSystemError,
        hinf_norm,
        hminus_index,
        peak_gain,
    )
    from geomfdi.generators.realization import minimal_realization, reachable_subspace  # noqa: F401
    from geomfdi.synthesis.sensor_transforms import pseudo_actuator_model  # noqa: F401
    from geomfdi.synthesis.specification.isolability import (  # noqa: F401
        IsolabilityReport,
        isolability_analysis,
    )
    from geomfdi.synthesis.specification.orders import structure_orders  # noqa: F401
    from geomfdi.synthesis.specification.signatures import (  # noqa: F401
        AchievableSignatures,
        achievable_signatures,
        achievable_structures,
    )
    from geomfdi.tolerance import CloseRankWarning, set_rtol  # noqa: F401
    from geomfdi.verification.gap import FaultToNoiseGap, fault_to_noise_gap  # noqa: F401
    from geomfdi.verification.numeric import VerificationReport, verify  # noqa: F401
    from geomfdi.verification.symbolic import SymbolicReport, verify_symbolic  # noqa: F401
