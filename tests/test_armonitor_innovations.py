"""Synthetic innovation generator (geomfdi.monitoring.innovations) for the AR-model monitor."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError


def test_white_innovations_have_sigma_6_and_no_correlation():
    X = gf.synthetic_innovations(50, n_series=8000, rng=0)
    assert X.shape == (8000, 50)
    # 400000 samples: the sample sd is within 0.5% of 6 m (its sd is 6 / sqrt(2 N) = 0.0067)
    assert X.std() == pytest.approx(6.0, rel=5e-3)
    assert abs(X.mean()) < 0.05
    r1 = np.corrcoef(X[:, :-1].ravel(), X[:, 1:].ravel())[0, 1]
    assert abs(r1) < 0.01


def test_coloured_innovations_are_stationary_from_the_first_sample():
    a = [0.5, -0.3]
    X = gf.synthetic_innovations(6, ar=a, sigma=2.0, n_series=100_000, rng=1)
    # stationary: the same variance at every epoch, including t = 0 (no transient)
    np.testing.assert_allclose(X.std(axis=0), 2.0, rtol=0.01)
    # lag-1 and lag-2 autocorrelations of the AR(2): rho1 = a1 / (1 - a2), rho2 = a1 rho1 + a2
    rho1 = 0.5 / 1.3
    rho2 = 0.5 * rho1 - 0.3
    assert np.corrcoef(X[:, 0], X[:, 1])[0, 1] == pytest.approx(rho1, abs=0.01)
    assert np.corrcoef(X[:, 0], X[:, 2])[0, 1] == pytest.approx(rho2, abs=0.01)


def test_coloured_innovations_follow_the_ar_recursion():
    """e_t - a1 e_{t-1} - a2 e_{t-2} is white with the scaled driving variance."""
    a = np.array([0.5, -0.3])
    x = gf.synthetic_innovations(100_000, ar=a, rng=2)
    w = lfilter(np.concatenate(([1.0], -a)), [1.0], x)[2:]
    assert abs(np.corrcoef(w[:-1], w[1:])[0, 1]) < 0.01
    # var(e) = var(w) * gamma0 with gamma0 = (1 - a2) / ((1 + a2)((1 - a2)^2 - a1^2))
    gamma0 = (1 + 0.3) / ((1 - 0.3) * ((1 + 0.3) ** 2 - 0.25))
    assert w.var() * gamma0 == pytest.approx(36.0, rel=0.02)


def test_fault_profiles_are_exact():
    f = gf.innovation_fault(10, kind="step", size=5, start=3, stop=7, sigma=6.0)
    np.testing.assert_array_equal(f, [0, 0, 0, 30, 30, 30, 30, 0, 0, 0])
    r = gf.innovation_fault(8, kind="ramp", size=2, start=4, sigma=3.0)
    np.testing.assert_allclose(r, [0, 0, 0, 0, 1.5, 3.0, 4.5, 6.0])
    assert not gf.innovation_fault(5, kind="none").any()
    # the generator adds exactly this profile to the same noise
    clean = gf.synthetic_innovations(10, rng=5)
    faulty = gf.synthetic_innovations(10, fault="step", size=5, start=3, stop=7, rng=5)
    np.testing.assert_allclose(faulty - clean, f)
    neg = gf.synthetic_innovations(10, fault="step", size=-5, start=3, rng=5) - clean
    np.testing.assert_allclose(neg[3:], -30.0, rtol=1e-12)
    assert np.all(np.abs(neg[:3]) < 1e-12)


def test_reproducible_with_seed_or_generator():
    a = gf.synthetic_innovations(20, ar=[0.2], rng=7)
    b = gf.synthetic_innovations(20, ar=[0.2], rng=np.random.default_rng(7))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, gf.synthetic_innovations(20, ar=[0.2], rng=8))


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"ar": [1.0]}, "ar"),
        ({"ar": [0.5, 0.6]}, "ar"),
        ({"ar": [[0.1, 0.2]]}, "ar"),
        ({"ar": [np.nan]}, "ar"),
        ({"sigma": 0.0}, "sigma"),
        ({"sigma": -1.0}, "sigma"),
        ({"fault": "spike"}, "fault"),
        ({"fault": "step", "start": 20, "stop": 10}, "start"),
        ({"fault": "step", "stop": 200}, "stop"),
        ({"n_series": 0}, "n_series"),
        ({"size": [1, 2]}, "size"),
    ],
)
def test_bad_generator_arguments(kwargs, argument):
    with pytest.raises(GeomFDIError) as exc:
        gf.synthetic_innovations(100, **kwargs)
    assert exc.value.argument == argument
    assert argument in str(exc.value)


def test_bad_length():
    with pytest.raises(GeomFDIError) as exc:
        gf.synthetic_innovations(0)
    assert exc.value.argument == "n_samples"
    with pytest.raises(ShapeError):
        gf.innovation_fault(5, size=np.ones(2))
