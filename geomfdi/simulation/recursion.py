"""Loop-free solution of a linear recursion ``z[k+1] = T z[k] + g[k]`` with ``T`` triangular.

With the Schur form ``Ad = Z T Z^H`` (T upper triangular) the transformed state
``z = Z^H x`` obeys ``z_i[k+1] = T_ii z_i[k] + g_i[k] + sum_{j>i} T_ij z_j[k]``, so the
states follow by back-substitution from ``i = n-1`` down to ``0``, each one a first-order
recursion over the whole time axis (over every Monte-Carlo run at once), evaluated by
:func:`first_order_filter` (blocks of samples: one matrix product with the Toeplitz
matrix of powers, block ends by a doubling scan) or, for long records, by one compiled
:func:`scipy.signal.lfilter` call.  When ``Ad`` has a well-conditioned
eigenvector basis (condition number <= 100) the modal form is used instead and the
scalar recursions are uncoupled.

:func:`lifted_recursion` runs a state-space system with outputs on blocks of ``M``
samples in these coordinates: the block-start states by the back-substitution above
(or, for few blocks, by recursive doubling), the outputs of all blocks by matrix
products with precomputed :class:`LiftedMaps`, so that the ``lfilter`` calls run over
``N / M`` samples only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

__all__ = [
    "LiftedMaps",
    "first_order_filter",
    "lift_factor",
    "lifted_maps",
    "lifted_recursion",
    "schur_form",
    "triangular_recursion",
]


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


_FILTER_BLOCK = {"f": 16, "c": 16}  # block length of first_order_filter (real, complex)
_NUMPY_FILTER_MAX = {"f": 2**16, "c": 2**15}
"""Largest ``R N`` per state filtered by :func:`first_order_filter` in
:func:`recursion_inplace` (real, complex); longer records go to ``lfilter``, faster
there.  Up to these sizes the numpy filter of all the states of a diagonal ``T`` at once
is about as fast as one ``lfilter`` call per state, and a simulation does not import
:mod:`scipy.signal` (about 0.6 s)."""
_NUMPY_FILTER_MIN = 2**14
"""Smallest ``R N`` filtered by :func:`first_order_filter` for one state alone (the
back-substitution of a coupled ``T``): below, the per-call cost of ``lfilter`` is
lower (records of at most ``_NUMPY_FILTER_TINY`` samples excepted)."""
_NUMPY_FILTER_TINY = 16
_TEMP_DOUBLES = 2**13  # largest temporary of the block carries (larger ones are slow)
_NEGLIGIBLE = 1e-150
"""Powers of a pole below this are set to zero in :func:`first_order_filter`: their terms
are negligible (relative 1e-150), and subnormal numbers would make the products slow."""
_OVERFLOW_LOG = 600.0  # |lambda|^N beyond e^600: the doubling powers could overflow


_TOEPLITZ_INDEX: dict[int, np.ndarray] = {}


def _toeplitz_index(L: int) -> np.ndarray:
    """``idx[i, j] = i - j`` for ``i >= j``, else ``L + 1`` (the index of a zero)."""
    idx = _TOEPLITZ_INDEX.get(L)
    if idx is None:
        d = np.subtract.outer(np.arange(L), np.arange(L))
        idx = _TOEPLITZ_INDEX.setdefault(L, np.where(d >= 0, d, L + 1))
    return idx


def first_order_filter(lam: Any, x: np.ndarray, block: int | None = None) -> np.ndarray:
    """``y[..., k] = lam y[..., k-1] + x[..., k]`` from rest (``y[..., -1] = 0``), along the
    last axis, with numpy only (the result of ``lfilter([1], [1, -lam], x)``).

    Parameters
    ----------
    lam : float or complex, or ndarray (n,)
        One pole, or one per index of the first axis of ``x`` (independent recursions
        filtered together).
    x : ndarray, (..., N), or (n, ..., N) with ``n`` poles
    block : int, optional
        Block length ``L`` (default 32 for real, 16 for complex data).

    Returns
    -------
    ndarray, shape of ``x``
        Complex when ``lam`` or ``x`` is.

    Notes
    -----
    On blocks of ``L`` samples, ``y_b = W x_b + lam^(i+1) s_(b-1)`` (``i = 0 .. L-1``)
    with the lower triangular Toeplitz matrix ``W[i, j] = lam^(i-j)`` (``i >= j``) and
    ``s_b`` the last sample of block ``b``.  One matrix product gives ``W x_b`` for every
    block, hence the zero-start block ends ``c_b``; the true ends obey
    ``s_b = lam^L s_(b-1) + c_b``, the same recursion on ``N / L`` samples with ``lam^L``,
    solved by the same method (``log_L N`` levels); then each block gets its carry.  The
    sums of the sequential recursion regrouped: rounding stays at its level (a few
    ``L eps`` relative).  ``|lam|^N`` must stay finite (the caller's concern).

    Examples
    --------
    >>> import numpy as np
    >>> first_order_filter(0.5, np.array([1.0, 0.0, 0.0, 1.0])).tolist()
    [1.0, 0.5, 0.25, 1.125]
    """
    x = np.asarray(x)
    lam = np.asarray(lam)
    dtype = np.result_type(lam, x, 1.0)
    shape = x.shape
    n = 1 if lam.ndim == 0 else lam.size
    N = shape[-1]
    X = x.reshape(n, -1, N) if x.size else x.reshape(n, 0, N)
    out = _filter_rows(lam.reshape(n).astype(dtype), X, block or _FILTER_BLOCK[dtype.kind])
    return out.reshape(shape)


def _filter_rows(lam: np.ndarray, X: np.ndarray, block: int) -> np.ndarray:
    """:func:`first_order_filter` of ``X`` (n, R, N) with the poles ``lam`` (n,)."""
    n, R, N = X.shape
    dtype = lam.dtype
    out = np.empty((n, R, N), dtype=np.result_type(dtype, X))
    if N == 0 or R == 0:
        return out
    L = min(max(block, 2), N)  # (blocks of one sample would not shorten the record)
    nb, r = divmod(N, L)
    pw = np.zeros((n, L + 2), dtype=dtype)  # lam^0 .. lam^L, then a zero
    pw[:, : L + 1] = lam[:, None] ** np.arange(L + 1)
    pw[np.abs(pw) < _NEGLIGIBLE] = 0.0  # no subnormal numbers (slow arithmetic)
    W = pw[:, _toeplitz_index(L)]  # (n, L, L)
    body = out[:, :, : nb * L].reshape(n, R, nb, L)
    np.matmul(X[:, :, : nb * L].reshape(n, R, nb, L), W[:, None].transpose(0, 1, 3, 2), out=body)
    if nb > 1:  # the block ends: the same recursion with lam^L
        S = _filter_rows(pw[:, L], body[..., -1], block)
        step = max(1, _TEMP_DOUBLES // (R * nb * L))  # rows at a time: small temporaries
        for i in range(0, n, step):
            j = min(n, i + step)
            body[i:j, :, 1:, :] += S[i:j, :, :-1, None] * pw[i:j, None, None, 1 : L + 1]
        last = S[:, :, -1:]
    else:
        last = body[:, :, 0, -1:]
    if r:
        tail = X[:, :, nb * L :] @ W[:, :r, :r].transpose(0, 2, 1)
        tail += last * pw[:, None, 1 : r + 1]
        out[:, :, nb * L :] = tail
    return out


def _grows(lam: Any, N: int) -> bool:
    """``|lam|^N`` too large for the powers of :func:`first_order_filter`."""
    big = float(np.max(np.abs(lam)))
    return big > 1.0 and N * math.log(big) > _OVERFLOW_LOG


def _lfilter(lam: Any, x: np.ndarray) -> np.ndarray:
    """``lfilter`` (``sosfilt`` with one first-order section for complex data) of ``x``
    (R, N) along its last axis: the compiled filter for long records."""
    import scipy.signal  # heavy: loaded for long records only, not with geomfdi

    if np.iscomplexobj(x) or np.iscomplexobj(lam):  # sosfilt: twice as fast as lfilter
        sos = np.array([[1.0, 0.0, 0.0, 1.0, -lam, 0.0]], dtype=complex)
        return scipy.signal.sosfilt(sos, x, axis=-1)
    return scipy.signal.lfilter([1.0], [1.0, -lam], x, axis=-1)


def _filter_state(lam: Any, x: np.ndarray) -> np.ndarray:
    """One state's record ``x`` (R, N): :func:`first_order_filter` for records of
    ``_NUMPY_FILTER_MIN`` to ``_NUMPY_FILTER_MAX`` values or of at most
    ``_NUMPY_FILTER_TINY`` samples, else :func:`_lfilter`."""
    N = x.shape[-1]
    kind = "c" if np.iscomplexobj(x) or np.iscomplexobj(lam) else "f"
    size = x.size
    if (
        (size >= _NUMPY_FILTER_MIN or N <= _NUMPY_FILTER_TINY)
        and size <= _NUMPY_FILTER_MAX[kind]
        and not _grows(lam, N)
    ):
        return first_order_filter(lam, x)
    return _lfilter(lam, x)


def _filter_states(lam: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Every state of a diagonal ``T`` (``x``: (n, R, N), ``lam``: (n,)) at once by
    :func:`first_order_filter` up to ``_NUMPY_FILTER_MAX`` values per state, else state
    by state."""
    kind = "c" if np.iscomplexobj(x) or np.iscomplexobj(lam) else "f"
    if x[0].size <= _NUMPY_FILTER_MAX[kind] and not _grows(lam, x.shape[-1]):
        return first_order_filter(lam, x)
    out = np.empty(x.shape, dtype=np.result_type(x, lam))
    for i in range(x.shape[0]):
        out[i] = _filter_state(lam[i], x[i])
    return out


def recursion_inplace(T: np.ndarray, G: np.ndarray, stops: Any = None) -> np.ndarray:
    """Back-substitution on ``G`` (n, R, N) in place: ``G[:, :, 0]`` holds ``z0`` and
    ``G[:, :, k]`` the forcing of the step ``k-1 -> k``; on return ``G`` holds ``z``.

    With ``z0`` prepended to the forcing, ``s[k] = lambda s[k-1] + G[i, :, k]`` started
    from rest reproduces ``z_i`` exactly, so each state is one first-order filter over
    the whole ``(R, N)`` array: for a diagonal ``T`` (``stops`` ``1 .. n``) all states at
    once by :func:`first_order_filter`, else state by state (:func:`_filter_state`);
    long records by ``lfilter``.
    """
    n, R, N = G.shape
    if n > 1 and stops is not None and np.array_equal(stops, np.arange(1, n + 1)):
        G[:] = _filter_states(np.diag(T), G)  # diagonal: every state at once
        return G
    for i in range(n - 1, -1, -1):
        stop = n if stops is None else int(stops[i])
        if i == stop - 2:  # one coupling: no temporary product
            G[i, :, 1:] += T[i, i + 1] * G[i + 1, :, :-1]
        elif i < stop - 2:
            k = stop - 1 - i
            coup = (T[i, i + 1 : stop] @ G[i + 1 : stop].reshape(k, R * N)).reshape(R, N)
            G[i, :, 1:] += coup[:, :-1]
        G[i] = _filter_state(T[i, i], G[i])
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
        One first-order filter per state over the whole (R, N) array
        (:func:`recursion_inplace`).
    """
    n, R = z0.shape
    G = np.empty((n, R, g.shape[-1] + 1), dtype=np.result_type(T, g, z0))
    G[:, :, 0] = z0
    G[:, :, 1:] = g
    return recursion_inplace(T, G, stops)


_LIFT_LFILTER = 150.0  # one lfilter sample, in multiply-adds of a matrix product
_MAX_LIFT = 32
_SCAN_BLOCKS = 384  # up to this many blocks the block-start recursion is a doubling scan
_CHUNK_DOUBLES = 2**16  # output values per product (cache-sized)


def lift_factor(n: int, nc: int, nz: int) -> int:
    """Block length ``M`` of :func:`lifted_recursion` for ``n`` states, ``nc`` outputs and
    ``nz`` inputs.

    Per sample the lifted recursion costs about ``c n / M`` for the block-start
    recursion (``c``: one ``lfilter`` sample in multiply-adds), ``nc nz M`` for the
    block-Toeplitz product and ``n (nc + nz)`` for the state maps; ``M`` minimises it
    (``sqrt(c n / (nc nz))``, between 1 and 32).
    """
    if n == 0:
        return 1
    M = round(float(np.sqrt(_LIFT_LFILTER * n / max(nc * max(nz, 1), 1))))
    return int(min(max(M, 1), _MAX_LIFT))


@dataclass(frozen=True)
class LiftedMaps:
    """The lifted form of ``x[k+1] = A x[k] + B z[k]``, ``c[k] = C x[k] + D z[k]`` on
    blocks of ``M`` samples, in Schur coordinates ``x = Z s`` (``A = Z T Z^H``).

    Attributes
    ----------
    M : int
    powers : ndarray, (M + 1, n, n)
        ``T^0 .. T^M`` (``T`` upper triangular, real or complex).
    Hz : ndarray, (n, M nz)
        Columns ``j nz + c``: ``T^(M-1-j) Z^H B[:, c]``, the effect of sample ``j`` of a
        block on the state at the start of the next block.
    Gam : ndarray, (M nc, M nz)
        Rows ``i nc + o``, columns ``j nz + c``: the Markov parameter
        ``(C A^(i-1-j) B)[o, c]`` for ``j < i``, ``D[o, c]`` for ``j = i``, 0 above.
    Psi : ndarray, (M nc, n)
        Rows ``i nc + o``: ``(C Z T^i)[o]``, the effect of the block-start state.
    stops : ndarray of int (n,) or None
        Block structure of ``T`` (see :func:`triangular_recursion`).
    doubling : tuple of ndarray
        ``T^(M 2^k)`` for the recursive doubling of :func:`_scan_recursion`.
    """

    M: int
    powers: np.ndarray
    Hz: np.ndarray
    Gam: np.ndarray
    Psi: np.ndarray
    stops: np.ndarray | None
    doubling: tuple[np.ndarray, ...] = ()

    @property
    def complex_states(self) -> bool:
        return np.iscomplexobj(self.Hz)


def lifted_maps(
    A: np.ndarray,
    B: np.ndarray,
    C: np.ndarray,
    D: np.ndarray,
    T: np.ndarray,
    Z: np.ndarray,
    M: int,
    stops: np.ndarray | None = None,
) -> LiftedMaps:
    """:class:`LiftedMaps` of ``(A, B, C, D)`` with the Schur form ``A = Z T Z^H``.

    The Markov parameters ``C A^k B`` are formed from the real matrices (no imaginary
    rounding residue); the state maps use the triangular ``T``.
    """
    n, nz = B.shape
    nc = C.shape[0]
    powers = np.empty((M + 1, n, n), dtype=T.dtype)
    powers[0] = np.eye(n)
    for i in range(M):
        powers[i + 1] = powers[i] @ T
    V = Z.conj().T @ B
    Hz = np.empty((n, M * nz), dtype=np.result_type(T, V))
    for j in range(M):
        Hz[:, j * nz : (j + 1) * nz] = powers[M - 1 - j] @ V
    Gam = np.zeros((M, nc, M, nz))
    P = B
    for r in range(M - 1):  # C A^r B links sample i = j + r + 1 of a block to sample j
        j = np.arange(M - 1 - r)
        Gam[j + r + 1, :, j, :] = C @ P
        P = A @ P
    Gam[np.arange(M), :, np.arange(M), :] = D
    CZ = C @ Z
    Psi = np.concatenate([CZ @ powers[i] for i in range(M)], axis=0)
    doubling = [powers[M]]
    while 1 << len(doubling) <= _SCAN_BLOCKS:
        doubling.append(doubling[-1] @ doubling[-1])
    return LiftedMaps(M, powers, Hz, Gam.reshape(M * nc, M * nz), Psi, stops, tuple(doubling))


def _scan_recursion(maps: LiftedMaps, E: np.ndarray) -> np.ndarray:
    """Solve ``S[b] = T^M S[b-1] + E[b]`` with ``S[0] = E[0]`` (``E``: ``(nb + 1, n)``) by
    recursive doubling, in place.

    After round ``k`` row ``b`` holds ``sum_{b - 2^(k+1) < j <= b} T^(M (b-j)) E[j]``:
    ``ceil(log2(nb + 1))`` products with the precomputed ``T^(M 2^k)`` (the scan of
    Hillis & Steele, CACM 1986), no loop over the blocks.
    """
    nb1 = E.shape[0]
    for k, P in enumerate(maps.doubling):
        d = 1 << k
        if d >= nb1:
            break
        E[d:] += E[: nb1 - d] @ P.T
    return E


def _real_rows(S: np.ndarray, Psi: np.ndarray) -> np.ndarray:
    """``Re(S @ Psi^T)`` for sample-major states ``S``."""
    if np.iscomplexobj(S):
        return S.real @ Psi.real.T - S.imag @ Psi.imag.T
    return S @ Psi.T


def lifted_recursion(
    maps: LiftedMaps, Zt: np.ndarray, s0: np.ndarray, out: np.ndarray
) -> np.ndarray:
    """Outputs and final state of the system of ``maps`` driven by ``Zt`` from ``s0``.

    Parameters
    ----------
    maps : LiftedMaps
    Zt : ndarray, (L, nz)
        Input samples, sample-major (C-contiguous).
    s0 : ndarray, (n,)
        Schur-coordinate state at the first sample.
    out : ndarray, (nc, L)
        Receives ``c[k] = C x[k] + D z[k]``.

    Returns
    -------
    ndarray, (n,)
        The Schur-coordinate state after the last sample, ``s[L]``.

    Notes
    -----
    On blocks of ``M`` samples (``zeta_b``: the block's samples, flattened) the
    block-start states obey ``s[(b+1) M] = T^M s[b M] + Hz zeta_b``: a doubling scan for
    few blocks (:func:`_scan_recursion`), else :func:`recursion_inplace` (one
    ``lfilter`` per state over the blocks).  The outputs of a block are
    ``Gam zeta_b + Re(Psi s[b M])``, one product for many blocks at once.  The last
    ``L mod M`` samples form a partial block (the leading rows and columns of the same
    maps).  It is the same recursion regrouped, not an approximation (the lifted system
    of Khargonekar, Poolla & Tannenbaum, IEEE TAC 1985); the Schur basis is unitary, so
    rounding stays at the level of the plain update.
    """
    M = maps.M
    L, nz = Zt.shape
    n = maps.powers.shape[1]
    nc = out.shape[0]
    nb, r = divmod(L, M)
    s = np.asarray(s0, dtype=maps.Hz.dtype)
    if nb:
        Zl = Zt[: nb * M].reshape(nb, M * nz)
        if nb <= _SCAN_BLOCKS:
            E = np.empty((nb + 1, n), dtype=maps.Hz.dtype)
            E[0] = s
            E[1:] = matrix_product(maps.Hz, Zl.T).T
            S = _scan_recursion(maps, E)
            states = S[:nb]
            s = S[nb].copy()
        else:
            G = np.empty((n, 1, nb + 1), dtype=maps.Hz.dtype)
            G[:, 0, 0] = s
            if np.iscomplexobj(G):
                G[:, 0, 1:] = matrix_product(maps.Hz, Zl.T)
            else:
                np.matmul(maps.Hz, Zl.T, out=G[:, 0, 1:])
            recursion_inplace(maps.powers[M], G, maps.stops)
            states = G[:, 0, :nb].T
            s = G[:, 0, nb].copy()
        step = max(1, _CHUNK_DOUBLES // (M * nc))  # blocks per product
        GamT = maps.Gam.T
        for b0 in range(0, nb, step):
            b1 = min(nb, b0 + step)
            Y = Zl[b0:b1] @ GamT
            Y += _real_rows(states[b0:b1], maps.Psi)
            out[:, b0 * M : b1 * M] = Y.reshape((b1 - b0) * M, nc).T
    if r:
        zt = Zt[nb * M :].reshape(r * nz)
        Y = maps.Gam[: r * nc, : r * nz] @ zt + _real_rows(s, maps.Psi[: r * nc])
        out[:, nb * M :] = Y.reshape(r, nc).T
        s = maps.powers[r] @ s + maps.Hz[:, (M - r) * nz :] @ zt
    return s
