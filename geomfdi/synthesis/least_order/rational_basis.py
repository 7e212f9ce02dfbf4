"""Real output-normal (orthonormal) rational bases and the frequencies that sample them.

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``,
section 6).

For stable poles ``p_1 … p_k`` (closed under conjugation), a real pair ``(Λ, h)`` with
``spec Λ = {p_i}`` and ``Λ + Λᵀ = −hᵀh`` (discrete ``ΛᵀΛ + hᵀh = I``) makes the functions
``h (sI − Λ)⁻¹ e_j`` orthonormal on the stability boundary (the Takenaka–Malmquist basis;
Ninness & Gustafsson 1997).  It is built directly, block by block::

    Λ = blockdiag(Λ_i) − (block strictly upper part of hᵀ h),
    Λ_i = p, h_i = √(−2 Re p)                          (a real pole)
    Λ_i = [[2σ, |p|], [−|p|, 0]], h_i = [2√(−σ), 0]    (a pair σ ± iω)

so that every entry is of the size of the poles, however many and however clustered;
the discrete basis is the bilinear image for the poles ``(z − 1)/(z + 1)``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["output_normal_basis", "output_normal_rows", "phase_frequencies"]


def _pairs_first(poles: np.ndarray) -> np.ndarray:
    """Real poles, then conjugate pairs as ``(p, p̄)`` with ``Im p > 0``."""
    p = np.asarray(poles, dtype=complex)
    tol = 1e-12 * np.maximum(1.0, np.abs(p))
    real = np.sort(p[np.abs(p.imag) <= tol].real).astype(complex)
    upper = p[p.imag > tol]
    upper = upper[np.argsort(upper.real)]
    return np.concatenate([real, np.column_stack([upper, upper.conj()]).ravel()])


def output_normal_basis(poles: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Real output-normal pair ``(Λ, h)`` with ``spec Λ = poles`` (module Notes, step 1).

    Parameters
    ----------
    poles : ndarray
        Stable poles, closed under conjugation (the pairs are matched here).
    dt : float
        0: continuous (``Λ + Λᵀ = −hᵀ h``); > 0: discrete (``ΛᵀΛ + hᵀh = I``).

    Returns
    -------
    Lam : ndarray, shape (k, k)
        Block upper triangular: real poles first, then 2 × 2 blocks of the pairs.
    h : ndarray, shape (k,)
    """
    p = _pairs_first(poles)
    if dt > 0:
        p = (p - 1.0) / (p + 1.0)
    k = p.size
    h = np.zeros(k)
    blocks: list[tuple[int, np.ndarray]] = []
    i = 0
    while i < k:
        if p[i].imag > 0:
            sig = p[i].real
            h[i] = 2.0 * np.sqrt(-sig)
            blocks.append((i, np.array([[2.0 * sig, abs(p[i])], [-abs(p[i]), 0.0]])))
            i += 2
        else:
            h[i] = np.sqrt(-2.0 * p[i].real)
            blocks.append((i, np.array([[p[i].real]])))
            i += 1
    Lam = -np.triu(np.outer(h, h), 1)
    for j, b in blocks:
        m = b.shape[0]
        Lam[j : j + m, j : j + m] = b
    if dt > 0 and k:
        X = np.linalg.inv(np.eye(k) - Lam)
        return (np.eye(k) + Lam) @ X, np.sqrt(2.0) * (h @ X)
    return Lam, h


def output_normal_rows(poles: np.ndarray, dt: float, pts: np.ndarray) -> np.ndarray:
    """``h (sI − Λ)⁻¹`` of :func:`output_normal_basis` at every point, ``O(k)`` per point.

    ``x = h (sI − Λ)⁻¹`` solves ``x (sI − blockdiag(Λ_i)) + x U = h`` with U the block
    strictly upper part of ``hᵀ h``, and ``(x U)_j = σ_j h_j``, ``σ_j = Σ_{i<j} x_i · h_i``:
    block by block, ``x_j = (1 − σ_j) h_j (sI − Λ_j)⁻¹`` (``1 − σ_j`` is the all-pass
    product of the earlier blocks).  Discrete: the continuous rows at
    ``s = (z − 1)/(z + 1)`` times ``√2 / (z + 1)`` (the bilinear map of the basis).

    Returns
    -------
    ndarray, shape (P, k)
        Row p is the basis at ``pts[p]``, in the order of :func:`output_normal_basis`.
    """
    p = _pairs_first(poles)
    z = np.asarray(pts, dtype=complex)
    s = z
    if dt > 0:
        p = (p - 1.0) / (p + 1.0)
        s = (z - 1.0) / (z + 1.0)
    k = p.size
    out = np.empty((z.size, k), dtype=complex)
    sig = np.zeros(z.size, dtype=complex)
    i = 0
    while i < k:
        if p[i].imag > 0:  # Λ_i = [[2σ, |p|], [−|p|, 0]], h_i = [2√(−σ), 0]
            sr, ap = p[i].real, abs(p[i])
            h1 = 2.0 * np.sqrt(-sr)
            f = (1.0 - sig) * h1 / (s * (s - 2.0 * sr) + ap * ap)
            out[:, i], out[:, i + 1] = f * s, f * ap
            sig = sig + out[:, i] * h1
            i += 2
        else:
            hj = np.sqrt(-2.0 * p[i].real)
            out[:, i] = (1.0 - sig) * hj / (s - p[i].real)
            sig = sig + out[:, i] * hj
            i += 1
    if dt > 0:
        out *= (np.sqrt(2.0) / (z + 1.0))[:, None]
    return out


