"""Verification of delivered generators on the physical plant, numeric and exact, and the
fault-to-noise gap of the approximate problems (with the system norms of
:mod:`geomfdi.generators.norms` re-exported: H∞ norm, H₋ index, peak-to-peak gain).

Layer: above :mod:`geomfdi.generators`.  It may import :mod:`geomfdi.model`,
:mod:`geomfdi.geometry` and :mod:`geomfdi.generators` (the generator types and their
transfer gains); never the design code of :mod:`geomfdi.synthesis`.
"""

from geomfdi.generators.norms import (
    HinfNorm,
    HminusIndex,
    UnstableSystemError,
    hinf_norm,
    hminus_index,
    peak_gain,
)
from geomfdi.verification.gap import FaultToNoiseGap, fault_to_noise_gap
from geomfdi.verification.numeric import VerificationReport, verify
from geomfdi.verification.symbolic import SymbolicReport, verify_symbolic

__all__ = [
    "verify",
    "verify_symbolic",
    "VerificationReport",
    "SymbolicReport",
    "fault_to_noise_gap",
    "FaultToNoiseGap",
    "hinf_norm",
    "hminus_index",
    "peak_gain",
    "HinfNorm",
    "HminusIndex",
    "UnstableSystemError",
]
