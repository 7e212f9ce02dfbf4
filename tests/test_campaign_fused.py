"""The fused pass of a campaign block (geomfdi.simulation.fused, geomfdi.campaign.fused_scoring)
against what it replaces: the vectorised simulation (gf.simulate_batch), the test's
statistic, and the numpy scores and isolation (evaluate_runs, isolate_runs)."""

from __future__ import annotations

import types
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import geomfdi as gf
from geomfdi.campaign import runner
from geomfdi.campaign.runner import evaluate_runs, isolate_runs
from geomfdi.evaluation.decision import MULTIPLE, isolate
from geomfdi.evaluation.persistence import _decide_patterns, every_pattern
from geomfdi.io.cli import design_all
from geomfdi.io.modelfile import load_model
from geomfdi.simulation import fused
from geomfdi.simulation.draw_cache import DrawCache

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
pytestmark = pytest.mark.usefixtures("c_cache")


@pytest.fixture(scope="module")
def hwc():
    spec = load_model(EXAMPLES / "hou_wen_chen.toml")
    return spec, design_all(spec)["exact"]


class _Two:
    """Biases on sensors 0 and 2 at once (a run of several faults: MULTIPLE truth)."""

    def __call__(self, size: float, onset: float) -> list:
        return [gf.BiasFault(0, start=onset, bias=size), gf.BiasFault(2, start=onset, bias=size)]


def _campaign(spec, bank, *, samples=1500, window=25, **kw):
    noise = kw.pop("noise", gf.Noise(measurement=[0.01, 0.02, 0.005], seed=7))
    t = spec.t[:samples]
    models = gf.residual_noise_models(spec.plant, bank, noise, step=0.002, controller=spec.K)
    args = dict(
        scenarios=[
            gf.Scenario.sensor("bias", 1, sizes=[0.0, 0.01, 0.03], onsets=[1.5, 2.0]),
            gf.Scenario.sensor("gain", 2, sizes=[0.05], onsets=[1.5]),
            gf.Scenario.of_kind("stuck", 0, sizes=[0.0, 0.2], onsets=[1.8]),
            gf.Scenario("two", _Two(), sizes=[0.03], onsets=[1.5]),
        ],
        noise=noise,
        t=t,
        runs=4,
        test=gf.ChiSquareTest.design(models, window, 1e-3),
        u=spec.u,
        controller=spec.K,
        x0=spec.x0,
        detection_window=0.8,
        eval_start=0.4,
        block_size=10,
        persistence=gf.Persistence(2, 3),
    )
    args.update(kw)
    return gf.Campaign(spec.plant, bank, **args)


def _reference(c, monkeypatch):
    """The table without the fused pass (gf.simulate_batch and the numpy scoring)."""
    with monkeypatch.context() as m:
        m.setattr(runner, "_fused_plan", lambda job, model: None)
        return c.run("serial", progress=False).table


def _same_tables(a: pd.DataFrame, b: pd.DataFrame) -> None:
    """Decisions and detections identical, numbers to rounding (1e-12 relative)."""
    floats = [k for k in a.columns if a[k].dtype.kind == "f"]
    pd.testing.assert_frame_equal(a.drop(columns=floats), b.drop(columns=floats))
    for k in floats:
        np.testing.assert_allclose(a[k], b[k], rtol=1e-12, atol=0, err_msg=k)


@pytest.mark.parametrize(
    "hold, rule",
    [
        # (the first builds the kernels the others reuse: 8-9 s on a fresh checkout)
        pytest.param("foh", gf.Persistence(2, 3), marks=pytest.mark.slow),
        ("zoh", gf.Persistence(3, 5, reset=20)),
        ("foh", gf.Persistence(2, 4, latch=False)),
        ("foh", None),
        ("foh", gf.Persistence(1, 1, latch=True)),
    ],
)
def test_fused_campaign_equals_the_vectorised_simulation(hwc, monkeypatch, hold, rule):
    spec, bank = hwc
    c = _campaign(spec, bank, hold=hold, persistence=rule)
    job = c._job()
    assert runner._fused_plan(job, 0) is not None, job["fused"][("why", 0)]
    table = c.run("serial", progress=False).table
    _same_tables(table, _reference(c, monkeypatch))
    bank_rows = table[table["residual"] == "bank"]
    # the sweep is not trivial: some runs detect, isolate right, wrong and not at all
    assert bank_rows["detected"].any() and not bank_rows["detected"].all()
    if rule is not None:
        assert {"correct", "none"} <= set(bank_rows["isolation"].astype(str))


