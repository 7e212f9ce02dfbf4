"""The bank recursion of many runs at once, compiled (C99, SIMD over the runs).

:func:`bank_recursion` is what :meth:`OpenLoopEngine.advance
<geomfdi.simulation.open_loop.OpenLoopEngine.advance>` calls (through
:func:`geomfdi.simulation.compiled_single.run_recursion`, which takes one run to the
library's single-run kernel) for the residual generators of a batch: with two runs or
more (a run axis to vectorise) it runs
:func:`compiled_block_recursion`, a fixed C99 kernel (``compiled_recursion.c``, the
dimensions passed at run time) compiled once per machine with the system's C compiler
(:mod:`geomfdi._cbuild`: cached by hash, built on first use in a process); a single run,
complex blocks, ``GEOMFDI_SIM_BACKEND=numpy`` or a missing compiler (one
:class:`~geomfdi.errors.BackendFallbackWarning` per process) keep the numpy
:func:`~geomfdi.simulation.lifting.block_recursion`.  Both implement

    x[k+1] = A x[k] + W d[k],     y_j[k] = C_j x[k] + D_j direct[k],    k = 0 .. N-1,

``A`` block diagonal; they agree to rounding (the numpy path sums in modal coordinates
on the lifted system, the C path in the blocks' own coordinates, one sample at a
time).  See the user guide, *Performance* (``docs/guide/performance.md``).
"""

from __future__ import annotations

import os
import warnings
from concurrent.futures import wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi._cbuild import load_kernel, typed
from geomfdi._threads import thread_pool, work_threads
from geomfdi.errors import BackendFallbackWarning, GeomFDIError, ShapeError
from geomfdi.simulation.lifting import Drive, block_recursion

__all__ = [
    "BACKENDS",
    "bank_recursion",
    "batch_runs",
    "compiled_block_recursion",
    "sim_backend",
]

BACKENDS = ("c", "numpy")
_ENV = "GEOMFDI_SIM_BACKEND"
_NAME = "gfsim"
_SOURCE = Path(__file__).with_name("compiled_recursion.c")
#: One channel of the kernel: base pointer, run and time strides (elements), scale too.
_CHAN = np.dtype(
    [
        ("p", np.uintp),
        ("rs", np.int64),
        ("ts", np.int64),
        ("sp", np.uintp),
        ("srs", np.int64),
        ("sts", np.int64),
    ]
)


def sim_backend() -> str:
    """The recursion of batch simulations: ``$GEOMFDI_SIM_BACKEND`` (``"c"`` by default).

    Returns
    -------
    str
        ``"c"`` (the compiled kernel for two runs or more, when a C compiler works) or
        ``"numpy"`` (always the numpy recursion).

    Raises
    ------
    GeomFDIError
        The variable holds another value.
    """
    value = os.environ.get(_ENV, "").strip().lower() or "c"
    if value not in BACKENDS:
        raise GeomFDIError(f"{_ENV}: must be one of {BACKENDS}, got {value!r}", argument=_ENV)
    return value


#: Runs per chunk a batch simulation wants with the compiled recursion (its SIMD lanes
#: many times over: the per-chunk work in numpy is then shared by as many runs).
BATCH_RUNS = 32


def batch_runs() -> int:
    """Runs per chunk that :func:`geomfdi.simulate_batch` wants at least (cut in time).

    :data:`BATCH_RUNS` with the compiled recursion (:func:`sim_backend` ``"c"``), else 1
    (the numpy recursion: whole records of one run are as fast).
    """
    return BATCH_RUNS if sim_backend() == "c" else 1


def _bind(dll: Any) -> tuple[Any, Any]:
    """The batch kernel and the one-run kernel of the library, typed."""
    # gfsim_run(nS, R, L, nb, bsize, A, nz, W, dch, fs, fsld, p, ostart, olen, C,
    #           nd, D, ech, ys, ysld, och, X)
    run = typed(dll.gfsim_run, "iiiivvivvviivvvivvvivv")
    # gfsim_single(L, nr, ar, nc, ca, cb, nb, bsize, Apk, nz, V, dch, p, sptr, seg,
    #              coef, ilp, ilc, ys, ysld, och, z)
    single = typed(dll.gfsim_single, "iivivvivvivvivvvivvivv")
    return run, single


