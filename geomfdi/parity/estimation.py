"""Fault sizes and the navigation (state) estimate after excluding isolated sensors.

With the isolated fault set ``S`` the maximum-likelihood fault sizes are the least-squares
solution in parity space, ``f_S = (G_S^T G_S)^{-1} G_S^T q`` with covariance
``sigma^2 (G_S^T G_S)^{-1}`` (``q`` the whitened parity vector, ``G`` the whitened fault
signatures).  Excluding the sensors ``S`` and solving the weighted least-squares problem
on the others gives the state estimate::

    x = (H_K^T R_K^{-1} H_K)^{-1} H_K^T R_K^{-1} Z_K,   cov x = (H_K^T R_K^{-1} H_K)^{-1}

with ``K`` the kept sensors and ``R = sigma^2 F F^T`` (``sigma^2 I`` by default).  See the
user guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import linalg as sla

from geomfdi._validation import as_indices
from geomfdi.errors import DesignError, GeomFDIError, RankDeficientError
from geomfdi.parity._input import _samples
from geomfdi.parity._records import ParityData, as_data
from geomfdi.parity.results import ParityDiagnosis
from geomfdi.tolerance import rank_decision

if TYPE_CHECKING:
    from geomfdi.parity._records import HasParityData

__all__ = ["FaultEstimate", "StateEstimate", "estimate_faults", "estimate_state"]


@dataclass(frozen=True)
class FaultEstimate:
    """Maximum-likelihood sizes of the faults of a hypothesis set (:func:`estimate_faults`).

    Attributes
    ----------
    faults : tuple of int
        The hypotheses (columns of ``D``; sensors when ``D = I``).
    size : ndarray, (N, len(faults))
        Estimated fault sizes, in the units of ``Z``.
    covariance : ndarray, (len(faults), len(faults))
        ``sigma^2 (G_S^T G_S)^{-1}``; the estimate is unbiased when the hypothesis holds.
    """

    faults: tuple[int, ...]
    size: np.ndarray
    covariance: np.ndarray


@dataclass(frozen=True)
class StateEstimate:
    """Least-squares state estimate without the excluded sensors (:func:`estimate_state`).

    Attributes
    ----------
    x : ndarray, (N, n)
        Estimates, one row per sample.
    covariance : ndarray, (N, n, n)
        Covariance of each row's estimate (samples with the same exclusion share it).
    excluded : ndarray of int, (N, r)
        Sensors excluded per sample, ``-1`` padded.
    """

    x: np.ndarray
    covariance: np.ndarray
    excluded: np.ndarray


def estimate_faults(pf: ParityData | HasParityData, Z: Any, faults: Any) -> FaultEstimate:
    """Fault sizes of the hypotheses ``faults`` from the parity vector of ``Z``.

    Parameters
    ----------
    pf : ParityFDI
    Z : array_like, (N, m) or (m,)
    faults : int or sequence of int
        Hypotheses (columns of ``D``) assumed faulty.

    Returns
    -------
    FaultEstimate

    Raises
    ------
    RankDeficientError
        The signatures of the hypotheses are dependent (their sizes are not identifiable
        from the parity vector).
    """
    pf = as_data(pf)
    S = as_indices(faults, "faults", pf.k)
    Zs = _samples(pf, Z)
    G = pf.G[:, list(S)]
    U, sv, Vt = np.linalg.svd(G, full_matrices=False)
    if rank_decision(sv, pf.scaleG, pf.m, what="fault signatures", warn=False).rank < len(S):
        raise RankDeficientError(
            f"faults: the parity signatures of {list(S)} are dependent; their sizes cannot "
            "be told apart",
            argument="faults",
        )
    q = Zs @ pf.T.T
    size = ((q @ U) / sv) @ Vt
    cov = pf.sigma**2 * (Vt.T / sv**2) @ Vt
    return FaultEstimate(tuple(S), size, cov)


def _wls(pf: ParityData, keep: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gain ``K`` (n, |keep|) and covariance of the WLS estimate from the rows ``keep``."""
    Hk = pf.H[keep]
    if pf.F is None:
        Wh = Hk
        scale = np.eye(keep.size)
    else:
        Rk = pf.F[keep] @ pf.F[keep].T
        L = np.linalg.cholesky((Rk + Rk.T) / 2.0)
        scale = sla.solve_triangular(L, np.eye(keep.size), lower=True)  # L^{-1}
        Wh = scale @ Hk
    Q, Rr = np.linalg.qr(Wh)
    sv = np.linalg.svd(Rr, compute_uv=False)
    if rank_decision(sv, float(sv[0]) if sv.size else 0.0, pf.m, warn=False).rank < pf.n:
        raise RankDeficientError(
            "exclude: the remaining sensors do not determine the state", argument="exclude"
        )
    Rinv = sla.solve_triangular(Rr, np.eye(pf.n))
    gain = Rinv @ Q.T @ scale
    return gain, pf.sigma**2 * (Rinv @ Rinv.T)


def estimate_state(pf: ParityData | HasParityData, Z: Any, exclude: Any = ()) -> StateEstimate:
    """State estimate from the sensors not excluded, with its covariance.

    Parameters
    ----------
    pf : ParityFDI
        A configuration of sensor faults (``D = I``).
    Z : array_like, (N, m) or (m,)
    exclude : int, sequence of int or ParityDiagnosis
        Sensors left out for every sample, or a diagnosis of ``Z`` whose isolated
        sensors (``faults``) are left out sample by sample.

    Returns
    -------
    StateEstimate

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=0.01)
    >>> Z = gf.parity.simulate(pf, 3, rng=0, x=[1.0, 2.0, 3.0], fault=[0, 0, 5.0, 0, 0, 0])
    >>> est = pf.estimate_state(Z, exclude=pf.diagnose(Z, 1e-3))
    >>> np.round(est.x, 1).tolist(), est.excluded[:, 0].tolist()
    ([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [1.0, 2.0, 3.0]], [2, 2, 2])
    """
    pf = as_data(pf)
    if pf.D is not None:
        raise DesignError(
            "exclude: the state estimate after exclusion needs D = I (sensor faults)",
            argument="exclude",
        )
    Zs = _samples(pf, Z)
    N = Zs.shape[0]
    if isinstance(exclude, ParityDiagnosis):
        ex = np.asarray(exclude.faults).reshape(-1, exclude.faults.shape[-1])
        if ex.shape[0] != N:
            raise GeomFDIError(
                f"exclude: the diagnosis has {ex.shape[0]} samples, Z has {N}",
                argument="exclude",
            )
    else:
        idx = () if exclude is None else as_indices(exclude, "exclude", pf.m)
        ex = np.broadcast_to(np.asarray(idx, dtype=np.intp).reshape(1, -1), (N, len(idx)))
    x = np.empty((N, pf.n))
    cov = np.empty((N, pf.n, pf.n))
    sets, inverse = np.unique(np.sort(ex, axis=1), axis=0, return_inverse=True)
    for g, row in enumerate(sets):
        keep = np.setdiff1d(np.arange(pf.m), row[row >= 0])
        gain, P = _wls(pf, keep)
        rows = np.flatnonzero(inverse.reshape(-1) == g)
        x[rows] = Zs[np.ix_(rows, keep)] @ gain.T
        cov[rows] = P
    return StateEstimate(x, cov, np.array(ex, dtype=np.intp))
