"""``gf.simulate`` against ``control.forced_response`` on the same composite system.

The scenario is the closed loop of Hou, Wen & Chen (2011) (state feedback ``u = v - K x``)
with a bias
fault on sensor 0 at 40 % of the horizon, observed by a bank of ``nb`` residual
generators (the three hand-built paper generators, padded with random stable third-order
generators for larger banks).  The bias ramps up over 0.5 s, so that both simulators see
the same piecewise-linear signal.

* ``forced_response``: the composite system ``[closed-loop plant; all generators]``
  with inputs ``[v; fault signal]`` and outputs ``r``, simulated by
  :func:`control.forced_response` (a Python loop over the samples);
* ``gf.simulate``: the plant once, faults applied to the readings, then the generators
  (in the coordinates ``w - Pi x``, which the plant state does not drive) by the
  loop-free modal/``lfilter`` recursion of :mod:`geomfdi.simulation.lti` on the lifted system;
* ``gf.simulate_batch``: many Monte-Carlo runs (measurement-noise seeds) in one call;
  aggregate throughput = runs x samples / time.

Both simulators use the first-order hold, so their residuals agree to rounding; the
largest difference is printed.  When ``forced_response`` would take too long at the
largest sizes it is timed at 10^5 samples and extrapolated linearly (rows marked ``*``).

Times are CPU times (``time.process_time``); they include the system time the operating
system spends mapping fresh memory pages, a large and variable part of ``gf.simulate`` at
10^6 samples.  ``gf.simulate`` is timed as the best of three calls.  The whole table is
measured twice, once with BLAS limited to one thread (``threadpoolctl``) and once with
the default threads, and the ratios of both runs are printed side by side.

``--memory`` measures peak memory in a fresh subprocess per case (``tracemalloc``, which
sees numpy's allocations, and the increase of the process's ``ru_maxrss`` after imports
and a warm-up call): ``gf.simulate`` of one long record with measurement noise and a
bank of 10 residuals (peak against the returned arrays), and
``gf.simulate_batch(store="summary")`` (peak against 0.5 GB); then the same calls
untraced, timed with one BLAS thread and with the default threads.  ``--baseline DIR``
runs every case also with the geomfdi of another checkout (e.g. the version before the
chunked simulation) and prints the ratio of its time to this checkout's.  Both calls
process their time axis in chunks sized from ``gf.limits`` ``chunk_memory``.

``--acceptance`` prints only the throughput ratios of ``benchmarks/_throughput.py`` (a
short record of a 12-state plant and a bank of 120 generator states against
``forced_response``; ``simulate_batch`` against a loop of ``simulate``); with
``--short-only``, the short record alone; ``--generator counter``: the batch case draws its
noise with ``gf.Noise(generator="counter")`` (batch and loop alike).

Run ``python benchmarks/bench_simulation.py`` (``--quick`` for a smoke run, ``--full`` to
time ``forced_response`` at every size instead of extrapolating, ``--memory`` for the
memory cases, ``--samples``/``--runs`` to size them).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import geomfdi as gf  # noqa: E402

A = np.array([[1.0, 1, 1], [0, 1, 0], [2, 0, 1]])
B = np.array([[1.0, 0, 1], [0, 1, 1], [0, 1, 0]])
C = np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 2]])
K = np.array([[5.0, -1.5, 3], [2, 0, 2], [-2, 2.5, -2]])
P_PAPER = np.array([[0.0, 1, 0], [-2, 2, 1], [-3, 3, 1]])


def make_bank(nb: int, seed: int = 0) -> gf.ResidualBank:
    """The three paper generators (Hou, Wen & Chen 2011, F = -2) plus random ones.

    A random generator of order 3 picks a stable ``F``, a ``P`` (3 x 3) and ``M``, then
    ``E = (F P - P A) C^-1``, ``G = P B``, ``H = M P C^-1``: it satisfies the identities
    ``F P = P A + E C``, ``M P = H C`` (so its residual is zero on healthy data) and sees
    every sensor.
    """
    Ci = np.linalg.inv(C)
    rng = np.random.default_rng(seed)
    gens = []
    for j in range(nb):
        if j < 3:
            P = P_PAPER[j : j + 1]
            F = np.array([[-2.0]])
            M = np.eye(1)
        else:
            Q = np.linalg.qr(rng.standard_normal((3, 3)))[0]
            F = Q @ np.diag(-rng.uniform(0.5, 5.0, 3)) @ Q.T
            P = rng.standard_normal((3, 3))
            M = rng.standard_normal((1, 3))
        gens.append(
            gf.ResidualGenerator(F, (F @ P - P @ A) @ Ci, P @ B, M, M @ P @ Ci, np.zeros((1, 3)))
        )
    S = np.zeros((nb, 3), dtype=bool)
    return gf.ResidualBank(
        gens, S, S, np.zeros(3, bool), ["ok"] * nb, [gf.SensorFault(i) for i in range(3)]
    )


def composite(bank: gf.ResidualBank):
    """python-control system: inputs [v; fault on y], states [x; w...], outputs r."""
    import control

    Acl = A - B @ K
    gens = bank.generators
    n, q, m = 3, 3, 3
    nw = sum(g.order for g in gens)
    nr = len(gens)
    As = np.zeros((n + nw, n + nw))
    Bs = np.zeros((n + nw, m + q))
    Cs = np.zeros((nr, n + nw))
    Ds = np.zeros((nr, m + q))
    As[:n, :n] = Acl
    Bs[:n, :m] = B
    i = n
    for k, g in enumerate(gens):
        o = g.order
        # y = C x + f, u = v - K x
        As[i : i + o, :n] = -g.E @ C - g.G @ K
        As[i : i + o, i : i + o] = g.F
        Bs[i : i + o, :m] = g.G
        Bs[i : i + o, m:] = -g.E
        Cs[k, :n] = -g.H @ C - g.K @ K
        Cs[k, i : i + o] = g.M
        Ds[k, :m] = g.K
        Ds[k, m:] = -g.H
        i += o
    return control.ss(As, Bs, Cs, Ds)


def consistent_state(bank: gf.ResidualBank, x0: np.ndarray) -> np.ndarray:
    """Generator states of gf.simulate's consistent start, for the baseline."""
    from geomfdi.simulation.initial_state import consistent_initial_state

    Acl = A - B @ K
    parts = [x0]
    for g in bank.generators:
        Pi, _ = consistent_initial_state(g.F, Acl, -g.E @ C - g.G @ K, g.M, -g.H @ C - g.K @ K)
        parts.append(Pi @ x0)
    return np.concatenate(parts)


