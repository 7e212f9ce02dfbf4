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

# --- simulation (fault_signals.py, simulation.py, decision.py, plotting.py) ---

# --- parity space (parity.py) ---

# --- diagnosability (diagnosability.py) ---

# --- AR-model monitor (armonitor.py) ---

__version__ = "0.1.0"