_COV = np.array([[1e-4, 2e-5, 0.0], [2e-5, 4e-4, 1e-5], [0.0, 1e-5, 2.5e-5]])


@pytest.mark.parametrize(
    "noise",
    [
        gf.Noise(measurement=[0.01, 0.02, 0.005], seed=7, generator="counter"),
        gf.Noise(measurement=_COV, seed=7, generator="counter"),
        gf.Noise(measurement=_COV, seed=7),
    ],
    ids=["counter", "counter-covariance", "numpy-covariance"],
)
def test_fused_campaign_with_either_generator_and_correlated_noise(hwc, monkeypatch, noise):
    spec, bank = hwc
    c = _campaign(spec, bank, samples=900, noise=noise)
    assert runner._fused_plan(c._job(), 0) is not None
    _same_tables(c.run("serial", progress=False).table, _reference(c, monkeypatch))


def test_fused_statistic_and_residuals_equal_simulate_batch(hwc, monkeypatch):
    spec, bank = hwc
    t = spec.t[:900]
    noise = gf.Noise(measurement=0.01, seed=3)
    lists = [
        [gf.BiasFault(1, start=0.5, bias=0.02)],
        [
            gf.GainFault(2, start=0.7, gain=1.3, bias=0.01, end=1.2),
            gf.BiasFault(2, start=0.9, bias=-0.02),
        ],
        [],
        [gf.StuckFault(0, start=0.3, value=0.1)],
        [gf.GainFault(0, start=0.2, gain=0.5)],
    ]
    seeds = list(np.random.SeedSequence(5).spawn(len(lists)))
    for hold in ("foh", "zoh"):
        ref = gf.simulate_batch(
            spec.plant, bank, t, spec.u, faults=lists, noise=noise, seeds=seeds,
            controller=spec.K, x0=spec.x0, hold=hold, progress=False,
        ).residuals  # fmt: skip
        for window in (0, 20):
            plan, why = fused.fused_plan(
                spec.plant, bank, t, spec.u, fault_lists=lists, noise=noise,
                controller=spec.K, x0=spec.x0, hold=hold, window=window,
            )  # fmt: skip
            assert plan is not None, why
            got = fused.fused_runs(plan, lists, seeds)
            want = ref if not window else gf.ChiSquareTest(window, np.ones(3)).statistic(ref)
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-14 * np.abs(want).max())
            # windows of the record carry every state: the same numbers, bit for bit
            monkeypatch.setattr(fused, "WINDOW", 37)
            np.testing.assert_array_equal(fused.fused_runs(plan, lists, seeds), got)
            monkeypatch.undo()


@pytest.mark.parametrize(
    "flags, specialise",
    [
        (("-DGFSIM_NV=2",), True),
        (("-DGFSIM_NV=3",), True),
        (("-DGFF_NO_VECTOR_EXT",), True),
        ((), False),
    ],
    ids=["2-vectors", "3-vectors", "plain-loops", "dimensions-at-run-time"],
)
def test_every_build_of_the_kernel_gives_the_same_bits(hwc, monkeypatch, flags, specialise):
    # every run is computed by the same operations whatever the width of the groups
    # of runs, the vector extension or the dimensions' binding time
    spec, bank = hwc
    t = spec.t[:300]
    noise = gf.Noise(measurement=0.01, seed=3)
    lists = [[gf.BiasFault(1, start=0.2, bias=0.01 * r)] for r in range(11)]
    lists += [[gf.GainFault(2, start=0.3, gain=1.5)], []]  # 13 runs: partial groups
    seeds = list(np.random.SeedSequence(9).spawn(len(lists)))
    args = dict(fault_lists=lists, noise=noise, controller=spec.K, x0=spec.x0, window=20)
    plan, _ = fused.fused_plan(spec.plant, bank, t, spec.u, **args)
    ref = fused.fused_runs(plan, lists, seeds)
    monkeypatch.setattr(fused, "_FLAGS", flags)
    monkeypatch.setattr(fused, "_SPECIALISE", specialise)
    other, _ = fused.fused_plan(spec.plant, bank, t, spec.u, **args)
    assert other.lib is not plan.lib
    np.testing.assert_array_equal(fused.fused_runs(other, lists, seeds), ref)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore::geomfdi.simulation.initial_state.InitialStateWarning")
