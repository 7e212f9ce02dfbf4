"""Approximate synthesis (fault-to-noise gap): design time against one SVD.

Table: time of one gap-maximising fault-detection row
(``design_residual_generator(..., objective="gap")``: decoupling basis, noise-channel
factorisation, row choice, minimal realisation and the H∞ measurement of β, γ and the gap)
on a dense stable random plant with ``q = max(2, n/10)`` sensors, two actuator faults,
process noise on every state and sensor noise on every output (the standard case), against
one ``n × n`` SVD, n = 10 … 200.  The order of the delivered generator and its gap are
printed with the time.

Runs once with one BLAS thread and once with the default threads
(``_threads.run_thread_modes``); every time is the best of a few repeats.  Both the wall
time and the CPU time of the process are printed (on a loaded machine the CPU time is
the steadier one; with one BLAS thread it is the wall time of an idle machine).
Run ``python benchmarks/bench_approximate.py`` (``--quick`` for n ≤ 20;
``--sizes 10 20 50`` to choose; ``--threads 1`` or ``--threads default`` for one mode).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _timing import svd_time  # noqa: E402

import geomfdi as gf  # noqa: E402


def noisy_plant(n: int, seed: int):
    """A dense stable plant with noise inputs and two actuator faults."""
    rng = np.random.default_rng(seed)
    q = max(2, n // 10)
    A = rng.standard_normal((n, n)) / np.sqrt(n)
    A -= (np.max(np.linalg.eigvals(A).real) + 0.5) * np.eye(n)
    B = rng.standard_normal((n, 1))
    C = rng.standard_normal((q, n))
    Bw = np.hstack([0.1 * np.eye(n), np.zeros((n, q))])
    Dw = np.hstack([np.zeros((q, n)), 0.01 * np.eye(q)])
    try:
        p = gf.Plant(A, B, C, Bw=Bw, Dw=Dw)
    except TypeError:  # a geomfdi without noise inputs in Plant: attach them
        p = gf.Plant(A, B, C)
        p.Bw, p.Dw, p.nw = Bw, Dw, Bw.shape[1]
    faults = [gf.ActuatorFault(rng.standard_normal(n)) for _ in range(2)]
    return p, faults


def table_time(sizes, repeats: int = 2) -> list[dict]:
    rows = []
    print(
        f"{'n':>5} {'q':>3} {'order':>6} {'gap':>10} {'design s':>10} {'cpu s':>8} "
        f"{'SVD s':>10} {'ratio':>9}"
    )
    for n in sizes:
        p, faults = noisy_plant(n, n)
        best, cpu, g = np.inf, np.inf, None
        for _ in range(repeats):
            t, c = time.perf_counter(), time.process_time()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", gf.CloseRankWarning)
                g = gf.design_residual_generator(p, faults, [0, 1], objective="gap")
            best = min(best, time.perf_counter() - t)
            cpu = min(cpu, time.process_time() - c)
        s = svd_time(n)
        row = dict(n=n, q=p.q, order=g.order, gap=g.info["gap"], time=best, cpu=cpu, svd=s)
        rows.append(row)
        print(
            f"{n:5d} {p.q:3d} {g.order:6d} {g.info['gap']:10.4g} {best:10.4f} {cpu:8.3f} "
            f"{s:10.2e} {best / s:9.0f}"
        )
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="n = 10, 20 (smoke run)")
    ap.add_argument("--sizes", type=int, nargs="+", default=None, help="plant orders")
    args = ap.parse_args(argv)
    sizes = args.sizes or ((10, 20) if args.quick else (10, 20, 50, 100, 200))
    return {"time": table_time(sizes)}


if __name__ == "__main__":
    from _threads import run_thread_modes

    run_thread_modes(main)
