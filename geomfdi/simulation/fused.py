"""The runs of a Monte-Carlo block in one compiled pass: :func:`fused_plan`, :func:`fused_runs`.

A campaign's block (many runs of one plant model, one shared initial state and input,
each run with its own noise seed and sensor-fault list) spends its time in per-run
passes over arrays of ``runs x samples``: the noisy readings, the faulty readings, the
drive channels of the sensors, the bank's recursion, the test's statistic.  This module
does them in one pass of C (``compiled_fused.c``, built once per machine like the batch
recursion of :mod:`geomfdi.simulation.compiled_recursion`), runs in SIMD lanes, sample
after sample, nothing but the statistic written out:

* what every run shares is computed once per plan with the code of
  :class:`~geomfdi.simulation.open_loop.OpenLoopEngine` (the same set-up): the plant's
  state ``x``, the healthy readings ``y0c``, the inputs ``u``, the bank's shared forcing
  (inputs, disturbances, and the plant state when the generators are not decoupled) and
  shared feedthrough;
* per run and sample: ``y0n = y0c + Lv z`` (``z`` as drawn by the run's noise stream of
  either generator, :meth:`geomfdi.Noise.source`; a correlated ``Lv`` applied as the
  batch applies it), ``y = eta y0n + lam`` (the sensor
  faults, Hou, Wen & Chen 2011, eq. 3-5, with ``eta`` piecewise constant per run and
  ``lam`` too, or sampled where a bias is a callable),
  the drive channels of the first-order (or zero-order) hold over each interval, the
  generators' states and outputs (vector residuals: their norm) with the operations of
  the batch recursion in the same order, and, for a :class:`~geomfdi.ChiSquareTest`, the
  windowed sum of squares (the sequential running sum of ``numpy.cumsum``: the
  statistic of the residuals, bit for bit).

The residuals equal those of :func:`geomfdi.simulate_batch`'s chunked engine to
rounding (and, with the same time chunks, bit for bit); :func:`geomfdi.simulate_batch`
itself runs its batches through this pass when it covers them (``store`` other than
``"all"``), judging each window of a few runs while it is in the cache (``sink`` of
:func:`fused_runs`).  What the fused pass does not cover is decided once
per plan (:func:`fused_plan` returns ``None`` with the reason): a nonlinear plant,
output feedback or actuator faults inside the loop, process noise or random noise
inputs, per-run initial states or disturbances, additive (input) faults, sensor faults
whose gain is not a number (a callable gain) or that hold their reading (a stuck sensor
without a value), ``GEOMFDI_SIM_BACKEND=numpy`` or no working C compiler (one
:class:`~geomfdi.errors.BackendFallbackWarning`).  See the user guide, *Performance*
(``docs/guide/performance.md``).
"""

from __future__ import annotations

import ctypes
import threading
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi._cbuild import load_kernel, typed
from geomfdi._threads import limit_blas_threads, thread_pool, work_threads
from geomfdi.errors import BackendFallbackWarning
from geomfdi.simulation.compiled_recursion import _layout, sim_backend
from geomfdi.simulation.compiled_single import run_recursion
from geomfdi.simulation.context import prepare, state_vector, to_balanced
from geomfdi.simulation.draw_cache import DrawCache
from geomfdi.simulation.lifting import Drive
from geomfdi.simulation.workspace import Workspace

__all__ = ["FusedPlan", "evaluation_struct", "fused_plan", "fused_runs", "isolate_codes"]

_SOURCE = Path(__file__).with_name("compiled_fused.c")
_POOLS = threading.local()


class _Evaluation(ctypes.Structure):
    """The kernel's ``gff_eval``: what a block's statistic is judged by."""

    _fields_ = [
        (name, ctypes.c_int64 if name in ("kal0", "kend") else ctypes.c_void_p)
        for name in (
            "thr", "lim", "kal0", "kend", "codes", "kpre0", "kon", "kpost1", "spre",
            "spost", "fhit", "bad",
        )
    ]  # fmt: skip


def evaluation_struct(arrays: dict[str, Any]) -> _Evaluation:
    """The kernel's evaluation arguments from ``arrays`` (numpy arrays of the kernel's
    dtypes, kept alive by the caller; ``kal0`` and ``kend`` integers): see
    ``gff_eval`` in ``compiled_fused.c``."""
    ev = _Evaluation()
    for name, _ in _Evaluation._fields_:
        v = arrays[name]
        setattr(ev, name, int(v) if name in ("kal0", "kend") else v.ctypes.data)
    return ev


