"""Where a campaign's blocks run (geomfdi.campaign.executors): the job is pickled once and
unpickled at most once per worker process, tasks are sized by the stated rule, workers
run one BLAS thread, and the table is the serial one bit for bit."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import time
import uuid
from collections import Counter
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from small_campaign import T, small_campaign

import geomfdi as gf
from geomfdi.campaign import executors
from geomfdi.campaign.spec import _SensorFaults
from geomfdi.errors import GeomFDIError

ROOT = Path(__file__).resolve().parents[1]


def _rebuild(folder: str, kind: str, sensor: int) -> _Spy:
    """Unpickling a :class:`_Spy` leaves a file named by the unpickling process."""
    Path(folder, f"{os.getpid()}-{uuid.uuid4().hex}").touch()
    return _Spy(folder, kind, sensor)


class _Spy(_SensorFaults):
    """Sensor faults whose every unpickling is recorded (a file per unpickling, named by
    the process), and whose every pickling is counted in the pickling process."""

    dumps = 0

    def __init__(self, folder: str, kind: str = "bias", sensor: int = 0) -> None:
        super().__init__(kind, sensor)
        self.folder = folder

    def __reduce__(self):
        type(self).dumps += 1
        return _rebuild, (self.folder, self.kind, self.sensor)


def _unpicklings(folder: Path) -> Counter:
    return Counter(p.name.split("-")[0] for p in folder.iterdir())


def _campaign(faults) -> gf.Campaign:
    return small_campaign(faults, block_size=2)  # 12 blocks


@pytest.fixture(scope="module")
def serial() -> pd.DataFrame:
    return _campaign(_SensorFaults("bias", 0)).run("serial", progress=False).table


# ------------------------------------------------------------------ task size rule
@settings(max_examples=200, deadline=None)
@given(
    blocks=st.integers(1, 10_000),
    workers=st.integers(1, 16),
    block=st.floats(1e-5, 10.0),
    overhead=st.floats(1e-4, 1.0),
)
def test_task_size_is_the_fewest_blocks_within_the_overhead_share_unless_balance_binds(
    blocks, workers, block, overhead
):
    per = executors.task_size(blocks, workers, block, overhead)
    share, k = executors.OVERHEAD_SHARE, executors.TASKS_PER_WORKER
    assert 1 <= per <= blocks
    within = overhead <= share * per * block * (1 + 1e-12)
    balance = max(1, blocks // (k * workers))
    # the overhead stays within its share, or the balance bound is what stopped it
    assert within or per == balance
    # every slot gets its k tasks whenever there are blocks for them
    assert -(-blocks // per) >= min(blocks, k * workers)
    # fewest: one block less would break the share (or it is one block already)
    assert per == 1 or overhead > share * (per - 1) * block or per == balance


@settings(max_examples=200, deadline=None)
@given(
    start=st.integers(0, 50),
    items=st.integers(0, 400),
    workers=st.integers(1, 16),
    least=st.integers(1, 40),
)
def test_guided_spans_cover_the_items_in_shrinking_tasks(start, items, workers, least):
    spans = executors.guided_spans(start, start + items, workers, least)
    if not items:
        assert spans == []
        return
    # consecutive, in order, every item once
    assert [a for a, _ in spans] == [start] + [b for _, b in spans[:-1]]
    assert (spans[-1][1] if spans else start) == start + items
    sizes = [b - a for a, b in spans]
    # none larger than its share of what was left; none smaller than least while more
    # than workers * least were left, then shrinking to one item
    left, tail = items, 0
    for z in sizes:
        share = -(-left // (2 * workers))
        if left > workers * least:
            assert z == min(left, max(least, share))
        else:
            assert z == max(1, share)
            tail += 1
        left -= z
    assert sizes == sorted(sizes, reverse=True)  # large first, small last
    assert sizes[-1] == 1 or tail == 0  # the tail ends with one item
    # before the tail, no more tasks than a fixed size of least
    assert len(spans) - tail <= -(-items // least)


def test_worker_slots_of_pools_and_clients():
    with ProcessPoolExecutor(max_workers=3) as pool:
        assert executors.worker_slots(pool) == 3

    class Client:  # what a distributed.Client answers
        def nthreads(self):
            return {"tcp://a": 2, "tcp://b": 1}

    assert executors.worker_slots(Client()) == 3


# ------------------------------------------------------------------------ shipping
def test_the_job_is_pickled_once_and_unpickled_once_per_process(tmp_path):
    spy = _Spy(str(tmp_path))
    shipped = executors.Shipped({"faults": spy, "t": T})
    before = _Spy.dumps
    blobs = [pickle.dumps(shipped) for _ in range(3)]
    assert _Spy.dumps - before == 1  # the job's pickle is made once and reused
    try:
        got = [pickle.loads(b) for b in blobs]
        assert sum(_unpicklings(tmp_path).values()) == 1  # then found by its key
        assert got[0] is got[1] is got[2]
        assert np.array_equal(got[0].job["t"], T) and got[0].job["t"] is not T
        # by key: a few bytes, and only where the job was installed
        small = pickle.dumps(shipped.by_key())
        assert len(small) < 200 < len(blobs[0])
        executors._JOBS.clear()
        with pytest.raises(GeomFDIError, match="not installed") as info:
            pickle.loads(small)
        assert info.value.argument == "executor"
    finally:
        executors._JOBS.clear()


def test_a_process_pool_unpickles_the_job_once_per_worker(tmp_path, serial):
    folder = tmp_path / "pool"
    folder.mkdir()
    with ProcessPoolExecutor(max_workers=2) as pool:
        res = _campaign(_Spy(str(folder))).run(pool, blocks_per_task=1, progress=False)
    seen = _unpicklings(folder)
    assert res.info["executor"]["tasks"] == 12
    assert os.getpid() not in {int(p) for p in seen}
    assert seen and set(seen.values()) == {1}  # each worker once, for its 6 or so tasks
    pd.testing.assert_frame_equal(res.table, serial, check_exact=True)


def test_own_processes_get_the_job_from_their_initializer(tmp_path, serial):
    folder = tmp_path / "own"
    folder.mkdir()
    res = _campaign(_Spy(str(folder))).run(
        "processes", workers=2, blocks_per_task=1, progress=False
    )
    seen = _unpicklings(folder)
    assert res.info["executor"]["tasks"] == 12
    assert all(n == 1 for n in seen.values()) and len(seen) <= 2  # forked: none at all
    pd.testing.assert_frame_equal(res.table, serial, check_exact=True)


def test_auto_task_size_gives_the_serial_table(serial):
    c = _campaign(_SensorFaults("bias", 0))
    res = c.run("processes", workers=2, progress=False)  # blocks_per_task="auto"
    info = res.info["executor"]
    assert info["block_seconds"] > 0 and info["task_overhead"] >= executors.MIN_OVERHEAD
    # 3 one-block tasks a worker measure; the other 6 blocks go into shrinking tasks,
    # none below the rule's size
    first = executors.FIRST_TASKS_PER_SLOT * 2
    least = executors.task_size(12 - first, 2, info["block_seconds"], info["task_overhead"])
    spans = executors.guided_spans(first, 12, 2, least)
    assert info["least_blocks_per_task"] == least
    assert info["tasks"] == first + len(spans)
    sizes = sorted(b - a for a, b in spans)
    assert info["blocks_per_task"] == sizes[len(sizes) // 2]
    pd.testing.assert_frame_equal(res.table, serial, check_exact=True)
    with pytest.raises(GeomFDIError) as exc:
        c.run("serial", blocks_per_task="many")
    assert exc.value.argument == "blocks_per_task"


@pytest.mark.slow
def test_dask_scatters_the_job_once_per_worker_and_gives_the_serial_table(tmp_path, serial):
    distributed = pytest.importorskip("distributed")
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        pids = {str(p) for p in client.run(os.getpid).values()}
        assert len(pids) == 2
        for per in (1, "auto"):
            folder = tmp_path / f"dask-{per}"
            folder.mkdir()
            res = _campaign(_Spy(str(folder))).run(client, blocks_per_task=per, progress=False)
            assert res.info["executor"]["tasks"] > 2
            assert _unpicklings(folder) == Counter(dict.fromkeys(pids, 1))
            pd.testing.assert_frame_equal(res.table, serial, check_exact=True)


class _ScatteringPool(ThreadPoolExecutor):
    """A thread pool that ``execute`` takes for a Dask client (it has ``scatter``)."""

    def __init__(self):
        super().__init__(2)
        self.futures = []

    def scatter(self, data, **kwargs):
        return list(data)

    def submit(self, fn, *args):
        fut = super().submit(fn, *args)
        self.futures.append(fut)
        return fut


def _scaled(job, item):
    return {"x": np.full(3, job["scale"] * item), "item": item}


def test_dask_like_tasks_bring_their_outcomes_back_as_one_pickle():
    items = list(range(7))
    with _ScatteringPool() as pool:
        done, stats = executors.execute(pool, _scaled, {"scale": 2.5}, items, per=3)
    # every task's outcome travelled as bytes, and came back as what the work returned
    assert len(pool.futures) == 3 and stats["tasks"] == 3
    assert all(isinstance(f.result()[0], bytes) for f in pool.futures)
    assert sorted(done) == [0, 3, 6]
    got = [o for i in sorted(done) for o in done[i]]
    assert [o["item"] for o in got] == items
    for o in got:
        np.testing.assert_array_equal(o["x"], np.full(3, 2.5 * o["item"]))


# ------------------------------------------------------------------- worker set-up
def test_tasks_run_with_one_blas_thread():
    from threadpoolctl import threadpool_info, threadpool_limits

    def blas_threads(job, item):
        return max(b["num_threads"] for b in threadpool_info() if b["user_api"] == "blas")

    with threadpool_limits(limits=2, user_api="blas"):
        out, seconds, setup = executors.run_items(blas_threads, None, [0, 1])
    assert out == [1, 1] and seconds >= 0 and setup >= 0


class _FakeLibc:
    def __init__(self):
        self.calls = []

    def mallopt(self, param, value):
        self.calls.append(("mallopt", param, value))

    def malloc_trim(self, pad):
        self.calls.append(("trim", pad))


@pytest.fixture
def fake_libc(monkeypatch):
    """A recording libc, with no thresholds raised or restore pending from tasks run
    earlier in this process (a Dask cluster of threads sets ``MALLOC_TRIM_THRESHOLD_``
    in this process's environment)."""
    pending = executors._alloc_timer
    if pending is not None:
        pending.cancel()
    fake = _FakeLibc()
    monkeypatch.setattr(executors, "_glibc", lambda: fake)
    monkeypatch.setattr(executors, "_alloc_raised", False)
    monkeypatch.setattr(executors, "_alloc_timer", None)
    monkeypatch.setattr(executors, "_alloc_users", 0)
    return fake


def test_allocator_set_up_is_raised_once_and_restored_by_the_last_task(monkeypatch, fake_libc):
    fake = fake_libc
    monkeypatch.setattr(executors, "ALLOCATOR_IDLE", 0.0)  # restored as the last task ends
    monkeypatch.delenv("MALLOC_MMAP_THRESHOLD_", raising=False)
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "65536")
    with executors.allocator_for_arrays():
        raised = list(fake.calls)
        with executors.allocator_for_arrays():  # a second task of the same process
            assert fake.calls == raised
        assert fake.calls == raised  # still running: nothing restored yet
    mmap, trim = executors.M_MMAP_THRESHOLD, executors.M_TRIM_THRESHOLD
    assert {c[1]: c[2] for c in raised} == {mmap: 32 << 20, trim: 64 << 20}
    assert fake.calls[len(raised) :] == [
        ("mallopt", mmap, 128 << 10),
        ("mallopt", trim, 65536),
        ("trim", 0),
    ]
    # the environment's own choices are left alone
    for env in ({"MALLOC_TRIM_THRESHOLD_": None}, {"MALLOC_MMAP_THRESHOLD_": "1000000"}):
        fake.calls.clear()
        for k, v in env.items():
            if v is None:
                monkeypatch.delenv(k)
            else:
                monkeypatch.setenv(k, v)
        with executors.allocator_for_arrays():
            pass
        assert fake.calls == []


