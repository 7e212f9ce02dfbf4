"""Residual evaluation on recorded and live data: throughput and latency.

Bank: 10 discrete generators of order 3 (30 states) reading 5 outputs and 2 inputs, a
random 10 x 10 structure, thresholds and 2-of-3 persistence.  Reports

* ``gf.evaluate`` (residuals, thresholds, persistence, isolation) on a record of ``N``
  samples against ``control.forced_response`` on the bank's ``StateSpace`` (the
  baseline; residuals only), for the discrete bank and for its continuous version
  (sampled with a first-order hold by both): the ratio of their times, the two timed
  alternately;
* ``Monitor.step``: latency per sample (one Python call per sample);
* ``Monitor.feed``: throughput on chunks of 1000 and 10000 samples;
* the generated C ``name_step`` (ns per sample, through ``name_run`` over the record;
  needs ``cc``; its residuals are checked against ``gf.evaluate``).

Every timing is the best of a few repeats, once with one BLAS thread (threadpoolctl) and
once with the default threads; the load average is printed with the table.  The
single-threaded geomfdi paths are timed by the process CPU time (``time.process_time``:
on a shared machine wall-clock time measures the other jobs as much as this one).  The
ratio to ``forced_response`` is timed by the wall clock, both calls alternated, each
after a pause that lets the BLAS worker threads go idle (``_timing.best_alternating``):
with the default threads, CPU time back to back charged ``evaluate`` for the spinning of
the OpenBLAS workers left by ``forced_response``, and charged ``forced_response`` for
its workers' spinning during its own call.  Goals: evaluate >= 10x forced_response,
Monitor.step <= 10 us, Monitor.feed >= 1e6 samples/s.

Run ``python benchmarks/bench_evaluate.py`` (``--quick`` for a smoke run).
"""

from __future__ import annotations

import argparse
import ctypes
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _timing import best_alternating  # noqa: E402

import geomfdi as gf  # noqa: E402

DT = 0.01
RULE = gf.Persistence(2, 3, reset=50)  # 2 of 3 samples, pattern held over 50-sample episodes


def make_bank(n_gen: int = 10, order: int = 3, q: int = 5, m: int = 2, seed: int = 0) -> Any:
    """A discrete bank of ``n_gen`` random stable generators of order ``order``."""
    rng = np.random.default_rng(seed)
    gens = []
    for _ in range(n_gen):
        Q, _ = np.linalg.qr(rng.normal(size=(order, order)))
        F = Q @ np.diag(rng.uniform(0.3, 0.9, order)) @ Q.T
        gens.append(
            gf.ResidualGenerator(
                F,
                rng.normal(size=(order, q)),
                rng.normal(size=(order, m)),
                rng.normal(size=(1, order)),
                rng.normal(size=(1, q)),
                rng.normal(size=(1, m)),
                dt=DT,
            )
        )
    S = rng.random((n_gen, n_gen)) < 0.5
    return gf.ResidualBank(gens, S, S, np.ones(n_gen, bool), ["ok"] * n_gen, [], DT)


def continuous_version(bank: Any) -> Any:
    """The same structure with continuous generators (F -> log-like stable matrices)."""
    gens = [
        gf.ResidualGenerator(g.F - np.eye(g.order), g.E, g.G, g.M, g.H, g.K)
        for g in bank.generators
    ]
    return gf.ResidualBank(
        gens, bank.requested, bank.structure, bank.isolable, bank.diagnostics, [], 0.0
    )


def best(fn: Callable[[], Any], repeats: int) -> float:
    """Least process CPU time of ``repeats`` calls of ``fn``."""
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return min(times)


def best_pair(fn: Callable[[], Any], base: Callable[[], Any], repeats: int) -> tuple[float, float]:
    """Least wall-clock times of ``fn`` and ``base``, timed alternately (``repeats`` each),
    each call after idle BLAS threads (``_timing.best_alternating``)."""
    t_fn, t_base = best_alternating([fn, base], repeats)
    return t_fn, t_base


def _c_library(mon: Any, tmp: Path) -> Any:
    cc = shutil.which("cc")
    if cc is None:
        return None
    _, c = gf.codegen.c(mon, "bench", tmp)
    lib = tmp / "libbench.so"
    flags = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", "-shared", "-fPIC"]
    subprocess.run([cc, *flags, "-o", str(lib), str(c), "-lm"], check=True)
    return ctypes.CDLL(str(lib))


