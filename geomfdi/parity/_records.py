"""The frozen record of a parity-space model that the statistic, decision, estimation and
Monte-Carlo functions take, so that they never import the
:class:`~geomfdi.parity.model.ParityFDI` object back.

See the user guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from geomfdi.errors import GeomFDIError

__all__ = ["HasParityData", "ParityData", "as_data"]


@dataclass(frozen=True, eq=False)
class ParityData:
    """The model ``Z = H x + D f + F eps`` and everything derived from it at construction
    (Zhang, Chen & Liu 2005): parity matrix ``V`` (``V H = 0``, ``V V^T = I``), projector
    ``W``, whitened parity map ``T`` (``q = T Z``), whitened fault signatures ``G``, the
    GLT maps ``B`` (``Z B = a``) and ``Bn`` (``Z Bn = sqrt(FI)`` with sign), ``w_ii``, the
    detectable and isolable hypotheses; plus the caches filled on first use (subset tables,
    optimal parity vectors, calibrated sequential thresholds, reduced configurations).
    Built by :class:`~geomfdi.parity.model.ParityFDI`; the arrays are not copied."""

    H: np.ndarray
    sigma: float
    D: np.ndarray | None
    F: np.ndarray | None
    V: np.ndarray
    W: np.ndarray
    basis: str
    potter_order: np.ndarray | None
    m: int
    n: int
    s: int
    k: int
    chunk_size: int
    sensors: np.ndarray
    T: np.ndarray
    Sigma: np.ndarray | None
    Dm: np.ndarray
    G: np.ndarray
    Omega: np.ndarray
    scaleG: float
    w: np.ndarray
    B: np.ndarray
    Bn: np.ndarray
    detectable: np.ndarray
    isolable: np.ndarray
    lut: np.ndarray
    subset_cache: dict[int, dict[str, np.ndarray]] = field(default_factory=dict, repr=False)
    opt_cache: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    sequential_thresholds: dict[tuple, Any] = field(default_factory=dict, repr=False)
    reduced_cache: dict[tuple[int, ...], ParityData] = field(default_factory=dict, repr=False)


class HasParityData(Protocol):
    """What the functions read of a :class:`~geomfdi.parity.model.ParityFDI`: its record."""

    @property
    def data(self) -> ParityData: ...


def as_data(pf: ParityData | HasParityData) -> ParityData:
    """The record of ``pf`` (a ``ParityFDI`` or the record itself)."""
    if isinstance(pf, ParityData):
        return pf
    data = getattr(pf, "data", None)
    if not isinstance(data, ParityData):
        raise GeomFDIError(f"pf: expected a ParityFDI, got {type(pf).__name__}", argument="pf")
    return data
