"""Co-outer–co-inner factorisation of a stable noise channel ``R_w = R_wo R_wi``.

``R_wi`` is co-inner (``R_wi R_wi~ = I``: all-pass from the left), ``R_wo`` square, stable and
invertible with a stable inverse.  A residual filter ``R_wo⁻¹`` then sees the noise through
an all-pass channel: ``‖R_wo⁻¹ R_w‖∞ = 1`` (Varga, *Solving Fault Diagnosis Problems*, 2017,
§5.3 and §10.3.6).  The factorisation is the inner–outer factorisation of the transposed
system (a Riccati equation on the dual realisation); see the user guide, *Theory: approximate
synthesis* (``docs/theory/approximate-synthesis.md``).

Standard case: the feed-through ``D`` has full row rank and ``R_w`` has no zeros on the
stability boundary (imaginary axis / unit circle).  Non-standard case (zeros at infinity —
``D`` row-rank deficient, e.g. process noise without a direct path — or on the boundary, or
``R_w`` of deficient normal rank): the factorisation is applied to the regularised channel
``[R_w, ε I]`` (Glover & Varga 2011; option ``nonstd = 2`` of Varga's ``afdsyn``), whose
co-outer factor has its zeros strictly inside the stability region.  The gap achieved then
grows as ``ε → 0`` while the filter gets poles close to the boundary or far from it (the gap
depends on the chosen poles, which is the nature of the non-standard problem).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from geomfdi.errors import DesignError

__all__ = ["CoOuterFactor", "co_outer_factor", "is_standard"]


@dataclass
class CoOuterFactor:
    """``R_wo`` and its stable inverse as state-space matrices, and how they were obtained.

    Attributes
    ----------
    A, B, C, D : ndarray
        Realisation of the co-outer factor ``R_wo`` (square, ``p × p``).
    Ai, Bi, Ci, Di : ndarray
        Realisation of ``R_wo⁻¹`` (stable): ``Ai = A − B D⁻¹ C``, ``Bi = B D⁻¹``,
        ``Ci = −D⁻¹ C``, ``Di = D⁻¹``.
    regularization : float
        ``ε`` of the regularised channel ``[R_w, ε I]`` (0 in the standard case).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    Ai: np.ndarray
    Bi: np.ndarray
    Ci: np.ndarray
    Di: np.ndarray
    regularization: float


def _row_rank_ok(D: np.ndarray, scale: float) -> bool:
    p = D.shape[0]
    if D.shape[1] < p:
        return False
    s = np.linalg.svd(D, compute_uv=False)
    return bool(s.size and s[-1] > 1e-8 * max(scale, 1e-300)) if p else True


def is_standard(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, dt: float, scale: float
) -> bool:
    """Whether ``(A, B, C, D)`` admits the standard factorisation (no regularisation).

    ``D`` of full row rank (relative to ``scale``, the size of the channel) and a
    stabilising Riccati solution whose inverse factor is strictly stable (no zero of the
    channel on the boundary).
    """
    if not _row_rank_ok(D, scale):
        return False
    try:
        _factor(A, B, C, D, dt)
    except (np.linalg.LinAlgError, ValueError, DesignError):
        return False
    return True


