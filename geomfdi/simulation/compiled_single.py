"""The recursion of one run, compiled: modal coordinates, vectorised over the states.

:func:`single_recursion` is what a simulation of one run (:func:`geomfdi.simulate`)
uses for its plant and for its bank of generators, in place of the lifted numpy
recursion of :func:`~geomfdi.simulation.lifting.block_recursion` (which
:func:`run_recursion` keeps for ``GEOMFDI_SIM_BACKEND=numpy``, a missing C compiler and
batches of runs).  Both implement

    x[k+1] = A x[k] + W d[k],     y_j[k] = C_j x[k] + D_j direct[k],    k = 0 .. N-1,

``A`` block diagonal, and agree to rounding.

How it is computed: each block of ``A`` goes into its real modal form when its
eigenvector basis is well conditioned (condition number <= 100, the limit of
:func:`~geomfdi.simulation.recursion.modal_form`) and that is cheaper per sample than
the block itself (a diagonal entry per real mode, a 2 x 2 rotation per complex pair,
the outputs then reading every mode); otherwise the block is kept in its own
coordinates.  The compiled kernel (``gfsim_single`` of ``compiled_recursion.c``) then
runs sample by sample: the outputs of the sample (each one dot product per part of the
state layout), the forcing ``V d[k]`` (one vectorised update per drive channel) and the
update of the modes; the feedthrough ``D direct`` is formed beforehand by one matrix
product per signal.  A drive read at the start and at the end of each step (the
first-order hold, ``W0 d[k] + W1 d[k+1]``) is folded into one channel by the exact
change of state ``z~[k] = z[k] - V1 d[k]``, ``z~[k+1] = T z~[k] + (V0 + T V1) d[k]``,
``C z[k] = C z~[k] + C V1 d[k]`` (``V = Z^-1 W`` in the modal coordinates): half the
forcing work.  A bank of four or more scalar residuals whose generators have real modes
only (the usual case) interleaves the modes, mode ``j`` of generator ``b`` at
``j P + b`` (``P``: the generators, rounded up to whole vectors of four), so that the
residuals of four generators are one vector sum over ``j``.  See the user guide,
*Performance* (``docs/guide/performance.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.linalg.blas import dgemm as _dgemm

from geomfdi.errors import ShapeError
from geomfdi.simulation.compiled_recursion import (
    _CHAN,
    _f64,
    _usable,
    bank_recursion,
    sim_backend,
    single_kernel,
)
from geomfdi.simulation.lifting import Drive, _digest, block_recursion
from geomfdi.simulation.recursion import _MODAL_COND
from geomfdi.simulation.workspace import thread_workspace

__all__ = ["run_recursion", "single_recursion"]


def run_recursion(
    blocks: list[np.ndarray],
    W: np.ndarray,
    drives: list[Drive],
    x0: np.ndarray,
    outputs: list[list[np.ndarray]],
    N: int,
    *,
    direct: tuple[list[np.ndarray], list[list[np.ndarray | None]]] | None = None,
    out: list[list[np.ndarray | None]] | None = None,
    final: bool = False,
    key: Any = None,
    batch: bool = True,
) -> Any:
    """:func:`single_recursion` for one run when the compiled kernel is available, else
    :func:`~geomfdi.simulation.compiled_recursion.bank_recursion` (``batch``: the
    compiled kernel of many runs) or the numpy
    :func:`~geomfdi.simulation.lifting.block_recursion`.

    Parameters and returns as :func:`single_recursion`.
    """
    kw = dict(direct=direct, out=out, final=final, key=key)
    if N > 0 and _one_run(drives, x0, direct) and sim_backend() == "c":
        kernel = single_kernel()
        if kernel is not None:
            return _single(kernel, blocks, W, drives, x0, outputs, N, **kw)
    if batch:
        return bank_recursion(blocks, W, drives, x0, outputs, N, **kw)
    return block_recursion(blocks, W, drives, x0, outputs, N, **kw)


def single_recursion(
    blocks: list[np.ndarray],
    W: np.ndarray,
    drives: list[Drive],
    x0: np.ndarray,
    outputs: list[list[np.ndarray]],
    N: int,
    *,
    direct: tuple[list[np.ndarray], list[list[np.ndarray | None]]] | None = None,
    out: list[list[np.ndarray | None]] | None = None,
    final: bool = False,
    key: Any = None,
) -> Any:
    """Independent subsystems ``x_b[k+1] = A_b x_b[k] + W_b d[k]`` of one run, in C.

    Parameters
    ----------
    blocks : list of ndarray
        Real transition matrices ``A_b`` (n_b, n_b).
    W : ndarray, (sum n_b, nz)
        Input matrix of the stacked drive signals (columns in the order of ``drives``).
    drives : list of Drive
        The drive signals of one run (run axis 1): step ``k -> k+1`` reads
        ``arr[..., k + shift]`` (times ``scale[..., k]`` when given).
    x0 : ndarray, (sum n_b, 1)
        Initial state.
    outputs : list of list of ndarray
        Per block, output matrices ``C`` (p, n_b).
    N : int
        Number of samples.
    direct : (signals, matrices), optional
        Direct feedthrough: signals (k_i, 1, N) and per block and output the matrix
        ``D`` (p, sum k_i) or None, added as ``D [signals][k]``.
    out : list of list of ndarray or None, optional
        Arrays (p, 1, N) (views with any float64 strides) that receive the outputs.
    final : bool
        Also return the state at sample ``N - 1`` (sum n_b, 1).
    key : hashable, optional
        Identifies the matrices (``blocks``, ``W``, ``outputs``) for the cache of the
        set-up; by default a digest of their values.

    Returns
    -------
    list of list of ndarray, each (p, 1, N)
        ``C_j x[k] + D_j direct[k]`` for ``k = 0 .. N-1``; with ``final=True`` the pair
        ``(outputs, x[N-1])``.

    Raises
    ------
    GeomFDIError
        More than one run, or no C compiler works (:func:`run_recursion` falls back
        instead).

    Notes
    -----
    See the module docstring: real modal form per block (or the block itself), the
    first-order hold folded into one channel, the feedthrough by matrix products.
    """
    from geomfdi.errors import GeomFDIError

    if not _one_run(drives, x0, direct):
        raise GeomFDIError("drives: single_recursion simulates one run", argument="drives")
    kernel = single_kernel()
    if kernel is None:
        raise GeomFDIError(
            "backend: no working C compiler for the single-run recursion", argument="backend"
        )
    return _single(kernel, blocks, W, drives, x0, outputs, N, direct=direct, out=out,
                   final=final, key=key)  # fmt: skip


def _one_run(drives: list[Drive], x0: np.ndarray, direct: Any) -> bool:
    sig = direct[0] if direct is not None else []
    return (
        all(d.runs == 1 for d in drives)
        and x0.shape[1] == 1
        and all(a.shape[1] == 1 for a in sig)
        and not any(np.iscomplexobj(d.arr) for d in drives)
    )


# ------------------------------------------------------------------ set-up
@dataclass(frozen=True)
class _Setup:
    """What the kernel reads of the matrices (cached: they depend on the models only)."""

    ar: np.ndarray  # real modes
    ca: np.ndarray  # complex pairs: real and imaginary parts of the eigenvalue
    cb: np.ndarray
    bs: np.ndarray  # sizes of the dense blocks (then a 0)
    Apk: np.ndarray  # the dense blocks, column-major one after the other
    Tin: np.ndarray  # layout coordinates from the original ones (nL, nS)
    Tout: np.ndarray  # and back (nS, nL)
    Vt: np.ndarray  # (channels, nL): forcing of every kernel channel
    chans: tuple[tuple[int, int, int], ...]  # (drive, row, shift) of every kernel channel
    chan_index: tuple[np.ndarray, ...]  # the same as three index arrays
    out_rows: tuple[tuple[int, ...], ...]  # rows of every output of every block
    folds: tuple[tuple[int, np.ndarray, np.ndarray], ...]  # (drive, V1 (nL, k), C V1)
    sptr: np.ndarray  # (p + 1,) first segment of every output row
    seg: np.ndarray  # start and length of every segment
    coef: np.ndarray  # packed coefficients
    ilp: int  # interleaved modes: blocks per row of modes (0: not; -1: outputs = state)
    ilc: np.ndarray  # their output coefficients, in the modes' order

    def __post_init__(self) -> None:
        # the kernel's arguments that depend on the matrices only (the arrays live as
        # long as the set-up)
        head = (
            self.ar.size, self.ar.ctypes.data, self.ca.size, self.ca.ctypes.data,
            self.cb.ctypes.data, self.bs.size - 1, self.bs.ctypes.data, self.Apk.ctypes.data,
            len(self.chans), self.Vt.ctypes.data,
        )  # fmt: skip
        tail = (
            self.sptr.ctypes.data, self.seg.ctypes.data, self.coef.ctypes.data, self.ilp,
            self.ilc.ctypes.data,
        )  # fmt: skip
        object.__setattr__(self, "args", (head, tail))


_SETUPS: dict[Any, _Setup] = {}
_SETUP_ENTRIES = 32
_INTERLEAVE_MIN = 4  # fewest scalar-residual blocks whose modes are interleaved


def _block_form(A: np.ndarray, out_cost: int, own_cost: int) -> Any:
    """``(lam_real, lam_pairs, Z)`` of the real modal form ``A = Z T Z^-1`` (columns: real
    modes, then the real parts of the pairs, then their imaginary parts), or ``None``
    when the block stays in its own coordinates (ill-conditioned basis, or dearer)."""
    n = A.shape[0]
    if n == 0:
        return None
    lam, V = np.linalg.eig(A)
    if not np.all(np.isfinite(V)):
        return None
    real = lam.imag == 0
    pos = lam.imag > 0
    if np.count_nonzero(pos) != np.count_nonzero(lam.imag < 0):
        return None
    nr, nc = int(np.count_nonzero(real)), int(np.count_nonzero(pos))
    if nr + 4 * nc + out_cost >= own_cost:
        return None
    Z = np.hstack([V[:, real].real, V[:, pos].real, V[:, pos].imag])
    if np.linalg.cond(Z) > _MODAL_COND:
        return None
    return lam[real].real, lam[pos], Z


def _setup(
    blocks: list[np.ndarray],
    W: np.ndarray,
    outputs: list[list[np.ndarray]],
    layout: tuple[tuple[int, int, bool, int], ...],
    has_direct: bool,
) -> _Setup:
    sizes = [int(b.shape[0]) for b in blocks]
    offs = np.cumsum([0] + sizes)
    nS = int(offs[-1])
    forms = []
    for A, outs, n in zip(blocks, outputs, sizes, strict=True):
        p_b = sum(C.shape[0] for C in outs)
        own = n * n + sum(_span_len(row) for C in outs for row in C)
        forms.append(_block_form(np.asarray(A, dtype=float), p_b * n, own))
    nr = sum(f[0].size for f in forms if f is not None)
    nc = sum(f[1].size for f in forms if f is not None)
    # a bank of scalar residuals with real modes only: the modes interleaved, mode j of
    # block b at j P + b (P: the blocks, rounded up to whole vectors), so that the
    # outputs of all blocks are one vector sum over j (no sum across a vector)
    P = len(blocks)
    inter = (
        P >= _INTERLEAVE_MIN
        and all(f is not None and f[1].size == 0 for f in forms)
        and all(len(outs) == 1 and outs[0].shape[0] == 1 for outs in outputs)
    )
    Pp = -(-P // 4) * 4 if inter else 0
    if inter:
        nr = max(sizes) * Pp
    nL = nr + 2 * nc + sum(s for s, f in zip(sizes, forms, strict=True) if f is None)
    Tout = np.zeros((nS, nL))
    ar, ca, cb, dense = [], [], [], []
    idx: list[list[np.ndarray]] = []  # per block: layout indices of each part
    r0 = c0 = 0
    d0 = nr + 2 * nc
    ar_ = np.zeros(nr)
    for b, (A, f) in enumerate(zip(blocks, forms, strict=True)):
        sl = slice(offs[b], offs[b + 1])
        if inter:
            lr, _, Z = f
            ir = np.arange(lr.size) * Pp + b
            Tout[sl, ir] = Z
            ar_[ir] = lr
            idx.append([ir, ir[:0], ir[:0], ir[:0]])
            continue
        if f is None:
            ii = np.arange(d0, d0 + sizes[b])
            Tout[sl, ii] = np.eye(sizes[b])
            dense.append(np.asarray(A, dtype=float))
            idx.append([ii[:0], ii[:0], ii[:0], ii])
            d0 += sizes[b]
            continue
        lr, lc, Z = f
        ir = np.arange(r0, r0 + lr.size)
        ic = np.arange(c0, c0 + lc.size)
        cols = np.concatenate([ir, nr + ic, nr + nc + ic])
        Tout[sl, cols] = Z
        ar.append(lr)
        ca.append(lc.real)
        cb.append(lc.imag)
        idx.append([ir, nr + ic, nr + nc + ic, ir[:0]])
        r0 += lr.size
        c0 += lc.size
    # the inverse, block by block (each block's own basis)
    Tin = np.zeros((nL, nS))
    for b in range(len(blocks)):
        sl = slice(offs[b], offs[b + 1])
        ii = np.concatenate(idx[b])
        Tin[ii, sl] = np.linalg.inv(Tout[sl, ii])
    if not inter:
        ar_ = np.concatenate(ar) if ar else np.zeros(0)
    ca_, cb_ = (np.concatenate(ca), np.concatenate(cb)) if ca else (np.zeros(0), np.zeros(0))
    # the transition in layout coordinates (for the folded first-order hold)
    Tl = np.zeros((nL, nL))
    Tl[np.arange(nr), np.arange(nr)] = ar_
    re, im = nr + np.arange(nc), nr + nc + np.arange(nc)
    Tl[re, re], Tl[re, im], Tl[im, re], Tl[im, im] = ca_, cb_, -cb_, ca_
    i0 = nr + 2 * nc
    for A in dense:
        n = A.shape[0]
        Tl[i0 : i0 + n, i0 : i0 + n] = A
        i0 += n
    V = Tin @ np.asarray(W, dtype=float)
    # output rows in layout coordinates
    Cz_rows, segs, coef, sptr = [], [], [], [0]
    for b, outs in enumerate(outputs):
        sl = slice(offs[b], offs[b + 1])
        for C in outs:
            for row in np.asarray(C, dtype=float):
                full = np.zeros(nL)
                full[np.concatenate(idx[b])] = row @ Tout[sl, np.concatenate(idx[b])]
                Cz_rows.append(full)
                for part in idx[b]:
                    vals = full[part]
                    nzi = np.flatnonzero(vals)
                    if nzi.size:  # one segment per part read, its zero ends left out
                        lo, hi = int(nzi[0]), int(nzi[-1]) + 1
                        segs += [int(part[0]) + lo, hi - lo]
                        coef.append(vals[lo:hi])
                sptr.append(len(segs) // 2)
    Cz = np.array(Cz_rows).reshape(len(Cz_rows), nL)
    if not inter and Cz.shape == (nL, nL) and np.array_equal(Cz, np.eye(nL)):
        Pp = -1  # the outputs are the state itself (a plant's): copied, not summed
    ilc = np.zeros(nr if inter else 0)
    if inter:  # the coefficient of mode j of block b at j P + b, like the modes
        ilc = Cz.sum(axis=0)[:nr].copy()
    # drive channels: a drive read at shifts 0 and 1 of one array is folded (module doc)
    col = np.cumsum([0] + [k for k, _, _, _ in layout])
    groups: dict[int, dict[int, int]] = {}
    for i, (_, shift, scaled, g) in enumerate(layout):
        if not scaled:
            groups.setdefault(g, {})[shift] = i
    # folding saves nL k multiply-adds per sample; it adds a feedthrough of every output
    # row (free when there is one already)
    p_tot = Cz.shape[0]
    fold = {
        g: s
        for g, s in groups.items()
        if sorted(s) == [0, 1]
        and _count(layout, g) == 2
        and (has_direct or nL * layout[s[0]][0] > 4 * p_tot)
    }
    Vcols, chans, folds = [], [], []
    skip = set()
    for s in fold.values():
        i0, i1 = s[0], s[1]
        V0 = V[:, col[i0] : col[i0 + 1]]
        V1 = V[:, col[i1] : col[i1 + 1]]
        Veff = V0 + Tl @ V1
        for r in range(layout[i0][0]):
            if np.any(Veff[:, r]):
                Vcols.append(Veff[:, r])
                chans.append((i0, r, 0))
        folds.append((i0, np.ascontiguousarray(V1), np.ascontiguousarray(Cz @ V1)))
        skip |= {i0, i1}
    for i, (k, shift, _, _) in enumerate(layout):
        if i in skip:
            continue
        for r in range(k):
            if np.any(V[:, col[i] + r]):
                Vcols.append(V[:, col[i] + r])
                chans.append((i, r, shift))
    Vt = np.array(Vcols).reshape(len(Vcols), nL)
    return _Setup(
        ar=np.ascontiguousarray(ar_),
        ca=np.ascontiguousarray(ca_),
        cb=np.ascontiguousarray(cb_),
        bs=np.array([A.shape[0] for A in dense] + [0], dtype=np.int64),
        Apk=np.concatenate([A.T.ravel() for A in dense] + [np.zeros(1)]),
        Tin=Tin,
        Tout=Tout,
        Vt=np.ascontiguousarray(Vt),
        chans=tuple(chans),
        chan_index=tuple(np.array(v, dtype=np.int64).reshape(-1) for v in zip(*chans, strict=True))
        if chans
        else (),
        out_rows=tuple(tuple(C.shape[0] for C in outs) for outs in outputs),
        folds=tuple(folds),
        sptr=np.array(sptr, dtype=np.int64),
        seg=np.array(segs + [0, 0], dtype=np.int64),
        coef=np.concatenate(coef + [np.zeros(1)]),
        ilp=Pp,
        ilc=np.concatenate([ilc, np.zeros(1)]),
    )


def _count(layout: tuple[tuple[int, int, bool, int], ...], g: int) -> int:
    return sum(1 for _, _, _, gi in layout if gi == g)


def _span_len(row: np.ndarray) -> int:
    nzi = np.flatnonzero(row)
    return int(nzi[-1] - nzi[0] + 1) if nzi.size else 0


def _layout(drives: list[Drive]) -> tuple[tuple[int, int, bool, int], ...]:
    """``(rows, shift, scaled, array group)`` of every drive: the set-up's view of them."""
    first: dict[int, int] = {}
    out = []
    for i, d in enumerate(drives):
        g = first.setdefault(id(d.arr), i) if d.scale is None else -1 - i
        out.append((int(d.arr.shape[0]), int(d.shift), d.scale is not None, g))
    return tuple(out)


