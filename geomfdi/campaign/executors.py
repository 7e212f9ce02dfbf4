"""Where a campaign's blocks run: the job shipped once per worker, tasks sized from the
measured block time, lost workers retried.

**Shipping.**  A campaign's *job* (the plant models, the bank, the test, the time grid
and inputs, the scenarios: everything a block needs besides its runs) is the same for
every task.  It is pickled once in the calling process and unpickled at most once in
every worker process:

* a Dask client: the job is scattered to every worker (``broadcast=True``) and a task
  names it by its future;
* ``"processes"``: the pool's initializer installs the job in every worker process (a
  forked worker inherits it without any pickling) and a task names it by its key;
* any other executor (a ``ProcessPoolExecutor`` of the caller, ...): a task carries the
  job's pickle, made once; a worker process unpickles it the first time it meets its key
  and reuses it for the following tasks (a thread pool passes the object itself).

A task then carries only its blocks (the indices of its runs with their scenario, size,
onset and repetition: a few kB) and brings back the table numbers of its runs (scores,
delays, isolation; never residuals or statistics).  A Dask task's outcome is fetched
as soon as the task finishes (by the client's event loop, while the workers compute the
other tasks: only the last task's transfer is left once the work is done; a final
``gather`` of every result took 0.03-0.06 s of a 2 s campaign), as one pickle
(:func:`run_packed`): Dask would otherwise serialise every array of every block's
outcome as a frame of its own.

**Task size** (``blocks_per_task="auto"``).  A task costs its blocks' compute time plus
a fixed overhead ``o`` (submitting, scheduling, shipping the blocks and the results).
The first ``3 W`` tasks (``W`` worker slots, :data:`FIRST_TASKS_PER_SLOT`) carry one block
each (every worker still has one to run while the client sizes and submits the others:
with ``2 W``, a Dask worker waited 30-70 ms for its third task); the first one to
finish gives the block's compute time ``b`` (measured in the worker) and ``o`` (its
round trip minus ``b`` and minus the worker's one-time set-up for the job, unpickling it
and building its plans, which later tasks do not pay; at least :data:`MIN_OVERHEAD`).
The remaining ``B`` blocks go into tasks that shrink toward the end
(:func:`guided_spans`, guided self-scheduling): each takes ``ceil(R / (2 W))`` of the
``R`` blocks still unassigned, but at least the :func:`task_size` of the overhead, the
fewest blocks for which ``o`` is at most :data:`OVERHEAD_SHARE` (10 %) of the task's
compute time (``ceil(o / (0.1 b))``, no more than ``B / (TASKS_PER_WORKER W)``), until
``W`` such tasks are all that is left: those shrink on to one block.  The first tasks
are large (few round trips), the last ones small, so that the slots finish together
(the last task of the slowest worker keeps the others idle for about one block); a
fixed size balancing as well would need about :data:`TASKS_PER_WORKER` times more
tasks.  ``o`` is the whole round trip, which a worker pays once at the end only (its
next task is queued while it computes): with Dask it is 10-40 ms, mostly the
scheduler's dispatch, so the least size is 4-7 blocks of about 60 ms while the gap
between a worker's tasks is 3-7 ms; ending on tasks of that size left a slot idle for up
to 140 ms.  The tasks are submitted in that order, the large first.  The grouping never
changes the table (a run's numbers depend on its index only, see
:mod:`geomfdi.campaign.runner`).

**Worker set-up.**  A task runs with the BLAS limited to ``gf.get_blas_threads()`` (one)
thread.  A Dask worker's default environment sets ``MALLOC_TRIM_THRESHOLD_`` (so that
freed memory goes back to the system), which also switches off glibc's adaptive
``mmap`` threshold: every array over 128 kiB is then a fresh ``mmap`` whose pages are
faulted in again on first write, which makes the vectorised simulation of a block 2-2.5
times slower than in a plain process.  While a task runs, the thresholds are raised to
the values glibc adapts to by itself (``M_MMAP_THRESHOLD`` 32 MiB, the trim threshold
64 MiB); they are restored and the free memory handed back (``malloc_trim``) once the
process has run no task for :data:`ALLOCATOR_IDLE` seconds (restoring after every task
made the next one fault its arrays in again: with one block per task, a campaign of 157
tasks on 2 workers took 3.1 s against 2.5 s, medians of four runs).  Nothing is changed
on other C libraries, when ``MALLOC_MMAP_THRESHOLD_`` is set too, or when
``MALLOC_TRIM_THRESHOLD_`` is not set.
"""

