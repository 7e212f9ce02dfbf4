"""Campaign throughput: ``gf.Campaign`` against a loop of ``gf.simulate`` calls.

Workload: the closed loop of seed 001 (Hou, Wen & Chen 2011, section 4) with its exact
bank of three residual generators (``examples/seed001.toml``), measurement noise 0.01 on
every sensor, ``10^4`` samples per run (20 s at 2 ms), a bias on sensor 1 at 8 s swept over
10 sizes x 1000 noise seeds = ``10^4`` runs, every run evaluated by the windowed chi-square
test (50 samples, analytic threshold) into the campaign table (scores, detection, delay).

* **baseline**: a Python loop of ``gf.simulate`` calls, one per run, each followed by the
  same test and scores.  It is timed on a subset of the runs (``--loop-runs``, default
  100) and **extrapolated linearly** to all runs (rows marked ``*``);
* **campaign, 1 worker**: ``Campaign.run("serial")`` (blocks of ``--block`` runs, each one
  vectorised ``gf.simulate_batch`` call);
* **campaign, 2 workers**: ``Campaign.run`` on a local ``ProcessPoolExecutor`` with two
  processes.

Everything runs twice: with one BLAS thread (threadpoolctl, also inside the worker
processes) and with the default threads.  Times are wall-clock (``time.perf_counter``).
The tables of the serial and the process runs are checked to be identical.

Run ``python benchmarks/bench_campaign.py`` (``--runs 1000`` for a shorter run).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import geomfdi as gf  # noqa: E402
from geomfdi.campaign.runner import evaluate_runs  # noqa: E402
from geomfdi.io.cli import design_all  # noqa: E402
from geomfdi.io.modelfile import load_model  # noqa: E402


def _limit_threads(n: int | None) -> None:
    if n is not None:
        from threadpoolctl import threadpool_limits

        threadpool_limits(n)


def setup(runs: int, samples: int, block: int) -> tuple[gf.Campaign, dict]:
    spec = load_model(ROOT / "examples" / "seed001.toml")
    bank = design_all(spec)["exact"]
    t = 0.002 * np.arange(samples)
    noise = gf.Noise(measurement=0.01, seed=1)
    models = gf.residual_noise_models(spec.plant, bank, noise, step=0.002, controller=spec.K)
    test = gf.ChiSquareTest.design(models, 50, 1e-4)
    sizes = np.linspace(0.0, 0.03, 10)
    per = max(1, runs // sizes.size)
    camp = gf.Campaign(
        spec.plant,
        bank,
        [gf.Scenario.sensor("bias", 1, sizes, [8.0])],
        noise,
        t=t,
        runs=per,
        test=test,
        u=spec.u,
        controller=spec.K,
        x0=spec.x0,
        detection_window=2.0,
        eval_start=2.0,
        block_size=block,
    )
    return camp, {"spec": spec, "bank": bank, "t": t, "test": test}


def loop_baseline(camp: gf.Campaign, ctx: dict, n: int) -> float:
    """Seconds for the first ``n`` runs of the grid, one ``gf.simulate`` call each."""
    g = camp.grid()
    spec = ctx["spec"]
    root = np.random.SeedSequence(camp.noise.seed)
    t0 = time.perf_counter()
    for i in range(n):
        sc = camp.scenarios[g["scenario"][i]]
        seed = np.random.SeedSequence(root.entropy, spawn_key=(int(g["repetition"][i]),))
        res = gf.simulate(
            spec.plant,
            ctx["bank"],
            ctx["t"],
            camp.u,
            faults=sc.faults(float(g["size"][i]), float(g["onset"][i])),
            noise=gf.Noise(measurement=0.01, seed=seed),
            controller=spec.K,
            x0=spec.x0,
        )
        stat = ctx["test"].statistic(res.residuals[None])
        evaluate_runs(ctx["t"], stat, ctx["test"].thresholds, g["onset"][i : i + 1], 2.0, 2.0)
    return time.perf_counter() - t0


def timed(fn) -> tuple[float, object]:
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10_000)
    ap.add_argument("--samples", type=int, default=10_000)
    ap.add_argument("--loop-runs", type=int, default=100)
    ap.add_argument("--block", type=int, default=64)
    args = ap.parse_args()
    from threadpoolctl import threadpool_limits

    camp, ctx = setup(args.runs, args.samples, args.block)
    total = camp.grid()["run"].size
    print(
        f"campaign: {total} runs x {args.samples} samples, bank of 3 (seed 001, exact), "
        f"chi-square test, blocks of {args.block} runs"
    )
    print(f"{'BLAS threads':<13} {'method':<34} {'time [s]':>10} {'runs/s':>9} {'vs loop':>8}")
    for threads in (1, None):
        label = "1" if threads == 1 else "default"
        with threadpool_limits(threads) if threads else contextlib.nullcontext():
            n = min(args.loop_runs, total)
            t_loop = loop_baseline(camp, ctx, n) * total / n
            t1, r1 = timed(lambda: camp.run("serial", progress=False))
            with ProcessPoolExecutor(
                max_workers=2, initializer=_limit_threads, initargs=(threads,)
            ) as ex:
                ex.submit(int, 0).result()  # start the workers before timing
                t2, r2 = timed(lambda ex=ex: camp.run(ex, progress=False))
        same = r1.table.equals(r2.table)
        rows = [
            (f"loop of gf.simulate ({n} runs)*", t_loop),
            ("campaign, 1 worker (serial)", t1),
            ("campaign, 2 worker processes", t2),
        ]
        for name, tt in rows:
            print(f"{label:<13} {name:<34} {tt:>10.1f} {total / tt:>9.1f} {t_loop / tt:>7.2f}x")
        print(f"{label:<13} scaling 1 -> 2 workers: {t1 / t2:.2f}x; identical tables: {same}")
    print("* timed on the first runs of the grid and extrapolated linearly to all runs")


if __name__ == "__main__":
    main()
