"""Campaign throughput against a loop of ``gf.simulate`` calls, and scaling to 2 workers.

Workload: the closed loop of Hou, Wen & Chen (2011, section 4) with its exact
bank of three residual generators (``examples/hou_wen_chen.toml``), measurement noise 0.01 on
every sensor, ``10^4`` samples per run (20 s at 2 ms), a bias on sensor 1 at 8 s swept over
10 sizes x 1000 noise seeds = ``10^4`` runs, every run evaluated by the windowed chi-square
test (50 samples, analytic threshold) into the campaign table (scores, detection, delay,
isolation with a 2-of-3 rule).

Methods, timed in one process run and alternated (every repeat times each method once;
the best of ``--repeats`` is kept):

* **loop**: a Python loop of ``gf.simulate`` calls, one per run, each followed by the same
  test, scores and isolation.  Timed on the first ``--loop-runs`` runs of the grid and
  **extrapolated linearly** to all runs (rows marked ``*``);
* **serial**: ``Campaign.run("serial")`` (blocks of ``--block`` runs, each one vectorised
  ``gf.simulate_batch`` call; with the default threads its noise draws and compiled
  recursion run on as many threads as the BLAS had, see ``geomfdi._threads``, so
  "serial" is one process, not one core);
* **processes, 1 / 2 workers**: a ``ProcessPoolExecutor`` with 1 and with 2 processes
  (started and warmed up before timing);
* **dask, 1 / 2 workers**: one ``distributed.LocalCluster`` of 2 single-threaded worker
  processes made by ``geomfdi.campaign.executors.local_dask_client`` (Dask's worker
  profiler off, its event-loop check once a second: ``DASK_THROUGHPUT``;
  ``--dask-defaults``: Dask's own settings); the 2-worker case passes the ``Client``
  itself to ``Campaign.run`` (as a user does: the scheduler places the tasks), the
  1-worker case pins every task to one worker (skipped without ``distributed`` or with
  ``--no-dask``).

A task carries ``--blocks-per-task`` blocks (default ``auto``: sized by
``Campaign.run`` from the first task's measured block time so that the per-task overhead
stays under 10 % while every worker gets about 4 tasks; a block of 64 runs x 10^4
samples is about half a second of vectorised work, against milliseconds of per-task
overhead, so a task is one block).  The job goes once to every worker (see
``geomfdi.campaign.executors``).  Per executor the benchmark prints the tasks, the
blocks per task, the compute seconds summed over the tasks (measured in the workers) and
the per-task overhead ``(t * workers - compute) / tasks`` (scheduling, shipping and the
slots left idle at the end), with ``(t(1 worker) - t(serial)) / tasks`` for the 1-worker
cases, and the ratio ``t(processes, 2 workers) / t(dask, 2 workers)``.  The scaling
ratio ``t(1 worker) / t(2 workers)`` is reported per executor with the machine's load
average (``os.getloadavg``) read before every timed run: on a machine whose 2 cores are
busy with other work the ratio cannot reach 2, so the load is part of the result.

The ``floor`` section: the flops of one run-sample of the campaign's arithmetic
(:func:`flops_per_sample`: plant, bank of 3, chi-square statistic) times the run-samples,
divided by the measured rate of a 1000 x 1000 matrix product (in the same thread mode):
the time the arithmetic alone would take at GEMM speed.  The serial campaign is reported
against it, and so is drawing the measurement noise alone (``q`` standard normals per
run-sample from each run's own generator, as ``gf.simulate`` draws them).

Everything runs twice (``benchmarks/_threads.py``): one BLAS thread, then the default
threads (worker processes inherit the limit through their initializer; Dask sets one
thread per worker process itself).  The tables of the serial and the parallel runs are
checked to be identical.

``python benchmarks/bench_campaign.py`` (the full workload, many minutes on 2 cores);
``--quick`` (256 runs x 2000 samples, one repeat, under a minute); ``--runs``,
``--samples``, ``--threads 1|default`` to choose; ``--generator counter`` draws the noise
with ``gf.Noise(generator="counter")`` (every method, and the noise-alone time).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from _threads import run_thread_modes  # noqa: E402

import geomfdi as gf  # noqa: E402
from geomfdi.campaign.executors import DASK_THROUGHPUT  # noqa: E402
from geomfdi.campaign.runner import evaluate_runs, isolate_runs  # noqa: E402
from geomfdi.io.cli import design_all  # noqa: E402
from geomfdi.io.modelfile import load_model  # noqa: E402
from geomfdi.simulation.counter_normal import fill_normals, run_key  # noqa: E402
from geomfdi.simulation.pcg64_normal import standard_normal  # noqa: E402

RULE = gf.Persistence(2, 3)
_STATE: dict[str, Any] = {}  # the Dask cluster, shared by both thread modes


def _limit_threads(n: int | None) -> None:
    if n is not None:
        from threadpoolctl import threadpool_limits

        threadpool_limits(n)


def setup(
    runs: int, samples: int, block: int, generator: str = "numpy"
) -> tuple[gf.Campaign, dict[str, Any]]:
    spec = load_model(ROOT / "examples" / "hou_wen_chen.toml")
    bank = design_all(spec)["exact"]
    t = 0.002 * np.arange(samples)
    onset = float(t[int(0.4 * samples)])
    noise = gf.Noise(measurement=0.01, seed=1, generator=generator)
    models = gf.residual_noise_models(spec.plant, bank, noise, step=0.002, controller=spec.K)
    test = gf.ChiSquareTest.design(models, 50, 1e-4)
    sizes = np.linspace(0.0, 0.03, 10)
    per = max(1, runs // sizes.size)
    window = min(2.0, float(t[-1] - onset))
    camp = gf.Campaign(
        spec.plant,
        bank,
        [gf.Scenario.sensor("bias", 1, sizes, [onset])],
        noise,
        t=t,
        runs=per,
        test=test,
        u=spec.u,
        controller=spec.K,
        x0=spec.x0,
        detection_window=window,
        eval_start=min(2.0, onset / 2),
        block_size=block,
        persistence=RULE,
    )
    return camp, {"spec": spec, "bank": bank, "t": t, "test": test, "window": window}


def flops_per_sample(ctx: dict[str, Any]) -> dict[str, int]:
    """Floating-point operations of one run-sample of the campaign's arithmetic, a
    multiply-add counted as 2 (as in a GEMM's ``2 n^3``), the bank's generators as
    separate blocks (what they are), every matrix dense otherwise:

    * plant: ``x+ = A_d x + B_d u`` (``u = -K x + r`` with state feedback), the readings
      ``y = C x + D u + v``;
    * bank: per generator ``w+ = F w - E y + G u``, ``r = M w - H y + K u``;
    * chi-square: ``r^2``, the running sum and the window's difference per residual.
    """
    p, gens = ctx["spec"].plant, [g for g in ctx["bank"].generators if g is not None]
    n, m, q = p.n, p.m, p.q
    out = {
        "plant": 2 * n * (n + m) + (2 * m * n if ctx["spec"].K is not None else 0),
        "readings": 2 * q * (n + m) + q,
        "bank states": sum(2 * g.order * (g.order + q + m) for g in gens),
        "residuals": sum(2 * g.n_outputs * (g.order + q + m) for g in gens),
        "chi-square": 3 * len(gens),
    }
    out["total"] = sum(out.values())
    return out


def gemm_rate(size: int = 1000, repeats: int = 3) -> float:
    """Measured flop rate (flop/s) of a ``size x size`` matrix product in this process
    (its BLAS threads), the best of ``repeats``."""
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((size, size)), rng.standard_normal((size, size))
    a @ b
    best = min(_seconds(lambda: a @ b) for _ in range(repeats))
    return 2.0 * size**3 / best


def noise_seconds(camp: gf.Campaign, ctx: dict[str, Any], runs: int) -> float:
    """Seconds to draw the measurement noise alone (``q`` standard normals per
    run-sample, each run from its own ``default_rng(seed)``, as ``gf.simulate`` draws
    them; a campaign draws each repetition once per process and its runs in the other
    cells read the draws again) for ``runs`` runs, extrapolated to the campaign's runs."""
    q, N = ctx["spec"].plant.q, ctx["t"].size
    root = np.random.SeedSequence(camp.noise.seed)
    buf = np.empty((q, N))

    def draw() -> None:
        for r in range(runs):
            seed = np.random.SeedSequence(root.entropy, spawn_key=(r,))
            if camp.noise.generator == "counter":
                fill_normals(run_key(seed)[None], 0, 0, 0, N, buf[None])
            else:
                # numpy's normals as the campaign draws them (the same bits, compiled)
                standard_normal(np.random.default_rng(seed), buf)

    total = camp.grid()["run"].size
    return min(_seconds(draw) for _ in range(2)) * total / runs


def _seconds(fn: Any) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def print_floor(camp: gf.Campaign, ctx: dict[str, Any], serial: float) -> dict[str, float]:
    """The ``floor`` section: flops per sample x run-samples / measured GEMM rate."""
    fl = flops_per_sample(ctx)
    total = camp.grid()["run"].size
    samples = total * ctx["t"].size
    rate = gemm_rate()
    floor = fl["total"] * samples / rate
    noise = noise_seconds(camp, ctx, min(total, 256))
    parts = ", ".join(f"{k} {v}" for k, v in fl.items() if k != "total")
    print(f"floor: {fl['total']} flops per run-sample ({parts})")
    print(
        f"floor: GEMM 1000x1000 {rate / 1e9:.1f} GFlop/s -> {fl['total']} x {samples:.3g} "
        f"run-samples = {floor:.2f} s"
    )
    print(
        f"floor: serial {serial:.2f} s = {serial / floor:.1f}x the floor, "
        f"{1e9 * serial / samples:.0f} ns per run-sample"
    )
    print(
        f"floor: drawing the noise alone ({ctx['spec'].plant.q} normals per run-sample) "
        f"{noise:.2f} s = {noise / floor:.1f}x the floor"
    )
    return {"floor": floor, "noise": noise, "gemm": rate, "flops": fl["total"]}


def loop_baseline(camp: gf.Campaign, ctx: dict[str, Any], n: int) -> float:
    """Seconds for the first ``n`` runs of the grid, one ``gf.simulate`` call each."""
    g = camp.grid()
    spec, test, t = ctx["spec"], ctx["test"], ctx["t"]
    root = np.random.SeedSequence(camp.noise.seed)
    S = np.asarray(ctx["bank"].structure, dtype=bool)
    t0 = time.perf_counter()
    for i in range(n):
        sc = camp.scenarios[g["scenario"][i]]
        size, onset = float(g["size"][i]), g["onset"][i : i + 1]
        seed = np.random.SeedSequence(root.entropy, spawn_key=(int(g["repetition"][i]),))
        res = gf.simulate(
            spec.plant,
            ctx["bank"],
            t,
            camp.u,
            faults=sc.faults(size, float(onset[0])),
            noise=gf.Noise(measurement=0.01, seed=seed, generator=camp.noise.generator),
            controller=spec.K,
            x0=spec.x0,
        )
        stat = test.statistic(res.residuals[None])
        evaluate_runs(t, stat, test.thresholds, onset, ctx["window"], camp.eval_start)
        col = res.events[0].index if size else -1
        truth = np.array([col])
        isolate_runs(
            t, stat, test.thresholds, S, RULE, truth, [frozenset({col})], onset, ctx["window"]
        )
    return time.perf_counter() - t0


class _Pinned:
    """A Dask client seen as an executor whose tasks all run on the given workers."""

    def __init__(self, client: Any, workers: list[str]) -> None:
        self.client, self.workers = client, workers

    def scatter(self, data: Any, **kwargs: Any) -> Any:
        return self.client.scatter(data, workers=self.workers, **kwargs)

    def submit(self, fn: Any, *args: Any) -> Any:
        return self.client.submit(fn, *args, workers=self.workers, pure=False)

    def nthreads(self) -> dict[str, int]:
        return {w: n for w, n in self.client.nthreads().items() if w in self.workers}


def _dask(defaults: bool) -> Any:
    """The benchmark's Dask client, made once (both thread modes use it):
    :func:`~geomfdi.campaign.executors.local_dask_client`, with ``defaults`` under Dask's
    own settings."""
    if "client" not in _STATE:
        from contextlib import ExitStack

        from geomfdi.campaign.executors import local_dask_client

        stack = _STATE["stack"] = ExitStack()
        _STATE["client"] = stack.enter_context(local_dask_client(2, {} if defaults else None))
    return _STATE["client"]


def _close_dask() -> None:
    if "client" in _STATE:
        _STATE.pop("client")
        _STATE.pop("stack").close()


def main(argv: list[str]) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10_000)
    ap.add_argument("--samples", type=int, default=10_000)
    ap.add_argument("--loop-runs", type=int, default=100)
    ap.add_argument("--block", type=int, default=64)
    ap.add_argument("--blocks-per-task", default="auto", help="an integer, or auto (the default)")
    ap.add_argument("--repeats", type=int, default=None, help="default 5 (--quick: 1)")
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument(
        "--dask-defaults",
        action="store_true",
        help="Dask's own settings for the cluster (default: geomfdi's DASK_THROUGHPUT)",
    )
    ap.add_argument(
        "--skip",
        default="",
        help="comma-separated parts of method names not to time (e.g. 'loop,1 worker')",
    )
    ap.add_argument("--quick", action="store_true", help="256 runs x 2000 samples, 1 repeat")
    ap.add_argument(
        "--generator", choices=("numpy", "counter"), default="numpy", help="gf.Noise(generator=)"
    )
    args = ap.parse_args(argv)
    if args.repeats is None:
        args.repeats = 1 if args.quick else 5
    if args.quick:
        args.runs, args.samples, args.loop_runs = 256, 2000, 8
    from threadpoolctl import threadpool_info

    blas = max((b["num_threads"] for b in threadpool_info() if b["user_api"] == "blas"), default=1)
    limit = 1 if blas == 1 else None  # the mode run_thread_modes set for this process
    camp, ctx = setup(args.runs, args.samples, args.block, args.generator)
    total = camp.grid()["run"].size
    nblocks = len(camp.blocks())
    per = args.blocks_per_task if args.blocks_per_task == "auto" else int(args.blocks_per_task)
    print(
        f"campaign: {total} runs x {args.samples} samples, bank of 3 (Hou-Wen-Chen, exact), "
        f"chi-square test (isolation {RULE.k} of {RULE.n} samples, held pattern), "
        f"{nblocks} blocks of {args.block} runs, blocks per task: {per}, "
        f"noise generator {args.generator!r}"
    )
    print(f"machine: {os.cpu_count()} CPUs, BLAS threads in this process: {blas}")
    from geomfdi.campaign.runner import _fused_plan

    job0 = camp._job()
    fused = _fused_plan(job0, 0) is not None
    print(
        "blocks: the fused compiled pass (geomfdi.simulation.fused)"
        if fused
        else f"blocks: gf.simulate_batch (no fused pass: {job0['fused'][('why', 0)]})"
    )
    # every method is a function of the campaign: a small one (8 blocks of 5 runs, so
    # that every worker gets tasks) warms each executor up before anything is timed
    small = setup(40, 400, 5)[0]
    methods: dict[str, Any] = {}
    n = min(args.loop_runs, total)
    methods["loop"] = lambda c: loop_baseline(camp, ctx, n) * total / n
    methods["serial"] = lambda c: c.run("serial", progress=False)
    pools = {}
    for w in (1, 2):
        pools[w] = ProcessPoolExecutor(max_workers=w, initializer=_limit_threads, initargs=(limit,))
        methods[f"processes, {w} worker{'s' * (w > 1)}"] = lambda c, w=w: c.run(
            pools[w], blocks_per_task=per, progress=False
        )
    dask_note = ""
    if not args.no_dask:
        try:
            client = _dask(args.dask_defaults)
        except ImportError:
            dask_note = "(dask skipped: distributed is not installed)"
        else:
            addrs = sorted(client.scheduler_info()["workers"])
            for w in (1, 2):
                ex = client if w == len(addrs) else _Pinned(client, addrs[:w])
                methods[f"dask, {w} worker{'s' * (w > 1)}"] = lambda c, ex=ex, w=w: c.run(
                    ex, blocks_per_task=per, progress=False
                )
    skip = [part.strip() for part in args.skip.split(",") if part.strip()]
    methods = {k: f for k, f in methods.items() if not any(part in k for part in skip)}
    for name, fn in methods.items():
        if name != "loop":
            fn(small)
    # one block's compute time in this process and inside a worker: tells a slower
    # worker (memory settings, contention) from per-task transfer and scheduling
    job, block = camp._job(), camp.blocks()[0]
    where = {"this process": _block_seconds(job, block)}
    where["a process worker"] = pools[1].submit(_block_seconds, job, block).result()
    if "client" in _STATE:
        fut = _STATE["client"].submit(_block_seconds, job, block, pure=False)
        where["a Dask worker"] = fut.result()
        fut = _STATE["client"].submit(_block_seconds, job, block, False, pure=False)
        where["a Dask worker without the allocator set-up"] = fut.result()
        env = _STATE["client"].run(_worker_env)
        print(f"Dask worker environment: {next(iter(env.values()))}")
        print(
            "Dask settings: "
            + ("Dask's defaults" if args.dask_defaults else f"DASK_THROUGHPUT {DASK_THROUGHPUT}")
        )
    print(
        f"one block of {args.block} runs: " + ", ".join(f"{k} {v:.2f} s" for k, v in where.items())
    )
    best: dict[str, float] = {}
    load: dict[str, tuple[float, float, float]] = {}
    tables: dict[str, Any] = {}
    stats: dict[str, dict[str, Any]] = {}
    paired: list[float] = []  # t(processes) / t(dask), 2 workers, in the same repeat
    try:
        for _ in range(args.repeats):
            times: dict[str, float] = {}
            for name, fn in methods.items():
                la = os.getloadavg()
                t0 = time.perf_counter()
                out = fn(camp)
                dt = times[name] = out if name == "loop" else time.perf_counter() - t0
                print(f"  {name}: {dt:.2f} s (load {la[0]:.2f})", flush=True)
                if name not in best or dt < best[name]:
                    best[name], load[name] = dt, la
                if name != "loop":
                    tables[name] = out.table
                    if best[name] == dt:
                        stats[name] = out.info["executor"]
            if "processes, 2 workers" in times and "dask, 2 workers" in times:
                paired.append(times["processes, 2 workers"] / times["dask, 2 workers"])
    finally:
        for p in pools.values():
            p.shutdown()
    t_loop = best.get("loop", float("nan"))
    print(
        f"{'method':<34} {'time [s]':>9} {'runs/s':>8} {'vs loop':>8} "
        f"{'load 1/5/15 min before':>24}"
    )
    for name, tt in best.items():
        label = f"loop of gf.simulate ({n} runs)*" if name == "loop" else name
        la = "/".join(f"{x:.2f}" for x in load[name])
        print(f"{label:<34} {tt:>9.2f} {total / tt:>8.1f} {t_loop / tt:>7.2f}x {la:>24}")
    for ex in ("processes", "dask"):
        one, two = f"{ex}, 1 worker", f"{ex}, 2 workers"
        if one in best and two in best:
            print(
                f"scaling 1 -> 2 workers ({ex}): {best[one] / best[two]:.2f}x "
                f"(load before: {load[one][0]:.2f} / {load[two][0]:.2f}; "
                f"{os.cpu_count()} CPUs)"
            )
    # per-task overhead: slot time not spent computing (scheduling, shipping, idle slots
    # at the end), per task; and against serial (the 1-worker cases)
    print(
        f"{'executor':<20} {'tasks':>6} {'blocks/task':>12} {'compute [s]':>12} "
        f"{'overhead/task [ms]':>19} {'share':>6} {'(t - serial)/task [ms]':>23}"
    )
    for name, st in stats.items():
        if name == "serial":
            continue
        slots = 1 if "1 worker" in name else 2
        idle = best[name] * slots - st["compute_seconds"]
        vs = (best[name] - best.get("serial", np.nan)) / st["tasks"] if slots == 1 else np.nan
        print(
            f"{name:<20} {st['tasks']:>6} {st['blocks_per_task']:>12} "
            f"{st['compute_seconds']:>12.2f} {1e3 * idle / st['tasks']:>19.1f} "
            f"{idle / (best[name] * slots):>6.1%} {1e3 * vs:>23.1f}"
        )
    if "dask, 2 workers" in best and "processes, 2 workers" in best:
        ratio = best["processes, 2 workers"] / best["dask, 2 workers"]
        print(
            f"dask vs processes, 2 workers: t(processes) / t(dask) = {ratio:.2f}x best of "
            f"each, {np.median(paired):.2f}x median of the repeats "
            f"({', '.join(f'{r:.2f}' for r in paired)}) (>= 0.9 wanted)"
        )
    ref = tables.get("serial", next(iter(tables.values())))
    same = all(tb.equals(ref) for tb in tables.values())
    print(f"identical tables (serial, processes, dask): {same}")
    print("* timed on the first runs of the grid and extrapolated linearly to all runs")
    floor = print_floor(camp, ctx, best["serial"]) if "serial" in best else None
    if dask_note:
        print(dask_note)
    return {
        "best": best,
        "load": load,
        "identical": same,
        "floor": floor,
        "executors": stats,
        "paired": paired,
    }


def _block_seconds(job: dict[str, Any], block: Any, as_task: bool = True) -> float:
    """Seconds to simulate and evaluate one block where this function runs (as a task
    does, or with the worker's own allocator settings)."""
    from geomfdi.campaign.executors import run_items
    from geomfdi.campaign.runner import _run_block

    if as_task:
        return run_items(_run_block, job, [block])[1]
    t0 = time.perf_counter()
    _run_block(job, block)
    return time.perf_counter() - t0


def _worker_env() -> dict[str, str | None]:
    keys = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
    return {k: os.environ.get(k) for k in (*keys, "MALLOC_TRIM_THRESHOLD_")}


if __name__ == "__main__":
    try:
        run_thread_modes(main)
    finally:
        _close_dask()
