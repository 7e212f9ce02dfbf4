"""Monte-Carlo campaigns: seeds x fault sizes x onsets x plant models, on any executor.

A campaign enumerates its runs in a fixed order (model, scenario, size, onset, repetition)
and cuts them into **blocks** of at most ``block_size`` runs of one model, by ranges of
repetitions (:mod:`geomfdi.campaign.blocks`).  A block is
simulated and evaluated in one compiled pass over its runs
(:mod:`geomfdi.simulation.fused`, :mod:`geomfdi.campaign.fused_scoring`: the statistic
of a chi-square test and its scores and isolation without a pass through memory) when
that pass covers the campaign, decided once per campaign and model; otherwise in one
vectorised :func:`geomfdi.simulate_batch` call, evaluated with numpy.  The two give the
same table (decisions and detections identical, numbers to rounding).  The executor
only decides where blocks run (in this process, in local processes, on a Dask cluster)
and how many blocks one task carries.  Repetition ``r`` draws its noise from child ``r``
of ``SeedSequence(noise.seed)`` (common random numbers across sizes, onsets and models),
so a run's numbers depend on its index alone and the table is **bitwise identical** for
every executor and every grouping of blocks into tasks.  (With ``gf.simulate_batch``,
changing ``block_size`` itself may change the last bit of floating-point results: the
vectorised simulation of a different set of runs rounds differently; the fused pass
computes every run alone.)

Per run and residual (and for the bank: any residual), with the residual's statistic
``s`` normalised by its threshold (``z = s / h``, so ``z > 1`` is an alarm):

* ``score_pre``: ``max z`` over the window of length ``W`` before the onset
  (``[max(eval_start, onset - W), onset)``): a false alarm when > 1;
* ``score_post``: ``max z`` over the detection window ``[onset, onset + W)``: detected when
  > 1 (for size 0 this is again a false-alarm probability over ``W``);
* ``delay``: first alarm time in the detection window minus the onset (NaN if none).

Per run (for the bank), isolation: the alarms ``z > 1`` go through the campaign's
decision rule (:class:`geomfdi.Persistence`: k-of-n confirmation, the pattern held over
the alarm episode, settled decisions; none: per-sample decisions), and the first
decision in the detection window is compared with the true fault (the structure column
of the run's fault, several columns for simultaneous faults, none for size 0):

* ``decision``: the first decision (a fault index, ``MULTIPLE`` = -4, or -1 for none);
* ``truth``: the true column (``MULTIPLE`` for several faults, -1 for a fault-free run,
  -2 when no column of the bank models the fault);
* ``outcome``: 0 correct, 1 wrong, 2 none (a ``MULTIPLE`` decision is correct when its
  suspects are exactly the true faults; any decision in a fault-free run is wrong);
* ``iso_delay``: first time in the window with the correct decision minus the onset.

See the user guide, *Theory: residual evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads, work_threads
from geomfdi._validation import as_int, as_positive
from geomfdi.campaign.blocks import Block, cut_blocks, grid_order
from geomfdi.campaign.executors import RETRIES
from geomfdi.campaign.scoring import evaluate_runs, isolate_runs
from geomfdi.campaign.spec import Scenario, Uncertainty
from geomfdi.errors import GeomFDIError, ResourceLimitError
from geomfdi.limits import estimate_bytes

__all__ = ["Campaign", "TABLE_ROW_BYTES", "RETRIES", "evaluate_runs", "isolate_runs"]

TABLE_ROW_BYTES = 160
"""Bytes of one row of a campaign's table (one run and residual: its numbers, the
summary's copies), as used in the size estimate."""


def _as_test(test: Any, n_res: int) -> Any:
    from geomfdi.evaluation.statistics import AbsTest

    if hasattr(test, "statistic") and hasattr(test, "thresholds"):
        return test
    values = np.asarray(test, dtype=float)
    if values.ndim == 0:
        values = np.full(n_res, float(values))
    if values.shape != (n_res,) or np.any(values <= 0):
        raise GeomFDIError(
            f"test: expected a test object or {n_res} positive thresholds on |r|",
            argument="test",
        )
    return AbsTest(values)


