"""Windowed and sequential parity tests: false-alarm rates and small-bias detection."""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import GeomFDIError
from geomfdi.parity.sequential import cusum_statistic, window_sprt_statistic
from geomfdi.parity.sprt import sprt_run, wald_boundaries, wald_rate

N_FA = 20_000


@pytest.fixture(scope="module")
def pf():
    return gf.ParityFDI(gf.parity.dodecahedron(), sigma=2.0)


def _brute_cusum(inc, window):
    R, N, _ = inc.shape
    out = np.zeros((R, N))
    for r in range(R):
        for t in range(N):
            sums = [inc[r, tau : t + 1].sum(axis=0) for tau in range(max(0, t - window + 1), t + 1)]
            out[r, t] = max(0.0, max(s.max() for s in sums))
    return out


def _brute_sprt(inc, window, beta):
    R, N, K = inc.shape
    out = np.zeros((R, N))
    for r in range(R):
        for t in range(N):
            cur = np.zeros(K)
            for tau in range(max(0, t - window + 1), t + 1):
                cur += inc[r, tau]
                cur[cur <= np.log(beta)] = 0.0
            out[r, t] = cur.max()
    return out


def test_cusum_and_sprt_match_their_recursions(pf):
    from geomfdi.parity.sequential import _llr

    Z = np.random.default_rng(0).standard_normal((2, 25, 6)) * 2.0
    Z[:, 12:, 3] += 3.0
    inc = _llr(pf.data, Z, 0.5)
    assert np.allclose(cusum_statistic(pf, Z, 0.5, 7)[0], _brute_cusum(inc, 7), atol=1e-12)
    assert np.allclose(window_sprt_statistic(pf, Z, 0.5, 0.1, 7)[0], _brute_sprt(inc, 7, 0.1))


def _brute_wald(inc, upper, lower):
    """Repeated Wald SPRT, one stream and one epoch at a time."""
    R, N, K = inc.shape
    stat, alarm = np.zeros((R, N)), np.zeros((R, N), dtype=bool)
    for r in range(R):
        S = [0.0] * K
        for t in range(N):
            S = [S[k] + inc[r, t, k] for k in range(K)]
            stat[r, t] = max(S)
            if max(S) >= upper:  # decide "fault": alarm, every hypothesis restarts
                alarm[r, t] = True
                S = [0.0] * K
            S = [0.0 if v <= lower else v for v in S]  # decide "no fault" on k: restart k
    return stat, alarm


def test_wald_sprt_matches_its_recursion_and_boundaries(pf):
    from geomfdi.parity.sequential import _llr

    A, B = wald_boundaries(0.01, 0.1)
    assert A == pytest.approx(np.log(0.9 / 0.01)) and B == pytest.approx(np.log(0.1 / 0.99))
    Z = np.random.default_rng(3).standard_normal((3, 60, 6)) * 2.0
    Z[:, 30:, 1] += 2.0
    inc = _llr(pf.data, Z, 0.5)
    stat, alarm, best = sprt_run(inc, A, B)
    ref_stat, ref_alarm = _brute_wald(inc, A, B)
    assert np.allclose(stat, ref_stat) and (alarm == ref_alarm).all()
    assert alarm[:, 30:].sum() > alarm[:, :30].sum()
    # through the public API: threshold=A uses Wald's B for alpha = (1 - beta) e^-A
    res = pf.diagnose(Z, method="sprt", threshold=A)
    assert (res.detected == ref_alarm).all() and res.info["lower"] == pytest.approx(B)
    assert (res.isolated[res.detected & (np.arange(60) >= 40)] == 1).mean() > 0.8
    # Wald's approximate rate of one repeated SPRT, checked on its own definition
    nu = 0.5 * np.sqrt(0.5)
    pa = (1 - np.exp(B)) / (np.exp(A) - np.exp(B))
    assert wald_rate(A, B, nu) == pytest.approx(pa / ((pa * A + (1 - pa) * B) / (-(nu**2) / 2)))
    with pytest.raises(GeomFDIError, match="beta"):
        wald_boundaries(0.5, 0.6)


@pytest.mark.slow
@pytest.mark.parametrize("pfa", [0.01, 0.001])
def test_wald_sprt_false_alarm_rate_matches_the_calibrated_one(pf, pfa):
    R, N, burn = 400, 550, 50  # 2e5 fault-free epochs after the renewal burn-in
    Z = np.random.default_rng(17).standard_normal((R, N, 6)) * pf.sigma
    res = pf.diagnose(Z, pfa, method="sprt")
    cal = res.info
    assert cal["n_epochs"] >= 400_000 and res.threshold == cal["upper"]
    rate = res.detected[:, burn:].mean()
    n = R * (N - burn)
    se = np.hypot(np.sqrt(pfa * (1 - pfa) / n), cal["rate_se"])
    assert abs(cal["rate"] - pfa) <= 3 * cal["rate_se"]  # the calibration hit its target
    assert abs(rate - cal["rate"]) <= 3 * se, (rate, cal["rate"], se)
    # Wald's formula at the calibrated A overstates the rate (it ignores the overshoot
    # and sums the 12 correlated hypotheses): about 1.6-1.9 x pfa
    assert cal["wald_rate"] > pfa * 1.3