RAMP = 0.5  # seconds for the bias to reach its final value


def bias(t_fault: float):
    """Bias ramping from 0 at the onset to 0.02 after RAMP seconds (continuous, so the
    first-order hold of forced_response represents it exactly)."""
    return lambda s: 0.02 * np.clip((s - t_fault) / RAMP, 0.0, 1.0)


def inputs(t: np.ndarray, t_fault: float) -> tuple[np.ndarray, np.ndarray]:
    v = np.vstack([np.sin(0.5 * t), np.cos(0.3 * t), 0.2 * np.ones_like(t)])
    f = np.zeros((3, t.size))
    f[0] = bias(t_fault)(t)
    return v, f


def time_gf(bank, t, v, x0, t_fault, repeat=1):
    best = np.inf
    plant = gf.Plant(A, B, C)
    fault = gf.BiasFault(0, start=t_fault, bias=bias(t_fault))
    for _ in range(repeat):
        t0 = time.process_time()
        res = gf.simulate(plant, bank, t, v, faults=[fault], x0=x0, controller=K)
        best = min(best, time.process_time() - t0)
    return best, res.residuals


def time_fr(sysc, t, v, f, X0):
    import control

    t0 = time.process_time()
    out = control.forced_response(sysc, t, np.vstack([v, f]), X0=X0)
    return time.process_time() - t0, np.atleast_2d(out.outputs)