def _signal_array(value: Any, t: np.ndarray, rows: int, name: str) -> np.ndarray | None:
    """A signal sampled on the grid (arrays pickle; closures need not)."""
    if value is None:
        return None
    arr = value(t) if callable(value) else value
    arr = np.asarray(arr, dtype=float)
    if arr.ndim == 1 and rows == 1:
        arr = arr[None]
    if arr.shape != (rows, t.size):
        raise GeomFDIError(f"{name}: expected shape ({rows}, {t.size})", argument=name)
    return arr


def _truth(
    faults: list[Any], size: float, design: Any, plant: Any, cache: dict[Any, Any]
) -> tuple[int, frozenset[int]]:
    """True structure column of a run: index, MULTIPLE, -1 (no fault) or -2 (unknown).

    ``cache`` keeps the column of each fault channel met (the signature match takes SVDs
    and a campaign meets the same few channels in every run).
    """
    from geomfdi.evaluation.decision import MULTIPLE
    from geomfdi.simulation.schedule import structure_columns

    if size == 0 or not faults:
        return -1, frozenset()
    cols = structure_columns(faults, design, plant, cache)
    if any(c is None for c in cols):
        return -2, frozenset()
    found = frozenset(int(c) for c in cols)
    if len(found) == 1:
        return next(iter(found)), found
    return MULTIPLE, found


def _run_block(
    job: dict[str, Any], block: Block, own_filters: bool = True
) -> dict[str, np.ndarray]:
    """Simulate and evaluate one block (runs in a worker).  ``own_filters=False``: the
    caller has set the warning filters of the campaign (blocks run on threads, which
    must not change the process's filters)."""
    from geomfdi.simulation.batch import simulate_batch

    root = job["seed_root"]
    # a repetition's seed, made once per process (a SeedSequence is not changed by
    # drawing from it; the runs of its other cells reuse it)
    memo = job["fused"].setdefault("seeds", {})
    seeds = []
    for r in block.repetition.tolist():
        sd = memo.get(r)
        if sd is None:
            sd = memo[r] = np.random.SeedSequence(
                entropy=root.entropy, spawn_key=(*root.spawn_key, r)
            )
        seeds.append(sd)
    scen = job["scenarios"]
    # one list per (scenario, size, onset), shared by its runs (nothing changes a list)
    cells: dict[tuple[int, float, float], list[Any]] = {}
    fault_lists = []
    for s, z, o in zip(block.scenario, block.size, block.onset, strict=True):
        cell = (int(s), float(z), float(o))
        if cell not in cells:
            cells[cell] = list(scen[cell[0]].faults(cell[1], cell[2]))
        fault_lists.append(cells[cell])
    test = job["test"]
    stat = None
    with _filters(job["perturbed"]) if own_filters else contextlib.nullcontext():
        plan = _fused_plan(job, block.model)
        if plan is not None and plan.window:
            # simulated and judged in one pass (None: a run diverged, or a rule the
            # compiled isolation does not take; then the statistic is judged below)
            from geomfdi.campaign.fused_scoring import fused_block

            truths = None
            if job["structure"] is not None:
                # the column of each fault channel, kept by the process for the campaign
                cache: dict[Any, Any] = job["fused"].setdefault("columns", {})
                known: dict[int, Any] = {}  # the runs of one cell share its list
                truths = []
                for fl, z in zip(fault_lists, block.size, strict=True):
                    if id(fl) not in known:
                        known[id(fl)] = _truth(
                            fl, float(z), job["design_faults"], job["nominal"], cache
                        )
                    truths.append(known[id(fl)])
            done = fused_block(
                job, plan, fault_lists, seeds, block.onset, truths, block.runs, DIVERGED_RATIO
            )
            if done is not None:
                return done
        if plan is not None:
            from geomfdi.simulation.fused import fused_runs
            from geomfdi.simulation.workspace import thread_workspace

            # the statistic in this thread's work array, reused block after block (the
            # table's columns computed from it are new arrays)
            shape = (len(seeds), plan.n_rows, plan.N)
            residuals = fused_runs(
                plan, fault_lists, seeds, thread_workspace("campaign").get("statistic", shape)
            )
            stat = residuals if plan.window else None
        elif job.get("system") is not None:
            residuals = _nonlinear_runs(job, fault_lists, seeds)
        else:
            residuals = simulate_batch(
                job["plants"][block.model],
                job["bank"],
                job["t"],
                job["u"],
                faults=fault_lists,
                noise=job["noise"],
                seeds=seeds,
                controller=job["controller"],
                d=job["d"],
                x0=job["x0"],
                hold=job["hold"],
                chunk_size=len(seeds),
                progress=False,
            ).residuals
    stat, diverged = cut_divergent(
        test.statistic(residuals) if stat is None else stat, test.thresholds
    )
    out = evaluate_runs(
        job["t"], stat, test.thresholds, block.onset, job["window"], job["eval_start"]
    )
    out["run"] = block.runs
    out["diverged"] = diverged
    structure = job["structure"]
    if structure is not None:
        cache: dict[Any, Any] = {}
        truths = [
            _truth(fl, float(z), job["design_faults"], job["nominal"], cache)
            for fl, z in zip(fault_lists, block.size, strict=True)
        ]
        out.update(
            isolate_runs(
                job["t"],
                stat,
                test.thresholds,
                structure,
                job["persistence"],
                np.array([tr for tr, _ in truths]),
                [ts for _, ts in truths],
                block.onset,
                job["window"],
                job["eval_start"],
            )
        )
    return out


