"""Scale invariance of the design and a verification that cannot be fooled.

Plants in coordinates ``T = diag(10^k)``, k ∈ [−6, 6], must give the same orders and
structure as unscaled, with leakage below 1e-9 by an independent angle check (numpy
only); ``gf.verify`` must fail every generator built to leak.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_synthesis_least_order import leak_angle

import geomfdi as gf
from geomfdi.model.faults import fault_matrices
from geomfdi.synthesis.build import FD_GAIN_TOL

SEED001 = (
    [[1, 1, 1], [0, 1, 0], [2, 0, 1]],
    [[1, 0, 1], [0, 1, 1], [0, 1, 0]],
    [[0, 1, 0], [0, 0, 1], [1, 0, 2]],
)


def _scaled(p, T):
    Ti = np.linalg.inv(T)
    return gf.Plant(T @ p.A @ Ti, T @ p.B, p.C @ Ti, p.D, Bd=T @ p.Bd, Dd=p.Dd, dt=p.dt)


def _random_plant(seed):
    rng = np.random.default_rng(seed)
    n, q, m = int(rng.integers(2, 7)), int(rng.integers(2, 5)), int(rng.integers(1, 3))
    A = rng.standard_normal((n, n)) / np.sqrt(n)
    p = gf.Plant(
        A,
        rng.standard_normal((n, m)),
        rng.standard_normal((q, n)),
        Bd=rng.standard_normal((n, 1)) if rng.random() < 0.5 else None,
    )
    return p, rng


def _independent_ok(bank, p):
    sigs = fault_matrices(bank.faults, p.n, p.q)
    for r, g in enumerate(bank.generators):
        if g is None:
            continue
        for j, (Bf, Df) in enumerate(sigs):
            if not bank.requested[r, j]:
                assert leak_angle(g, p.A, p.B, p.C, p.D, Bf, Df, False, p.dt) < 1e-9
        assert leak_angle(g, p.A, p.B, p.C, p.D, p.B, p.D, True, p.dt) < 1e-9
        if p.nd:
            assert leak_angle(g, p.A, p.B, p.C, p.D, p.Bd, p.Dd, False, p.dt) < 1e-9


def test_seed001_in_scaled_coordinates():
    p = gf.Plant(*SEED001)
    ref = gf.design_sensor_bank(p)
    for k in (2, 4, 6):
        P = _scaled(p, np.diag([10.0**-k, 1.0, 10.0**k]))
        bank = gf.design_sensor_bank(P)
        assert [g.order for g in bank.generators] == [g.order for g in ref.generators] == [1, 3, 3]
        assert (bank.structure == ref.structure).all()
        _independent_ok(bank, P)
        assert gf.verify(bank, P).ok


@pytest.mark.slow
def test_random_plants_in_scaled_coordinates():
    for seed in range(20):
        p, rng = _random_plant(seed)
        faults = [gf.SensorFault(i) for i in range(p.q)] + [
            gf.ActuatorFault(rng.standard_normal(p.n))
        ]
        S = (rng.random((3, len(faults))) < 0.5).astype(int)
        S[:, 0] = 1
        ref = gf.design_bank(p, faults, S)
        T = np.diag(10.0 ** rng.integers(-6, 7, p.n))
        P = _scaled(p, T)
        bank = gf.design_bank(P, faults, S)
        for g, h in zip(bank.generators, ref.generators, strict=True):
            assert (g is None) == (h is None), seed
            if g is None:
                continue
            # the least order is a property of the plant, not of its coordinates
            assert g.info["least_order"]["order"] == h.info["least_order"]["order"], seed
            if g.order != h.order:  # raised for strength in one only: a borderline verdict
                low = g if "raised_from" not in g.info["least_order"] else h
                high = h if low is g else g
                assert "raised_from" in high.info["least_order"], seed
                dc = min(v["dc"] for v in low.info["target_strength"].values())
                assert FD_GAIN_TOL <= dc < 2 * FD_GAIN_TOL, (seed, dc)
        assert (bank.structure == ref.structure).all(), seed
        _independent_ok(bank, P)


def _planted(g, rng, rel):
    """g with its E (or G, or H) perturbed by ``rel`` of its norm: a generator that leaks."""
    which = rng.integers(0, 3) if g.order else 2
    F, E, G, M, H, K = (x.copy() for x in (g.F, g.E, g.G, g.M, g.H, g.K))
    X = (E, G, H)[which]
    size = max(np.linalg.norm(E), np.linalg.norm(G), np.linalg.norm(H))
    X += rel * size * rng.standard_normal(X.shape)
    return gf.ResidualGenerator(
        F,
        E,
        G,
        M,
        H,
        K,
        dt=g.dt,
        target=g.target,
        decoupled=g.decoupled,
        info={"faults": g.info["faults"]},
    )


def test_verify_fails_planted_leaks():
    rng = np.random.default_rng(1)
    p0 = gf.Plant(*SEED001)
    planted = 0
    for k in (0, 3, 6):
        p = _scaled(p0, np.diag([10.0**-k, 1.0, 10.0**k]))
        for g in gf.design_sensor_bank(p).generators:
            assert gf.verify(g, p).ok
            for rel in (1e-3, 1e-6):
                bad = _planted(g, rng, rel)
                rep = gf.verify(bad, p)
                assert not rep.ok
                planted += 1
    assert planted == 18


def test_verify_rejects_bad_tol():
    p = gf.Plant(*SEED001)
    bank = gf.design_sensor_bank(p)
    for tol in (np.inf, 0.0, -1.0, float("nan"), "abc"):
        with pytest.raises(gf.errors.GeomFDIError, match="tol"):
            gf.verify(bank, p, tol=tol)
