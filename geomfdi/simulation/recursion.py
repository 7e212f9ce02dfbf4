"""Loop-free solution of a linear recursion ``z[k+1] = T z[k] + g[k]`` with ``T`` triangular.

With the Schur form ``Ad = Z T Z^H`` (T upper triangular) the transformed state
``z = Z^H x`` obeys ``z_i[k+1] = T_ii z_i[k] + g_i[k] + sum_{j>i} T_ij z_j[k]``, so the
states follow by back-substitution from ``i = n-1`` down to ``0``, each one a first-order
recursion over the whole time axis evaluated by one compiled :func:`scipy.signal.lfilter`
call (over every Monte-Carlo run at once).  When ``Ad`` has a well-conditioned
eigenvector basis (condition number <= 100) the modal form is used instead and the
scalar recursions are uncoupled.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg

__all__ = ["schur_form", "triangular_recursion"]


def schur_form(Ad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangular Schur form ``Ad = Z T Z^H``: real when every eigenvalue is real."""
    T, Z = scipy.linalg.schur(Ad, output="real")
    n = T.shape[0]
    if n > 1 and np.any(np.diag(T, -1) != 0):
        T, Z = scipy.linalg.rsf2csf(T, Z)
    return T, Z


_MODAL_COND = 100.0  # largest eigenvector-basis condition number for the modal form


def modal_form(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """``A = Z T Z^-1`` with ``T`` diagonal when that is safe, else the Schur form.

    The eigenvector basis (unit columns) is used when its condition number is at most
    ``_MODAL_COND``: the scalar recursions are then uncoupled, and rounding errors grow
    by at most that factor.  Otherwise (defective or nearly defective ``A``) the unitary
    Schur form of :func:`schur_form`, ``Z^-1 = Z^H``.  Returns ``(T, Z, Z^-1, diagonal)``.
    """
    n = A.shape[0]
    if n > 1:
        lam, V = np.linalg.eig(A)
        if np.all(np.isfinite(V)) and np.linalg.cond(V) <= _MODAL_COND:
            if not np.any(lam.imag):
                lam, V = lam.real, V.real
            return np.diag(lam), V, np.linalg.inv(V), True
    T, Z = schur_form(A)
    return T, Z, Z.conj().T, n <= 1


def matrix_product(Mat: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """``Mat @ flat`` for a real ``flat``; a complex ``Mat`` as two real products."""
    if np.iscomplexobj(Mat):
        out = np.empty((Mat.shape[0], flat.shape[1]), dtype=complex)
        out.real = Mat.real @ flat
        out.imag = Mat.imag @ flat
        return out
    return Mat @ flat


def recursion_inplace(T: np.ndarray, G: np.ndarray, stops: Any = None) -> np.ndarray:
    """Back-substitution on ``G`` (n, R, N) in place: ``G[:, :, 0]`` holds ``z0`` and
    ``G[:, :, k]`` the forcing of the step ``k-1 -> k``; on return ``G`` holds ``z``.

    With ``z0`` prepended to the forcing, ``s[k] = lambda s[k-1] + G[i, :, k]`` started
    from rest reproduces ``z_i`` exactly, so each state is a single ``lfilter`` call
    (``sosfilt`` with one first-order section for complex states).
    """
    import scipy.signal  # heavy: loaded on the first simulation, not with geomfdi

    n, R, N = G.shape
    for i in range(n - 1, -1, -1):
        stop = n if stops is None else int(stops[i])
        if i == stop - 2:  # one coupling: no temporary product
            G[i, :, 1:] += T[i, i + 1] * G[i + 1, :, :-1]
        elif i < stop - 2:
            k = stop - 1 - i
            coup = (T[i, i + 1 : stop] @ G[i + 1 : stop].reshape(k, R * N)).reshape(R, N)
            G[i, :, 1:] += coup[:, :-1]
        lam = T[i, i]
        if np.iscomplexobj(G):  # sosfilt's complex path is about twice as fast as lfilter's
            sos = np.array([[1.0, 0.0, 0.0, 1.0, -lam, 0.0]], dtype=complex)
            G[i] = scipy.signal.sosfilt(sos, G[i], axis=-1)
        else:
            G[i] = scipy.signal.lfilter([1.0], [1.0, -lam], G[i], axis=-1)
    return G


def triangular_recursion(
    T: np.ndarray, g: np.ndarray, z0: np.ndarray, stops: np.ndarray | None = None
) -> np.ndarray:
    """``z[k+1] = T z[k] + g[k]`` for upper triangular ``T`` by back-substitution.

    Parameters
    ----------
    T : ndarray, (n, n), upper triangular (real or complex)
    g : ndarray, (n, Rg, N-1)
        Forcing, state-major layout (``Rg`` is 1 or ``R``).
    z0 : ndarray, (n, R)
    stops : ndarray of int, (n,), optional
        For a block-diagonal ``T``: state ``i`` couples only to states ``i+1 ..
        stops[i]-1`` (the end of its block), which skips the zero blocks.

    Returns
    -------
    ndarray, (n, R, N)
        One :func:`scipy.signal.lfilter` call per state over the whole (R, N) array.
    """
    n, R = z0.shape
    G = np.empty((n, R, g.shape[-1] + 1), dtype=np.result_type(T, g, z0))
    G[:, :, 0] = z0
    G[:, :, 1:] = g
    return recursion_inplace(T, G, stops)
