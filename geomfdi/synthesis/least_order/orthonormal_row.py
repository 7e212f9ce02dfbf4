"""A single-output row realised in an orthonormal rational basis (no injection gain).

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``,
section "Rows that read one output").

A row that reads one measurement combination (``ρ = 1``: e.g. a residual of a
sensor-fault bank that may use one sensor only) needs the whole decoupled quotient
``(A0, M)``: its least order is ``k``.  The minimum-energy observer moves the
eigenvalues outside the stability degree to their mirror images
(:func:`geomfdi.synthesis.least_order.injection.mirror_rule`) and, for one output, that fixes the
residual's transfer from ``[y; u]`` up to scale::

    Q(s) = f(s) [H − M (sI − A0)⁻¹ B_qy,  −H D_u − M (sI − A0)⁻¹ B_qu],
    f(s) = Π_moved (s − λ_i) / (s − μ_i)

(``f = det(sI − A0) / det(sI − A0 + L M)``; ``μ_i`` the mirror images).  Through one
output, moving many weakly observable eigenvalues needs an injection gain ``L`` that
grows exponentially with their number (``‖L‖ ≈ 1e9`` for 30 eigenvalues of a dense
random 60-state plant): a realisation ``(A0 − L M, L, …)`` then carries rounding of
``ε ‖L‖`` and leaks.  Yet ``Q`` itself is harmless: on the imaginary axis ``|f| ≈ 1``,
and ``Q(jω)`` is computed pointwise to working accuracy from the eigenvalues and the
resolvent of ``A0``.

So the row is realised without ``L``:

1. **Basis.**  ``(Λ, h)`` real, output normal (``Λ + Λᵀ = −hᵀ h``; discrete
   ``ΛᵀΛ + hᵀh = I``) with ``spec Λ`` = the kept and mirrored eigenvalues::

       Λ = blockdiag(Λ_i) − (block strictly upper part of hᵀ h)

   with ``Λ_i = p``, ``h_i = √(−2 Re p)`` for a real pole and
   ``Λ_i = [[2σ, |p|], [−|p|, 0]]``, ``h_i = [2√(−σ), 0]`` for a pair ``σ ± iω``; the
   discrete basis is its bilinear image ``((I + Λ)(I − Λ)⁻¹, √2 h (I − Λ)⁻¹)`` for the
   poles ``(z − 1)/(z + 1)``.  The functions ``h (sI − Λ)⁻¹ e_j`` are orthonormal on the
   imaginary axis (Takenaka–Malmquist; Ninness & Gustafsson 1997), so every entry of
   ``Λ`` and ``h`` is of the size of the poles, whatever their number.
2. **Coefficients.**  ``Q(s) = Q(∞) + h (sI − Λ)⁻¹ B_r`` with ``Q(∞) = [H, −H D_u]``; the
   real ``B_r`` solves the weighted least-squares problem at frequencies equispaced in
   the phase of the basis (weights ``density^{-1/2}``: a discretised inner product of the
   orthonormal basis, so the problem is well conditioned; :func:`_frequencies`).  The
   data lie in the span exactly, so the relative misfit measures the accuracy (reported
   as the identity ``"orthonormal-basis fit"``; above ``IDENTITY_TOL`` the attempt
   fails).
3. **Resolution.**  Mirroring about ``Re λ = −α`` keeps ``|f| = 1`` on that line, not on
   the axis; where many lightly damped eigenvalues cluster, ``|f(iω)|`` is exponentially
   small.  A response spanning more than ``SPREAD_MAX`` over the sample frequencies is
   not resolved: the attempt stops and the caller relaxes the stability degree.

The generator is ``F = Λ``, ``[−E, G] = B_r``, ``M_g = h``, ``[−H_g, K] = Q(∞)``; it is
checked on the physical plant like every other realisation.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg

from geomfdi.generators.gains import _tri_solve_rows_many
from geomfdi.synthesis.least_order.injection import mirror_rule
from geomfdi.synthesis.least_order.quotient import Quotient
from geomfdi.synthesis.least_order.rational_basis import (
    output_normal_basis,
    output_normal_rows,
    phase_frequencies,
)
from geomfdi.synthesis.least_order.search import LeastOrderRow

__all__ = ["orthonormal_row", "POINTS_PER_POLE", "SPREAD_MAX"]

SPREAD_MAX = 1e6
"""Largest ratio of the row's largest to smallest response over the sample frequencies:
beyond it the pointwise accuracy of the smallest responses is below the leakage check."""

POINTS_PER_POLE = 6
"""Real equations per basis function in the least-squares fit (``k · 6 / 2`` frequencies)."""


GRAM_COND_MAX = 10.0
"""Largest condition number of the weighted basis matrix for which the fit is solved by
its normal equations (error ``≤ GRAM_COND_MAX² ε`` relative); the sampled orthonormal
basis has a condition number close to 1."""


class _Basis:
    """The orthonormal basis of one pole set and its least-squares factorisation.

    Everything in the fit that depends on the poles only (module Notes, steps 1–2): the
    pair ``(Λ, h)``, the sample frequencies and weights, the weighted basis matrix and
    its factorisation.  Rows of a bank whose quotients share their eigenvalues (a sensor bank whose
    quotients are the plant in rotated coordinates) share one (:func:`_basis`).
    """

    def __init__(self, poles: np.ndarray, dt: float) -> None:
        self.poles, self.dt = poles, dt
        self.Lam, self.h = output_normal_basis(poles, dt)
        self._look: np.ndarray | None = None
        self._fit: tuple[np.ndarray, ...] | None = None
        self._chol: tuple[np.ndarray, bool] | None = None

    @property
    def look(self) -> np.ndarray:
        """Every ``POINTS_PER_POLE``-th sample frequency (a first look at the response)."""
        if self._look is None:
            pp = POINTS_PER_POLE
            self._look = phase_frequencies(self.poles, self.dt, pp, every=pp)[0]
        return self._look

    @property
    def fit(self) -> tuple[np.ndarray, ...]:
        """``(pts, wts, Ar, s)``: the samples, weights, the real weighted basis matrix
        ``Ar`` and its singular values (from the Gram matrix ``Arᵀ Ar``, factored once by
        Cholesky when ``Ar`` is within :data:`GRAM_COND_MAX` of orthonormal columns)."""
        if self._fit is None:
            pts, wts = phase_frequencies(self.poles, self.dt, POINTS_PER_POLE)
            Phi = output_normal_rows(self.poles, self.dt, pts) * wts[:, None]
            Ar = np.vstack([Phi.real, Phi.imag])
            G = Ar.T @ Ar
            lam = np.linalg.eigvalsh(G)[::-1]
            sv = np.sqrt(np.maximum(lam, 0.0))
            self._chol = None
            if sv.size and sv[-1] > 0 and sv[0] <= GRAM_COND_MAX * sv[-1]:
                self._chol = scipy.linalg.cho_factor(G, check_finite=False)
            self._fit = (pts, wts, Ar, sv)
        return self._fit

    def solve(self, Yr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Least-squares ``Ar B = Yr`` and the singular values of ``Ar``: the minimum-norm
        solution with singular values at or below ``ε max(rows, cols) σ_1`` dropped (the
        cut-off of ``numpy.linalg.lstsq`` with ``rcond=None``).

        The basis is orthonormal on the samples (``Arᵀ Ar ≈ I``, the discretised inner
        product of module Notes, step 2): no singular value is cut and the normal
        equations ``Arᵀ Ar B = Arᵀ Yr``, solved by Cholesky, are as accurate as a QR
        factorisation (their error grows as ``cond(Ar)² ε`` against ``cond(Ar) ε``;
        ``cond(Ar) ≤ GRAM_COND_MAX``).  Otherwise B is taken from the SVD of ``Ar``."""
        _, _, Ar, sv = self.fit
        if self._chol is not None:
            return scipy.linalg.cho_solve(self._chol, Ar.T @ Yr, check_finite=False), sv
        cut = np.finfo(float).eps * max(Ar.shape) * (sv[0] if sv.size else 0.0)
        U, s, Vt = np.linalg.svd(Ar, full_matrices=False)
        r = int(np.count_nonzero(s > cut))
        return Vt[:r].T @ ((U[:, :r].T @ Yr) / s[:r, None]), s