from __future__ import annotations

import functools
import math
import numbers
import os
import pickle
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager, nullcontext
from typing import Any

from geomfdi._threads import limit_blas_threads, using_work_threads
from geomfdi.errors import CampaignIncompleteError, GeomFDIError

__all__ = [
    "ALLOCATOR_IDLE",
    "DASK_THROUGHPUT",
    "FIRST_TASKS_PER_SLOT",
    "MIN_OVERHEAD",
    "OVERHEAD_SHARE",
    "RETRIES",
    "TASKS_PER_WORKER",
    "Shipped",
    "allocator_for_arrays",
    "execute",
    "guided_spans",
    "install",
    "local_dask_client",
    "lost_worker",
    "run_items",
    "run_packed",
    "task_size",
    "worker_slots",
]

RETRIES = 2
"""Times the tasks of a lost worker are run again (on a fresh process pool, or with the
job shipped again to a Dask cluster) before the campaign gives up."""

OVERHEAD_SHARE = 0.1
"""Largest share of a task's compute time its fixed overhead may take (when the
balance between workers allows)."""

TASKS_PER_WORKER = 4
"""Tasks per worker slot that the task size keeps at least (when there are blocks for
them)."""

FIRST_TASKS_PER_SLOT = 3
"""One-block tasks per worker slot submitted first, before the task size is known."""

MIN_OVERHEAD = 2e-3
"""Seconds of per-task overhead assumed at least (a measured round trip can be shorter
than the task's compute time measured in the worker: clock granularity, queueing)."""

DASK_THROUGHPUT: dict[str, Any] = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
}
"""Dask settings for a cluster that runs campaigns: ``dask.config.set(DASK_THROUGHPUT)``
in force while the cluster lives (as in :func:`local_dask_client`), or the same in a
Dask configuration file (a worker started again after a loss reads them anew).

By default every worker samples its task thread's stack every 10 ms for the dashboard's
profile, and every Dask server checks its event loop every 20 ms: an idle
``LocalCluster`` of two workers took 0.16 of a core (0.066 in the calling process,
which holds the scheduler and the nannies, and 0.05 in each worker), 8 % of a two-core
machine taken from the campaign's workers.  Without the profiler and with the event-loop
check once a second: 0.04 of a core.  What is lost: the dashboard's profile page, and a
blocked event loop is noticed after a second instead of 20 ms."""

_LOST = {
    "BrokenProcessPool",
    "BrokenExecutor",
    "CancelledError",
    "FutureCancelledError",
    "KilledWorker",
    "CommClosedError",
}


@contextmanager
def local_dask_client(workers: int, settings: dict[str, Any] | None = None) -> Iterator[Any]:
    """A ``distributed.Client`` of a ``LocalCluster`` of ``workers`` single-threaded
    worker processes under the Dask configuration ``settings`` (default
    :data:`DASK_THROUGHPUT`; ``{}``: Dask's own), closed with the cluster on exit (the
    settings are in force in this process until then).

    Raises :class:`~geomfdi.errors.GeomFDIError` for ``workers`` not a positive integer,
    ``ImportError`` without the ``distributed`` package (``geomfdi[dask]``).

    Examples
    --------
    >>> with gf.local_dask_client(2) as client:  # doctest: +SKIP
    ...     result = campaign.run(client)
    """
    if isinstance(workers, bool) or not isinstance(workers, numbers.Integral) or workers < 1:
        raise GeomFDIError(
            f"workers: expected a positive integer, got {workers!r}", argument="workers"
        )
    import dask
    from distributed import Client, LocalCluster

    # in force while the cluster lives: a worker started again after a loss reads them
    # then (its nanny keeps a shallow copy of the configuration, which a set that has
    # ended no longer holds)
    with (
        dask.config.set(DASK_THROUGHPUT if settings is None else settings),
        LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster, set_as_default=False) as client,
    ):
        yield client