#: Samples per window of a fused pass (the noise of a window is taken at once).
WINDOW = 2**16
#: Fewest run-samples per thread (a shorter pass gains nothing from a second thread).
_MIN_PART_WORK = 2**18
#: Runs whose noise is drawn and passed through the kernel at a time, about (a multiple
#: of the kernel's group of lanes; their draws stay in the cache, the next runs draw
#: into the same buffers).
_SUB = 16
#: Samples per window handed to a ``sink`` of :func:`fused_runs` (the rows of the
#: window's runs, 16 x rows x SINK_WINDOW doubles, stay in the cache for the sink).
SINK_WINDOW = 2**12
#: More compiler flags of the kernel (tests: ``-DGFSIM_NV=3`` three vectors per group of
#: runs, ``-DGFF_NO_VECTOR_EXT`` the plain loops of compilers without vector types).
_FLAGS: tuple[str, ...] = ()
#: Build the kernel for each plan's dimensions (loops of known length; a library per
#: layout, cached like the others); ``False``: one kernel reading them at run time.
_SPECIALISE = True


def _bind(dll: Any) -> tuple[Any, Any, int]:
    """The run and isolate functions of the library, typed, and its group of lanes."""
    run = typed(dll.gffused_run, "iiiiiii" + "vvvvvvvvv" + "ivvvvvv" + "iivvivvvivvvivvivvvviiiv")
    iso = typed(dll.gffused_isolate, "iiivviiiiiivvvvvvv")
    return run, iso, int(typed(dll.gffused_group, "", ctypes.c_int64)())


def _library(flags: tuple[str, ...] = ()) -> Any:
    """The fused kernel's ``(run, isolate)`` functions (built on first use; ``flags``
    fix the dimensions of a plan, :func:`_dims_flags`), or ``None`` without a working
    compiler (then one :class:`BackendFallbackWarning` per cache folder and compiler)."""

    def failed(exc: Exception) -> Any:
        if flags:  # the plan's dimensions: the generic kernel does the same
            return _library()
        warnings.warn(
            f"{exc}; campaign blocks use the vectorised simulation",
            BackendFallbackWarning,
            stacklevel=6,
        )
        return None

    return load_kernel("gffused", _SOURCE, _bind, flags=flags, on_fail=failed)


def _dims_flags(plan: FusedPlan) -> tuple[str, ...]:
    """Compiler flags that fix a plan's dimensions and channel layout in the kernel."""
    lay = plan.lay

    def ints(a: Any) -> str:
        return "".join(f"{int(v)}," for v in a)

    nrow = plan.rbeg.size - 1
    nz = plan.W.shape[1]
    return (
        "-DGFF_DIMS",
        f"-DGFF_Q={plan.q}",
        f"-DGFF_NS={int(lay.bs[:-1].sum())}",
        f"-DGFF_NZ={nz}",
        f"-DGFF_P={int(plan.rbeg[-1])}",
        f"-DGFF_ND={plan.D.shape[1]}",
        f"-DGFF_NROW={nrow}",
        f"-DGFF_NB={lay.bs.size - 1}",
        f"-DGFF_BSIZE={ints(lay.bs[:-1])}",
        f"-DGFF_OSTART={ints(lay.ostart[:-1])}",
        f"-DGFF_OLEN={ints(lay.olen[:-1])}",
        f"-DGFF_DKIND={ints(plan.kind[:nz])}",
        f"-DGFF_DSENS={ints(plan.sens[:nz])}",
        f"-DGFF_DROW={ints(plan.srow[:nz])}",
        f"-DGFF_ESENS={ints(plan.esens[: plan.D.shape[1]])}",
        f"-DGFF_RBEG={ints(plan.rbeg)}",
        f"-DGFF_RDST={ints(plan.rdst[:nrow])}",
    )


def _seed_key(seed: Any) -> Any:
    """What identifies a run's draws: its seed's entropy and spawn key (None: unknown)."""
    if isinstance(seed, np.random.SeedSequence):
        ent = seed.entropy
        return (tuple(ent) if isinstance(ent, list | tuple) else ent, tuple(seed.spawn_key))
    if isinstance(seed, int | np.integer):
        return int(seed)
    return None