def _no_compiler(exc: Exception) -> None:
    warnings.warn(
        f"{exc}; simulations use the numpy recursion", BackendFallbackWarning, stacklevel=5
    )


def _kernels() -> tuple[Any, Any] | None:
    return load_kernel(_NAME, _SOURCE, _bind, on_fail=_no_compiler)


def _library() -> Any:
    """The compiled kernel (built on first use), or ``None`` when no compiler works
    (then a :class:`BackendFallbackWarning`, once per cache folder and compiler)."""
    lib = _kernels()
    return None if lib is None else lib[0]


def single_kernel() -> Any:
    """The one-run kernel of the same library (:mod:`geomfdi.simulation.compiled_single`),
    or ``None`` when no compiler works."""
    lib = _kernels()
    return None if lib is None else lib[1]


def _runs(drives: list[Drive], x0: np.ndarray, direct: Any) -> int:
    sig = direct[0] if direct is not None else []
    return max([d.runs for d in drives] + [a.shape[1] for a in sig] + [x0.shape[1], 1])


def bank_recursion(
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
    **options: Any,
) -> Any:
    """:func:`~geomfdi.simulation.lifting.block_recursion` of a bank, compiled for many runs.

    Parameters and returns as :func:`compiled_block_recursion`; ``options`` go to the
    numpy recursion (its chunking and lifting options, which the compiled kernel does
    not need).  The compiled kernel runs when there are two runs or more, the blocks
    are real, :func:`sim_backend` is ``"c"`` and the kernel builds; otherwise the
    numpy recursion (the same values to rounding).
    """
    if (
        N > 0
        and _runs(drives, x0, direct) >= 2
        and not any(np.iscomplexobj(b) for b in blocks)
        and sim_backend() == "c"
    ):
        lib = _library()
        if lib is not None:
            return _compiled(lib, blocks, W, drives, x0, outputs, N, direct, out, final)
    return block_recursion(
        blocks, W, drives, x0, outputs, N, direct=direct, out=out, final=final, **options
    )


def compiled_block_recursion(
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
) -> Any:
    """Independent subsystems ``x_b[k+1] = A_b x_b[k] + W_b d[k]`` of many runs, in C.

    Parameters
    ----------
    blocks : list of ndarray
        Real transition matrices ``A_b`` (n_b, n_b).
    W : ndarray, (sum n_b, nz)
        Input matrix of the stacked drive signals (columns in the order of ``drives``).
    drives : list of Drive
        The drive signals: step ``k -> k+1`` reads ``arr[..., k + shift]`` (times
        ``scale[..., k]`` when given).
    x0 : ndarray, (sum n_b, R0)
        Initial states (a run axis of length 1 broadcasts).
    outputs : list of list of ndarray
        Per block, output matrices ``C`` (p, n_b).
    N : int
        Number of samples.
    direct : (signals, matrices), optional
        Direct feedthrough: signals (k_i, R_i, N) and per block and output the matrix
        ``D`` (p, sum k_i) or None, added as ``D [signals][k]``.
    out : list of list of ndarray or None, optional
        Arrays (p, R, N) (views with any float64 strides) that receive the outputs.
    final : bool
        Also return the state at sample ``N - 1`` (sum n_b, R).

    Returns
    -------
    list of list of ndarray, each (p, R, N)
        ``C_j x[k] + D_j direct[k]`` for ``k = 0 .. N-1``; with ``final=True`` the pair
        ``(outputs, x[N-1])``.

    Raises
    ------
    GeomFDIError
        No C compiler works (:func:`bank_recursion` falls back instead).

    Notes
    -----
    Drives and feedthrough signals shared by every run (run axis 1) enter as one
    matrix product each per call (``W_s d_s`` over all steps, ``D_s s`` over all
    samples); the kernel adds them and forms the runs' own channels sample by sample,
    in groups of runs as wide as two SIMD registers (8 runs with AVX2), the state in
    the blocks' own coordinates.
    """
    lib = _library()
    if lib is None:
        raise GeomFDIError(
            "backend: no working C compiler for the batch recursion", argument="backend"
        )
    return _compiled(lib, blocks, W, drives, x0, outputs, N, direct, out, final)


