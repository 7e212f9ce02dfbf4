"""Residual evaluation tests: noise covariance, windowed chi-square, CUSUM, GLR."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

import geomfdi as gf
from geomfdi.errors import GeomFDIError
from geomfdi.io.cli import design_all
from geomfdi.io.modelfile import load_model

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def motor():
    spec = load_model(EXAMPLES / "discrete_disturbance.toml")
    return spec, design_all(spec)["full"], gf.Noise(**spec.noise)


@pytest.fixture(scope="module")
def seed001_bank():
    spec = load_model(EXAMPLES / "hou_wen_chen.toml")
    return spec, design_all(spec)["exact"]


def _binomial_ok(count: int, n: int, p: float, k: float = 3.5) -> bool:
    return abs(count - n * p) <= k * np.sqrt(n * p * (1 - p))


# ----------------------------------------------------------------- Imhof
@pytest.mark.parametrize("dof, alpha", [(2, 1e-3), (7, 1e-3), (120, 1e-2)])
def test_imhof_matches_chi2_for_equal_weights(dof, alpha):
    x = chi2.isf(alpha, dof)
    assert gf.weighted_chi2_sf(x, np.ones(dof)) == pytest.approx(alpha, rel=1e-6)
    # a scale of the weights scales the quantile
    assert gf.weighted_chi2_sf(3.0 * x, 3.0 * np.ones(dof)) == pytest.approx(alpha, rel=1e-6)


def test_imhof_matches_monte_carlo_for_unequal_weights():
    w = np.array([3.0, 1.0, 0.5, 0.5, 0.1])
    z = np.random.default_rng(0).standard_normal((400_000, 5)) ** 2 @ w
    for x in (2.0, 8.0, 15.0, 25.0):
        p = gf.weighted_chi2_sf(x, w)
        assert _binomial_ok(int(np.sum(z > x)), z.size // 1, p, k=4.0) or abs(
            np.mean(z > x) - p
        ) < 4 * np.sqrt(p * (1 - p) / z.size)


def test_imhof_rejects_bad_weights():
    with pytest.raises(GeomFDIError, match="weights"):
        gf.weighted_chi2_sf(1.0, [1.0, -1.0])
    with pytest.raises(GeomFDIError, match="weights"):
        gf.weighted_chi2_sf(1.0, [0.0])


# -------------------------------------------------------- noise covariance
def test_noise_model_matches_simulated_covariance(seed001_bank):
    spec, bank = seed001_bank
    noise = gf.Noise(measurement=[0.01, 0.02, 0.005], process=0.05, seed=3)
    t = spec.t[:3001]
    for hold in ("foh", "zoh"):
        b = gf.simulate_batch(
            spec.plant,
            bank,
            t,
            spec.u,
            runs=60,
            noise=noise,
            controller=spec.K,
            x0=spec.x0,
            hold=hold,
        )
        r = b.residuals[:, :, 1500:]
        models = gf.residual_noise_models(
            spec.plant, bank, noise, step=t[1] - t[0], controller=spec.K, hold=hold
        )
        for k, m in enumerate(models):
            assert m.reduced
            var = m.variance()
            # 60 runs x 1500 correlated samples: a few per cent of sampling error
            assert np.mean(r[:, k] ** 2) == pytest.approx(var, rel=0.03), (hold, k)
    # foh and zoh give different covariances (the hold matters, and is modelled)
    v_f = gf.residual_noise_model(
        spec.plant, bank.generators[1], noise, step=0.002, controller=spec.K
    ).variance()
    v_z = gf.residual_noise_model(
        spec.plant, bank.generators[1], noise, step=0.002, controller=spec.K, hold="zoh"
    ).variance()
    assert abs(v_f - v_z) > 0.01 * v_f


def test_noise_model_errors(seed001_bank):
    spec, bank = seed001_bank
    g = bank.generators[0]
    with pytest.raises(GeomFDIError, match="noise"):
        gf.residual_noise_model(spec.plant, g, gf.Noise(), step=0.01)
    with pytest.raises(GeomFDIError, match="step"):
        gf.residual_noise_model(spec.plant, g, gf.Noise(measurement=0.1))
    # open loop, process noise, generator decoupled: still stationary (plant removed)
    m = gf.residual_noise_model(spec.plant, g, gf.Noise(process=0.1), step=0.01)
    assert m.reduced and m.variance() > 0


def test_window_covariance_is_block_toeplitz():
    g = np.random.default_rng(1).standard_normal((4, 2, 2))
    S = gf.window_covariance(g, 3)
    assert S.shape == (6, 6)
    np.testing.assert_array_equal(S[2:4, 0:2], g[1])  # block (1, 0): lag 1
    np.testing.assert_array_equal(S[0:2, 2:4], g[1].T)
    np.testing.assert_array_equal(S[4:6, 0:2], g[2])


def test_windowed_sum_of_squares_against_direct_sums():
    r = np.random.default_rng(2).standard_normal((3, 2, 40))
    S = gf.windowed_sum_of_squares(r, 5)
    for k in (0, 3, 4, 17, 39):
        lo = max(0, k - 4)
        np.testing.assert_allclose(S[..., k], np.sum(r[..., lo : k + 1] ** 2, axis=-1))


# ------------------------------------------- acceptance: analytic chi2 FAR
@pytest.fixture(scope="module")
def motor_windows(motor):
    """2e4 noise-only windows of residual r[3] of the motor bank (two components).

    Independent windows: 100 samples apart, the generator's poles are <= 0.95.
    """
    spec, bank, noise = motor
    L, gap, per_run, runs = 20, 100, 40, 500
    gen = bank.generators[3]
    t = spec.plant.dt * np.arange(gap * (per_run + 1))
    b = gf.simulate_batch(spec.plant, gen, t, spec.u, d=spec.d, runs=runs, noise=noise, x0=spec.x0)
    model = gf.residual_noise_model(spec.plant, gen, noise)
    assert model.n_outputs == 2
    idx = gap * np.arange(1, per_run + 1) + gap - 1
    return model, L, b.residuals, idx


@pytest.mark.parametrize("alpha", [0.01, 0.001])
def test_chi2_threshold_gives_the_requested_false_alarm_rate(motor_windows, alpha):
    model, L, r, idx = motor_windows
    test = gf.ChiSquareTest.design([model], L, alpha)
    S = test.statistic(r)[:, 0, idx]
    n = S.size
    assert n == 20_000
    count = int(np.sum(S > test.thresholds[0]))
    assert _binomial_ok(count, n, alpha), count / n
    # RMS thresholds are the same test
    np.testing.assert_allclose(test.rms_thresholds**2 * L, test.thresholds)
    # Satterthwaite's two-moment approximation is a different (and here a worse) threshold
    sat = gf.ChiSquareTest.design([model], L, alpha, method="satterthwaite")
    assert abs(sat.thresholds[0] - test.thresholds[0]) > 1e-3 * test.thresholds[0]


# ----------------------------------------------------------------- CUSUM
def test_cusum_equals_the_recursion():
    x = np.random.default_rng(3).standard_normal((2, 300)) + 0.3
    g = gf.cusum(x, 0.5, two_sided=False)
    ref = np.zeros_like(x)
    prev = np.zeros(2)
    for k in range(x.shape[1]):
        prev = np.maximum(0.0, prev + x[:, k] - 0.5)
        ref[:, k] = prev
    np.testing.assert_allclose(g, ref, atol=1e-12)
    g2 = gf.cusum(x, 0.5)
    np.testing.assert_allclose(g2, np.maximum(ref, gf.cusum(-x, 0.5, two_sided=False)))


def test_cusum_arl_matches_white_noise_run_lengths():
    rng = np.random.default_rng(4)
    h, nu = 3.0, 0.5
    x = rng.standard_normal((3000, 1500))
    g = gf.cusum(x, nu, two_sided=False)
    hit = g > h
    assert hit.any(axis=1).all()
    rl = np.argmax(hit, axis=1) + 1
    arl = gf.cusum_arl(h, nu)
    assert np.mean(rl) == pytest.approx(arl, rel=0.08)
    # with a shift the run length shrinks to the Siegmund value too
    x1 = rng.standard_normal((3000, 200)) + 1.0
    rl1 = np.argmax(gf.cusum(x1, nu, two_sided=False) > h, axis=1) + 1
    assert np.mean(rl1) == pytest.approx(gf.cusum_arl(h, nu, shift=1.0), rel=0.1)


def _noise_runs(spec, bank, runs, seed, n=1000):
    noise = gf.Noise(measurement=[0.01, 0.02, 0.005], seed=seed)
    t = spec.t[:n]
    b = gf.simulate_batch(
        spec.plant, bank, t, spec.u, runs=runs, noise=noise, controller=spec.K, x0=spec.x0
    )
    return noise, b.residuals


def test_cusum_and_glr_calibrated_false_alarm_rates(seed001_bank):
    """Calibrated on 300 noise-only runs, checked on 300 fresh ones (per-run rate 0.1)."""
    spec, bank = seed001_bank
    noise, cal = _noise_runs(spec, bank, 300, seed=10)
    _, fresh = _noise_runs(spec, bank, 300, seed=11)
    models = gf.residual_noise_models(spec.plant, bank, noise, step=0.002, controller=spec.K)
    cus = gf.CusumTest.design(models, drift=0.5, arl=1e4)
    glr = gf.GLRTest.design(models, window=20, false_alarm_rate=1e-3)
    for test in (cus, glr):
        cal_test = test.calibrated(cal, 0.1)
        alarms = cal_test.alarms(fresh).any(axis=-1)  # (runs, residuals)
        for k in range(alarms.shape[1]):
            assert _binomial_ok(int(alarms[:, k].sum()), 300, 0.1), (test.name, k)


def test_glr_bound_and_definition(seed001_bank):
    spec, bank = seed001_bank
    noise, r = _noise_runs(spec, bank, 100, seed=12)
    models = gf.residual_noise_models(spec.plant, bank, noise, step=0.002, controller=spec.K)
    L, alpha = 30, 2e-3
    test = gf.GLRTest.design(models, L, alpha)
    # the Bonferroni bound holds for the per-sample false-alarm rate
    rate = test.alarms(r[:, :, 200:]).mean(axis=(0, 2))
    assert np.all(rate <= alpha + 4 * np.sqrt(alpha / r[:, :, 200:][:, 0].size))
    # white noise: V_m = m sigma^2 and the statistic is the brute-force maximum
    V = gf.sum_variances(np.r_[2.0, np.zeros(9)], 10)
    np.testing.assert_allclose(V, 2.0 * np.arange(1, 11))
    x = np.random.default_rng(5).standard_normal(60)
    g = gf.glr(x, V)
    k = 45
    ref = max(np.sum(x[k - m + 1 : k + 1]) ** 2 / (2 * V[m - 1]) for m in range(1, 11))
    assert g[k] == pytest.approx(ref)
    with pytest.raises(GeomFDIError, match="scalar"):
        gf.GLRTest.design(
            [
                gf.ResidualNoiseModel(
                    np.eye(1) * 0.5, np.ones((1, 1)), np.ones((2, 1)), np.zeros((2, 1))
                )
            ],
            5,
            0.01,
        )


def test_calibrate_max_needs_enough_runs():
    with pytest.raises(GeomFDIError, match="runs"):
        gf.calibrate_max(np.zeros((10, 1, 5)), 0.01)
