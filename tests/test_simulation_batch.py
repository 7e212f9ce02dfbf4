"""Monte-Carlo batches: many runs in one vectorised call, identical to single runs."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import control
import numpy as np
import pytest
from hwc_bank import K_FB, P_PAPER, X0, A, B, C, hand_generator, leaky_bank, v_ext

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError

ROOT = Path(__file__).resolve().parents[1]
T = np.arange(0, 12.0, 0.01)


def setup():
    plant = gf.Plant(A, B, C)
    return plant, leaky_bank([hand_generator(plant, P_PAPER[j : j + 1]) for j in range(3)])


def test_batch_runs_equal_single_runs_with_spawned_seeds():
    plant, bank = setup()
    noise = gf.Noise(measurement=2e-3, process=[0.0, 1e-2, 0.0], seed=11)
    faults = [gf.GainFault(0, start=6.0, gain=1.5, bias=0.02)]
    batch = gf.simulate_batch(
        plant,
        bank,
        T,
        v_ext,
        runs=5,
        faults=faults,
        x0=X0,
        controller=K_FB,
        noise=noise,
        threshold=0.06,
        store="all",
        progress=False,
    )
    assert batch.residuals.shape == (5, 3, T.size) and batch.x.shape == (5, 3, T.size)
    for i in (0, 3):
        single = gf.simulate(
            plant,
            bank,
            T,
            v_ext,
            faults=faults,
            x0=X0,
            controller=K_FB,
            noise=gf.Noise(measurement=2e-3, process=[0.0, 1e-2, 0.0], seed=batch.seeds[i]),
            threshold=0.06,
        )
        assert np.allclose(batch.residuals[i], single.residuals, rtol=1e-10, atol=1e-13)
        assert np.array_equal(batch.alarms[i], single.alarms)
        assert batch.events[i][0].detection_time == single.events[0].detection_time
        run = batch.run(i)
        assert np.allclose(run.x, single.x, atol=1e-12)
    assert not np.allclose(batch.residuals[0], batch.residuals[1])
    assert batch.detection_rate() == 1.0
    assert "5 runs" in batch.summary()


def test_fault_size_sweep_per_run():
    plant, bank = setup()
    gains = [1.1, 1.3, 1.5, 2.0]
    lists = [[gf.GainFault(0, start=6.0, gain=g, bias=0.02)] for g in gains]
    batch = gf.simulate_batch(
        plant, bank, T, v_ext, faults=lists, x0=X0, controller=K_FB, threshold=0.06, progress=False
    )
    assert batch.runs == 4
    for i in range(len(gains)):
        single = gf.simulate(plant, bank, T, v_ext, faults=lists[i], x0=X0, controller=K_FB)
        assert np.allclose(batch.peak[i], np.max(np.abs(single.residuals), axis=1), rtol=1e-10)
    # larger gain faults give larger residual peaks on r1
    assert np.all(np.diff(batch.peak[:, 0]) > 0)


def test_chunking_and_summary_store_do_not_change_results():
    plant, bank = setup()
    kw = dict(
        runs=6,
        faults=[gf.BiasFault(1, start=5.0, bias=0.05)],
        x0=X0,
        controller=K_FB,
        noise=gf.Noise(measurement=1e-3, seed=2),
        threshold=0.03,
        progress=False,
    )
    a = gf.simulate_batch(plant, bank, T, v_ext, **kw)
    b = gf.simulate_batch(plant, bank, T, v_ext, chunk_size=2, **kw)
    c = gf.simulate_batch(plant, bank, T, v_ext, store="summary", **kw)
    assert np.allclose(a.residuals, b.residuals, rtol=1e-12, atol=1e-15)
    assert c.residuals is None and c.alarms is None
    assert np.allclose(a.peak, c.peak)
    assert [e[0].detection_time for e in a.events] == [e[0].detection_time for e in c.events]
    assert a.false_alarm_rate() == c.false_alarm_rate()
    with pytest.raises(GeomFDIError, match="store='all'"):
        a.run(0)


def test_false_alarm_rate_is_pooled_over_healthy_samples():
    plant, bank = setup()
    batch = gf.simulate_batch(
        plant,
        bank,
        T,
        v_ext,
        runs=8,
        x0=X0,
        controller=K_FB,
        noise=gf.Noise(measurement=5e-3, seed=4),
        threshold=0.02,
        progress=False,
    )
    manual = batch.alarms.any(axis=1).mean()
    assert batch.false_alarm_rate() == pytest.approx(manual)
    assert 0 < manual < 1


def test_output_feedback_batch_shared_and_per_run():
    plant, bank = setup()
    ctrl = control.ss([], [], [], -K_FB @ np.linalg.inv(C))
    t = T[:600]
    kw = dict(x0=X0, controller=ctrl, progress=False)
    noise = gf.Noise(measurement=1e-3, seed=9)
    shared = gf.simulate_batch(
        plant,
        bank,
        t,
        v_ext,
        runs=3,
        noise=noise,
        faults=[gf.GainFault(2, start=3.0, gain=0.8)],
        store="all",
        **kw,
    )
    one = gf.simulate(
        plant,
        bank,
        t,
        v_ext,
        noise=gf.Noise(measurement=1e-3, seed=shared.seeds[2]),
        faults=[gf.GainFault(2, start=3.0, gain=0.8)],
        x0=X0,
        controller=ctrl,
    )
    assert np.allclose(shared.residuals[2], one.residuals, rtol=1e-9, atol=1e-12)
    lists = [[gf.GainFault(2, start=3.0, gain=g)] for g in (0.5, 0.8)]
    per = gf.simulate_batch(plant, bank, t, v_ext, faults=lists, **kw)
    single = gf.simulate(plant, bank, t, v_ext, faults=lists[1], x0=X0, controller=ctrl)
    assert np.allclose(per.residuals[1], single.residuals, rtol=1e-9, atol=1e-12)


def test_batch_argument_errors():
    plant, bank = setup()
    with pytest.raises(ShapeError, match="faults"):
        gf.simulate_batch(
            plant, bank, T, runs=3, faults=[[gf.BiasFault(0, start=1.0, bias=1.0)]] * 2
        )
    with pytest.raises(ShapeError, match="seeds"):
        gf.simulate_batch(plant, bank, T, runs=3, noise=gf.Noise(measurement=1.0), seeds=[1])
    with pytest.raises(GeomFDIError, match="store"):
        gf.simulate_batch(plant, bank, T, store="everything")
    with pytest.raises(GeomFDIError, match="runs"):
        gf.simulate_batch(plant, bank, T, runs=0)
    with pytest.raises(ShapeError, match="x0"):
        gf.simulate_batch(plant, bank, T, runs=2, x0=np.zeros((3, 3)))


def test_progress_bar_writes_to_stderr(capsys):
    plant, bank = setup()
    gf.simulate_batch(
        plant, bank, T[:200], v_ext, runs=4, chunk_size=1, x0=X0, controller=K_FB, progress=True
    )
    assert "runs" in capsys.readouterr().err


def test_benchmark_quick_mode_runs(capsys):
    spec = importlib.util.spec_from_file_location(
        "bench_simulation", ROOT / "benchmarks" / "bench_simulation.py"
    )
    mod = importlib.util.module_from_spec(spec)
    sys.modules["bench_simulation"] = mod
    spec.loader.exec_module(mod)
    rows = mod.bench(
        sizes=(300, 600), banks=(3, 4), batch_runs=3, batch_samples=300, extrapolate_above=300
    )
    out = capsys.readouterr().out
    assert "ratio" in out and "aggregate" in out and "extrapolated" in out
    exact = [r for r in rows if "max_diff" in r and not r["extrapolated"]]
    assert exact and all(r["max_diff"] < 1e-10 for r in exact)  # same numbers as the baseline


def test_detection_rate_at_fault_size_zero_equals_the_false_alarm_rate():
    # a zero-size fault leaves the residual healthy: P_d in a window of n samples after
    # the onset must equal the per-run FAR over n healthy samples (binomial error)
    plant = gf.Plant([[-1.0]], [[1.0]], [[1.0]])
    gen = gf.ResidualGenerator([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], [[1.0]], [[0.0]])
    t = np.arange(400) * 0.01
    runs = 400
    kw = dict(
        runs=runs,
        faults=[gf.BiasFault(0, start=1.0, bias=0.0)],
        noise=gf.Noise(measurement=0.1, seed=11),
        threshold=0.28,
        store="summary",
    )
    batch = gf.simulate_batch(plant, gen, t, detection_window=0.995, **kw)
    assert np.all(batch.healthy_samples == 100)
    far_run = batch.false_alarm_rate(per="run")
    pd = batch.detection_rate()
    assert 0.1 < far_run < 0.6  # a rate where the comparison has power
    se = np.sqrt(2 * far_run * (1 - far_run) / runs)
    assert abs(pd - far_run) < 3.5 * se
    assert batch.missed_detection_rate() == pytest.approx(1 - pd)
    # without the window an alarm anywhere in the 300 samples after onset counts: the
    # old, inflated figure
    loose = gf.simulate_batch(plant, gen, t, **kw)
    assert loose.detection_rate() > far_run + 6 * se
    m = batch.metrics()
    assert m.far_per_run == far_run and m.detection_rate == pd and m.runs == runs
