"""Verification of delivered generators on the physical plant, numeric and exact."""

from geomfdi.verification.numeric import VerificationReport, verify
from geomfdi.verification.symbolic import SymbolicReport, verify_symbolic

__all__ = ["verify", "verify_symbolic", "VerificationReport", "SymbolicReport"]
