"""Single-output rows realised in the orthonormal rational basis (no injection gain)."""

from __future__ import annotations

import numpy as np
import pytest
from test_synthesis_least_order import leak_angle

import geomfdi as gf
from geomfdi.model.faults import fault_matrices
from geomfdi.synthesis.build import _quotient
from geomfdi.synthesis.least_order.injection import mirror_rule
from geomfdi.synthesis.least_order.orthonormal_row import orthonormal_row
from geomfdi.synthesis.least_order.quotient_observer import quotient_observer_row
from geomfdi.synthesis.least_order.rational_basis import output_normal_basis
from geomfdi.synthesis.least_order.search import plant_scale


def _match(a, b):
    """Largest distance of a greedy one-to-one matching of two spectra."""
    b = list(b)
    worst = 0.0
    for x in a:
        j = int(np.argmin([abs(x - y) for y in b]))
        worst = max(worst, abs(x - b.pop(j)))
    return worst


@pytest.mark.parametrize("dt", [0.0, 0.1])
def test_output_normal_basis_gramian_spectrum_and_size(dt):
    rng = np.random.default_rng(5)
    if dt:
        r, th = rng.uniform(0.1, 0.97, 40), rng.uniform(0.05, 3.0, 40)
        pairs = r * np.exp(1j * th)
        real = rng.uniform(-0.95, 0.95, 20)
    else:  # 100 poles clustered near the axis, the case the basis is for
        pairs = -rng.uniform(0.01, 0.3, 40) + 1j * rng.uniform(0.1, 1.0, 40)
        real = -rng.uniform(0.01, 1.0, 20)
    poles = np.concatenate([real, pairs, pairs.conj()])
    rng.shuffle(poles)
    Lam, h = output_normal_basis(poles, dt)
    k = poles.size
    if dt:
        gram = Lam.T @ Lam + np.outer(h, h) - np.eye(k)
    else:
        gram = Lam + Lam.T + np.outer(h, h)
    assert np.linalg.norm(gram) < 1e-13 * k
    assert _match(np.linalg.eigvals(Lam), poles) < 1e-9
    # every entry of the size of the poles, whatever their number and clustering
    assert np.max(np.abs(Lam)) <= 2.0 * max(1.0, np.max(np.abs(poles)))
    assert np.all(np.isreal(Lam)) and np.all(np.isreal(h))


def test_output_normal_basis_repeated_poles_is_a_jordan_chain():
    Lam, h = output_normal_basis(np.array([-1.0, -1.0, -1.0]), 0.0)
    assert np.allclose(np.diag(Lam), -1.0)
    # non-derogatory: (Λ + I) has rank 2, so (Λ, h) is observable with one Jordan block
    assert np.linalg.matrix_rank(Lam + np.eye(3)) == 2
    assert np.linalg.matrix_rank(np.vstack([h, h @ Lam, h @ Lam @ Lam])) == 3


def _dense(n, q, seed, dt=0.0):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) / np.sqrt(n)
    return gf.Plant(A, rng.standard_normal((n, 2)), rng.standard_normal((q, n)), dt=dt)


def _row_quotient(p, i):
    faults = [gf.SensorFault(j) for j in range(p.q)]
    sigs = fault_matrices(faults, p.n, p.q)
    decouple = tuple(j for j in range(p.q) if j != i)
    Qm, _ = _quotient(p, sigs, (i,), decouple, f"row {i}", True)
    return Qm


def _tf(F, E, G, M, H, K, s):
    R = np.linalg.solve(s * np.eye(F.shape[0]) - F, np.hstack([-E, G]))
    return M @ R + np.hstack([-H, K])