@contextlib.contextmanager
def _filters(perturbed: bool) -> Iterator[None]:
    """The warning filters of a campaign's blocks: a bank designed on the nominal plant
    is not decoupled from a perturbed one (expected, and the point of the campaign: its
    residuals see the inputs)."""
    with warnings.catch_warnings():
        if perturbed:
            warnings.filterwarnings("ignore", message=".*not decoupled.*")
        yield


#: The noise draws a process keeps for a campaign's repetitions (their runs in every
#: other cell read them again), in units of ``gf.limits`` ``chunk_memory`` (4: 256 MiB
#: by default; the draws of 1000 repetitions of 10^4 samples on 3 sensors take 240 MB).
DRAW_CACHE_CHUNKS = 4

#: A statistic this many times its threshold (or non-finite) marks a run as diverged.
DIVERGED_RATIO = 1e6


def cut_divergent(statistic: np.ndarray, thresholds: Any) -> tuple[np.ndarray, np.ndarray]:
    """Runs ``(R, n, N)`` whose statistic turns non-finite or exceeds
    :data:`DIVERGED_RATIO` times its threshold: from that sample on the statistic is set to
    0 (no alarm, no decision, no score).  Returns the statistic and ``diverged`` (R,).

    A campaign keeps no plant states, so a run that a fault destabilises is recognised on
    its residuals (they grow with the state); :func:`geomfdi.simulate` judges the state.
    """
    thr = np.asarray(thresholds, dtype=float)
    lim = np.where(np.isfinite(thr), DIVERGED_RATIO * thr, np.inf)[:, None]
    # the usual case first: two reductions (nan propagates through max and min) show
    # that no run diverged, without the element-wise masks below
    hi, lo = statistic.max(axis=-1, initial=-np.inf), statistic.min(axis=-1, initial=np.inf)
    if (
        statistic.size
        and np.all(np.isfinite(hi) & np.isfinite(lo))
        and np.all(np.maximum(np.abs(hi), np.abs(lo)) <= lim[:, 0])
    ):
        return statistic, np.zeros(statistic.shape[0], dtype=bool)
    bad = ~np.isfinite(statistic) | (np.abs(statistic) > lim)
    bad = bad.any(axis=-2)  # (R, N)
    hit = bad.any(axis=-1)
    if not hit.any():
        return statistic, hit
    k = np.where(hit, np.argmax(bad, axis=-1), statistic.shape[-1])
    after = np.arange(statistic.shape[-1])[None, :] >= k[:, None]
    return np.where(after[:, None, :], 0.0, statistic), hit


