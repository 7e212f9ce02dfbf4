"""Consistent initial states of residual generators: ``w0 = Pi X0``, ``F Pi - Pi A_cl = -Sigma``.

The healthy interconnection of the loop state ``X`` and a generator state ``w`` is block
lower triangular, ``[X; w]' = [[A_cl, 0], [Sigma, F]] [X; w]``, and the subspace
``w = Pi X`` is invariant under it; the residual on it is ``(M Pi + N_out) X``, zero for a
generator decoupled from the healthy loop, so starting there removes the start-up
transient.  See the user guide, *Theory: the geometric approach*
(``docs/theory/geometric-approach.md``).
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg

_MISMATCH_WARN = 1e-8


class InitialStateWarning(UserWarning):
    """The generator cannot start consistently: it is not decoupled from the healthy loop."""


# ========================================================== consistent state
def consistent_initial_state(
    F: np.ndarray, A_cl: np.ndarray, Sigma: np.ndarray, M: np.ndarray, N_out: np.ndarray
) -> tuple[np.ndarray, float]:
    """``Pi`` with ``F Pi - Pi A_cl = -Sigma``, and the relative output mismatch.

    The healthy interconnection is block lower triangular::

        [X; w]' = [[A_cl, 0], [Sigma, F]] [X; w],      r = M w + N_out X

    and ``w = Pi X`` is invariant under it.  Then ``r = (M Pi + N_out) X``, which is
    zero for a generator decoupled from the healthy loop.

    Returns
    -------
    Pi : ndarray, (nw, nX)
    mismatch : float
        ``||M Pi + N_out|| / (||M|| ||Pi|| + ||N_out||)`` in Frobenius norms (0 when both
        vanish).

    Notes
    -----
    Unique when ``F`` and ``A_cl`` have no common eigenvalue (Bartels-Stewart,
    :func:`scipy.linalg.solve_sylvester`); otherwise the Sylvester equation and
    ``M Pi = -N_out`` are solved together in least squares (a minimum-norm solution).
    """
    nw, nX = F.shape[0], A_cl.shape[0]
    if nw == 0 or nX == 0:
        Pi = np.zeros((nw, nX))
    else:
        if _spectra_apart(F, A_cl):
            Pi = scipy.linalg.solve_sylvester(F, -A_cl, -Sigma)
        else:
            Inx, Inw = np.eye(nX), np.eye(nw)
            lhs = np.vstack([np.kron(Inx, F) - np.kron(A_cl.T, Inw), np.kron(Inx, M)])
            rhs = np.concatenate([-Sigma.ravel(order="F"), -N_out.ravel(order="F")])
            sol = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
            Pi = sol.reshape((nw, nX), order="F")
    return Pi, output_mismatch(M, Pi, N_out)


def _spectra_apart(F: np.ndarray, A_cl: np.ndarray, ea: np.ndarray | None = None) -> bool:
    """No eigenvalue of ``F`` within ``1e-8 max(||F||, ||A_cl||)`` of one of ``A_cl``
    (``ea``: the eigenvalues of ``A_cl`` when already known): the Sylvester equation
    ``F Pi - Pi A_cl = -Sigma`` then has a unique, well-posed solution."""
    ef = np.linalg.eigvals(F)
    ea = np.linalg.eigvals(A_cl) if ea is None else ea
    scale = max(np.linalg.norm(F), np.linalg.norm(A_cl), 1e-300)
    return bool(np.min(np.abs(ef[:, None] - ea[None, :])) > 1e-8 * scale)


def output_mismatch(M: np.ndarray, Pi: np.ndarray, N_out: np.ndarray) -> float:
    """``||M Pi + N_out|| / (||M|| ||Pi|| + ||N_out||)`` (0 when both terms vanish)."""
    res = M @ Pi + N_out
    den = np.linalg.norm(M) * np.linalg.norm(Pi) + np.linalg.norm(N_out)
    return float(np.linalg.norm(res) / den) if den > 0 else 0.0


def joint_sylvester(
    Fs: list[np.ndarray], A_cl: np.ndarray, Sigma: np.ndarray
) -> list[np.ndarray | None]:
    """``Pi`` of the generators from one Sylvester equation with ``blockdiag(F_g)``.

    The block-diagonal equation decouples into the generators' own equations, so this is
    :func:`consistent_initial_state` for all of them in one Bartels-Stewart solve.  A
    generator whose ``F_g`` shares an eigenvalue with ``A_cl`` is left out (None: it is
    solved on its own, with the least-squares fallback).  ``Sigma`` stacks the generators'
    ``Sigma_g`` row-wise.
    """
    out: list[np.ndarray | None] = [None] * len(Fs)
    if A_cl.shape[0] == 0:
        return out
    ea = np.linalg.eigvals(A_cl)
    offs = np.cumsum([0] + [F.shape[0] for F in Fs])
    keep = [g for g, F in enumerate(Fs) if F.shape[0] and _spectra_apart(F, A_cl, ea)]
    if not keep:
        return out
    rows = np.concatenate([np.arange(offs[g], offs[g + 1]) for g in keep])
    Pi = scipy.linalg.solve_sylvester(
        scipy.linalg.block_diag(*[Fs[g] for g in keep]), -A_cl, -Sigma[rows]
    )
    o = 0
    for g in keep:
        out[g] = Pi[o : o + Fs[g].shape[0]]
        o += Fs[g].shape[0]
    return out


DECOUPLE_TOL = 1e-12  # relative Sylvester residual below which w - Pi x is decoupled


def sylvester_residual(F: np.ndarray, A_cl: np.ndarray, Sigma: np.ndarray, Pi: np.ndarray) -> float:
    """``||F Pi - Pi A_cl + Sigma|| / (||F|| ||Pi|| + ||Pi|| ||A_cl|| + ||Sigma||)``."""
    res = F @ Pi - Pi @ A_cl + Sigma
    nPi = np.linalg.norm(Pi)
    den = (np.linalg.norm(F) + np.linalg.norm(A_cl)) * nPi + np.linalg.norm(Sigma)
    return float(np.linalg.norm(res) / den) if den > 0 else 0.0


def check_mismatch(k: int, mismatch: float) -> None:
    if mismatch > _MISMATCH_WARN:
        warnings.warn(
            f"generator {k}: no consistent initial state, relative |M Pi + N| = {mismatch:.3g}; "
            "the residual is not decoupled from the healthy loop and will show a start-up "
            "transient",
            InitialStateWarning,
            stacklevel=4,
        )
