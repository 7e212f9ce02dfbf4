"""geomfdi: model-based fault detection and isolation.

Geometric residual-generator synthesis (minimal conditioned-invariant and
unobservability subspaces), simulation of sensor faults, parity-space FDI for redundant
sensors, quantitative diagnosability indices and AR-model innovation monitoring.

Use as ``import geomfdi as gf``.
"""

from __future__ import annotations

from . import errors, tolerance
from .faults import ActuatorFault, Fault, SensorFault
from .generator import ResidualBank, ResidualGenerator
from .plant import Plant
from .tolerance import CloseRankWarning, set_rtol

# --- geometry (subspace.py, conditioned_invariant.py, unobservability.py, exact.py) ---
from . import exact
from .conditioned_invariant import (
    FriendSet,
    InvariantSubspace,
    friend,
    friends,
    is_conditioned_invariant,
    min_conditioned_invariant,
)
from .subspace import Subspace, apply, image, kernel, preimage, principal_angles
from .unobservability import (
    is_unobservability_subspace,
    measurement_map,
    min_unobservability_subspace,
    unobservable_subspace,
)

# --- synthesis and verification (transforms.py, synthesis.py, verification.py) ---
from .realization import minimal_realization, reachable_subspace
from .synthesis import design_bank, design_residual_generator, design_sensor_bank
from .transforms import pseudo_actuator_model
from .verification import SymbolicReport, VerificationReport, verify, verify_symbolic

# --- simulation (fault_signals.py, simulation.py, decision.py, plotting.py) ---
from . import decision, lti_sim, plotting
from .decision import FaultEvent, Threshold, calibrate_threshold, isolate
from .fault_signals import BiasFault, GainFault, SensorFaultSignal, StuckFault, apply_faults
from .lti_sim import simulate_lti
from .plotting import plot_residuals, plot_structure, save_png
from .simulation import (
    BatchResult,
    InitialStateWarning,
    Noise,
    SimulationResult,
    simulate,
    simulate_batch,
)

# --- parity space (parity.py) ---
from . import parity
from .parity import ParityDiagnosis, ParityFDI

# --- diagnosability (diagnosability.py) ---
from .diagnosability import (
    ApplicabilityReport,
    DiagnosabilityTable,
    FaultApplicability,
    StackedWindow,
    WindowModel,
    diagnosability_table,
    plot_isolability,
)

# --- AR-model monitor (armonitor.py) ---
from .armonitor import ARMonitor, ARMonitorResult, ARMonitorWarning, ARStep, plot_ar_monitor
from .innovations import innovation_fault, synthetic_innovations

__version__ = "0.1.0"