def test_orthonormal_row_is_the_quotient_observer_in_other_coordinates():
    # where the Riccati injection is still accurate (k = 16, one output), the two
    # realisations of the single-output row have the same transfer up to scale
    p = _dense(16, 3, 4)
    Qm = _row_quotient(p, 0)
    assert Qm.rho == 1 and Qm.k == 16
    # the spectral radius as scale: the regime where the injection is accurate
    om = float(np.max(np.abs(np.linalg.eigvals(Qm.A0))))
    from geomfdi.synthesis.least_order.search import realise_on_plant

    a = realise_on_plant(
        Qm, orthonormal_row(Qm, p.D, omega=om, dt=0.0, relax=1.0, certificate={}), p.D
    )
    b = realise_on_plant(
        Qm, quotient_observer_row(Qm, omega=om, dt=0.0, relax=1.0, certificate={}), p.D
    )
    assert a["identities"]["orthonormal-basis fit"] < 1e-12
    # the injection realisation has entries ~400: its eigenvalues are good to ~1e-7
    assert _match(np.linalg.eigvals(a["F"]), np.linalg.eigvals(b["F"])) < 1e-6
    for w in (0.05, 0.3, 1.0, 4.0):
        qa = _tf(*(a[x] for x in "FEGMHK"), 1j * w)
        qb = _tf(*(b[x] for x in "FEGMHK"), 1j * w)
        scale = (qb @ qa.conj().T) / (qa @ qa.conj().T)
        assert np.linalg.norm(qb - scale * qa) < 1e-9 * np.linalg.norm(qb)


def test_mirror_rule_targets():
    eig = np.array([0.3 + 1j, 0.3 - 1j, -5.0, 0.0])
    r = mirror_rule(eig, dt=0.0, omega=5.0)
    assert r.moved.tolist() == [True, True, False, True]
    assert np.allclose(r.targets[[0, 1, 3]].real, -2 * r.shift - eig[[0, 1, 3]].real)
    assert np.allclose(r.targets[[0, 1, 3]].imag, eig[[0, 1, 3]].imag)
    assert r.targets[2] == -5.0
    rd = mirror_rule(np.array([1.2, 0.5 + 0.9j, 0.5 - 0.9j, 0.2]), dt=0.1, omega=1.0)
    assert rd.moved.tolist() == [True, True, True, False]
    assert np.all(np.abs(rd.targets) < 1.0)


def _check_bank(p, bank):
    sigs = fault_matrices(bank.faults, p.n, p.q)
    for r, g in enumerate(bank.generators):
        assert g is not None, bank.diagnostics[r]
        lam = np.linalg.eigvals(g.F)
        assert np.all(np.abs(lam) < 1) if p.dt else np.all(lam.real < 0)
        for j, (Bf, Df) in enumerate(sigs):
            if j != r:
                assert leak_angle(g, p.A, p.B, p.C, p.D, Bf, Df, False, p.dt, boundary=True) < 1e-9
            else:
                assert leak_angle(g, p.A, p.B, p.C, p.D, Bf, Df, False, p.dt, boundary=True) > 1e-3
        assert leak_angle(g, p.A, p.B, p.C, p.D, p.B, p.D, True, p.dt, boundary=True) < 1e-9
        assert g.order == p.n == g.info["least_order"]["order"]
        assert g.info["realisation"] == "orthonormal basis"
    assert gf.verify(bank, p).ok


@pytest.mark.parametrize("dt", [0.0, 0.1])
def test_dense_single_sensor_rows_where_the_injection_fails(dt):
    # 60 states read through one sensor, ~30 eigenvalues to move: the Riccati injection
    # has no accurate solution, the orthonormal realisation delivers every row
    p = _dense(60, 4, 60, dt)
    if dt:
        p = gf.Plant(1.1 * p.A, p.B, p.C, dt=dt)
    Qm = _row_quotient(p, 0)
    om = plant_scale(Qm.A0, dt)
    if not dt:
        with pytest.raises(np.linalg.LinAlgError):
            quotient_observer_row(Qm, omega=om, dt=dt, relax=1.0, certificate={})
    bank = gf.design_sensor_bank(p)
    _check_bank(p, bank)


@pytest.mark.slow
def test_dense_sensor_bank_hundred_states():
    p = _dense(100, 20, 100)
    bank = gf.design_sensor_bank(p)
    _check_bank(p, bank)


@pytest.mark.parametrize("dt", [0.0, 0.1])
def test_phase_equispaced_frequencies_make_the_fit_orthogonal(dt):
    # 80 poles clustered as a lightly damped chain's (dense near the top frequency): the
    # weighted sampled basis is orthogonal up to scale (condition ~1), so the coefficients
    # of the fit are as accurate as the data
    from geomfdi.synthesis.least_order.orthonormal_row import POINTS_PER_POLE
    from geomfdi.synthesis.least_order.rational_basis import phase_frequencies as _frequencies

    om = 2 * np.sin(np.arange(1, 41) * np.pi / 81)
    poles = np.concatenate([-0.05 + 1j * om, -0.05 - 1j * om])
    if dt:
        poles = np.exp(0.1 * poles)
    Lam, h = output_normal_basis(poles, dt)
    pts, wts = _frequencies(poles, dt, POINTS_PER_POLE)
    Phi = np.array([np.linalg.solve((s * np.eye(h.size) - Lam).T, h) for s in pts])
    Ar = np.vstack([(Phi * wts[:, None]).real, (Phi * wts[:, None]).imag])
    sv = np.linalg.svd(Ar, compute_uv=False)
    assert sv[0] / sv[-1] < 1.5


