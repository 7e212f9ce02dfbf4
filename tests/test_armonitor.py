"""AR-model innovation monitor (Jin, Ding & Cong; docs/theory/ar-monitoring.md)."""

from __future__ import annotations

import importlib.util
import math
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.lib.stride_tricks import sliding_window_view
from scipy.stats import chi2

import geomfdi as gf
from geomfdi.errors import GeomFDIError, NonFiniteError, RankDeficientError, ShapeError
from geomfdi.monitoring._kernels import _moving_sums

ROOT = Path(__file__).resolve().parents[1]
PAPER_AR = [-0.3]  # coloured innovations reproducing the paper's mu = -0.31 (Jin, Ding & Cong)


def lstsq_phi(w: np.ndarray, n: int) -> np.ndarray:
    """Reference: AR(n) fit of one window from scratch with numpy.linalg.lstsq."""
    rows = sliding_window_view(w, n + 1)[:, ::-1]
    return np.linalg.lstsq(rows[:, 1:], rows[:, 0], rcond=None)[0]


def stream_all(mon: gf.ARMonitor, x: np.ndarray):
    mon.reset()
    steps = []
    for v in x:
        mon.update(v)
        steps.append(mon.last)
    return steps


def trained(order=5, window=60, ar=PAPER_AR, n_windows=900, seed=1, **kw) -> gf.ARMonitor:
    mon = gf.ARMonitor(order, window, **kw)
    return mon.fit(gf.synthetic_innovations(window, ar=ar, n_series=n_windows, rng=seed))


def rel_err(a: np.ndarray, b: np.ndarray) -> float:
    """Normwise relative error per window (max over windows)."""
    num = np.linalg.norm(a - b, axis=-1)
    den = np.maximum(np.linalg.norm(b, axis=-1), 1e-300)
    return float(np.max(num / den))


# --------------------------------------------------------------------------- threshold


def test_threshold_pfa_1e4_is_15_1367():
    mon = gf.ARMonitor(order=5, window=60, coefficient=0, pfa=1e-4, reset_after=10)
    assert round(mon.threshold, 4) == 15.1367
    assert mon.threshold == pytest.approx(chi2.isf(1e-4, 1), rel=1e-14)
    assert gf.ARMonitor(pfa=0.05).threshold == pytest.approx(1.959964**2, rel=1e-6)


# --------------------------------------------------------------------------- the fit


@settings(max_examples=25)
@given(
    order=st.integers(1, 6),
    extra=st.integers(0, 25),
    length=st.integers(0, 80),
    scale=st.sampled_from([1e-3, 1.0, 6.0, 1e4]),
    seed=st.integers(0, 2**31 - 1),
)
def test_batch_fit_equals_lstsq_of_every_window(order, extra, length, scale, seed):
    window = 2 * order + extra
    rng = np.random.default_rng(seed)
    x = scale * rng.standard_normal(window + length)
    mon = gf.ARMonitor(order, window, reset_after=None)
    mon.fit(rng.standard_normal((3, window)))
    out = mon.run(x)
    wins = sliding_window_view(x, window)
    ref = np.array([lstsq_phi(w, order) for w in wins])
    kappa = np.array([np.linalg.cond(sliding_window_view(w, order + 1)[:, :-1]) for w in wins])
    assert not out.valid[: window - 1].any()
    assert out.valid[window - 1 :].all()
    # normal equations: forward error ~ eps kappa(R)^2 (kappa ~ 1e2 at most for m >= 2n + 5)
    tol = 1e-10 + 100 * np.finfo(float).eps * kappa**2
    phi = out.coefficients[window - 1 :]
    err = np.linalg.norm(phi - ref, axis=1) / np.linalg.norm(ref, axis=1)
    assert np.all(err <= tol)
    if extra >= 5:
        assert err.max() < 1e-9
    lam = ((ref[:, 0] - mon.mu) / mon.delta) ** 2
    good = tol < 1e-9
    np.testing.assert_allclose(out.statistic[window - 1 :][good], lam[good], rtol=1e-7)


