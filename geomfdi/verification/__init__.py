"""Verification of delivered generators on the physical plant, numeric and exact."""

from geomfdi.verification.numeric import SymbolicReport, VerificationReport, verify, verify_symbolic

__all__ = ["verify", "verify_symbolic", "VerificationReport", "SymbolicReport"]