@dataclass
class FusedPlan:
    """What every run of a plan shares (:func:`fused_plan`); the arrays the kernel reads."""

    N: int
    q: int
    n_rows: int
    y0c: np.ndarray  # (q, N)
    lv: np.ndarray | None  # (q,) diagonal of Lv, or None (Lv applied in numpy)
    Lv: np.ndarray | None
    ctx: Any
    kind: np.ndarray  # per own drive channel: 0 y, 1 rhoL, 2 rhoR, 3/4 scaled shared
    sens: np.ndarray
    srow: np.ndarray
    W: np.ndarray  # (nS, nz) own channels' columns
    sh: np.ndarray  # (n + ne, N) shared rows scaled by (eta - 1)
    fs: np.ndarray | None  # (N-1, nS): sample-major (a sample's forcing in a cache line or
    # two, read in order)
    lay: Any
    esens: np.ndarray
    D: np.ndarray
    ys: np.ndarray | None  # (N, p), sample-major
    rbeg: np.ndarray
    rdst: np.ndarray
    w0: np.ndarray  # (nS,) initial bank state of every run
    window: int = 0  # the chi-square window (0: residuals)
    segments: dict[Any, Any] = field(default_factory=dict)  # fault list -> profiles
    lib: Any = None  # the kernel's (run, isolate), built for the plan's dimensions
    noise: Any = None  # the Noise (its generator: Noise.source)
    process_rows: int = -1  # Noise.process_rows of the plant
    draws: DrawCache | None = None  # draws kept by seed (a campaign shares it), or None

    @property
    def run_draw_bytes(self) -> int:
        """Bytes of one run's draws as the cache keeps them (``q`` rows of ``N``)."""
        return self.q * self.N * 8


def _why_not(ctx: Any, schedules: Sequence[Any], x0: np.ndarray) -> str | None:
    """Why the fused pass cannot simulate these runs (None: it can)."""
    from geomfdi.simulation.profiles import _PLAIN, _values

    if ctx.ctrl.mode == "output":
        return "output feedback"
    if ctx.Lw is not None or ctx.nwp:
        return "process noise or random noise inputs"
    if ctx.d.ndim == 3 or x0.shape[0] > 1:
        return "per-run disturbances or initial states"
    if ctx.plant.q > 64:
        return "more than 64 sensors"
    for sc in schedules:
        if sc.inputs:
            return "actuator or additive faults"
        for f in sc.sensor:
            if type(f) not in _PLAIN or f.holds_reading or callable(_values(f)[0]):
                return "a sensor fault whose gain is not a number or that holds its reading"
    return None