@pytest.mark.parametrize(("size", "refit_every"), [(5, 10**9), (100, None), (100, 10**9)])
def test_recursive_fit_equals_refit_over_1e4_steps(size, refit_every):
    """Streaming rank-1 updates vs lstsq from scratch on each of 10^4 windows.

    The stream carries a step of ``size`` sigma for 300 samples: its lagged products are
    added to and later removed from the sliding sums, which is where cancellation would
    show.  ``refit_every=10**9`` disables the periodic exact refit (pure recursion; the
    refit on large removed rows still acts), ``None`` is the default (every window).
    """
    m, n, L = 60, 5, 10_000 + 59
    x = gf.synthetic_innovations(L, fault="step", size=size, start=4000, stop=4300, rng=5)
    mon = gf.ARMonitor(n, m, reset_after=None, refit_every=refit_every)
    mon.fit(gf.synthetic_innovations(60, n_series=50, rng=2))
    steps = stream_all(mon, x)
    ref = np.array([lstsq_phi(x[e - m + 1 : e + 1], n) for e in range(m - 1, L)])
    rec = np.array([s.coefficients for s in steps[m - 1 :]])
    assert rel_err(rec, ref) < 1e-9
    batch = mon.run(x).coefficients[m - 1 :]
    assert rel_err(batch, ref) < 1e-9
    assert rel_err(batch, rec) < 1e-9


def test_blockwise_cumsums_keep_accuracy_after_a_huge_fault():
    """A 1e6-sigma fault early in a 2e5-sample stream must not spoil later windows.

    A global cumulative sum would carry the fault's products (~1e15) into every later
    difference and lose all digits; the blockwise sums restart.
    """
    m, n = 60, 5
    x = gf.synthetic_innovations(200_000, fault="step", size=1e6, start=100, stop=200, rng=3)
    mon = gf.ARMonitor(n, m, reset_after=None)
    with warnings.catch_warnings():
        # the windows that span the fault are rank-deficient in floating point (reported
        # by an ARMonitorWarning); this test is about the windows long after it
        warnings.simplefilter("ignore", gf.ARMonitorWarning)
        out = mon.fit(gf.synthetic_innovations(m, n_series=20, rng=4)).run(x)
    ends = np.arange(150_000, 200_000, 997)
    ref = np.array([lstsq_phi(x[e - m + 1 : e + 1], n) for e in ends])
    assert rel_err(out.coefficients[ends], ref) < 1e-9
    q = np.random.default_rng(0).standard_normal((2, 50_000))
    q[:, :10] = 1e12
    direct = sliding_window_view(q, 55, axis=-1).sum(axis=-1)
    assert np.max(np.abs(_moving_sums(q, 55) - direct)[:, 3000:]) < 1e-9


def test_periodic_refit_and_batch_agree_with_streaming():
    x = gf.synthetic_innovations(3000, ar=PAPER_AR, rng=11)
    for refit_every in (1, 7, 60, 10**9):
        mon = trained(refit_every=refit_every, reset_after=None)
        rec = np.array([s.coefficients for s in stream_all(mon, x)])[59:]
        assert rel_err(rec, mon.run(x).coefficients[59:]) < 1e-10


def test_window_coefficients_and_training_statistics():
    rng = np.random.default_rng(4)
    W = gf.synthetic_innovations(60, ar=PAPER_AR, n_series=400, rng=rng)
    mon = gf.ARMonitor(5, 60, coefficient=2).fit(W)
    phi = np.array([lstsq_phi(w, 5) for w in W])
    assert rel_err(mon.window_coefficients(W), phi) < 1e-10
    assert mon.mu == pytest.approx(phi[:, 2].mean(), rel=1e-9)
    assert mon.delta == pytest.approx(phi[:, 2].std(ddof=1), rel=1e-9)
    np.testing.assert_array_equal(mon.normal, W[-1, 1:])
    # 1-D training with step = window uses the same (non-overlapping) windows
    mon1 = gf.ARMonitor(5, 60, coefficient=2).fit(W.reshape(-1), step=60)
    assert mon1.mu == pytest.approx(mon.mu, rel=1e-9)
    assert mon1.delta == pytest.approx(mon.delta, rel=1e-9)
    # paper-like innovations give the paper's mean of phi_1 (-0.3094) within sampling error
    mon0 = trained(n_windows=900, seed=7)
    assert abs(mon0.mu - (-0.3094)) < 0.03
    assert 0.10 < mon0.delta < 0.18


# --------------------------------------------------------------------------- statistics


