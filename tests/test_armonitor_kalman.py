"""Innovations of a steady-state Kalman filter in the loop (filter form)."""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import GeomFDIError

A2 = np.array([[1.0, 1.0], [0.0, 0.95]])
C2 = np.array([[1.0, 0.0]])


def _simulate(A, C, Q, R, N, runs, rng):
    n = A.shape[0]
    x = np.zeros((runs, n))
    ys = np.empty((runs, N, C.shape[0]))
    Lq = np.linalg.cholesky(Q)
    for k in range(N):
        ys[:, k] = x @ C.T + rng.standard_normal((runs, C.shape[0])) * np.sqrt(R)
        x = x @ A.T + rng.standard_normal((runs, n)) @ Lq.T
    return ys


def test_filter_form_matches_a_direct_recursion_and_dlqe():
    rng = np.random.default_rng(0)
    Q = np.diag([0.01, 0.02])
    y = _simulate(A2, C2, Q, 1.0, 50, 1, rng)[0]
    res = gf.monitoring.kalman_innovations(A2, C2, Q, 1.0, y)
    assert np.allclose(res.predictor_gain, A2 @ res.gain)
    xf = np.zeros(2)
    for k in range(50):
        xp = A2 @ xf
        nu = y[k] - C2 @ xp
        assert res.innovations[k] == pytest.approx(nu, abs=1e-10)
        xf = xp + res.gain @ nu


def test_innovations_are_white_with_the_computed_covariance():
    rng = np.random.default_rng(1)
    Q = np.diag([0.01, 0.02])
    y = _simulate(A2, C2, Q, 1.0, 600, 200, rng)
    res = gf.monitoring.kalman_innovations(A2, C2, Q, 1.0, y)
    nu = res.normalized[:, 300:, 0]  # steady state
    assert nu.var() == pytest.approx(1.0, rel=0.03)
    r1 = np.mean(nu[:, 1:] * nu[:, :-1])
    assert abs(r1) < 0.02


def test_step_fault_is_absorbed_by_the_filter():
    rng = np.random.default_rng(2)
    Q, R, b, t0 = np.array([[0.01]]), 1.0, 5.0, 300
    y = _simulate(np.eye(1), np.eye(1), Q, R, 400, 2000, rng)
    y[:, t0:] += b
    res = gf.monitoring.kalman_innovations([[1.0]], [[1.0]], Q, R, y)
    K = float(res.gain[0, 0])
    mean = res.innovations[:, t0:, 0].mean(axis=0)
    j = np.arange(mean.size)
    expected = b * (1 - K) ** j
    se = np.sqrt(res.S[0, 0] / 2000)
    assert np.all(np.abs(mean[:40] - expected[:40]) < 5 * se)
    # the chi-square test of the normalised innovation sees the step only for a while
    chi2 = gf.monitoring.innovation_chi2(res.innovations[..., 0], np.sqrt(res.S[0, 0]), 1e-3)
    assert chi2.alarm[:, t0].mean() > 0.4 and chi2.alarm[:, t0 + 60 :].mean() < 0.01


def test_bad_model_is_a_named_error():
    with pytest.raises(GeomFDIError):
        gf.monitoring.kalman_innovations([[1.0]], [[1.0]], 0.01, 1.0, np.zeros((10, 2)))