def _usable(a: np.ndarray) -> bool:
    """Float64 with strides in whole elements: the kernels read it in place."""
    if a.dtype != np.float64:
        return False
    for st in a.strides:  # a loop: cheaper than all() on a generator for 2-3 strides
        if st % 8:
            return False
    return True


def _f64(a: np.ndarray) -> np.ndarray:
    """``a`` as float64 with strides in whole elements (a copy only when needed)."""
    return a if _usable(a) else np.ascontiguousarray(a, dtype=float)


def _channels(rows: list[tuple[np.ndarray, np.ndarray | None]]) -> np.ndarray:
    """Kernel channels of ``(samples, scale)`` pairs, each (R|1, T) float64 views."""
    ch = np.zeros(max(len(rows), 1), dtype=_CHAN)
    for i, (a, sc) in enumerate(rows):
        ch[i] = (
            a.ctypes.data,
            a.strides[0] // 8 if a.shape[0] > 1 else 0,
            a.strides[1] // 8,
            0 if sc is None else sc.ctypes.data,
            0 if sc is None or sc.shape[0] == 1 else sc.strides[0] // 8,
            0 if sc is None else sc.strides[1] // 8,
        )
    return ch


@dataclass(frozen=True)
class _Layout:
    """What the kernel reads of a bank's matrices (cached: the same for every chunk)."""

    Apk: np.ndarray  # the blocks, packed row-major one after the other
    bs: np.ndarray  # block sizes
    Cpk: np.ndarray  # every output row's coefficients over its nonzero span of states
    ostart: np.ndarray  # first state of each output row's span
    olen: np.ndarray  # length of the span
    Dall: np.ndarray  # (p, nd) feedthrough of every output row
    wcols: np.ndarray  # which columns of W are nonzero (bool)
    dcols: np.ndarray  # which columns of Dall are nonzero (bool)


_LAYOUTS: list[tuple[tuple[Any, ...], int, _Layout]] = []


def _layout(blocks: list[np.ndarray], W: np.ndarray, outputs: Any, dmats: Any, nd: int) -> _Layout:
    """The :class:`_Layout` of these matrices (a hit when the same objects come again:
    a record simulated chunk by chunk; the objects are kept, so their ids stay theirs)."""
    objs = (blocks, W, outputs, dmats)
    for key, n, lay in _LAYOUTS:
        if n == nd and all(a is b for a, b in zip(key, objs, strict=True)):
            return lay
    sizes = [int(b.shape[0]) for b in blocks]
    Cs, ostart, olen, Drows = [], [], [], []
    i0 = 0
    for b, outs in enumerate(outputs):
        for j, Cm in enumerate(outs):
            Dm = dmats[b][j] if b < len(dmats) and j < len(dmats[b]) else None
            for r in range(Cm.shape[0]):
                row = np.asarray(Cm[r], dtype=float)
                nzi = np.flatnonzero(row)
                lo, hi = (int(nzi[0]), int(nzi[-1]) + 1) if nzi.size else (0, 0)
                Cs.append(row[lo:hi])
                ostart.append(i0 + lo)
                olen.append(hi - lo)
                Drows.append(np.zeros(nd) if Dm is None else np.asarray(Dm[r], dtype=float))
        i0 += sizes[b]
    Dall = np.array(Drows, dtype=float).reshape(len(Drows), nd)
    lay = _Layout(
        Apk=np.concatenate([np.asarray(b, dtype=float).ravel() for b in blocks] + [np.zeros(1)]),
        bs=np.array(sizes + [0], dtype=np.int64),
        Cpk=np.concatenate(Cs + [np.zeros(1)]),
        ostart=np.array(ostart + [0], dtype=np.int64),
        olen=np.array(olen + [0], dtype=np.int64),
        Dall=Dall,
        wcols=np.any(W != 0, axis=0),
        dcols=np.any(Dall != 0, axis=0),
    )
    if len(_LAYOUTS) >= 8:
        _LAYOUTS.pop(0)
    _LAYOUTS.append((objs, nd, lay))
    return lay