def test_fused_vector_residual_discrete_plant_undecoupled_bank_no_measurement_noise():
    # a discrete plant, one generator of two outputs (its row: the norm of both)
    p = gf.Plant([[0.9, 0.1], [0.0, 0.8]], [[1.0], [0.5]], [[1.0, 0.0], [0.0, 1.0]], dt=0.01)
    g = gf.ResidualGenerator(
        np.array([[0.5]]), np.array([[1.0, -1.0]]), np.array([[0.2]]),
        np.array([[1.0], [2.0]]), np.array([[0.3, 0.1], [0.0, 1.0]]), np.array([[0.1], [0.0]]),
        dt=0.01,
    )  # fmt: skip
    t = np.arange(400) * 0.01
    u = np.sin(t)[None]
    lists = [[gf.BiasFault(0, start=1.0, bias=0.3)], [gf.GainFault(1, start=2.0, gain=2.0)]]
    for noise in (gf.Noise(measurement=[0.1, 0.2], seed=1), gf.Noise(seed=1)):
        seeds = list(np.random.SeedSequence(2).spawn(2))
        ref = gf.simulate_batch(
            p, g, t, u, faults=lists, noise=noise, seeds=seeds, progress=False
        ).residuals
        plan, why = fused.fused_plan(p, g, t, u, fault_lists=lists, noise=noise)
        assert plan is not None, why
        got = fused.fused_runs(plan, lists, seeds)
        assert np.all(got >= 0.0) and np.any(got != 0.0)  # norms
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-14 * np.abs(ref).max())
    # a continuous generator sharing a pole with the plant (no change of state removes
    # the plant's state from it): the plant's state drives it, a shared forcing
    pc = gf.Plant([[-1.0, 0.5], [0.0, -2.0]], [[1.0], [0.5]], [[1.0, 0.0], [0.0, 1.0]])
    gc = gf.ResidualGenerator(
        np.array([[-1.0]]), np.array([[1.0, -1.0]]), np.array([[0.2]]),
        np.array([[1.0]]), np.array([[0.3, 0.1]]), np.array([[0.1]]),
    )  # fmt: skip
    noise = gf.Noise(measurement=[0.1, 0.2], seed=1)
    ref = gf.simulate_batch(
        pc, gc, t, u, faults=lists, noise=noise, seeds=seeds, x0=[1.0, -1.0], progress=False
    ).residuals
    plan, why = fused.fused_plan(pc, gc, t, u, fault_lists=lists, noise=noise, x0=[1.0, -1.0])
    assert plan is not None, why
    assert not plan.ctx.info["plant_state_decoupled"]
    got = fused.fused_runs(plan, lists, seeds)
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-14 * np.abs(ref).max())


def test_what_the_fused_pass_does_not_take_falls_back(hwc):
    spec, bank = hwc
    t = spec.t[:200]
    common = dict(controller=spec.K, x0=spec.x0)
    plan, why = fused.fused_plan(
        spec.plant, bank, t, spec.u, fault_lists=[[]],
        noise=gf.Noise(measurement=0.01, process=0.01, seed=1), **common,
    )  # fmt: skip
    assert plan is None and "process noise" in why
    held = [[gf.StuckFault(1, start=0.1)]]  # holds its reading: not a pair of numbers
    plan, why = fused.fused_plan(
        spec.plant, bank, t, spec.u, fault_lists=held, noise=gf.Noise(0.01, seed=1), **common
    )
    assert plan is None and "holds its reading" in why
    fine = gf.Noise(measurement=0.01, seed=1)
    plan, _ = fused.fused_plan(spec.plant, bank, t, spec.u, fault_lists=[[]], noise=fine, **common)
    assert plan is not None


def test_a_diverging_run_is_cut_as_before(hwc, monkeypatch):
    # thresholds so small that every statistic is over a million times its threshold:
    # the block is judged by numpy (cut_divergent), the table as without the fused pass
    spec, bank = hwc
    c = _campaign(spec, bank, samples=800, test=gf.ChiSquareTest(25, np.full(3, 1e-15)))
    table = c.run("serial", progress=False).table
    assert table["diverged"].all()
    _same_tables(table, _reference(c, monkeypatch))