def test_false_alarm_rate_on_white_innovations_is_nominal():
    """Independent windows: spaced by the window length on white streams.

    lambda of overlapping windows is strongly correlated (a window shares m-1 samples
    with the next), so only every m-th epoch of each stream is used: those windows share
    no sample and are independent for white noise.  With 400 streams x 40 epochs =
    16000 windows at Pfa = 0.05 the binomial standard deviation of the rate is 3.4% of
    0.05; mu and delta from 6000 windows add about 2% to the realised rate's spread;
    the chi-square law of lambda is asymptotic (m = 60).  Tolerance: +-15% relative.
    (At Pfa = 1e-4 the realised rate is about 1.8x nominal: the least-squares phi_1
    has heavier tails than the normal law; see test_far_tail_is_heavier_than_nominal.)
    """
    m = 60
    mon = gf.ARMonitor(5, m, pfa=0.05, reset_after=None)
    mon.fit(gf.synthetic_innovations(m, n_series=6000, rng=21))
    X = gf.synthetic_innovations(40 * m, n_series=400, rng=22)
    out = mon.run(X)
    spaced = out.alarm[:, m - 1 :: m]
    assert spaced.shape == (400, 40) and out.valid[:, m - 1 :: m].all()
    rate = spaced.mean()
    assert abs(rate / 0.05 - 1) < 0.15, rate
    # all (correlated) epochs: same expectation, wider tolerance (effective sample ~ /m)
    assert abs(out.alarm[:, m - 1 :].mean() / 0.05 - 1) < 0.25


@pytest.mark.slow
def test_far_tail_is_heavier_than_nominal():
    """At Pfa = 1e-4 (paper) the realised rate is of the right order but above nominal.

    400000 independent windows: expected 40 alarms at the nominal rate (sd 6.3).
    """
    mon = gf.ARMonitor(5, 60, pfa=1e-4, reset_after=None)
    mon.fit(gf.synthetic_innovations(60, n_series=50_000, rng=31))
    lam = mon.statistic_of(
        mon.window_coefficients(gf.synthetic_innovations(60, n_series=400_000, rng=32))
    )
    rate = float(np.mean(lam > mon.threshold))
    assert 1e-4 < rate < 3.5e-4, rate


def test_5_sigma_step_detected_within_a_few_samples():
    """Paper setting (sigma = 6 m, mu of phi_1 near -0.31), fault in the last samples."""
    mon = trained(reset_after=None)
    X = gf.synthetic_innovations(
        160, ar=PAPER_AR, fault="step", size=5, start=100, n_series=300, rng=41
    )
    out = mon.run(X)
    delay = np.where(out.alarm[:, 100:].any(axis=1), out.alarm[:, 100:].argmax(axis=1), 99)
    assert np.median(delay) <= 3
    assert np.mean(delay <= 5) >= 0.8
    assert np.mean(out.alarm[:, 59:100]) < 2e-3  # before the fault: false alarms only
    # a fault in the last 2 samples already moves phi_1 most (paper, Fig. 2)
    W = gf.synthetic_innovations(60, ar=PAPER_AR, n_series=200, rng=42)
    f = gf.innovation_fault(60, kind="step", size=5, start=58)
    dphi = np.abs(mon.window_coefficients(W + f) - mon.window_coefficients(W)).mean(axis=0)
    assert np.argmax(dphi) == 0 and dphi[0] > 2 * dphi[1:].max()


# --------------------------------------------------------------------------- reset strategy


def _counter_restarts(alarm: np.ndarray, k: int) -> np.ndarray:
    """Reference restart epochs from the documented rule (k consecutive alarms)."""
    out = np.zeros_like(alarm)
    c = 0
    for t, a in enumerate(alarm):
        c = c + 1 if a else 0
        if c >= k:
            out[t] = True
            c = 0
    return out


@pytest.mark.parametrize("keep", [0, 1, 3])
def test_restart_window_content_is_as_documented(keep):
    k = 10
    mon = trained(reset_after=k, reset_keep=keep)
    x = gf.synthetic_innovations(700, ar=PAPER_AR, fault="step", start=100, stop=500, rng=8)
    normal_before = mon.normal.copy()
    out = mon.run(x)
    rst = np.flatnonzero(out.restarted)
    assert rst.size >= 3
    np.testing.assert_array_equal(out.restarted, _counter_restarts(out.alarm, k))
    for t in rst[rst < x.size - 1]:
        assert out.alarm[t - k + 1 : t + 1].all()
        win = np.concatenate([mon.normal[keep:], x[t - keep + 1 : t + 1], x[t + 1 : t + 2]])
        assert win.size == 60
        np.testing.assert_allclose(
            out.coefficients[t + 1], lstsq_phi(win, 5), rtol=1e-9, atol=1e-12
        )
    np.testing.assert_array_equal(mon.normal, normal_before)  # never refreshed