def _compiled(
    lib: Any,
    blocks: list[np.ndarray],
    W: np.ndarray,
    drives: list[Drive],
    x0: np.ndarray,
    outputs: list[list[np.ndarray]],
    N: int,
    direct: Any,
    out: Any,
    final: bool,
) -> Any:
    nS = int(sum(b.shape[0] for b in blocks))
    R = _runs(drives, x0, direct)
    if x0.shape[1] not in (1, R):
        raise ShapeError(f"x0: {x0.shape[1]} runs, the signals have {R}", argument="x0")
    dsig, dmats = direct if direct is not None else ([], [[None] * len(o) for o in outputs])
    nd_all = int(sum(a.shape[0] for a in dsig))
    nz_all = int(sum(d.arr.shape[0] for d in drives))
    if np.shape(W) != (nS, nz_all):
        raise ShapeError(
            f"W: expected ({nS}, {nz_all}) (states, drive channels), got {np.shape(W)}",
            argument="W",
        )
    lay = _layout(blocks, W, outputs, dmats, nd_all)
    W = np.asarray(W, dtype=float)
    keep: list[np.ndarray] = []  # converted arrays: alive until the kernel returns
    # ---- drives: those shared by every run as one product, the runs' own as channels
    col = np.cumsum([0] + [d.arr.shape[0] for d in drives])
    shared_cols, shared_rows, own, own_cols = [], [], [], []
    for d, c0, c1 in zip(drives, col[:-1], col[1:], strict=True):
        if d.runs == 1:
            if N > 1:
                shared_rows.append(d.window(0, N - 1)[:, 0])
                shared_cols.append(np.arange(c0, c1))
            continue
        arr = _f64(d.arr)
        sc = None if d.scale is None else _f64(d.scale[0])
        keep += [arr] + ([] if sc is None else [sc])
        for i in range(d.arr.shape[0]):
            if lay.wcols[c0 + i]:  # a channel nothing reads is not formed
                own.append((arr[i, :, d.shift :], sc))
                own_cols.append(c0 + i)
    fs = None
    if shared_rows:
        fs = W[:, np.concatenate(shared_cols)] @ np.concatenate(shared_rows)
    Wp = np.ascontiguousarray(W[:, own_cols])
    dch = _channels(own)
    # ---- outputs: every row of every C into its destination
    res: list[list[np.ndarray]] = []
    dests = []
    for b, outs in enumerate(outputs):
        res.append([])
        for j, Cm in enumerate(outs):
            p_j = Cm.shape[0]
            dest = out[b][j] if out is not None and out[b][j] is not None else None
            if dest is None:
                dest = np.empty((p_j, R, N))
            if dest.dtype != np.float64 or dest.shape != (p_j, R, N):
                raise ShapeError(
                    f"out: expected float64 arrays ({p_j}, {R}, {N}), got {dest.shape}",
                    argument="out",
                )
            res[b].append(dest)
            dests += [_dest_view(dest[r]) for r in range(p_j)]
    p = len(dests)
    och = _channels([(dv, None) for dv in dests])
    ys, ech, Dp = None, _channels([]), np.zeros((p, 0))
    if nd_all and lay.dcols.any():
        Dall = lay.Dall
        cst = np.cumsum([0] + [a.shape[0] for a in dsig])
        sh = [i for i, a in enumerate(dsig) if a.shape[1] == 1]
        if sh:
            cols = np.concatenate([np.arange(cst[i], cst[i + 1]) for i in sh])
            ys = Dall[:, cols] @ np.concatenate([dsig[i][:, 0, :N] for i in sh])
        erows, ecols = [], []
        for i, a in enumerate(dsig):
            if a.shape[1] == 1:
                continue
            a = _f64(a)
            keep.append(a)
            for c in range(a.shape[0]):
                if lay.dcols[cst[i] + c]:
                    erows.append((a[c], None))
                    ecols.append(cst[i] + c)
        ech, Dp = _channels(erows), np.ascontiguousarray(Dall[:, ecols])
    X = np.array(np.broadcast_to(x0, (nS, R)), dtype=float, order="C")
    fs = None if fs is None else np.ascontiguousarray(fs)
    ys = None if ys is None else np.ascontiguousarray(ys)
    args = [
        nS,
        R,
        N,
        len(blocks),
        lay.bs.ctypes.data,
        lay.Apk.ctypes.data,
        Wp.shape[1],
        Wp.ctypes.data,  # never NULL: numpy gives empty arrays a buffer
        dch,
        None if fs is None else fs.ctypes.data,
        0 if fs is None else fs.shape[1],
        p,
        lay.ostart.ctypes.data,
        lay.olen.ctypes.data,
        lay.Cpk.ctypes.data,
        Dp.shape[1],
        Dp.ctypes.data,
        ech,
        None if ys is None else ys.ctypes.data,
        0 if ys is None else ys.shape[1],
        och,
        X,
    ]
    status = _call_parts(lib, args, R, N * nS)
    del keep
    if status != 0:
        raise MemoryError("the batch recursion could not allocate its work arrays")
    return (res, X) if final else res


