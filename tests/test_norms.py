"""H∞ norm and H₋ index (geomfdi.generators.norms) against independent methods."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.optimize
from threadpoolctl import threadpool_limits

import geomfdi as gf
from geomfdi.errors import GeomFDIError
from geomfdi.generators.norms import UnstableSystemError


def _random_stable(rng, dt):
    n = int(rng.integers(1, 9))
    p, m = int(rng.integers(1, 4)), int(rng.integers(1, 4))
    M = rng.standard_normal((n, n))
    lam = np.linalg.eigvals(M)
    if dt:
        A = M / (np.max(np.abs(lam)) * (1.0 + rng.uniform(0.02, 0.5)))
    else:
        A = M - (np.max(lam.real) + rng.uniform(0.02, 1.0)) * np.eye(n)
    B, C = rng.standard_normal((n, m)), rng.standard_normal((p, n))
    D = rng.standard_normal((p, m)) if rng.uniform() < 0.5 else np.zeros((p, m))
    return A, B, C, D


def _sigma(A, B, C, D, dt, w):
    """σ_max of the frequency response by dense batched solves (independent of geomfdi)."""
    w = np.atleast_1d(w)
    s = np.exp(1j * w * dt) if dt else 1j * w
    n = A.shape[0]
    X = np.linalg.solve(s[:, None, None] * np.eye(n) - A, np.broadcast_to(B, (w.size, *B.shape)))
    return np.linalg.norm(C @ X + D, 2, axis=(1, 2))


def _sweep_norm(A, B, C, D, dt):
    """Dense sweep with the largest local maxima refined by a bounded scalar search."""
    wmax = np.pi / dt if dt else 1e4
    lam = np.linalg.eigvals(A)
    pole_w = np.abs(np.angle(lam)) / dt if dt else np.abs(lam.imag)
    grid = np.unique(
        np.concatenate(
            [[0.0], np.geomspace(1e-4, wmax, 2500), np.linspace(0, min(wmax, 50), 2500), pole_w]
        )
    )
    grid = grid[grid <= wmax]
    v = _sigma(A, B, C, D, dt, grid)
    best = max(float(v.max()), float(np.linalg.norm(D, 2)) if not dt else 0.0)
    peaks = np.flatnonzero((v[1:-1] >= v[:-2]) & (v[1:-1] >= v[2:])) + 1
    for i in peaks[np.argsort(-v[peaks])][:5]:
        res = scipy.optimize.minimize_scalar(
            lambda x: -float(_sigma(A, B, C, D, dt, x)[0]),
            bounds=(grid[i - 1], grid[i + 1]),
            method="bounded",
            options={"xatol": 1e-13 * grid[i + 1]},
        )
        best = max(best, -float(res.fun))
    return best


def _control_norm(A, B, C, D, dt, scale):
    """python-control's scipy method on ``G / scale`` (square-padded: it needs p = m)."""
    import control

    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    k = max(p, m)
    Bp = np.hstack([B, np.zeros((n, k - m))])
    Cp = np.vstack([C, np.zeros((k - p, n))]) / scale
    Dp = np.zeros((k, k))
    Dp[:p, :m] = D / scale
    with warnings.catch_warnings(), threadpool_limits(1):
        warnings.simplefilter("ignore")
        sys = control.ss(A, Bp, Cp, Dp, dt if dt else 0)
        return scale * float(control.norm(sys, "inf", tol=1e-9, print_warning=False))


def _agreement(dt: float, count: int, seed: int) -> tuple[float, float]:
    """Largest relative differences to the sweep and to python-control over ``count``
    random stable systems."""
    rng = np.random.default_rng(seed)
    worst_sweep = worst_control = 0.0
    for _ in range(count):
        A, B, C, D = _random_stable(rng, dt)
        r = gf.hinf_norm(A, B, C, D, dt)
        with threadpool_limits(1):
            ref = _sweep_norm(A, B, C, D, dt)
        ctl = _control_norm(A, B, C, D, dt, ref)
        worst_sweep = max(worst_sweep, abs(r.value - ref) / ref)
        worst_control = max(worst_control, abs(r.value - ctl) / ctl)
        # the reported frequency attains the value
        at = np.linalg.norm(D, 2) if np.isinf(r.frequency) else _sigma(A, B, C, D, dt, r.frequency)
        assert at == pytest.approx(r.value, rel=1e-9)
    return worst_sweep, worst_control


@pytest.mark.slow
@pytest.mark.parametrize("dt", [0.0, 0.1])
def test_hinf_norm_agrees_with_sweep_and_python_control(dt):
    """The acceptance test: 40 random continuous and 40 random discrete systems."""
    worst_sweep, worst_control = _agreement(dt, 40, 2025 if dt else 7)
    assert worst_sweep < 1e-6
    assert worst_control < 1e-6


@pytest.mark.parametrize("dt", [0.0, 0.1])
def test_hinf_norm_agrees_on_a_few_systems(dt):
    worst_sweep, worst_control = _agreement(dt, 6, 99)
    assert worst_sweep < 1e-6 and worst_control < 1e-6


