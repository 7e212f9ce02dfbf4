"""Residual-bank synthesis cost: ``gf.design_sensor_bank`` and ``gf.verify_symbolic``.

Table 1 times ``gf.design_sensor_bank`` (exact transform, default spectrum, minimal
realizations; each design also evaluates every fault's gain on the physical model) for
random plants of order n with q sensors, and prints the ratio to the time of one n x n
SVD measured in the same run.  The plants come from a family in which every residual is
well posed: q sensor blocks of b = clip(n // q, 1, 4) states, each read by one sensor
(sensors beyond the number of blocks read a block again: redundant sensors), plus
states no sensor sees, driven by the blocks and by u; the block spectra are random
around -2, so some eigenvalues must be moved to meet the default margin.  A random
orthogonal change of coordinates hides the structure.  (On dense random plants each
sensor residual is a single-output observer of the whole plant, whose pole placement is
intrinsically ill-conditioned beyond n ~ 12-20: such rows come back missing with a
"design failed numerically" diagnostic instead of an unstable generator; see Table 3.)

Table 2 times ``gf.verify_symbolic`` on the exact design for n = 2 ... 8, q = 2, 3 with
small-integer data (dense plants: there the orders are small enough).

Table 3 shows what happens on dense random plants (spectrum around -2, dense C): every
sensor residual then needs an observer of the whole plant through one output, whose
rank decisions and construction lose accuracy as n grows; the table counts delivered
and numerically failed rows.

Every design is checked with ``gf.verify``; the largest leakage seen (decoupled faults,
u) is printed at the end.

Times are wall-clock times of single-threaded runs (BLAS limited to one thread when run
as a script; the SVD baseline likewise), best of two for n <= 50.

The least-order tables (total order against an independent least order, success rates on
lightly damped chains and dense plants by n, design time and S* time against one n x n
SVD up to n = 400, the 32-state aircraft model) are in ``benchmarks/bench_least_order.py``.

Run ``python benchmarks/bench_synthesis.py`` (``--quick`` for a smoke run).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _timing import svd_time  # noqa: E402

import geomfdi as gf  # noqa: E402

FULL_N = (10, 20, 50, 100, 200)
FULL_Q = (2, 5, 10, 20)
QUICK_N = (8, 16)
QUICK_Q = (2, 4)
SYM_N = tuple(range(2, 9))
SYM_Q = (2, 3)
DENSE_N = (10, 20, 50)
DENSE_N_QUICK = (8,)
DENSE_Q_QUICK = (2,)
DENSE_Q = (2, 5)
BUDGET = 120.0  # seconds per design above which the larger sizes of that q are skipped


def block_plant(n: int, q: int, rng: np.random.Generator, m: int = 2) -> gf.Plant:
    """Random plant of the family described in the module docstring."""
    b = int(np.clip(n // q, 1, 4))
    nblocks = min(q, n // b)
    no = nblocks * b
    A = np.zeros((n, n))
    for k in range(nblocks):
        sl = slice(k * b, (k + 1) * b)
        A[sl, sl] = rng.standard_normal((b, b)) / np.sqrt(b) - 2.0 * np.eye(b)
    if n > no:  # unseen states, driven by the observed blocks
        nu = n - no
        A[no:, no:] = rng.standard_normal((nu, nu)) / np.sqrt(nu) - 2.0 * np.eye(nu)
        A[no:, :no] = rng.standard_normal((nu, no)) / np.sqrt(no)
    C = np.zeros((q, n))
    for i in range(q):
        k = i % nblocks
        C[i, k * b : (k + 1) * b] = rng.standard_normal(b)
    B = rng.standard_normal((n, m))
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    return gf.Plant(V @ A @ V.T, V @ B, C @ V.T)


def _leakage(bank: gf.ResidualBank, plant: gf.Plant) -> float:
    if not bank.present:
        return 0.0
    rep = gf.verify(bank, plant)
    return float(max(np.max(rep.leakage), np.max(rep.input_leakage)))


def bench_design(ns, qs, seed: int = 0, repeats: int = 2, budget: float = BUDGET):
    """Rows ``(n, q, t_design, t_svd, delivered, max_order, leakage)`` or a skip note."""
    rows = []
    for q in qs:
        skip = False
        for n in ns:
            if skip:
                rows.append((n, q, "skipped: the previous size exceeded the time budget"))
                continue
            rng = np.random.default_rng(seed + 1000 * n + q)
            plant = block_plant(n, q, rng)
            best = np.inf
            for _ in range(repeats if n <= 50 else 1):
                t = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", gf.CloseRankWarning)
                    bank = gf.design_sensor_bank(plant)
                best = min(best, time.perf_counter() - t)
            ts = svd_time(n, 5, rng)
            orders = [g.order for g in bank.generators if g is not None]
            rows.append(
                (n, q, best, ts, len(orders), max(orders, default=0), _leakage(bank, plant))
            )
            skip = best > budget
    return rows


def dense_plant(n: int, q: int, rng: np.random.Generator, m: int = 2) -> gf.Plant:
    """Dense random plant, spectrum around -2 (nothing to move), dense C."""
    A = rng.standard_normal((n, n)) / np.sqrt(n) - 2.0 * np.eye(n)
    return gf.Plant(A, rng.standard_normal((n, m)), rng.standard_normal((q, n)))


def bench_dense(ns, qs, seed: int = 0):
    """Rows ``(n, q, t_design, delivered, failed, max_order, leakage)`` on dense plants."""
    rows = []
    for n in ns:
        for q in qs:
            plant = dense_plant(n, q, np.random.default_rng(seed + 7 * n + q))
            t = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", gf.CloseRankWarning)
                bank = gf.design_sensor_bank(plant)
            td = time.perf_counter() - t
            orders = [g.order for g in bank.generators if g is not None]
            failed = sum("numerically" in d for d in bank.diagnostics)
            rows.append(
                (n, q, td, len(orders), failed, max(orders, default=0), _leakage(bank, plant))
            )
    return rows


def print_dense(rows) -> float:
    print("design_sensor_bank on dense random plants (each residual: a single-output observer)")
    print(
        f"{'n':>4} {'q':>3} {'design [s]':>11} {'rows':>6} {'failed':>7} {'max order':>9} "
        f"{'leakage':>9}"
    )
    worst = 0.0
    for n, q, td, ok, failed, order, leak in rows:
        worst = max(worst, leak)
        print(f"{n:>4} {q:>3} {td:>11.3f} {ok:>3}/{q:<2} {failed:>7} {order:>9} {leak:>9.1e}")
    return worst


def dense_int_plant(n: int, q: int, rng: np.random.Generator) -> gf.Plant:
    A = rng.integers(-3, 4, (n, n)).astype(float)
    B = rng.integers(-2, 3, (n, 1)).astype(float)
    C = rng.integers(-2, 3, (q, n)).astype(float)
    return gf.Plant(A, B, C)


def bench_symbolic(ns, qs, seed: int = 0):
    """Rows ``(n, q, orders, t_design, t_symbolic, ok, leakage)``."""
    rows = []
    for n in ns:
        for q in qs:
            rng = np.random.default_rng(seed + 100 * n + q)
            plant = dense_int_plant(n, q, rng)
            t = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", gf.CloseRankWarning)
                bank = gf.design_sensor_bank(plant)
            td = time.perf_counter() - t
            t = time.perf_counter()
            sym = gf.verify_symbolic(bank, plant)
            tsym = time.perf_counter() - t
            orders = [g.order if g is not None else None for g in bank.generators]
            rows.append((n, q, orders, td, tsym, sym.ok, _leakage(bank, plant)))
    return rows


def print_design(rows) -> float:
    print("design_sensor_bank (exact, default spectrum) vs one n x n SVD")
    print(
        f"{'n':>4} {'q':>3} {'design [s]':>11} {'SVD [ms]':>9} {'ratio':>9} "
        f"{'rows':>6} {'max order':>9} {'leakage':>9}"
    )
    worst = 0.0
    for r in rows:
        if len(r) == 3:
            print(f"{r[0]:>4} {r[1]:>3}  {r[2]}")
            continue
        n, q, td, ts, ok, order, leak = r
        worst = max(worst, leak)
        print(
            f"{n:>4} {q:>3} {td:>11.3f} {1e3 * ts:>9.3f} {td / ts:>9.0f} "
            f"{ok:>3}/{q:<2} {order:>9} {leak:>9.1e}"
        )
    return worst


def print_symbolic(rows) -> float:
    print("verify_symbolic (exact proof of the delivered generator) on dense integer plants")
    print(
        f"{'n':>4} {'q':>3} {'orders':>12} {'design [s]':>11} {'symbolic [s]':>13} "
        f"{'ok':>5} {'leakage':>9}"
    )
    worst = 0.0
    for n, q, orders, td, tsym, ok, leak in rows:
        worst = max(worst, leak)
        o = ",".join("-" if x is None else str(x) for x in orders)
        print(f"{n:>4} {q:>3} {o:>12} {td:>11.3f} {tsym:>13.2f} {ok!s:>5} {leak:>9.1e}")
    return worst


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes (smoke run)")
    args = parser.parse_args(argv)
    ns, qs = (QUICK_N, QUICK_Q) if args.quick else (FULL_N, FULL_Q)
    sns = (2, 3) if args.quick else SYM_N
    design = bench_design(ns, qs, repeats=1 if args.quick else 2)
    worst = print_design(design)
    print()
    sym = bench_symbolic(sns, (2,) if args.quick else SYM_Q)
    worst = max(worst, print_symbolic(sym))
    print()
    dense = bench_dense(*((DENSE_N_QUICK, DENSE_Q_QUICK) if args.quick else (DENSE_N, DENSE_Q)))
    worst_dense = print_dense(dense)
    print()
    print(
        f"largest leakage seen (gf.verify, decoupled faults and u): {worst:.2e} "
        f"(block family and symbolic table); {worst_dense:.2e} (dense plants)"
    )
    return {
        "design": design,
        "symbolic": sym,
        "dense": dense,
        "leakage": worst,
        "leakage_dense": worst_dense,
    }


if __name__ == "__main__":
    from _threads import run_thread_modes

    run_thread_modes(main)