@limit_blas_threads
def fused_plan(
    plant: Any,
    bank: Any,
    t: Any,
    u: Any,
    *,
    fault_lists: Sequence[Sequence[Any]],
    noise: Any,
    controller: Any = None,
    d: Any = None,
    x0: Any = None,
    hold: str = "foh",
    window: int = 0,
    xc0: Any = None,
    ctx: Any = None,
) -> tuple[FusedPlan | None, str]:
    """The shared part of runs whose fault lists are among ``fault_lists``, or ``None``
    and the reason when the fused pass does not cover them (module docstring).

    Parameters
    ----------
    plant, bank, t, u, controller, d, x0, hold
        As for :func:`geomfdi.simulate_batch` (``x0`` one state for every run).
    fault_lists : sequence of fault lists
        Every fault list the runs may have (a campaign: one per scenario, size and onset).
    noise : Noise
    window : int
        The chi-square window of the statistic (0: the runs give their residuals).
    xc0 : array_like, optional
        The controller's initial state (zero by default), as for
        :func:`geomfdi.simulate_batch`.
    ctx : optional
        The simulation context of these arguments when the caller has prepared it
        (:func:`geomfdi.simulation.context.prepare` with consistent initial states and
        no noise input ``w``): not prepared again.

    Returns
    -------
    (FusedPlan or None, str)
    """
    from geomfdi.model.plant import as_plant
    from geomfdi.simulation.open_loop import OpenLoopEngine, _affine
    from geomfdi.simulation.schedule import fault_schedule
    from geomfdi.simulation.simulate import make_engine

    if sim_backend() != "c":
        return None, "GEOMFDI_SIM_BACKEND=numpy"
    plant = as_plant(plant)
    if ctx is None:
        ctx = prepare(plant, bank, t, u, d, noise, controller, hold, True, False)
    schedules = [fault_schedule(fl, plant) for fl in fault_lists] or [fault_schedule([], plant)]
    x0a = state_vector(x0, plant.n, "x0")
    xc0a = state_vector(xc0, ctx.ctrl.nc, "xc0")
    why = _why_not(ctx, schedules, x0a)
    if why is not None:
        return None, why
    if _library() is None:
        return None, "no working C compiler"
    N, q = ctx.N, plant.q
    x0c = to_balanced(ctx, x0a)
    eng = make_engine(ctx, x0c, xc0a, schedules, False, len(schedules), N)
    if not isinstance(eng, OpenLoopEngine):
        return None, "faults inside the closed loop"
    p = ctx.plant
    n, nd = p.n, p.nd
    es = ctx.u_ext
    e = (np.vstack([es, ctx.d]) if nd else es)[:, None, :]
    ne = e.shape[0]
    foh = eng.foh
    dX = [Drive(e), Drive(e, 1)] if foh else [Drive(e)]
    ((X,),) = run_recursion(
        [eng.dis.Ad], eng.WX, dX, eng.x, [[np.eye(n)]], N, key=("plant", eng.key), batch=False
    )
    y0c = _affine(eng.Cy0, X, eng.Dy0, e)[:, 0]
    uu = _affine(eng.Cu, X, eng.Du, e)[:, 0]
    X2 = X[:, 0]
    # ---- the bank's drive channels, in the columns' order of W_all (OpenLoopEngine.advance)
    # per column: a shared signal row (array row, shift) or a run's own channel (kind,
    # sensor, shared row); the runs' own channels in the kernel, the shared as one product
    cols: list[tuple[Any, ...]] = []

    def shared(a: np.ndarray, sh: int = 0) -> None:
        cols.extend(("s", a[r], sh) for r in range(a.shape[0]))

    if ctx.discrete:  # w[k+1] = F w[k] - E y[k] + G u[k]
        cols += [("o", 0, i, 0) for i in range(q)]
        shared(uu)
    else:
        if not eng.decoupled:
            shared(X2)
        shared(e[:, 0])
        if foh:
            shared(e[:, 0], 1)
        cols += [("o", 1, i, 0) for i in eng.sens]
        if foh:
            cols += [("o", 2, i, 0) for i in eng.sens]
        for i in eng.chan:
            cols += [("o", 3, i, r) for r in range(n)] + [("o", 3, i, n + r) for r in range(ne)]
            if foh:
                cols += [("o", 4, i, n + r) for r in range(ne)]
    W_all = np.asarray(eng.W_all, dtype=float)
    if W_all.shape[1] != len(cols):
        return None, "an unexpected layout of the bank's drive channels"
    blocks, outs, dmats = eng.Fd, eng.outs, eng.dmats
    dsig = [uu, X2] if eng.decoupled else [uu]  # the shared direct signals, after y
    lay = _layout(blocks, W_all, outs, dmats, q + sum(a.shape[0] for a in dsig))
    fs = None
    sc = [c for c, col in enumerate(cols) if col[0] == "s"]
    if sc and N > 1:
        rows = np.array([cols[c][1][cols[c][2] : cols[c][2] + N - 1] for c in sc])
        fs = np.ascontiguousarray((W_all[:, sc] @ rows).T)
    keep = [c for c, col in enumerate(cols) if col[0] == "o" and lay.wcols[c]]
    Wp = np.ascontiguousarray(W_all[:, keep])
    kind = np.array([cols[c][1] for c in keep] + [0], dtype=np.int64)
    sens = np.array([cols[c][2] for c in keep] + [0], dtype=np.int64)
    srow = np.array([cols[c][3] for c in keep] + [0], dtype=np.int64)
    Dall = lay.Dall
    ys = None
    if Dall.shape[1] > q and lay.dcols[q:].any():
        ys = np.ascontiguousarray((Dall[:, q:] @ np.concatenate(dsig)).T)
    ecols = [c for c in range(q) if lay.dcols[c]]
    # ---- residual rows: the outputs of each generator (one row, or the norm of several)
    rbeg, rdst, o = [0], [], 0
    for (k, _), Cs in zip(eng.gens, outs, strict=True):
        o += Cs[0].shape[0]
        rbeg.append(o)
        rdst.append(k)
    w0 = np.array(eng.w[:, 0], dtype=float)
    Lv = ctx.Lv
    lv = None
    if Lv is not None:
        dg = np.diagonal(Lv)
        if np.all(dg != 0) and np.count_nonzero(Lv) == dg.size:
            lv = np.ascontiguousarray(dg, dtype=float)
    plan = FusedPlan(
        N=N,
        q=q,
        n_rows=len(ctx.view.generators),
        y0c=np.ascontiguousarray(y0c, dtype=float),
        lv=lv,
        Lv=Lv,
        ctx=ctx,
        kind=kind,
        sens=sens,
        srow=srow,
        W=Wp,
        sh=np.ascontiguousarray(np.vstack([X2, e[:, 0]]), dtype=float),
        fs=fs,
        lay=lay,
        esens=np.array(ecols + [0], dtype=np.int64),
        D=np.ascontiguousarray(Dall[:, ecols]),
        ys=ys,
        rbeg=np.array(rbeg, dtype=np.int64),
        rdst=np.array(rdst + [0], dtype=np.int64),
        w0=w0,
        window=int(window),
        noise=noise,
        process_rows=noise.process_rows(plant) if noise is not None else -1,
    )
    plan.lib = _library((_dims_flags(plan) if _SPECIALISE else ()) + _FLAGS)
    if plan.lib is None:
        return None, "no working C compiler"
    return plan, ""


