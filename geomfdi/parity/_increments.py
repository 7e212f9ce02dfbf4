"""Fault-hypothesis increments of the sequential parity tests (shared by their modules).

For sensor ``i`` the standardised isolation residual ``e_i = a_i / sqrt(w_ii)`` is
``N(0, 1)`` without fault and ``N(nu_i, 1)`` under a bias of ``shift * sigma`` on ``i``, with
``nu_i = shift sqrt(w_ii)``; the log-likelihood ratio of one sample is
``+/- nu_i e_i - nu_i^2 / 2``.  See the user guide, *Theory: parity space*
(``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.parity._records import ParityData

__all__: list[str] = []


def _series(pf: ParityData, Z: Any) -> np.ndarray:
    """``Z`` as a float array ``(R, N, m)`` (a single stream gets ``R = 1``)."""
    arr = np.asarray(Z, dtype=float) if not isinstance(Z, np.ndarray) else Z.astype(float)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[-1] != pf.m or arr.shape[1] == 0:
        raise ShapeError(
            f"Z: a time series needs shape (N, {pf.m}) or (R, N, {pf.m}) with N >= 1, "
            f"got {np.shape(Z)}",
            argument="Z",
        )
    if not np.isfinite(arr).all():
        raise GeomFDIError("Z: entries must be finite", argument="Z")
    return arr


def _standardised(pf: ParityData, X: np.ndarray) -> np.ndarray:
    """``e_i = a_i / sqrt(w_ii)``, N(0, 1) per hypothesis without fault, (R, N, k)."""
    return X @ pf.Bn


def _llr(pf: ParityData, X: np.ndarray, shift: float) -> np.ndarray:
    """Log-likelihood-ratio increments ``+/- nu_i e_i - nu_i^2 / 2``, (R, N, 2k)."""
    E = _standardised(pf, X)
    nu = shift * np.sqrt(pf.w)
    nu = np.where(pf.detectable, nu, 0.0)
    return np.concatenate([nu * E, -nu * E], axis=-1) - 0.5 * np.concatenate([nu, nu]) ** 2