def test_high_degree_parity_basis_matches_the_brute_force_least_order(monkeypatch):
    # every degree ≥ 1 through the orthonormal parity basis (as above NU_PF_MAX): on
    # random problems the delivered order is the independent brute-force least order,
    # decoupling holds and every target is seen (check_row's independent checks)
    from test_synthesis_least_order import check_row, random_problem

    import geomfdi.synthesis.least_order.search as lo

    monkeypatch.setattr(lo, "NU_PF_MAX", 0)
    orders, onb = [], 0
    for seed in range(60):
        plant, faults, row = random_problem(seed)
        got = check_row(plant, faults, row)
        if got is not None:
            orders.append(got)
            tgt = [j for j in range(len(faults)) if row[j]]
            g = gf.design_residual_generator(
                plant, faults, tgt, decouple=[j for j in range(len(faults)) if not row[j]]
            )
            onb += g.info["realisation"] == "orthonormal parity basis"
    assert max(orders) >= 2 and onb >= 5


def test_chain_rows_of_high_least_order_are_delivered_at_it():
    # 40-state lightly damped chain, 4 position sensors; a row reading three of them: the
    # observer staircase (blocks 3 × 12, 2, 2) leaves no residual below degree 12, and the
    # degree-12 space (one row) sees every target weakly (gains ~1e-4 of the largest).
    # The partial-fraction basis misses two of them at degree 12 (its gains fall to
    # rounding) and the row came out at 13-14, or as the 40-state quotient observer.
    from test_synthesis_realsize import chain

    p = chain(20, 4)
    faults = [gf.SensorFault(i) for i in range(4)]
    g = gf.design_residual_generator(p, faults, [1, 2, 3], decouple=[0])
    cert = g.info["least_order"]
    assert g.info["realisation"] == "orthonormal parity basis"
    assert g.order == cert["order"] == 12 < g.info["quotient_order"] == 40
    assert cert["parity_dims"][:12] == [0] * 12  # no residual of lower degree at all
    sigs = fault_matrices(faults, p.n, p.q)
    assert leak_angle(g, p.A, p.B, p.C, p.D, *sigs[0], False, 0.0, boundary=True) < 1e-9
    assert leak_angle(g, p.A, p.B, p.C, p.D, p.B, p.D, True, 0.0, boundary=True) < 1e-9
    for j in (1, 2, 3):
        assert leak_angle(g, p.A, p.B, p.C, p.D, *sigs[j], False, 0.0, boundary=True) > 1e-7


def test_basis_fit_by_normal_equations_is_the_least_squares_solution():
    # the fit of a sampled orthonormal basis by its Gram matrix (Cholesky) and, with the
    # factor withheld, by the SVD: both the least-squares solution of numpy's lstsq
    from geomfdi.synthesis.least_order.orthonormal_row import _Basis

    om = 2 * np.sin(np.arange(1, 21) * np.pi / 41)
    poles = np.concatenate([-0.05 + 1j * om, -0.05 - 1j * om, [-0.3]])
    b = _Basis(poles, 0.0)
    _, _, Ar, sv = b.fit
    assert b._chol is not None and sv[0] / sv[-1] < 1.5
    Yr = np.random.default_rng(2).standard_normal((Ar.shape[0], 3))
    ref = np.linalg.lstsq(Ar, Yr, rcond=None)[0]
    got, _ = b.solve(Yr)
    assert np.allclose(got, ref, rtol=1e-12, atol=1e-12)
    b._chol = None  # as for an ill-conditioned basis
    got2, s2 = b.solve(Yr)
    assert np.allclose(got2, ref, rtol=1e-12, atol=1e-12)
    assert np.allclose(s2, sv, rtol=1e-12)
