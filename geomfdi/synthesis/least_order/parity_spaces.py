"""High-degree parity spaces of the quotient in an orthonormal rational basis.

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``,
section "High degrees").

A scalar row of degree ν is a functional observer ``(Λ, G_s, T, c, h)`` of the quotient
``(A0, M)`` with::

    T A0 − Λ T = G_s M,        c T + h M = 0

(:mod:`geomfdi.synthesis.least_order.search`).  Fix ``(Λ, c)``: a real output-normal pair
(:func:`geomfdi.synthesis.least_order.rational_basis.output_normal_basis`) with ν stable
poles.  Then T is
linear in ``G_s`` and the rows of degree ν are the left null space of the linear map::

    (G_s, h)  ↦  c T(G_s) + h M          (ν ρ + ρ unknowns, k equations).

Its rows ``c T(E_ij)`` are the projections of the quotient's transfer ``M (sI − A0)⁻¹`` on
functions that are orthonormal on the imaginary axis, so the matrix keeps its
conditioning at any degree — unlike the partial-fraction basis ``M (λ_i − A0)⁻¹`` with
real poles spread over decades, whose Cauchy-like structure makes it useless beyond
``NU_PF_MAX``.  The dimension of the null space is that of the observer staircase (no
rank decision on the map); ``T(E_ij)`` comes from the complex Schur forms of ``Λ`` and
``A0`` and one triangular Sylvester solve (LAPACK ``trsyl``) per unknown.  The target
responses ``r_f(s) = c (sI − Λ)⁻¹ (G_s H D_f − T B_f) + h H D_f`` are linear in the
unknowns too; the direction of the row maximises the smallest normalised target gain,
as at low degrees.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg as sla
from scipy.linalg import lapack

from geomfdi.geometry.subspace import _norm2
from geomfdi.synthesis.least_order.rational_basis import output_normal_basis

__all__ = ["onb_parity_space", "realise_onb", "spectral_pole_set", "clear_of_spectrum"]


def _sylvester_maps(Lam: np.ndarray, A0: np.ndarray, M: np.ndarray) -> list[np.ndarray]:
    """``T(E_ij)`` solving ``T A0 − Λ T = E_ij M`` for every unit ``E_ij`` (ν × ρ)."""
    nu, rho = Lam.shape[0], M.shape[0]
    SL, UL = sla.schur(Lam.astype(complex), output="complex")
    SA, UA = sla.schur(A0.astype(complex), output="complex")
    MU = M @ UA
    out = []
    for i in range(nu):
        left = UL.conj().T[:, i]  # U_Lᴴ e_i
        for j in range(rho):
            # S_L X − X S_A = −U_Lᴴ E_ij M U_A, with X = U_Lᴴ T U_A
            rhs = -np.outer(left, MU[j])
            X, scale, info = lapack.ztrsyl(SL, SA, rhs, isgn=-1)
            if info < 0 or scale == 0:
                raise np.linalg.LinAlgError("parity space: Sylvester solve failed")
            out.append((UL @ (X / scale) @ UA.conj().T).real)
    return out


def onb_parity_space(
    Qm: Any, nu: int, dim: int, poles: np.ndarray, dt: float, points: np.ndarray
) -> dict[str, Any]:
    """The degree-ν parity space in the orthonormal basis and its target responses.

    Parameters
    ----------
    Qm : Quotient
    nu : int
        Degree (ν ≥ 1).
    dim : int
        Its dimension, from the observer staircase.
    poles : ndarray
        ν distinct stable poles closed under conjugation.
    dt : float
    points : ndarray
        Complex points for the target responses.

    Returns
    -------
    dict
        ``Lam``, ``c``, ``X`` (basis of the space in the unknowns ``(vec G_s, h)``, columns
        orthonormal in the normalised coordinates), ``maps`` (the ``T(E_ij)``), ``W``
        (per target, the response matrix ``X``-coordinates × (points · m_j)), ``full``
        (per target, the response of every unknown, for the relative size), ``gap``.
    """
    k, rho = Qm.k, Qm.rho
    Lam, c = output_normal_basis(poles, dt)
    maps = _sylvester_maps(Lam, Qm.A0, Qm.M)
    rows = [c @ T for T in maps] + [Qm.M[j] for j in range(rho)]
    R = np.array(rows)  # (ν ρ + ρ) × k
    norms = np.linalg.norm(R, axis=1)
    norms[norms == 0] = 1.0
    Rn = R / norms[:, None]
    U, s, _ = np.linalg.svd(Rn, full_matrices=True)
    rank = Rn.shape[0] - dim
    if rank < 0 or dim <= 0:
        raise np.linalg.LinAlgError("parity space: inconsistent dimension")
    kept = float(s[rank - 1]) if rank > 0 else 1.0
    dropped = float(s[rank]) if rank < s.size else 0.0
    X = U[:, rank:] / norms[:, None]  # in the unknowns' own coordinates
    # target responses: r_f(s) = c (sI − Λ)⁻¹ (G_s Df − T Bf) + h Df
    nt = len(Qm.Bf)
    W: list[list[np.ndarray]] = [[] for _ in range(nt)]
    full: list[list[np.ndarray]] = [[] for _ in range(nt)]
    for sp in points:
        phi = np.linalg.solve((sp * np.eye(nu) - Lam).T, c)  # c (sI − Λ)⁻¹
        for j in range(nt):
            Bf, Df = Qm.Bf[j], Qm.Df[j]
            resp = []
            for idx, T in enumerate(maps):
                i, jj = divmod(idx, rho)
                resp.append(phi[i] * Df[jj] - phi @ (T @ Bf))
            resp += [Df[jj].astype(complex) for jj in range(rho)]
            Fj = np.array(resp)  # unknowns × m_j
            W[j].append(X.T @ Fj)
            full[j].append(Fj / norms[:, None])
    Wj = [np.hstack(w) for w in W]
    Fj = [np.hstack(f) for f in full]
    rel = np.array(
        [_norm2(w) / max(_norm2(f), 1e-300) if f.size else 0.0 for w, f in zip(Wj, Fj, strict=True)]
    )
    return {
        "Lam": Lam,
        "c": c,
        "X": X,
        "maps": maps,
        "W": Wj,
        "rel": rel,
        "gap": kept / max(dropped, np.finfo(float).eps),
        "k": k,
    }


def realise_onb(space: dict[str, Any], x: np.ndarray, rho: int) -> tuple[np.ndarray, ...]:
    """``(Λ, G_s, T, c, h)`` of the row ``x`` (coordinates ``(vec G_s, h)``)."""
    Lam, c, maps = space["Lam"], space["c"], space["maps"]
    nu = Lam.shape[0]
    g = x[: nu * rho]
    Gs = g.reshape(nu, rho)
    T = sum(gi * Ti for gi, Ti in zip(g, maps, strict=True))
    if not isinstance(T, np.ndarray):
        T = np.zeros((nu, space["k"]))
    h = x[nu * rho :]
    return Lam, Gs, T, c, h


def clear_of_spectrum(poles: np.ndarray, eig: np.ndarray, scale: float) -> np.ndarray:
    """The poles, each moved outwards by factors ``1 + 1e-3`` until it is more than
    ``1e-6 scale`` from every eigenvalue (a Sylvester equation with a shared eigenvalue
    has no unique solution)."""
    out = np.asarray(poles, dtype=complex).copy()
    for t in range(out.size):
        for _ in range(20):
            if not eig.size or np.min(np.abs(eig - out[t])) > 1e-6 * max(scale, 1e-300):
                break
            out[t] *= 1.0 + 1e-3
    return out


def spectral_pole_set(A0: np.ndarray, nu: int, omega: float, dt: float) -> np.ndarray:
    """ν stable poles spread over the quotient's own frequencies (orthonormal parity basis).

    Every eigenvalue λ of A0 gets a damped copy at its frequency: continuous
    ``−(|Re λ| + 2α) + i Im λ`` with ``α = SDEG · ω`` (the stability degree of
    :func:`geomfdi.synthesis.least_order.injection.mirror_rule`),
    discrete ``0.9 min(|λ|, 1/|λ|) λ/|λ|``
    (at least 0.05); never an eigenvalue of A0.  The copies are sorted by frequency and ν of
    them taken evenly (conjugate pairs kept whole; an odd ν gets a real copy, or ``−ω``
    / 0.5).  A basis whose poles follow the quotient's dynamics represents its rows with
    small coefficients; poles far from them (the default sequence) amplify rounding.
    """
    eig = np.linalg.eigvals(A0) if A0.size else np.zeros(0, complex)
    if dt > 0:
        r = np.abs(eig)
        rr = np.maximum(0.9 * np.where(r <= 1.0, r, 1.0 / np.maximum(r, 1e-300)), 0.05)
        ang = np.where(r > 0, eig / np.maximum(r, 1e-300), 1.0)
        cand = rr * ang
        filler = 0.5
    else:
        alpha = 0.05 * max(omega, 1e-300)
        cand = -(np.abs(eig.real) + 2 * alpha) + 1j * eig.imag
        filler = -max(omega, 1e-300)
    tol = 1e-12 * np.maximum(1.0, np.abs(cand))
    up = cand[cand.imag > tol]
    real = np.sort(cand[np.abs(cand.imag) <= tol].real)
    up = up[np.argsort(up.imag)]
    npair = min(nu // 2, up.size)
    nreal = nu - 2 * npair
    out: list[complex] = []
    if npair:
        for i in np.linspace(0, up.size - 1, npair).round().astype(int):
            out += [complex(up[i]), complex(np.conj(up[i]))]
    if nreal:
        pick = real[np.linspace(0, real.size - 1, nreal).round().astype(int)] if real.size else []
        vals = [complex(x) for x in pick]
        vals += [complex(filler * (1 + 0.1 * j)) for j in range(nreal - len(vals))]
        out += vals
    return clear_of_spectrum(np.array(out, dtype=complex), eig, omega)
