"""Throughput cases of ``bench_simulation.py --acceptance``: ratios measured in one run.

* ``short``: ``gf.simulate`` of a short record (10^4 samples) of a 12-state plant with a
  bank of 10 generators of order 12 (120 generator states), against
  ``control.forced_response`` of the plant in series with ``bank.to_statespace()`` (the
  way a python-control user simulates a residual bank: inputs ``u``, outputs ``r``).
* ``batch``: ``gf.simulate_batch`` of ``runs`` Monte-Carlo runs (measurement noise, a
  bias fault, state feedback, the bank of 10 of ``bench_simulation.make_bank``) against
  a loop of ``gf.simulate`` calls with the same seeds, both keeping every record
  (residuals, alarms, decisions: about 1 GB for 100 runs of 10^5 samples, whose pages
  the operating system maps and zeroes, populated at once by
  ``geomfdi.simulation.result_memory.mapped``).  Each call first drops its own previous
  records, so that both write into memory the process has just freed.  On a virtual
  machine that hands free memory back to its host (a balloon's free-page reporting), a
  page not used for a few seconds costs 2-17 microseconds on its next first touch, 0.5-4.5
  s of system time for the batch's 1 GB against about 0.5 s for memory just freed; when
  each call replaced its previous records only after making the new ones, the alternation
  gave the loop the batch's freed memory and the batch memory unused for the loop's 10 s.
  Then what a Monte-Carlo study keeps, the events and peaks of every run:
  ``simulate_batch(store="summary")`` against a loop that keeps each run's events and
  peaks only.

Baseline and candidate are timed alternately, each the best of ``repeat`` wall-clock
times, every call started after a pause that lets the BLAS worker threads go idle
(``_timing.best_alternating``: CPU time charged a fast candidate for the spinning of the
baseline's multithreaded BLAS), so that a load change on a shared machine hits both; the
load average is printed with the ratios.  The short case also prints the ratio of the
best CPU times of the same calls (``_timing.best_times``): steadier on a loaded machine,
exact with one BLAS thread; with the default threads it also counts the baseline's BLAS
workers spinning during its call (a flattering baseline), so the wall-clock ratio is
the one that counts.
"""

from __future__ import annotations

import resource
import time

import numpy as np
from _timing import SETTLE, _best_by_clocks, best_alternating, best_times

import geomfdi as gf


def _user() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_utime


def _sys() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_stime


#: Wall clock, then the process's user and system CPU time (the system time of a call
#: with records is mostly the mapping of their fresh memory).
CLOCKS = (time.perf_counter, _user, _sys)


def best_by_clocks(fns, repeat: int, clocks) -> list[list[float]]:
    """Best time of each function by each clock, called alternately after a pause."""
    return _best_by_clocks(fns, repeat, SETTLE, 1, clocks)


def twelve_state_case(nb: int = 10, n: int = 12, m: int = 3, seed: int = 1):
    """A stable 12-state plant with 12 sensors and ``nb`` random generators of order 12.

    Each generator picks a stable symmetric ``F``, ``P`` (n x n) and ``M`` (1 x n), then
    ``E = (F P - P A) C^-1``, ``G = P B``, ``H = M P C^-1`` (``F P = P A + E C``,
    ``M P = H C``: zero residual on healthy data).
    """
    rng = np.random.default_rng(seed)
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    A = Q @ np.diag(-rng.uniform(0.2, 3.0, n)) @ Q.T + 0.3 * rng.standard_normal((n, n))
    B = rng.standard_normal((n, m))
    C = np.eye(n) + 0.1 * rng.standard_normal((n, n))
    Ci = np.linalg.inv(C)
    gens = []
    for _ in range(nb):
        Qj = np.linalg.qr(rng.standard_normal((n, n)))[0]
        F = Qj @ np.diag(-rng.uniform(0.5, 5.0, n)) @ Qj.T
        P = rng.standard_normal((n, n))
        M = rng.standard_normal((1, n))
        E = (F @ P - P @ A) @ Ci
        gens.append(gf.ResidualGenerator(F, E, P @ B, M, M @ P @ Ci, np.zeros((1, m))))
    S = np.zeros((nb, n), dtype=bool)
    faults = [gf.SensorFault(i) for i in range(n)]
    bank = gf.ResidualBank(gens, S, S, np.zeros(n, bool), ["ok"] * nb, faults)
    return gf.Plant(A, B, C), bank


def short_vs_forced_response(N: int = 10**4, repeat: int = 5) -> dict:
    import control

    plant, bank = twelve_state_case()
    n, m = plant.n, plant.m
    t = np.arange(N) * 1e-3
    u = np.vstack([np.sin(0.5 * t), np.cos(0.3 * t), 0.2 * np.ones_like(t)])
    aug = control.ss(
        plant.A,
        plant.B,
        np.vstack([plant.C, np.zeros((m, n))]),
        np.vstack([0 * plant.B, np.eye(m)]),
    )
    sysc = control.series(aug, bank.to_statespace())
    rf = np.atleast_2d(control.forced_response(sysc, t, u).outputs)
    rg = gf.simulate(plant, bank, t, u).residuals
    (tf, cf), (tg, cg) = best_times(
        [lambda: control.forced_response(sysc, t, u), lambda: gf.simulate(plant, bank, t, u)],
        repeat,
        burst=3,  # short calls: the steady state of calls made back to back (_timing)
    )
    return {
        "forced_response": tf,
        "simulate": tg,
        "forced_response_cpu": cf,
        "simulate_cpu": cg,
        "max_diff": float(np.max(np.abs(rf - rg))),
    }