def _nonlinear_runs(job: dict[str, Any], fault_lists: list[Any], seeds: list[Any]) -> np.ndarray:
    """Residuals ``(R, n, N)`` of a block on a nonlinear plant: one
    :func:`geomfdi.simulation.nonlinear.simulate_nonlinear` run per seed (a Python loop
    over samples; divergence shows as ``nan`` residuals, caught by :func:`cut_divergent`).
    """
    import dataclasses

    from geomfdi.simulation.nonlinear import DivergenceWarning, simulate_nonlinear

    out = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        for faults, seed in zip(fault_lists, seeds, strict=True):
            res = simulate_nonlinear(
                job["system"],
                job["bank"],
                job["t"],
                job["u"],
                faults=faults,
                x0=job["x0"],
                d=job["d"],
                noise=dataclasses.replace(job["noise"], seed=seed),
                controller=job["controller"],
            )
            out.append(res.residuals)
    return np.stack(out)


class PlanCache(dict):  # type: ignore[type-arg]
    """The fused plans of a campaign's models (:mod:`geomfdi.simulation.fused`), made in
    the process that runs the blocks: shipped to a worker, the cache travels empty."""

    def __reduce__(self) -> tuple[Any, tuple[()]]:
        return PlanCache, ()


def _fused_plan(job: dict[str, Any], model: int) -> Any:
    """The fused plan of ``model`` (made once per process), or ``None``: the campaign
    runs its blocks through :func:`geomfdi.simulate_batch` (the reason in the cache).

    Decided once per campaign and model from every fault list of the grid (one per
    scenario, size and onset, built with the job in the calling process: a worker
    builds only the lists of its own runs): a campaign whose faults, noise or plant
    the fused pass does not cover (:mod:`geomfdi.simulation.fused`) never uses it.
    """
    cache = job["fused"]
    if job.get("system") is not None:
        return None
    if model not in cache:
        from geomfdi.evaluation.statistics import ChiSquareTest
        from geomfdi.simulation.fused import fused_plan

        test = job["test"]
        chi2 = isinstance(test, ChiSquareTest) and type(test).statistic is ChiSquareTest.statistic
        plan, why = fused_plan(
            job["plants"][model],
            job["bank"],
            job["t"],
            job["u"],
            fault_lists=job["cell_faults"],
            noise=job["noise"],
            controller=job["controller"],
            d=job["d"],
            x0=job["x0"],
            hold=job["hold"],
            window=int(test.window) if chi2 else 0,
        )
        if plan is not None and len(job["cell_faults"]) > 1:
            # the draws of a repetition, made once per process for all its cells (common
            # random numbers), within DRAW_CACHE_CHUNKS times the chunk memory budget
            from geomfdi.limits import get_limits
            from geomfdi.simulation.draw_cache import DrawCache

            if "draws" not in cache:
                budget = DRAW_CACHE_CHUNKS * get_limits().chunk_memory
                if job.get("slots"):
                    # tasks run their blocks by ranges of repetitions (Campaign.blocks):
                    # the ranges of the tasks running in this process (at most one per
                    # task slot) and one more are all it reads again, and the memory of
                    # the draws dropped holds the next ones (no fresh pages)
                    per_range = job["block_size"] * plan.run_draw_bytes
                    budget = min(budget, (job["slots"] + 1) * per_range)
                cache["draws"] = DrawCache(budget)
            plan.draws = cache["draws"]
        cache[model] = plan
        cache[("why", model)] = why
    return cache[model]


def _prepare_blocks(job: dict[str, Any], blocks: Sequence[Block]) -> None:
    """The fused plans of the blocks' models, made before a task's timed work
    (:func:`geomfdi.campaign.executors.run_items`)."""
    with _filters(job["perturbed"]):
        for model in sorted({b.model for b in blocks}):
            _fused_plan(job, model)


