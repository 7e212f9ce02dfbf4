"""The blocked ("lifted") recursion that drives a bank of systems by stacked signals.

:func:`block_recursion` advances several systems ``x_b[k+1] = Ad_b x_b[k] + W_b drive[k]``
over a long horizon in chunks of time, on the lifted system of blocks of ``M`` samples
for large state dimensions (most of the work moves from ``lfilter`` samples to matrix
products), with outputs ``C x + D direct`` written in place.  :func:`linear_recursion`
and :func:`driven_recursion` are its one-system forms.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.simulation.recursion import matrix_product, modal_form, recursion_inplace
from geomfdi.simulation.workspace import thread_workspace

__all__ = ["Drive", "block_recursion", "driven_recursion", "linear_recursion"]


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
_LIFT_OVERHEAD = 40.0  # per lifted output and drive row and sample: strided layout copies
_TOEPLITZ_FILL = 0.6  # share of the block-Toeplitz product computed (zero blocks skipped)
_TOEPLITZ_SPLITS = 4  # row blocks of the block-Toeplitz product
_MAX_LIFT = 32
_CHUNK_DOUBLES = 2**20
_MIN_BLOCKS = 512


def _lift_factor(n_states: int, n_out: int, n_drive: int, complex_: bool) -> int:
    """Lifting factor ``M`` of :func:`block_recursion` from a cost model.

    Per sample, the plain recursion costs ``c n`` (``n`` scalar recursions, ``c`` about
    150: what one ``lfilter`` sample costs in matrix-product multiply-adds, twice that for
    complex states).  The lifted one costs ``c n / M`` for the recursions at the lifted
    rate, about ``0.6 p nz M`` multiply-adds for the block-Toeplitz product (``p``
    outputs, ``nz`` drive channels; the zero blocks above the diagonal are mostly
    skipped) and ``k (p + nz)`` for copying to and from the lifted layout (``k`` about
    40, measured).  ``M`` minimises that cost over ``1 .. 32``.
    """
    c = _LFILTER_COST * (2 if complex_ else 1)
    n, p, nz = n_states, n_out, max(n_drive, 1)

    def cost(M: int) -> float:
        if M == 1:
            return c * n
        return c * n / M + _TOEPLITZ_FILL * p * nz * M + _LIFT_OVERHEAD * (p + nz)

    return min(range(1, _MAX_LIFT + 1), key=cost)


def _markov_toeplitz(Ab: np.ndarray, W: np.ndarray, Cb: np.ndarray, M: int) -> np.ndarray:
    """Lower block-Toeplitz map of the lifted system, ``(M, p, nz, M)``.

    Entry ``[i, o, c, j]`` is ``(C A^(i-1-j) W)[o, c]`` for ``j < i`` and 0 otherwise
    (output ``o`` at sample ``i`` of a block, drive channel ``c`` at step ``j``).
    """
    p, nz = Cb.shape[0], W.shape[1]
    Gam = np.zeros((M, p, nz, M))
    P = W
    for r in range(M - 1):  # the Markov parameter C A^r W links i = j + r + 1 to j
        Gam[np.arange(r + 1, M), :, :, np.arange(M - 1 - r)] = Cb @ P
        P = Ab @ P
    return Gam


@dataclass
class _Source:
    """Drive channels read from one array, at one or more shifts.

    Drives of one unscaled array (a first-order hold reads ``u[k]`` and ``u[k+1]``) share
    their lifted rows: a block needs the ``M + 1`` samples ``u[bM] .. u[bM + M]`` once,
    not ``2 M``.  ``parts`` holds ``(shift, first W column)`` of every drive.
    """

    drive: Drive
    k: int
    parts: list[tuple[int, int]]
    smin: int = 0
    smax: int = 0
    row0: int = 0  # first channel in the main lifted rows
    tail0: int = 0  # first extra row (samples past the block)

    def samples(self, s: int, Lw: int, N: int) -> np.ndarray:
        """Samples ``s + smin .. s + smin + Lw - 1`` (zeros past the data)."""
        d = self.drive
        if d.scale is None:
            a = d.arr[..., s + self.smin : min(N, s + self.smin + Lw)]
        else:  # one drive: steps s .. (at most N - 2)
            a = d.window(s, max(0, min(Lw, N - 1 - s)))
        if a.shape[-1] < Lw:
            pad = np.zeros(a.shape[:2] + (Lw,))
            pad[..., : a.shape[-1]] = a
            a = pad
        return a


def _sources(drives: list[Drive], spans: list[tuple[int, int]]) -> list[_Source]:
    srcs: dict[Any, _Source] = {}
    for i, (d, (c0, _)) in enumerate(zip(drives, spans, strict=True)):
        key = ("array", id(d.arr)) if d.scale is None else ("scaled", i)
        if key not in srcs:
            srcs[key] = _Source(d, d.arr.shape[0], [], d.shift, d.shift)
        src = srcs[key]
        src.parts.append((d.shift, c0))
        src.smin, src.smax = min(src.smin, d.shift), max(src.smax, d.shift)
    return list(srcs.values())


def _blocked_view(arr: np.ndarray, M: int, Mw: int | None = None) -> np.ndarray:
    """A ``(p, R, L)`` array seen as ``(p, R, L // M, Mw)``: blocks of ``M`` samples
    (overlapping windows of ``Mw > M`` samples when given)."""
    p, R, L = arr.shape
    s0, s1, s2 = arr.strides
    Mw = M if Mw is None else Mw
    nb = L // M if Mw == M else (L - Mw) // M + 1
    return np.lib.stride_tricks.as_strided(arr, (p, R, nb, Mw), (s0, s1, M * s2, s2))


def _as_slice(idx: np.ndarray) -> slice | np.ndarray:
    """A run of consecutive indices as a slice (a view instead of a gather)."""
    if idx.size and np.array_equal(idx, np.arange(idx[0], idx[0] + idx.size)):
        return slice(int(idx[0]), int(idx[0]) + idx.size)
    return idx


def _real_product(Mat: np.ndarray, arr: np.ndarray) -> np.ndarray:
    """``Re(Mat @ arr)`` without forming the complex product: one real product of
    ``[Re Mat, -Im Mat]`` with ``[Re arr; Im arr]`` (contiguous operands: the strided
    real and imaginary views would miss the BLAS)."""
    if np.iscomplexobj(arr):
        if not np.iscomplexobj(Mat):
            return Mat @ np.ascontiguousarray(arr.real)
        W = np.concatenate([Mat.real, -Mat.imag], axis=-1)
        return W @ np.concatenate([arr.real, arr.imag], axis=-2)
    return Mat.real @ arr


_CACHE_ENTRIES = 64
_MODAL: dict[Any, Any] = {}
_LIFTED: dict[Any, Any] = {}
_BLOCKS: dict[Any, Any] = {}  # block-diagonal modal bases (the final state's coordinates)


def _digest(arrays: list[np.ndarray]) -> bytes:
    """A fingerprint of the shapes and values of ``arrays``."""
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(repr((a.shape, a.dtype.str)).encode())
        h.update(a.tobytes())
    return h.digest()


def _cached(cache: dict[Any, Any], key: Any, make: Any) -> Any:
    """``cache[key]``, made by ``make()`` when missing.  The set-up of
    :func:`block_recursion` depends on the matrices only, so a long record simulated
    chunk by chunk (the same matrices each time) computes it once; the cached arrays
    are never written to."""
    hit = cache.get(key)
    if hit is None:
        hit = make()
        if len(cache) >= _CACHE_ENTRIES:
            cache.clear()
        cache[key] = hit
    return hit


def _modal_setup(blocks: list[np.ndarray], W: np.ndarray) -> tuple[Any, ...]:
    """Modal (or Schur) forms of the blocks: ``(Ts, Zs, Zis, stops, Z^-1, complex, Z^-1 W)``."""
    Ts, Zs, Zis, stops = [], [], [], []
    i = 0
    for A in blocks:
        T, Z, Zi, diagonal = modal_form(A)
        Ts.append(T)
        Zs.append(Z)
        Zis.append(Zi)
        n_b = A.shape[0]
        # state j couples to the states after it up to the end of its block (Schur form)
        stops += list(range(i + 1, i + n_b + 1)) if diagonal else [i + n_b] * n_b
        i += n_b
    Zinv = scipy.linalg.block_diag(*Zis) if Zis else np.zeros((0, 0))
    cplx = any(np.iscomplexobj(T) for T in Ts)
    return Ts, Zs, Zis, stops, Zinv, cplx, Zinv @ W


def _lifted_setup(
    blocks: list[np.ndarray],
    W: np.ndarray,
    outputs: list[list[np.ndarray]],
    flat: list[Any],
    srcs: list[_Source],
    modal: tuple[Any, ...],
    M: int,
    nL: int,
    nzc: int,
    nz: int,
    p_tot: int,
) -> tuple[Any, ...]:
    """The lifted system of :func:`block_recursion` (see its Notes):
    ``(Tb, Tb^M, Hz, Gam, splits, CZ, state_maps)``."""
    Ts, Zs, _, _, _, cplx, V = modal
    nS = V.shape[0]
    dtype = complex if cplx else float
    Tb = scipy.linalg.block_diag(*Ts) if Ts else np.zeros((0, 0), dtype=dtype)
    TbM = np.linalg.matrix_power(Tb, M)  # A^M in modal coordinates: the lifted transition
    # Hp[:, c, j] = Z^-1 A^(M-1-j) W[:, c] = T^(M-1-j) V[:, c]: forcing of step j of a block
    Hp = np.empty((nS, nz, M), dtype=dtype)
    Hj = V.astype(dtype)
    for j in range(M - 1, -1, -1):
        Hp[:, :, j] = Hj
        Hj = Tb @ Hj
    # Markov parameters C A^(i-1-j) W (j < i) map the drive steps of a block to its
    # outputs, rows (i, o); the feedthrough is applied at the original rate
    Gp = None
    if M > 1 and nz:
        Cb = np.zeros((p_tot, nS))
        for _, sl, C, _, o0 in flat:
            Cb[o0 : o0 + C.shape[0], sl] = C
        Gp = _markov_toeplitz(scipy.linalg.block_diag(*blocks), W, Cb, M)
    # gather the per-drive columns (c, step j) onto the lifted rows of their source
    Hz = np.zeros((nS, nL), dtype=dtype)
    Gam = np.zeros((M * p_tot, nL)) if Gp is not None else None
    for src in srcs:
        for shift, c0 in src.parts:
            j = np.arange(M) + shift - src.smin  # sample of step jj within the window
            ch = np.arange(src.k)[:, None]
            rows = np.where(
                j < M, j * nzc + src.row0 + ch, src.tail0 + (j - M) * src.k + ch
            ).ravel()  # (channel, step) order, distinct within one drive
            Hz[:, rows] += Hp[:, c0 : c0 + src.k].reshape(nS, src.k * M)
            if Gam is not None:
                Gam[:, rows] += Gp[:, :, c0 : c0 + src.k].reshape(M * p_tot, src.k * M)
    # output rows (i, o) with i in [i0, i1) see steps j < i only, whose lifted rows (all at
    # sample <= i1 - 1, a step read one sample late included) are the first i1 nzc: the
    # product is split in row blocks that skip the zero blocks above the diagonal
    splits = []
    if Gam is not None:
        nspl = min(_TOEPLITZ_SPLITS, M - 1)
        edges = [1 + round(q * (M - 1) / nspl) for q in range(nspl + 1)]
        splits = [(i0, i1) for i0, i1 in zip(edges[:-1], edges[1:], strict=True) if i1 > i0]
    # C A^i Z = C Z T^i on the block-start state, rows (i, o), grouped by output and block
    # sizes so that each group is one stacked product (slices when the group is contiguous)
    groups: dict[tuple[int, int], list[tuple[slice, int, np.ndarray]]] = {}
    CZ = []
    for b, sl, C, _, o0 in flat:
        P = [C @ Zs[b]]
        CZ.append(P[0])
        for _ in range(M - 1):
            P.append(P[-1] @ Ts[b])
        groups.setdefault((C.shape[0], sl.stop - sl.start), []).append(
            (sl, o0, np.stack(P).reshape(M * C.shape[0], -1))
        )
    state_maps = []
    for (p, _), members in groups.items():
        sidx = np.concatenate([np.arange(sl.start, sl.stop) for sl, _, _ in members])
        oidx = np.concatenate([np.arange(o0, o0 + p) for _, o0, _ in members])
        Psi = np.stack([P for _, _, P in members])
        state_maps.append((_as_slice(sidx), _as_slice(oidx), p, Psi))
    return Tb, TbM, Hz, Gam, splits, CZ, state_maps


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
    final: bool = False,
    key: Any = None,
) -> Any:
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
    final : bool
        Also return the state at the last sample ``N - 1`` (sum n_b, R), in the
        coordinates of ``x0``: a long record simulated in consecutive calls (each call's
        window ending on the sample where the next one starts) carries it over as the
        next call's ``x0``.
    key : hashable, optional
        The caller's fingerprint of ``blocks``, ``W`` and ``outputs`` (equal keys: equal
        matrices), naming their set-up in the caches instead of a digest of their values
        (a caller that already holds one saves hashing the matrices on every call).

    Returns
    -------
    list of list of ndarray, each (p, R, N)
        With ``final=True``, the pair ``(outputs, state at sample N - 1)``.

    Notes
    -----
    The modal (or Schur) form of the block-diagonal transition matrix is block diagonal
    (:func:`modal_form` per block), so all subsystems share one forcing product per
    chunk and one ``lfilter`` call per state; back-substitution couplings (Schur blocks
    only) stay inside each block.  Time is processed in chunks
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
    cost is mostly per-sample overhead, for matrix-product flops.  Two savings: drives
    that read one array at shifts 0 and 1 (a first-order hold) share their lifted rows,
    ``M + 1`` samples per block instead of ``2 M``; and the Toeplitz product is done in
    row blocks of output samples ``i``, each with only the drive samples ``j <= i`` it
    can see (about 60 % of the full product).
    """
    sizes = [b.shape[0] for b in blocks]
    nS = int(sum(sizes))
    Rd = max([d.runs for d in drives] + [1])
    R = max(Rd, x0.shape[1])
    mkey = _digest(blocks + [W]) if key is None else ("key", key)
    modal = _cached(_MODAL, mkey, lambda: _modal_setup(blocks, W))
    Ts, Zs, Zis, stops, Zinv, cplx, V = modal
    dtype = complex if cplx else float
    col = np.cumsum([0] + [d.arr.shape[0] for d in drives])
    spans = list(zip(col[:-1], col[1:], strict=True))
    nz = int(col[-1])
    srcs = _sources(drives, spans)
    nzc = sum(src.k for src in srcs)  # drive channels per sample
    dsig, dmats = direct if direct is not None else ([], [[None] * len(o) for o in outputs])
    dmats = [[m if m is not None and np.any(m) else None for m in ms] for ms in dmats]
    if all(m is None for ms in dmats for m in ms):
        dsig = []
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
    Dms = [m for ms in dmats for m in ms]  # feedthrough of every output, in flat's order
    if lift is None:
        M = _lift_factor(nS, p_tot, nzc, cplx) if nz and N >= 64 * _MAX_LIFT else 1
    else:
        M = int(lift)
        if M < 1:
            raise GeomFDIError(f"lift: must be a positive integer, got {lift!r}", argument="lift")
    # lifted drive rows: sample j < M of every channel, j-major (row j nzc + channel),
    # then the samples past the block of sources read at two shifts (forcing only)
    r0 = t0 = 0
    for src in srcs:
        src.row0, src.tail0 = r0, M * nzc + t0
        r0 += src.k
        t0 += (src.smax - src.smin) * src.k
    nL = M * nzc + t0
    layout = tuple(
        (src.k, src.smin, src.smax, tuple(src.parts), src.drive.scale is None) for src in srcs
    )
    okey = _digest([C for outs in outputs for C in outs]) if key is None else None
    lkey = (mkey, okey, layout, M)
    hit = _LIFTED.get(lkey)
    if hit is not None:
        Tb, TbM, Hz, Gam, splits, CZ, state_maps = hit
    else:
        lifted = _lifted_setup(blocks, W, outputs, flat, srcs, modal, M, nL, nzc, nz, p_tot)
        Tb, TbM, Hz, Gam, splits, CZ, state_maps = _cached(_LIFTED, lkey, lambda: lifted)
    # feedthrough: signals of every run, then the signals shared by all runs (their
    # product computed once and added to every run)
    Rdd = max([a.shape[1] for a in dsig] + [1])
    feeds = []
    if nd:
        Dall = np.zeros((p_tot, nd))
        for (_, _, C, _, o0), Dm in zip(flat, Dms, strict=True):
            if Dm is not None:
                Dall[o0 : o0 + C.shape[0]] = Dm
        if any(a.shape[1] not in (1, Rdd) for a in dsig):
            raise ShapeError(
                f"direct: signals with {sorted({a.shape[1] for a in dsig})} runs do not broadcast",
                argument="direct",
            )
        cstart = np.cumsum([0] + [a.shape[0] for a in dsig])
        for shared in (False, True):
            sel = [i for i, a in enumerate(dsig) if (a.shape[1] < Rdd) == shared]
            if sel:
                cols = np.concatenate([np.arange(cstart[i], cstart[i + 1]) for i in sel])
                feeds.append(([dsig[i] for i in sel], np.ascontiguousarray(Dall[:, cols])))
    z = (Zinv @ np.broadcast_to(x0, (nS, x0.shape[1]))).astype(dtype)
    z = np.broadcast_to(z, (nS, R))

    # real states, no lifting: every output is one product (per run) written straight
    # into its destination, then the feedthrough added in place
    straight = M == 1 and not cplx
    # chunk: work arrays of about 2**20 doubles in all, reused from chunk to chunk and
    # from call to call (fresh memory costs page faults), between 512 and 16384 lifted
    # samples (each lfilter call has an overhead of a few microseconds)
    per = nL * Rd + M * (2 * p_tot * R + nd * Rdd + p_tot * Rdd) + (2 if cplx else 1) * nS * R
    Lb = chunk // M if chunk else max(_MIN_BLOCKS, min(2**14, _CHUNK_DOUBLES // max(per, 1)))
    Lc = max(Lb, 1) * M
    # chunk-sized work arrays, kept by the thread from call to call (geomfdi.simulation.workspace)
    work = thread_workspace("recursion").get

    s = 0
    while s < N:
        e = min(s + Lc, N)
        # the end: the last chunk runs to the record's end, its last block partial (the
        # steps past the data read zeros and only reach states past the end), not a
        # further chunk for the fewer than M + 1 samples left
        if e > N - 1 - M:
            e = N
        L = e - s  # samples s .. e-1 of this chunk
        nb = -(-L // M)
        Lp = nb * M  # steps s .. s+Lp-1 (those past N-2 only reach states past the end)
        G = work("G", (nS, R, nb + 1), dtype)
        G[:, :, 0] = z
        Y = None
        if nz:
            Dl = work("Dl", (nL, Rd, nb))
            Dmain = Dl[: M * nzc].reshape(M, nzc, Rd, nb)
            for src in srcs:
                ext = src.smax - src.smin
                win = _blocked_view(src.samples(s, Lp + ext, N), M, M + ext)
                Dmain[:, src.row0 : src.row0 + src.k] = win[..., :M].transpose(3, 0, 1, 2)
                if ext:
                    tail = Dl[src.tail0 : src.tail0 + ext * src.k]
                    tail.reshape(ext, src.k, Rd, nb)[...] = win[..., M:].transpose(3, 0, 1, 2)
            D2 = Dl.reshape(nL, Rd * nb)
            if R == 1 and not cplx:  # the product straight into the forcing slots
                np.matmul(Hz, D2, out=G[:, 0, 1:])
            else:
                G[:, :, 1:] = matrix_product(Hz, D2).reshape(nS, Rd, nb)
            if Gam is not None:
                Y = work("Y", (M * p_tot, Rd, nb))
                Y2 = Y.reshape(M * p_tot, Rd * nb)
                Y2[:p_tot] = 0.0  # the first sample of a block: block-start state only
                for i0, i1 in splits:
                    k1 = i1 * nzc
                    np.matmul(
                        Gam[i0 * p_tot : i1 * p_tot, :k1], D2[:k1], out=Y2[i0 * p_tot : i1 * p_tot]
                    )
        else:
            G[:, :, 1:] = 0.0
        zc = recursion_inplace(TbM, G, stops)
        if final and s <= N - 1 < s + Lp:
            last = _state_at(N - 1, s, M, zc, Tb, V, drives, spans)
        if nd:
            F = work("F", (p_tot, Rdd, L))
            for fi, (sigs, Dq) in enumerate(feeds):
                if len(sigs) == 1:  # a strided view is enough for the product
                    Dd = sigs[0][:, :, s:e]
                else:
                    Dd = work(f"Dd{fi}", (Dq.shape[1], sigs[0].shape[1], L))
                    i = 0
                    for a in sigs:
                        Dd[i : i + a.shape[0]] = a[:, :, s:e]
                        i += a.shape[0]
                if fi == 0:  # runs as the batch axis, straight into F
                    np.matmul(Dq, Dd.transpose(1, 0, 2), out=F.transpose(1, 0, 2))
                else:  # shared by all runs
                    F += (Dq @ Dd[:, 0])[:, None, :]
        if straight:
            for (_, sl, C, dest, o0), Dm, CZj in zip(flat, Dms, CZ, strict=True):
                dst = dest[:, :, s:e]
                if R == 1:
                    np.matmul(CZj, zc[sl, 0, :L], out=dst[:, 0])
                else:  # one product per run (runs as the batch axis)
                    np.matmul(CZj, zc[sl, :, :L].transpose(1, 0, 2), out=dst.transpose(1, 0, 2))
                if Dm is not None:
                    dst += F[o0 : o0 + C.shape[0]]
            z = zc[:, :, nb].copy()
            s = e
            continue
        if Y is None or Rd < R:
            Yr = work("Yr", (M * p_tot, R, nb))
            Yr[...] = 0.0 if Y is None else Y
            Y = Yr
        Y3 = Y.reshape(M, p_tot, R * nb)  # rows (i, o)
        for sidx, oidx, p, Psi in state_maps:
            nG = len(Psi)
            zg = zc[sidx, :, :nb].reshape(nG, -1, R * nb)
            if np.iscomplexobj(zg):
                tmp = _real_product(Psi, zg)
            else:
                tmp = work("psi", (nG, M * p, R * nb))
                np.matmul(Psi, zg, out=tmp)
            add = tmp.reshape(nG, M, p, R * nb).transpose(1, 0, 2, 3)
            if isinstance(oidx, slice):
                Yv = Y3[:, oidx].reshape(M, nG, p, R * nb)
                np.add(Yv, add, out=Yv)
            else:
                Y3[:, oidx] += add.reshape(M, nG * p, R * nb)
        for (_, _, C, dest, o0), Dm in zip(flat, Dms, strict=True):
            p = C.shape[0]
            val4 = Y3[:, o0 : o0 + p].reshape(M, p, R, nb).transpose(1, 2, 3, 0)
            dst = dest[:, :, s:e]
            nf = L // M  # whole blocks (a partial last one ends the record)
            if nf:
                whole = val4[:, :, :nf]
                if Dm is not None:
                    np.add(whole, _blocked_view(F[o0 : o0 + p], M), out=_blocked_view(dst, M))
                else:
                    np.copyto(_blocked_view(dst, M), whole)
            if nf < nb:
                part = dst[:, :, nf * M :]
                part[...] = val4[:, :, nf, : L - nf * M]
                if Dm is not None:
                    part += F[o0 : o0 + p, :, nf * M :]
        z = zc[:, :, nb].copy()
        s = e
    res: list[list[np.ndarray]] = [[] for _ in outputs]
    for b, _, _, dest, _ in flat:
        res[b].append(dest)
    if not final:
        return res
    if N == 0:
        return res, np.array(np.broadcast_to(x0, (nS, R)), dtype=float)
    Zb = _cached(_BLOCKS, mkey, lambda: scipy.linalg.block_diag(*Zs) if Zs else np.zeros((0, 0)))
    return res, np.ascontiguousarray(_real_product(Zb, last))


def _state_at(
    k: int,
    s: int,
    M: int,
    zc: np.ndarray,
    Tb: np.ndarray,
    V: np.ndarray,
    drives: list[Drive],
    spans: list[tuple[int, int]],
) -> np.ndarray:
    """Modal state at sample ``k`` of a chunk starting at ``s``: the block-start state
    before it (``zc[:, :, b]`` is the state at ``s + b M``), then the remaining steps
    (fewer than ``M``) one by one."""
    b0 = (k - s) // M
    z = np.array(zc[:, :, b0])
    for j in range(s + b0 * M, k):  # step j -> j + 1
        f = np.zeros(z.shape, dtype=z.dtype)
        for d, (c0, c1) in zip(drives, spans, strict=True):
            f = f + V[:, c0:c1] @ d.window(j, 1)[..., 0]
        z = Tb @ z + f
    return z


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
    ``O(n^2 R N)`` flops for the couplings (none in the modal form, used when the
    eigenvector basis has condition number <= 100, which bounds the growth of rounding
    errors by that factor).  The unitary Schur basis keeps rounding errors at the level
    of the naive recursion; repeated or defective eigenvalues need no special treatment.
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