def bench(
    sizes=(10**4, 10**5, 10**6),
    banks=(3, 10, 20),
    batch_runs=100,
    batch_samples=10**5,
    full=False,
    extrapolate_above=10**5,
    dt=1e-3,
) -> list[dict]:
    x0 = np.array([0.5, -0.3, 0.2])
    rows = []
    print(
        f"{'samples':>9} {'bank':>5} {'forced_response s':>18} {'gf.simulate s':>14} "
        f"{'ratio':>8} {'max |dr|':>10}"
    )
    for nb in banks:
        bank = make_bank(nb)
        sysc = composite(bank)
        X0 = consistent_state(bank, x0)
        fr_rate = None
        for N in sizes:
            t = np.arange(N) * dt
            t_fault = float(t[int(0.4 * t.size)])
            v, f = inputs(t, t_fault)
            tg, rg = time_gf(bank, t, v, x0, t_fault, repeat=3)
            if N > extrapolate_above and not full:
                tf = fr_rate * N
                diff = None  # no baseline run to compare with
                mark = "*"
            else:
                tf, rf = time_fr(sysc, t, v, f, X0)
                fr_rate = tf / N
                diff = float(np.max(np.abs(rf - rg)))
                mark = " "
            row = {
                "samples": N,
                "bank": nb,
                "forced_response": tf,
                "simulate": tg,
                "ratio": tf / tg,
                "extrapolated": mark == "*",
                "max_diff": diff,
            }
            rows.append(row)
            dtxt = "-" if diff is None else f"{diff:.2e}"
            print(f"{N:>9} {nb:>5} {tf:>17.3f}{mark} {tg:>14.4f} {tf / tg:>8.1f} {dtxt:>10}")
    if any(r["extrapolated"] for r in rows):
        print(
            f"* forced_response timed at {extrapolate_above} samples and extrapolated "
            "linearly (it steps through time in a Python loop)"
        )
    # ---------------------------------------------------------------- batch
    bank = make_bank(3)
    t = np.arange(batch_samples) * dt
    t_fault = float(t[int(0.4 * t.size)])
    v, f = inputs(t, t_fault)
    noise = gf.Noise(measurement=2e-4, seed=1)
    plant = gf.Plant(A, B, C)
    fl = [gf.BiasFault(0, start=t_fault, bias=bias(t_fault))]
    tb = np.inf
    for _ in range(2):  # best of two, like the single runs
        t0 = time.process_time()
        batch = gf.simulate_batch(
            plant,
            bank,
            t,
            v,
            runs=batch_runs,
            faults=fl,
            x0=x0,
            controller=K,
            noise=noise,
            threshold=0.01,
            progress=False,
        )
        tb = min(tb, time.process_time() - t0)
    n_single = min(batch_runs, 5)
    t0 = time.process_time()
    for i in range(n_single):
        gf.simulate(
            plant,
            bank,
            t,
            v,
            faults=fl,
            x0=x0,
            controller=K,
            noise=gf.Noise(measurement=2e-4, seed=batch.seeds[i]),
            threshold=0.01,
        )
    ts = (time.process_time() - t0) / n_single
    sysc = composite(bank)
    X0 = consistent_state(bank, x0)
    m = min(batch_samples, extrapolate_above)
    tf, _ = time_fr(sysc, t[:m], v[:, :m], f[:, :m], X0)
    fr_sps = m / tf
    agg = batch_runs * batch_samples / tb
    single = batch_samples / ts
    print()
    print(
        f"batch: {batch_runs} Monte-Carlo runs x {batch_samples} samples (bank of 3, "
        "measurement noise)"
    )
    print(f"{'method':<34} {'samples/s':>12} {'vs forced_response':>19}")
    print(f"{'control.forced_response':<34} {fr_sps:>12.3g} {1.0:>19.1f}")
    print(f"{'gf.simulate (one run per call)':<34} {single:>12.3g} {single / fr_sps:>19.1f}")
    print(f"{'gf.simulate_batch (aggregate)':<34} {agg:>12.3g} {agg / fr_sps:>19.1f}")
    print(
        f"detection rate {batch.detection_rate():.2f}, false-alarm rate "
        f"{batch.false_alarm_rate():.3g}"
    )
    rows.append(
        {
            "batch_runs": batch_runs,
            "batch_samples": batch_samples,
            "batch_aggregate": agg,
            "single": single,
            "forced_response_rate": fr_sps,
        }
    )
    return rows