_BASES: dict[tuple[bytes, float], _Basis] = {}
_BASES_KEPT = 8


def _basis(poles: np.ndarray, dt: float) -> _Basis:
    """The :class:`_Basis` of the poles, from the last few pole sets used (bit for bit)."""
    key = (np.ascontiguousarray(poles, dtype=complex).tobytes(), float(dt))
    hit = _BASES.pop(key, None)
    if hit is None:
        hit = _Basis(np.array(poles, dtype=complex), dt)
    _BASES[key] = hit  # most recent last
    while len(_BASES) > _BASES_KEPT:
        try:
            _BASES.pop(next(iter(_BASES)), None)
        except (RuntimeError, StopIteration):  # another thread changed it
            break
    return hit


def _resolvent_rows(T: np.ndarray, left: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """``left (s I − T)⁻¹`` for an upper triangular complex T at every point (rows):
    :func:`geomfdi.generators.gains._tri_solve_rows_many`."""
    return _tri_solve_rows_many(T, pts, left)


def orthonormal_row(
    Qm: Quotient,
    Du: np.ndarray,
    *,
    omega: float,
    dt: float,
    relax: float,
    certificate: dict[str, Any],
) -> LeastOrderRow:
    """The single-output quotient row realised in the orthonormal basis (module Notes).

    Returns a :class:`~geomfdi.synthesis.least_order.search.LeastOrderRow` whose ``direct``
    holds the generator's ``(E, G)`` reading ``y`` and ``u``, and ``identities`` the
    relative least-squares misfit.

    Raises
    ------
    numpy.linalg.LinAlgError
        The quotient reads more than one output combination; the row's response over the
        sample frequencies spans more than ``SPREAD_MAX``; or the fit fails.
    """
    k = Qm.k
    if Qm.rho != 1 or k == 0:
        raise np.linalg.LinAlgError("the orthonormal-basis realisation needs ρ = 1, k > 0")
    eig = Qm.eigenvalues
    rule = mirror_rule(eig, dt=dt, omega=omega, relax=relax)
    poles = rule.targets
    basis = _basis(poles, dt)
    Lam, h = basis.Lam, basis.h
    lam_m, mu_m = eig[rule.moved], poles[rule.moved]
    TA, UA = Qm.schur
    Bq = np.hstack([Qm.Bqy, Qm.Bqu])
    MU = Qm.M @ UA
    UhB = UA.conj().T @ Bq
    Hrow = Qm.H[0]
    q = Hrow.size
    Qinf = np.concatenate([Hrow, -Hrow @ Du])

    def response(pts: np.ndarray) -> np.ndarray:
        """``Q(s)`` at the points, through the complex Schur form of A0 (module Notes)."""
        f = np.prod((pts[:, None] - lam_m[None, :]) / (pts[:, None] - mu_m[None, :]), axis=1)
        fa = np.abs(f)
        if not np.max(fa) <= SPREAD_MAX * 1e6 * max(float(np.min(fa)), 1e-300):
            raise np.linalg.LinAlgError(  # clearly unresolved: no resolvent needed to tell
                "orthonormal-basis realisation: the row's frequency response spans "
                f"{np.log10(np.max(fa) / max(float(np.min(fa)), 1e-300)):.0f} decades at "
                "this stability degree"
            )
        MR = _resolvent_rows(TA, MU, pts)[:, 0, :]  # M U (sI − T)⁻¹
        Qpts = f[:, None] * (Qinf[None, :] - MR @ UhB)
        size = np.linalg.norm(Qpts, axis=1)
        spread = float(np.max(size) / max(float(np.min(size)), 1e-300))
        if not spread <= SPREAD_MAX:
            # mirroring far from the axis makes |f(iω)| exponentially small where many
            # lightly damped eigenvalues cluster: the response is not resolved in floating
            # point there (a larger relaxation mirrors closer to the axis)
            raise np.linalg.LinAlgError(
                f"orthonormal-basis realisation: the row's frequency response spans "
                f"{np.log10(spread):.0f} decades at this stability degree"
            )
        return Qpts

    # every POINTS_PER_POLE-th sample first: a spread it shows, the whole set shows too
    response(basis.look)
    # basis: h (sI − Λ)⁻¹ block by block (O(k) per point), weighted, and its SVD
    pts, wts, Ar, *_ = basis.fit
    Qpts = response(pts)
    data = (Qpts - Qinf[None, :]) * wts[:, None]
    Yr = np.vstack([data.real, data.imag])
    Br, sv = basis.solve(Yr)
    ny = max(float(np.linalg.norm(Yr)), 1e-300)
    misfit = float(np.linalg.norm(Ar @ Br - Yr)) / ny
    if not np.isfinite(misfit):
        raise np.linalg.LinAlgError("orthonormal-basis fit: non-finite coefficients")
    cert = dict(certificate)
    cert["realisation"] = "orthonormal basis"
    cert["injection"] = {
        "rule": "orthonormal basis (no injection gain): " + rule.text,
        "shift": rule.shift,
        "moved": int(np.count_nonzero(rule.moved)),
    }
    cert["basis_condition"] = float(sv[0] / max(sv[-1], 1e-300))
    direct = {
        "E": -Br[:, :q],
        "G": Br[:, q:],
        "identities": {"orthonormal-basis fit": misfit},
    }
    return LeastOrderRow(k, Lam, None, None, h, np.ones(1), poles, cert, direct)