def test_reset_keeps_the_alarm_and_releases_it_after_the_fault():
    """Without reset the alarm dies once the fault fills the window; with it, it persists.

    After the fault ends, the monitor goes back to normal: across 40 streams no alarm
    later than ``stop + m`` (beyond the false-alarm rate) and, with the reset, the
    fault-related alarms end within ``reset_after + m`` epochs of the fault's end.
    """
    m, k, start, stop, L = 60, 10, 100, 500, 800
    X = gf.synthetic_innovations(
        L, ar=PAPER_AR, fault="step", start=start, stop=stop, n_series=40, rng=9
    )
    plain = trained(reset_after=None).run(X)
    late = slice(start + m, stop)  # the fault fills every window here
    assert plain.alarm[:, late].mean() < 0.05
    with_reset = trained(reset_after=k, reset_keep=1).run(X)
    assert with_reset.alarm[:, late].mean() > 0.7
    # a stream whose first alarm run is shorter than reset_after never restarts
    assert np.mean(with_reset.restarted[:, late].sum(axis=1) >= 10) >= 0.85
    # with the reset, the fault's alarms stop soon after its end (next restart)
    tail = with_reset.alarm[:, stop : stop + m]
    last = np.array([np.flatnonzero(r)[-1] if r.any() else -1 for r in tail])
    assert np.mean(last <= k + 5) >= 0.8
    for res in (plain, with_reset):
        assert res.alarm[:, stop + m :].mean() < 1e-3
        assert res.alarm[:, :start].mean() < 2e-3


def test_stream_equals_batch_with_reset_prefill_and_nan():
    mon = trained(reset_after=10, reset_keep=2, prefill=True)
    x = gf.synthetic_innovations(
        1200, ar=PAPER_AR, fault="step", size=5, start=200, stop=700, rng=12
    )
    x[900] = np.nan
    x[1000] = np.inf
    with pytest.warns(gf.ARMonitorWarning):
        out = mon.run(x)
    with pytest.warns(gf.ARMonitorWarning):
        steps = stream_all(mon, x)
    stat = np.array([s.statistic for s in steps])
    for name in ("alarm", "valid", "restarted", "nonfinite", "singular"):
        np.testing.assert_array_equal(
            np.array([getattr(s, name) for s in steps]), getattr(out, name), err_msg=name
        )
    np.testing.assert_array_equal(np.isnan(stat), np.isnan(out.statistic))
    ok = out.valid
    np.testing.assert_allclose(stat[ok], out.statistic[ok], rtol=1e-9, atol=1e-12)
    assert out.restarted.sum() >= 3
    assert out.valid[0]  # prefill: a statistic from the first sample on
    lam, alarm = mon.update(0.5)  # the tuple of the streaming API
    assert isinstance(lam, float) and isinstance(alarm, bool)


# --------------------------------------------------------------------------- bad data


def test_nan_sample_is_reported_and_not_propagated():
    m = 60
    mon = trained(reset_after=None)
    x = gf.synthetic_innovations(400, ar=PAPER_AR, rng=13)
    s = 150
    results = []
    for value in (np.nan, 0.0, 1e6):
        y = x.copy()
        y[s] = value
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            results.append(mon.run(y))
        if np.isnan(value):
            assert any(issubclass(w.category, gf.ARMonitorWarning) for w in rec)
            assert any("index 150" in str(w.message) for w in rec)
    bad = results[0]
    hit = np.zeros(400, dtype=bool)
    hit[s : s + m] = True  # exactly the windows containing sample s
    np.testing.assert_array_equal(bad.nonfinite, hit)
    np.testing.assert_array_equal(bad.valid, ~hit & (np.arange(400) >= m - 1))
    assert np.all(np.isnan(bad.statistic[hit])) and not bad.alarm[hit].any()
    after = slice(s + m, None)
    assert np.all(np.isfinite(bad.statistic[after]))
    for other in results[1:]:  # later statistics do not depend on the bad sample
        np.testing.assert_allclose(bad.statistic[after], other.statistic[after], rtol=1e-9)
    # streaming: same windows flagged, a warning at the sample
    mon.reset()
    for v in x[:s]:
        mon.update(v)
    with pytest.warns(gf.ARMonitorWarning, match="non-finite"):
        lam, alarm = mon.update(np.nan)
    assert math.isnan(lam) and alarm is False and mon.last.nonfinite
    for t in range(s + 1, 400):
        mon.update(x[t])
        assert mon.last.nonfinite == (t < s + m)
        assert mon.last.valid == (t >= s + m)
    assert mon.last.statistic == pytest.approx(results[1].statistic[-1], rel=1e-9)


