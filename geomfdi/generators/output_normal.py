"""Resolvents of a generator in output-normal form, ``O(k)`` per point.

A single-output generator realised in an orthonormal rational basis (the user guide,
*Theory: least-order synthesis*, ``docs/theory/least-order.md``) has::

    F = blockdiag(F_1, …, F_b) − (block strictly upper part of Mᵀ M),   M = h (one row)

with 1 × 1 and 2 × 2 diagonal blocks ``F_j`` (Ninness & Gustafsson 1997).  The strictly
upper part is of rank one, so the resolvents are block substitutions carrying one scalar
per point: for the rows ``x = h (sI − F)⁻¹``,
``x_j = (1 − σ_j) h_j (sI − F_j)⁻¹`` with ``σ_j = Σ_{i<j} x_i · h_i``; for a column
``y = (sI − F)⁻¹ w``, ``y_j = (sI − F_j)⁻¹ (w_j − h_jᵀ τ_j)`` with
``τ_j = Σ_{i>j} h_i · y_i``.  The structure is recognised exactly (the entries of F above
its diagonal blocks must equal ``−h_i h_j`` bit for bit), so these are substitutions on
the generator's own matrix, not on an approximation of it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["output_normal_blocks", "rows_resolvent", "column_resolvent"]


def output_normal_blocks(F: np.ndarray, M: np.ndarray) -> np.ndarray | None:
    """Start of each diagonal block of F when ``(F, M)`` has the structure of the module
    Notes (continuous form, one output), else None.  O(k²)."""
    k = F.shape[0]
    if M.shape != (1, k) or k < 2:
        return None
    sub = np.diag(F, -1) != 0
    if np.any(sub[1:] & sub[:-1]) or np.any(np.tril(F, -2)):
        return None
    h = M[0]
    mask = np.triu(np.ones((k, k), dtype=bool), 1)
    two = np.flatnonzero(sub)
    mask[two, two + 1] = False
    if not np.array_equal(F[mask], -np.outer(h, h)[mask]):
        return None
    starts = np.ones(k, dtype=bool)
    starts[two + 1] = False
    return np.flatnonzero(starts)


def _blocks(F: np.ndarray, starts: np.ndarray) -> list[tuple[int, int]]:
    ends = [*starts[1:].tolist(), F.shape[0]]
    return list(zip(starts.tolist(), ends, strict=True))


FEW_POINTS = 8
"""Point count up to which :func:`rows_resolvent` takes every block at once (the loop over
the blocks costs a few numpy calls per block, whatever the number of points)."""


def rows_resolvent(F: np.ndarray, h: np.ndarray, starts: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """``h (s_p I − F)⁻¹`` at every point, shape ``(P, k)`` (module Notes)."""
    s = np.asarray(pts, dtype=complex)
    if s.size <= FEW_POINTS:
        return _rows_at_few(F, h, starts, s)
    out = np.empty((s.size, F.shape[0]), dtype=complex)
    sig = np.zeros(s.size, dtype=complex)
    for a, b in _blocks(F, starts):
        if b - a == 1:
            x = (1.0 - sig) * h[a] / (s - F[a, a])
            out[:, a] = x
            sig = sig + x * h[a]
            continue
        f11, f12, f21, f22 = F[a, a], F[a, a + 1], F[a + 1, a], F[a + 1, a + 1]
        det = (s - f11) * (s - f22) - f12 * f21
        c = 1.0 - sig
        r1, r2 = c * h[a], c * h[a + 1]
        # [r1, r2] [[s − f11, −f12], [−f21, s − f22]]⁻¹
        x1 = (r1 * (s - f22) + r2 * f21) / det
        x2 = (r1 * f12 + r2 * (s - f11)) / det
        out[:, a], out[:, a + 1] = x1, x2
        sig = sig + x1 * h[a] + x2 * h[a + 1]
    return out


def column_resolvent(
    F: np.ndarray, h: np.ndarray, starts: np.ndarray, pts: np.ndarray, w: np.ndarray
) -> np.ndarray:
    """``(s_p I − F)⁻¹ w`` at every point for one vector w, shape ``(P, k)`` (module
    Notes)."""
    s = np.asarray(pts, dtype=complex)
    out = np.empty((s.size, F.shape[0]), dtype=complex)
    tau = np.zeros(s.size, dtype=complex)
    for a, b in reversed(_blocks(F, starts)):
        if b - a == 1:
            y = (w[a] - h[a] * tau) / (s - F[a, a])
            out[:, a] = y
            tau = tau + h[a] * y
            continue
        f11, f12, f21, f22 = F[a, a], F[a, a + 1], F[a + 1, a], F[a + 1, a + 1]
        det = (s - f11) * (s - f22) - f12 * f21
        r1, r2 = w[a] - h[a] * tau, w[a + 1] - h[a + 1] * tau
        # [[s − f11, −f12], [−f21, s − f22]]⁻¹ [r1; r2]
        y1 = ((s - f22) * r1 + f12 * r2) / det
        y2 = (f21 * r1 + (s - f11) * r2) / det
        out[:, a], out[:, a + 1] = y1, y2
        tau = tau + h[a] * y1 + h[a + 1] * y2
    return out


def _rows_at_few(F: np.ndarray, h: np.ndarray, starts: np.ndarray, s: np.ndarray) -> np.ndarray:
    """:func:`rows_resolvent` at a few points, every block at once: with the blocks' own
    rows ``r_j = h_j (sI − F_j)⁻¹``, ``x_j = (1 − σ_j) r_j`` and ``1 − σ_j`` the product
    of the all-pass factors ``b_i = 1 − r_i h_iᵀ`` of the blocks before j
    (``1 − σ_{i+1} = (1 − σ_i) b_i``): one cumulative product over the blocks."""
    k = F.shape[0]
    ends = np.append(starts[1:], k)
    one, two = starts[ends - starts == 1], starts[ends - starts == 2]
    col_block = np.cumsum(np.isin(np.arange(k), starts)) - 1
    x = s[None, :]
    r = np.empty((k, s.size), dtype=complex)
    r[one] = h[one, None] / (x - F[one, one][:, None])
    f11, f12 = F[two, two][:, None], F[two, two + 1][:, None]
    f21, f22 = F[two + 1, two][:, None], F[two + 1, two + 1][:, None]
    det = (x - f11) * (x - f22) - f12 * f21
    ha, hb = h[two, None], h[two + 1, None]
    # [ha, hb] [[s − f11, −f12], [−f21, s − f22]]⁻¹
    r[two] = (ha * (x - f22) + hb * f21) / det
    r[two + 1] = (ha * f12 + hb * (x - f11)) / det
    b = 1.0 - np.add.reduceat(r * h[:, None], starts, axis=0)
    c = np.ones_like(b)
    np.cumprod(b[:-1], axis=0, out=c[1:])
    return (c[col_block] * r).T