#: Runs per SIMD group of the kernel (``GFSIM_G``: 16 with AVX-512, 8 with AVX): the
#: fewest runs worth a thread of their own in :func:`_call_parts`.
_GROUP = 16
#: Fewest state-samples (runs x samples x states) per thread in :func:`_call_parts`: a
#: call of a few milliseconds gains little from a second thread (measured on 2 cores:
#: 1.1-1.3x at 2e6 state-samples per call, 1.5-1.8x at 2e7).
_MIN_PART_WORK = 2**22
_CHANNEL_ARGS = (8, 17, 20)  # positions of the channel tables in the kernel's arguments


def _call_parts(lib: Any, args: list[Any], R: int, work_per_run: int) -> int:
    """Run the kernel on ``args`` (channel tables and the states ``X`` as arrays), the
    runs split into contiguous parts of about equal size (whole groups of 8 runs), one
    per work thread (:func:`geomfdi._threads.work_threads`; ``ctypes`` releases the
    interpreter lock for the call).  A part sees its runs only: the channels' base
    pointers move to its first run (a run stride of 0, a signal shared by the runs,
    stays), its states are a contiguous copy written back after.  The runs are
    independent and each is computed by the same instructions in either case, so the
    results do not depend on the split.
    """
    k = min(work_threads(), -(-R // _GROUP), max(1, R * work_per_run // _MIN_PART_WORK))
    X = args[-1]
    if k <= 1:
        return lib(*[a.ctypes.data if isinstance(a, np.ndarray) else a for a in args])
    # parts of about R / k runs, cut at whole groups of the narrower SIMD width (8)
    edges = [0] + [round(i * R / (k * 8)) * 8 for i in range(1, k)] + [R]
    calls = []
    for r0, r1 in zip(edges[:-1], edges[1:], strict=True):
        if r1 <= r0:
            continue
        part = list(args)
        part[1] = r1 - r0
        for pos in _CHANNEL_ARGS:
            ch = args[pos].copy()
            ch["p"] += (r0 * 8 * ch["rs"]).astype(np.uintp)
            moved = ch["sp"] != 0
            ch["sp"][moved] += (r0 * 8 * ch["srs"][moved]).astype(np.uintp)
            part[pos] = ch
        part[-1] = np.ascontiguousarray(X[:, r0:r1])
        calls.append((r0, r1, part))

    def run(part: list[Any]) -> int:
        return int(lib(*[a.ctypes.data if isinstance(a, np.ndarray) else a for a in part]))

    futures = [thread_pool(k).submit(run, part) for _, _, part in calls]
    wait(futures)
    status = 0
    for (r0, r1, part), f in zip(calls, futures, strict=True):
        status = status or f.result()
        X[:, r0:r1] = part[-1]
    return status


def _dest_view(dv: np.ndarray) -> np.ndarray:
    """A destination row (R, N) checked for the kernel's element strides."""
    if not (_usable(dv) and dv.flags.writeable):
        raise ShapeError("out: destinations must be writeable float64 arrays", argument="out")
    return dv
