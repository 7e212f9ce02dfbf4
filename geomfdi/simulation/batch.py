"""Monte-Carlo runs (noise seeds, fault sizes) simulated together: :func:`simulate_batch`."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import as_choice, as_int
from geomfdi.errors import ShapeError
from geomfdi.evaluation.decision import (
    FaultEvent,
    as_threshold,
    detection_events,
)
from geomfdi.evaluation.metrics import false_alarms
from geomfdi.evaluation.persistence import as_persistence, decisions
from geomfdi.limits import check_allocation, check_runs
from geomfdi.model.plant import Plant, as_plant
from geomfdi.simulation.context import (
    detection_window_of,
    from_balanced,
    prepare,
    progress_bar,
    residual_labels_of,
    residual_rows,
    state_vector,
    to_balanced,
)
from geomfdi.simulation.noise import Noise, run_seeds
from geomfdi.simulation.results import (
    BatchResult,
)
from geomfdi.simulation.schedule import fault_schedule, structure_columns
from geomfdi.simulation.signals import FaultSignal
from geomfdi.simulation.simulate import run_chunk
from geomfdi.synthesis.generator import ResidualBank, ResidualGenerator


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
    chunk_size: int | None = None,
    persistence: Any = None,
    detection_window: float | None = None,
    progress: bool | None = None,
) -> BatchResult:
    """Many Monte-Carlo runs (noise seeds, fault sizes) in one vectorised call.

    Parameters
    ----------
    plant, bank, t, u, x0, controller, threshold, d, xc0, hold, consistent_init
        As for :func:`simulate`; ``x0`` may also be ``(runs, n)``.
    persistence, detection_window
        The decision rule, as for :func:`simulate`.
    runs : int, optional
        Number of runs; defaults to the number of fault lists when ``faults`` is a list
        of lists, else 1.
    faults : sequence of fault signals, or a sequence of such sequences
        One list shared by all runs, or one list per run (e.g. a sweep of fault sizes).
    noise : Noise, optional
        Run ``i`` draws its noise from ``numpy.random.default_rng(seeds[i])``; by default
        the seeds are ``SeedSequence(noise.seed).spawn(runs)``, so run ``i`` equals
        ``simulate(..., noise=Noise(..., seed=seeds[i]))``.
    seeds : sequence, optional
        Explicit per-run seeds (integers >= 0 or ``numpy.random.SeedSequence``), one per
        run; needs ``noise``.
    store : {"residuals", "all", "summary"}
        What to keep per run: residuals, alarms and decisions (default); also ``x, y,
        u`` (``"all"``, enables :meth:`BatchResult.run`); or only peaks and events.
    chunk_size : int, optional
        Runs simulated together (default: as many as fit ~2e7 array elements).
    progress : bool, optional
        tqdm progress bar over the chunks (default: when stderr is a terminal).

    Returns
    -------
    BatchResult

    Notes
    -----
    Open loop and state feedback are vectorised across all runs of a chunk (one compiled
    recursion per state over the ``(runs, N)`` array).  Under output feedback runs with a
    shared fault list are vectorised; per-run fault lists are simulated one run at a time
    (the loop dynamics differ between runs).
    """
    store = as_choice(store, "store", ("residuals", "all", "summary"))
    plant = as_plant(plant)
    ctx = prepare(plant, bank, t, u, d, noise, controller, hold, consistent_init, progress)
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
    view = ctx.view
    nres = len(view.generators)
    N = ctx.N
    width = (
        plant.n
        + 3 * q
        + plant.m
        + ctx.ctrl.nc
        + 2 * sum(g.order + g.n_outputs for g in view.generators if g is not None)
    )
    if chunk_size is None:
        chunk_size = max(1, int(2e7 // max(width * N, 1)))
    chunk_size = as_int(chunk_size, "chunk_size", minimum=1)
    stored = 2 * nres + 1 if store != "summary" else nres
    stored += plant.n + 3 * q + plant.m if store == "all" else 0
    check_allocation(N, runs, stored, argument="runs", what="simulate_batch")
    thr = as_threshold(threshold, nres, view.present)
    keep_r = store in ("residuals", "all")
    R_res = np.zeros((runs, nres, N)) if keep_r else None
    R_al = np.zeros((runs, nres, N), dtype=bool) if keep_r else None
    R_iso = np.zeros((runs, N), dtype=int) if keep_r else None
    R_x = np.zeros((runs, plant.n, N)) if store == "all" else None
    R_y = np.zeros((runs, q, N)) if store == "all" else None
    R_yh = np.zeros((runs, q, N)) if store == "all" else None
    R_u = np.zeros((runs, plant.m, N)) if store == "all" else None
    peak = np.zeros((runs, nres))
    events: list[list[FaultEvent]] = []
    fa_counts = np.zeros(runs)
    healthy = np.zeros(runs, dtype=int)
    columns: dict[int, list[int | None]] = {}
    fa_events = np.zeros(runs, dtype=int)
    bar = progress_bar(ctx.progress, runs, "runs")
    for a in range(0, runs, chunk_size):
        b = min(a + chunk_size, runs)
        rngs = [None if s is None else np.random.default_rng(s) for s in seeds[a:b]]
        x0c = x0a[a:b] if x0a.shape[0] > 1 else x0a
        chunk = schedules[a:b]
        raw = run_chunk(ctx, to_balanced(ctx, x0c), xc0a, rngs, chunk, not per_run)
        Rc = b - a
        res = np.broadcast_to(residual_rows(ctx, raw), (Rc, nres, N))
        al, iso = decisions(res, thr, view.structure, rule)
        peak[a:b] = np.max(np.abs(res), axis=-1)
        for r in range(Rc):
            sched = chunk[r]
            cols = columns.get(id(sched))
            if cols is None:
                cols = columns[id(sched)] = structure_columns(
                    sched.faults, view.design_faults, plant
                )
            evs = detection_events(
                ctx.t,
                al[r],
                iso.isolated[r],
                sched.faults,
                cols,
                window=window,
                suspects=iso.suspects[r],
            )
            events.append(evs)
            onset = min((ev.onset for ev in evs), default=None)
            k = N if onset is None else int(np.searchsorted(ctx.t, onset - 1e-12))
            fa = false_alarms(al[r], k)
            healthy[a + r] = fa.samples
            fa_counts[a + r] = fa.alarm_samples
            fa_events[a + r] = fa.events
        if keep_r:
            R_res[a:b] = res
            R_al[a:b] = al
            R_iso[a:b] = iso.isolated
        if store == "all":
            R_x[a:b] = from_balanced(ctx, raw.x)
            R_y[a:b] = raw.y
            R_yh[a:b] = raw.y_healthy
            R_u[a:b] = raw.u
        if bar is not None:
            bar.update(Rc)
    if bar is not None:
        bar.close()
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