def _factor(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, dt: float
) -> tuple[np.ndarray, ...]:
    """Standard factorisation: realisation of ``R_wo`` and of its inverse.

    Dual inner–outer factorisation (Zhou, Doyle & Glover 1996, Thm 13.34; Varga 2017,
    §10.3.6): with ``R = D Dᵀ`` solve the filter Riccati equation for ``Y ≥ 0``::

        A Y + Y Aᵀ − (Y Cᵀ + B Dᵀ) R⁻¹ (C Y + D Bᵀ) + B Bᵀ = 0                (continuous)
        A Y Aᵀ − Y − (A Y Cᵀ + B Dᵀ)(R + C Y Cᵀ)⁻¹(C Y Aᵀ + D Bᵀ) + B Bᵀ = 0   (discrete)

    then ``R_wo = (A, K R̃^{1/2}, C, R̃^{1/2})`` with ``K = (Y Cᵀ + B Dᵀ) R̃⁻¹``
    (``A Y Cᵀ + B Dᵀ`` in discrete time) and ``R̃ = R`` (``R + C Y Cᵀ``).  Its inverse has the
    state matrix ``A − K C``, stable by the stabilising solution.
    """
    n = A.shape[0]
    R = D @ D.T
    S = B @ D.T
    Q = B @ B.T
    if dt > 0:
        Y = sla.solve_discrete_are(A.T, C.T, Q, R, s=S)
        Rt = R + C @ Y @ C.T
        K = np.linalg.solve(Rt, (A @ Y @ C.T + S).T).T
    else:
        Y = sla.solve_continuous_are(A.T, C.T, Q, R, s=S)
        Rt = R
        K = np.linalg.solve(Rt, (Y @ C.T + S).T).T
    if not np.all(np.isfinite(Y)):
        raise DesignError("noise channel: the factorisation's Riccati equation failed")
    w, V = np.linalg.eigh((Rt + Rt.T) / 2)
    if w.min() <= 0:
        raise DesignError("noise channel: the factorisation's weight is not positive definite")
    Rh = (V * np.sqrt(w)) @ V.T
    Rhi = (V / np.sqrt(w)) @ V.T
    Ao, Bo, Co, Do = A, K @ Rh, C, Rh
    Ai, Bi, Ci, Di = A - K @ C, K, -Rhi @ C, Rhi
    ev = np.linalg.eigvals(Ai) if n else np.zeros(0)
    # a zero on the boundary shows as an eigenvalue of A − K C within rounding of it
    tol = 1e-6 * max(1.0, float(np.linalg.norm(A, 1)) if n else 1.0)
    unstable = np.any(np.abs(ev) >= 1 - tol) if dt > 0 else np.any(ev.real >= -tol)
    if n and unstable:
        raise DesignError("noise channel: zeros on the stability boundary")
    return Ao, Bo, Co, Do, Ai, Bi, Ci, Di


def co_outer_factor(
    A: np.ndarray,
    B: np.ndarray,
    C: np.ndarray,
    D: np.ndarray,
    dt: float,
    *,
    scale: float,
    regularization: float | None = None,
) -> CoOuterFactor:
    """Quasi-co-outer factor of a stable channel ``R_w = (A, B, C, D)`` (``p`` outputs).

    Parameters
    ----------
    A, B, C, D : ndarray
        A stable, minimal realisation of the noise channel.
    dt : float
        0 (continuous) or the sampling period.
    scale : float
        Size of the channel (its H∞ norm): the reference of the rank decision on ``D`` and
        of ``regularization``.
    regularization : float, optional
        ``ε / scale`` of the regularised channel ``[R_w, ε I]``.  ``None``: 0 in the standard
        case, ``1e-2`` otherwise.  A positive value forces the regularisation.

    Returns
    -------
    CoOuterFactor
        ``R_w = R_wo R_wi`` with ``R_wi`` co-inner (standard case), or
        ``[R_w, ε I] = R_wo R_wi`` (regularised): then ``‖R_wo⁻¹ R_w‖∞ ≤ 1``.
    """
    p = C.shape[0]
    eps = 0.0 if regularization is None else float(regularization)
    if eps < 0 or not np.isfinite(eps):
        raise DesignError(
            f"regularization: must be a finite number >= 0, got {regularization!r}",
            argument="regularization",
        )
    if eps == 0:
        if _row_rank_ok(D, scale):
            try:
                return CoOuterFactor(*_factor(A, B, C, D, dt), 0.0)
            except (np.linalg.LinAlgError, ValueError, DesignError):
                pass
        if regularization is not None:  # the user asked for the standard factorisation
            raise DesignError(
                "regularization: the noise channel is non-standard (zeros at infinity or "
                "on the stability boundary); give regularization > 0",
                argument="regularization",
            )
        eps = 1e-2
    e = eps * max(scale, 1e-300)
    n = A.shape[0]
    Br = np.hstack([B, np.zeros((n, p))])
    Dr = np.hstack([D, e * np.eye(p)])
    try:
        return CoOuterFactor(*_factor(A, Br, C, Dr, dt), eps)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise DesignError(
            f"regularization: the regularised factorisation failed ({exc})",
            argument="regularization",
        ) from None
