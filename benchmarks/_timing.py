"""Timing helpers shared by the benchmark scripts.

* :func:`best_alternating`: the best CPU time (``time.process_time``) of each of several
  functions, called alternately so that a load change on a shared machine hits them all;
* :func:`svd_time`: the best wall-clock time of one dense ``n x n`` SVD, the yardstick the
  synthesis benchmarks report their design times against.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["best_alternating", "svd_time"]


def best_alternating(fns: Sequence[Callable[[], object]], repeat: int) -> list[float]:
    """Best CPU time of each function over ``repeat`` rounds, the functions called alternately."""
    best = [np.inf] * len(fns)
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            t0 = time.process_time()
            fn()
            best[i] = min(best[i], time.process_time() - t0)
    return best


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