_run_block.prepare = _prepare_blocks  # type: ignore[attr-defined]


@limit_blas_threads
def _run_serial(job: dict[str, Any], blocks: Sequence[Block], bar: Any) -> dict[int, list[Any]]:
    """The blocks in this process: one after the other, or, when every block runs
    through the fused pass and geomfdi may use several threads
    (:func:`geomfdi._threads.work_threads`), on as many threads, a block each (its
    set-up in Python overlaps another block's compiled pass; each block on one thread,
    so its numbers are those of the loop).  The plans are made first, here; the warning
    filters are set once around the threads (a thread must not change them)."""
    k = min(work_threads(), len(blocks))
    _prepare_blocks(job, blocks)
    cache = job["fused"]
    models = {b.model for b in blocks}
    if k > 1 and not all(cache.get(m) is not None and cache[m].window for m in models):
        k = 1  # blocks through simulate_batch: it splits each block itself
    done: dict[int, list[Any]] = {}
    order = list(range(len(blocks)))
    draws = cache.get("draws")
    plans = [cache.get(m) for m in models]
    if draws is not None and all(p is not None for p in plans):
        reps = max(int(b.repetition.max()) for b in blocks) + 1
        if reps * max(p.run_draw_bytes for p in plans) <= draws.budget:
            order = grid_order(blocks)  # every draw stays: geomfdi.campaign.blocks
    with contextlib.ExitStack() as stack:
        if k <= 1:
            outs: Iterator[Any] = (_run_block(job, blocks[i]) for i in order)
        else:
            from concurrent.futures import ThreadPoolExecutor

            stack.enter_context(_filters(job["perturbed"]))  # (left after the threads)
            pool = stack.enter_context(ThreadPoolExecutor(k))
            # k blocks run at once (the others wait in the queue: memory as in the
            # loop); an error cancels the blocks not begun
            outs = pool.map(lambda i: _run_block(job, blocks[i], False), order)
        for i, out in zip(order, outs, strict=True):
            done[i] = [out]
            if bar is not None:
                bar.update(1)
    return done


def _run_task(job: dict[str, Any], blocks: list[Block]) -> list[dict[str, np.ndarray]]:
    return [_run_block(job, b) for b in blocks]


def _pool(workers: int | None, shipped: Any) -> Any:
    """A process pool whose workers hold the job (installed once, by the initializer)."""
    from concurrent.futures import ProcessPoolExecutor

    from geomfdi.campaign.executors import install

    return ProcessPoolExecutor(max_workers=workers, initializer=install, initargs=(shipped,))