def test_wald_sprt_detects_a_drift_earlier_than_the_per_sample_glt(pf):
    rng = np.random.default_rng(7)
    R, N, t0, pfa = 60, 900, 200, 1e-3
    Z = rng.standard_normal((R, N, 6)) * pf.sigma
    Z[:, t0:, 2] += 0.004 * pf.sigma * np.arange(N - t0)  # drift: one sigma per 250 samples
    glt = pf.diagnose(Z.reshape(-1, 6), pfa).detected.reshape(R, N)
    sprt = pf.diagnose(Z, pfa, method="sprt")

    def delay(det):
        d = det[:, t0:]
        return np.where(d.any(axis=1), d.argmax(axis=1), N - t0)

    d_glt, d_sprt = delay(glt), delay(sprt.detected)
    # measured: median delays of about 130 (SPRT) and 350 (GLT) samples
    assert np.median(d_sprt) < 0.6 * np.median(d_glt)
    assert (d_sprt < d_glt).mean() > 0.8


@pytest.mark.slow
@pytest.mark.parametrize("method", ["windowed", "cusum", "sprt-window"])
def test_per_epoch_false_alarm_rate_matches_the_computed_one(pf, method):
    window, pfa = 30, 0.01
    # independent noise-only streams; the statistic at epoch window - 1 has the law of
    # any epoch of a long stream (finite memory)
    Z = np.random.default_rng(11).standard_normal((N_FA, window, 6)) * pf.sigma
    res = pf.diagnose(Z, pfa, method=method, window=window)
    rate = res.detected[:, -1].mean()
    se = np.sqrt(pfa * (1 - pfa) / N_FA)
    if method != "windowed":  # the calibrated threshold has its own binomial error
        se = np.hypot(se, np.sqrt(pfa * (1 - pfa) / 100_000))
    assert abs(rate - pfa) < 4 * se
    if method == "windowed":
        assert res.threshold == pytest.approx(gf.parity.chi2_threshold(pfa, 3))


def test_windowed_test_detects_a_bias_the_per_sample_test_misses(pf):
    rng = np.random.default_rng(4)
    N, t0, window, pfa = 6000, 1000, 800, 1e-3
    Z = rng.standard_normal((N, 6)) * pf.sigma
    Z[t0:, 2] += 0.3 * pf.sigma  # a 0.3 sigma bias on sensor 2
    per_sample = pf.diagnose(Z, pfa)
    windowed = pf.diagnose(Z, pfa, method="windowed", window=window)
    full = slice(t0 + window, N)  # window entirely faulty
    assert windowed.detected[full].mean() > 0.9
    assert (windowed.isolated[full] == 2).mean() > 0.8
    assert windowed.detected[:t0].mean() < 0.01
    # the per-sample GLT at the same false-alarm rate sees only its false alarms
    assert per_sample.detected[t0:].mean() < 5 * pfa


def test_sequential_options_are_validated(pf):
    Z = np.zeros((10, 6))
    with pytest.raises(GeomFDIError, match="window"):
        pf.diagnose(Z, method="windowed", window=0)
    with pytest.raises(GeomFDIError, match="shift"):
        pf.diagnose(Z, method="cusum", shift=-1, threshold=1.0)
    with pytest.raises(GeomFDIError, match="Z"):
        pf.diagnose(np.zeros((10, 5)), method="cusum", threshold=1.0)
    with pytest.raises(GeomFDIError, match="method"):
        pf.diagnose(Z, method="ewma")