def _list_key(faults: Sequence[Any]) -> Any:
    """What a fault list's profiles depend on (its faults' types and attributes), or
    ``None`` when some attribute is not hashable."""
    try:
        key = tuple((type(f), tuple(sorted(vars(f).items()))) for f in faults)
        hash(key)
    except TypeError:
        return None
    return key


def _profile_segments(plan: FusedPlan, faults: Sequence[Any]) -> list[tuple[Any, ...]]:
    """Per sensor, the segments ``(first samples, eta, lam, sampled)`` of one run's fault
    list, composed in list order as :func:`geomfdi.simulation.profiles.fault_profiles`
    does (``eta <- g eta``, ``lam <- g lam + b`` where a fault is active).  ``sampled``
    is ``None``, or, for a sensor with a callable bias, ``lam`` and its left limits
    ``(2, N)`` as :func:`geomfdi.simulation.signals.fault_profile` composes them (the
    segments then give ``eta`` alone)."""
    from geomfdi.simulation.profiles import _values
    from geomfdi.simulation.schedule import fault_schedule
    from geomfdi.simulation.signals import activity_span, fault_profile

    q, N = plan.q, plan.N
    per: list[list[tuple[int, int, float, float]]] = [[] for _ in range(q)]
    # the sensor faults as the simulation sees them (output names resolved, gains on the
    # physical reading: geomfdi.simulation.physical)
    sensor_faults = fault_schedule(list(faults), plan.ctx.original or plan.ctx.plant).sensor
    sampled: set[int] = set()
    for f in sensor_faults:
        span = activity_span(f, plan.ctx.t)
        if span is None or span[0] >= span[1]:
            continue
        g, b = _values(f)
        if callable(b):
            sampled.add(f.sensor)
            b = 0.0
        per[f.sensor].append((span[0], span[1], float(g), float(b)))
    lam_rows: dict[int, np.ndarray] = {}
    if sampled:
        rows = sorted(sampled)
        prof = fault_profile(
            [f for f in sensor_faults if f.sensor in sampled], plan.ctx.t, None, q=q,
            sensors=rows,
        )  # fmt: skip
        for j, i in enumerate(rows):
            lam_rows[i] = np.ascontiguousarray(np.stack([prof.lam[0, j], prof.lam_left[0, j]]))
    out = []
    for i, fl in enumerate(per):
        cuts = sorted({0} | {k for a, z, _, _ in fl for k in (a, z) if 0 < k < N})
        ks, etas, lams = [], [], []
        for k in cuts:
            eta, lam = 1.0, 0.0
            for a, z, g, b in fl:
                if a <= k < z:
                    if g != 1.0:
                        eta *= g
                        lam *= g
                    lam += b
            ks.append(k)
            etas.append(eta)
            lams.append(lam)
        out.append((ks, etas, lams, lam_rows.get(i)))
    return out


def _segments(plan: FusedPlan, fault_lists: Sequence[Sequence[Any]]) -> tuple[np.ndarray, ...]:
    """The piecewise-constant profiles of the runs, per (sensor, run): pointers into the
    first samples, ``eta`` and ``lam`` of the segments (:func:`_profile_segments`, kept
    per distinct fault list)."""
    q = plan.q
    cache = plan.segments
    runs = []
    seen: dict[int, Any] = {}  # the runs of one cell share their list
    for fl in fault_lists:
        if id(fl) in seen:
            runs.append(seen[id(fl)])
            continue
        key = _list_key(fl)
        seg = cache.get(key) if key is not None else None
        if seg is None:
            seg = _profile_segments(plan, fl)
            if key is not None:
                if len(cache) > 4096:
                    cache.clear()
                cache[key] = seg
        seen[id(fl)] = seg
        runs.append(seg)
    ptr, ks, etas, lams, lsp = [0], [], [], [], []
    for i in range(q):
        for seg in runs:
            k, e, lm, sampled = seg[i]
            ks += k
            etas += e
            lams += lm
            ptr.append(len(ks))
            lsp.append(0 if sampled is None else sampled.ctypes.data)
    return (
        np.array(ptr, dtype=np.int64),
        np.array(ks, dtype=np.int64),
        np.array(etas, dtype=float),
        np.array(lams, dtype=float),
        np.array(lsp, dtype=np.uintp) if any(lsp) else None,
        runs,  # the sampled profiles' arrays, alive while the caller holds this
    )


