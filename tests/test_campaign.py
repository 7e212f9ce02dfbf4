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
    spec = load_model(EXAMPLES / "hou_wen_chen.toml")
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
        # 2 of 3 samples; an episode ends after 0.1 s without alarm (the perturbed
        # models' start-up alarms do not stay in the pattern)
        persistence=gf.Persistence(2, 3, reset=50),
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


def test_isolation_columns_per_run(serial):
    c, res = serial
    tb = res.table
    bank = tb[tb["residual"] == "bank"]
    other = tb[tb["residual"] != "bank"]
    assert other[["true_fault", "isolated", "isolation"]].isna().all().all()
    assert other["isolation_delay"].isna().all()
    labels = c.fault_labels
    assert labels == ["sensor 0", "sensor 1", "sensor 2"]
    assert list(bank["isolated"].cat.categories) == [*labels, "multiple", "none"]
    assert not bank[["true_fault", "isolated", "isolation"]].isna().any().any()
    faulty = bank["size"] > 0
    assert (bank.loc[~faulty, "true_fault"] == "no fault").all()
    truth = np.where(bank["scenario"].str.startswith("bias"), "sensor 0", "sensor 2")
    assert (bank.loc[faulty, "true_fault"] == truth[faulty.to_numpy()]).all()
    # correct = the first decision is the true fault; none = no decision
    dec, true, out = bank["isolated"], bank["true_fault"], bank["isolation"]
    assert ((out == "correct") == (dec.astype(str) == true.astype(str))).all()
    assert ((out == "none") == (dec == "none")).all()
    assert ((out == "wrong") == ~((out == "correct") | (out == "none"))).all()
    # an isolation delay exactly for the runs with a correct decision in the window
    d = bank["isolation_delay"]
    assert (d.notna() >= (out == "correct")).all()
    assert ((d[d.notna()] >= 0) & (d[d.notna()] < 1.0)).all()
    assert (out[faulty] == "correct").mean() > 0.9
    # summary: rates with Wilson bounds, delays, on the bank rows
    s = res.summary()
    sb = s.xs("bank", level="residual")
    for (sc, z), row in sb.iterrows():
        sel = bank[(bank["scenario"] == sc) & (bank["size"] == z)]
        n = len(sel)
        for k in ("correct", "wrong", "none"):
            p = float(np.mean(sel["isolation"] == k))
            assert row[f"iso_{k}"] == pytest.approx(p)
            lo, hi = gf.wilson_interval(p * n, n)
            assert row[f"iso_{k}_low"] == pytest.approx(lo)
            assert row[f"iso_{k}_high"] == pytest.approx(hi)
        assert row["iso_multiple"] == pytest.approx(np.mean(sel["isolated"] == "multiple"))
        dd = sel["isolation_delay"].dropna()
        if len(dd):
            assert row["iso_delay_median"] == pytest.approx(dd.median())
    assert s.xs("r[0]", level="residual")["iso_correct"].isna().all()
    # confusion: every run once, rows = true faults, columns = decisions
    C = res.confusion()
    assert C.to_numpy().sum() == len(bank)
    assert list(C.columns) == [*labels, "multiple", "none"]
    assert C.loc["no fault"].sum() == (~faulty).sum()
    pd.testing.assert_series_equal(
        C.loc["sensor 0"], res.confusion(scenario="bias on sensor 0").loc["sensor 0"]
    )
    norm = res.confusion(normalize=True)
    np.testing.assert_allclose(norm.sum(axis=1), 1.0)
    fig = res.plot_confusion(size=0.02)
    assert [t.get_text() for t in fig.axes[0].get_yticklabels()] == ["sensor 0"]