def test_singular_windows_are_flagged_not_solved():
    mon = trained(reset_after=None)
    x = gf.synthetic_innovations(300, rng=14)
    x[100:200] = 0.0  # windows entirely inside have an all-zero regressor matrix
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.warns(gf.ARMonitorWarning, match="rank-deficient"):
            out = mon.run(x)
    assert out.singular[159:200].all()
    assert not out.valid[159:200].any() and np.isnan(out.statistic[159:200]).all()
    assert out.valid[210:].all()
    with pytest.warns(gf.ARMonitorWarning, match="rank-deficient"):
        steps = stream_all(mon, x)
    np.testing.assert_array_equal([s.singular for s in steps], out.singular)
    with pytest.raises(RankDeficientError) as exc:
        gf.ARMonitor(2, 10).fit(np.zeros((5, 10)))
    assert exc.value.argument == "training"


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"order": 60, "window": 60}, "order"),
        ({"order": 61, "window": 60}, "order"),
        ({"order": 31, "window": 60}, "order"),
        ({"order": 0}, "order"),
        ({"window": 1}, "window"),
        ({"coefficient": 5}, "coefficient"),
        ({"pfa": 0.0}, "pfa"),
        ({"pfa": 1.5}, "pfa"),
        ({"reset_after": 0}, "reset_after"),
        ({"reset_keep": 60}, "reset_keep"),
        ({"refit_every": 0}, "refit_every"),
        ({"prefill": "yes"}, "prefill"),
    ],
)
def test_bad_constructor_arguments(kwargs, argument):
    with pytest.raises(GeomFDIError) as exc:
        gf.ARMonitor(**kwargs)
    assert exc.value.argument == argument
    assert argument in str(exc.value)


def test_bad_training_and_stream():
    mon = gf.ARMonitor(5, 60)
    good = gf.synthetic_innovations(60, n_series=10, rng=0)
    bad = good.copy()
    bad[3, 7] = np.nan
    cases = [
        (bad, NonFiniteError),
        (good[:1], GeomFDIError),  # one window: no delta
        (good[:, :59], ShapeError),  # windows of the wrong length
        (good[0, :59], GeomFDIError),  # sequence shorter than a window
        (good[0], GeomFDIError),  # exactly one window
        (np.zeros((2, 3, 60)), ShapeError),
        (good + 1j, gf.errors.ComplexInputError),
    ]
    for training, err in cases:
        with pytest.raises(err) as exc:
            mon.fit(training)
        assert exc.value.argument == "training"
    with pytest.raises(GeomFDIError, match="fit") as exc:
        mon.run(good[0])
    with pytest.raises(GeomFDIError, match="fit"):
        mon.update(1.0)
    mon.fit(good)
    for stream in ([], np.zeros((2, 2, 2)), [1 + 2j, 0], ["a", "b"]):
        with pytest.raises(GeomFDIError) as exc:
            mon.run(stream)
        assert exc.value.argument == "stream"
    for x in ([1.0, 2.0], 1 + 1j, "x", True):
        with pytest.raises(GeomFDIError) as exc:
            mon.update(x)
        assert exc.value.argument == "x"
    with pytest.raises(ShapeError) as exc:
        mon.set_normal(np.zeros(60))
    assert exc.value.argument == "normal"
    with pytest.raises(GeomFDIError) as exc:
        mon.fit(np.ones((4, 60)))  # phi_1 = ... identical (or singular) in every window
    assert exc.value.argument == "training"


