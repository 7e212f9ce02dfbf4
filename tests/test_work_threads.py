"""geomfdi's own threads (``geomfdi._threads.work_threads``): how many an entry point
may use, and that a batch split between threads gives exactly the unsplit results.

The cores the BLAS limit frees go to the runs of a batch: the noise draws of a chunk's
runs and the compiled recursion of their bank are split into parts, one per thread.
Each run keeps its own generator and its own SIMD lanes, so splitting may not change a
single bit.
"""

from __future__ import annotations

import importlib
import os
import shutil
import threading

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import geomfdi as gf
import geomfdi._threads as th
import geomfdi.simulation.compiled_recursion as cr
from geomfdi.campaign.executors import Shipped, run_items
from geomfdi.errors import ShapeError
from geomfdi.simulation.lifting import Drive

sim = importlib.import_module("geomfdi.simulation.simulate")  # the module, not the function
needs_cc = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler (cc)")


pytestmark = pytest.mark.usefixtures("c_cache")


@th.limit_blas_threads
def _inside() -> int:
    return th.work_threads()


def _blas_libraries() -> bool:
    import scipy.linalg  # noqa: F401  (its BLAS loaded too)

    return any(i["user_api"] == "blas" for i in threadpool_info())


def _blas_threads() -> int:
    return max(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas")


# ------------------------------------------------------------------ the thread count
def test_work_threads_follow_the_blas_setting_at_the_entry_point():
    if not _blas_libraries():
        pytest.skip("no BLAS library seen by threadpoolctl")
    assert th.work_threads() == 1  # outside an entry point
    with threadpool_limits(limits=1, user_api="blas"):
        assert _inside() == 1
    cores = os.cpu_count() or 1
    with threadpool_limits(limits=3, user_api="blas"):
        assert _inside() == min(3, cores)
        # the BLAS itself runs one thread inside, and is set back after
        assert _blas_threads() == 3
    with th.using_work_threads(5):
        assert th.work_threads() == 5
        assert _inside() == 5  # nested entry point: the outer setting stands
    assert th.work_threads() == 1


def test_no_work_threads_off_the_main_thread_or_without_a_limit():
    if not _blas_libraries():
        pytest.skip("no BLAS library seen by threadpoolctl")
    seen = []
    with threadpool_limits(limits=2, user_api="blas"):
        t = threading.Thread(target=lambda: seen.append(_inside()))
        t.start()
        t.join()
        old = th.get_blas_threads()
        th.set_blas_threads(None)  # the BLAS keeps its threads: no core is freed
        try:
            seen.append(_inside())
        finally:
            th.set_blas_threads(old)
    assert seen == [1, 1]


def _probe(job, item):
    return th.work_threads()


def test_campaign_tasks_in_worker_processes_use_one_thread():
    with th.using_work_threads(4):
        shipped, _, _ = run_items.__wrapped__(_probe, Shipped({"job": 1}), [0, 1])
        own, _, _ = run_items.__wrapped__(_probe, {"job": 1}, [0])  # serial: the job itself
    assert shipped == [1, 1]
    assert own == [4]


# ------------------------------------------------------------------ same results
def _spy(monkeypatch, module):
    calls = []
    real = module.thread_pool

    def pool(k):
        calls.append(k)
        return real(k)

    monkeypatch.setattr(module, "thread_pool", pool)
    return calls


def _case(runs: int, N: int, gain: bool):
    A = [[0.0, 1.0, 0.0], [-2.0, -0.7, 0.3], [0.0, 0.0, -1.5]]
    plant = gf.Plant(A, [[0.0], [1.0], [0.5]], np.eye(3))
    bank = gf.design_sensor_bank(plant)
    t = np.arange(N) * 1e-3
    u = np.sin(3 * t)[None]
    onset = float(t[N // 3])
    if gain:  # exact gain channels: scaled drives in the compiled kernel
        faults = [[gf.GainFault(1, start=onset, gain=1.0 + 0.01 * i)] for i in range(runs)]
    else:
        faults = [[gf.BiasFault(0, start=onset, bias=0.002 * i)] for i in range(runs)]
    return plant, bank, t, u, faults


@needs_cc
@pytest.mark.parametrize(("runs", "gain"), [(37, False), (40, True)])
def test_batch_split_between_threads_equals_one_thread(monkeypatch, runs, gain):
    plant, bank, t, u, faults = _case(runs, 6000, gain)
    noise = gf.Noise(measurement=1e-3, seed=3)
    monkeypatch.setattr(cr, "_MIN_PART_WORK", 1)  # split even this small case

    def run(threads):
        with th.using_work_threads(threads):
            return gf.simulate_batch.__wrapped__(
                plant, bank, t, u, faults=faults, noise=noise, threshold=0.05, progress=False
            )

    one = run(1)
    kernel, draws = _spy(monkeypatch, cr), _spy(monkeypatch, sim)
    three = run(3)
    assert kernel and max(kernel) >= 2  # runs split in parts of whole SIMD groups
    assert draws and max(draws) >= 2
    np.testing.assert_array_equal(three.residuals, one.residuals)
    np.testing.assert_array_equal(three.alarms, one.alarms)
    np.testing.assert_array_equal(three.isolated, one.isolated)
    assert np.any(one.alarms)  # the faults are seen: the comparison is not of zeros
    # and a run equals its own simulate (the seed contract)
    r5 = gf.simulate(
        plant, bank, t, u, faults=faults[5], noise=gf.Noise(measurement=1e-3, seed=one.seeds[5]),
        threshold=0.05,
    )  # fmt: skip
    np.testing.assert_allclose(r5.residuals, one.residuals[5], rtol=0, atol=1e-12)


@needs_cc
def test_kernel_parts_move_every_per_run_pointer(monkeypatch):
    """The compiled recursion of a system with per-run, shared and scaled drives and
    feedthrough, split in parts: equal to the unsplit call bit for bit, final states too."""
    rng = np.random.default_rng(7)
    R, N, sizes = 45, 900, [2, 3]
    blocks = [0.5 * rng.standard_normal((n, n)) / n for n in sizes]
    own, shared = rng.standard_normal((2, R, N)), rng.standard_normal((2, 1, N))
    drives = [
        Drive(own),
        Drive(own, 1),
        Drive(shared),
        Drive(shared, 0, rng.standard_normal((1, R, N - 1))),  # shared, scaled per run
        Drive(own[:1], 0, rng.standard_normal((1, 1, N - 1))),  # per run, shared scale
    ]
    W = rng.standard_normal((sum(sizes), 9))
    x0 = rng.standard_normal((sum(sizes), R))
    outputs = [[rng.standard_normal((2, n))] for n in sizes]
    direct = ([rng.standard_normal((2, R, N)), rng.standard_normal((1, 1, N))],
              [[rng.standard_normal((2, 3))] for _ in sizes])  # fmt: skip
    monkeypatch.setattr(cr, "_MIN_PART_WORK", 1)
    results = {}
    parts = _spy(monkeypatch, cr)
    for k in (1, 2, 3):
        with th.using_work_threads(k):
            results[k] = cr.compiled_block_recursion(
                blocks, W, drives, x0, outputs, N, direct=direct, final=True
            )
    assert parts == [2, 2, 3, 3, 3]  # a task per part; 45 runs: 3 groups of 16 runs
    for k in (2, 3):
        for a, b in zip(sum(results[k][0], []), sum(results[1][0], []), strict=True):
            np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(results[k][1], results[1][1])
    assert np.all(np.isfinite(results[1][1])) and np.any(results[1][1] != x0)


@needs_cc
def test_kernel_refuses_an_input_matrix_of_the_wrong_width():
    drives = [Drive(np.zeros((2, 3, 50)))]
    with pytest.raises(ShapeError, match="W: expected"):
        cr.compiled_block_recursion([np.eye(2)], np.zeros((2, 3)), drives, np.zeros((2, 1)),
                                    [[np.eye(2)]], 50)  # fmt: skip


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork")
def test_a_forked_child_gets_its_own_thread_pool():
    """A child forked after the parent used its pool (a process pool of the caller's)
    must not submit to the parent's threads, which do not exist in the child."""
    import multiprocessing as mp

    parent = th.thread_pool(2)
    assert parent.submit(lambda: 7).result() == 7
    ctx = mp.get_context("fork")
    with ctx.Pool(1) as pool:
        got = pool.apply_async(_child_pool_works).get(timeout=60)
    assert got == (True, 7)


def _child_pool_works():
    pool = th.thread_pool(2)
    return pool is not None, pool.submit(lambda: 7).result(timeout=5)