def test_fused_campaign_is_the_same_in_processes_and_replays_with_simulate(hwc):
    spec, bank = hwc
    c = _campaign(spec, bank, block_size=7)
    res = c.run("serial", progress=False)
    pd.testing.assert_frame_equal(res.table, c.run("processes", workers=2, progress=False).table)
    g = c.grid()
    root = np.random.SeedSequence(c.noise.seed)
    tb = res.table.set_index(["run", "residual"])
    for r in (5, 13, 30):
        sc = c.scenarios[g["scenario"][r]]
        seed = np.random.SeedSequence(root.entropy, spawn_key=(int(g["repetition"][r]),))
        one = gf.simulate(
            spec.plant, bank, c.t, c.u, faults=sc.faults(float(g["size"][r]), g["onset"][r]),
            noise=gf.Noise(measurement=c.noise.measurement, seed=seed), controller=spec.K,
            x0=spec.x0,
        )  # fmt: skip
        stat = c.test.statistic(one.residuals[None])
        ev = evaluate_runs(c.t, stat, c.test.thresholds, g["onset"][r : r + 1], c.window,
                           c.eval_start)  # fmt: skip
        rows = tb.loc[r]
        np.testing.assert_allclose(rows["score_post"], ev["score_post"][0], rtol=1e-9)
        np.testing.assert_array_equal(rows["delay"].isna(), np.isnan(ev["delay"][0]))
        np.testing.assert_allclose(rows["delay"].fillna(-1), np.nan_to_num(ev["delay"][0], nan=-1))


def test_fused_campaign_of_perturbed_models_equals_the_vectorised_simulation(hwc, monkeypatch):
    # one plan per model (the bank's set-up on each perturbed plant)
    spec, bank = hwc
    c = _campaign(spec, bank, samples=900, uncertainty=gf.Uncertainty(0.05, samples=2, seed=3))
    job = c._job()
    plans = [runner._fused_plan(job, m) for m in range(2)]
    assert all(p is not None for p in plans)
    assert plans[0] is not plans[1] and not np.array_equal(plans[0].y0c, plans[1].y0c)
    _same_tables(c.run("serial", progress=False).table, _reference(c, monkeypatch))


def test_fused_campaign_in_windows_and_with_another_test(hwc, monkeypatch):
    spec, bank = hwc
    # the record in windows of 37 samples (states, sums, scores and patterns carried)
    c = _campaign(spec, bank, samples=700)
    want = _reference(c, monkeypatch)
    monkeypatch.setattr(fused, "WINDOW", 37)
    _same_tables(c.run("serial", progress=False).table, want)
    monkeypatch.undo()
    # thresholds on |r|: the pass gives the residuals, numpy the test's statistic
    c = _campaign(spec, bank, samples=700, test=0.05)
    plan = runner._fused_plan(c._job(), 0)
    assert plan is not None and plan.window == 0
    _same_tables(c.run("serial", progress=False).table, _reference(c, monkeypatch))


@pytest.mark.parametrize("gen", ["numpy", "counter"])
def test_the_draws_kept_for_a_repetition_are_the_draws(hwc, monkeypatch, gen):
    # the runs of one repetition read the draws kept when its first cell drew them: the
    # table is the one drawn again for every run (no cache)
    spec, bank = hwc
    noise = gf.Noise(measurement=[0.01, 0.02, 0.005], seed=7, generator=gen)
    c = _campaign(spec, bank, samples=700, noise=noise, block_size=4)
    job = c._job()
    for block in c.blocks()[:3]:
        runner._run_block(job, block)
    draws = job["fused"]["draws"]
    assert 0 < len(draws.arrays) <= c.runs and draws.nbytes <= draws.budget
    table = c.run("serial", progress=False).table
    monkeypatch.setattr(runner, "DRAW_CACHE_CHUNKS", 0)
    pd.testing.assert_frame_equal(table, c.run("serial", progress=False).table, check_exact=True)


def test_fused_runs_do_not_depend_on_the_block_size(hwc):
    spec, bank = hwc
    a = _campaign(spec, bank, samples=700, block_size=5).run("serial", progress=False)
    b = _campaign(spec, bank, samples=700, block_size=64).run("serial", progress=False)
    pd.testing.assert_frame_equal(a.table, b.table, check_exact=True)


def test_fused_campaign_is_the_same_on_dask(hwc):
    distributed = pytest.importorskip("distributed")
    spec, bank = hwc
    c = _campaign(spec, bank, samples=900, block_size=7)
    ref = c.run("serial", progress=False)
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        dk = c.run(client, progress=False)
    pd.testing.assert_frame_equal(ref.table, dk.table, check_exact=True)


