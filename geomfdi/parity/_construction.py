"""Construction of a parity-space model: the parity matrix (Potter-Suman or SVD), the
noise whitening, the whitened fault signatures and the detectable / isolable hypotheses,
as a frozen :class:`~geomfdi.parity._records.ParityData` record; and the reduced
configuration without some sensors (re-detection after isolation).

References
----------
Potter & Suman (1977), thresholdless redundancy management; Zhang, Chen & Liu (2005), "Is
OPT better than GLT in fault diagnosis of redundant sensor system?".  See the user guide,
*Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from scipy import linalg as sla

from geomfdi._validation import as_int, as_matrix, as_positive, as_real_array, as_sequence_of
from geomfdi.errors import DesignError, GeomFDIError, RankDeficientError, ShapeError
from geomfdi.parity._records import ParityData
from geomfdi.parity.multiple import _subset_info
from geomfdi.tolerance import get_rtol, rank_decision

__all__ = ["build_data", "reduced_data"]

# Rows per block in diagnose: the block product (statistics x m) @ (m x rows) is kept at
# <= 2**19 multiply-adds, small enough for the cache and below OpenBLAS's threshold for
# threading a GEMM.
_CHUNK_FLOPS = 1 << 19
# Leading block of W used by the Potter-Suman construction must have its smallest singular
# value above this, otherwise the columns are pivoted (conditioning guard, not a rank
# decision: a nearly dependent leading block would make the QR span inaccurate).
_POTTER_MIN_SV = 1e-6


def _potter_suman(W: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormalise the first ``s`` columns (= rows) of the projector ``W``.

    Returns ``V`` ((s, m), rows orthonormal, ``V^T V = W``) and the sensor order used.
    ``V[:, order[:s]]`` is upper triangular with a positive diagonal: the explicit
    Potter-Suman form.  If the first ``s`` columns are (nearly) dependent, QR with
    column pivoting chooses the columns instead.
    """
    m = W.shape[0]
    Q, R = np.linalg.qr(W[:, :s])
    # sigma_min(lead) = sigma_min(R) >= 1 / (sqrt(s) ||R^-1||_1); LAPACK's trcon estimates
    # ||R^-1||_1 in O(s^2) (an SVD of the m x s block would cost as much as the QR)
    rcond = float(sla.lapack.dtrcon(R, norm="1", uplo="U", diag="N")[0]) if s else 1.0
    norm1 = float(np.abs(R).sum(axis=0).max()) if s else 1.0
    if rcond * norm1 / np.sqrt(max(s, 1)) > _POTTER_MIN_SV:
        order = np.arange(m)
    else:
        Qf, Rf, order = sla.qr(W, pivoting=True)
        Q, R = Qf[:, :s], Rf[:s, :s]
    signs = np.sign(np.diag(R))
    signs[signs == 0] = 1.0
    return (Q * signs).T.copy(), np.asarray(order)


def _sensor_labels(sensors: Any, m: int) -> np.ndarray:
    """Distinct non-negative integer labels, one per sensor (default ``0..m-1``)."""
    if sensors is None:
        return np.arange(m)
    arr = as_real_array(sensors, "sensors").reshape(-1)
    if arr.shape != (m,):
        raise ShapeError(f"sensors: expected {m} labels, got {arr.size}", argument="sensors")
    if np.any(arr != np.round(arr)) or np.any(arr < 0) or np.any(arr > np.iinfo(np.intp).max):
        raise GeomFDIError("sensors: labels must be non-negative integers", argument="sensors")
    labels = arr.astype(np.intp)
    uniq, counts = np.unique(labels, return_counts=True)
    if np.any(counts > 1):
        raise GeomFDIError(
            f"sensors: labels must be distinct, {uniq[counts > 1].tolist()} repeated",
            argument="sensors",
        )
    return labels


