"""Benchmark: W* (Algorithm 1) and S* (Algorithm 2) on random systems of growing size.

For each n the script builds a random system with q = round(n / 3) outputs (so Ker C has
dimension about 2n/3), L with one or two columns, the first in Ker C so that the W*
recursion takes more than one step, and times ``gf.min_conditioned_invariant`` and
``gf.min_unobservability_subspace`` (best of ``--repeat`` runs).  The baseline is one
``numpy.linalg.svd`` of an n x n matrix measured in the same run; the table gives each
time, its ratio to that SVD, the number of iterations, and the empirical growth exponent
(least-squares slope of log time against log n).

Usage::

    python benchmarks/bench_geometry.py            # n = 10 ... 400
    python benchmarks/bench_geometry.py --quick    # n = 10, 20, 50
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np  # noqa: E402
import scipy.linalg  # noqa: E402

try:
    import geomfdi as gf  # noqa: E402
except ImportError:  # running from a source checkout without installation
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import geomfdi as gf

FULL_SIZES = (10, 20, 50, 100, 200, 400)
QUICK_SIZES = (10, 20, 50)


def random_system(
    n: int, rng: np.random.Generator, columns: int = 2
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random (A, C, L): ||A|| ~ 2, q = round(n/3) outputs, L's first column in Ker C."""
    q = max(1, round(n / 3))
    A = rng.standard_normal((n, n)) / np.sqrt(n)
    C = rng.standard_normal((q, n))
    kerC = scipy.linalg.null_space(C)
    cols = [kerC @ rng.standard_normal(kerC.shape[1])]
    if columns > 1:
        cols += [rng.standard_normal(n) for _ in range(columns - 1)]
    return A, C, np.column_stack(cols)


def best_time(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    """Smallest wall time over ``repeat`` calls, and the last result."""
    best, out = np.inf, None
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def growth_exponent(ns: Sequence[int], ts: Sequence[float]) -> float:
    """Least-squares slope of log t against log n (nan with fewer than two sizes)."""
    if len(ns) < 2:
        return float("nan")
    return float(np.polyfit(np.log(ns), np.log(ts), 1)[0])


def run(
    sizes: Sequence[int], *, repeat: int = 3, seed: int = 0, columns: int = 2
) -> list[dict[str, Any]]:
    """Time W*, S* and the SVD baseline for each n; one dict per size."""
    rows = []
    for n in sizes:
        rng = np.random.default_rng(seed + n)
        A, C, L = random_system(n, rng, columns)
        M = rng.standard_normal((n, n))
        np.linalg.svd(M)  # warm-up (LAPACK workspace, threads)
        gf.min_unobservability_subspace(A, C, L)
        t_svd, _ = best_time(lambda M=M: np.linalg.svd(M), repeat)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", gf.CloseRankWarning)
            t_w, W = best_time(lambda A=A, C=C, L=L: gf.min_conditioned_invariant(A, C, L), repeat)
            t_s, S = best_time(
                lambda A=A, C=C, L=L: gf.min_unobservability_subspace(A, C, L), repeat
            )
        rows.append(
            {
                "n": n,
                "q": C.shape[0],
                "t_svd": t_svd,
                "t_w": t_w,
                "t_s": t_s,
                "w_steps": W.steps,
                "w_dim": W.dim,
                "s_steps": S.steps,
                "s_dim": S.dim,
                "min_gap": min(W.min_gap, S.min_gap),
                "warnings": len(caught),
            }
        )
    return rows


def format_table(rows: Sequence[dict[str, Any]]) -> str:
    head = (
        f"{'n':>5} {'q':>4} {'svd [ms]':>10} {'W* [ms]':>10} {'W*/svd':>8} {'it':>3} "
        f"{'dim':>4} {'S* [ms]':>10} {'S*/svd':>8} {'it':>3} {'dim':>4} {'min gap':>9}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['n']:>5} {r['q']:>4} {1e3 * r['t_svd']:>10.3f} {1e3 * r['t_w']:>10.3f} "
            f"{r['t_w'] / r['t_svd']:>8.1f} {r['w_steps']:>3} {r['w_dim']:>4} "
            f"{1e3 * r['t_s']:>10.3f} {r['t_s'] / r['t_svd']:>8.1f} {r['s_steps']:>3} "
            f"{r['s_dim']:>4} {r['min_gap']:>9.2e}"
        )
    ns = [r["n"] for r in rows]
    lines.append("")
    lines.append("growth exponent (slope of log t vs log n, all sizes / n >= 100):")
    big = [i for i, n in enumerate(ns) if n >= 100]
    for key, label in (("t_svd", "svd"), ("t_w", "W*"), ("t_s", "S*")):
        ts = [r[key] for r in rows]
        tail = growth_exponent([ns[i] for i in big], [ts[i] for i in big])
        lines.append(
            f"  {label:>3}: {growth_exponent(ns, ts):5.2f}"
            + (f" / {tail:5.2f}" if len(big) >= 2 else "")
        )
    n_warn = sum(r["warnings"] for r in rows)
    if n_warn:
        lines.append(f"CloseRankWarning issued {n_warn} times")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> list[dict[str, Any]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="n = 10, 20, 50 only")
    parser.add_argument("--sizes", type=int, nargs="+", help="state dimensions to time")
    parser.add_argument("--repeat", type=int, default=3, help="runs per timing (best kept)")
    parser.add_argument("--columns", type=int, default=2, choices=(1, 2), help="columns of L")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    sizes = args.sizes or (QUICK_SIZES if args.quick else FULL_SIZES)
    rows = run(sizes, repeat=args.repeat, seed=args.seed, columns=args.columns)
    from threadpoolctl import threadpool_info

    threads = max(  # the BLAS threads in force for this run
        (lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"), default=1
    )
    print(
        f"W* / S* on random systems, q = n/3, L with {args.columns} column(s); "
        f"best of {args.repeat}; BLAS threads: {threads}"
    )
    print(format_table(rows))
    return rows


if __name__ == "__main__":
    from _threads import run_thread_modes

    run_thread_modes(main)