def batch_vs_loop(
    runs: int = 100, N: int = 10**5, repeat: int = 2, generator: str = "numpy"
) -> dict:
    from bench_simulation import A, B, C, K, bias, inputs, make_bank

    bank, plant = make_bank(10), gf.Plant(A, B, C)
    t = np.arange(N) * 1e-3
    tf = float(t[int(0.4 * N)])
    v, _ = inputs(t, tf)
    kw = dict(
        faults=[gf.BiasFault(0, start=tf, bias=bias(tf))],
        controller=K,
        x0=np.array([0.5, -0.3, 0.2]),
        threshold=0.01,
    )
    noise = gf.Noise(measurement=2e-4, seed=1, generator=generator)

    def noise_of(seed):
        return gf.Noise(measurement=2e-4, seed=seed, generator=generator)

    out = {}

    # each call first drops its own previous records (about 1 GB), as a loop over
    # studies does (``del res`` before ``res = ...``): module docstring
    def batch():
        out.pop("batch", None)
        out["batch"] = gf.simulate_batch(
            plant, bank, t, v, runs=runs, noise=noise, progress=False, **kw
        )

    def loop():
        out.pop("loop", None)
        out["loop"] = [gf.simulate(plant, bank, t, v, noise=noise_of(s), **kw) for s in seeds]

    def batch_summary():
        out["summary"] = gf.simulate_batch(
            plant, bank, t, v, runs=runs, noise=noise, progress=False, store="summary", **kw
        )

    def loop_events():
        # what a Monte-Carlo loop keeps of each run: its events and peaks, not the record
        out["events"] = []
        for s in seeds:
            r = gf.simulate(plant, bank, t, v, noise=noise_of(s), **kw)
            out["events"].append((r.events, np.max(np.abs(r.residuals), axis=1)))

    batch()
    seeds = out["batch"].seeds
    (tb, ub, sb), (tl, ul, sl) = best_by_clocks([batch, loop], repeat, CLOCKS)
    diff = max(
        float(np.max(np.abs(r.residuals - out["batch"].residuals[i])))
        for i, r in enumerate(out["loop"])
    )
    out.pop("loop")
    ts, te = best_alternating([batch_summary, loop_events], repeat)
    same = all(
        [e.detection_time for e in out["summary"].events[i]] == [e.detection_time for e in ev]
        for i, (ev, _) in enumerate(out["events"])
    )
    return {
        "batch": tb,
        "loop": tl,
        "batch_user": ub,
        "batch_sys": sb,
        "loop_user": ul,
        "loop_sys": sl,
        "max_diff": diff,
        "summary": ts,
        "loop_events": te,
        "same_events": same,
    }


def acceptance(quick: bool = False, short_only: bool = False, generator: str = "numpy") -> dict:
    """Print the ratios of both cases (``short_only``: of the short record); returns them.
    ``generator``: the noise generator of the batch case (``gf.Noise(generator=...)``),
    the same for the batch and the loop."""
    import os

    print(f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    s = short_vs_forced_response(N=10**4, repeat=3 if quick else 9)
    cpu_ratio = s["forced_response_cpu"] / s["simulate_cpu"]
    print(
        f"short record, 1e4 samples, 12-state plant, bank of 10 x order 12: "
        f"forced_response {s['forced_response'] * 1e3:.1f} ms, gf.simulate "
        f"{s['simulate'] * 1e3:.1f} ms, ratio {s['forced_response'] / s['simulate']:.1f} "
        f"(max |dr| {s['max_diff']:.1e}); by CPU time {s['forced_response_cpu'] * 1e3:.1f} / "
        f"{s['simulate_cpu'] * 1e3:.1f} ms, ratio {cpu_ratio:.1f}"
    )
    if short_only:
        return {"short": s}
    runs, N = (10, 10**4) if quick else (100, 10**5)
    b = batch_vs_loop(runs=runs, N=N, repeat=1 if quick else 3, generator=generator)
    print(
        f"batch, {runs} runs x {N} samples, bank of 10, noise ({generator}): loop of gf.simulate "
        f"{b['loop']:.2f} s, gf.simulate_batch {b['batch']:.2f} s, ratio "
        f"{b['loop'] / b['batch']:.2f} (max |dr| {b['max_diff']:.1e})"
    )
    print(
        f"batch, CPU time (best of each): loop user {b['loop_user']:.2f} s + system "
        f"{b['loop_sys']:.2f} s, batch user {b['batch_user']:.2f} s + system "
        f"{b['batch_sys']:.2f} s; user-time ratio {b['loop_user'] / b['batch_user']:.2f} "
        f"(system time: mostly mapping the records' fresh memory)"
    )
    print(
        f"batch, summaries only: loop of gf.simulate keeping each run's events and peaks "
        f"{b['loop_events']:.2f} s, gf.simulate_batch(store='summary') {b['summary']:.2f} s, "
        f"ratio {b['loop_events'] / b['summary']:.2f} (same detection times: {b['same_events']})"
    )
    return {"short": s, "batch": b}
