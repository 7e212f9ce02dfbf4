"""Fast exact simulation of LTI state-space systems on a uniform time grid.

A continuous system ``x' = A x + B u`` is discretised exactly for a piecewise-linear
(first-order hold, ``"foh"``) or piecewise-constant (zero-order hold, ``"zoh"``) input,
giving the recursion

    x[k+1] = Ad x[k] + B0 u[k] + B1 u[k+1]          (B1 = 0 for "zoh")

which is then solved **without a per-sample Python loop**: with the Schur form
``Ad = Z T Z^H`` (T upper triangular) the transformed state ``z = Z^H x`` obeys

    z_i[k+1] = T_ii z_i[k] + (Z^H f)_i[k] + sum_{j>i} T_ij z_j[k]

so the states are obtained by back-substitution from ``i = n-1`` down to ``0``; each one
is a first-order linear recursion over the whole time axis, evaluated by one call of the
compiled :func:`scipy.signal.lfilter` (and over many Monte-Carlo runs at once, since
``lfilter`` filters every row of an ``(runs, N)`` array).  The cost is ``O(n^2 N)`` flops
in ``n`` compiled calls.  For many states :func:`block_recursion` runs the recursion on
the *lifted* system (blocks of ``M`` samples), which moves most of the work from
``lfilter`` samples to matrix products.

The ``"foh"`` discretisation is the one of :func:`control.forced_response` for continuous
systems (linear interpolation of the input between samples, the same block matrix
exponential), so both agree to rounding; a discrete system (``dt > 0``) is simulated as
``x[k+1] = A x[k] + B u[k]`` like :func:`scipy.signal.dlsim`.

Array layout: time is the **last** axis (python-control convention); an optional leading
axis holds Monte-Carlo runs: ``u`` is ``(m, N)`` or ``(runs, m, N)``, ``x`` comes back as
``(n, N)`` or ``(runs, n, N)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
import scipy.signal

from ._validation import as_matrix, as_real_array
from .errors import GeomFDIError, ShapeError

__all__ = [
    "HOLDS",
    "Discretization",
    "discretize",
    "linear_recursion",
    "driven_recursion",
    "block_recursion",
    "Drive",
    "triangular_recursion",
    "schur_form",
    "simulate_lti",
    "uniform_step",
]

HOLDS = ("foh", "zoh")


@dataclass(frozen=True)
class Discretization:
    """Exact sampled form ``x[k+1] = Ad x[k] + B0 u[k] + B1 u[k+1]`` of an LTI system.

    Attributes
    ----------
    Ad : ndarray, (n, n)
    B0, B1 : ndarray, (n, m)
        ``B1`` is zero for a zero-order hold and for discrete-time systems.
    dt : float
        The sampling step.
    hold : str
        ``"foh"``, ``"zoh"`` or ``"discrete"`` (the system was already discrete).
    """

    Ad: np.ndarray
    B0: np.ndarray
    B1: np.ndarray
    dt: float
    hold: str

    def forcing(self, u: np.ndarray) -> np.ndarray:
        """``B0 u[k] + B1 u[k+1]`` for ``k = 0 .. N-2``; ``u`` is ``(..., m, N)``."""
        f = self.B0 @ u[..., :-1]
        if self.hold == "foh":
            f = f + self.B1 @ u[..., 1:]
        return f


def _check_hold(hold: str) -> str:
    if hold not in HOLDS:
        raise GeomFDIError(f"hold: must be one of {HOLDS}, got {hold!r}", argument="hold")
    return hold


def discretize(A: Any, B: Any, dt: float, hold: str = "foh") -> Discretization:
    """Exact discretisation of ``x' = A x + B u`` for a held input.

    Parameters
    ----------
    A : array_like, (n, n)
    B : array_like, (n, m)
        May have zero columns.
    dt : float
        Sampling step (> 0).
    hold : {"foh", "zoh"}
        ``"foh"``: ``u`` linear between samples (the convention of
        :func:`control.forced_response`); ``"zoh"``: ``u`` constant between samples.

    Returns
    -------
    Discretization
        ``Ad = e^{A dt}``; for ``"zoh"`` ``B0 = int_0^dt e^{A s} ds B``, ``B1 = 0``; for
        ``"foh"`` the weights of ``u[k]`` and ``u[k+1]``.

    Notes
    -----
    Both holds use one matrix exponential of a block matrix (Van Loan's method).  For the
    first-order hold, with ``M = [[A dt, B dt, 0], [0, 0, I], [0, 0, 0]]`` and
    ``e^M = [[Ad, G0, G1], ...]``: ``B1 = G1`` and ``B0 = G0 - G1`` (the same formula as
    ``control.forced_response``).
    """
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float).reshape(A.shape[0], -1)
    hold = _check_hold(hold)
    n, m = B.shape
    if hold == "zoh":
        Mz = np.zeros((n + m, n + m))
        Mz[:n, :n] = A * dt
        Mz[:n, n:] = B * dt
        ez = scipy.linalg.expm(Mz)
        return Discretization(ez[:n, :n], ez[:n, n:], np.zeros((n, m)), float(dt), "zoh")
    Mf = np.block(
        [
            [A * dt, B * dt, np.zeros((n, m))],
            [np.zeros((m, n + m)), np.identity(m)],
            [np.zeros((m, n + 2 * m))],
        ]
    )
    ef = scipy.linalg.expm(Mf)
    Ad = ef[:n, :n]
    B1 = ef[:n, n + m :]
    B0 = ef[:n, n : n + m] - B1
    return Discretization(Ad, B0, B1, float(dt), "foh")


def _discrete(A: np.ndarray, B: np.ndarray, dt: float) -> Discretization:
    return Discretization(A, B, np.zeros_like(B), float(dt), "discrete")


def schur_form(Ad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangular Schur form ``Ad = Z T Z^H``: real when every eigenvalue is real."""
    T, Z = scipy.linalg.schur(Ad, output="real")
    n = T.shape[0]
    if n > 1 and np.any(np.diag(T, -1) != 0):
        T, Z = scipy.linalg.rsf2csf(T, Z)
    return T, Z


def _product(Mat: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """``Mat @ flat`` for a real ``flat``; a complex ``Mat`` as two real products."""
    if np.iscomplexobj(Mat):
        out = np.empty((Mat.shape[0], flat.shape[1]), dtype=complex)
        out.real = Mat.real @ flat
        out.imag = Mat.imag @ flat
        return out
    return Mat @ flat


def _recursion_inplace(T: np.ndarray, G: np.ndarray, stops: Any = None) -> np.ndarray:
    """Back-substitution on ``G`` (n, R, N) in place: ``G[:, :, 0]`` holds ``z0`` and
    ``G[:, :, k]`` the forcing of the step ``k-1 -> k``; on return ``G`` holds ``z``.

    With ``z0`` prepended to the forcing, ``s[k] = lambda s[k-1] + G[i, :, k]`` started
    from rest reproduces ``z_i`` exactly, so each state is a single ``lfilter`` call
    (``sosfilt`` with one first-order section for complex states).
    """
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
    return _recursion_inplace(T, G, stops)


@dataclass(frozen=True)
class Drive:
    """One block of drive signals for :func:`block_recursion`.

    The forcing of step ``k -> k+1`` uses ``arr[..., k + shift]`` (times ``scale[..., k]``
    when a scale is given).

    Attributes
    ----------
    arr : ndarray, (k, R, M)
        State-major samples (``R`` is 1 or the number of runs).
    shift : int
        0: the value at the start of the step; 1: at its end (first-order hold).
    scale : ndarray, (1, R, N-1), optional
        Per-step factor (used for the exact channel of a faulty sensor gain).
    """

    arr: np.ndarray
    shift: int = 0
    scale: np.ndarray | None = None

    @property
    def runs(self) -> int:
        """Number of runs of the windows (1 broadcasts)."""
        return max(self.arr.shape[1], 1 if self.scale is None else self.scale.shape[1])

    def window(self, s: int, L: int) -> np.ndarray:
        a = self.arr[..., s + self.shift : s + self.shift + L]
        if self.scale is not None:
            a = self.scale[..., s : s + L] * a
        return a


_LFILTER_COST = 150.0  # one lfilter sample, in matrix-product multiply-adds (measured)
_MAX_LIFT = 32


def _lift_factor(n_states: int, n_out: int, n_drive: int, complex_: bool) -> int:
    """Lifting factor ``M`` of :func:`block_recursion` from a flop model.

    Per sample, the lifted scheme costs about ``p nz M`` multiply-adds for the Toeplitz
    block (``p`` outputs, ``nz`` drive rows) and ``c n / M`` for the ``n`` scalar
    recursions run at the lifted rate, where ``c`` (about 150) is what one ``lfilter``
    sample costs in matrix-product multiply-adds (twice that for complex states).  The
    minimum is at ``M = sqrt(c n / (p nz))``; below 2 lifting does not pay and ``M = 1``
    (the plain recursion) is used.
    """
    c = _LFILTER_COST * (2 if complex_ else 1)
    m = float(np.sqrt(c * n_states / max(n_out * max(n_drive, 1), 1)))
    return 1 if m < 2 else int(min(round(m), _MAX_LIFT))


def _markov_toeplitz(Ab: np.ndarray, W: np.ndarray, Cb: np.ndarray, M: int) -> np.ndarray:
    """Lower block-Toeplitz map of the lifted system, ``(p M, nz M)``.

    Rows ``(o, i)``, columns ``(c, j)`` (output / drive index major): the entry is
    ``(C A^(i-1-j) W)[o, c]`` for ``j < i`` and 0 otherwise.
    """
    p, nz = Cb.shape[0], W.shape[1]
    Gam = np.zeros((p, M, nz, M))
    P = W
    for r in range(M - 1):  # the Markov parameter C A^r W links i = j + r + 1 to j
        Mk = Cb @ P
        for j in range(M - 1 - r):
            Gam[:, j + r + 1, :, j] = Mk
        P = Ab @ P
    return Gam.reshape(p * M, nz * M)


def _blocked_view(arr: np.ndarray, M: int) -> np.ndarray:
    """A ``(p, R, nb M)`` array seen as ``(p, R, nb, M)`` (its last axis split)."""
    p, R, L = arr.shape
    s0, s1, s2 = arr.strides
    return np.lib.stride_tricks.as_strided(arr, (p, R, L // M, M), (s0, s1, M * s2, s2))


def _as_slice(idx: np.ndarray) -> slice | np.ndarray:
    """A run of consecutive indices as a slice (a view instead of a gather)."""
    if idx.size and np.array_equal(idx, np.arange(idx[0], idx[0] + idx.size)):
        return slice(int(idx[0]), int(idx[0]) + idx.size)
    return idx


def _real_product(Mat: np.ndarray, arr: np.ndarray) -> np.ndarray:
    """``Re(Mat @ arr)`` without forming the complex product."""
    if np.iscomplexobj(arr):
        return Mat.real @ arr.real - Mat.imag @ arr.imag
    return Mat.real @ arr


def block_recursion(
    blocks: list[np.ndarray],
    W: np.ndarray,
    drives: list[Drive],
    x0: np.ndarray,
    outputs: list[list[np.ndarray]],
    N: int,
    *,
    chunk: int | None = None,
    direct: tuple[list[np.ndarray], list[list[np.ndarray | None]]] | None = None,
    out: list[list[np.ndarray | None]] | None = None,
    lift: int | None = None,
) -> list[list[np.ndarray]]:
    """Independent subsystems ``x_b[k+1] = A_b x_b[k] + W_b d[k]``, chunked over time.

    Parameters
    ----------
    blocks : list of ndarray
        Transition matrices ``A_b`` (n_b, n_b) of independent subsystems.
    W : ndarray, (sum n_b, nz)
        Input matrix of the stacked drive blocks (columns in the order of ``drives``).
    drives : list of Drive
        The drive signals (see :class:`Drive`); ``nz`` rows in all.
    x0 : ndarray, (sum n_b, R0)
        Initial states.
    outputs : list of list of ndarray
        Per block, output matrices ``C`` (p, n_b); ``C x_b`` is returned for each.
    N : int
        Number of samples.
    chunk : int, optional
        Samples per time chunk (default: ``M`` times about 2**19 / (states x runs),
        between 1024 and 65536, with ``M`` the lifting factor).
    direct : (signals, matrices), optional
        Direct feedthrough: ``signals`` is a list of sampled arrays (k_i, R_i, N), and
        ``matrices[b][j]`` (p, sum k_i) or None is added to output ``j`` of block ``b``
        times the stacked signals, sample by sample.
    out : list of list of ndarray or None, optional
        Preallocated (possibly strided) arrays (p, R, N) to write the outputs into.
    lift : int, optional
        Lifting factor ``M`` (see Notes); by default chosen by :func:`_lift_factor`
        from the sizes; 1 runs the plain recursion.

    Returns
    -------
    list of list of ndarray, each (p, R, N)

    Notes
    -----
    The Schur form of the block-diagonal transition matrix is block diagonal, so all
    subsystems share one forcing product per chunk and one ``lfilter`` call per state;
    back-substitution couplings stay inside each block.  Time is processed in chunks
    whose arrays stay cache-sized; the state at the end of a chunk starts the next one
    (exactly: the recursion is the same, only split).

    *Lifting* (the lifted system of Khargonekar, Poolla & Tannenbaum, IEEE TAC 1985):
    with time blocks of ``M`` samples the block-start states obey

        x[(b+1) M] = A^M x[b M] + sum_{j<M} A^(M-1-j) W d[b M + j]

    (one matrix product forms the forcing of every block, then the scalar ``lfilter``
    recursions run on ``N / M`` samples), and the outputs inside a block follow from the
    block-start state and the block's drive samples,

        C x[b M + i] = C A^i x[b M] + sum_{j<i} C A^(i-1-j) W d[b M + j],

    one product with the lower block-Toeplitz matrix of Markov parameters.  It is the
    same recursion regrouped, not an approximation: it trades ``lfilter`` samples, whose
    cost is mostly per-sample overhead, for matrix-product flops.
    """
    sizes = [b.shape[0] for b in blocks]
    nS = int(sum(sizes))
    Rd = max([d.runs for d in drives] + [1])
    R = max(Rd, x0.shape[1])
    Ts, Zs, stops = [], [], []
    i = 0
    for A in blocks:
        T, Z = schur_form(A)
        Ts.append(T)
        Zs.append(Z)
        i += A.shape[0]
        stops += [i] * A.shape[0]
    Zb = scipy.linalg.block_diag(*Zs) if Zs else np.zeros((0, 0))
    Zh = Zb.conj().T
    cplx = any(np.iscomplexobj(T) for T in Ts)
    dtype = complex if cplx else float
    V = Zh @ W
    col = np.cumsum([0] + [d.arr.shape[0] for d in drives])
    spans = list(zip(col[:-1], col[1:], strict=True))
    nz = int(col[-1])
    dsig, dmats = direct if direct is not None else ([], [[None] * len(o) for o in outputs])
    nd = int(sum(a.shape[0] for a in dsig))
    # every output: (block, state slice, C, destination, first row in the output stack)
    flat = []
    i = o = 0
    for b, (n_b, outs) in enumerate(zip(sizes, outputs, strict=True)):
        for j, C in enumerate(outs):
            dest = out[b][j] if out is not None and out[b][j] is not None else None
            if dest is None:
                dest = np.empty((C.shape[0], R, N))
            flat.append((b, slice(i, i + n_b), C, dest, o))
            o += C.shape[0]
        i += n_b
    p_tot = o
    if lift is None:
        M = _lift_factor(nS, p_tot, nz, cplx) if nz and N >= 64 * _MAX_LIFT else 1
    else:
        M = int(lift)
        if M < 1:
            raise GeomFDIError(f"lift: must be a positive integer, got {lift!r}", argument="lift")
    Tb = scipy.linalg.block_diag(*Ts) if Ts else np.zeros((0, 0), dtype=dtype)
    TbM = np.linalg.matrix_power(Tb, M)  # A^M in Schur coordinates: the lifted transition
    # Hz[:, (c, j)] = Z^H A^(M-1-j) W[:, c] = T^(M-1-j) V[:, c]
    Hz = np.empty((nS, nz, M), dtype=dtype)
    Hj = V.astype(dtype)
    for j in range(M - 1, -1, -1):
        Hz[:, :, j] = Hj
        Hj = Tb @ Hj
    Hz = Hz.reshape(nS, nz * M)
    # Markov parameters C A^(i-1-j) W (j < i) map the lifted drive, rows (c, j), to the
    # lifted outputs, rows (o, i); the feedthrough is applied at the original rate
    Gam = None
    if M > 1 and nz:
        Cb = np.zeros((p_tot, nS))
        for _, sl, C, _, o0 in flat:
            Cb[o0 : o0 + C.shape[0], sl] = C
        Gam = _markov_toeplitz(scipy.linalg.block_diag(*blocks), W, Cb, M)
    Dall = None
    if nd:
        Dall = np.zeros((p_tot, nd))
        for (_, _, C, _, o0), Dm in zip(flat, (m for ms in dmats for m in ms), strict=True):
            if Dm is not None:
                Dall[o0 : o0 + C.shape[0]] = Dm
    # C A^i Z = C Z T^i on the block-start state, grouped by output and block sizes so
    # that each group is one stacked product (slices when the group is contiguous)
    groups: dict[tuple[int, int], list[tuple[slice, int, np.ndarray]]] = {}
    for b, sl, C, _, o0 in flat:
        P = [C @ Zs[b]]
        for _ in range(M - 1):
            P.append(P[-1] @ Ts[b])
        Psi = np.stack(P, axis=1).reshape(C.shape[0] * M, -1)  # rows (o, i)
        groups.setdefault((C.shape[0], sl.stop - sl.start), []).append((sl, o0, Psi))
    state_maps = []
    for (p, _), members in groups.items():
        sidx = np.concatenate([np.arange(sl.start, sl.stop) for sl, _, _ in members])
        ridx = np.concatenate([np.arange(o0 * M, (o0 + p) * M) for _, o0, _ in members])
        state_maps.append((_as_slice(sidx), _as_slice(ridx), np.stack([P for _, _, P in members])))
    z = (Zh @ np.broadcast_to(x0, (nS, x0.shape[1]))).astype(dtype)
    z = np.broadcast_to(z, (nS, R))
    # chunk: about 2**21 doubles of lifted arrays, between 1024 and 16384 lifted samples
    # (each lfilter call has an overhead of a few microseconds)
    # chunk: work arrays of about 2**20 doubles in all, reused from chunk to chunk (fresh
    # memory costs page faults), between 512 and 16384 lifted samples (each lfilter call
    # has an overhead of a few microseconds)
    Rdd = max([a.shape[1] for a in dsig] + [1])
    per = M * (nz * Rd + 2 * p_tot * R + nd * Rdd + p_tot * Rdd) + (2 if cplx else 1) * nS * R
    Lb = chunk // M if chunk else max(512, min(2**14, 2**20 // max(per, 1)))
    Lc = max(Lb, 1) * M
    pool: dict[str, np.ndarray] = {}

    def work(name: str, shape: tuple[int, ...], dt: Any = float) -> np.ndarray:
        size = int(np.prod(shape))
        if name not in pool or pool[name].size < size:
            pool[name] = np.empty(max(size, 1), dtype=dt)
        return pool[name][:size].reshape(shape)

    s = 0
    while s < N:
        e = min(s + Lc, N)
        if e > N - 1 - M or e - s < M:  # the end: whole blocks with data, then the rest
            e = s + (N - 1 - s) // M * M if N - 1 - s >= M else N
        L = e - s  # samples s .. e-1 of this chunk
        nb = -(-L // M)
        Lp = nb * M  # steps s .. s+Lp-1 (those past N-2 are padded with zeros)
        G = work("G", (nS, R, nb + 1), dtype)
        G[:, :, 0] = z
        Y = None
        if nz:
            Lv = max(0, min(Lp, N - 1 - s))
            Dl = work("Dl", (nz, M, Rd, nb))
            for (c0, c1), d in zip(spans, drives, strict=True):
                w = d.window(s, Lv)
                if Lv < Lp:
                    pad = np.zeros(w.shape[:2] + (Lp,))
                    pad[..., :Lv] = w
                    w = pad
                Dl[c0:c1] = w.reshape(c1 - c0, w.shape[1], nb, M).transpose(0, 3, 1, 2)
            D2 = Dl.reshape(nz * M, Rd * nb)
            if R == 1 and not cplx:  # the product straight into the forcing slots
                np.matmul(Hz, D2, out=G[:, 0, 1:])
            else:
                G[:, :, 1:] = _product(Hz, D2).reshape(nS, Rd, nb)
            if Gam is not None:
                Y = work("Y", (p_tot * M, Rd, nb))
                np.matmul(Gam, D2, out=Y.reshape(p_tot * M, Rd * nb))
        else:
            G[:, :, 1:] = 0.0
        zc = _recursion_inplace(TbM, G, stops)
        if Y is None or Rd < R:
            Yr = work("Yr", (p_tot * M, R, nb))
            Yr[...] = 0.0 if Y is None else Y
            Y = Yr
        for sidx, ridx, Psi in state_maps:
            zg = zc[sidx, :, :nb].reshape(len(Psi), -1, R * nb)
            if np.iscomplexobj(zg):
                Y[ridx] += _real_product(Psi, zg).reshape(-1, R, nb)
            else:
                tmp = work("psi", (len(Psi), Psi.shape[1], R * nb))
                np.matmul(Psi, zg, out=tmp)
                Y[ridx] += tmp.reshape(-1, R, nb)
        if nd:
            Dd = work("Dd", (nd, Rdd, L))
            i = 0
            for a in dsig:
                Dd[i : i + a.shape[0]] = a[:, :, s:e]
                i += a.shape[0]
            F = work("F", (p_tot, Rdd, L))
            np.matmul(Dall, Dd.reshape(nd, Rdd * L), out=F.reshape(p_tot, Rdd * L))
        for (_, _, C, dest, o0), Dm in zip(flat, (m for ms in dmats for m in ms), strict=True):
            p = C.shape[0]
            val4 = Y[o0 * M : (o0 + p) * M].reshape(p, M, R, nb).transpose(0, 2, 3, 1)
            dst = dest[:, :, s:e]
            if Lp == L:
                if Dm is not None and nd:
                    np.add(val4, _blocked_view(F[o0 : o0 + p], M), out=_blocked_view(dst, M))
                else:
                    np.copyto(_blocked_view(dst, M), val4)
            else:
                dst[...] = val4.reshape(p, R, Lp)[..., :L]
                if Dm is not None and nd:
                    dst += F[o0 : o0 + p]
        z = zc[:, :, nb].copy()
        s = e
    res: list[list[np.ndarray]] = [[] for _ in outputs]
    for b, _, _, dest, _ in flat:
        res[b].append(dest)
    return res


def driven_recursion(
    Ad: np.ndarray, W: np.ndarray, drive: np.ndarray, x0: np.ndarray
) -> np.ndarray:
    """``x[k+1] = Ad x[k] + W drive[k]``, state-major layout, without a time loop.

    Parameters
    ----------
    Ad : ndarray, (n, n)
    W : ndarray, (n, nz)
        Input matrix of the stacked drive signals.
    drive : ndarray, (nz, Rd, N-1)
        Drive samples (``Rd`` is 1 or the number of runs).
    x0 : ndarray, (n, R0)

    Returns
    -------
    ndarray, (n, R, N) with ``R = max(Rd, R0)``

    Notes
    -----
    See :func:`block_recursion` (a single block, the identity as output).
    """
    n = Ad.shape[0]
    nz, Rd, L = drive.shape
    R = max(Rd, x0.shape[1])
    if x0.shape[1] not in (1, R):
        raise ShapeError(f"x0: {x0.shape[1]} runs, the drive has {Rd}", argument="x0")
    if n == 0:
        return np.zeros((0, R, L + 1))
    return block_recursion([Ad], W, [Drive(drive)], x0, [[np.eye(n)]], L + 1)[0][0]


def linear_recursion(Ad: Any, forcing: Any, x0: Any) -> np.ndarray:
    """Solve ``x[k+1] = Ad x[k] + forcing[k]`` for ``k = 0 .. N-2`` from ``x[0] = x0``.

    Parameters
    ----------
    Ad : array_like, (n, n)
        Transition matrix.
    forcing : array_like, (n, N-1) or (R, n, N-1)
        Forcing per step (a leading run axis of length 1 broadcasts).
    x0 : array_like, (n,) or (R, n)
        Initial state(s).

    Returns
    -------
    ndarray, (R, n, N)
        The state sequence of every run (``R = 1`` when neither argument has a run axis).

    Notes
    -----
    Back-substitution on the Schur form (module docstring): ``n`` calls of
    :func:`scipy.signal.lfilter` over the whole ``(R, N)`` time/run array, each solving a
    scalar recursion ``s[k] = lambda s[k-1] + g[k]`` exactly as the naive loop would, and
    ``O(n^2 R N)`` flops for the couplings.  The unitary change of basis keeps rounding
    errors at the level of the naive recursion; repeated or defective eigenvalues need no
    special treatment (no eigenvector basis is formed).
    """
    Ad = np.asarray(Ad, dtype=float)
    n = Ad.shape[0]
    f = np.asarray(forcing, dtype=float)
    if f.ndim == 2:
        f = f[None]
    x0 = np.asarray(x0, dtype=float)
    if x0.ndim == 1:
        x0 = x0[None]
    if f.ndim != 3 or f.shape[1] != n or x0.shape[1] != n:
        raise ShapeError(
            f"forcing, x0: expected {n} state rows, got {f.shape} and {x0.shape}",
            argument="forcing",
        )
    R = max(f.shape[0], x0.shape[0])
    if f.shape[0] not in (1, R) or x0.shape[0] not in (1, R):
        raise ShapeError(
            f"forcing, x0: run axes {f.shape[0]} and {x0.shape[0]} do not broadcast",
            argument="forcing",
        )
    drive = np.ascontiguousarray(f.transpose(1, 0, 2))
    x = driven_recursion(Ad, np.eye(n), drive, np.ascontiguousarray(x0.T))
    return np.ascontiguousarray(x.transpose(1, 0, 2))


def uniform_step(t: Any, name: str = "t") -> tuple[np.ndarray, float]:
    """Validate a uniform, increasing time grid; return it and its step.

    The step is ``(t[-1] - t[0]) / (N - 1)``; every difference must match it to a relative
    ``1e-6`` (python-control accepts ``np.allclose``).
    """
    t = as_real_array(t, name)
    if t.ndim != 1:
        raise ShapeError(f"{name}: must be a 1-D time vector, got shape {t.shape}", argument=name)
    if t.size < 2:
        raise ShapeError(f"{name}: needs at least 2 samples, got {t.size}", argument=name)
    step = (t[-1] - t[0]) / (t.size - 1)
    if not step > 0:
        raise GeomFDIError(f"{name}: must be increasing", argument=name)
    if np.max(np.abs(np.diff(t) - step)) > 1e-6 * step:
        raise GeomFDIError(f"{name}: time values must be equally spaced", argument=name)
    return t, float(step)


def simulate_lti(
    A: Any,
    B: Any,
    C: Any,
    D: Any,
    u: Any,
    t: Any,
    *,
    x0: Any = None,
    dt: float = 0.0,
    hold: str = "foh",
) -> tuple[np.ndarray, np.ndarray]:
    """Simulate ``x' = A x + B u, y = C x + D u`` (or its discrete form) on a uniform grid.

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices, (n, n), (n, m), (p, n), (p, m).
    u : array_like, (m, N) or (R, m, N), or None
        Input samples (``None``: zero input); a 1-D array is read as ``(1, N)``.
    t : array_like, (N,)
        Uniform time grid.
    x0 : array_like, (n,) or (R, n), optional
        Initial state(s), zero by default.
    dt : float
        0: continuous system (discretised exactly with ``hold``); > 0: a discrete system
        with that sampling period, which must equal the grid step.
    hold : {"foh", "zoh"}
        Input interpolation for continuous systems.  ``"foh"`` reproduces
        :func:`control.forced_response`.

    Returns
    -------
    x : ndarray, (n, N) or (R, n, N)
    y : ndarray, (p, N) or (R, p, N)
        With a run axis when ``u`` or ``x0`` has one.

    Examples
    --------
    >>> import numpy as np
    >>> from geomfdi.lti_sim import simulate_lti
    >>> t = np.linspace(0, 5, 501)
    >>> x, y = simulate_lti([[-1.0]], [[1.0]], [[1.0]], [[0.0]], np.ones((1, 501)), t)
    >>> bool(abs(y[0, -1] - (1 - np.exp(-5))) < 1e-12)
    True
    """
    A = as_matrix(A, "A", square=True)
    n = A.shape[0]
    B = as_matrix(B, "B", rows=n, allow_empty=True, vector_as="column")
    m = B.shape[1]
    C = as_matrix(C, "C", cols=n, allow_empty=True, vector_as="row")
    p = C.shape[0]
    D = np.zeros((p, m)) if D is None else as_matrix(D, "D", rows=p, cols=m, allow_empty=True)
    t, step = uniform_step(t)
    N = t.size
    batched = False
    if u is None:
        u = np.zeros((1, m, N))
    else:
        u = as_real_array(u, "u")
        if u.ndim == 1:
            u = u[None]
        if u.ndim == 3:
            batched = True
        elif u.ndim == 2:
            u = u[None]
        else:
            raise ShapeError(f"u: expected (m, N) or (R, m, N), got shape {u.shape}", argument="u")
        if u.shape[1:] != (m, N):
            raise ShapeError(
                f"u: expected shape ({m}, {N}) per run, got {u.shape[1:]}", argument="u"
            )
    if x0 is None:
        x0 = np.zeros((1, n))
    else:
        x0 = as_real_array(x0, "x0")
        if x0.ndim == 2:
            batched = True
        elif x0.ndim == 1:
            x0 = x0[None]
        if x0.ndim != 2 or x0.shape[1] != n:
            raise ShapeError(
                f"x0: expected length {n} per run, got shape {x0.shape}", argument="x0"
            )
    dt = float(dt)
    if dt > 0:
        if abs(step - dt) > 1e-6 * dt:
            raise GeomFDIError(
                f"t: the grid step {step:g} must equal the sampling period dt={dt:g}",
                argument="t",
            )
        dis = _discrete(A, B, dt)
    else:
        dis = discretize(A, B, step, hold)
    x = linear_recursion(dis.Ad, dis.forcing(u), x0)
    y = C @ x + D @ u
    if not batched:
        return x[0], y[0]
    return x, y