def phase_frequencies(
    poles: np.ndarray, dt: float, per: int, every: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """Sample points on the stability boundary, equispaced in the basis' phase, and weights.

    Continuous: with ``w_j = |Re p_j|``, ``b_j = Im p_j ≥ 0`` (each pair once), the phase
    ``Θ(ω) = Σ_j atan((ω − b_j)/w_j) + atan((ω + b_j)/w_j)`` increases from 0 to
    ``π · #poles`` on ``ω ≥ 0``; its derivative ``ρ(ω)`` is the density of
    ``|h (iω − Λ)⁻¹|²`` (the orthonormal functions behave like ``e^{ikΘ}``).  The points
    solve ``Θ(ω_i) = π #poles (i + ½)/N`` (Newton in ``atan ω`` from a grid,
    safeguarded by bisection of its bracket), ``N = per · k / 2``
    complex points for k real basis functions; weights ``ρ(ω_i)^{-1/2}`` make the
    least-squares problem a discretised inner product.  Clustered poles thus get as many
    points as their share of the phase, not copies of one another's.  Discrete: the
    same on the bilinear images, mapped to ``z = e^{2i atan ω}``.  ``every > 1``: only
    the points ``0, every, 2 every, …`` of that set (a cheap first look at the response).
    """
    p = np.asarray(poles, dtype=complex)
    c = (p - 1.0) / (p + 1.0) if dt > 0 else p
    k = c.size
    c = c[c.imag >= 0]
    w, b = np.abs(c.real), c.imag

    def theta(om: np.ndarray) -> np.ndarray:
        x = om[:, None]
        return np.sum(np.arctan((x - b) / w) + np.arctan((x + b) / w), axis=1)

    def density(om: np.ndarray) -> np.ndarray:
        x = om[:, None]
        return np.sum(w / ((x - b) ** 2 + w * w) + w / ((x + b) ** 2 + w * w), axis=1)

    npts = max(1, int(np.ceil(per * k / 2)))
    target = (np.pi * c.size * (np.arange(npts) + 0.5) / npts)[:: max(1, int(every))]
    npts = target.size
    # bracket and first guess from Θ on a grid in φ = atan ω (Θ increases), then Newton
    # safeguarded by the bracket
    grid = np.linspace(0.0, np.pi / 2, 2 * npts + 1)
    tg = np.maximum.accumulate(theta(np.tan(grid)))
    idx = np.clip(np.searchsorted(tg, target), 1, grid.size - 1)
    lo, hi = grid[idx - 1], grid[idx]
    frac = (target - tg[idx - 1]) / np.maximum(tg[idx] - tg[idx - 1], 1e-300)
    phi = lo + np.clip(frac, 0.0, 1.0) * (hi - lo)
    todo = np.arange(npts)
    tol = 32 * np.finfo(float).eps
    for _ in range(40):
        p_, om = phi[todo], np.tan(phi[todo])
        res = theta(om) - target[todo]
        up = res < 0
        lo[todo] = np.where(up, p_, lo[todo])
        hi[todo] = np.where(up, hi[todo], p_)
        new = p_ - res / np.maximum(density(om) * (1.0 + om * om), 1e-300)
        out = ~((new >= lo[todo]) & (new <= hi[todo]))
        new[out] = 0.5 * (lo[todo][out] + hi[todo][out])
        phi[todo] = new
        moving = np.abs(new - p_) > tol * np.maximum(np.abs(p_), 1.0)
        todo = todo[moving & (hi[todo] - lo[todo] > tol)]
        if not todo.size:
            break
    om = np.tan(phi)
    dens = density(om)
    wts = 1.0 / np.sqrt(np.maximum(dens, 1e-300))
    pts = np.exp(2j * np.arctan(om)) if dt > 0 else 1j * om
    return pts, wts
