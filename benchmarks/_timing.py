"""Timing helpers shared by the benchmark scripts.

* :func:`best_alternating`: the best wall-clock time of each of several functions, called
  alternately (so that a load change on a shared machine hits them all), each call
  started after the BLAS worker threads have gone idle (:data:`SETTLE`);
  :func:`best_times`: the same calls timed by both clocks (wall and process CPU);
* :func:`svd_time`: the best wall-clock time of one dense ``n x n`` SVD, the yardstick the
  synthesis benchmarks report their design times against.

Why wall-clock after a pause, not CPU time back to back: a multithreaded OpenBLAS keeps
its worker threads spinning (busy-waiting for the next call) for about 2^28 cycles,
~0.1 s, after its last call.  Timed back to back with ``time.process_time`` (the whole
process's CPU time), a fast candidate timed right after a baseline that used the BLAS's
default threads (``control.forced_response`` of a 132-state system: one multithreaded
``gemv`` per sample) was charged that spinning: a 7 ms ``gf.simulate`` measured 13 ms and
more, half of its ratio, although it runs with one BLAS thread itself.  The same CPU
clock also charges a multithreaded baseline for its workers' spinning during its own
call, time its user does not wait for.  So every call starts on an idle BLAS (a pause of
``SETTLE`` seconds before it) and is timed by the wall clock, the time its caller waits;
the best of ``repeat`` calls discards the rounds slowed by other processes.  Code that
runs on one thread (no multithreaded BLAS in any of the timed functions: the online
monitor) may pass ``clock=time.process_time`` instead: after the pause its CPU time is
its own, and it is less disturbed by other processes than the wall clock.

``burst``: after the pause a function is called that many times back to back, each call
timed on its own.  A short call (a few milliseconds) that starts after a pause runs on
cold caches and a clock-scaled core and pays that start-up on every timed call; a user
simulating many short records calls back to back.  The later calls of a burst measure
that steady state, while the pause still keeps the other function's spinning BLAS
threads out of the first one.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["SETTLE", "best_alternating", "best_times", "svd_time"]

SETTLE = 0.15
"""Seconds of pause before each timed call: longer than OpenBLAS's spin of its idle
worker threads (``THREAD_TIMEOUT`` 2^28 cycles, about 0.11 s at 2.4 GHz)."""


def _best_by_clocks(
    fns: Sequence[Callable[[], object]],
    repeat: int,
    settle: float,
    burst: int,
    clocks: Sequence[Callable[[], float]],
) -> list[list[float]]:
    """``best[i][c]``: the best time of ``fns[i]`` by ``clocks[c]`` over ``repeat`` rounds,
    the functions called alternately, each after a pause of ``settle`` seconds, ``burst``
    calls back to back each time (module docstring)."""
    best = [[np.inf] * len(clocks) for _ in fns]
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            if settle > 0:
                time.sleep(settle)
            for _ in range(max(int(burst), 1)):
                t0 = [clock() for clock in clocks]
                fn()
                t1 = [clock() for clock in reversed(clocks)][::-1]
                best[i] = [min(b, e - s) for b, s, e in zip(best[i], t0, t1, strict=True)]
    return best


def best_times(
    fns: Sequence[Callable[[], object]], repeat: int, settle: float = SETTLE, burst: int = 1
) -> list[tuple[float, float]]:
    """Best wall-clock and best process CPU time of each function, ``(wall, cpu)``, over
    ``repeat`` rounds, the functions called alternately, each after a pause of
    ``settle`` seconds (idle BLAS threads), ``burst`` calls back to back each time (see the
    module docstring).  On a loaded machine the CPU time is the steadier of the two; with
    a multithreaded BLAS it also counts the worker threads' spinning during the call."""
    best = _best_by_clocks(fns, repeat, settle, burst, (time.perf_counter, time.process_time))
    return [(w, c) for w, c in best]


def best_alternating(
    fns: Sequence[Callable[[], object]],
    repeat: int,
    settle: float = SETTLE,
    clock: Callable[[], float] = time.perf_counter,
    burst: int = 1,
) -> list[float]:
    """Best time of each function over ``repeat`` rounds by ``clock`` (the wall clock by
    default), the functions called alternately, each after a pause of ``settle`` seconds
    (idle BLAS threads), ``burst`` calls back to back each time (see the module
    docstring)."""
    return [b[0] for b in _best_by_clocks(fns, repeat, settle, burst, (clock,))]


def svd_time(n: int, repeats: int = 3, rng: np.random.Generator | None = None) -> float:
    """Best wall-clock time of ``np.linalg.svd`` of a random ``n x n`` matrix (drawn from
    ``rng``; default ``np.random.default_rng(n)``) over ``repeats`` calls."""
    X = (np.random.default_rng(n) if rng is None else rng).standard_normal((n, n))
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        np.linalg.svd(X)
        best = min(best, time.perf_counter() - t)
    return best
