"""Fault-to-noise gap of designed generators against an independent frequency sweep."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize

import geomfdi as gf
from geomfdi.generators.norms import UnstableSystemError


def _plant(dt: float, seed: int = 4, unstable: bool = False) -> gf.Plant:
    rng = np.random.default_rng(seed)
    n, q = 3, 3
    M = rng.standard_normal((n, n))
    lam = np.linalg.eigvals(M)
    if dt:
        A = M / (np.max(np.abs(lam)) * (0.5 if unstable else 1.3))
    else:
        A = M - (np.max(lam.real) + (-0.5 if unstable else 0.5)) * np.eye(n)
    return gf.Plant(
        A,
        rng.standard_normal((n, 1)),
        rng.standard_normal((q, n)),
        dt=dt,
        Bw=rng.standard_normal((n, 2)),
        Dw=0.1 * rng.standard_normal((q, 2)),
    )


def _row_response(g, plant, Bx, Dy, w):
    """``R(e^{iω})`` of one generator row by dense solves (independent of geomfdi)."""
    s = np.exp(1j * w * plant.dt) if plant.dt else 1j * w
    n, k = plant.n, g.order
    P = plant.C @ np.linalg.solve(s[:, None, None] * np.eye(n) - plant.A, Bx) + Dy
    Gy = -g.M @ np.linalg.solve(s[:, None, None] * np.eye(k) - g.F, g.E) - g.H
    return Gy @ P


def _gain(g, plant, Bx, Dy):
    return lambda w: np.linalg.norm(_row_response(g, plant, Bx, Dy, w), 2, axis=(1, 2))


def _sweep_peak(fun, dt):
    wmax = np.pi / dt if dt else 1e4
    grid = np.unique(np.concatenate([[0.0], np.geomspace(1e-4, wmax, 3000)]))
    v = fun(grid)
    best = float(v.max())
    peaks = np.flatnonzero((v[1:-1] >= v[:-2]) & (v[1:-1] >= v[2:])) + 1
    for i in peaks[np.argsort(-v[peaks])][:4]:
        res = scipy.optimize.minimize_scalar(
            lambda x: -float(fun(np.array([x]))[0]),
            bounds=(grid[i - 1], grid[i + 1]),
            method="bounded",
            options={"xatol": 1e-13 * grid[i + 1]},
        )
        best = max(best, -float(res.fun))
    return best


@pytest.mark.parametrize("dt", [0.0, 0.2])
@pytest.mark.parametrize("unstable", [False, True])
def test_gap_of_a_bank_matches_an_independent_sweep(dt, unstable):
    plant = _plant(dt, unstable=unstable)
    faults = [gf.SensorFault(i) for i in range(3)]
    S = np.array([[0, 1, 1], [1, 0, 1], [1, 1, 0]], dtype=bool)
    bank = gf.design_bank(plant, faults, S, objective="decoupling")
    res = gf.fault_to_noise_gap(bank, plant)
    assert res.missing == []
    sigs = [f.signatures(plant.n, plant.q) for f in faults]
    for r, g in enumerate(bank.generators):
        gamma = _sweep_peak(_gain(g, plant, plant.Bw, plant.Dw), dt)
        betas = {j: _sweep_peak(_gain(g, plant, *sigs[j]), dt) for j in np.flatnonzero(S[r])}
        beta = min(betas.values())
        assert res.gamma[r] == pytest.approx(gamma, rel=1e-6)
        assert res.noise_gamma[r] == pytest.approx(gamma, rel=1e-6)
        assert res.beta[r] == pytest.approx(beta, rel=1e-6)
        assert res.gap[r] == pytest.approx(beta / gamma, rel=1e-6)
        assert res.weakest[r] == min(betas, key=betas.get)
        assert res.nontarget[r] < 1e-8 * beta  # the exact design decouples the others
    assert res.min_gap == pytest.approx(res.gap.min())


def test_gap_frequencies_and_band_and_no_noise():
    plant = _plant(0.0)
    faults = [gf.SensorFault(i) for i in range(3)]
    S = np.array([[0, 1, 1], [1, 0, 1], [1, 1, 0]], dtype=bool)
    bank = gf.design_bank(plant, faults, S, objective="decoupling")
    w = np.array([0.0, 0.3, 2.0])
    res = gf.fault_to_noise_gap(bank, plant, frequencies=w)
    full = gf.fault_to_noise_gap(bank, plant)
    g = bank.generators[0]
    R = _row_response(g, plant, np.zeros((3, 2)), np.eye(3)[:, 1:], w)  # faults 1 and 2
    assert res.beta[0] == pytest.approx(np.linalg.norm(R, axis=1).min(), rel=1e-10)
    assert np.allclose(res.gamma, full.gamma)  # γ is always the full H∞ norm
    assert np.all(res.beta <= full.beta * (1 + 1e-9))
    band = gf.fault_to_noise_gap(bank, plant, band=(0.1, 5.0))
    assert np.all(band.beta <= full.beta * (1 + 1e-9)) and band.band == (0.1, 5.0)
    quiet = gf.Plant(plant.A, plant.B, plant.C)
    r0 = gf.fault_to_noise_gap(bank, quiet, faults)
    assert np.all(np.isinf(r0.gap)) and np.all(r0.gamma == 0)
    assert np.allclose(r0.beta, full.beta)


def test_gap_of_a_leaking_row_counts_the_leak_as_noise():
    plant = _plant(0.0)
    faults = [gf.SensorFault(i) for i in range(3)]
    g = gf.ResidualGenerator(
        np.zeros((0, 0)), np.zeros((0, 3)), np.zeros((0, 1)), np.zeros((1, 0)),
        [[1.0, 0.5, 0.0]], np.zeros((1, 1)), target=(0,), decoupled=(1, 2),
    )  # fmt: skip
    res = gf.fault_to_noise_gap(g, plant, faults)
    assert res.beta[0] == pytest.approx(1.0) and res.nontarget[0] == pytest.approx(0.5)
    assert res.gamma[0] >= 0.5 and res.gamma[0] >= res.noise_gamma[0]


def test_gap_refuses_an_unstable_generator():
    plant = _plant(0.0)
    g = gf.ResidualGenerator(
        [[1.0]], [[1.0, 0.0, 0.0]], [[0.0]], [[1.0]], np.zeros((1, 3)), np.zeros((1, 1)),
        target=(0,),
    )  # fmt: skip
    with pytest.raises(UnstableSystemError) as exc:
        gf.fault_to_noise_gap(g, plant, [gf.SensorFault(0)])
    assert exc.value.argument == "generator_or_bank"


def test_gap_threshold_energy_and_peak_bounds_hold_in_simulation():
    plant = _plant(0.0)
    faults = [gf.SensorFault(i) for i in range(3)]
    S = np.array([[0, 1, 1], [1, 0, 1], [1, 1, 0]], dtype=bool)
    bank = gf.design_bank(plant, faults, S, objective="decoupling")
    res = gf.fault_to_noise_gap(bank, plant, peak=True)
    delta = 0.2
    en = gf.gap_threshold(res, delta)
    assert np.allclose(en.threshold, res.gamma * delta)
    assert np.allclose(en.min_fault, 2 * delta / res.gap)
    pk = gf.gap_threshold(res, delta, norm="peak")
    assert np.all(pk.threshold >= en.threshold * 0)  # defined for every row
    # peak bound: any noise with |w_j(t)| <= delta keeps |r| below the peak threshold
    t = np.linspace(0, 30, 6001)
    rng = np.random.default_rng(1)
    for _ in range(3):
        w = delta * np.sign(rng.standard_normal((2, 60))).repeat(100, axis=1)[:, : t.size]
        w = np.pad(w, ((0, 0), (0, t.size - w.shape[1])), mode="edge")
        r = gf.simulate(plant, bank, t, w=w).residuals
        assert np.all(np.max(np.abs(r), axis=1) <= pk.threshold * (1 + 1e-6))
    # energy bound: the L2 norm of the residual stays below gamma * ||w||_2
    w = np.vstack([np.sin(res.gamma_frequency[0] * t), np.zeros_like(t)]) * np.exp(-0.05 * t)
    r = gf.simulate(plant, bank, t, w=w).residuals
    l2 = lambda x: np.sqrt(np.trapezoid(x**2, t, axis=-1))  # noqa: E731
    assert np.all(l2(r) <= res.gamma * l2(w[0]) * (1 + 1e-3))
    assert l2(r[0]) >= 0.3 * res.gamma[0] * l2(w[0])  # and is not loose at the peak frequency
    with pytest.raises(gf.errors.GeomFDIError) as exc:
        gf.gap_threshold(gf.fault_to_noise_gap(bank, plant), delta, norm="peak")
    assert exc.value.argument == "gap"


def test_peak_gain_known_values():
    from geomfdi.generators.norms import peak_gain

    assert peak_gain([[-1.0]], [[1.0]], [[1.0]])[0] == pytest.approx(1.0, rel=1e-5)
    assert peak_gain([[-2.0]], [[1.0]], [[1.0]], [[0.5]])[0] == pytest.approx(1.0, rel=1e-5)
    assert peak_gain([[-0.5]], [[1.0]], [[1.0]], dt=0.1)[0] == pytest.approx(2.0, rel=1e-12)
    # e^{-t} sin t: ∫|h| = (1 + e^{-π}) / (2 (1 - e^{-π}))
    exact = (1 + np.exp(-np.pi)) / (2 * (1 - np.exp(-np.pi)))
    assert peak_gain([[-1, 1], [-1, -1]], [[0], [1]], [[1, 0]])[0] == pytest.approx(exact, rel=1e-5)