def _sink_rows(sub: int, runs: int, rows: int, samples: int, zero: bool) -> np.ndarray:
    """The calling thread's buffer of a window's rows ``(runs, rows, samples)``, runs at
    most ``sub`` (the rows of missing generators zeroed when ``zero``: the kernel writes
    only the others)."""
    buf = _POOLS.work.get("fused sink", (sub, rows, SINK_WINDOW))[:runs, :, :samples]
    if zero:
        buf[:] = 0.0
    return buf


@limit_blas_threads
def fused_runs(
    plan: FusedPlan,
    fault_lists: Sequence[Sequence[Any]],
    seeds: Sequence[Any],
    out: np.ndarray | None = None,
    *,
    evaluation: _Evaluation | None = None,
    sink: Callable[[int, int, int, int, np.ndarray], None] | None = None,
) -> np.ndarray | None:
    """The statistic (``plan`` with a chi-square window) or the residuals of the runs,
    ``(R, n_residuals, N)``; with ``evaluation`` (:func:`evaluation_struct`) and no
    ``out`` only their evaluation (nothing returned); with ``sink`` the rows of each
    window of each few runs handed over as soon as they are computed.

    Parameters
    ----------
    plan : FusedPlan
    fault_lists : sequence of fault lists
        One per run (each among the plan's).
    seeds : sequence
        One noise seed per run (as :func:`geomfdi.simulate_batch`'s ``seeds``).
    out : ndarray, optional
        Array ``(R, n_residuals, N)`` to fill (rows of missing generators: 0).
    evaluation : optional
        Scores, alarm codes and divergence of the statistic, filled by the kernel.
    sink : callable, optional
        ``sink(a, b, s, e, rows)`` after the kernel has computed the samples ``s .. e-1``
        of the runs ``a .. b-1`` (the few runs drawn at a time, 16 with AVX2; windows of
        :data:`SINK_WINDOW` samples, each run's windows in order): ``rows`` is
        ``out[a:b, :, s:e]``, or without ``out`` a buffer of the calling thread, valid
        until ``sink`` returns (the memory does not grow with the record's length).  Runs
        split between work threads call ``sink`` from those threads, for disjoint runs.
    """
    from geomfdi.simulation.noise import CounterStream, counter_normals
    from geomfdi.simulation.simulate import noise_streams, noise_window

    lib = plan.lib[0]
    R, N, q = len(fault_lists), plan.N, plan.q
    nrow = plan.rbeg.size - 1
    if out is None and evaluation is None and sink is None:
        out = np.zeros((R, plan.n_rows, N))
    elif out is not None and nrow < plan.n_rows:
        out[:] = 0.0
    wlen = SINK_WINDOW if sink is not None else WINDOW
    ctx, lay = plan.ctx, plan.lay
    segptr, segk, segeta, seglam, lsp, held = _segments(plan, fault_lists)
    win = plan.window
    nS = int(lay.bs[:-1].sum())
    X = np.array(np.broadcast_to(plan.w0[:, None], (nS, R)), order="C")
    cs = np.zeros((nrow, R))
    ring = np.zeros((max(win, 1), nrow, R))
    zp = np.zeros(R * q, dtype=np.uintp)
    zts = np.ones(R * q, dtype=np.int64)
    base = [
        R, 0, 0, N, 0, 0, q, plan.y0c.ctypes.data,
        zp.ctypes.data if plan.Lv is not None else None, zts.ctypes.data,
        plan.lv.ctypes.data if plan.lv is not None else None,
        segptr.ctypes.data, segk.ctypes.data, segeta.ctypes.data, seglam.ctypes.data,
        None if lsp is None else lsp.ctypes.data, plan.W.shape[1], plan.kind.ctypes.data,
        plan.sens.ctypes.data, plan.srow.ctypes.data, plan.W.ctypes.data, plan.sh.ctypes.data,
        None if plan.fs is None else plan.fs.ctypes.data,
        nS, lay.bs.size - 1, lay.bs.ctypes.data, lay.Apk.ctypes.data,
        int(plan.rbeg[-1]), lay.ostart.ctypes.data, lay.olen.ctypes.data,
        lay.Cpk.ctypes.data, plan.D.shape[1], plan.esens.ctypes.data,
        plan.D.ctypes.data, None if plan.ys is None else plan.ys.ctypes.data,
        nrow, plan.rbeg.ctypes.data, plan.rdst.ctypes.data, win,
        X.ctypes.data, cs.ctypes.data, ring.ctypes.data,
        None, *((0, 0, 0) if out is None else (st // 8 for st in out.strides)),
        None if evaluation is None else ctypes.addressof(evaluation),
    ]  # fmt: skip

    def runs(a: int, b: int) -> int:
        """Runs ``a .. b-1``, a few at a time: their noise drawn, then passed through
        the kernel while it is in the cache (the buffers reused by the next few)."""
        pool = getattr(_POOLS, "pool", None)  # this thread's draw buffers, kept
        if pool is None:
            pool = _POOLS.pool = {}
            _POOLS.work = Workspace()
        for a1 in range(a, b, sub):
            b1 = min(a1 + sub, b)
            if cached:
                status = kept_runs(a1, b1, pool)
                if status != 0:
                    return status
                continue
            streams = None
            if plan.Lv is not None:
                sources = [plan.noise.source(sd, plan.process_rows) for sd in seeds[a1:b1]]
                streams = noise_streams(ctx, sources, pool, 1)
            # a diagonal Lv: each run's draws read where they are (numpy's generator) or
            # where the counter generator fills them, scaled in the kernel (the product
            # of gf.simulate_batch's scaling); otherwise its scaled window
            direct = streams is not None and plan.lv is not None
            counter = direct and isinstance(streams[0], CounterStream)
            for s in range(0, N, wlen):
                e = min(s + wlen, N)
                e1 = min(e + 1, N)  # the reading at the end of the window's last interval
                keep, ptrs = [], []
                if counter:
                    z = _POOLS.work.get("fused z", (q, b1 - a1, e1 - s))
                    counter_normals(streams, s, e1, z, None)
                    z0, si, sr = z.ctypes.data, z.strides[0], z.strides[1]
                    ptrs = [z0 + r * sr + i * si for r in range(b1 - a1) for i in range(q)]
                elif direct:
                    for st in streams:
                        z = st.take(s, e1)[0]
                        if z.strides[1] != 8:
                            z = np.ascontiguousarray(z)
                        keep.append(z)
                        z0, step = z.ctypes.data, z.strides[0]
                        ptrs += [z0 + i * step for i in range(q)]
                elif streams is not None:
                    v = noise_window(ctx, streams, s, e1, _POOLS.work)[0]
                    keep.append(v)
                    v0, si, sr = v.ctypes.data, v.strides[0], v.strides[1]
                    ptrs = [v0 + r * sr + i * si for r in range(b1 - a1) for i in range(q)]
                if ptrs:
                    zp[a1 * q : b1 * q] = ptrs
                args = list(base)
                args[1], args[2], args[4], args[5] = a1, b1, s, e - s
                args[10] = plan.lv.ctypes.data if direct else None
                rows = None
                if out is not None:
                    args[-5] = out[a1:, :, s:].ctypes.data
                elif sink is not None:
                    rows = _sink_rows(sub, b1 - a1, plan.n_rows, e - s, nrow < plan.n_rows)
                    args[-5] = rows.ctypes.data
                    args[-4:-1] = [st // 8 for st in rows.strides]
                status = int(lib(*args))
                del keep
                if status != 0:
                    return status
                if sink is not None:
                    sink(a1, b1, s, e, out[a1:b1, :, s:e] if rows is None else rows)
            for st in streams or ():
                st.release()
        return 0

    G = plan.lib[2]  # runs per group of lanes: parts and draws cut at multiples of it
    sub = max(G, _SUB // G * G)
    # one window, a diagonal Lv and a cache: draws read from the cache or made and kept
    cached = plan.draws is not None and plan.lv is not None and N <= WINDOW and sink is None
    cache: DrawCache = plan.draws  # type: ignore[assignment]

    def draw(a1: int, js: list[int], keys: list[Any], zs: list[Any], pool: Any) -> list[Any]:
        """Runs ``a1 + j`` (``j`` in ``js``) drawn and offered to the cache; the streams
        to release once the kernel has read them."""
        sources = [plan.noise.source(seeds[a1 + j], plan.process_rows) for j in js]
        streams = noise_streams(ctx, sources, pool, 1)
        if isinstance(streams[0], CounterStream):
            zb = _POOLS.work.get("fused z", (q, len(js), N))
            counter_normals(streams, 0, N, zb, None)
            drawn = [zb[:, j] for j in range(len(js))]
        else:
            drawn = [st.take(0, N)[0] for st in streams]
        for j, z in zip(js, drawn, strict=True):
            zs[j] = cache.put(keys[j], z)
        return streams

    def kept_runs(a1: int, b1: int, pool: dict[int, list[np.ndarray]]) -> int:
        keys = [_seed_key(sd) for sd in seeds[a1:b1]]
        zs: list[Any] = [None] * len(keys)
        miss, waits = [], []
        for j, (z, event) in enumerate(cache.reserve_all(keys)):
            zs[j] = z
            if z is None and event is None:
                miss.append(j)  # reserved here
            elif z is None:
                waits.append((j, event))  # being drawn by another thread
        streams: list[Any] = []
        try:
            if miss:  # reserved here: drawn before waiting for any other thread's
                streams = draw(a1, miss, keys, zs, pool)
        finally:
            for j in miss:
                cache.release(keys[j])  # (a no-op once put; an error: the waiters go on)
        for _, event in waits:
            event.wait()
        late = []  # reserved by another thread and not kept (the budget): drawn here
        for j, _ in waits:
            zs[j] = cache.get(keys[j])
            if zs[j] is None:
                late.append(j)
        if late:
            if streams:
                for st in streams:
                    st.release()
            miss = sorted(miss + late)
            streams = draw(a1, miss, keys, zs, pool)
        zs = [z if z.strides[1] == 8 else np.ascontiguousarray(z) for z in zs]  # type: ignore
        ptrs = []
        for z in zs:
            z0, step = z.ctypes.data, z.strides[0]
            ptrs += [z0 + i * step for i in range(q)]
        zp[a1 * q : b1 * q] = ptrs
        args = list(base)
        args[1], args[2], args[4], args[5] = a1, b1, 0, N
        args[10] = plan.lv.ctypes.data  # type: ignore[union-attr]
        args[-5] = None if out is None else out[a1:].ctypes.data
        status = int(lib(*args))
        for st in streams:
            st.release()
        del zs
        return status

    k = max(1, min(work_threads(), -(-R // G), R * N // _MIN_PART_WORK))
    edges = [0] + [round(i * R / (k * G)) * G for i in range(1, k)] + [R]
    spans = [(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]
    if len(spans) == 1:
        status = runs(*spans[0])
    else:
        futs = [thread_pool(len(spans)).submit(runs, a, b) for a, b in spans]
        wait(futs)
        status = min(f.result() for f in futs)
    del held  # the sampled profiles, alive through the kernel's calls
    if status != 0:
        raise MemoryError("the fused block could not allocate its work arrays")
    return out


def isolate_codes(
    plan: FusedPlan,
    codes: np.ndarray,
    lut: np.ndarray,
    rule: Any,
    n_faults: int,
    kon: np.ndarray,
    kpost1: np.ndarray,
    truth: np.ndarray,
    right_lut: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The first decision of each run in its window from its alarm codes ``(R, kend)``
    (``gffused_isolate`` in ``compiled_fused.c``): ``(first sample, decision, first
    sample of the true decision)``, -1 for none.

    ``lut`` (``2**n_res``,) decides each pattern code; ``rule`` a
    :class:`~geomfdi.evaluation.persistence.Persistence` or ``None`` (per-sample
    decisions); ``right_lut`` ``(R, 2**n_res)``: whether a pattern's suspects are the
    run's true faults (runs of several faults).
    """
    iso = plan.lib[1]
    R, kend = codes.shape
    nres = int(lut.size).bit_length() - 1
    trivial = rule is None or rule.trivial
    k, n = (1, 1) if trivial else (rule.k, rule.n)
    latch = 0 if trivial else int(rule.latch)
    reset = -1 if trivial or rule.reset is None else int(rule.reset)
    first = np.empty(R, dtype=np.int64)
    dec = np.empty(R, dtype=np.int64)
    right = np.empty(R, dtype=np.int64)
    codes = np.ascontiguousarray(codes, dtype=np.uint8)
    lut = np.ascontiguousarray(lut, dtype=np.int64)
    kon = np.ascontiguousarray(kon, dtype=np.int64)
    kpost1 = np.ascontiguousarray(kpost1, dtype=np.int64)
    truth = np.ascontiguousarray(truth, dtype=np.int64)
    rl = None if right_lut is None else np.ascontiguousarray(right_lut, dtype=np.uint8)
    status = iso(
        R, kend, nres, codes.ctypes.data, lut.ctypes.data, int(trivial), k, n, latch, reset,
        n_faults, kon.ctypes.data, kpost1.ctypes.data, truth.ctypes.data,
        None if rl is None else rl.ctypes.data, first.ctypes.data, dec.ctypes.data,
        right.ctypes.data,
    )  # fmt: skip
    if status != 0:
        raise MemoryError("the isolation of a block could not allocate its work arrays")
    return first, dec, right