# ------------------------------------------------------------------ estimation after exclusion
@pytest.mark.parametrize("F", [None, "correlated"])
def test_state_estimate_after_exclusion_has_the_computed_covariance(F):
    rng = np.random.default_rng(21)
    H = gf.parity.dodecahedron()
    Fm = None
    if F == "correlated":
        Fm = np.eye(6) + 0.3 * rng.standard_normal((6, 6))
    pf = gf.ParityFDI(H, sigma=0.05, F=Fm)
    x_true = np.array([0.3, -1.0, 2.0])
    fault = np.zeros(6)
    fault[4] = 3.0
    Z = gf.parity.simulate(pf, 10_000, rng=rng, x=x_true, fault=fault)
    est = pf.estimate_state(Z, exclude=[4])
    err = est.x - x_true
    assert np.abs(err.mean(axis=0)).max() < 4 * np.sqrt(np.diag(est.covariance[0]).max() / 1e4)
    emp = np.cov(err.T)
    P = est.covariance[0]
    assert np.allclose(np.diag(emp), np.diag(P), rtol=0.05)
    assert np.linalg.norm(emp - P) < 0.05 * np.linalg.norm(P)
    # without the exclusion the faulty sensor biases the estimate
    assert np.abs(pf.estimate_state(Z).x.mean(axis=0) - x_true).max() > 0.5
    # the fault size estimate: unbiased, with the computed variance
    fe = pf.estimate_faults(Z, 4)
    assert abs(fe.size.mean() - 3.0) < 4 * np.sqrt(fe.covariance[0, 0] / 1e4)
    assert fe.size.var() == pytest.approx(fe.covariance[0, 0], rel=0.05)


def test_state_estimate_follows_a_diagnosis_sample_by_sample():
    pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=0.01)
    rng = np.random.default_rng(2)
    Z = gf.parity.simulate(pf, 200, rng=rng, x=[1.0, 2.0, 3.0])
    Z[:100, 1] += 1.0
    Z[100:150, 5] -= 1.0
    diag = pf.diagnose(Z, 1e-4)
    est = pf.estimate_state(Z, exclude=diag)
    assert (est.excluded[:100, 0] == 1).all() and (est.excluded[100:150, 0] == 5).all()
    assert np.abs(est.x - [1.0, 2.0, 3.0]).max() < 6 * np.sqrt(est.covariance[:, 0, 0].max())
    full = pf.estimate_state(Z[150:])
    assert full.covariance[0, 0, 0] < est.covariance[0, 0, 0]  # six sensors beat five
    with pytest.raises(GeomFDIError, match="exclude"):
        pf.estimate_state(Z, exclude=[0, 1, 2, 3])


# ------------------------------------------------------------------ configurations, faults, ROC
def test_configurations_from_cosines_and_angles():
    H = gf.parity.dodecahedron()
    assert np.allclose(gf.parity.from_direction_cosines(3 * H), H)
    az = np.degrees(np.arctan2(H[:, 1], H[:, 0]))
    el = np.degrees(np.arcsin(H[:, 2]))
    assert np.allclose(gf.parity.from_angles(az, el, degrees=True), H)
    with pytest.raises(GeomFDIError, match="cosines"):
        gf.parity.from_direction_cosines([[1, 0, 0], [0, 0, 0]])


def test_scale_factor_and_misalignment_faults_are_isolated():
    pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=1e-3)
    rng = np.random.default_rng(9)
    x = rng.standard_normal((500, 3)) * 10.0
    Z0 = x @ pf.H.T + 1e-3 * rng.standard_normal((500, 6))
    sf = gf.parity.scale_factor_fault(pf.H, x, 3, 0.01)
    assert np.allclose(sf[:, 3], 0.01 * x @ pf.H[3]) and not sf[:, [0, 1, 2, 4, 5]].any()
    mis = gf.parity.misalignment_fault(pf.H, x, 1, 0.5, degrees=True)
    # a small rotation changes the reading by about angle * |x_perp|, orthogonal to h_1
    assert np.abs(mis[:, 1]).max() < np.radians(0.5) * np.linalg.norm(x, axis=1).max() * 1.01
    for fault, sensor in ((sf, 3), (mis, 1)):
        res = pf.diagnose(Z0 + fault, 1e-4)
        big = np.abs(fault[:, sensor]) > 0.02
        assert (res.isolated[big] == sensor).mean() > 0.95


def test_roc_curves_order_the_tests_and_match_nominal_rates():
    pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=1.0)
    f = np.zeros(6)
    f[2] = 3.0
    roc = gf.parity.roc_curves(pf, f, 20_000, rng=3, pfa=[1e-3, 1e-2, 1e-1])
    assert np.allclose(roc.pd["glt"], roc.pd["opt"])  # Theorem 4
    assert (np.diff(roc.pd["glt"]) > 0).all()
    # at a realised false-alarm rate the GLT power equals the noncentral chi-square power
    from scipy import stats

    exact = stats.ncx2.sf(stats.chi2.isf([1e-3, 1e-2, 1e-1], 3), 3, 9.0 * 0.5)
    assert np.allclose(roc.pd["glt"], exact, atol=4 * np.sqrt(0.25 / 20_000) + 0.01)
    fig = roc.plot()
    assert len(fig.axes[0].lines) == 3
