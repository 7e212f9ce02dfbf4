"""Detection and isolation by any rule: per-sample (:mod:`~geomfdi.parity.decision`) or on
a time series (:mod:`~geomfdi.parity.sequential`, :mod:`~geomfdi.parity.sprt`).

See the user guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from geomfdi.parity import decision as _decision
from geomfdi.parity import sequential as _sequential
from geomfdi.parity._records import ParityData, as_data
from geomfdi.parity.results import ParityDiagnosis

if TYPE_CHECKING:
    from geomfdi.parity._records import HasParityData

__all__ = ["diagnose"]


def diagnose(
    pf: ParityData | HasParityData,
    Z: Any,
    pfa: float = 0.01,
    *,
    method: str = "glt",
    max_faults: int | None = None,
    window: int = 100,
    shift: float = 0.5,
    beta: float = 0.1,
    threshold: float | None = None,
) -> ParityDiagnosis:
    """Detect and isolate faults in every sample (or epoch of a time series).

    ``method`` in :data:`~geomfdi.parity.decision.METHODS` treats the rows of ``Z`` as
    independent samples (:func:`.decision.diagnose`, ``max_faults``); a method in
    :data:`~geomfdi.parity.sequential.SEQUENTIAL_METHODS` treats them as consecutive
    samples (:func:`.sequential.diagnose_sequential`, ``window``, ``shift``, ``beta``,
    ``threshold``).  See ``ParityFDI.diagnose``.
    """
    pf = as_data(pf)
    if isinstance(method, str) and method in _sequential.SEQUENTIAL_METHODS:
        return _sequential.diagnose_sequential(
            pf, Z, pfa, method, window=window, shift=shift, beta=beta, threshold=threshold
        )
    return _decision.diagnose(pf, Z, pfa, method=method, max_faults=max_faults)