# --------------------------------------------------------------------------- batch / api


def test_batch_of_streams_equals_rows_and_result_api():
    mon = trained(reset_after=None)
    X = gf.synthetic_innovations(300, ar=PAPER_AR, fault="step", start=200, n_series=4, rng=15)
    out = mon.run(X)
    assert out.statistic.shape == (4, 300) and out.coefficients.shape == (4, 300, 5)
    for i in range(4):
        row = mon.run(X[i])
        np.testing.assert_allclose(out.statistic[i], row.statistic, rtol=1e-12, equal_nan=True)
        np.testing.assert_array_equal(out.alarm[i], row.alarm)
        assert out.first_alarm[i] == (row.first_alarm if row.first_alarm is not None else -1)
    assert out.info["restarts"] == 0 and out.threshold == mon.threshold
    assert "ARMonitor(order=5" in repr(mon)


def test_plot_helper_returns_figure():
    from matplotlib.figure import Figure

    mon = trained(reset_after=10, prefill=False)
    x = gf.synthetic_innovations(400, ar=PAPER_AR, fault="step", start=100, rng=16)
    x[300] = np.nan
    with pytest.warns(gf.ARMonitorWarning):
        out = mon.run(x)
    fig = out.plot(time=np.arange(1, 401), title="lambda")
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert ax.get_yscale() == "log"
    assert any(line.get_ydata()[0] == pytest.approx(out.threshold) for line in ax.get_lines())
    with pytest.raises(ShapeError):
        gf.plot_ar_monitor(out, time=np.arange(3))
    import matplotlib.pyplot as plt

    plt.close("all")


# --------------------------------------------------------------------------- scripts


def _load(path: Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = mod
    spec.loader.exec_module(mod)
    return mod


def test_benchmark_quick_mode_runs(capsys):
    bench = _load(ROOT / "benchmarks" / "bench_armonitor.py")
    rows = bench.bench(
        n_samples=800, windows=(60,), subset=50, subset_autoreg=3, stream_samples=200
    )
    methods = {r["method"] for r in rows}
    assert {"sliding (batch)", "sliding (stream)", "refit lstsq (loop)"} <= methods
    assert all(r["max_err"] < 1e-9 for r in rows)
    bench.print_table(rows, 800)
    assert "speed-up" in capsys.readouterr().out


def test_example_script_runs(tmp_path, capsys):
    example = _load(ROOT / "examples" / "ar_innovation_monitor.py")
    res = example.main(["--out", str(tmp_path), "--seed", "3", "--buffers", "20", "--streams", "4"])
    assert (tmp_path / "ar_parameter_changes.png").exists()
    assert (tmp_path / "ar_stream_reset.png").exists()
    shift = res["shift"]["5σ in last 2"]
    assert np.argmax(shift) == 0  # phi_1 changes most (paper, Fig. 2)
    no_reset = res["stream"]["without reset"]
    with_reset = res["stream"]["with reset (10 alarms)"]
    assert 61 <= no_reset["first_alarm_s"] <= 70
    assert with_reset["alarm_fraction_during_fault"] > 2 * no_reset["alarm_fraction_during_fault"]
    out = capsys.readouterr().out
    assert "first alarm" in out
    # the alarm-fraction distribution over 20 stored buffers, with and without the reset,
    # and the chi-square baseline on the same streams
    assert "20 stored normal buffers" in out and "chi2 of innovation" in out
    dist = res["buffers"]
    assert dist["fractions"]["reset (10 alarms)"].size == 20
    assert dist["fractions"]["no reset"].size == 20
    spread = np.ptp(dist["fractions"]["reset (10 alarms)"])
    assert spread > 0.2  # the reset's benefit depends strongly on the stored buffer
    assert dist["chi2"] > np.median(dist["fractions"]["no reset"])


@pytest.mark.parametrize("training", [[], np.zeros((0, 60)), np.zeros((1, 60)), [[]]])
def test_fit_on_empty_or_single_window_is_a_named_error(training):
    with pytest.raises(GeomFDIError, match="training"):
        gf.ARMonitor().fit(training)


def test_module_docstring_examples_run():
    import doctest

    import geomfdi.monitoring.monitor as mod

    res = doctest.testmod(mod, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert res.attempted > 0 and res.failed == 0
