"""Least degree of a row whose residuals detect every target strongly at given points.

See the user guide, *Theory: achievable signatures* (``docs/theory/achievable-signatures.md``,
"Least orders for strong detection") and *Theory: least-order synthesis*
(``docs/theory/least-order.md``).

**Principle.**  At degree ν the candidate residuals of the row are the parity space
``P_ν`` of the decoupled quotient ``(A0, M)`` (:mod:`geomfdi.synthesis.least_order.search`):
the polynomial rows ``v(s)`` of degree ν with ``v(s) M (sI − A0)⁻¹`` polynomial, divided by
``d(s) = Π (s − λ_i)``.  The response of such a residual to target j is
``p_j(s) / d(s)`` with the polynomial ``p_j(s) = v(s) G_j(s)``,
``G_j(s) = M (sI − A0)⁻¹ B_fj + H D_fj``; it is linear in v.  For a point λ₀ on the
stability boundary, the vectors v with ``p_j(λ₀) = 0`` form a subspace of ``P_ν``; it is
proper iff the space's response to j at λ₀ is not identically zero.  A real vector space
is no finite union of proper subspaces, so a generic vector of ``P_ν`` is strong for every
(target, point) pair iff each pair has a non-zero response on ``P_ν``, and the least
strong order is the least degree at which every pair has one.

**Poles.**  ``P_ν`` (the numerators ``v``, and so ``p_j``) does not depend on the poles
λ_i: they only fix the denominator ``d``.  The poles are the design's (the default
sequence, clear of spec(A0)); they are stable and the points lie on the stability
boundary, so ``d(λ₀) ≠ 0`` and ``p_j(λ₀) = 0 ⇔ p_j(λ₀)/d(λ₀) = 0`` — the responses are
evaluated in the partial-fraction form at the poles, never through ``(λ₀ I − A0)⁻¹``, so a
plant pole at λ₀ (an integrator, an undamped mode) needs no care either.  The poles are
moved off the points all the same (:func:`clear_of_spectrum`), which changes ``d`` only.

**Degrees.**  A degree with no minimal-basis vector of its own (``_fresh``) holds only the
multiples ``a(s) v(s)`` of the previous space, which are non-zero at λ₀ exactly where the
previous space is (choose ``a(λ₀) ≠ 0``): it is skipped.  The search runs from the row's
least weak order to its largest observability index, where the space holds every
minimal-basis vector; a pair unseen there is unseen at every degree.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.geometry.staircase import Staircase, observer_staircase
from geomfdi.synthesis.least_order.parity_spaces import (
    clear_of_spectrum,
    onb_parity_space,
    spectral_pole_set,
)
from geomfdi.synthesis.least_order.poles import _check_poles, default_pole_sequence
from geomfdi.synthesis.least_order.quotient import Quotient
from geomfdi.synthesis.least_order.search import (
    NU_PF_MAX,
    ONB_CHECK_FROM,
    SEE_OVERRIDE,
    SEE_TOL,
    _blocks,
    _fresh,
    _null_rows,
    _target_grams,
)

__all__ = ["strong_degree_responses", "strong_least_degree"]


def _onb_responses(
    Qm: Quotient, nu: int, dim: int, points: np.ndarray, omega: float, dt: float
) -> np.ndarray | None:
    """(points, targets) relative responses of the degree-ν space in the orthonormal basis
    (poles on the quotient's frequencies); ``None`` when it cannot be computed."""
    poles = clear_of_spectrum(spectral_pole_set(Qm.A0, nu, omega, dt), points, omega)
    try:
        return np.array(
            [onb_parity_space(Qm, nu, dim, poles, dt, np.array([p]))["rel"] for p in points]
        )
    except (np.linalg.LinAlgError, ValueError):
        return None


def strong_degree_responses(
    Qm: Quotient,
    nu: int,
    dim: int,
    points: np.ndarray,
    *,
    omega: float,
    dt: float,
) -> np.ndarray:
    """(points, targets): the relative response of the degree-ν parity space at each point.

    ``‖Xᵀ W_j(λ₀)‖ / ‖W_j(λ₀)‖`` (X an orthonormal basis of the space in the normalised
    coordinates of the search, ``W_j`` the map from a row's coordinates to its response to
    target j): the fraction of the whole response map that the space keeps; rounding
    level (``< SEE_TOL``) when every residual of degree ν has a zero at λ₀ for target j.
    Degrees up to ``NU_PF_MAX`` in the partial-fraction basis at the default poles (from
    ``ONB_CHECK_FROM`` a pair that basis misses is checked again in the orthonormal basis,
    as the degree search does), higher degrees in the orthonormal basis only.
    """
    nt = len(Qm.Bf)
    if nu > NU_PF_MAX:
        got = _onb_responses(Qm, nu, dim, points, omega, dt)
        return got if got is not None else np.zeros((points.size, nt))
    pool = default_pole_sequence(max(nu, 1), omega, dt).astype(complex)
    eig = Qm.eigenvalues if Qm.k else np.zeros(0)
    pool = clear_of_spectrum(clear_of_spectrum(pool, eig, omega), points, omega).real
    cand = _check_poles(pool[:nu].astype(complex), Qm.A0, dt, Qm.eigenvalues)
    blocks, kinds = _blocks(Qm, cand)
    X, _, _ = _null_rows(blocks, dim)
    out = np.array(
        [_target_grams(Qm, cand, kinds, X, np.array([p]), blocks)[1] for p in points]
    ).reshape(points.size, nt)
    if nu >= ONB_CHECK_FROM and np.any(out <= SEE_TOL):
        onb = _onb_responses(Qm, nu, dim, points, omega, dt)
        if onb is not None:
            out = np.where((out <= SEE_TOL) & (onb > SEE_OVERRIDE), onb, out)
    return out


def strong_least_degree(
    Qm: Quotient,
    points: np.ndarray,
    *,
    omega: float,
    dt: float,
    start: int = 0,
) -> dict[str, Any]:
    """The least degree ν ≥ ``start`` whose parity space responds to every target at every
    point (module Notes).

    Parameters
    ----------
    Qm : Quotient
        The row's decoupled quotient.
    points : ndarray
        Points on the stability boundary (``iω``, or ``e^{iω dt}``).
    omega, dt : float
        Plant frequency scale and sampling period (the design's default poles).
    start : int
        First degree tried: the row's least weak order (no lower degree sees every
        target at all).

    Returns
    -------
    dict
        ``order``: the least degree, or ``None`` when even the largest observability index
        leaves a pair unseen; ``unseen``: per degree tried, the unseen ``(point index,
        target index)`` pairs; ``responses``: the responses at the degree returned (or the
        last one tried).
    """
    pts = np.asarray(points, dtype=complex).ravel()
    nt = len(Qm.Bf)
    st = observer_staircase(Qm.A0, Qm.M) if Qm.k else Staircase(Qm.A0, Qm.M, np.eye(0), [])
    top = st.max_index
    unseen: dict[int, list[tuple[int, int]]] = {}
    resp = np.zeros((pts.size, nt))
    for nu in range(max(start, 0), max(top, start) + 1):
        dim = st.parity_dim(nu)
        if dim == 0:
            unseen[nu] = [(i, j) for i in range(pts.size) for j in range(nt)]
            continue
        if nu > start and nu - 1 in unseen and _fresh(st, nu) == 0:
            unseen[nu] = list(unseen[nu - 1])
            continue
        resp = strong_degree_responses(Qm, nu, dim, pts, omega=omega, dt=dt)
        miss = np.argwhere(~(resp > SEE_TOL))
        unseen[nu] = [(int(i), int(j)) for i, j in miss]
        if not miss.size:
            return {"order": nu, "unseen": unseen, "responses": resp}
    return {"order": None, "unseen": unseen, "responses": resp}