def test_hinf_norm_known_values():
    # 1/(s^2 + 2 zeta s + 1): peak 1 / (2 zeta sqrt(1 - zeta^2)) at sqrt(1 - 2 zeta^2)
    z = 0.05
    r = gf.hinf_norm([[0, 1], [-1, -2 * z]], [[0], [1]], [[1, 0]])
    assert r.value == pytest.approx(1 / (2 * z * np.sqrt(1 - z**2)), rel=1e-12)
    assert r.frequency == pytest.approx(np.sqrt(1 - 2 * z**2), rel=1e-6)
    # feedthrough dominates: (s + 2)/(s + 1) -> peak 2 at 0; (s + 1)/(s + 2) -> 1 at infinity
    assert gf.hinf_norm([[-1.0]], [[1.0]], [[1.0]], [[1.0]]).value == pytest.approx(2.0)
    r = gf.hinf_norm([[-2.0]], [[1.0]], [[-1.0]], [[1.0]])
    assert r.value == pytest.approx(1.0) and np.isinf(r.frequency)
    # discrete 1 / (z - a): peak 1 / (1 - a) at 0, 1 / (1 + a) at pi/dt for a < 0
    assert gf.hinf_norm([[0.5]], [[1.0]], [[1.0]], dt=0.1).value == pytest.approx(2.0)
    r = gf.hinf_norm([[-0.5]], [[1.0]], [[1.0]], dt=0.1)
    assert r.value == pytest.approx(2.0) and r.frequency == pytest.approx(np.pi / 0.1)


def test_hinf_norm_boundary_unstable_and_hidden_modes():
    # pole on the imaginary axis: infinite norm at its frequency
    r = gf.hinf_norm([[0, 2], [-2, 0]], [[0], [1]], [[1, 0]])
    assert np.isinf(r.value) and r.frequency == pytest.approx(2.0)
    assert np.isinf(gf.hinf_norm([[1.0]], [[1.0]], [[1.0]], dt=0.5).value)
    with pytest.raises(UnstableSystemError) as exc:
        gf.hinf_norm([[1.0]], [[1.0]], [[1.0]])
    assert exc.value.argument == "A"
    # an unstable mode that the output does not see does not count
    r = gf.hinf_norm([[1.0, 0], [0, -1.0]], [[1.0], [1.0]], [[0.0, 1.0]])
    assert r.value == pytest.approx(1.0)


def test_hminus_index_definitions():
    rng = np.random.default_rng(3)
    A, B, C, D = _random_stable(rng, 0.0)
    B = rng.standard_normal((A.shape[0], 3))
    D = np.zeros((C.shape[0], 3))
    cols = [gf.hinf_norm(A, B[:, [j]], C, D[:, [j]]).value for j in range(3)]
    r = gf.hminus_index(A, B, C, D)
    assert r.value == pytest.approx(min(cols), rel=1e-12) and r.column == int(np.argmin(cols))
    grp = gf.hminus_index(A, B, C, D, columns=[[0, 1], [2]])
    assert grp.value == pytest.approx(
        min(gf.hinf_norm(A, B[:, :2], C, D[:, :2]).value, cols[2]), rel=1e-12
    )
    # frequency list: the smallest column 2-norm over the listed frequencies
    w = np.array([0.0, 0.5, 3.0])
    s = 1j * w
    G = C @ np.linalg.solve(s[:, None, None] * np.eye(A.shape[0]) - A, B)
    assert gf.hminus_index(A, B, C, D, frequencies=w).value == pytest.approx(
        np.linalg.norm(G, axis=1).min(), rel=1e-10
    )
    sing = gf.hminus_index(A, B, C, D, frequencies=w, measure="singular")
    k = min(G.shape[1], G.shape[2])
    assert sing.value == pytest.approx(np.linalg.svd(G, compute_uv=False)[:, k - 1].min())
    # band: no grid point of a fine independent sweep is below the reported minimum
    band = gf.hminus_index(A, B, C, D, band=(0.1, 10.0))
    fine = np.linspace(0.1, 10.0, 20001)
    Gf = C @ np.linalg.solve(1j * fine[:, None, None] * np.eye(A.shape[0]) - A, B)
    assert band.value <= np.linalg.norm(Gf, axis=1).min() * (1 + 1e-9)
    assert band.value >= np.linalg.norm(Gf, axis=1).min() * (1 - 1e-4)
    with pytest.raises(GeomFDIError) as exc:
        gf.hminus_index(A, B, C, D, band=(2.0, 1.0))
    assert exc.value.argument == "band"


@pytest.mark.parametrize("n", [10, 50])
def test_hinf_norm_is_fast(n):
    import time

    rng = np.random.default_rng(n)
    M = rng.standard_normal((n, n))
    A = M - (np.max(np.linalg.eigvals(M).real) + 0.1) * np.eye(n)
    t0 = time.perf_counter()
    gf.hinf_norm(A, rng.standard_normal((n, 2)), rng.standard_normal((2, n)))
    assert time.perf_counter() - t0 < 2.0