def lost_worker(exc: BaseException) -> bool:
    """Whether ``exc`` says that a task's worker was lost (not that the task failed)."""
    return any(cls.__name__ in _LOST for cls in type(exc).__mro__)


# --------------------------------------------------------------------------- task size
def task_size(
    blocks: int,
    workers: int,
    block_seconds: float,
    overhead: float,
    *,
    share: float = OVERHEAD_SHARE,
    tasks_per_worker: int = TASKS_PER_WORKER,
) -> int:
    """Blocks per task: ``min(ceil(o / (share b)), floor(B / (k W)))``, at least 1.

    Parameters
    ----------
    blocks : int
        ``B``, the blocks to group into tasks.
    workers : int
        ``W``, the worker slots (processes, or Dask threads) running tasks at once.
    block_seconds : float
        ``b``, compute time of one block in a worker.
    overhead : float
        ``o``, fixed cost of one task (submitting, scheduling, shipping blocks and results).
    share : float
        Largest ``o / (blocks per task * b)`` wanted (0.1).
    tasks_per_worker : int
        ``k``: tasks per slot kept at least, so that the slots finish together.

    Examples
    --------
    >>> task_size(1000, 2, 0.5, 0.005)      # long blocks: one block is plenty
    1
    >>> task_size(1000, 2, 0.001, 0.005)    # 1 ms blocks, 5 ms overhead: 50 blocks a task
    50
    >>> task_size(40, 2, 0.001, 0.005)      # few short blocks: 4 tasks per worker win
    5
    """
    need = math.ceil(overhead / (share * block_seconds)) if block_seconds > 0 else blocks
    most = blocks // (tasks_per_worker * max(1, workers))
    return max(1, min(need, most))