def test_isolation_of_runs_by_hand():
    """First decision, outcome and delay of hand-made statistics (threshold 1)."""
    from geomfdi.campaign.runner import isolate_runs
    from geomfdi.evaluation.decision import MULTIPLE

    t = np.arange(10) * 0.5
    S = np.eye(3, dtype=bool)
    z = np.zeros((5, 3, 10))
    z[0, 0, 4:] = 2  # run 0: fault 0 from k=4 (onset k=3): correct, delay 0.5
    z[1, 1, 4] = 2  # run 1: fault 0, r1 alone at k=4 (wrong), then r0 from k=6
    z[1, 0, 6:] = 2
    z[2, 2, 1] = 2  # run 2: fault-free, false alarm before the onset only: none
    z[3, :2, 5:] = 2  # run 3: faults 0 and 1 at once: MULTIPLE with the right suspects
    z[4, 2, 8] = 2  # run 4: fault-free, an alarm in the window: a wrong isolation
    truth = np.array([0, 0, -1, MULTIPLE, -1])
    sets = [frozenset({0}), frozenset({0}), frozenset(), frozenset({0, 1}), frozenset()]
    onsets = np.full(5, 1.5)
    out = isolate_runs(t, z, np.ones(3), S, None, truth, sets, onsets, 3.0)
    # per-sample decisions: run 3's pattern matches no column (no decision)
    assert out["decision"].tolist() == [0, 1, -1, -1, 2]
    assert out["outcome"].tolist() == [0, 1, 2, 2, 1]  # correct, wrong, none, none, wrong
    np.testing.assert_array_equal(out["iso_delay"], [0.5, 1.5, np.nan, np.nan, np.nan])
    # the window ends before run 1's r0 (k=6 at 3.0 s): no correct decision in it
    short = isolate_runs(t, z, np.ones(3), S, None, truth, sets, onsets, 1.5)
    assert short["outcome"].tolist()[:2] == [0, 1] and np.isnan(short["iso_delay"][1])
    # the held pattern: run 1's r1 stays ("multiple" from k=6, never fault 0 alone), run
    # 3 is "multiple" with suspects {0, 1} (correct), run 2's early alarm stays (wrong)
    held = isolate_runs(t, z, np.ones(3), S, gf.Persistence(1, 1), truth, sets, onsets, 3.0)
    assert held["decision"].tolist() == [0, 1, 2, MULTIPLE, 2]
    assert held["outcome"].tolist() == [0, 1, 1, 0, 1]
    np.testing.assert_array_equal(held["iso_delay"], [0.5, np.nan, np.nan, 1.0, np.nan])
    # ... unless its episode ends (2 quiet samples), or it is before eval_start
    rule = gf.Persistence(1, 1, reset=2)
    assert isolate_runs(t, z, np.ones(3), S, rule, truth, sets, onsets, 3.0)["outcome"][2] == 2
    late = isolate_runs(t, z, np.ones(3), S, gf.Persistence(1, 1), truth, sets, onsets, 3.0, 1.0)
    assert late["outcome"].tolist() == [0, 1, 2, 0, 1]


def test_simultaneous_faults_in_a_campaign(seed001):
    spec, bank = seed001
    both = gf.Scenario(
        "bias on sensors 0 and 2",
        lambda size, onset: [
            gf.BiasFault(0, start=onset, bias=size),
            gf.BiasFault(2, start=onset, bias=size),
        ],
        sizes=[0.05],
        onsets=[2.5],
    )
    # settled over 10 samples (20 ms): r0 and r2 cross within it
    rule = gf.Persistence(10, 10, reset=50)
    res = _campaign(spec, bank, scenarios=[both], runs=4, block_size=4, persistence=rule).run()
    bank_rows = res.table[res.table["residual"] == "bank"]
    assert (bank_rows["true_fault"] == "multiple").all()
    assert (bank_rows["isolated"] == "multiple").all()
    assert (bank_rows["isolation"] == "correct").all()
    assert res.confusion().loc["multiple", "multiple"] == 4
    assert bank_rows["isolation_delay"].between(0.0, 0.1).all()


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
        # not the default client: the campaign must use the one it is given
        distributed.Client(cluster, set_as_default=False) as client,
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


def test_size_zero_has_no_delay_and_figures_name_their_scenario(serial):
    _, res = serial
    scen = "bias on sensor 0"
    curve = res.detection_curve(scenario=scen)
    assert curve.loc[0.0, ["delay_median", "delay_p90"]].isna().all()
    assert np.isfinite(curve.loc[0.02, "delay_median"])
    fig = res.plot_detection(scenario=scen)
    ax1, ax2 = fig.axes
    (line,) = ax2.get_lines()
    x, y = line.get_data()
    assert np.isnan(np.asarray(y)[np.isclose(x, 0.0)]).all()  # no delay drawn at size 0
    assert ax1.get_title().startswith(scen)
    assert res.plot_roc([0.02], scenario=scen).axes[0].get_title().startswith(scen)
    assert "all scenarios" in res.plot_confusion().axes[0].get_title()
