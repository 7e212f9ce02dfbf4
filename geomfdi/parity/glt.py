"""Generalised likelihood test (GLT) statistics of the parity vector.

``p = V Z`` with ``V H = 0``, ``V V^T = I``; whitened ``q = L^{-1} p`` when the noise
matrix ``F`` is not the identity, and whitened fault signatures ``G = L^{-1} V D``::

    FD    = ||q||^2 / sigma^2                     ~ chi2(m - n) without fault
    FI(i) = (q^T G_i)^2 / (sigma^2 G_i^T G_i)     = (Z^T W_i)^2 / (sigma^2 w_ii)

References: Zhang, Chen & Liu (2005), eq. 2-5; Qin & Niu (1999), eq. 5-7. See the user
guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from geomfdi._validation import as_probability
from geomfdi.errors import GeomFDIError
from geomfdi.parity._input import _guarded, _samples
from geomfdi.parity._records import ParityData, as_data
from geomfdi.parity.thresholds import chi2_threshold

if TYPE_CHECKING:
    from geomfdi.parity._records import HasParityData

__all__ = [
    "parity",
    "detection_statistic",
    "isolation_statistics",
    "detection_threshold",
    "min_detectable_fault",
]


def _a(pf: ParityData, Z: np.ndarray) -> np.ndarray:
    """``a_i = q^T G_i / sigma`` (``= Z^T W_i / sigma`` for ``D = F = I``), (N, k)."""
    return Z @ pf.B


def _fd(pf: ParityData, Z: np.ndarray) -> np.ndarray:
    P = Z @ pf.T.T
    return np.einsum("ij,ij->i", P, P) / pf.sigma**2


def _check_fd(fd: np.ndarray) -> None:
    # every GLR statistic is bounded by FD: a finite FD means finite statistics
    if not np.isfinite(fd).all():
        raise GeomFDIError("Z: entries too large, the statistics overflow", argument="Z")


def _fi_from_a(pf: ParityData, a: np.ndarray) -> np.ndarray:
    out = np.zeros_like(a)
    det = pf.detectable
    out[:, det] = a[:, det] ** 2 / pf.w[det]
    return out


@_guarded
def parity(pf: ParityData | HasParityData, Z: Any) -> np.ndarray:
    """Parity vectors ``p = V Z``, shape (N, m - n) (Zhang, Chen & Liu (2005), §1.1)."""
    pf = as_data(pf)
    Z = _samples(pf, Z)
    return Z @ pf.V.T


@_guarded
def detection_statistic(pf: ParityData | HasParityData, Z: Any) -> np.ndarray:
    """GLT detection function ``FD = p^T p / sigma^2`` (whitened if ``F != I``).

    Parameters
    ----------
    Z : array_like, shape (N, m) or (m,)
        Measurements, one sample per row.

    Returns
    -------
    ndarray, shape (N,)
        ``FD ~ chi2(m - n)`` without fault.

    References
    ----------
    Zhang, Chen & Liu (2005), eq. 2; Qin & Niu (1999), eq. 5.
    """
    pf = as_data(pf)
    return _fd(pf, _samples(pf, Z))


@_guarded
def isolation_statistics(pf: ParityData | HasParityData, Z: Any) -> np.ndarray:
    """GLT isolation functions ``FI(i) = (p^T V_i)^2 / (sigma^2 V_i^T V_i)``, (N, k).

    References
    ----------
    Zhang, Chen & Liu (2005), eq. 4 (scaled by ``1/sigma^2`` as in its eq. 22); Qin & Niu
    (1999), eq. 7.
    """
    pf = as_data(pf)
    Z = _samples(pf, Z)
    return _fi_from_a(pf, _a(pf, Z))


def detection_threshold(
    pf: ParityData | HasParityData, pfa: float, dof: int | None = None
) -> float:
    """``chi2`` threshold for the detection function (``dof`` default ``m - n``)."""
    pf = as_data(pf)
    return chi2_threshold(pfa, pf.s if dof is None else dof)


def min_detectable_fault(pf: ParityData | HasParityData, pfa: float, pd: float = 0.9) -> np.ndarray:
    """Smallest single-fault size detected with probability ``pd`` at rate ``pfa``.

    A fault ``f`` on hypothesis ``i`` makes ``FD`` noncentral ``chi2(m - n, lambda)``
    with ``lambda = f^2 w_ii / sigma^2``; the returned size solves
    ``P(chi2(m - n, lambda) >= T) = pd``.  Undetectable faults get ``inf``.

    Parameters
    ----------
    pfa : float
        False-alarm rate fixing the threshold ``T = chi2_{1-pfa}(m - n)``.
    pd : float
        Required detection probability.

    Returns
    -------
    ndarray, shape (k,)
        Fault sizes, in the units of ``Z``.
    """
    pf = as_data(pf)
    pfa = as_probability(pfa, "pfa")
    pd = as_probability(pd, "pd")
    T = chi2_threshold(pfa, pf.s)
    if pd <= pfa:
        lam = 0.0
    else:
        from scipy import optimize, stats

        lam = optimize.brentq(lambda x: stats.ncx2.sf(T, pf.s, x) - pd, 1e-12, 1e6)
    out = np.full(pf.k, np.inf)
    det = pf.detectable
    out[det] = pf.sigma * np.sqrt(lam / pf.w[det])
    return out
