"""Stacking a plant over a window, the left null space ``N_H`` and the whitened fault maps.

Eq. (2) of Li, Wang & Liu (2015), ``L z_s = H x_s + F f_s + E e_s``; the projection on the
left null space of ``H`` and the whitening ``Gamma = (N_H E Sigma E^T N_H^T)^{-1/2}`` give
``q_i = Gamma N_H F_i theta``.  See the user guide, *Theory: diagnosability*
(``docs/theory/diagnosability.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from geomfdi.diagnosability._linalg import (
    _block_toeplitz,
    _left_null_rows,
    _sym_inv_sqrt,
    _times_kron,
)
from geomfdi.diagnosability.results import StackedWindow
from geomfdi.errors import DesignError
from geomfdi.tolerance import get_rtol, rank_decision

if TYPE_CHECKING:
    from geomfdi.diagnosability._records import NullSpaceMethod, WindowData

__all__ = [
    "stacked",
    "observability_matrix",
    "left_null_basis",
    "residual_generator",
    "fault_matrix",
    "fault_vector",
]


@dataclass(frozen=True)
class _Reduced:
    """Whitened fault-to-residual maps ``Phi = Gamma N_H F`` (all faults side by side)."""

    basis: np.ndarray  # N_H (direct, d x (n+m)s) or N_O (structured, d x m s)
    gamma: np.ndarray  # (d, d) whitening Gamma
    nf: np.ndarray  # (d, p s): N_H F (direct) or N_O T_f (structured)
    phi: np.ndarray  # (d, p s): Gamma N_H F
    f_norms: np.ndarray  # (p,) ||F_i|| (or ||T_f,i||): the data producing N_H F_i
    scales: np.ndarray  # (p,) ||Gamma|| ||F_i||: the data producing Phi_i
    method: str
    images: dict[int, np.ndarray] = field(default_factory=dict)  # orthonormal bases of Im Phi_j


def stacked(model: WindowData) -> StackedWindow:
    """The matrices ``L, H, F, E`` of eq. (2) and the covariance of ``e_s``."""
    n, m, s = model.n, model.m, model.window
    nu = model.B.shape[1]
    I_s = np.eye(s)
    H = np.zeros(((n + m) * s, n * (s + 1)))
    Hv = H[: n * s].reshape(s, n, s + 1, n)
    t = np.arange(s)
    Hv[t, :, t, :] = model.A
    Hv[t, :, t + 1, :] = -np.eye(n)
    H[n * s :].reshape(s, m, s + 1, n)[t, :, t, :] = model.C
    L = np.zeros(((n + m) * s, (m + nu) * s))
    L[: n * s, m * s :] = -np.kron(I_s, model.B)
    L[n * s :, : m * s] = np.eye(m * s)
    L[n * s :, m * s :] = -np.kron(I_s, model.D)
    F = np.vstack([np.kron(I_s, model.Bf), np.kron(I_s, model.Df)])
    l, tv = model.Bw.shape[1], model.Dv.shape[1]
    E = np.zeros(((n + m) * s, (l + tv) * s))
    E[: n * s, : l * s] = np.kron(I_s, model.Bw)
    E[n * s :, : l * s] = np.kron(I_s, model.Dw)
    E[n * s :, l * s :] = np.kron(I_s, model.Dv)
    Sigma = np.zeros(((l + tv) * s, (l + tv) * s))
    Sigma[: l * s, : l * s] = np.kron(I_s, model.Qw)
    Sigma[l * s :, l * s :] = np.kron(I_s, model.Rv)
    return StackedWindow(L=L, H=H, F=F, E=E, Sigma=Sigma)


def observability_matrix(model: WindowData) -> np.ndarray:
    """Extended observability matrix ``O_s = [C; C A; ...; C A^{s-1}]``."""
    return _markov(model, np.eye(model.n)).reshape(model.m * model.window, model.n)


def _markov(model: WindowData, X: np.ndarray) -> np.ndarray:
    """``[C X, C A X, ..., C A^{s-1} X]`` as an ``(s, m, cols)`` array."""
    out = np.empty((model.window, model.m, X.shape[1]))
    Y = X
    for j in range(model.window):
        out[j] = model.C @ Y
        if j + 1 < model.window:
            Y = model.A @ Y
    return out


def _toeplitz(model: WindowData, Bx: np.ndarray, Dx: np.ndarray) -> np.ndarray:
    """Block-Toeplitz map of a channel ``(Bx, Dx)`` over the window: ``D, CB, CAB, ...``."""
    s = model.window
    markov = np.zeros((s, model.m, Bx.shape[1]))
    markov[0] = Dx
    if s > 1:
        markov[1:] = _markov(model, Bx)[: s - 1]
    return _block_toeplitz(markov)


def _observability_null(model: WindowData) -> np.ndarray:
    O = observability_matrix(model)
    N_O, rank = _left_null_rows(O, "extended observability matrix O_s")
    model.cache["rank_O"] = rank
    if N_O.shape[0] == 0:
        raise DesignError(
            f"window: a window of {model.window} samples gives no parity relation "
            f"(m s = {model.m * model.window} <= rank O_s = {rank}); lengthen the window",
            argument="window",
        )
    return N_O


def left_null_basis(model: WindowData, method: NullSpaceMethod | None = None) -> np.ndarray:
    """Orthonormal basis ``N_H`` (rows) of the left null space of the stacked ``H``.

    Parameters
    ----------
    method : {"structured", "direct"}, optional
        Default: the model's ``nullspace``.  The two bases differ by a rotation; the
        projector ``N_H^T N_H`` is the same.

    Returns
    -------
    ndarray, (d, (n + m) s)
    """
    method = model.nullspace_method(method)
    if method == "direct":
        N, rank = _left_null_rows(stacked(model).H, "stacked H")
        model.cache["rank_O"] = rank - model.n * model.window
        if N.shape[0] == 0:
            _observability_null(model)  # raises the DesignError
        return N
    n, m, s = model.n, model.m, model.window
    N_O = _observability_null(model)
    markov = np.zeros((s, m, n))
    if s > 1:
        markov[1:] = _markov(model, np.eye(n))[: s - 1]
    G = _block_toeplitz(markov)  # (m s, n s), block (k, t) = C A^{k-t-1}
    W = np.vstack([G.T @ N_O.T, N_O.T])  # columns span the left null space
    Q, _ = np.linalg.qr(W)
    return Q.T


def _reduced(model: WindowData, method: str | None = None) -> _Reduced:
    method = model.nullspace_method(method)
    if method in model.cache:
        return model.cache[method]
    p, s = model.p, model.window
    if method == "direct":
        N = left_null_basis(model, "direct")
        Nx, Ny = N[:, : model.n * s], N[:, model.n * s :]
        NF = _times_kron(Nx, model.Bf) + _times_kron(Ny, model.Df)
        NW = _times_kron(Nx, model.Bw) + _times_kron(Ny, model.Dw)
        NV = _times_kron(Ny, model.Dv)
        # ||F_i||_2: the columns of F_i are orthogonal, each of norm ||[Bf_i; Df_i]||
        f_norms = np.hypot(np.linalg.norm(model.Bf, axis=0), np.linalg.norm(model.Df, axis=0))
    else:
        N_O = _observability_null(model)
        Tf = _toeplitz(model, model.Bf, model.Df)
        NF = N_O @ Tf
        NW = N_O @ _toeplitz(model, model.Bw, model.Dw)
        NV = _times_kron(N_O, model.Dv)
        f_norms = np.array([np.linalg.norm(Tf[:, i::p], 2) for i in range(p)])
    M = _times_kron(NW, model.Qw) @ NW.T + _times_kron(NV, model.Rv) @ NV.T
    Gamma = _sym_inv_sqrt(M, f"{method} path")
    red = _Reduced(
        basis=N if method == "direct" else N_O,
        gamma=Gamma,
        nf=NF,
        phi=Gamma @ NF,
        f_norms=f_norms,
        scales=float(np.linalg.norm(Gamma, 2)) * f_norms,
        method=method,
    )
    model.cache[method] = red
    return red


def residual_generator(model: WindowData, *, method: NullSpaceMethod | None = None) -> np.ndarray:
    """The whitened parity residual over the window, ``R = Gamma N_H L`` (eq. 3).

    ``r = R z_s`` with ``z_s = [y(k-s+1); ...; y(k); u(k-s+1); ...; u(k)]`` does not
    depend on the states; without fault ``r ~ N(0, I_d)`` and with fault ``f_i`` of
    profile ``theta``, ``r ~ N(q_i, I_d)`` in the same basis as :meth:`fault_vector`.

    Returns
    -------
    ndarray, (d, (m + q) s)
    """
    red = _reduced(model, method)
    if red.method == "direct":
        return red.gamma @ (red.basis @ stacked(model).L)
    Tu = _toeplitz(model, model.B, model.D)
    return red.gamma @ np.hstack([red.basis, -(red.basis @ Tu)])


def fault_matrix(model: WindowData, i: int, *, method: NullSpaceMethod | None = None) -> np.ndarray:
    """``Phi_i = Gamma N_H F_i`` (``d x s``): whitened map from the profile of ``f_i``.

    Defined up to a left orthogonal factor (the choice of basis ``N_H``).
    """
    i = model.fault_index(i)
    return _reduced(model, method).phi[:, i :: model.p].copy()


def fault_vector(
    model: WindowData, i: int, theta: Any, *, method: NullSpaceMethod | None = None
) -> np.ndarray:
    """``q_i = Gamma N_H F_i theta`` for the profile ``theta`` (length ``window``)."""
    i = model.fault_index(i)
    theta = model.profile(theta)
    return _reduced(model, method).phi[:, i :: model.p] @ theta


def _q(
    model: WindowData, i: int, theta: np.ndarray, method: str | None
) -> tuple[np.ndarray, float, float]:
    """``q_i = scale * q_unit`` for the profile ``theta``: ``(q_unit, zero_tol, scale)``.

    The profile is divided by ``scale = max |theta|`` first, so that ``q_unit`` and its
    rounding-level zero test do not overflow or underflow whatever the fault size; every
    index is then computed from ``q_unit`` and ``scale`` (the directional indices from
    ``q_unit`` alone).
    """
    red = _reduced(model, method)
    scale = float(np.max(np.abs(theta))) if theta.size else 0.0
    if scale == 0.0:
        return np.zeros(red.phi.shape[0]), 0.0, 0.0
    unit = theta / scale
    q = red.phi[:, i :: model.p] @ unit
    zero_tol = get_rtol(q.size) * float(red.scales[i]) * float(np.linalg.norm(unit))
    if np.linalg.norm(q) <= zero_tol:  # rounding level: the profile is undetectable
        q = np.zeros_like(q)
    return q, zero_tol, scale


def _scaled_square(x: np.ndarray, scale: float) -> float:
    """``||scale x||^2`` in floating point; ``inf`` when it overflows."""
    sq = float(x @ x)
    if sq == 0.0:
        return 0.0
    with np.errstate(over="ignore", under="ignore"):
        return float((np.float64(scale) * np.sqrt(sq)) ** 2)


def _complement_residual(
    model: WindowData, q: np.ndarray, j: int, method: str | None, tol: float
) -> tuple[np.ndarray, int]:
    """``N_{Phi_j} q`` (component outside ``Im Phi_j``; zero below ``tol``) and
    ``d - rank Phi_j``."""
    red = _reduced(model, method)
    Ur = red.images.get(j)
    if Ur is None:
        Phi = red.phi[:, j :: model.p]
        U, sv, _ = np.linalg.svd(Phi, full_matrices=False)
        r = rank_decision(
            sv, float(red.scales[j]), Phi.shape[0], what=f"image of fault {model.fault_names[j]}"
        ).rank
        Ur = red.images[j] = U[:, :r]
    res = q - Ur @ (Ur.T @ q)
    if np.linalg.norm(res) <= tol:
        res = np.zeros_like(res)
    return res, q.size - Ur.shape[1]
