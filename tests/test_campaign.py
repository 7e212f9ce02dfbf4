"""Monte-Carlo campaigns: grid, seeds, executors, uncertainty, tables and curves."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import geomfdi as gf
from geomfdi.errors import GeomFDIError
from geomfdi.io.cli import design_all
from geomfdi.io.modelfile import load_model

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def seed001():
    spec = load_model(EXAMPLES / "seed001.toml")
    return spec, design_all(spec)["exact"]


_NOISE = gf.Noise(measurement=[0.01, 0.02, 0.005], process=0.01, seed=42)
_TESTS: dict[int, gf.ChiSquareTest] = {}


def _campaign(spec, bank, **kw):
    noise = _NOISE
    t = spec.t[:2001]  # 4 s
    if id(bank) not in _TESTS:
        models = gf.residual_noise_models(spec.plant, bank, noise, step=0.002, controller=spec.K)
        _TESTS[id(bank)] = gf.ChiSquareTest.design(models, 25, 1e-3)
    test = _TESTS[id(bank)]
    args = dict(
        scenarios=[
            gf.Scenario.sensor("bias", 0, sizes=[0.0, 0.02], onsets=[2.5]),
            gf.Scenario.sensor("gain", 2, sizes=[0.0, 0.05], onsets=[2.0, 2.5]),
        ],
        noise=noise,
        t=t,
        runs=5,
        test=test,
        u=spec.u,
        controller=spec.K,
        x0=spec.x0,
        detection_window=1.0,
        eval_start=0.5,
        block_size=10,
    )
    args.update(kw)
    return gf.Campaign(spec.plant, bank, **args)


@pytest.fixture(scope="module")
def serial(seed001):
    spec, bank = seed001
    c = _campaign(spec, bank, uncertainty=gf.Uncertainty(relative=0.02, samples=2, seed=3))
    return c, c.run("serial")


def test_grid_and_table_layout(serial):
    c, res = serial
    g = c.grid()
    # 2 models x (2 sizes x 1 onset + 2 sizes x 2 onsets) x 5 runs
    assert g["run"].size == 2 * 6 * 5
    tb = res.table
    assert len(tb) == g["run"].size * 4  # 3 residuals + bank
    assert list(tb["residual"].cat.categories) == ["r[0]", "r[1]", "r[2]", "bank"]
    assert set(tb.columns) >= {
        "run",
        "model",
        "scenario",
        "size",
        "onset",
        "repetition",
        "score_pre",
        "score_post",
        "false_alarm",
        "detected",
        "delay",
    }
    # the bank score is the largest residual score of the run
    wide = tb.pivot(index="run", columns="residual", values="score_post")
    np.testing.assert_array_equal(wide["bank"], wide[["r[0]", "r[1]", "r[2]"]].max(axis=1))
    # a delay exactly when detected, never negative, inside the window
    det = tb["detected"].to_numpy()
    assert np.all(np.isnan(tb["delay"].to_numpy()[~det]))
    assert np.all((tb["delay"][det] >= 0) & (tb["delay"][det] < 1.0))


def test_same_table_for_every_grouping_of_blocks(seed001, serial):
    spec, bank = seed001
    _, res = serial
    c = _campaign(spec, bank, uncertainty=gf.Uncertainty(relative=0.02, samples=2, seed=3))
    again = c.run("serial", blocks_per_task=3)
    pd.testing.assert_frame_equal(res.table, again.table, check_exact=True)


def test_same_table_on_two_local_processes(seed001, serial):
    spec, bank = seed001
    _, res = serial
    c = _campaign(spec, bank, uncertainty=gf.Uncertainty(relative=0.02, samples=2, seed=3))
    par = c.run("processes", workers=2, blocks_per_task=2)
    pd.testing.assert_frame_equal(res.table, par.table, check_exact=True)


@pytest.mark.slow
def test_same_table_on_a_dask_local_cluster(seed001, serial):
    distributed = pytest.importorskip("distributed")
    spec, bank = seed001
    _, res = serial
    c = _campaign(spec, bank, uncertainty=gf.Uncertainty(relative=0.02, samples=2, seed=3))
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        assert len(client.scheduler_info()["workers"]) == 2
        dk = c.run(client)
    pd.testing.assert_frame_equal(res.table, dk.table, check_exact=True)


def test_runs_depend_on_their_index_only(seed001, serial):
    """A run's numbers do not depend on the other runs of the grid (seed by repetition)."""
    spec, bank = seed001
    c, res = serial
    small = _campaign(
        spec, bank, runs=3, scenarios=[gf.Scenario.sensor("bias", 0, sizes=[0.0], onsets=[2.5])]
    ).run()
    # model 0, scenario 0, size 0, onset 3: runs 0..2 of the big grid, same block layout
    big = res.table[(res.table["run"] < 3) & (res.table["model"] == 0)]
    assert c.plants[0] is not c.plant  # the big campaign's model 0 is a perturbed plant
    assert not np.array_equal(big["score_post"].to_numpy(), small.table["score_post"].to_numpy())
    nominal = _campaign(
        spec,
        bank,
        runs=3,
        scenarios=[gf.Scenario.sensor("bias", 0, sizes=[0.0], onsets=[2.5])],
        uncertainty=gf.Uncertainty(models=[c.plants[0]]),
    ).run()
    np.testing.assert_array_equal(
        big["score_post"].to_numpy(), nominal.table["score_post"].to_numpy()
    )


