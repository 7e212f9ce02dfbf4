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
        d, e = state_scaling(A_cl), state_scaling(F)
        Ab, Sb, Nb = A_cl * d[None, :] / d[:, None], Sigma * d / e[:, None], N_out * d
        Fb, Mb = F * e[None, :] / e[:, None], M * e[None, :]
        if _spectra_apart(Fb, Ab):
            Pb = scipy.linalg.solve_sylvester(Fb, -Ab, -Sb)
        else:
            Inx, Inw = np.eye(nX), np.eye(nw)
            lhs = np.vstack([np.kron(Inx, Fb) - np.kron(Ab.T, Inw), np.kron(Inx, Mb)])
            rhs = np.concatenate([-Sb.ravel(order="F"), -Nb.ravel(order="F")])
            sol = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
            Pb = sol.reshape((nw, nX), order="F")
        Pi = Pb * e[:, None] / d[None, :]
    return Pi, output_mismatch(M, Pi, N_out)


def state_scaling(A_cl: np.ndarray) -> np.ndarray:
    """Diagonal scaling ``d`` with ``D^-1 A_cl D`` balanced (``D = diag(d)``, powers of 2).

    Every check of ``Pi`` is made in these coordinates, so that it does not depend on
    the units of the states (a change ``x -> T x`` with ``T`` diagonal).
    """
    if A_cl.shape[0] == 0:
        return np.ones(0)
    key = (A_cl.shape, A_cl.tobytes())
    hit = _SCALINGS.get(key)
    if hit is None:
        _, (scale, _) = scipy.linalg.matrix_balance(A_cl, permute=False, separate=True)
        hit = np.asarray(scale, dtype=float)
        if len(_SCALINGS) > 256:
            _SCALINGS.clear()
        _SCALINGS[key] = hit
    return hit


_SCALINGS: dict[tuple, np.ndarray] = {}  # state_scaling of recent matrices (small, per process)


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
    d = state_scaling(A_cl)
    Ab = A_cl * d[None, :] / d[:, None]
    ea = np.linalg.eigvals(Ab)
    offs = np.cumsum([0] + [F.shape[0] for F in Fs])
    es = [state_scaling(F) for F in Fs]
    Fbs = [F * e[None, :] / e[:, None] for F, e in zip(Fs, es, strict=True)]
    keep = [g for g, F in enumerate(Fbs) if F.shape[0] and _spectra_apart(F, Ab, ea)]
    if not keep:
        return out
    rows = np.concatenate([np.arange(offs[g], offs[g + 1]) for g in keep])
    ek = np.concatenate([es[g] for g in keep])
    Pb = scipy.linalg.solve_sylvester(
        scipy.linalg.block_diag(*[Fbs[g] for g in keep]), -Ab, -Sigma[rows] * d / ek[:, None]
    )
    Pb = Pb * ek[:, None] / d[None, :]
    o = 0
    for g in keep:
        out[g] = Pb[o : o + Fs[g].shape[0]]
        o += Fs[g].shape[0]
    return out


EXACT_TOL = 1e-8  # largest start_error for which w0 = Pi x0 (and w - Pi x) is used


def sylvester_residual(F: np.ndarray, A_cl: np.ndarray, Sigma: np.ndarray, Pi: np.ndarray) -> float:
    """``||F Pi - Pi A_cl + Sigma|| / (||F|| ||Pi|| + ||Pi|| ||A_cl|| + ||Sigma||)``.

    Evaluated in the balanced coordinates of ``A_cl`` (:func:`state_scaling`): invariant
    under a diagonal change of the state's units.
    """
    if A_cl.shape[0]:
        d = state_scaling(A_cl)
        A_cl, Sigma, Pi = A_cl * d[None, :] / d[:, None], Sigma * d, Pi * d
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


def start_error(
    F: np.ndarray,
    A_cl: np.ndarray,
    Sigma: np.ndarray,
    M: np.ndarray,
    N_out: np.ndarray,
    Pi: np.ndarray,
) -> float:
    """How far ``w = Pi X`` is from an invariant subspace, measured on the residual.

    The Sylvester error ``R = F Pi - Pi A_cl + Sigma`` drives the residual through
    ``M (sI - F)^-1 R``.  Per loop state ``j`` its size at ``s0 = i max(1, rho(F))`` is
    compared with that of the healthy coupling, ``|M (s0 I - F)^-1 Sigma_j| + |N_j|``
    (floored at 1e-6 of the largest, in the balanced units of ``A_cl``): the largest
    ratio is returned.  The measure does not depend on the generator's state
    coordinates, nor on the units of the loop states beyond what balancing removes.
    """
    nw = F.shape[0]
    if nw == 0 or A_cl.shape[0] == 0:
        return 0.0
    R = F @ Pi - Pi @ A_cl + Sigma
    rho = float(np.max(np.abs(np.linalg.eigvals(F))))
    s0 = 1j * max(1.0, rho)
    try:
        G = M @ np.linalg.solve(s0 * np.eye(nw) - F, np.hstack([R, Sigma]))
    except np.linalg.LinAlgError:
        return float("inf")
    nX = A_cl.shape[0]
    d = state_scaling(A_cl)  # columns in balanced units
    err = np.linalg.norm(G[:, :nX], axis=0) * d
    ref = (np.linalg.norm(G[:, nX:], axis=0) + np.linalg.norm(N_out, axis=0)) * d
    if not np.any(err):
        return 0.0
    # a state that does not reach the residual is compared with 1e-6 of the largest
    top = float(np.max(ref))
    if top == 0:
        return float("inf")
    return float(np.max(err / np.maximum(ref, 1e-6 * top)))


def inexact_start(k: int, residual: float) -> None:
    """Warn that generator ``k`` starts at zero: no exact consistent state was found."""
    warnings.warn(
        f"generator {k}: the consistent initial state is not exact (its error reaches "
        f"{residual:.3g} of the residual, > {EXACT_TOL:g}); the generator starts at zero",
        InitialStateWarning,
        stacklevel=4,
    )


def consistent_start(
    k: int,
    F: np.ndarray,
    A_cl: np.ndarray,
    Sigma: np.ndarray,
    M: np.ndarray,
    N_out: np.ndarray,
    info: dict,
    Pi: np.ndarray | None = None,
    *,
    warn: bool = True,
) -> np.ndarray | None:
    """``Pi`` to start generator ``k`` at ``w0 = Pi X0``, or None when no exact one exists.

    The start is used only when ``Pi`` solves the Sylvester equation to a relative
    :data:`EXACT_TOL` in balanced coordinates (checked, not assumed): otherwise the
    generator starts at zero with an :class:`InitialStateWarning` (``warn=False``: the
    caller warns, :func:`inexact_start`, when a start state is not zero: from ``X0 = 0``
    the zero start is the consistent one), never from a wrong state.  ``info`` records
    ``init_mismatch``, ``init_residual`` and ``initial_state``.
    """
    if Pi is None:
        Pi, mm = consistent_initial_state(F, A_cl, Sigma, M, N_out)
    else:
        mm = output_mismatch(M, Pi, N_out)
    res = start_error(F, A_cl, Sigma, M, N_out, Pi)
    info.setdefault("init_mismatch", {})[k] = mm
    info.setdefault("init_residual", {})[k] = res
    if not res <= EXACT_TOL:
        if warn:
            inexact_start(k, res)
        info.setdefault("initial_state", {})[k] = "zero"
        return None
    check_mismatch(k, mm)
    info.setdefault("initial_state", {})[k] = "consistent"
    return Pi
