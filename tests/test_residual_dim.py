"""Multi-row residuals (``residual_dim=p``) against an independent parity-space reference.

The reference (numpy only) works on the physical model: the degree-ν parity space is the
left null space of ``[O_ν, T_w]`` (see tests/test_synthesis_least_order.py); a row ``v``
acts on y as the polynomial row ``Σ v_i s^i``.  A p-row residual must decouple every
decoupled signal (angle measure), have a stacked transfer of normal rank p, see every
target, and row i must have the least degree at which the parity space holds a row
independent of rows 0 … i−1.  The largest possible p is ``q − rank G_w(s)``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_synthesis_least_order import _toeplitz, assert_decouples, random_problem

import geomfdi as gf
from geomfdi.model.faults import fault_matrices


def _rows_y(g, s):
    """The generator's transfer from y at s (rows = residual components), numpy only."""
    k = g.F.shape[0]
    Gy = -g.H.astype(complex)
    if k:
        Gy = Gy - g.M @ np.linalg.solve(s * np.eye(k) - g.F, g.E)
    return Gy


def _rank(X, tol=1e-8):
    if X.size == 0:
        return 0
    X = X / np.maximum(np.linalg.norm(X, axis=1, keepdims=True), 1e-300)
    s = np.linalg.svd(X, compute_uv=False)
    return int(np.sum(s > tol * max(s[0], 1e-300)))


def _points(count=3, seed=5):
    rng = np.random.default_rng(seed)
    return rng.uniform(0.6, 1.4, count) * np.exp(1j * rng.uniform(0.4, np.pi - 0.4, count))


def parity_y_rows(A, C, Bw, Dw, nu, s):
    """The degree-ν parity rows of the physical model evaluated on y at s (numpy only)."""
    O = np.vstack([C @ np.linalg.matrix_power(A, i) for i in range(nu + 1)])
    X = np.hstack([O, _toeplitz(A, C, Bw, Dw, nu)])
    U, sv, _ = np.linalg.svd(X, full_matrices=True)
    N = U[:, int(np.sum(sv > 1e-9 * max(sv[0] if sv.size else 1.0, 1.0))) :]
    q = C.shape[0]
    powers = np.concatenate([np.full(q, s**i) for i in range(nu + 1)])
    V = (N.T * powers[None, :]).reshape(N.shape[1], nu + 1, q).sum(axis=1)
    return V


def reference_max_rows(plant, Bw, Dw):
    """``q − rank G_w(s)`` at generic points: the number of independent decoupling rows."""
    r = 0
    for s in _points():
        if plant.dt:
            s = 1.0 + 0.5 * s
        Gw = plant.C @ np.linalg.solve(s * np.eye(plant.n) - plant.A, Bw) + Dw
        r = max(r, _rank(Gw.T) if Gw.size else 0)
    return plant.q - r


def check_multirow(plant, faults, row, p=None):
    sig = fault_matrices(faults, plant.n, plant.q)
    tgt = [j for j in range(len(faults)) if row[j]]
    dec = [j for j in range(len(faults)) if not row[j]]
    Bw = np.hstack([plant.Bd] + [sig[j][0] for j in dec])
    Dw = np.hstack([plant.Dd] + [sig[j][1] for j in dec])
    rho = reference_max_rows(plant, Bw, Dw)
    try:
        g1 = gf.design_residual_generator(plant, faults, tgt, decouple=dec)
    except gf.errors.NotIsolableError:
        return None
    p = rho if p is None else p
    if p < 2:
        return None
    g = gf.design_residual_generator(plant, faults, tgt, decouple=dec, residual_dim=p)
    info = g.info
    assert g.n_outputs == p and info["residual_dim"] == p
    assert info["max_residual_dim"] == rho
    orders = info["row_orders"]
    assert orders[0] == g1.order  # row 0 is the scalar least-order row
    assert g.order == info["stacked_order"] <= info["block_order"] == sum(orders)
    lam = np.linalg.eigvals(g.F) if g.order else np.zeros(0)
    assert np.all(np.abs(lam) < 1) if plant.dt else np.all(lam.real < 0)
    # every decoupling holds for the stack (independent angle measure)
    assert_decouples(g, plant, sig, tgt, dec)
    # stacked transfer has normal rank p; row i is least among rows independent of 0..i-1
    pts = _points(seed=11)
    if plant.dt:
        pts = 1.0 + 0.5 * pts
    assert max(_rank(_rows_y(g, s)) for s in pts) == p
    for i in range(1, p):
        prev = [_rows_y(g, s)[:i] for s in pts]
        base = [_rank(P) for P in prev]
        least = None
        for nu in range(plant.n + 2):
            ranks = [
                _rank(np.vstack([P, parity_y_rows(plant.A, plant.C, Bw, Dw, nu, s)]))
                for P, s in zip(prev, pts, strict=True)
            ]
            if any(r > b for r, b in zip(ranks, base, strict=True)):
                least = nu
                break
        assert least == orders[i], (i, orders, least)
    return orders


