"""Two-fault and k-fault statistics: Qin & Niu's ``D+/-`` and the subset GLR.

For a subset ``S`` of fault hypotheses with whitened signatures ``G_S`` the GLR is
``a_S^T (G_S^T G_S)^+ a_S`` with ``a_i = q^T G_i / sigma``. Qin & Niu (1999) test the
equal-size hypotheses ``f (e_i +/- e_j)``:
``D+/-_ij = ((V_i +/- V_j)^T p)^2 / (sigma^2 ||V_i +/- V_j||^2)``. See the user guide,
*Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING, Any

import numpy as np

from geomfdi._validation import as_int
from geomfdi.errors import GeomFDIError
from geomfdi.parity._input import _guarded, _samples
from geomfdi.parity._records import ParityData, as_data
from geomfdi.parity.glt import _a, _fi_from_a
from geomfdi.tolerance import get_rtol, rank_decision

if TYPE_CHECKING:
    from geomfdi.parity._records import HasParityData

__all__ = ["pair_statistics", "two_fault_glr", "glr_statistics"]


def _subset_info(pf: ParityData, kk: int) -> dict[str, np.ndarray]:
    """Rank, ambiguity and ``(G_S^T G_S)^+`` for every ``kk``-subset of faults."""
    if kk in pf.subset_cache:
        return pf.subset_cache[kk]
    if kk == 1:
        info = _single_info(pf)
        pf.subset_cache[1] = info
        return info
    G, k, s = pf.G, pf.k, pf.s
    subsets = np.array(list(itertools.combinations(range(k), kk)), dtype=np.intp)
    if subsets.size == 0:
        subsets = subsets.reshape(0, kk)
    C = subsets.shape[0]
    tol_n = pf.m
    GS = G[:, subsets].transpose(1, 0, 2)  # (C, s, kk)
    _, S, Vt = np.linalg.svd(GS, full_matrices=False)
    rank = np.array(
        [rank_decision(S[c], pf.scaleG, tol_n, warn=False).rank for c in range(C)],
        dtype=np.intp,
    )
    pinv = np.zeros((C, kk, kk))
    for c in range(C):
        r = rank[c]
        if r:
            Vr = Vt[c, :r, :]
            pinv[c] = Vr.T @ (Vr / S[c, :r, None] ** 2)
    valid = rank == kk
    ambiguous = np.zeros(C, dtype=bool)
    # S is ambiguous when a detectable fault j outside S lies in span(G_S): swapping
    # j for a member of S then gives another subset with the same span
    for c in np.flatnonzero(valid):
        others = np.setdiff1d(np.flatnonzero(pf.detectable), subsets[c])
        if others.size == 0:
            continue
        stack = np.concatenate(
            [
                np.broadcast_to(G[:, subsets[c]], (others.size, s, kk)),
                G[:, others].T[:, :, None],
            ],
            axis=2,
        )
        sv = np.linalg.svd(stack, compute_uv=False)
        ranks = [rank_decision(x, pf.scaleG, tol_n, warn=False).rank for x in sv]
        ambiguous[c] = min(ranks) <= kk
    info = {
        "subsets": subsets,
        "rank": rank,
        "valid": valid,
        "ambiguous": ambiguous,
        "pinv": pinv,
    }
    pf.subset_cache[kk] = info
    return info


def _parallel_pairs(pf: ParityData) -> np.ndarray:
    """``(k, k)`` bool: detectable hypotheses ``i != j`` with parallel signatures.

    A pair is screened from the Gram matrix ``G^T G`` (one matrix product): the smallest
    singular value of ``[G_i, G_j]`` is about ``min(|G_i|, |G_j|) sin(angle)``, and the
    angle from the Gram matrix is accurate to ~1e-8.  Only the screened candidates get the
    exact rank decision on the SVD of ``[G_i, G_j]``; this keeps the construction at
    ``O(k^2 (m - n))`` instead of one SVD per pair.
    """
    G, k = pf.G, pf.k
    det = pf.detectable
    out = np.zeros((k, k), dtype=bool)
    idx = np.flatnonzero(det)
    if idx.size < 2:
        return out
    Gd = G[:, idx]
    norms = np.linalg.norm(Gd, axis=0)
    U = Gd / norms
    cos = np.clip(np.abs(U.T @ U), 0.0, 1.0)
    sin = np.sqrt(np.maximum(1.0 - cos * cos, 0.0))
    small = np.minimum.outer(norms, norms)
    tol = get_rtol(pf.m) * pf.scaleG
    cand = small * np.maximum(sin - 1e-6, 0.0) <= 10.0 * tol
    np.fill_diagonal(cand, False)
    for a, b in zip(*np.nonzero(np.triu(cand)), strict=True):
        sv = np.linalg.svd(Gd[:, [a, b]], compute_uv=False)
        if rank_decision(sv, pf.scaleG, pf.m, warn=False).rank <= 1:
            out[idx[a], idx[b]] = out[idx[b], idx[a]] = True
    return out


def _single_info(pf: ParityData) -> dict[str, np.ndarray]:
    """:func:`_subset_info` for single faults, without a per-pair SVD loop."""
    k = pf.k
    valid = pf.detectable.copy()
    pinv = np.zeros((k, 1, 1))
    pinv[valid, 0, 0] = 1.0 / pf.w[valid]
    return {
        "subsets": np.arange(k, dtype=np.intp).reshape(k, 1),
        "rank": valid.astype(np.intp),
        "valid": valid,
        "ambiguous": _parallel_pairs(pf).any(axis=1) & valid,
        "pinv": pinv,
    }


def _pairs_from_a(pf: ParityData, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    G = pf.G
    plus_dir = G[:, :, None] + G[:, None, :]
    minus_dir = G[:, :, None] - G[:, None, :]
    den_p = np.einsum("sij,sij->ij", plus_dir, plus_dir)
    den_m = np.einsum("sij,sij->ij", minus_dir, minus_dir)
    tol2 = (get_rtol(pf.m) * pf.scaleG) ** 2
    inv_p = np.where(den_p > tol2, 1.0 / np.where(den_p > tol2, den_p, 1.0), 0.0)
    inv_m = np.where(den_m > tol2, 1.0 / np.where(den_m > tol2, den_m, 1.0), 0.0)
    np.fill_diagonal(inv_p, 0.0)
    np.fill_diagonal(inv_m, 0.0)
    plus = (a[:, :, None] + a[:, None, :]) ** 2 * inv_p
    minus = (a[:, :, None] - a[:, None, :]) ** 2 * inv_m
    return plus, minus


@_guarded
def pair_statistics(pf: ParityData | HasParityData, Z: Any) -> tuple[np.ndarray, np.ndarray]:
    """Qin & Niu (1999)'s two-fault isolation functions ``(D+, D-)``, each (N, k, k).

    ``D+/-_ij = ((V_i +/- V_j)^T p)^2 / (sigma^2 ||V_i +/- V_j||^2)`` is the
    likelihood-ratio gain of the hypothesis "sensors i and j carry faults of equal
    size and equal (+) or opposite (-) sign".

    Returns
    -------
    plus, minus : ndarray, shape (N, k, k)
        Symmetric; the diagonal (``i = j`` is not a pair) and pairs whose direction
        ``V_i +/- V_j`` vanishes are 0.

    Notes
    -----
    The formulas of Qin & Niu (1999) eq. 11-16 were lost in the OCR; they are rebuilt from
    its text: ``p = V eps + f (V_i + V_j)`` (eq. 11), the likelihood is a parabola in
    ``f`` maximised at ``f = (V_i + V_j)^T p / ||V_i + V_j||^2`` (eq. 13), and the
    maximal density is largest when ``D+_ij`` is (eq. 14-15); eq. 16 likewise with
    ``V_i - V_j``.

    References
    ----------
    Qin & Niu (1999), eq. 8-16.
    """
    pf = as_data(pf)
    Z = _samples(pf, Z)
    return _pairs_from_a(pf, _a(pf, Z))


def _glr2_from_a(pf: ParityData, a: np.ndarray, fi: np.ndarray) -> np.ndarray:
    info = _subset_info(pf, 2)
    N, k = a.shape
    out = np.zeros((N, k, k))
    idx = np.arange(k)
    out[:, idx, idx] = fi
    for c, (i, j) in enumerate(info["subsets"]):
        if info["valid"][c]:
            P = info["pinv"][c]
            ai, aj = a[:, i], a[:, j]
            val = P[0, 0] * ai * ai + 2.0 * P[0, 1] * ai * aj + P[1, 1] * aj * aj
        else:  # parallel or zero signatures: the span is (at most) one of them
            val = np.maximum(fi[:, i], fi[:, j])
        out[:, i, j] = val
        out[:, j, i] = val
    return out


@_guarded
def two_fault_glr(pf: ParityData | HasParityData, Z: Any) -> np.ndarray:
    """Two-fault GLR ``p^T V_S (V_S^T V_S)^{-1} V_S^T p / sigma^2`` for every pair.

    Returns
    -------
    ndarray, shape (N, k, k)
        Symmetric; entry ``(i, j)`` is the likelihood-ratio gain of "faults of any
        sizes on i and j"; the diagonal holds the single-fault ``FI(i)``.  For
        ``||V_i|| = ||V_j||`` the entry equals ``D+_ij + D-_ij``.

    Notes
    -----
    With ``a_i = p^T V_i / sigma`` and ``w_ij = V_i^T V_j``, the entry is
    ``(w_jj a_i^2 - 2 w_ij a_i a_j + w_ii a_j^2) / (w_ii w_jj - w_ij^2)``; a pair
    with parallel signatures spans one direction and gets ``max(FI(i), FI(j))``.

    References
    ----------
    Generalised likelihood ratio for the two-fault hypothesis ``H_ij`` of Qin & Niu (1999)
    eq. 8 with both sizes free.
    """
    pf = as_data(pf)
    Z = _samples(pf, Z)
    a = _a(pf, Z)
    return _glr2_from_a(pf, a, _fi_from_a(pf, a))


@_guarded
def glr_statistics(
    pf: ParityData | HasParityData, Z: Any, n_faults: int
) -> tuple[np.ndarray, np.ndarray]:
    """k-fault GLR ``p^T V_S (V_S^T V_S)^+ V_S^T p / sigma^2`` for every k-subset ``S``.

    Parameters
    ----------
    Z : array_like, shape (N, m) or (m,)
    n_faults : int
        Subset size ``k >= 1`` (keep it small: there are ``C(m, k)`` subsets).

    Returns
    -------
    stats : ndarray, shape (N, C)
        GLR of each subset (pseudo-inverse for subsets whose signatures are
        dependent).
    subsets : ndarray of int, shape (C, k)
        The subsets, in lexicographic order.
    """
    pf = as_data(pf)
    kk = as_int(n_faults, "n_faults", minimum=1)
    if kk > pf.k:
        raise GeomFDIError(
            f"n_faults: at most {pf.k} fault hypotheses exist, got {kk}",
            argument="n_faults",
        )
    Z = _samples(pf, Z)
    a = _a(pf, Z)
    info = _subset_info(pf, kk)
    out = np.empty((a.shape[0], info["subsets"].shape[0]))
    for c, S in enumerate(info["subsets"]):
        aS = a[:, S]
        out[:, c] = np.einsum("ni,ij,nj->n", aS, info["pinv"][c], aS)
    return out, info["subsets"].copy()