class Campaign:
    """A Monte-Carlo campaign over seeds, fault sizes, onsets and plant models.

    Parameters
    ----------
    plant : Plant
        Nominal plant (the bank is designed on it).
    bank : ResidualBank or ResidualGenerator
    scenarios : sequence of Scenario
    noise : Noise
        Noise model; its seed is the root of all run seeds.
    t : array_like
        Time grid of every run.
    uncertainty : Uncertainty, optional
        Plant models to simulate (default: the nominal plant only).
    runs : int
        Repetitions (noise seeds) per (model, scenario, size, onset).
    test : test object or thresholds
        Residual evaluation test with ``statistic(residuals)`` and ``thresholds`` (e.g.
        :class:`geomfdi.ChiSquareTest`, :class:`geomfdi.CusumTest`); numbers are fixed
        thresholds on ``|r|``.
    u, d : arrays or callables of t, optional
    controller : state-feedback gain or python-control system, optional
    x0 : array_like, optional
    detection_window : float, optional
        ``W`` (module docstring); default: from the earliest onset to the end.
    eval_start : float
        Samples before it are ignored (start-up transients).
    block_size : int
        Runs simulated together in one vectorised call.
    hold : {"foh", "zoh"}
    persistence : None, int, (k, n) or Persistence
        Decision rule of the isolation (module docstring); ``None``: per-sample decisions.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> p = gf.Plant([[-1.0]], [[1.0]], [[1.0]])
    >>> g = gf.ResidualGenerator([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], [[1.0]], [[0.0]])
    >>> c = gf.Campaign(p, g, [gf.Scenario.sensor("bias", 0, [0.0, 1.0], [1.0])],
    ...                 gf.Noise(measurement=0.1, seed=1), t=np.linspace(0, 2, 201),
    ...                 runs=20, test=0.5)
    >>> res = c.run()
    >>> float(res.summary().loc[("bias on sensor 0", 1.0, "bank"), "pd"])
    1.0
    """

    def __init__(
        self,
        plant: Any,
        bank: Any,
        scenarios: Sequence[Scenario],
        noise: Any,
        *,
        t: Any,
        uncertainty: Uncertainty | None = None,
        runs: int = 100,
        test: Any = None,
        u: Any = None,
        d: Any = None,
        controller: Any = None,
        x0: Any = None,
        detection_window: float | None = None,
        eval_start: float = 0.0,
        block_size: int = 64,
        hold: str = "foh",
        persistence: Any = None,
    ) -> None:
        from geomfdi.evaluation.persistence import as_persistence
        from geomfdi.model.plant import as_plant
        from geomfdi.simulation.noise import Noise
        from geomfdi.simulation.nonlinear import design_plant, is_nonlinear

        #: a python-control nonlinear plant (None: linear); it must pickle for workers
        self.system = plant if is_nonlinear(plant) else None
        if self.system is not None and uncertainty is not None:
            raise GeomFDIError(
                "uncertainty: not available for a nonlinear plant (perturb its parameters "
                "and run one campaign per model)",
                argument="uncertainty",
            )
        self.plant = as_plant(plant) if self.system is None else design_plant(plant, bank)
        self.bank = bank
        gens = bank.generators if hasattr(bank, "generators") else [bank]
        self.n_residuals = len(gens)
        structure = getattr(bank, "structure", None)
        self.structure = None if structure is None else np.asarray(structure, dtype=bool)
        self.fault_labels = (
            []
            if structure is None
            else [
                getattr(f, "name", None) or f"fault {j}"
                for j, f in enumerate(getattr(bank, "faults", [None] * self.structure.shape[1]))
            ]
        )
        self.persistence = as_persistence(persistence)
        self.scenarios = list(scenarios)
        if not self.scenarios or not all(isinstance(s, Scenario) for s in self.scenarios):
            raise GeomFDIError(
                "scenarios: expected a non-empty list of Scenario", argument="scenarios"
            )
        if not isinstance(noise, Noise):
            raise GeomFDIError("noise: expected a geomfdi Noise", argument="noise")
        self.noise = noise
        self.t = np.asarray(t, dtype=float)
        if self.t.ndim != 1 or self.t.size < 2:
            raise GeomFDIError("t: expected a time grid of at least 2 samples", argument="t")
        self.uncertainty = uncertainty
        self.runs = as_int(runs, "runs", minimum=1)
        if test is None:
            raise GeomFDIError("test: a test or thresholds are needed", argument="test")
        self.test = _as_test(test, self.n_residuals)
        self.u = _signal_array(u, self.t, self.plant.m, "u")
        if self.system is None:
            self.d = _signal_array(d, self.t, self.plant.nd, "d")
        else:  # the system's other inputs, by name or in order (see simulate_nonlinear)
            self.d = d
        self.controller = controller
        self.x0 = x0
        first = min(min(s.onsets) for s in self.scenarios)
        self.window = (
            float(self.t[-1] - first + (self.t[1] - self.t[0]))
            if detection_window is None
            else as_positive(detection_window, "detection_window")
        )
        self.eval_start = float(eval_start)
        if not self.eval_start < first:
            raise GeomFDIError(
                f"eval_start: {self.eval_start!r} must be before the first of the onsets "
                f"({first!r})",
                argument="eval_start",
            )
        self.block_size = as_int(block_size, "block_size", minimum=1)
        self.hold = hold
        self.estimate = self._check_size()  # before the plant models are drawn
        self.plants = [self.plant] if uncertainty is None else uncertainty.plants(self.plant)

    def _check_size(self) -> float:
        """Refuse a campaign over the caps of :mod:`geomfdi.limits` before any work: its
        runs (models x scenarios x sizes x onsets x ``runs``) against ``max_runs``, the
        estimated memory of its table and of one block's simulation against
        ``max_memory``.  Returns the estimate in bytes."""
        from geomfdi.limits import check_allocation, check_runs, format_bytes

        unc = self.uncertainty
        models = 1 if unc is None else len(unc.models) if unc.models is not None else unc.samples
        cells = sum(len(s.sizes) * len(s.onsets) for s in self.scenarios)
        total = models * cells * self.runs
        try:
            check_runs(total, argument="runs")
        except ResourceLimitError as exc:
            table = estimate_bytes(total, 1, self.n_residuals + 1, itemsize=TABLE_ROW_BYTES)
            raise ResourceLimitError(
                f"runs: the campaign has {models} model(s) x {cells} (scenario, size, onset) "
                f"x {self.runs} runs = {total} runs, its table about {format_bytes(table)}; "
                f"{exc}",
                limit="max_runs",
                estimate=table,
                argument="runs",
            ) from exc
        table = check_allocation(
            total,
            1,
            self.n_residuals + 1,
            itemsize=TABLE_ROW_BYTES,
            argument="runs",
            what="campaign table",
        )
        states = self.plant.n + self.plant.q + self.plant.m + 2 * self.n_residuals
        block = check_allocation(
            self.t.size,
            min(self.block_size, total),
            states,
            copies=4,
            argument="t",
            runs_argument="block_size",
            what="campaign block",
        )
        return table + block

    # ------------------------------------------------------------------ the grid
    def grid(self) -> dict[str, np.ndarray]:
        """Run index -> model, scenario, size, onset, repetition (the fixed order)."""
        cols: dict[str, list[Any]] = {k: [] for k in ("model", "scenario", "size", "onset")}
        for mi in range(len(self.plants)):
            for si, sc in enumerate(self.scenarios):
                for z in sc.sizes:
                    for o in sc.onsets:
                        cols["model"].append(mi)
                        cols["scenario"].append(si)
                        cols["size"].append(z)
                        cols["onset"].append(o)
        R = self.runs
        out = {k: np.repeat(np.asarray(v), R) for k, v in cols.items()}
        out["repetition"] = np.tile(np.arange(R), len(cols["model"]))
        out["run"] = np.arange(out["repetition"].size)
        return out

    def blocks(self) -> list[Block]:
        """The grid cut into blocks of at most ``block_size`` runs of one model, by
        ranges of ``block_size`` repetitions (:mod:`geomfdi.campaign.blocks`)."""
        return cut_blocks(self.grid(), self.block_size)

    def _job(self) -> dict[str, Any]:
        seed = self.noise.seed
        root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        return {
            "system": self.system,
            "plants": self.plants,
            "bank": self.bank,
            "t": self.t,
            "u": self.u,
            "d": self.d,
            "noise": self.noise,
            "controller": self.controller,
            "x0": self.x0,
            "hold": self.hold,
            "test": self.test,
            "window": self.window,
            "eval_start": self.eval_start,
            "scenarios": self.scenarios,
            "seed_root": root,
            "perturbed": self.uncertainty is not None,
            "structure": self.structure,
            "nominal": self.plant,
            "design_faults": list(getattr(self.bank, "faults", [])),
            "persistence": self.persistence,
            "block_size": self.block_size,
            "slots": 0,  # tasks at once on the executor's workers (Campaign.run)
            "fused": PlanCache(),
            "cell_faults": [
                list(sc.faults(float(z), float(o)))
                for sc in self.scenarios
                for z in sc.sizes
                for o in sc.onsets
            ],
        }

    # ------------------------------------------------------------------- running
    def _partial(self, done: dict[int, list[dict[str, np.ndarray]]]) -> Any:
        """The table of the runs done (a :class:`CampaignResult` marked incomplete)."""
        from geomfdi.campaign.result import CampaignResult

        parts = [p for i in sorted(done) for p in done[i]]
        return CampaignResult.from_parts(self, parts, partial=True) if parts else None

    def run(
        self,
        executor: Any = "serial",
        *,
        workers: int | None = None,
        blocks_per_task: int | str = "auto",
        progress: bool | None = None,
    ) -> Any:
        """Run every block and collect the table (a :class:`CampaignResult`).

        The job (models, bank, test, time grid, inputs, scenarios) goes once to every
        worker and a task carries only its blocks (:mod:`geomfdi.campaign.executors`).

        Parameters
        ----------
        executor : "serial", "processes", a ``concurrent.futures.Executor`` or a
            ``distributed.Client``
            Where the tasks run.  ``"processes"`` starts a local
            :class:`concurrent.futures.ProcessPoolExecutor` with ``workers`` processes for
            this call.  Any object with ``submit(fn, *args)`` returning a future with
            ``result()`` works (a Dask client: install ``geomfdi[dask]``; a local one
            with settings for throughput: :func:`~geomfdi.campaign.executors.local_dask_client`).
        workers : int, optional
        blocks_per_task : int or "auto"
            Blocks carried by one task (does not change the results); ``"auto"``: tasks
            that shrink toward the end (large first, for few round trips; small last,
            so that the workers finish together), none so small that its overhead,
            measured on the first tasks, is over 10 % of it, but the last few, which
            shrink on to one block
            (:func:`geomfdi.campaign.executors.guided_spans`,
            :func:`~geomfdi.campaign.executors.task_size`).
        progress : bool, optional
            tqdm bar over the blocks (default: when stderr is a terminal).

        Returns
        -------
        CampaignResult
            Its ``info["executor"]`` holds what the run measured: tasks, blocks per task
            (with ``"auto"``: the median task, and ``least_blocks_per_task``), the
            compute seconds of the tasks (in the workers), and with ``"auto"`` the block
            time and the per-task overhead that sized the tasks.
        """
        import sys

        from geomfdi.campaign.executors import execute, worker_slots
        from geomfdi.campaign.result import CampaignResult

        per = (
            None
            if isinstance(blocks_per_task, str) and blocks_per_task == "auto"
            else as_int(blocks_per_task, "blocks_per_task", minimum=1)
        )
        blocks = self.blocks()
        job = self._job()
        if progress is None:
            progress = sys.stderr.isatty()
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(blocks), desc="campaign", unit="block", leave=False)
        try:
            if isinstance(executor, str) and executor == "serial":
                done = _run_serial(job, blocks, bar)
                stats: dict[str, Any] = {"tasks": len(blocks), "items_per_task": 1}
            elif isinstance(executor, str) and executor != "processes":
                raise GeomFDIError(
                    f"executor: 'serial', 'processes' or an executor, got {executor!r}",
                    argument="executor",
                )
            elif not isinstance(executor, str) and not hasattr(executor, "submit"):
                raise GeomFDIError("executor: has no submit method", argument="executor")
            else:
                own = isinstance(executor, str)  # "processes": a pool for this call
                slots = (workers or os.cpu_count() or 1) if own else worker_slots(executor)
                job["slots"] = slots
                done, stats = execute(
                    None if own else executor,
                    _run_block,
                    job,
                    blocks,
                    per=per,
                    bar=bar,
                    new_pool=(lambda shipped: _pool(workers, shipped)) if own else None,
                    partial=self._partial,
                )
        finally:
            if bar is not None:
                bar.close()
        parts = [p for i in sorted(done) for p in done[i]]
        result = CampaignResult.from_parts(self, parts)
        stats["blocks_per_task"] = stats.pop("items_per_task")
        if "least_items_per_task" in stats:
            stats["least_blocks_per_task"] = stats.pop("least_items_per_task")
        result.info["executor"] = stats
        return result
