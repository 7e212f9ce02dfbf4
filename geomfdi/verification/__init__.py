"""Verification of delivered generators on the physical plant, numeric and exact.

Layer: above :mod:`geomfdi.generators`.  It may import :mod:`geomfdi.model`,
:mod:`geomfdi.geometry` and :mod:`geomfdi.generators` (the generator types and their
transfer gains); never the design code of :mod:`geomfdi.synthesis`.
"""

from geomfdi.verification.numeric import VerificationReport, verify
from geomfdi.verification.symbolic import SymbolicReport, verify_symbolic

__all__ = ["verify", "verify_symbolic", "VerificationReport", "SymbolicReport"]