_MEMORY_CASE = """
import contextlib, resource, sys, time, tracemalloc
root, bench = {root!r}, {bench!r}
kind, N, runs, trace, threads = {kind!r}, {samples}, {runs}, {trace}, {threads!r}
sys.path.insert(0, root)
import numpy as np
import geomfdi as gf  # the checkout under test (root), imported before the benchmark module
sys.path.insert(0, bench)
from bench_simulation import A, B, C, K, inputs, make_bank
from threadpoolctl import threadpool_limits
bank, plant = make_bank(10), gf.Plant(A, B, C)
t = np.arange(N) * 1e-3
tf = float(t[int(0.4 * N)])
v, _ = inputs(t, tf)
fl = [gf.BiasFault(0, start=tf, bias=0.02)]
noise = gf.Noise(measurement=2e-4, seed=1)
gf.simulate(plant, bank, t[:1000], v[:, :1000], faults=fl, controller=K, noise=noise,
            threshold=0.01)
gf.simulate_batch(plant, bank, t[:1000], v[:, :1000], runs=2, faults=fl, controller=K,
                  noise=noise, threshold=0.01, store="summary", progress=False)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
limit = threadpool_limits(limits=1) if threads == "1" else contextlib.nullcontext()
with limit:
    if trace:
        tracemalloc.start()
    t0 = time.perf_counter()
    if kind == "single":
        res = gf.simulate(plant, bank, t, v, faults=fl, controller=K, noise=noise,
                          threshold=0.01)
        arrays = (res.x, res.y, res.y_healthy, res.u, res.residuals, res.alarms,
                  res.isolated, res.candidates, res.suspects)
        out = sum(a.nbytes for a in arrays)
    else:
        res = gf.simulate_batch(plant, bank, t, v, runs=runs, faults=fl, controller=K,
                                noise=noise, threshold=0.01, store="summary",
                                progress=False)
        out = res.peak.nbytes + res.healthy_samples.nbytes * 3
    el = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1] if trace else -1
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 - base
print(peak, out, rss, el)
"""


