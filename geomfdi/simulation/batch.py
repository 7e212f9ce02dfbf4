"""Monte-Carlo runs (noise seeds, fault sizes) simulated together: :func:`simulate_batch`."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads, work_threads
from geomfdi._validation import as_choice, as_int
from geomfdi.errors import ShapeError
from geomfdi.evaluation.decision import NO_ALARM, as_threshold
from geomfdi.evaluation.persistence import as_persistence
from geomfdi.generators.generator import ResidualBank, ResidualGenerator
from geomfdi.limits import check_allocation, check_runs, get_limits
from geomfdi.model.plant import Plant, as_plant
from geomfdi.simulation.compiled_recursion import batch_runs
from geomfdi.simulation.context import (
    detection_window_of,
    from_balanced,
    prepare,
    progress_bar,
    residual_labels_of,
    state_vector,
    to_balanced,
)
from geomfdi.simulation.noise import Noise, run_seeds
from geomfdi.simulation.open_loop import OpenLoopEngine
from geomfdi.simulation.result_memory import mapped
from geomfdi.simulation.results import (
    BatchResult,
)
from geomfdi.simulation.schedule import fault_schedule, structure_columns
from geomfdi.simulation.signals import FaultSignal
from geomfdi.simulation.simulate import (
    chunk_width,
    in_loop,
    make_engine,
    noise_streams,
    noise_window,
)
from geomfdi.simulation.streaming import (
    DecisionStream,
    RunSummary,
    Workspace,
    chunk_plan,
    time_chunks,
)


@limit_blas_threads
def simulate_batch(
    plant: Plant,
    bank: ResidualBank | ResidualGenerator,
    t: Any,
    u: Any = None,
    *,
    runs: int | None = None,
    faults: Any = (),
    x0: Any = None,
    noise: Noise | None = None,
    seeds: Sequence[Any] | None = None,
    controller: Any = None,
    threshold: Any = None,
    d: Any = None,
    xc0: Any = None,
    hold: str = "foh",
    consistent_init: bool = True,
    store: str = "residuals",
    w: Any = None,
    chunk_size: int | None = None,
    persistence: Any = None,
    detection_window: float | None = None,
    progress: bool | None = None,
) -> BatchResult:
    """Many Monte-Carlo runs (noise seeds, fault sizes) in one vectorised call.

    Parameters
    ----------
    plant, bank, t, u, x0, controller, threshold, d, w, xc0, hold, consistent_init
        As for :func:`simulate`; ``x0`` may also be ``(runs, n)``.
    persistence, detection_window
        The decision rule, as for :func:`simulate`.
    runs : int, optional
        Number of runs; defaults to the number of fault lists when ``faults`` is a list
        of lists, else 1.
    faults : sequence of fault signals, or a sequence of such sequences
        One list shared by all runs, or one list per run (e.g. a sweep of fault sizes).
    noise : Noise, optional
        Run ``i`` draws its noise from ``seeds[i]`` (``numpy.random.default_rng``, or
        the counter generator of ``Noise(generator="counter")``, whose normals are the
        same bits as ``simulate``'s for that seed); by default the seeds are
        ``SeedSequence(noise.seed).spawn(runs)``, so run ``i`` equals
        ``simulate(..., noise=Noise(..., seed=seeds[i]))`` up to rounding (the bank of
        a batch runs in the compiled recursion of
        :mod:`geomfdi.simulation.compiled_recursion`; see the user guide,
        *Performance*, ``docs/guide/performance.md``).
    seeds : sequence, optional
        Explicit per-run seeds (integers >= 0 or ``numpy.random.SeedSequence``), one per
        run; needs ``noise``.
    store : {"residuals", "all", "summary"}
        What to keep per run: residuals, alarms and decisions (default); also ``x, y,
        u`` (``"all"``, enables :meth:`BatchResult.run`); or only peaks and events.
    chunk_size : int, optional
        Runs simulated together.  By default the chunks (runs, and samples of the time
        axis) are sized from the memory budget ``gf.limits.get_limits().chunk_memory``
        (see :mod:`geomfdi.limits`): whole records of several runs when they fit, else
        one run at a time with its time axis cut into chunks, the states carried across
        chunk boundaries.  Memory is then the stored results plus about the budget;
        with ``store="summary"`` it does not grow with the record's length.
    progress : bool, optional
        tqdm progress bar over the chunks (default: when stderr is a terminal).

    Returns
    -------
    BatchResult

    Notes
    -----
    A batch of at least :data:`FUSED_MIN_WORK` run-samples that the fused pass covers
    (open loop or state feedback, measurement noise, sensor faults with numeric gains,
    one initial state, ``store`` other than ``"all"``; :mod:`geomfdi.simulation.fused`)
    runs through it: readings, faults, bank and decisions of 16 runs at a time, window
    by window, the same results as the chunked engine (residuals to rounding).
    Otherwise open loop and state feedback are vectorised across all runs of a chunk
    (one compiled recursion per state over the ``(runs, N)`` array).  Under output
    feedback runs with a shared fault list are vectorised; per-run fault lists are
    simulated one run at a time (the loop dynamics differ between runs).
    """
    store = as_choice(store, "store", ("residuals", "all", "summary"))
    plant = as_plant(plant)
    ctx = prepare(plant, bank, t, u, d, noise, controller, hold, consistent_init, progress, w)
    per_run = (
        not isinstance(faults, FaultSignal)
        and isinstance(faults, Sequence)
        and len(faults) > 0
        and all(isinstance(f, Sequence) for f in faults)
    )
    if per_run:
        schedules = [
            fault_schedule(f, plant, argument=f"faults[{i}]") for i, f in enumerate(faults)
        ]
        if runs is None:
            runs = len(schedules)
        runs = check_runs(runs)
        if runs != len(schedules):
            raise ShapeError(
                f"faults: {len(schedules)} fault lists for runs={runs}", argument="faults"
            )
    else:
        runs = check_runs(1 if runs is None else runs)
        schedules = [fault_schedule(faults, plant)] * runs
    q = plant.q
    rule = as_persistence(persistence)
    window = detection_window_of(detection_window)
    x0a = state_vector(x0, plant.n, "x0", runs)
    xc0a = state_vector(xc0, ctx.ctrl.nc, "xc0")
    seeds = run_seeds(noise, seeds, runs)
    kp = noise.process_rows(plant) if noise is not None else 0
    view = ctx.view
    nres = len(view.generators)
    N = ctx.N
    if chunk_size is not None:
        chunk_size = as_int(chunk_size, "chunk_size", minimum=1)
    stored = 2 * nres + 1 if store != "summary" else nres
    stored += plant.n + 3 * q + plant.m if store == "all" else 0
    check_allocation(N, runs, stored, argument="runs", what="simulate_batch")
    thr = as_threshold(threshold, nres, view.present)
    keep_r = store in ("residuals", "all")
    # the records in populated mappings (geomfdi.simulation.result_memory.mapped)
    R_res = mapped((runs, nres, N)) if keep_r else None
    R_al = mapped((runs, nres, N), bool) if keep_r else None
    R_iso = mapped((runs, N), int, fill=NO_ALARM) if keep_r else None
    R_x = mapped((runs, plant.n, N)) if store == "all" else None
    R_y = mapped((runs, q, N)) if store == "all" else None
    R_yh = mapped((runs, q, N)) if store == "all" else None
    R_u = mapped((runs, plant.m, N)) if store == "all" else None
    cache: dict[Any, Any] = {}  # the column of each fault channel (not per run)
    columns = [structure_columns(sc.faults, view.design_faults, plant, cache) for sc in schedules]
    summary = RunSummary(ctx.t, [sc.faults for sc in schedules], columns, nres, window)
    loop = in_loop(ctx, schedules)
    width = chunk_width(ctx, keep_states=loop, loop=loop)
    Rc, L = chunk_plan(N, runs, width, runs_per_chunk=chunk_size, min_runs=batch_runs())
    bar = progress_bar(ctx.progress, runs, "runs")
    plan = None
    if store != "all" and consistent_init and w is None and runs * N >= FUSED_MIN_WORK:
        plan = _fused_plan(ctx, plant, bank, t, u, noise, schedules, controller, d, x0a, xc0, hold)
    if plan is not None:
        _fused_batch(
            plan, schedules, seeds, (thr, view.structure, rule), R_res, (R_al, R_iso), summary, bar
        )
    else:
        kept: dict[str, Any] = {}  # for the next chunk of runs: open-loop engine, noise buffers
        work = kept["work"] = Workspace()  # chunk-sized work arrays, reused chunk after chunk
        kept["threads"] = work_threads()  # the noise draws of a chunk's runs, in parallel
        for a in range(0, runs, Rc):
            b = min(a + Rc, runs)
            rngs = [None if sd is None else noise.source(sd, kp) for sd in seeds[a:b]]
            x0c = to_balanced(ctx, x0a[a:b] if x0a.shape[0] > 1 else x0a)
            chunk = schedules[a:b]
            ds = DecisionStream(thr, view.structure, rule, work)
            pieces = _pieces(ctx, x0c, xc0a, rngs, chunk, not per_run, L, R_res, a, kept)
            for s, e, pc, res, written in pieces:
                if keep_r and not written:
                    R_res[a:b, :, s:e] = res
                _judge(ds, res, (R_al, R_iso, a, b, s, e), work, summary)
                if store == "all":
                    L_s = e - s
                    R_x[a:b, :, s:e] = from_balanced(ctx, pc.X[:, :, :L_s].transpose(1, 0, 2))
                    R_y[a:b, :, s:e] = pc.y[:, :, :L_s].transpose(1, 0, 2)
                    R_yh[a:b, :, s:e] = pc.y0n[:, :, :L_s].transpose(1, 0, 2)
                    R_u[a:b, :, s:e] = pc.u[:, :, :L_s].transpose(1, 0, 2)
            if bar is not None:
                bar.update(b - a)
    if bar is not None:
        bar.close()
    events = [summary.events(r) for r in range(runs)]
    fa = [summary.false_alarms(r) for r in range(runs)]
    peak = summary.peak
    fa_counts = np.array([f.alarm_samples for f in fa], dtype=float)
    healthy = np.array([f.samples for f in fa], dtype=int)
    fa_events = np.array([f.events for f in fa], dtype=int)
    return BatchResult(
        t=ctx.t,
        runs=runs,
        residuals=R_res,
        alarms=R_al,
        isolated=R_iso,
        x=R_x,
        y=R_y,
        y_healthy=R_yh,
        u=R_u,
        peak=peak,
        events=events,
        false_alarm_counts=fa_counts,
        healthy_samples=healthy,
        fault_lists=[list(sc.faults) for sc in schedules],
        seeds=seeds,
        threshold=thr,
        structure=view.structure,
        requested=view.requested,
        fault_labels=view.fault_labels,
        residual_labels=residual_labels_of(view),
        info=ctx.info,
        vector_rows=[g is not None and g.n_outputs > 1 for g in view.generators],
        persistence=rule,
        false_alarm_events=fa_events,
    )


def _judge(
    ds: DecisionStream,
    res: np.ndarray,
    records: tuple[Any, ...],
    work: Workspace,
    summary: RunSummary,
) -> None:
    """Alarms, decisions and summary of the residuals ``res`` (R, n_rows, L) of the runs
    ``a .. b-1`` and samples ``s .. e-1`` (``records``: the alarms and decisions kept, or
    None, then ``a, b, s, e``), written into the records when they are kept."""
    R_al, R_iso, a, b, s, e = records
    if ds.threshold is not None and _decide_compiled(ds, res, records, work, summary):
        return  # decided and summarised in one compiled pass
    if ds.threshold is None:  # no alarm, no decision: R_al and R_iso stay as they are
        peaks = np.max(np.abs(res, out=work.get("abs", res.shape)), axis=-1)
        summary.update(s, res, None, None, a, peaks=peaks)
        return
    absr = np.abs(res, out=work.get("abs", res.shape))
    peaks = np.max(absr, axis=-1)
    dest = R_al[a:b, :, s:e] if R_al is not None else work.get("alarms", res.shape, bool)
    al, isolated, suspects = ds.decide(res, absolute=absr, peaks=peaks, out=dest)
    summary.update(s, res, al, isolated, a, suspects, peaks=peaks)
    if R_al is not None:
        if al is not dest:
            R_al[a:b, :, s:e] = al
        R_iso[a:b, s:e] = isolated


#: Fewest run-samples of a batch simulated by the fused pass of
#: :mod:`geomfdi.simulation.fused` (a smaller batch: the chunked engine, which needs no
#: plan; both give the same residuals to rounding).
FUSED_MIN_WORK = 2**20
#: Chunk memory budgets (``gf.limits.get_limits().chunk_memory``) the fused plan's shared
#: signals may take, whole records (more: the chunked engine, whose memory does not grow
#: with the record's length).
FUSED_PLAN_CHUNKS = 4


def _fused_plan(
    ctx: Any,
    plant: Plant,
    bank: Any,
    t: Any,
    u: Any,
    noise: Noise | None,
    schedules: list[Any],
    controller: Any,
    d: Any,
    x0a: np.ndarray,
    xc0: Any,
    hold: str,
) -> Any:
    """The fused plan of the batch's runs (:func:`geomfdi.simulation.fused.fused_plan`),
    or ``None`` when the fused pass does not cover them (then the chunked engine)."""
    from geomfdi.simulation.fused import fused_plan

    if x0a.shape[0] > 1:
        return None
    # the plan's signals shared by the runs, whole records (readings, forcing of every
    # state, feedthrough, plant state and inputs): within FUSED_PLAN_CHUNKS budgets
    p, gens = ctx.plant, [g for g in ctx.view.generators if g is not None]
    rows = 2 * p.q + 3 * p.n + 2 * (p.m + p.nd) + sum(g.order + g.n_outputs for g in gens)
    if 8 * ctx.N * rows > FUSED_PLAN_CHUNKS * get_limits().chunk_memory:
        return None
    lists: dict[int, list[Any]] = {}
    for sc in schedules:
        lists.setdefault(id(sc.faults), sc.faults)
    plan, _ = fused_plan(
        plant, bank, t, u, fault_lists=list(lists.values()), noise=noise,
        controller=controller, d=d, x0=x0a[0], hold=hold, xc0=xc0, ctx=ctx,
    )  # fmt: skip
    return plan


def _fused_batch(
    plan: Any,
    schedules: list[Any],
    seeds: list[Any],
    rule: tuple[Any, Any, Any],
    R_res: np.ndarray | None,
    kept: tuple[np.ndarray | None, np.ndarray | None],
    summary: RunSummary,
    bar: Any,
) -> None:
    """The runs by the fused pass: each window of a few runs judged while it is in the
    cache (:func:`_judge`, on the thread that computed it), the residuals written
    straight into ``R_res`` when kept (``rule``: threshold, structure and persistence of
    the decisions; ``kept``: the alarms and decisions kept, or None)."""
    from geomfdi.simulation.fused import fused_runs
    from geomfdi.simulation.workspace import thread_workspace

    deciding: dict[int, DecisionStream] = {}  # per first run of a few: their decisions
    R_al, R_iso = kept
    N = plan.N

    def sink(a: int, b: int, s: int, e: int, res: np.ndarray) -> None:
        work = thread_workspace("batch decisions")
        if s == 0:
            deciding[a] = DecisionStream(*rule, work)
        _judge(deciding[a], res, (R_al, R_iso, a, b, s, e), work, summary)
        if e == N:
            del deciding[a]
            if bar is not None:
                bar.update(b - a)

    fused_runs(plan, [sc.faults for sc in schedules], seeds, R_res, sink=sink)


def _decide_compiled(
    ds: DecisionStream,
    res: np.ndarray,
    records: tuple[Any, ...],
    work: Workspace,
    summary: RunSummary,
) -> bool:
    """The decisions of a chunk straight into the records (when kept) and its summary,
    by :meth:`DecisionStream.decide_compiled`; False when it declined (nothing done).
    ``records``: the alarms and decisions kept (or None), the chunk's runs ``a .. b-1``
    and samples ``s .. e-1``."""
    R_al, R_iso, a, b, s, e = records
    R, L = res.shape[0], res.shape[-1]
    if R_al is not None and R_iso is not None:
        al, iso = R_al[a:b, :, s:e], R_iso[a:b, s:e]
    else:
        al, iso = work.get("alarms", res.shape, bool), work.get("isolated", (R, L), np.int64)
    any_alarm = work.get("any alarm", (R, L), bool)
    peaks = ds.decide_compiled(res, al, iso, any_alarm)
    if peaks is None:
        return False
    summary.update(s, res, al, iso, a, None, peaks=peaks, any_alarm=any_alarm)
    return True


def _pieces(
    ctx: Any,
    x0: np.ndarray,
    xc0: np.ndarray,
    rngs: list[Any],
    schedules: list[Any],
    shared: bool,
    L: int,
    R_res: np.ndarray | None,
    a: int,
    kept: dict[str, Any],
) -> Iterator[tuple[int, int, Any, np.ndarray, bool]]:
    """The time chunks of a chunk of runs: ``(s, e, signals, residuals (Rc, n, e-s),
    written)`` (``written``: the residuals are already in ``R_res``).

    The engine advances chunk by chunk; the residual rows are written straight into
    ``R_res`` when it is kept and every run differs.  With one fault list shared by
    every run, the open-loop engine of the first chunk of runs is restarted for the
    next (``kept``, which also holds the noise draws' buffers, reused chunk after chunk).
    """
    view, N = ctx.view, ctx.N
    nres, Rc = len(view.generators), len(rngs)
    eng = kept.get("open")
    if eng is not None:  # shared fault list in open loop: same matrices, new runs
        eng.restart(x0, Rc)
    else:
        eng = make_engine(ctx, x0, xc0, schedules, shared, Rc, L)
        if shared and isinstance(eng, OpenLoopEngine):
            kept["open"] = eng
    # the draws' memory, reused; the runs' draws split between the work threads
    parts = kept["threads"]
    streams = noise_streams(ctx, rngs, kept.setdefault("noise buffers", {}), parts)
    work = kept["work"]
    if isinstance(eng, OpenLoopEngine):
        eng.workspace = work
    direct = R_res is not None and eng.R == Rc
    chunks = time_chunks(N, L)
    buf = None if direct else np.zeros((eng.R, nres, max(e1 - s for s, _, e1 in chunks)))
    for s, e, e1 in chunks:
        dest = R_res[a : a + Rc, :, s:e1] if direct else buf[:, :, : e1 - s]
        v, wp = noise_window(ctx, streams, s, e1, work, parts)
        pc = eng.advance(s, e1, v, wp, dest)
        yield s, e, pc, np.broadcast_to(dest[:, :, : e - s], (Rc, nres, e - s)), direct
    for st in streams or ():
        st.release()