def build_data(
    H: Any,
    sigma: float = 1.0,
    D: Any = None,
    F: Any = None,
    basis: Any = "potter",
    chunk_size: int | None = None,
    sensors: Any = None,
) -> ParityData:
    """The record of the model ``Z = H x + D f + F eps`` (arguments as in
    :class:`~geomfdi.parity.model.ParityFDI`), validated."""
    H = as_matrix(H, "H", vector_as="column")
    m, n = H.shape
    if m <= n:
        raise ShapeError(
            f"H: a parity space needs more sensors than unknowns (m > n), got shape {H.shape}",
            argument="H",
        )
    sv = np.linalg.svd(H, compute_uv=False)
    dec = rank_decision(sv, float(sv[0]), m, what="H: full column rank")
    if dec.rank < n:
        raise RankDeficientError(
            f"H: must have full column rank {n}, numerical rank is {dec.rank} "
            f"(singular values {np.array2string(sv, precision=3)})",
            argument="H",
        )
    s = m - n
    sigma = as_positive(sigma, "sigma")
    if chunk_size is None:
        per_row = (m + s) * m  # (k + m - n) statistics per row, k = m by default
        chunk_size = 1 << max(10, min(16, (_CHUNK_FLOPS // per_row).bit_length() - 1))
    chunk_size = as_int(chunk_size, "chunk_size", minimum=1)
    labels = _sensor_labels(sensors, m)

    Qh = np.linalg.qr(H)[0]
    W = np.eye(m) - Qh @ Qh.T
    W = (W + W.T) / 2.0

    potter_order: np.ndarray | None = None
    if isinstance(basis, str):
        if basis == "potter":
            V, potter_order = _potter_suman(W, s)
        elif basis == "svd":
            U = np.linalg.svd(H, full_matrices=True)[0]
            V = U[:, n:].T.copy()
        else:
            raise GeomFDIError(
                f"basis: expected 'potter', 'svd' or an (m-n) x m matrix, got {basis!r}",
                argument="basis",
            )
        kind = basis
    else:
        V = as_matrix(basis, "basis", rows=s, cols=m)
        tol = 1e-8
        err_h = np.linalg.norm(V @ H, 2) / max(np.linalg.norm(H, 2), 1.0)
        err_o = np.linalg.norm(V @ V.T - np.eye(s), 2)
        if err_h > tol or err_o > tol:
            raise DesignError(
                f"basis: must satisfy V H = 0 and V V^T = I (errors {err_h:.2g}, {err_o:.2g})",
                argument="basis",
            )
        kind = "given"

    # noise model: whitening of the parity vector
    if F is None:
        Fm = None
        Sigma = None
        T = V.copy()
    else:
        Fm = as_matrix(F, "F", rows=m, vector_as="column")
        Sigma = Fm @ Fm.T
        Sp = V @ Sigma @ V.T
        Sp = (Sp + Sp.T) / 2.0
        ev = np.clip(np.linalg.eigvalsh(Sp)[::-1], 0.0, None)
        fnorm = float(np.linalg.norm(Fm, 2))
        d2 = rank_decision(np.sqrt(ev), fnorm, m, what="F: noise in parity space")
        if d2.rank < s:
            raise DesignError(
                "F: the noise must reach every parity direction (V F F^T V^T is "
                f"singular, rank {d2.rank} < {s})",
                argument="F",
            )
        L = np.linalg.cholesky(Sp)
        T = sla.solve_triangular(L, V, lower=True)
    # T: the whitened parity map, q = T Z

    # fault model
    if D is None:
        Dg = None
        Dm = np.eye(m)
    else:
        Dm = as_matrix(D, "D", rows=m, vector_as="column")
        Dg = Dm
    k = Dm.shape[1]
    plain = D is None and F is None  # V^T V = W: skip the m x m x m products
    G = T if D is None else T @ Dm
    Omega = W if plain else G.T @ G
    norm_t = 1.0 if F is None else float(np.linalg.norm(T, 2))
    norm_d = 1.0 if D is None else float(np.linalg.norm(Dm, 2))
    scaleG = max(norm_t * norm_d, 1e-300)
    gnorm = np.linalg.norm(G, axis=0)
    tolG = get_rtol(m) * scaleG
    detectable = gnorm > tolG
    w = np.where(detectable, gnorm**2, 0.0)
    TtG = W if plain else T.T @ G
    Bm = TtG / sigma  # Z @ B = a, a_i = q^T G_i / sigma
    Bn = np.zeros((m, k))  # Z @ Bn = sqrt(FI) with sign
    Bn[:, detectable] = Bm[:, detectable] / np.sqrt(w[detectable])
    data = ParityData(
        H=H,
        sigma=sigma,
        D=Dg,
        F=Fm,
        V=V,
        W=W,
        basis=kind,
        potter_order=potter_order,
        m=m,
        n=n,
        s=s,
        k=k,
        chunk_size=chunk_size,
        sensors=labels,
        T=T,
        Sigma=Sigma,
        Dm=Dm,
        G=G,
        Omega=Omega,
        scaleG=scaleG,
        w=w,
        B=Bm,
        Bn=Bn,
        detectable=detectable,
        isolable=detectable,
        lut=detectable,
    )
    # single-fault ambiguity needs the record; the subset cache carries over
    isolable = detectable & ~_subset_info(data, 1)["ambiguous"]
    lut = np.where(isolable, np.arange(k), -1).astype(np.intp)
    return replace(data, isolable=isolable, lut=lut)


def reduced_data(pf: ParityData, remove: int | Sequence[int]) -> ParityData:
    """The record of the configuration without the sensors ``remove`` (cached on ``pf``):
    what :func:`~geomfdi.parity.model.reduced_configuration` wraps, with its parameters and
    errors."""
    if pf.D is not None:
        raise DesignError(
            "remove: a reduced configuration needs D = I (faults are sensor faults)",
            argument="remove",
        )
    if isinstance(remove, int | np.integer):
        rem = [as_int(remove, "remove")]
    else:
        rem = [int(as_int(r, "remove")) for r in as_sequence_of(remove, "remove", object)]
    for r in rem:
        if not 0 <= r < pf.m:
            raise GeomFDIError(f"remove: index {r} out of range 0..{pf.m - 1}", argument="remove")
    key = tuple(sorted(set(rem)))
    if key in pf.reduced_cache:
        return pf.reduced_cache[key]
    keep = np.setdiff1d(np.arange(pf.m), key)
    if keep.size <= pf.n:
        raise DesignError(
            f"remove: removing {len(key)} sensor(s) leaves {keep.size} <= n = {pf.n}: "
            "no redundancy left",
            argument="remove",
        )
    basis = pf.basis if pf.basis in ("potter", "svd") else "potter"
    red = build_data(
        pf.H[keep],
        pf.sigma,
        None,
        None if pf.F is None else pf.F[keep],
        basis,
        None,
        pf.sensors[keep],
    )
    pf.reduced_cache[key] = red
    return red
