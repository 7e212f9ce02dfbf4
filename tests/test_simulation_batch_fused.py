"""``simulate_batch`` through the fused pass: the same runs as the chunked engine."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

import geomfdi as gf
from geomfdi._threads import using_work_threads
from geomfdi.simulation import batch, fused

A = np.array([[1.0, 1, 1], [0, 1, 0], [2, 0, 1]])
B = np.array([[1.0, 0, 1], [0, 1, 1], [0, 1, 0]])
C = np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 2]])
K = np.array([[5.0, -1.5, 3], [2, 0, 2], [-2, 2.5, -2]])
X0 = np.array([0.5, -0.3, 0.2])


def _bank(nb: int = 5, vector: bool = False) -> gf.ResidualBank:
    """Generators with ``F P = P A + E C``, ``M P = H C`` (zero residual when healthy),
    each seeing every sensor; ``vector``: the last one has two outputs."""
    Ci = np.linalg.inv(C)
    rng = np.random.default_rng(3)
    gens = []
    for j in range(nb):
        Q = np.linalg.qr(rng.standard_normal((3, 3)))[0]
        F = Q @ np.diag(-rng.uniform(0.5, 5.0, 3)) @ Q.T
        P = rng.standard_normal((3, 3))
        M = rng.standard_normal((2 if vector and j == nb - 1 else 1, 3))
        gens.append(
            gf.ResidualGenerator(
                F, (F @ P - P @ A) @ Ci, P @ B, M, M @ P @ Ci, np.zeros((M.shape[0], 3))
            )
        )
    S = np.zeros((nb, 3), dtype=bool)
    return gf.ResidualBank(
        gens, S, S, np.zeros(3, bool), ["ok"] * nb, [gf.SensorFault(i) for i in range(3)]
    )


def _ramp(t0: float):
    return lambda s: 0.02 * np.clip((s - t0) / 0.5, 0.0, 1.0)


def _both(monkeypatch, **kw):
    """The batch through the fused pass and through the chunked engine, and how many
    times the fused pass ran."""
    calls = []
    run = batch._fused_batch

    def counted(*a, **k):
        calls.append(1)
        return run(*a, **k)

    monkeypatch.setattr(batch, "_fused_batch", counted)
    monkeypatch.setattr(batch, "FUSED_MIN_WORK", 0)
    got = gf.simulate_batch(progress=False, **kw)
    monkeypatch.setattr(batch, "FUSED_MIN_WORK", 10**18)
    ref = gf.simulate_batch(progress=False, **kw)
    return got, ref, len(calls)


def _same(got, ref, kept: bool) -> None:
    def events(res):
        return [
            [(e.detection_time, e.isolation_time, e.decided, e.hypothesis) for e in r]
            for r in res.events
        ]

    assert events(got) == events(ref)
    np.testing.assert_allclose(got.peak, ref.peak, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(got.false_alarm_counts, ref.false_alarm_counts)
    np.testing.assert_array_equal(got.false_alarm_events, ref.false_alarm_events)
    np.testing.assert_array_equal(got.healthy_samples, ref.healthy_samples)
    if kept:
        scale = np.abs(ref.residuals).max()
        np.testing.assert_allclose(got.residuals, ref.residuals, rtol=1e-12, atol=1e-13 * scale)
        np.testing.assert_array_equal(got.alarms, ref.alarms)
        np.testing.assert_array_equal(got.isolated, ref.isolated)


@pytest.mark.parametrize("generator", ["numpy", "counter"])
@pytest.mark.parametrize("store", ["residuals", "summary"])
@pytest.mark.parametrize("per_run", [False, True])
def test_fused_batch_equals_the_engine(monkeypatch, generator, store, per_run):
    N, runs = 6000, 37  # a last group of lanes partly filled
    t = np.arange(N) * 1e-3
    v = np.vstack([np.sin(0.5 * t), np.cos(0.3 * t), 0.2 * np.ones_like(t)])
    if per_run:  # a sweep: each run its sensor, size and onset
        faults = [
            [gf.BiasFault(r % 3, start=2.0 + 0.01 * r, bias=0.002 * (r + 1))] for r in range(runs)
        ]
    else:  # a callable bias (sampled), a gain and a constant bias on one sensor
        faults = [
            gf.BiasFault(0, start=2.4, bias=_ramp(2.4)),
            gf.GainFault(1, start=1.5, gain=1.4),
            gf.BiasFault(1, start=3.0, end=4.0, bias=lambda s: 0.01 * np.sin(3 * s)),
        ]
    noise = gf.Noise(measurement=2e-4, seed=5, generator=generator)
    kw = dict(
        plant=gf.Plant(A, B, C), bank=_bank(), t=t, u=v, runs=runs, faults=faults,
        controller=K, x0=X0, threshold=0.01, noise=noise, store=store,
    )  # fmt: skip
    got, ref, fused_calls = _both(monkeypatch, **kw)
    assert fused_calls == 1
    assert any(r for r in ref.events) and ref.false_alarm_counts.sum() >= 0
    _same(got, ref, store == "residuals")
    # the residuals see the faults: a detection in most runs
    assert sum(any(e.detection_time is not None for e in r) for r in got.events) > runs // 2


@pytest.mark.parametrize("threads", [1, 2])
def test_fused_batch_rules_vectors_and_threads(monkeypatch, threads):
    # a persistence rule (decided by numpy on each window), a vector residual, no
    # threshold; the runs split between two threads
    N, runs = 5000, 40
    t = np.arange(N) * 1e-3
    v = np.vstack([np.sin(t), np.cos(t), np.ones_like(t)])
    common = dict(
        plant=gf.Plant(A, B, C), bank=_bank(4, vector=True), t=t, u=v, runs=runs,
        faults=[gf.GainFault(2, start=2.0, gain=1.3)], controller=K, x0=X0,
        noise=gf.Noise(measurement=1e-3, seed=2),
    )  # fmt: skip
    with using_work_threads(threads):
        for extra in (
            dict(threshold=0.02, persistence=gf.Persistence(3, 5), store="residuals"),
            dict(threshold=None, store="summary"),
        ):
            got, ref, fused_calls = _both(monkeypatch, **common, **extra)
            assert fused_calls == 1
            _same(got, ref, extra["store"] == "residuals")


def test_fused_summary_memory_does_not_grow_with_the_runs(monkeypatch):
    monkeypatch.setattr(batch, "FUSED_MIN_WORK", 0)
    N = 200_000
    t = np.arange(N) * 1e-4
    kw = dict(
        plant=gf.Plant(A, B, C), bank=_bank(3), t=t, u=np.ones((3, N)),
        faults=[gf.BiasFault(0, start=10.0, bias=0.05)], controller=K, x0=X0,
        threshold=0.05, noise=gf.Noise(measurement=1e-3, seed=1), store="summary",
        progress=False,
    )  # fmt: skip
    gf.simulate_batch(runs=32, **kw)  # the kernel built, the thread's buffers made
    peaks = {}
    for runs in (32, 64):
        tracemalloc.start()
        try:
            res = gf.simulate_batch(runs=runs, **kw)
            peaks[runs] = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert all(any(e.detection_time is not None for e in r) for r in res.events)
    record = 32 * 3 * N * 8  # the residuals of 32 runs: 154 MB
    # what is shared by the runs is O(N); per run, O(1): 32 more runs add no record
    assert peaks[32] < record / 2, peaks
    assert peaks[64] - peaks[32] < record / 20, peaks


def test_a_plan_larger_than_its_budget_takes_the_engine(monkeypatch):
    from geomfdi import limits

    calls = []
    monkeypatch.setattr(batch, "_fused_batch", lambda *a, **k: calls.append(1))
    monkeypatch.setattr(batch, "FUSED_MIN_WORK", 0)
    N = 20_000
    t = np.arange(N) * 1e-3
    kw = dict(
        plant=gf.Plant(A, B, C), bank=_bank(3), t=t, runs=4, controller=K, x0=X0,
        noise=gf.Noise(measurement=1e-3, seed=1), store="summary", progress=False,
    )  # fmt: skip
    with limits.limits(chunk_memory=2**20):  # the shared arrays need about 4 MB
        gf.simulate_batch(**kw)
    assert calls == []


def test_fused_plan_takes_callable_biases_not_callable_gains():
    t = np.arange(300) * 1e-3
    p, bank = gf.Plant(A, B, C), _bank(2)
    noise = gf.Noise(measurement=1e-3, seed=1)
    ok, why = fused.fused_plan(
        p, bank, t, None, fault_lists=[[gf.BiasFault(1, start=0.1, bias=_ramp(0.1))]],
        noise=noise, controller=K,
    )  # fmt: skip
    assert ok is not None, why
    no, why = fused.fused_plan(
        p, bank, t, None, fault_lists=[[gf.GainFault(1, start=0.1, gain=lambda s: 1 + s)]],
        noise=noise, controller=K,
    )  # fmt: skip
    assert no is None and "gain is not a number" in why


def test_fused_runs_sink_sees_every_window_once():
    N, runs = 9000, 20
    t = np.arange(N) * 1e-3
    p, bank = gf.Plant(A, B, C), _bank(3)
    lists = [[gf.BiasFault(0, start=4.0, bias=_ramp(4.0))]]
    noise = gf.Noise(measurement=1e-3, seed=1)
    plan, why = fused.fused_plan(p, bank, t, None, fault_lists=lists, noise=noise, controller=K)
    assert plan is not None, why
    seeds = list(np.random.SeedSequence(4).spawn(runs))
    ref = fused.fused_runs(plan, lists * runs, seeds)
    got = np.full_like(ref, np.nan)
    seen = []

    def sink(a, b, s, e, rows):
        assert rows.shape == (b - a, ref.shape[1], e - s)
        got[a:b, :, s:e] = rows
        seen.append((a, s))

    assert fused.fused_runs(plan, lists * runs, seeds, sink=sink) is None
    np.testing.assert_array_equal(got, ref)
    assert len(seen) == len(set(seen))
    starts = sorted({a for a, _ in seen})
    assert all(
        [s for a2, s in seen if a2 == a] == sorted(s for a2, s in seen if a2 == a) for a in starts
    )


def test_fused_runs_called_directly_use_the_blas_threads():
    # an entry point: as many work threads as the BLAS had when it was called
    import threading

    from threadpoolctl import threadpool_limits

    N, runs = 20_000, 40
    t = np.arange(N) * 1e-3
    p, bank = gf.Plant(A, B, C), _bank(3)
    lists = [[gf.BiasFault(0, start=4.0, bias=0.02)]]
    noise = gf.Noise(measurement=1e-3, seed=1)
    plan, why = fused.fused_plan(p, bank, t, None, fault_lists=lists, noise=noise, controller=K)
    assert plan is not None, why
    seeds = list(np.random.SeedSequence(4).spawn(runs))
    for threads in (1, 2):
        names = set()

        def sink(a, b, s, e, rows, names=names):
            names.add(threading.current_thread().name)

        with threadpool_limits(threads):
            fused.fused_runs(plan, lists * runs, seeds, sink=sink)
        assert len(names) == threads
