"""Optimal parity vectors (OPT) and the corrected OPT detection function.

Jin & Zhang's optimal parity vector for fault ``i`` maximises the fault-to-noise ratio
over the parity space; with ``D = F = I`` it is ``v_i = W_i / ||W_i||`` and
``d_i^2 = FI(i)`` (Zhang, Chen & Liu 2005, Theorems 2-3). The corrected detection
function ``FD_OPT`` sums squares over a noise-orthonormal basis of the span of the
``v_i`` and equals ``FD_GLT`` (their Theorem 4). See the user guide, *Theory: parity
space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import linalg as sla

from geomfdi.parity._input import _guarded, _samples
from geomfdi.parity._records import ParityData, as_data
from geomfdi.tolerance import rank_decision

if TYPE_CHECKING:
    from geomfdi.parity._records import HasParityData

__all__ = [
    "opt_vectors",
    "opt_performance",
    "opt_statistics",
    "opt_detection_statistic",
    "opt_dof",
]


def _opt_data(pf: ParityData) -> dict[str, np.ndarray]:
    if pf.opt_cache:
        return pf.opt_cache
    V, Dm = pf.V, pf.Dm
    Sigma = np.eye(pf.m) if pf.Sigma is None else pf.Sigma
    U = V @ Dm  # u_i = V D e_i
    M0 = V @ (Sigma + Dm @ Dm.T) @ V.T
    vecs = np.zeros((pf.m, pf.k))
    perf = np.zeros(pf.k)
    for i in np.flatnonzero(pf.detectable):
        ui = U[:, i]
        Mi = M0 - np.outer(ui, ui)  # V (F F^T + sum_{j != i} D e_j e_j^T D^T) V^T
        ci = sla.solve((Mi + Mi.T) / 2.0, ui, assume_a="pos")
        perf[i] = float(ui @ ci)
        v = V.T @ ci
        v /= np.linalg.norm(v)
        if v @ Dm[:, i] < 0:
            v = -v
        vecs[:, i] = v
    noise = np.sqrt(np.einsum("ji,jk,ki->i", vecs, Sigma, vecs))
    dmat = np.zeros_like(vecs)
    ok = pf.detectable
    dmat[:, ok] = vecs[:, ok] / (pf.sigma * noise[ok])
    # corrected OPT: noise-orthonormal basis of span{v_i} (Gram-Schmidt with pivoting)
    if ok.any():
        Qv, Rv, _ = sla.qr(vecs[:, ok], pivoting=True, mode="economic")
        dr = rank_decision(
            np.abs(np.diag(Rv)), 1.0, pf.m, what="span of the optimal parity vectors"
        )
        Bv = Qv[:, : dr.rank]
        C = Bv.T @ Sigma @ Bv
        Lc = np.linalg.cholesky((C + C.T) / 2.0)
        Ubasis = sla.solve_triangular(Lc, Bv.T, lower=True).T
    else:
        Ubasis = np.zeros((pf.m, 0))
    pf.opt_cache.update({"vectors": vecs, "perf": perf, "dmat": dmat, "U": Ubasis})
    return pf.opt_cache


def opt_vectors(pf: ParityData | HasParityData) -> np.ndarray:
    """Unit optimal parity vectors ``v_i`` as columns, shape (m, k).

    Notes
    -----
    Zhang, Chen & Liu (2005) eq. 7 maximises, over ``v = V^T c`` (so that ``v^T H = 0``),

    ``S_i(c) = (c^T u_i)^2 / (c^T M_i c)``,   ``u_i = V D e_i``,
    ``M_i = V (F F^T + sum_{j != i} D e_j e_j^T D^T) V^T``.

    This is a generalised Rayleigh quotient whose numerator has rank one: the
    generalised eigenproblem ``u_i u_i^T c = lambda M_i c`` has the single nonzero
    eigenvalue ``lambda = u_i^T M_i^{-1} u_i`` with eigenvector ``c_i = M_i^{-1} u_i``
    (Cauchy-Schwarz in the ``M_i`` inner product), so ``v_i = V^T M_i^{-1} u_i``
    (eq. 8), normalised and signed so that ``v_i^T D e_i > 0``.  ``M_i`` is
    positive definite because ``V F F^T V^T`` is.  By Sherman-Morrison
    ``M_i^{-1} u_i`` is proportional to ``M_0^{-1} u_i`` with
    ``M_0 = V (F F^T + D D^T) V^T``.  With ``D = F = I``: ``M_0 = 2 I`` and
    ``v_i = W_i / sqrt(w_ii)`` (Theorem 3).  An undetectable fault (``u_i = 0``) gets
    the zero vector.
    """
    pf = as_data(pf)
    return _opt_data(pf)["vectors"].copy()


def opt_performance(pf: ParityData | HasParityData) -> np.ndarray:
    """The maximised OPT index ``S_i = u_i^T M_i^{-1} u_i`` (Zhang, Chen & Liu 2005, eq. 7)."""
    pf = as_data(pf)
    return _opt_data(pf)["perf"].copy()


@_guarded
def opt_statistics(pf: ParityData | HasParityData, Z: Any) -> np.ndarray:
    """Standardised optimal parity residuals ``d_i = v_i^T Z / (sigma ||v_i^T F||)``.

    Returns
    -------
    ndarray, shape (N, k)
        ``d_i ~ N(0, 1)`` without fault; ``d_i^2 = FI(i)`` when ``D = F = I``
        (Theorem 2).

    References
    ----------
    Zhang, Chen & Liu (2005), eq. 9 and Theorem 2.
    """
    pf = as_data(pf)
    Z = _samples(pf, Z)
    return Z @ _opt_data(pf)["dmat"]


@_guarded
def opt_detection_statistic(pf: ParityData | HasParityData, Z: Any) -> np.ndarray:
    """Corrected OPT detection function ``FD_OPT = sum_k (v_0k^T Z / sigma)^2``, (N,).

    Notes
    -----
    The ``v_0k`` are an orthonormal basis (in the noise metric ``F F^T``, so that the
    terms are independent by Zhang, Chen & Liu (2005)'s Lemma 3) of the span of the optimal parity
    vectors, obtained by Gram-Schmidt with column pivoting (QR).  Its dimension
    :attr:`opt_dof` is ``m - n`` whenever the vectors span the parity space (always
    for ``D = I``), and then ``FD_OPT = FD_GLT`` (Theorem 4).

    References
    ----------
    Zhang, Chen & Liu (2005), eq. 23, 25-26.
    """
    pf = as_data(pf)
    Z = _samples(pf, Z)
    P = Z @ _opt_data(pf)["U"]
    return np.einsum("ij,ij->i", P, P) / pf.sigma**2


def opt_dof(pf: ParityData | HasParityData) -> int:
    """Degrees of freedom of :meth:`opt_detection_statistic`."""
    pf = as_data(pf)
    return int(_opt_data(pf)["U"].shape[1])