def guided_spans(start: int, stop: int, workers: int, least: int) -> list[tuple[int, int]]:
    """The items ``start .. stop-1`` in consecutive spans that shrink toward the end:
    each takes ``ceil(R / (2 workers))`` of the ``R`` items left (guided self-scheduling,
    Polychronopoulos & Kuck 1987, with a factor of two), at least ``least`` while more
    than ``workers * least`` are left; the last ones shrink on to one item, so that the
    workers finish within about one item of each other (a worker has its next task
    queued while it computes, so a task's round trip is paid at the end only).

    Examples
    --------
    >>> guided_spans(0, 40, 2, 3)
    [(0, 10), (10, 18), (18, 24), (24, 28), (28, 31), (31, 34), (34, 36), (36, 37), (37, 38), (38, 39), (39, 40)]
    """  # noqa: E501
    spans, a = [], start
    workers, least = max(1, int(workers)), max(1, int(least))
    while a < stop:
        left = stop - a
        floor = least if left > workers * least else 1
        size = min(left, max(floor, -(-left // (2 * workers))))
        spans.append((a, a + size))
        a += size
    return spans


def worker_slots(executor: Any) -> int:
    """Tasks ``executor`` runs at once: a Dask client's worker threads, a
    ``concurrent.futures`` pool's ``max_workers``; otherwise the machine's CPUs."""
    nthreads = getattr(executor, "nthreads", None)
    if callable(nthreads):
        try:
            total = sum(int(v) for v in nthreads().values())
        except Exception:  # an object with another ``nthreads``: not a Dask client
            total = 0
        if total > 0:
            return total
    slots = getattr(executor, "_max_workers", None)
    if isinstance(slots, int) and slots > 0:
        return slots
    return os.cpu_count() or 1


# ------------------------------------------------------------------------- shipping
class Shipped:
    """A job pickled once in this process and unpickled at most once per worker process.

    Pickling a :class:`Shipped` gives the job's pickle (made on the first call, then
    reused) with its key, or its key alone (:meth:`by_key`, for workers where the job
    was installed by :func:`install`).  A worker keeps the last jobs it met by key.
    """

    def __init__(self, job: Any, key: str | None = None, data: bytes | None = None) -> None:
        self.job = job
        self.key = key or uuid.uuid4().hex
        self._data = data
        self._by_key = False

    def data(self) -> bytes:
        """The job's pickle (``cloudpickle`` when installed, as Dask would use)."""
        if self._data is None:
            try:
                import cloudpickle
            except ImportError:  # pragma: no cover - distributed brings cloudpickle
                dumps: Callable[..., bytes] = pickle.dumps
            else:
                dumps = cloudpickle.dumps
            self._data = dumps(self.job, protocol=pickle.HIGHEST_PROTOCOL)
        return self._data

    def by_key(self) -> Shipped:
        """The same job, pickled as its key only."""
        ref = Shipped(self.job, self.key, self._data)
        ref._by_key = True
        return ref

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        if self._by_key:
            return _lookup, (self.key,)
        return _unpack, (self.key, self.data())


_JOBS: dict[str, Shipped] = {}  # in a worker process: the last jobs met, by key
_KEEP = 2


def _remember(shipped: Shipped) -> Shipped:
    _JOBS.pop(shipped.key, None)
    _JOBS[shipped.key] = shipped
    while len(_JOBS) > _KEEP:
        _JOBS.pop(next(iter(_JOBS)))
    return shipped


_unpacking = threading.local()  # seconds spent unpickling a job for the next task


def _unpack(key: str, data: bytes) -> Shipped:
    hit = _JOBS.get(key)
    if hit is None:
        t0 = time.perf_counter()
        hit = _remember(Shipped(pickle.loads(data), key, data))
        _unpacking.seconds = getattr(_unpacking, "seconds", 0.0) + time.perf_counter() - t0
    return hit


def _lookup(key: str) -> Shipped:
    hit = _JOBS.get(key)
    if hit is None:
        raise GeomFDIError(
            "executor: the campaign's job is not installed in this worker process",
            argument="executor",
        )
    return hit


def install(shipped: Shipped) -> None:
    """Pool initializer: keep ``shipped`` in this worker process."""
    _remember(shipped)


# ------------------------------------------------------------------ worker set-up
M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameters (malloc.h)
_MMAP_DEFAULT = 128 * 1024  # glibc's fixed mmap threshold once the trim threshold is set
_RAISED = {M_MMAP_THRESHOLD: 32 * 1024 * 1024, M_TRIM_THRESHOLD: 64 * 1024 * 1024}
_alloc_lock = threading.Lock()
_alloc_users = 0
_alloc_raised = False
_alloc_timer: threading.Timer | None = None

ALLOCATOR_IDLE = 0.5
"""Seconds without a running task after which a worker's own allocator thresholds are
restored (:func:`allocator_for_arrays`)."""


@functools.cache
def _glibc() -> Any:
    """glibc's ``mallopt`` and ``malloc_trim``, typed once (None on other C libraries)."""
    import ctypes

    from geomfdi._libc import is_glibc, libc

    lib = libc() if is_glibc() else None
    if lib is None:
        return None
    try:
        lib.mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
        lib.malloc_trim.argtypes = [ctypes.c_size_t]
    except AttributeError:  # pragma: no cover - an unusual libc
        return None
    return lib


def _fixed_trim_threshold() -> int | None:
    """The trim threshold set by the environment when it also fixed the mmap threshold
    at glibc's 128 kiB (the Dask worker's default), else None."""
    if "MALLOC_MMAP_THRESHOLD_" in os.environ:
        return None
    try:
        return int(os.environ["MALLOC_TRIM_THRESHOLD_"])
    except (KeyError, ValueError):
        return None


@contextmanager
def allocator_for_arrays() -> Any:
    """Run with glibc's adaptive-like thresholds where the environment fixed them
    (module docstring); the first task in a process raises them, and they are restored
    :data:`ALLOCATOR_IDLE` seconds after the last one ended, unless another task began
    meanwhile (back-to-back tasks keep their memory: a restore hands the free heap back
    and the next task faults it in again)."""
    global _alloc_users, _alloc_timer, _alloc_raised
    trim = _fixed_trim_threshold()
    libc = _glibc() if trim is not None else None
    if libc is None:
        yield
        return
    with _alloc_lock:
        _alloc_users += 1
        if _alloc_timer is not None:
            _alloc_timer.cancel()
            _alloc_timer = None
        if not _alloc_raised:
            for param, value in _RAISED.items():
                libc.mallopt(param, value)
            _alloc_raised = True
    try:
        yield
    finally:
        with _alloc_lock:
            _alloc_users -= 1
            if _alloc_users == 0:
                if ALLOCATOR_IDLE > 0:
                    _alloc_timer = threading.Timer(ALLOCATOR_IDLE, _restore, (libc, trim))
                    _alloc_timer.daemon = True
                    _alloc_timer.start()
                else:
                    _restore_locked(libc, trim)


def _restore(libc: Any, trim: int) -> None:
    with _alloc_lock:
        _restore_locked(libc, trim)


def _restore_locked(libc: Any, trim: int) -> None:
    """The environment's thresholds back and the free memory handed back, when no task
    runs (a task that began after the timer fired keeps the raised thresholds)."""
    global _alloc_raised, _alloc_timer
    if _alloc_users == 0 and _alloc_raised:
        libc.mallopt(M_MMAP_THRESHOLD, _MMAP_DEFAULT)
        libc.mallopt(M_TRIM_THRESHOLD, trim)
        libc.malloc_trim(0)
        _alloc_raised = False
    _alloc_timer = None


@limit_blas_threads
def run_items(
    work: Callable[[Any, Any], Any], shipped: Any, items: Sequence[Any]
) -> tuple[list[Any], float, float]:
    """``[work(job, item) for item in items]`` in a worker, its compute seconds and the
    seconds of the task's one-time set-up.

    ``shipped`` is a :class:`Shipped` (or, in this process, the job itself).  When
    ``work`` has a ``prepare(job, items)`` attribute it runs first, untimed: the set-up
    a process makes once and keeps for the job's later tasks (a campaign's fused plans,
    :mod:`geomfdi.campaign.runner`), so that the first task's time, which sizes the
    others, is what a task costs.  The set-up seconds (``prepare``, and unpickling the
    job when this task brought it to the process) are returned apart: the first task's
    round trip minus both is the per-task overhead (:func:`execute`).
    """
    job = shipped.job if isinstance(shipped, Shipped) else shipped
    setup = getattr(_unpacking, "seconds", 0.0)
    _unpacking.seconds = 0.0
    # a worker process (the job came shipped) shares the cores with the other workers:
    # no threads of its own (geomfdi._threads.work_threads)
    alone = using_work_threads(1) if isinstance(shipped, Shipped) else nullcontext()
    prepare = getattr(work, "prepare", None)
    with allocator_for_arrays(), alone:
        t0 = time.perf_counter()
        if prepare is not None:
            prepare(job, items)
        t1 = time.perf_counter()
        out = [work(job, item) for item in items]
        return out, time.perf_counter() - t1, setup + t1 - t0


def run_packed(
    work: Callable[[Any, Any], Any], shipped: Any, items: bytes | Sequence[Any]
) -> tuple[bytes, float, float]:
    """:func:`run_items` with the items (when ``bytes``) and the outcomes as one pickle
    each (a Dask task: its arguments and its result then travel as one frame, not one
    frame per array: submitting a task of 38 blocks took 19-38 ms, against about 1)."""
    if isinstance(items, bytes):
        items = pickle.loads(items)
    out, seconds, setup = run_items(work, shipped, items)
    return pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL), seconds, setup


# ------------------------------------------------------------------------ running
def _spans(start: int, stop: int, per: int) -> list[tuple[int, int]]:
    return [(a, min(a + per, stop)) for a in range(start, stop, per)]


class _Round:
    """One pass over the pending spans of items on one executor."""

    def __init__(self, executor: Any, work: Any, ref: Any, items: Sequence[Any], bar: Any):
        self.executor, self.work, self.ref, self.items, self.bar = executor, work, ref, items, bar
        self.futures: list[tuple[tuple[int, int], Any, float]] = []
        self.lost: list[tuple[int, int]] = []
        self.why = ""
        self.seconds: list[float] = []
        self.overheads: list[float] = []
        # a Dask client: outcomes come back pickled (run_packed, module docstring)
        self.run = run_packed if hasattr(executor, "scatter") else run_items

    def submit(self, span: tuple[int, int]) -> None:
        a, b = span
        items: Any = self.items[a:b]
        if self.run is run_packed:
            items = pickle.dumps(items, protocol=pickle.HIGHEST_PROTOCOL)
        try:
            fut = self.executor.submit(self.run, self.work, self.ref, items)
        except Exception as exc:
            if not lost_worker(exc):
                raise
            self.lost.append(span)
            self.why = f"{type(exc).__name__}: {exc}"
            return
        self.futures.append((span, fut, time.perf_counter()))

    def _failed(self, span: tuple[int, int], exc: BaseException) -> None:
        if not lost_worker(exc):
            raise exc
        self.lost.append(span)
        self.why = f"{type(exc).__name__}: {exc}"

    def _store(
        self,
        k: int,
        out: list[Any] | bytes,
        seconds: float,
        setup: float,
        done: dict[int, list[Any]],
    ) -> None:
        span, _, t0 = self.futures[k]
        if isinstance(out, bytes):  # (run_packed)
            out = pickle.loads(out)
        if k == 0:
            self.overheads.append(time.perf_counter() - t0 - seconds - setup)
        self.seconds.append(seconds)
        done[span[0]] = out
        if self.bar is not None:
            self.bar.update(span[1] - span[0])

    def collect(self, k: int, done: dict[int, list[Any]]) -> None:
        """The outcome of task ``k`` (waiting for it)."""
        span, fut, _ = self.futures[k]
        try:
            out, seconds, setup = fut.result()
        except Exception as exc:
            self._failed(span, exc)
            return
        self._store(k, out, seconds, setup, done)

    def collect_from(self, start: int, done: dict[int, list[Any]]) -> None:
        """The outcomes of tasks ``start, ...``: one by one, or for Dask futures in the
        order they finish, each fetched by the client's event loop while the workers
        compute the others (only the last task's transfer is left at the end)."""
        ks = range(start, len(self.futures))
        if not ks:
            return
        if not type(self.futures[start][1]).__module__.startswith("distributed"):
            for k in ks:
                self.collect(k, done)
            return
        from distributed import as_completed

        index = {self.futures[k][1].key: k for k in ks}
        futs = [self.futures[k][1] for k in ks]
        # the futures' own client's loop: the client need not be the default one
        loop = futs[0].client.loop
        for fut, res in as_completed(futs, loop=loop, with_results=True, raise_errors=False):
            k = index[fut.key]
            if fut.status != "finished":  # an error, a lost or recomputed task
                self.collect(k, done)
            else:
                self._store(k, *res, done)


def execute(
    executor: Any,
    work: Callable[[Any, Any], Any],
    job: Any,
    items: Sequence[Any],
    *,
    per: int | None = None,
    bar: Any = None,
    new_pool: Callable[[Shipped], Any] | None = None,
    partial: Callable[[dict[int, list[Any]]], Any] | None = None,
) -> tuple[dict[int, list[Any]], dict[str, Any]]:
    """Run ``work(job, item)`` for every item on ``executor``, in tasks of ``per`` items
    (``None``: sized by :func:`task_size` after the first task, module docstring).

    Returns the outcomes by the index of each task's first item, and what the run
    measured: ``tasks``, ``items_per_task``, ``block_seconds`` (the first task's compute
    time per item), ``task_overhead`` (its round trip minus its compute time),
    ``compute_seconds`` (summed over the tasks, measured in the workers).  With
    ``new_pool`` (``"processes"``), the pool is made here with the job installed in its
    workers, and made again after a lost worker.  Workers lost ``RETRIES + 1`` times
    raise :class:`~geomfdi.errors.CampaignIncompleteError` with ``partial(done)``.
    """
    shipped = Shipped(job)
    own = new_pool(shipped) if new_pool is not None else None
    ex = own if own is not None else executor
    done: dict[int, list[Any]] = {}
    stats: dict[str, Any] = {"tasks": 0, "compute_seconds": 0.0}
    spans = None if per is None else _spans(0, len(items), per)
    try:
        for attempt in range(RETRIES + 1):
            if own is not None:
                ref: Any = shipped.by_key()
            elif hasattr(ex, "scatter"):  # a Dask client: the job once to every worker
                # (a fresh key: a campaign run twice, or a retry, must not share it with
                # a previous run's data being released or lost with its worker)
                ref = ex.scatter([shipped], broadcast=True, hash=False)[0]
            else:
                ref = shipped
            rnd = _Round(ex, work, ref, items, bar)
            if spans is None:
                spans = _adaptive(rnd, len(items), worker_slots(ex), done, stats)
            else:
                for span in spans:
                    rnd.submit(span)
                rnd.collect_from(0, done)
            stats.setdefault("planned", len(spans))
            stats["tasks"] += len(rnd.futures)
            stats["compute_seconds"] += sum(rnd.seconds)
            if not rnd.lost:
                break
            if attempt == RETRIES:
                raise CampaignIncompleteError(
                    f"executor: workers lost {RETRIES + 1} times ({rnd.why}); "
                    f"{len(rnd.lost)} of {stats['planned']} tasks not done",
                    partial=partial(done) if partial is not None else None,
                    argument="executor",
                )
            if own is not None:  # a broken pool takes no more tasks: a new one
                own.shutdown(wait=False, cancel_futures=True)
                own = ex = new_pool(shipped)  # type: ignore[misc]
            spans = sorted(rnd.lost)
    finally:
        if own is not None:
            own.shutdown()
    stats.setdefault("items_per_task", per)
    del stats["planned"]
    return done, stats


def _adaptive(
    rnd: _Round, n: int, slots: int, done: dict[int, list[Any]], stats: dict[str, Any]
) -> list[tuple[int, int]]:
    """Submit ``FIRST_TASKS_PER_SLOT * slots`` one-item tasks, size the rest on the
    first one's times, submit and collect everything; returns the spans submitted."""
    first = _spans(0, min(n, FIRST_TASKS_PER_SLOT * slots), 1)
    for span in first:
        rnd.submit(span)
    per, collected = 1, 0
    if rnd.futures:
        rnd.collect(0, done)
        collected = 1
        if rnd.seconds:  # the first task came back: its times size the others
            b = rnd.seconds[0] / (rnd.futures[0][0][1] - rnd.futures[0][0][0])
            o = max(MIN_OVERHEAD, rnd.overheads[0])
            per = task_size(n - first[-1][1], slots, b, o)
            stats.update(block_seconds=b, task_overhead=o)
    rest = guided_spans(first[-1][1], n, slots, per)
    for span in rest:
        rnd.submit(span)
    rnd.collect_from(collected, done)
    sizes = sorted(b - a for a, b in rest) or [1]
    stats["items_per_task"] = sizes[len(sizes) // 2]  # the median task
    stats["least_items_per_task"] = per
    return first + rest