@pytest.mark.parametrize("seed", range(4))
def test_compiled_isolation_equals_isolate_runs(seed):
    rng = np.random.default_rng(seed)
    R, n, N = 40, 3, 300
    S = np.array([[1, 0, 1], [1, 1, 0], [0, 1, 1]], dtype=bool)
    t = np.arange(N) * 0.01
    thr = np.array([1.0, 1.0, np.inf if seed == 3 else 1.0])
    # alarms in bursts, some runs quiet, some with two faults (MULTIPLE truths)
    stat = rng.random((R, n, N)) * (rng.random((R, 1, 1)) * 1.6)
    stat[: R // 4] *= 0.5
    onsets = rng.choice([0.8, 1.5], R)
    truth = rng.choice([-2, -1, 0, 1, 2, MULTIPLE], R)
    sets = [frozenset({0, 2}) if tr == MULTIPLE else frozenset({tr}) for tr in truth]
    rule = [gf.Persistence(2, 3), gf.Persistence(3, 5, reset=7), gf.Persistence(2, 3, latch=False),
            None][seed]  # fmt: skip
    W, e0 = 1.0, 0.3
    ref = isolate_runs(t, stat, thr, S, rule, truth, sets, onsets, W, e0)
    # the codes the kernel writes: the alarm pattern of each sample after eval_start
    al = (stat > thr[:, None]) & (t >= e0 - 1e-9 * t.max())
    codes = (al * (1 << np.arange(n))[None, :, None]).sum(axis=1).astype(np.uint8)
    kon = np.searchsorted(t, onsets - 1e-9 * t.max())
    kpost1 = np.searchsorted(t, onsets + W - 1e-9 * t.max())
    pats = every_pattern(n)
    table = isolate(pats, S) if rule is None or rule.trivial else _decide_patterns(pats, S)
    rl = np.zeros((R, pats.shape[1]), dtype=np.uint8)
    for r in np.flatnonzero(truth == MULTIPLE):
        want = np.zeros(3, dtype=bool)
        want[list(sets[r])] = True
        rl[r] = np.all(table.suspects == want[:, None], axis=0)
    lib = types.SimpleNamespace(lib=fused._library())
    first, dec, right = fused.isolate_codes(
        lib, codes, table.isolated, rule, 3, kon, kpost1, truth, rl
    )
    np.testing.assert_array_equal(np.where(first >= 0, dec, -1), ref["decision"])
    outcome = np.where(first < 0, 2, np.where((right == first) & (truth != -1), 0, 1))
    np.testing.assert_array_equal(outcome, ref["outcome"])
    delay = np.where(right >= 0, t[np.maximum(right, 0)] - onsets, np.nan)
    np.testing.assert_array_equal(delay, ref["iso_delay"])
    assert len(set(ref["outcome"].tolist())) > 1


def test_serial_campaign_on_two_threads_is_the_loop_bit_for_bit(hwc, monkeypatch):
    import threading
    import warnings

    from geomfdi._threads import using_work_threads

    spec, bank = hwc
    c = _campaign(spec, bank, samples=900, uncertainty=gf.Uncertainty(0.05, samples=2, seed=3))
    with using_work_threads(1):
        one = c.run("serial", progress=False).table
    names = set()
    run = runner._run_block

    def seen(job, block, own_filters=True):
        names.add(threading.current_thread().name)
        return run(job, block, own_filters)

    monkeypatch.setattr(runner, "_run_block", seen)
    filters = list(warnings.filters)
    with using_work_threads(2):
        two = c.run("serial", progress=False).table
    assert len(names) == 2 and threading.main_thread().name not in names  # blocks on threads
    pd.testing.assert_frame_equal(one, two)  # the same numbers, in the same order
    assert warnings.filters == filters  # the perturbed models' filter set once, and undone
    # blocks that simulate_batch runs (no plan): one after the other, in this thread
    names.clear()
    monkeypatch.setattr(runner, "_fused_plan", lambda job, model: None)
    with using_work_threads(2):
        three = c.run("serial", progress=False).table
    assert names == {threading.main_thread().name}
    _same_tables(three, one)


# ------------------------------------------------------------- draws shared by runs
def test_blocks_run_by_ranges_of_repetitions(hwc):
    spec, bank = hwc
    c = _campaign(spec, bank, samples=300, runs=7, block_size=3)
    g = c.grid()
    blocks = c.blocks()
    runs = np.concatenate([b.runs for b in blocks])
    assert np.array_equal(np.sort(runs), g["run"])  # every run once
    ranges = [set(b.repetition // 3) for b in blocks]
    assert all(len(r) == 1 for r in ranges)  # a block: one range of 3 repetitions
    first = [r.pop() for r in ranges]
    assert first == sorted(first)  # ranges one after the other
    for b in blocks:  # one model, the grid's order inside a block, no more than 3 runs
        assert b.runs.size <= 3 and np.all(np.diff(b.runs) > 0)
        assert np.all(g["model"][b.runs] == b.model)
    # fewer repetitions than the block size: the grid's order, cut every block_size runs
    c = _campaign(spec, bank, samples=300, runs=4, block_size=10)
    assert [list(b.runs) for b in c.blocks()] == [
        list(range(a, min(a + 10, c.grid()["run"].size)))
        for a in range(0, c.grid()["run"].size, 10)
    ]


def test_the_draw_cache_drops_the_draws_used_longest_ago():
    cache = DrawCache(3 * 80)
    z = {k: np.full((2, 5), float(k)) for k in range(5)}
    for k in (0, 1, 2):
        assert cache.put(k, z[k]) is not z[k]  # kept: a copy
    cache.get(0)  # used again: now the newest
    cache.put(3, z[3])  # room made by the oldest, 1
    assert list(cache.arrays) == [2, 0, 3] and cache.nbytes == 240
    np.testing.assert_array_equal(cache.get(0), z[0])
    assert cache.get(1) is None
    big = np.zeros((2, 50))
    assert cache.put(9, big) is big and 9 not in cache.arrays  # over the whole budget


def test_a_run_reserved_by_one_thread_is_waited_for_by_another():
    import threading

    cache = DrawCache(1e6)
    z = np.arange(6.0).reshape(2, 3)
    assert cache.reserve("k") == (None, None)  # this thread draws it
    got, event = cache.reserve("k")
    assert got is None and event is not None and not event.is_set()
    seen = []

    def other():
        arr, ev = cache.reserve("k")
        ev.wait(10)
        seen.append(cache.get("k"))

    th = threading.Thread(target=other)
    th.start()
    kept = cache.put("k", z)
    th.join(10)
    assert event.is_set() and seen[0] is kept
    assert cache.reserve("k")[0] is kept  # kept: nothing to wait for
    # a reservation given up (the drawing thread failed) lets the waiters draw
    assert cache.reserve("j") == (None, None)
    _, ev = cache.reserve("j")
    cache.release("j")
    assert ev.is_set() and cache.get("j") is None and cache.reserve("j") == (None, None)


def test_draws_evicted_or_shared_by_threads_give_the_same_table(hwc, monkeypatch):
    # a draw cache holding 3 runs' draws: the blocks of a range of repetitions read
    # them while kept, draw again once dropped; blocks on two threads reserve and wait
    spec, bank = hwc
    c = _campaign(spec, bank, samples=700, runs=6, block_size=3)
    want = c.run("serial", progress=False).table
    per_run = 3 * 700 * 8
    monkeypatch.setattr(
        runner, "DRAW_CACHE_CHUNKS", 3 * per_run / gf.limits.get_limits().chunk_memory
    )
    job = c._job()
    blocks = c.blocks()
    runner._prepare_blocks(job, blocks)
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(2) as pool:  # the blocks of a range at once, on 2 threads
        parts = list(pool.map(lambda b: runner._run_block(job, b, False), blocks))
    draws = job["fused"]["draws"]
    assert 0 < len(draws.arrays) <= 3 and not draws._pending
    got = gf.CampaignResult.from_parts(c, parts).table
    pd.testing.assert_frame_equal(got, want, check_exact=True)
    # a serial campaign whose draws do not all fit runs its blocks by ranges (in the
    # order of Campaign.blocks, not the grid's): the same table
    seen = []
    run = runner._run_block

    def spy(job, block, own_filters=True):
        seen.append(int(block.runs[0]))
        return run(job, block, own_filters)

    from geomfdi._threads import using_work_threads

    monkeypatch.setattr(runner, "_run_block", spy)
    with using_work_threads(1):  # (one thread: the blocks start in the order run)
        table = c.run("serial", progress=False).table
    pd.testing.assert_frame_equal(table, want, check_exact=True)
    assert seen == [int(b.runs[0]) for b in blocks] and seen != sorted(seen)
