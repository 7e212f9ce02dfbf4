"""Thread and task safety of the rank-decision policy (``geomfdi.tolerance``).

The tolerance set by ``with tolerance(...)`` and the recorders of
``record_decisions()`` are context variables: a design running in one thread (or asyncio
task) must give the same result as when run alone, whatever other threads do with their
own tolerance at the same time.
"""

from __future__ import annotations

import asyncio
import random
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.tolerance import default_rtol, get_rtol, record_decisions, tolerance

SEED001 = (
    [[1, 1, 1], [0, 1, 0], [2, 0, 1]],
    [[1, 0, 1], [0, 1, 1], [0, 1, 0]],
    [[0, 1, 0], [0, 0, 1], [1, 0, 2]],
)


def tolerance_sensitive_case(kept: float = 1e-3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """W* = span(e1, e2, e3) decided on a singular value ``kept`` (dimension 2 when
    ``rtol`` exceeds ``kept``): C = e4ᵀ, L = [e1, e2], A e1 = kept e3, A e4 = e4."""
    A = np.zeros((4, 4))
    A[3, 3], A[2, 0] = 1.0, kept
    return A, np.array([[0.0, 0.0, 0.0, 1.0]]), np.eye(4)[:, :2]


def w_star(rtol: float | None) -> tuple:
    A, C, L = tolerance_sensitive_case()
    with tolerance(rtol):
        W = gf.min_conditioned_invariant(A, C, L)
        S = gf.min_unobservability_subspace(A, C, L)
    return (
        "W",
        W.dim,
        tuple(W.history),
        W.min_gap,
        S.W.dim,
        S.min_gap,
        W.basis.round(12).tobytes(),
    )


def bank(rtol: float | None) -> tuple:
    with tolerance(rtol):
        b = gf.design_sensor_bank(gf.Plant(*SEED001))
    gens = [g for g in b.generators if g is not None]
    mats = tuple(np.asarray(m).round(10).tobytes() for g in gens for m in (g.F, g.E, g.G, g.M, g.H))
    return ("bank", tuple(g.order for g in gens), b.structure.tobytes(), mats)


TASKS = [
    (w_star, None),
    (w_star, 1e-2),
    (w_star, 0.5),
    (w_star, 1e-9),
    (bank, None),
    (bank, 1e-6),
]


def test_the_tasks_depend_on_the_tolerance():
    """Otherwise the threaded comparison below could not detect a leak."""
    assert w_star(None)[1] == 3 and w_star(0.5)[1] == 2 and w_star(1e-2)[1] == 2
    assert w_star(None) != w_star(0.5)


@pytest.mark.slow
def test_eight_threads_mixing_tolerance_contexts_give_the_sequential_results():
    expected = [fn(rtol) for fn, rtol in TASKS]
    barrier = threading.Barrier(8)

    def worker(seed: int) -> list[tuple[int, tuple]]:
        order = [i for i in range(len(TASKS)) for _ in range(2)]
        random.Random(seed).shuffle(order)
        barrier.wait()
        return [(i, TASKS[i][0](TASKS[i][1])) for i in order]

    with ThreadPoolExecutor(8) as pool:
        results = list(pool.map(worker, range(8)))
    mismatches = [(i, got) for run in results for i, got in run if got != expected[i]]
    assert sum(len(run) for run in results) == 8 * 2 * len(TASKS)
    assert mismatches == []


def test_w_star_unaffected_by_another_thread_inside_tolerance_half():
    A, C, L = tolerance_sensitive_case()
    inside, done = threading.Event(), threading.Event()
    loose_dims: list[int] = []

    def loose() -> None:
        with tolerance(0.5):
            inside.set()
            while not done.is_set():
                loose_dims.append(gf.min_conditioned_invariant(A, C, L).dim)

    t = threading.Thread(target=loose)
    t.start()
    try:
        assert inside.wait(10)
        dims = [gf.min_conditioned_invariant(A, C, L).dim for _ in range(200)]
    finally:
        done.set()
        t.join()
    assert dims == [3] * 200
    assert loose_dims and set(loose_dims) == {2}


def test_recorders_see_only_their_own_thread():
    A, C, L = tolerance_sensitive_case()
    start = threading.Barrier(2)
    counts: dict[str, int] = {}

    def record(name: str, calls: int) -> None:
        with record_decisions() as rec:
            start.wait()
            for _ in range(calls):
                gf.min_conditioned_invariant(A, C, L)
        counts[name] = len(rec)

    one = gf.min_conditioned_invariant(A, C, L)
    with record_decisions() as rec:
        gf.min_conditioned_invariant(A, C, L)
    per_call = len(rec)
    assert per_call > 0 and one.dim == 3
    threads = [threading.Thread(target=record, args=(n, k)) for n, k in (("a", 5), ("b", 40))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert counts == {"a": 5 * per_call, "b": 40 * per_call}


def test_set_rtol_inside_a_block_is_local_and_outside_is_process_wide():
    seen: list[float] = []
    with tolerance(1e-4):
        gf.set_rtol(1e-5)
        assert get_rtol(3) == 1e-5
        other = threading.Thread(target=lambda: seen.append(get_rtol(3)))
        other.start()
        other.join()
    assert seen == [default_rtol(3)]
    assert get_rtol(3) == default_rtol(3)
    gf.set_rtol(1e-6)
    try:
        other = threading.Thread(target=lambda: seen.append(get_rtol(3)))
        other.start()
        other.join()
        assert seen[-1] == 1e-6
        with tolerance(None):
            assert get_rtol(3) == default_rtol(3)
    finally:
        gf.set_rtol(None)
    assert get_rtol(3) == default_rtol(3)


def test_asyncio_tasks_keep_their_own_tolerance():
    async def task(rtol: float, out: list[float]) -> None:
        with tolerance(rtol):
            for _ in range(5):
                await asyncio.sleep(0)
                out.append(get_rtol(3))

    async def main() -> tuple[list[float], list[float]]:
        a: list[float] = []
        b: list[float] = []
        await asyncio.gather(task(1e-3, a), task(1e-8, b))
        return a, b

    a, b = asyncio.run(main())
    assert a == [1e-3] * 5 and b == [1e-8] * 5
    assert get_rtol(3) == default_rtol(3)


@pytest.mark.parametrize("bad", [0.0, 1.0, float("nan"), "abc", True, 1j, [1e-3]])
def test_tolerance_block_rejects_bad_rtol_before_entering(bad):
    with pytest.raises(gf.errors.GeomFDIError) as err:
        with tolerance(bad):
            pass  # pragma: no cover - never entered
    assert err.value.argument == "rtol"
    assert get_rtol(3) == default_rtol(3)
