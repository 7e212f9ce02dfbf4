"""Baselines on the AR monitor's innovations: false-alarm rates, power, T^2, latching."""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import GeomFDIError
from geomfdi.monitoring import baselines as bl

N_FA = 20_000
SIGMA = 6.0


@pytest.mark.slow
@pytest.mark.parametrize("method", ["chi2", "cusum", "glr"])
def test_per_epoch_false_alarm_rate_matches_the_computed_one(method):
    pfa, window = 0.01, 40
    X = np.random.default_rng(31).standard_normal((N_FA, window)) * SIGMA
    if method == "chi2":
        res = bl.innovation_chi2(X, SIGMA, pfa)
    elif method == "cusum":
        res = bl.innovation_cusum(X, SIGMA, pfa, window=window, n_blocks=100_000)
    else:
        res = bl.innovation_glr(X, SIGMA, pfa, window=window, n_blocks=100_000)
    rate = res.alarm[:, -1].mean()  # independent streams; finite memory: any epoch >= window-1
    se = np.sqrt(pfa * (1 - pfa) / N_FA)
    if method != "chi2":
        se = np.hypot(se, np.sqrt(pfa * (1 - pfa) / 100_000))
    assert abs(rate - pfa) < 4 * se


def test_glr_and_cusum_match_their_definitions():
    z = np.random.default_rng(1).standard_normal((1, 30))
    z[0, 15:] += 1.5
    g = bl._glr(z, 8)[0]
    for t in range(30):
        ref = max(z[0, t - k + 1 : t + 1].sum() ** 2 / k for k in range(1, min(8, t + 1) + 1))
        assert g[t] == pytest.approx(ref)
    c = bl._cusum(z, 1.0, 8)[0]
    for t in range(30):
        inc = np.stack([z[0] - 0.5, -z[0] - 0.5], axis=-1)
        ref = max(
            [0.0] + [inc[tau : t + 1].sum(axis=0).max() for tau in range(max(0, t - 7), t + 1)]
        )
        assert c[t] == pytest.approx(ref)


def test_baselines_alarm_on_a_step_the_ar_test_loses():
    mon = gf.ARMonitor(5, 60, reset_after=None)
    mon.fit(gf.synthetic_innovations(60, ar=[-0.3], n_series=400, rng=0))
    x = gf.synthetic_innovations(
        400, ar=[-0.3], fault="step", size=5, start=150, n_series=20, rng=1
    )
    ar = mon.run(x)
    chi2 = bl.innovation_chi2(x, SIGMA * np.sqrt(1 / (1 - 0.09)))
    glr = bl.innovation_glr(x, SIGMA * np.sqrt(1 / (1 - 0.09)), window=60, n_blocks=20_000)
    late = slice(260, 400)  # the step fills every window: the AR statistic has died out
    assert ar.alarm[:, late].mean() < 0.2
    assert chi2.alarm[:, late].mean() > 0.5 and glr.alarm[:, late].mean() > 0.9
    # the joint T^2 (5 dof), calibrated: it detects the onset at pfa = 1e-3 (at 1e-4 it
    # catches 5 % of these streams in 20 epochs against 80 % for the phi_1 test)
    t2 = bl.coefficient_t2(mon, ar, pfa=1e-3, n_draws=50_000)
    assert t2.alarm[:, 150:170].any(axis=1).mean() > 0.5
    assert not np.isnan(t2.statistic[:, 59:]).any()
    latched = bl.latch_alarms(ar.alarm)
    assert latched[:, late].mean() >= ar.alarm[:, late].mean()
    assert (latched[ar.alarm.any(axis=1)][:, -1]).all()


@pytest.fixture(scope="module")
def t2_setting():
    mon = gf.ARMonitor(5, 60, reset_after=None)
    mon.fit(gf.synthetic_innovations(60, ar=[-0.3], n_series=2000, rng=2))
    # fresh independent windows: the statistic at the last epoch is the fit of the window
    res = mon.run(gf.synthetic_innovations(60, ar=[-0.3], n_series=N_T2, rng=3))
    return mon, res


N_T2 = 50_000


@pytest.mark.slow
@pytest.mark.parametrize("pfa", [0.01, 0.001])
def test_t2_bootstrap_false_alarm_rate_within_binomial_error(t2_setting, pfa):
    mon, res = t2_setting
    t2 = bl.coefficient_t2(mon, res, pfa=pfa, n_draws=100_000, rng=5)
    rate = t2.alarm[:, -1].mean()
    se = np.hypot(np.sqrt(pfa * (1 - pfa) / N_T2), t2.info["calibration_se"])
    assert t2.info["n_draws"] == 100_000 and t2.info["null"] == "bootstrap"
    assert abs(rate - pfa) <= 3 * se, (rate, pfa, se)
    # Hotelling's F law ignores the mixture of window covariances sigma^2 (R^T R)^-1:
    # its realised rate is far outside the same band (about 1.7x and 4x the nominal)
    hot = bl.coefficient_t2(mon, res, pfa=pfa, null="hotelling")
    assert hot.threshold < t2.threshold
    assert hot.alarm[:, -1].mean() > pfa + 3 * se


def test_t2_bootstrap_is_reproducible_cached_and_reset_by_training():
    mon = gf.ARMonitor(3, 30, reset_after=None)
    mon.fit(gf.synthetic_innovations(30, n_series=300, rng=0))
    res = mon.run(gf.synthetic_innovations(30, n_series=5, rng=1))
    a = bl.coefficient_t2(mon, res, pfa=0.01, n_draws=2000, rng=1)
    assert list(mon._t2_null) == [(2000, 1)]
    b = bl.coefficient_t2(mon, res, pfa=0.01, n_draws=2000, rng=1)
    assert a.threshold == b.threshold
    c = bl.coefficient_t2(mon, res, pfa=0.01, n_draws=2000, rng=2)
    assert c.threshold != a.threshold
    np.testing.assert_allclose(mon.training_model, np.zeros(3), atol=0.03)  # white noise
    mon.fit(gf.synthetic_innovations(30, n_series=300, rng=4))
    assert mon._t2_null == {}
    with pytest.raises(GeomFDIError, match="null"):
        bl.coefficient_t2(mon, res, null="F")
    with pytest.raises(GeomFDIError, match="n_draws"):
        bl.coefficient_t2(mon, res, n_draws=10)


def test_latching_and_options_are_validated():
    a = np.array([0, 1, 0, 0, 0, 1, 0, 0, 0, 0], dtype=bool)
    assert bl.latch_alarms(a, 2).astype(int).tolist() == [0, 1, 1, 1, 0, 1, 1, 1, 0, 0]
    assert bl.latch_alarms(a).astype(int).tolist() == [0] + [1] * 9
    with pytest.raises(GeomFDIError, match="hold"):
        bl.latch_alarms(a, -1)
    with pytest.raises(GeomFDIError, match="sigma"):
        bl.innovation_chi2([1.0, 2.0], 0.0)
    with pytest.raises(GeomFDIError, match="x"):
        bl.innovation_glr([], 1.0)
