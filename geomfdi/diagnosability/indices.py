"""Diagnosability indices of one fault or one pair: KL, directional, probabilities.

* Kullback-Leibler (Eriksson, Frisk & Krysander 2013): ``FD = 1/2 ||q_i||^2``,
  ``FI = 1/2 ||N_{Gamma N_H F_j} q_i||^2``;
* directional similarity (Li, Wang & Liu 2015, eqs. 17, 21, 22);
* detection / isolation probabilities of the chi-square GLR tests at false-alarm rate
  ``alpha``.

See the user guide, *Theory: diagnosability* (``docs/theory/diagnosability.md``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from geomfdi._validation import as_positive, as_probability
from geomfdi.diagnosability._linalg import _chi2_power
from geomfdi.diagnosability.stacking import _complement_residual, _q, _scaled_square
from geomfdi.errors import GeomFDIError
from geomfdi.tolerance import rank_decision

if TYPE_CHECKING:
    from geomfdi.diagnosability._records import CosineConvention, NullSpaceMethod, WindowData

__all__ = [
    "kl_detectability",
    "kl_isolability",
    "directional_detectability",
    "directional_isolability",
    "detection_probability",
    "isolation_probability",
    "probabilistic_detectability",
    "probabilistic_isolability",
]

_COSINES = ("absolute", "signed")


def _half_square(x: np.ndarray, scale: float) -> float:
    """``1/2 ||scale x||^2``; a named error when it leaves the floating-point range."""
    value = 0.5 * _scaled_square(x, scale)
    if not math.isfinite(value) or (value == 0.0 and np.any(x)):
        raise GeomFDIError(
            f"theta: a fault profile of size {scale:.3g} gives a KL index outside the "
            "floating-point range (overflow or underflow); rescale the fault (the index "
            "grows as the square of the fault size)",
            argument="theta",
        )
    return value


def kl_detectability(
    model: WindowData, i: int, theta: Any, *, method: NullSpaceMethod | None = None
) -> float:
    """KL detectability ``FD(f_i) = 1/2 ||q_i||^2`` (Li, Wang & Liu (2015), eq. 8, upper).

    Parameters
    ----------
    i : int
        Fault index (0-based column of ``Bf``/``Df``).
    theta : array_like, (window,)
        Profile of ``f_i`` over the window (``f_si`` of the paper).
    method : {"structured", "direct"}, optional
        Null-space path (default: the model's).

    Returns
    -------
    float
        ``min KL(p_i, p_0)``: the divergence between the residual distributions with and
        without the fault.  0 exactly when the profile is undetectable.

    Notes
    -----
    Eriksson, Frisk & Krysander (2013) convention: the residual is whitened after the
    projection, ``q_i = Gamma N_H F_i theta`` .  Reproduces Table 1.
    """
    i = model.fault_index(i)
    q, _, scale = _q(model, i, model.profile(theta), method)
    return _half_square(q, scale)


def kl_isolability(
    model: WindowData, i: int, j: int, theta: Any, *, method: NullSpaceMethod | None = None
) -> float:
    """KL isolability ``FI(f_i, f_j) = 1/2 ||N_{Gamma N_H F_j} q_i||^2`` (eq. 8, lower).

    Parameters
    ----------
    i, j : int
        The fault present (``i``) and the fault it must be told from (``j``).
    theta : array_like, (window,)
        Profile of ``f_i``.  The minimum runs over all profiles of ``f_j``.

    Returns
    -------
    float
        ``min over theta_j of KL(p_i, p_j(theta_j))``: half the squared distance from
        ``q_i`` to the image of ``Gamma N_H F_j``.  Not symmetric in ``(i, j)``.

    Notes
    -----
    The paper writes ``N_[H F_j] F_i f_si`` without whitening; the whitened form here is
    the one of Eriksson, Frisk & Krysander (2013) and reproduces Table 1 exactly.  The
    projection uses the rank of ``Gamma N_H F_j`` decided by :mod:`geomfdi.tolerance`.
    """
    i = model.fault_index(i)
    j = model.fault_index(j, "j")
    q, tol, scale = _q(model, i, model.profile(theta), method)
    res, _ = _complement_residual(model, q, j, method, tol)
    return _half_square(res, scale)


def directional_detectability(
    model: WindowData, i: int, theta: Any, *, method: NullSpaceMethod | None = None
) -> float:
    """Directional detectability ``FD(f_i) = 1/(p(q_i) + 1)`` (Li, Wang & Liu (2015), eq. 17).

    ``p`` is the ``N(0, I_d)`` density, ``p(q) = (2 pi)^{-d/2} exp(-||q||^2 / 2)``.

    Returns
    -------
    float
        In ``(0, 1)``; reproduces the FD columns of Tables 2-4.

    Notes
    -----
    **Flaw** : an undetectable fault (``q_i = 0``) gets
    ``1 / ((2 pi)^{-d/2} + 1)`` (0.7148 for ``d = 1``, Table 3), not 0, and every index
    tends to 1 as ``d`` grows whatever the fault.  Use
    :meth:`probabilistic_detectability` for an index that is 0 exactly when the fault
    is undetectable.
    """
    i = model.fault_index(i)
    q, _, scale = _q(model, i, model.profile(theta), method)
    d = q.size
    log_p = -0.5 * d * math.log(2.0 * math.pi) - 0.5 * _scaled_square(q, scale)
    return 1.0 / (math.exp(log_p) + 1.0)


def directional_isolability(
    model: WindowData,
    i: int,
    j: int,
    theta: Any,
    kappa: float = 3.0,
    *,
    theta_j: Any = None,
    cosine: CosineConvention = "absolute",
    method: NullSpaceMethod | None = None,
) -> float:
    """Directional isolability ``FI(f_i, f_j) = 1/(||q_i||_c + 1)`` (Li, Wang & Liu (2015), eq. 22).

    Parameters
    ----------
    i, j : int
        The two faults.
    theta : array_like, (window,)
        Profile of ``f_i``.
    kappa : float
        Norm of the worst-case noise in eq. (21) (3: a 3-sigma noise).
    theta_j : array_like, optional
        Profile of ``f_j`` (default: ``theta``, as in the paper's tables).
    cosine : {"absolute", "signed"}
        ``"absolute"``: ``c = |n_i . n_j|`` (the harder of the two cases of eq. 21);
        reproduces Table 2.  ``"signed"``: ``c = n_i . n_j`` (the first case of eq. 21
        with the signed cosine), needed for Table 4's 0.25 where the two fault vectors
        point in opposite directions (``c = -1``).
    method : {"structured", "direct"}, optional

    Returns
    -------
    float
        ``1 / (kappa sqrt(2 / (1 - c)) + 1)``: eq. (21) evaluated at the noise of norm
        ``kappa`` along ``n_j - n_i``, ``||q_i||_c = kappa ||n_j - n_i|| / (1 - c)``.
        0 when the vectors are collinear (``c = 1``) or when either fault vector is
        zero (an undetectable fault cannot be isolated; Table 3).

    Notes
    -----
    Symmetric in ``(i, j)`` when both use the same profile.  ``1 - c`` is computed as the
    squared smaller singular value of ``[n_i, n_j]`` (and ``1 + |c|`` as the larger one)
    to keep nearly collinear pairs accurate; collinearity is a rank decision of
    :mod:`geomfdi.tolerance`.
    """
    i = model.fault_index(i)
    j = model.fault_index(j, "j")
    kappa = float(as_positive(kappa, "kappa"))
    if not isinstance(cosine, str) or cosine not in _COSINES:
        raise GeomFDIError(f"cosine: must be one of {_COSINES}, got {cosine!r}", argument="cosine")
    theta = model.profile(theta)
    theta_j = theta if theta_j is None else model.profile(theta_j, "theta_j")
    qi, tol_i, _ = _q(model, i, theta, method)
    qj, tol_j, _ = _q(model, j, theta_j, method)
    ni, nj = float(np.linalg.norm(qi)), float(np.linalg.norm(qj))
    if ni <= tol_i or nj <= tol_j:
        return 0.0
    pair = (qi / ni, qj / nj) if i <= j else (qj / nj, qi / ni)  # exactly symmetric
    one_minus_c = _one_minus_cosine(*pair, cosine)
    if one_minus_c == 0.0:
        return 0.0
    return 1.0 / (kappa * math.sqrt(2.0 / one_minus_c) + 1.0)


def detection_probability(
    model: WindowData,
    i: int,
    theta: Any,
    alpha: float = 0.01,
    *,
    method: NullSpaceMethod | None = None,
) -> float:
    """Detection probability ``P_D = 1 - F_{chi2_d(||q_i||^2)}(chi2_{d,1-alpha})``.

    The test is ``||r||^2 > chi2_{d,1-alpha}`` on the whitened residual ``r = Gamma N_H L
    z_s ~ N(q_i, I_d)``; it has false-alarm rate ``alpha`` and, with the fault, a
    non-central chi-square statistic with ``d`` degrees of freedom and non-centrality
    ``||q_i||^2 = 2 FD_KL``.

    Returns
    -------
    float
        In ``[alpha, 1)``; equals ``alpha`` for an undetectable fault.
    """
    i = model.fault_index(i)
    alpha = as_probability(alpha, "alpha")
    q, _, scale = _q(model, i, model.profile(theta), method)
    return _chi2_power(q.size, _scaled_square(q, scale), alpha)


def isolation_probability(
    model: WindowData,
    i: int,
    j: int,
    theta: Any,
    alpha: float = 0.01,
    *,
    method: NullSpaceMethod | None = None,
) -> float:
    """Probability of rejecting "only ``f_j`` (any profile) or no fault" when ``f_i`` acts.

    The test projects the whitened residual on the orthogonal complement of
    ``Im(Gamma N_H F_j)`` (dimension ``d_j = d - rank Gamma N_H F_j``) and rejects when
    ``||N_{Gamma N_H F_j} r||^2 > chi2_{d_j, 1-alpha}``.  Under ``f_j`` with any profile
    the statistic is central ``chi2_{d_j}`` (false-isolation rate exactly ``alpha``);
    under ``f_i`` with profile ``theta`` it is non-central with
    ``lambda = ||N_{Gamma N_H F_j} q_i||^2 = 2 FI_KL(f_i, f_j)``.

    Returns
    -------
    float
        ``1 - F_{chi2_{d_j}(lambda)}(chi2_{d_j,1-alpha})``; ``alpha`` when
        ``lambda = 0`` and when ``d_j = 0`` (no test exists; the randomised level-alpha
        test is the best one).
    """
    i = model.fault_index(i)
    j = model.fault_index(j, "j")
    alpha = as_probability(alpha, "alpha")
    q, tol, scale = _q(model, i, model.profile(theta), method)
    res, dof = _complement_residual(model, q, j, method, tol)
    return _chi2_power(dof, _scaled_square(res, scale), alpha)


def probabilistic_detectability(
    model: WindowData,
    i: int,
    theta: Any,
    alpha: float = 0.01,
    *,
    method: NullSpaceMethod | None = None,
) -> float:
    """``(P_D - alpha) / (1 - alpha)``: 0 exactly for an undetectable fault, -> 1 as
    ``||q_i||`` grows (see :meth:`detection_probability`)."""
    alpha = as_probability(alpha, "alpha")
    pd = detection_probability(model, i, theta, alpha, method=method)
    return max(pd - alpha, 0.0) / (1.0 - alpha)


def probabilistic_isolability(
    model: WindowData,
    i: int,
    j: int,
    theta: Any,
    alpha: float = 0.01,
    *,
    method: NullSpaceMethod | None = None,
) -> float:
    """``(P_I - alpha) / (1 - alpha)`` of :meth:`isolation_probability`; 0 when ``f_i``
    cannot be told from ``f_j``."""
    alpha = as_probability(alpha, "alpha")
    pi = isolation_probability(model, i, j, theta, alpha, method=method)
    return max(pi - alpha, 0.0) / (1.0 - alpha)


def _one_minus_cosine(ni: np.ndarray, nj: np.ndarray, cosine: str) -> float:
    """``1 - c`` for unit vectors, ``c = |ni.nj|`` or ``ni.nj``; 0 when collinear."""
    sv = np.linalg.svd(np.column_stack([ni, nj]), compute_uv=False)
    dec = rank_decision(sv, 1.0, ni.size, what="fault directions", warn=False)
    small = 0.0 if dec.rank < 2 else float(sv[1]) ** 2  # 1 - |c|
    large = float(sv[0]) ** 2  # 1 + |c|
    if cosine == "signed" and float(ni @ nj) < 0.0:
        return large
    return small