def measure(N: int, repeats: int, tmp: Path) -> dict[str, float]:
    import control

    bank = make_bank()
    q, m = 5, 2
    rng = np.random.default_rng(1)
    t = np.arange(N) * DT
    Y = rng.normal(size=(q, N))
    U = rng.normal(size=(m, N))
    Z = np.vstack([Y, U])
    thr = np.full(10, 3.0)
    out: dict[str, float] = {}

    for label, b in (("discrete", bank), ("continuous", continuous_version(bank))):
        ss = b.to_statespace()
        t_ev, t_fr = best_pair(
            lambda b=b: gf.evaluate(b, Y, U, t, threshold=thr, persistence=RULE),
            lambda ss=ss: control.forced_response(ss, t, Z),
            repeats,
        )
        out[f"evaluate / forced_response ({label})"] = t_fr / t_ev

    mon = gf.Monitor(bank, threshold=thr, persistence=RULE)
    steps = min(N, 20000)
    cols = [(Y[:, k].copy(), U[:, k].copy()) for k in range(steps)]

    def run_steps() -> None:
        step = mon.step
        for y, u in cols:
            step(y, u)

    out["Monitor.step [us/sample]"] = best(run_steps, repeats) / steps * 1e6
    for chunk in (1000, 10000):

        def feed(chunk: int = chunk) -> None:
            for s in range(0, N, chunk):
                mon.feed(Y[:, s : s + chunk], U[:, s : s + chunk])

        out[f"Monitor.feed, chunks of {chunk} [Msamples/s]"] = N / best(feed, repeats) / 1e6

    lib = _c_library(mon, tmp)
    if lib is not None:
        state = ctypes.create_string_buffer(lib.bench_state_size())
        Yc, Uc = np.ascontiguousarray(Y.T), np.ascontiguousarray(U.T)
        R = np.zeros((N, 10))
        Al = np.zeros((N, 10), dtype=np.intc)
        iso = np.zeros(N, dtype=np.intc)
        lib.bench_run.argtypes = [ctypes.c_void_p, ctypes.c_long] + [ctypes.c_void_p] * 5
        ptrs = [a.ctypes.data_as(ctypes.c_void_p) for a in (Yc, Uc, R, Al, iso)]

        def run_c() -> None:
            lib.bench_init(state)
            lib.bench_run(state, N, *ptrs)

        out["generated C step [ns/sample]"] = best(run_c, repeats) / N * 1e9
        ref = gf.evaluate(bank, Y, U, t, threshold=thr, persistence=RULE)
        if not np.max(np.abs(R.T - ref.residuals)) <= 1e-12 * max(1.0, np.abs(R).max()):
            raise RuntimeError("the generated C residuals differ from gf.evaluate")
        if not (np.array_equal(Al.T, ref.alarms) and np.array_equal(iso, ref.isolated)):
            raise RuntimeError("the generated C decisions differ from gf.evaluate")
    return out


def main(argv: Sequence[str] | None = None) -> dict[str, dict[str, float]]:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="small sizes (smoke run)")
    args = p.parse_args(argv)
    N, repeats = (20000, 2) if args.quick else (200000, 3)
    from threadpoolctl import threadpool_limits

    results: dict[str, dict[str, float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        with threadpool_limits(limits=1, user_api="blas"):
            results["1 BLAS thread"] = measure(N, repeats, Path(tmp))
        results["default threads"] = measure(N, repeats, Path(tmp))
    keys = list(results["1 BLAS thread"])
    width = max(len(k) for k in keys)
    import os

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"bank: 10 generators of order 3, 5 outputs, 2 inputs; record of {N} samples")
    print(
        f"ratios by wall clock, the rest CPU times; load average {load:.1f} "
        f"on {os.cpu_count()} CPUs"
    )
    print(f"{'':<{width}}  {'1 BLAS thread':>14}  {'default threads':>16}")
    for k in keys:
        a, b = results["1 BLAS thread"][k], results["default threads"][k]
        print(f"{k:<{width}}  {a:>14.4g}  {b:>16.4g}")
    return results


if __name__ == "__main__":
    main()
