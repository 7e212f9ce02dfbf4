"""The post-design checks sized to the row: shared plant frequencies, row-wise resolvents.

A delivered row is checked on the k + 2 frequencies (and random points) of its own scale
plus the plant's n + 2 shared by every row of the bank; these tests plant leaks and blind
targets in rows of a lightly damped chain and show that the checks still refuse them, and
check the factorisations the checks are built on against their definitions.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.linalg

import geomfdi as gf
from geomfdi.generators.gains import (
    Composite,
    PlantFactor,
    _tri_solve_many,
    _tri_solve_rows_many,
    complex_schur,
)
from geomfdi.geometry.staircase import observer_staircase
from geomfdi.model.faults import fault_matrices
from geomfdi.synthesis.build import check_angles
from geomfdi.synthesis.construction import _NumericalDesignError
from geomfdi.synthesis.least_order.rational_basis import (
    output_normal_basis,
    output_normal_rows,
    phase_frequencies,
)


def _chain(N: int = 15, q: int = 4, zeta: float = 0.01) -> gf.Plant:
    """Lightly damped chain, q position sensors, forces on two masses."""
    return gf.mass_spring_chain(N, sensors=q, forces=(N // 3, N - 1), zeta=zeta)


@pytest.fixture(scope="module")
def chain_bank():
    p = _chain()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gf.CloseRankWarning)
        bank = gf.design_sensor_bank(p)
    return p, bank


def _copy(g: gf.ResidualGenerator, **change) -> gf.ResidualGenerator:
    mats = {x: getattr(g, x).copy() for x in "FEGMHK"}
    mats.update(change)
    kw = {"target": g.target, "decoupled": g.decoupled, "info": {"faults": g.info["faults"]}}
    kw.update({k: change.pop(k) for k in ("target", "decoupled") if k in change})
    return gf.ResidualGenerator(*(mats[x] for x in "FEGMHK"), dt=g.dt, **kw)


def test_chain_bank_rows_verified_and_checked_on_the_shared_points(chain_bank):
    p, bank = chain_bank
    rep = gf.verify(bank, p)
    assert rep.ok, rep.details
    factor = PlantFactor(p)
    for g in bank.generators:
        comp = Composite(g, p, factor)
        # the row's own k + 2 frequencies, then the plant's n + 2 (shared)
        assert comp.raw_points.size == g.order + 2 + p.n + 2
        np.testing.assert_array_equal(comp.raw_points[g.order + 2 :], factor.plant_points)
        assert np.unique(np.round(comp.raw_points, 12)).size >= p.n + g.order + 2
        assert comp.points.size == g.order + 2 + p.n + 2


@pytest.mark.parametrize("rel", [1e-3, 1e-6])
def test_planted_leaks_in_a_chain_row_are_refused(chain_bank, rel):
    p, bank = chain_bank
    rng = np.random.default_rng(5)
    sigs = fault_matrices(bank.faults, p.n, p.q)
    factor = PlantFactor(p)
    for g in bank.generators:
        dec = g.decoupled[0]
        size = max(np.linalg.norm(g.E), np.linalg.norm(g.H))
        E = g.E.copy()
        E[:, dec] += rel * size * rng.standard_normal(g.order)  # reads a decoupled sensor
        G = g.G + rel * np.linalg.norm(g.G) * rng.standard_normal(g.G.shape)  # u leaks
        F = g.F + rel * np.linalg.norm(g.F) * rng.standard_normal(g.F.shape)  # u leaks
        for bad, what in ((_copy(g, E=E), "fault"), (_copy(g, G=G), "input"), (_copy(g, F=F), "")):
            rep = gf.verify(bad, p, bank.faults)
            assert not rep.ok
            if what == "fault":
                assert rep.leakage[0, dec] > rep.tol
            if what == "input":
                assert rep.input_leakage[0] > rep.tol
            with pytest.raises(_NumericalDesignError, match="leaks"):
                check_angles(bad, p, sigs, factor, "row")
        check_angles(g, p, sigs, factor, "row")  # the delivered row passes
        assert g.info["leak_angle"] < 1e-9


def test_blind_target_of_a_chain_row_is_flagged(chain_bank):
    p, bank = chain_bank
    g0 = bank.generators[0]
    others = tuple(j for j in range(p.q) if j != 1)
    # row 0's generator declared as the row of sensor 1: blind to it, leaks sensor 0
    wrong = _copy(g0, target=(1,), decoupled=others)
    rep = gf.verify(wrong, p, bank.faults)
    assert not rep.ok
    assert any("does not see fault 1" in d for d in rep.details)
    assert any("leaks fault 0" in d for d in rep.details)


def test_complex_schur_is_a_schur_form():
    rng = np.random.default_rng(0)
    poles = np.concatenate(
        [[-1.0, -0.3], -0.01 + 1j * np.arange(1, 8), -0.01 - 1j * np.arange(1, 8)]
    )
    Lam, _ = output_normal_basis(poles, 0.0)  # quasi-triangular: rotated blocks only
    for A in (rng.standard_normal((60, 60)), Lam, rng.standard_normal((1, 1)), np.zeros((3, 3))):
        T, U = complex_schur(A)
        n = A.shape[0]
        assert np.allclose(np.tril(T, -1), 0)
        np.testing.assert_allclose(U.conj().T @ U, np.eye(n), atol=1e-13)
        np.testing.assert_allclose(U @ T @ U.conj().T, A, atol=1e-12 * max(1, np.linalg.norm(A)))
        ref = scipy.linalg.eigvals(A)
        got = np.diag(T)
        assert np.all(np.min(np.abs(got[:, None] - ref[None, :]), axis=1) < 1e-8)


@pytest.mark.parametrize("n", [7, 75])  # batched LU and blocked back substitution
def test_resolvents_at_many_points_match_dense_solves(n):
    rng = np.random.default_rng(n)
    T, _ = complex_schur(rng.standard_normal((n, n)))
    pts = 1j * rng.uniform(0.1, 3.0, 9) + rng.uniform(-0.2, 0.2, 9)
    X = rng.standard_normal((n, 3))
    L = rng.standard_normal((2, n))
    cols = _tri_solve_many(T, pts, X)
    rows = _tri_solve_rows_many(T, pts, L)
    for i, s in enumerate(pts):
        R = np.linalg.inv(s * np.eye(n) - T)
        np.testing.assert_allclose(cols[i], R @ X, rtol=1e-10, atol=1e-12 * np.abs(R @ X).max())
        np.testing.assert_allclose(rows[i], L @ R, rtol=1e-10, atol=1e-12 * np.abs(L @ R).max())


def test_single_output_staircase_matches_the_general_loop():
    rng = np.random.default_rng(3)
    n, no = 40, 6  # an unobservable part of dimension 6
    A = rng.standard_normal((n, n))
    A[: n - no, n - no :] = 0.0
    c = np.zeros((1, n))
    c[0, : n - no] = rng.standard_normal(n - no)
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    A, c = Q @ A @ Q.T, c @ Q.T
    one = observer_staircase(A, c)
    two = observer_staircase(A, np.vstack([c, 0 * c]))  # same row space: the general loop
    assert one.blocks == [1] * (n - no) == two.blocks
    np.testing.assert_allclose(one.Z.T @ one.Z, np.eye(n), atol=1e-12)
    np.testing.assert_allclose(one.Z.T @ A @ one.Z, one.A, atol=1e-11)
    assert np.abs(one.A[np.triu_indices(n - no, 2)]).max() < 1e-10  # staircase form


@pytest.mark.parametrize("dt", [0.0, 0.1])
def test_phase_frequencies_equispaced_in_phase_and_subsets(dt):
    rng = np.random.default_rng(2)
    w = rng.uniform(0.1, 2.0, 20)
    poles = np.concatenate([-0.002 + 1j * w, -0.002 - 1j * w, [-0.5, -3.0]])
    if dt:
        poles = np.exp(poles * dt)
    pts, wts = phase_frequencies(poles, dt, 6)
    c = (poles - 1) / (poles + 1) if dt else poles
    c = c[c.imag >= 0]
    om = np.tan(np.angle(pts) / 2) if dt else pts.imag
    theta = np.sum(
        np.arctan((om[:, None] - c.imag) / -c.real) + np.arctan((om[:, None] + c.imag) / -c.real),
        axis=1,
    )
    N = pts.size
    np.testing.assert_allclose(theta, np.pi * c.size * (np.arange(N) + 0.5) / N, atol=1e-10)
    sub, _ = phase_frequencies(poles, dt, 6, every=6)
    np.testing.assert_allclose(sub, pts[::6], rtol=1e-12)
    assert np.all(wts > 0)


@pytest.mark.parametrize("dt", [0.0, 0.1])
def test_output_normal_rows_match_the_resolvent_of_the_basis(dt):
    rng = np.random.default_rng(4)
    w = rng.uniform(0.1, 2.0, 12)
    poles = np.concatenate([-0.01 + 1j * w, -0.01 - 1j * w, [-0.5, -3.0, -0.02]])
    if dt:
        poles = np.exp(poles * dt)
    Lam, h = output_normal_basis(poles, dt)
    pts = np.exp(1j * rng.uniform(0.1, 3.0, 20)) if dt else 1j * rng.uniform(0.01, 3.0, 20)
    ref = np.array([h @ np.linalg.inv(z * np.eye(h.size) - Lam) for z in pts])
    got = output_normal_rows(poles, dt, pts)
    np.testing.assert_allclose(got, ref, atol=1e-12 * np.abs(ref).max())