def _memory_case(
    root: str, kind: str, N: int, runs: int, *, trace: bool, threads: str = "1"
) -> dict:
    """One case in a fresh interpreter: tracemalloc peak (``trace``), the increase of the
    peak RSS over the process after imports and a warm-up call, and the time."""
    import subprocess

    here = str(Path(__file__).resolve().parent)
    code = _MEMORY_CASE.format(
        bench=here, root=root, kind=kind, samples=N, runs=runs, trace=trace, threads=threads
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split()
    return {
        "case": kind,
        "samples": N,
        "runs": runs,
        "traced_peak": int(out[0]),
        "returned": int(out[1]),
        "rss_increase": int(out[2]),
        "seconds": float(out[3]),
    }


def memory(
    samples: int = 10**7,
    batch_samples: int = 10**6,
    runs: int = 100,
    trace_runs: int = 10,
    baseline: str | None = None,
) -> list[dict]:
    """Peak memory and time of one long record and of a summary batch.

    Each case runs in a fresh subprocess (this checkout, and ``baseline``: another
    checkout of geomfdi, e.g. the version before chunking, when given):

    * memory: ``tracemalloc`` peak of the call (numpy's allocations) and the increase
      of ``ru_maxrss`` over the process after imports and a warm-up call; the summary
      batch is traced with ``trace_runs`` runs (its memory does not grow with the
      runs: they are simulated a chunk at a time) and its RSS is also taken from the
      untimed full run below;
    * speed: the same calls untraced, once with BLAS limited to one thread and once
      with the default threads; ratio of the baseline's time to this checkout's.
    """
    here = str(Path(__file__).resolve().parents[1])
    roots = [("this checkout", here)] + ([("baseline", baseline)] if baseline else [])
    cases = [("single", samples, 1), ("batch", batch_samples, runs)]
    MB = 1e6
    rows = []
    print(f"chunk_memory budget: {gf.limits.get_limits().chunk_memory / 2**20:.0f} MiB")
    print(
        f"{'case':<34} {'code':<14} {'traced MB':>10} {'RSS+ MB':>9} {'returned MB':>12} "
        f"{'traced/ret':>10} {'RSS+/ret':>9}"
    )
    for kind, N, R in cases:
        name = (
            f"simulate {N:.0e} x 10 residuals"
            if kind == "single"
            else f"batch summary {min(R, trace_runs)} x {N:.0e}"
        )
        for label, root in roots:
            row = _memory_case(
                root, kind, N, min(R, trace_runs) if kind == "batch" else R, trace=True
            )
            row["code"] = label
            rows.append(row)
            ret = row["returned"]
            ratio = f"{row['traced_peak'] / ret:>10.2f}" if kind == "single" else f"{'-':>10}"
            rr = f"{row['rss_increase'] / ret:>9.2f}" if kind == "single" else f"{'-':>9}"
            print(
                f"{name:<34} {label:<14} {row['traced_peak'] / MB:>10.0f} "
                f"{row['rss_increase'] / MB:>9.0f} {ret / MB:>12.1f} {ratio} {rr}"
            )
    print()
    print(
        f"{'case (untraced)':<34} {'threads':<8} {'code':<14} {'s':>8} {'RSS+ MB':>9} "
        f"{'baseline/this':>14}"
    )
    for kind, N, R in cases:
        name = f"simulate {N:.0e}" if kind == "single" else f"batch summary {R} x {N:.0e}"
        for mode in ("1", "default"):
            times = {}
            for label, root in roots:
                row = _memory_case(root, kind, N, R, trace=False, threads=mode)
                row.update(code=label, threads=mode)
                rows.append(row)
                times[label] = row["seconds"]
                ratio = (
                    f"{times['baseline'] / times['this checkout']:>14.2f}"
                    if label == "baseline"
                    else f"{'':>14}"
                )
                print(
                    f"{name:<34} {mode:<8} {label:<14} {row['seconds']:>8.1f} "
                    f"{row['rss_increase'] / MB:>9.0f} {ratio}"
                )
    return rows


def main(argv: list[str] | None = None) -> list[dict]:
    from threadpoolctl import threadpool_limits

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small smoke run")
    ap.add_argument("--full", action="store_true", help="time forced_response at every size")
    ap.add_argument("--memory", action="store_true", help="measure peak memory instead")
    ap.add_argument(
        "--acceptance",
        action="store_true",
        help="only the throughput ratios: short record vs forced_response, batch vs loop",
    )
    ap.add_argument(
        "--short-only", action="store_true", help="acceptance: the short-record ratio alone"
    )
    ap.add_argument(
        "--generator",
        choices=("numpy", "counter"),
        default="numpy",
        help="acceptance: noise generator of the batch case (batch and loop alike)",
    )
    ap.add_argument("--samples", type=float, default=1e7, help="memory: one record's length")
    ap.add_argument("--batch-samples", type=float, default=1e6, help="memory: run length")
    ap.add_argument("--runs", type=int, default=100, help="memory: batch runs")
    ap.add_argument("--trace-runs", type=int, default=10, help="memory: traced batch runs")
    ap.add_argument(
        "--baseline", default=None, help="memory: another geomfdi checkout to compare with"
    )
    args = ap.parse_args(argv)
    if args.memory:
        return memory(
            int(args.samples), int(args.batch_samples), args.runs, args.trace_runs, args.baseline
        )
    if args.acceptance:
        from _throughput import acceptance

        return [acceptance(quick=args.quick, short_only=args.short_only, generator=args.generator)]
    if args.quick:
        kw = dict(
            sizes=(10**3, 10**4),
            banks=(3, 5),
            batch_runs=8,
            batch_samples=2000,
            extrapolate_above=5000,
        )
    else:
        kw = dict(full=args.full)
    print("== BLAS limited to one thread")
    with threadpool_limits(limits=1):
        one = bench(**kw)
    print("\n== default BLAS threads")
    default = bench(**kw)
    print("\nratio forced_response / gf.simulate: one thread vs default threads")
    print(f"{'samples':>9} {'bank':>5} {'1 thread':>9} {'default':>9}")
    for a, b in zip(one, default, strict=True):
        if "ratio" in a:
            print(f"{a['samples']:>9} {a['bank']:>5} {a['ratio']:>9.1f} {b['ratio']:>9.1f}")
    return one + default


if __name__ == "__main__":
    from _threads import run_thread_modes

    if "--memory" in sys.argv:  # each case sets its own thread mode in its subprocess
        main(sys.argv[1:])
    else:
        run_thread_modes(main)