@pytest.mark.slow
@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_multirow_matches_reference(seed):
    plant, faults, row = random_problem(seed)
    check_multirow(plant, faults, row)


@pytest.mark.slow
def test_some_random_problems_need_several_degrees():
    seen = []
    for seed in range(60):
        out = check_multirow(*random_problem(seed))
        if out is not None:
            seen.append(out)
    assert len(seen) >= 10
    assert any(len(set(o)) > 1 for o in seen)  # rows of different degrees occur


def _plant3():
    return gf.Plant(
        [[1, 1, 1], [0, 1, 0], [2, 0, 1]],
        [[1, 0, 1], [0, 1, 1], [0, 1, 0]],
        [[0, 1, 0], [0, 0, 1], [1, 0, 2]],
    )


def test_triplex_two_static_rows():
    p = gf.Plant([[-1.0]], [[1.0]], np.ones((3, 1)))
    faults = [gf.SensorFault(i) for i in range(3)]
    g = gf.design_residual_generator(p, faults, [0, 1, 2], residual_dim=2)
    assert g.order == 0 and g.info["row_orders"] == [0, 0]
    assert np.allclose(g.H @ p.C, 0, atol=1e-12)
    assert np.linalg.matrix_rank(g.H) == 2
    # the third independent row must read the dynamics: degree 1
    g3 = gf.design_residual_generator(p, faults, [0, 1, 2], residual_dim=3)
    assert g3.info["row_orders"] == [0, 0, 1] and g3.order == 1
    with pytest.raises(gf.errors.DesignError, match="at most 3") as exc:
        gf.design_residual_generator(p, faults, [0, 1, 2], residual_dim=4)
    assert exc.value.argument == "residual_dim"


@pytest.mark.parametrize("bad", [0, -1, 1.5, "2", True, [2]])
def test_residual_dim_validation(bad):
    p = _plant3()
    faults = [gf.SensorFault(i) for i in range(3)]
    with pytest.raises(gf.errors.GeomFDIError) as exc:
        gf.design_residual_generator(p, faults, 0, residual_dim=bad)
    assert exc.value.argument == "residual_dim"


def test_residual_dim_other_methods_refused():
    p = _plant3()
    faults = [gf.SensorFault(i) for i in range(3)]
    for kw in ({"method": "full"}, {"method": "paper", "poles": [-2]}, {"exact": True}):
        with pytest.raises(gf.errors.DesignError) as exc:
            gf.design_residual_generator(p, faults, [0, 1, 2], residual_dim=2, **kw)
        assert exc.value.argument == "residual_dim"
    with pytest.raises(gf.errors.DesignError):
        gf.design_bank(p, faults, np.eye(3), residual_dim=2, exact=True)
    # residual_dim=1 is the scalar design, also for the other methods
    g = gf.design_residual_generator(p, faults, 0, method="full", residual_dim=1)
    assert g.info["synthesis"] == "full"


def test_bank_residual_dim_per_row():
    p = _plant3()
    faults = [gf.SensorFault(i) for i in range(3)]
    S = [[1, 1, 1], [1, 0, 0], [0, 1, 1]]
    bank = gf.design_bank(p, faults, S, residual_dim=[3, 2, None])
    g0, g1, g2 = bank.generators
    assert g0.n_outputs == 3 and g2.n_outputs == 1
    assert g1 is None  # decoupling two sensors of three leaves one row only
    assert "residual_dim" in bank.diagnostics[1] and "at most 1" in bank.diagnostics[1]
    assert bank.diagnostics[0] == "ok"
    rep = gf.verify(bank, p)  # the delivered rows are right, but row 1 is missing
    assert rep.rows_ok and not rep.complete and not rep.ok
    with pytest.raises(gf.errors.DesignError) as exc:
        gf.design_bank(p, faults, S, residual_dim=[2, 2])
    assert exc.value.argument == "residual_dim"
    scalar = gf.design_bank(p, faults, S)
    assert [g.n_outputs for g in scalar.generators] == [1, 1, 1]


def test_user_poles_are_shared_by_the_rows():
    p = _plant3()
    faults = [gf.SensorFault(i) for i in range(3)]
    g = gf.design_residual_generator(p, faults, [0, 1, 2], residual_dim=2, poles=[-1.5, -4])
    assert g.info["row_orders"] == [1, 1]
    assert np.allclose(g.poles, -1.5)  # a row of order ν uses the first ν poles
    assert gf.verify(g, p).ok
    bank = gf.design_bank(p, faults, [[1, 1, 1]], residual_dim=2, poles=[-1.5], common_poles=True)
    assert bank.generators[0].n_outputs == 2 and np.allclose(bank.generators[0].poles, -1.5)