# ------------------------------------------------------------------ the call
def _address(a: np.ndarray) -> int:
    return a.__array_interface__["data"][0]


def _single(
    kernel: Any,
    blocks: list[np.ndarray],
    W: np.ndarray,
    drives: list[Drive],
    x0: np.ndarray,
    outputs: list[list[np.ndarray]],
    N: int,
    *,
    direct: Any,
    out: Any,
    final: bool,
    key: Any,
) -> Any:
    layout = _layout(drives)
    mkey = (
        ("key", key)
        if key is not None
        else _digest([*blocks, W, *(C for outs in outputs for C in outs)])
    )
    skey = (mkey, layout, direct is not None)
    st = _SETUPS.get(skey)
    if st is None:
        st = _setup(blocks, W, outputs, layout, direct is not None)
        if len(_SETUPS) >= _SETUP_ENTRIES:
            _SETUPS.clear()
        _SETUPS[skey] = st
    # destinations: one kernel channel per output row
    res: list[list[np.ndarray]] = []
    optr, ots = [], []
    views: list[tuple[np.ndarray, int]] = []  # every output (p_j, 1, N) and its address
    for b, outs in enumerate(outputs):
        res.append([])
        for j, Cm in enumerate(outs):
            dest = out[b][j] if out is not None else None
            if dest is None:
                dest = np.empty((Cm.shape[0], 1, N))
            elif not (_usable(dest) and dest.flags.writeable) or dest.shape != (Cm.shape[0], 1, N):
                raise ShapeError(
                    f"out: expected writeable float64 arrays ({Cm.shape[0]}, 1, {N})",
                    argument="out",
                )
            res[b].append(dest)
            base = dest.ctypes.data
            s0, _, s2 = dest.strides
            views.append((dest, base))
            if Cm.shape[0] == 1:
                optr.append(base)
                ots.append(s2 // 8)
            else:
                optr += [base + r * s0 for r in range(Cm.shape[0])]
                ots += [s2 // 8] * Cm.shape[0]
    x0v = np.asarray(x0, dtype=float)[:, 0]
    if N == 0:
        return (res, np.array(x0v[:, None])) if final else res
    arrs = [_f64(d.arr) for d in drives]
    z = st.Tin @ x0v
    for i, V1, _ in st.folds:
        z -= V1 @ arrs[i][:, 0, 0]
    z = np.ascontiguousarray(z)
    # drive channels: row r of drive i from sample `shift` (its scale, when given)
    where = [(_address(a), a.strides[0], a.strides[2]) for a in arrs]
    scales = [None if d.scale is None else np.asarray(d.scale[0], dtype=float) for d in drives]
    rows_ch = []
    for i, r, shift in st.chans:
        a0, s0, s2 = where[i]
        sc = scales[i]
        if sc is None:
            rows_ch.append((a0 + r * s0 + shift * s2, 0, s2 // 8, 0, 0, 0))
        else:
            sc = scales[i] = _f64(sc)
            rows_ch.append(
                (a0 + r * s0 + shift * s2, 0, s2 // 8, _address(sc), 0, sc.strides[1] // 8)
            )
    dch = np.array(rows_ch or [(0, 0, 0, 0, 0, 0)], dtype=_CHAN)
    och = np.array([(a, 0, ts, 0, 0, 0) for a, ts in zip(optr, ots, strict=True)] or [(0,) * 6],
                   dtype=_CHAN)  # fmt: skip
    head, tail = st.args  # type: ignore[attr-defined]
    status = kernel(
        N, *head, dch.ctypes.data, len(optr), *tail, None, 0, och.ctypes.data, z.ctypes.data
    )
    del scales  # alive until the kernel has returned
    if status != 0:
        raise MemoryError("the single-run recursion could not allocate its work arrays")
    # then the feedthrough of every output row: D direct, and C V1 d of the folded drives
    _add_feedthrough(direct, st, drives, arrs, N, _groups(views))
    if not final:
        return res
    for i, V1, _ in st.folds:
        z += V1 @ drives[i].arr[:, 0, N - 1]
    return res, (st.Tout @ z)[:, None]


_DALL: dict[int, tuple[_Setup, Any, Any, list[tuple[np.ndarray, bool]]]] = {}


def _groups(views: list[tuple[np.ndarray, int]]) -> list[tuple[int, np.ndarray]]:
    """The outputs ``(p_j, 1, N)`` (with their addresses) merged where they are
    consecutive rows of one array: ``(first output row, (p, N) view)`` (one product per
    group and signal)."""
    spans: list[list[int]] = []  # [first output, rows, address past the last row]
    for k, (v, a) in enumerate(views):
        p_j = v.shape[0]
        if spans:
            g = spans[-1]
            v0 = views[g[0]][0]
            if v0.strides == v.strides and a == g[2]:
                g[1] += p_j
                g[2] += p_j * v.strides[0]
                continue
        spans.append([k, p_j, a + p_j * v.strides[0]])
    out, row = [], 0
    for k, rows, _ in spans:
        v = views[k][0]
        if rows == v.shape[0]:
            view = v[:, 0, :]
        else:
            st = (v.strides[0], v.strides[2])
            view = np.lib.stride_tricks.as_strided(v, (rows, v.shape[2]), st, writeable=True)
        out.append((row, view))
        row += rows
    return out


def _accumulate(D: np.ndarray, S: np.ndarray, Y: np.ndarray) -> None:
    """``Y += D S`` in place: one BLAS product with ``beta = 1`` on row-major ``Y`` and
    ``S`` (no temporary of ``Y``'s size, whose fresh pages cost more than the product),
    else with numpy."""
    if (
        Y.shape[1] > 0
        and Y.strides == (8 * Y.shape[1], 8)
        and S.strides == (8 * S.shape[1], 8)
        and Y.flags.writeable
    ):
        r = _dgemm(1.0, S.T, D.T, beta=1.0, c=Y.T, overwrite_c=1)
        if not np.may_share_memory(r, Y):  # the wrapper worked on a copy
            Y[...] = r.T
        return
    # rows of a longer record (a time chunk): the product in a work array of the thread
    # (kept: a fresh temporary of the chunk's size would fault its pages in every call)
    tmp = thread_workspace("recursion").get("feedthrough", Y.shape)
    np.matmul(D, S, out=tmp)
    Y += tmp


def _add_feedthrough(
    direct: Any,
    st: _Setup,
    drives: list[Drive],
    arrs: list[np.ndarray],
    N: int,
    groups: list[tuple[int, np.ndarray]],
) -> None:
    """Add ``D direct`` of every output row and ``C V1 d`` of the folded drives to the
    outputs, one product per signal and group of outputs (a folded drive that is also a
    feedthrough signal adds its ``C V1`` to that signal's matrix)."""
    sigs: list[np.ndarray] = []
    dmats: Any = None
    if direct is not None:
        sigs, dmats = list(direct[0]), direct[1]
    merged = {}
    for f, (i, _, _) in enumerate(st.folds):
        j = next((j for j, a in enumerate(sigs) if a is drives[i].arr), None)
        if j is not None:
            merged[f] = j
    parts = _stacked(st, dmats, [a.shape[0] for a in sigs], merged)
    for f, (i, _, _) in enumerate(st.folds):
        if f not in merged:
            sigs.append(arrs[i])
    for a, (Di, used) in zip(sigs, parts, strict=True):
        if used:
            S = a[:, 0, :N]
            if S.dtype != np.float64 or S.strides != (8 * N, 8):
                S = np.ascontiguousarray(S, dtype=float)
            for r0, Y in groups:
                _accumulate(Di[r0 : r0 + Y.shape[0]], S, Y)


def _stacked(
    st: _Setup, dmats: Any, widths: list[int], merged: dict[int, int]
) -> list[tuple[np.ndarray, bool]]:
    """The feedthrough matrices of every output row, one per signal: ``(D_i, nonzero)``
    for the signals of ``dmats`` (``C V1`` of the folds ``merged`` into them added),
    then ``C V1`` of the other folds (kept while the same matrices come again)."""
    mkey = (tuple(widths), tuple(sorted(merged.items())))
    hit = _DALL.get(id(st))  # the entry holds st and dmats: their ids stay theirs
    if hit is not None and hit[0] is st and hit[1] is dmats and hit[2] == mkey:
        return hit[3]
    nd = int(sum(widths))
    p = int(sum(sum(ps) for ps in st.out_rows))
    rows = [
        np.zeros((p_j, nd)) if Dm is None else np.asarray(Dm, dtype=float)
        for ms, ps in zip(dmats or [], st.out_rows, strict=False)
        for Dm, p_j in zip(ms, ps, strict=True)
    ]
    Dall = np.vstack(rows) if rows else np.zeros((p, nd))
    parts, c0 = [], 0
    for w in widths:
        parts.append(np.array(Dall[:, c0 : c0 + w]))
        c0 += w
    for f, (_, _, CV1) in enumerate(st.folds):
        if f in merged:
            parts[merged[f]] = parts[merged[f]] + CV1
        else:
            parts.append(CV1)
    out = [(np.ascontiguousarray(D), bool(D.size and np.any(D))) for D in parts]
    if len(_DALL) >= _SETUP_ENTRIES:
        _DALL.clear()
    _DALL[id(st)] = (st, dmats, mkey, out)
    return out
