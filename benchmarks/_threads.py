"""Run a benchmark twice: BLAS limited to one thread, then with the BLAS's default threads.

Every benchmark script ends with ``run_thread_modes(main)``: the two runs print the same
tables one after the other, so the ratios (each measured against a baseline timed in the
same run and the same thread mode) can be compared; geomfdi limits its own small-matrix
work to one BLAS thread unless told otherwise (``gf.set_blas_threads``), so its ratios
should not depend on the mode, while a baseline that uses the BLAS directly may.

``--threads 1`` or ``--threads default`` on the command line runs one mode only.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["MODES", "default_threads", "run_thread_modes"]

MODES = ("1", "default")


def default_threads() -> int:
    """The BLAS's own thread count (the largest over the loaded BLAS libraries)."""
    from threadpoolctl import threadpool_info

    counts = [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]
    return max(counts, default=1)


def _split_modes(argv: Sequence[str]) -> tuple[list[str], tuple[str, ...]]:
    args = list(argv)
    modes: tuple[str, ...] = MODES
    if "--threads" in args:
        k = args.index("--threads")
        if k + 1 >= len(args) or args[k + 1] not in MODES:
            raise SystemExit("--threads: expected 1 or default")
        modes = (args[k + 1],)
        del args[k : k + 2]
    return args, modes


def run_thread_modes(
    main: Callable[[list[str]], Any], argv: Sequence[str] | None = None
) -> dict[str, Any]:
    """Call ``main(argv)`` once per BLAS thread mode; returns ``{mode: result}``.

    Parameters
    ----------
    main : callable
        The benchmark's ``main``, taking its argument list.
    argv : sequence of str, optional
        Defaults to ``sys.argv[1:]``; ``--threads 1|default`` selects one mode.
    """
    # load every BLAS before threadpoolctl looks for them: numpy's and scipy's own OpenBLAS
    # (a library loaded after the limit was set would keep its default threads)
    import numpy  # noqa: F401
    import scipy.linalg  # noqa: F401
    from threadpoolctl import threadpool_limits

    args, modes = _split_modes(sys.argv[1:] if argv is None else argv)
    results: dict[str, Any] = {}
    for mode in modes:
        if mode == "1":
            print("=== BLAS threads: 1", flush=True)
            with threadpool_limits(limits=1, user_api="blas"):
                results[mode] = main(args)
        else:
            print(f"\n=== BLAS threads: default ({default_threads()})", flush=True)
            results[mode] = main(args)
    return results