def test_allocator_set_up_outlives_back_to_back_tasks(monkeypatch, fake_libc):
    """A task that begins within ``ALLOCATOR_IDLE`` of the last one finds the thresholds
    still raised (nothing handed back between them); once the process is idle that long,
    they are restored, once."""
    fake = fake_libc
    monkeypatch.setattr(executors, "ALLOCATOR_IDLE", 0.3)
    monkeypatch.delenv("MALLOC_MMAP_THRESHOLD_", raising=False)
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "65536")
    for _ in range(3):  # three tasks back to back
        with executors.allocator_for_arrays():
            pass
    assert [c[0] for c in fake.calls] == ["mallopt", "mallopt"]  # raised once, kept
    deadline = time.monotonic() + 10
    while len(fake.calls) < 5 and time.monotonic() < deadline:
        time.sleep(0.05)
    mmap, trim = executors.M_MMAP_THRESHOLD, executors.M_TRIM_THRESHOLD
    assert fake.calls[2:] == [("mallopt", mmap, 128 << 10), ("mallopt", trim, 65536), ("trim", 0)]
    time.sleep(0.4)
    assert len(fake.calls) == 5  # restored once
    with executors.allocator_for_arrays():  # the next task raises them again
        assert len(fake.calls) == 7


_WHERE = """
import time

import numpy as np
from geomfdi.campaign.executors import ALLOCATOR_IDLE, allocator_for_arrays

def on_heap(address):
    with open("/proc/self/maps") as maps:
        for line in maps:
            if line.rstrip().endswith("[heap]"):
                lo, hi = (int(x, 16) for x in line.split()[0].split("-"))
                if lo <= address < hi:
                    return True
    return False

def where():
    a = np.empty(1 << 19)  # 4 MiB
    a[:] = 1.0
    return on_heap(a.ctypes.data)

plain = [where() for _ in range(3)]
with allocator_for_arrays():
    tuned = [where() for _ in range(3)]
with allocator_for_arrays():  # a task right after: still tuned
    tuned += [where()]
time.sleep(ALLOCATOR_IDLE + 1.0)  # idle: the worker's own settings are back
after = where()
print(all(plain), any(plain), all(tuned), after)
"""


