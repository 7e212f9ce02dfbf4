"""Stabilising output injection with a stability degree (Riccati, well conditioned for any k).

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``).

Given an observable pair ``(A, C)`` (the decoupled quotient of a residual row), find ``L``
with ``A − L C`` stable *without* placing every pole through the outputs (placing ~k poles
through one output is hopeless for k ≳ 10).  The rule follows Varga's stability degree
(Varga 2017): eigenvalues that are already stable enough are kept, only the others move.

* Continuous time: with ``α = SDEG_REL · ω`` (``ω`` the plant scale of
  :func:`geomfdi.synthesis.least_order.poles.plant_scale`, the plant's time scale), the
  eigenvalues with ``Re λ > −α`` move and those with ``Re λ ≤ −α`` stay.  ``L = X Cᵀ``
  with X the stabilising solution of the dual Riccati equation of the shifted pair::

      (A + α I) X + X (A + α I)ᵀ − X Cᵀ C X = 0

  (zero state weight: the minimum-energy injection).  The moved eigenvalues are mirrored
  about ``Re λ = −α`` (``λ ↦ −2α − λ̄``), so ``spec(A − L C) ⊂ {Re λ ≤ −α}``.
* Discrete time: ``β = SDEG_DISCRETE`` (0.95); eigenvalues with ``|z| > β`` move, mirrored
  about the circle of radius β (``z ↦ β² / z̄``), through the discrete Riccati equation
  of ``(Aᵀ/β, Cᵀ)`` with zero state weight; ``L = β Kᵀ`` with K its gain.

Both equations are solved on the pair scaled to ``‖C‖ = 1`` and (continuous) time scaled
by ω, so the computation does not depend on units.

**Relaxation.**  Mirroring lightly damped, weakly observable modes far to the left
through few outputs needs a large gain (the inverse of an ill-conditioned observability
Gramian): on a 200-state mass–spring chain read by one sensor, ``α = 0.05 ω`` needs
``‖L‖ ≈ 3e9``, ``α = 0.01 ω`` only ``≈ 7e4``.  The caller therefore tries the stability
degrees ``RELAX`` in turn: ``α = SDEG_REL · ω / r`` (discrete: ``β = 1 − 0.05 / r``),
and keeps the first whose realisation passes the checks on the physical plant.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from geomfdi.geometry.subspace import _norm2

__all__ = [
    "stabilising_injection",
    "mirror_rule",
    "MirrorRule",
    "SDEG_REL",
    "SDEG_DISCRETE",
    "RELAX",
]

SDEG_REL = 0.05
"""Continuous stability degree relative to the plant scale: move ``Re λ > −0.05 ω``."""

SDEG_DISCRETE = 0.95
"""Discrete stability degree: move ``|z| > 0.95``."""

RELAX = (1.0, 5.0, 25.0)
"""Relaxation factors r of the stability degree tried in turn (module Notes)."""


def _mirror_gain(A: np.ndarray, C: np.ndarray, dt: float, bound: float) -> np.ndarray:
    """Minimum-energy injection mirroring the eigenvalues outside ``bound`` (module Notes).

    Ordered real Schur form ``A = Z T Zᵀ`` with the k1 eigenvalues to move in the
    upper-left block ``T11``; with ``C1 = C Z[:, :k1]`` and ``L = Z[:, :k1] L1``,
    ``Zᵀ (A − L C) Z = [[T11 − L1 C1, *], [0, T22]]``: only the small problem on
    ``(T11, C1)`` is solved and the kept eigenvalues (those of ``T22``) stay exactly.
    Continuous: ``Y`` from the Lyapunov equation ``aᵀ Y + Y a = C1ᵀ C1`` with the
    anti-stable ``a = T11 + αI`` (Y ≻ 0) and ``L1 = Y⁻¹ C1ᵀ``, so that
    ``a − L1 C1 = −Y⁻¹ aᵀ Y``.  Discrete: the stabilising solution of the discrete
    Riccati equation of the dual ``(T11ᵀ / β, C1ᵀ)`` with zero state weight.
    """
    k = A.shape[0]
    if dt > 0:
        T, Z, k1 = sla.schur(A, output="real", sort=lambda x, y: np.hypot(x, y) > bound)
    else:
        T, Z, k1 = sla.schur(A, output="real", sort=lambda x, y: x > -bound)
    if k1 == 0:
        return np.zeros((k, C.shape[0]))
    T11 = T[:k1, :k1]
    C1 = C @ Z[:, :k1]
    p = C.shape[0]
    if dt > 0:
        a = T11.T / bound
        X = sla.solve_discrete_are(a, C1.T, np.zeros((k1, k1)), np.eye(p))
        L1 = bound * np.linalg.solve(np.eye(p) + C1 @ X @ C1.T, C1 @ X @ a).T
    else:
        a = T11 + bound * np.eye(k1)
        Y = sla.solve_continuous_lyapunov(a.T, C1.T @ C1)
        L1 = np.linalg.solve((Y + Y.T) / 2, C1.T)
    return Z[:, :k1] @ L1


def _gap(values: np.ndarray, edge: float, direction: float) -> float:
    """The boundary in ``[edge, edge + 0.2 |edge| direction]`` farthest from every value.

    A boundary through an eigenvalue puts a Hamiltonian (symplectic) eigenvalue on the
    imaginary axis (unit circle); the Riccati solvers then fail.
    """
    cand = edge + direction * 0.2 * abs(edge) * np.linspace(0.0, 1.0, 21)
    dist = np.min(np.abs(cand[:, None] - values[None, :]), axis=1)
    if dist[0] >= 0.02 * abs(edge):
        return float(edge)
    return float(cand[int(np.argmax(dist))])


def stabilising_injection(
    A: np.ndarray, C: np.ndarray, *, dt: float, omega: float, relax: float = 1.0
) -> tuple[np.ndarray, dict[str, Any]]:
    """Output injection ``L`` with ``A − L C`` inside the stability degree (module Notes).

    Parameters
    ----------
    A : ndarray, shape (k, k)
    C : ndarray, shape (p, k)
        An observable pair.
    dt : float
        Sampling period (0: continuous).
    omega : float
        Plant frequency scale (continuous: the shift is ``SDEG_REL · ω / relax``).
    relax : float
        Relaxation r ≥ 1 of the stability degree (module Notes).

    Returns
    -------
    L : ndarray, shape (k, p)
    info : dict
        ``"rule"`` (text), ``"shift"`` (α, or β in discrete time), ``"moved"`` (number of
        eigenvalues of A outside the stability degree, mirrored inside it).

    Raises
    ------
    numpy.linalg.LinAlgError
        The Riccati equation has no stabilising solution in floating point (an
        eigenvalue on the boundary, or a pair too close to unobservable), or ``A − L C``
        is not stable.
    """
    k, p = A.shape[0], C.shape[0]
    if k == 0:
        return np.zeros((0, p)), {"rule": "no states", "shift": 0.0, "moved": 0}
    cn = max(_norm2(C), 1e-300)
    Cs = C / cn
    eig = np.linalg.eigvals(A)
    try:
        rule = mirror_rule(eig, dt=dt, omega=omega, relax=relax)
        shift, moved = rule.shift, int(np.count_nonzero(rule.moved))
        if dt > 0:
            L = _mirror_gain(A, Cs, dt, shift) / cn
            ok = np.max(np.abs(np.linalg.eigvals(A - L @ C))) < 1.0
        else:
            w = max(float(omega), 1e-300)
            L = w * _mirror_gain(A / w, Cs, 0.0, shift / w) / cn
            ok = np.max(np.linalg.eigvals(A - L @ C).real) < 0.0
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise np.linalg.LinAlgError(f"no stabilising output injection: {exc}") from None
    if not (ok and np.all(np.isfinite(L))):
        raise np.linalg.LinAlgError("no stabilising output injection: unstable result")
    how = {"rule": "Riccati injection: " + rule.text, "shift": float(shift), "moved": moved}
    return L, {**how, "gain": float(_norm2(L))}


@dataclass(frozen=True)
class MirrorRule:
    """Which eigenvalues move and where to (the stability degree of the module Notes)."""

    moved: np.ndarray
    """Boolean mask over the eigenvalues: outside the stability degree."""
    targets: np.ndarray
    """The spectrum after the move: kept eigenvalues, moved ones mirrored."""
    shift: float
    """α (continuous: the boundary is ``Re λ = −α``) or β (discrete: ``|z| = β``)."""
    text: str


def mirror_rule(eig: np.ndarray, *, dt: float, omega: float, relax: float = 1.0) -> MirrorRule:
    """The eigenvalues outside the stability degree and their mirror images (module Notes).

    Continuous: ``α = SDEG_REL · ω / relax`` (nudged clear of every eigenvalue), the
    eigenvalues with ``Re λ > −α`` move to ``−2α − λ̄``.  Discrete: ``β = 1 − 0.05 / relax``,
    those with ``|z| > β`` move to ``β² / z̄``.  These are the closed-loop eigenvalues of
    the minimum-energy injection; for a single output they fix the observer uniquely.
    """
    eig = np.asarray(eig, dtype=complex)
    out = eig.copy()
    if dt > 0:
        beta = _gap(np.abs(eig), 1.0 - (1.0 - SDEG_DISCRETE) / relax, -1.0)
        moved = np.abs(eig) > beta
        out[moved] = beta**2 / eig[moved].conj()
        text = f"eigenvalues with |z| > {beta:.4g} mirrored to {beta:.4g}²/z̄, the others kept"
        return MirrorRule(moved, out, float(beta), text)
    w = max(float(omega), 1e-300)
    alpha = -_gap(eig.real, -SDEG_REL * w / relax, -1.0)
    moved = eig.real > -alpha
    out[moved] = -2.0 * alpha - eig[moved].conj()
    text = (
        f"eigenvalues with Re λ > −{alpha:.3g} (= −{SDEG_REL / relax:.3g} ω, ω = {w:.3g}) "
        "mirrored about that line, the others kept"
    )
    return MirrorRule(moved, out, float(alpha), text)