def test_uncertainty_models():
    p = gf.Plant([[1.0, 0.0], [2.0, -3.0]], [[1.0], [0.0]], [[1.0, 1.0]])
    u = gf.Uncertainty(relative=0.1, samples=4, seed=1)
    ps = u.plants(p)
    assert len(ps) == 4
    for q in ps:
        ratio = q.A[p.A != 0] / p.A[p.A != 0]
        assert np.all(np.abs(ratio - 1) <= 0.1) and np.any(ratio != 1)
        assert q.A[0, 1] == 0 and q.B[1, 0] == 0  # zeros stay zero
        np.testing.assert_array_equal(q.C, p.C)  # not in `matrices`
    np.testing.assert_array_equal(ps[2].A, gf.Uncertainty(0.1, 4, seed=1).plants(p)[2].A)
    with pytest.raises(GeomFDIError, match="models"):
        gf.Uncertainty(models=[gf.Plant([[1.0]], [[1.0]], [[1.0]])]).plants(p)
    with pytest.raises(GeomFDIError, match="matrices"):
        gf.Uncertainty(matrices=("Q",))


def test_pd_at_size_zero_is_the_false_alarm_rate_and_grows_with_size(seed001):
    spec, _ = seed001
    # the full-quotient observer: its residual keeps a sensor-bias step visible longer
    # than the least-order rows do (both decay in this closed loop), so the largest size
    # below is detected in every run
    bank = gf.design_bank(spec.plant, spec.faults, spec.structure, method="full")
    bank = bank.normalized("markov")
    noise = gf.Noise(measurement=[0.01, 0.02, 0.005], seed=7)
    models = gf.residual_noise_models(spec.plant, bank, noise, step=0.002, controller=spec.K)
    c = gf.Campaign(
        spec.plant,
        bank,
        [gf.Scenario.sensor("bias", 1, sizes=[0.0, 0.004, 0.01, 0.05], onsets=[2.0])],
        noise,
        t=spec.t[:1751],
        runs=120,
        test=gf.ChiSquareTest.design(models, 50, 2e-4),
        u=spec.u,
        controller=spec.K,
        x0=spec.x0,
        detection_window=1.0,
        eval_start=0.5,
        block_size=240,
    )
    res = c.run()
    s = res.summary().xs("bank", level="residual")
    pd0, far = s["pd"].iloc[0], s["far"].mean()
    # same window length before and after the onset: both estimate one probability
    n = 120
    assert abs(pd0 - far) <= 4 * np.sqrt(far * (1 - far) * (1 / n + 1 / (4 * n))) + 1 / n
    assert 0 < far < 0.5
    pdv = s["pd"].to_numpy()
    assert np.all(np.diff(pdv) >= -0.05) and pdv[-1] == 1.0 and pdv[1] < 1.0
    assert np.all((s["pd_low"] <= s["pd"]) & (s["pd"] <= s["pd_high"]))
    # bias on sensor 1 is seen by the residuals that read sensor 1, not by the others
    per = res.summary().xs(("bias on sensor 1", 0.05), level=("scenario", "size"))
    S = bank.structure
    for k in range(3):
        assert (per.loc[f"r[{k}]", "pd"] == 1.0) == bool(S[k, 1])
    # curves and ROC
    dc = res.detection_curve(residual="bank")
    np.testing.assert_allclose(dc["pd"].to_numpy(), pdv)
    assert res.roc(0.05).auc > 0.99 and res.roc(0.0).auc == pytest.approx(0.5, abs=0.1)
    assert res.roc(0.05, residual="r[1]").auc > res.roc(0.004, residual="r[1]").auc
    assert len(res.plot_roc([0.004, 0.01]).axes[0].lines) == 2
    assert len(res.plot_detection(residuals=["r[1]", "bank"]).axes[0].lines) == 2


def test_campaign_errors(seed001, serial):
    spec, bank = seed001
    with pytest.raises(GeomFDIError, match="executor"):
        _campaign(spec, bank).run("threads")
    with pytest.raises(GeomFDIError, match="test"):
        _campaign(spec, bank, test=None)
    with pytest.raises(GeomFDIError, match="test"):
        _campaign(spec, bank, test=[1.0, 2.0])
    with pytest.raises(GeomFDIError, match="scenarios"):
        _campaign(spec, bank, scenarios=[])
    with pytest.raises(GeomFDIError, match="onsets"):
        _campaign(spec, bank, scenarios=[gf.Scenario.sensor("bias", 0, [1.0], [0.2])]).run()
    with pytest.raises(GeomFDIError, match="residual"):
        serial[1].roc(0.02, residual="r[9]")


def test_docstring_examples_run():
    import doctest

    import geomfdi.campaign.runner
    import geomfdi.campaign.spec

    for mod in (geomfdi.campaign.spec, geomfdi.campaign.runner):
        result = doctest.testmod(mod, optionflags=doctest.NORMALIZE_WHITESPACE)
        assert result.attempted > 0 and result.failed == 0, mod.__name__