@pytest.mark.skipif(
    not sys.platform.startswith("linux") or executors._glibc() is None, reason="glibc only"
)
def test_allocator_set_up_puts_large_arrays_on_the_heap_in_a_dask_like_worker():
    """With ``MALLOC_TRIM_THRESHOLD_`` set (a Dask worker), a 4 MiB array is a fresh
    ``mmap`` (faulted in page by page on every allocation); inside the set-up it comes
    from the heap, and after it the worker's settings are back."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MALLOC_TRIM_THRESHOLD_": "65536"}
    env.pop("MALLOC_MMAP_THRESHOLD_", None)
    proc = subprocess.run(
        [sys.executable, "-c", _WHERE], capture_output=True, text=True, env=env, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    _, any_plain, all_tuned, after = proc.stdout.split()
    assert any_plain == "False" and all_tuned == "True" and after == "False"
    # without the variable glibc adapts by itself (after the first free of a large
    # array) and the set-up has nothing to do
    env.pop("MALLOC_TRIM_THRESHOLD_")
    proc = subprocess.run(
        [sys.executable, "-c", _WHERE], capture_output=True, text=True, env=env, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split()[1:] == ["True", "True", "True"]


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "2"])
def test_local_dask_client_refuses_a_bad_worker_count(bad) -> None:
    from geomfdi.campaign.executors import local_dask_client

    with pytest.raises(GeomFDIError, match="workers") as info:
        with local_dask_client(bad):
            pass
    assert info.value.argument == "workers"


def test_local_dask_client_with_dask_own_settings() -> None:
    pytest.importorskip("distributed")
    import dask

    from geomfdi.campaign.executors import DASK_THROUGHPUT, local_dask_client

    own = {k: dask.config.get(k) for k in DASK_THROUGHPUT}
    assert own != DASK_THROUGHPUT
    with local_dask_client(1, settings={}) as client:
        got = client.run(lambda: {k: dask.config.get(k) for k in DASK_THROUGHPUT})
        assert client.nthreads() and sorted(client.nthreads().values()) == [1]
    assert list(got.values()) == [own]
