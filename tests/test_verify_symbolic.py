"""verify_symbolic proves the delivered generator: exact conversion, rounding level, row blocks."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import sympy as sp

import geomfdi as gf
from geomfdi.errors import GeomFDIError

A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
B = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]
C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]


@pytest.fixture(scope="module")
def plant():
    return gf.Plant(A, B, C)


@pytest.fixture(scope="module")
def exact_bank(plant):
    return gf.design_sensor_bank(plant)


def test_seed001_delivered_bank_is_proven(plant, exact_bank):
    rep = gf.verify_symbolic(exact_bank, plant)
    assert rep.ok, rep.details
    off = ~np.eye(3, dtype=bool)
    assert np.all(rep.zero[off]) and not np.any(rep.zero[~off])
    # r1 reads only y1 and u: its decoupled entries are structural zeros
    assert rep.structural[0, 1] and rep.structural[0, 2]
    # the others cancel up to rounding, measured exactly and reported
    assert 0 < rep.rounding_level < 1e-12
    assert np.all(rep.leak[off] <= rep.rounding_level)
    assert np.all(rep.leak[~off] > 1e-3)
    assert rep.summary().startswith("proven (rounding-level coefficients")
    # the exact matrices are the delivered floats, converted without rounding
    g = exact_bank.generators[1]
    F_exact = rep.generators[1]["F"]
    assert all(x.is_Rational for x in F_exact)
    assert np.array_equal(np.array(F_exact.tolist(), dtype=float), g.F)
    assert "Exact proof" in rep._repr_latex_()


def test_a_leaking_generator_fails_with_the_leak_shown(plant):
    paper = gf.design_sensor_bank(plant, method="paper", poles=[-2])
    rep = gf.verify_symbolic(paper, plant)
    assert not rep.ok
    assert rep.zero[0, 1] and rep.zero[0, 2]  # r1 of the paper method is exact
    assert not rep.zero[1, 0] and rep.leak[1, 0] > 1e-3
    s = rep.variable
    assert sp.simplify(rep.transfer[1, 0] - s / (s + 2)) == 0  # readable: simple rationals
    assert any("row 1: fault 0 is not decoupled" in d for d in rep.details)
    # a perturbation of one delivered entry is caught as a leak, not as rounding
    g = gf.design_sensor_bank(plant).generators[1]
    bad = gf.ResidualGenerator(g.F, g.E + 1e-6, g.G, g.M, g.H, g.K, target=(1,), decoupled=(0, 2))
    rep = gf.verify_symbolic(bad, plant)
    assert not rep.ok and rep.leak[0, 0] > 1e-9


def _stack(g1, g2, target, decoupled):
    F = scipy.linalg.block_diag(g1.F, g2.F)
    M = scipy.linalg.block_diag(g1.M, g2.M)
    return gf.ResidualGenerator(
        F,
        np.vstack([g1.E, g2.E]),
        np.vstack([g1.G, g2.G]),
        M,
        np.vstack([g1.H, g2.H]),
        np.vstack([g1.K, g2.K]),
        target=target,
        decoupled=decoupled,
    )


def test_vector_residual_judged_by_its_row_block(plant, exact_bank):
    g0, g1 = exact_bank.generators[0], exact_bank.generators[1]
    # one residual with two components: component 0 sees fault 0 only, component 1 fault 1
    vec = _stack(g0, g1, (0, 1), (2,))
    faults = [gf.SensorFault(i) for i in range(3)]
    bank = gf.ResidualBank(
        [vec],
        requested=np.array([[True, True, False]]),
        structure=np.array([[True, True, False]]),
        isolable=np.array([False, False, False]),
        diagnostics=["ok"],
        faults=faults,
    )
    assert gf.verify(bank, plant).ok
    rep = gf.verify_symbolic(bank, plant)
    assert rep.ok, rep.details  # each target is seen by some component
    assert rep.rows == [0, 0]
    assert rep.zero[0, 1] and rep.zero[1, 0]  # ... though not by every component
    # a block that sees a target in no component fails
    bank.requested = np.array([[True, False, True]])
    rep = gf.verify_symbolic(bank, plant)
    assert not rep.ok
    assert any("target fault 2 has a zero transfer" in d for d in rep.details)


def test_size_cap_and_time_limit_are_checked(plant, exact_bank):
    with pytest.raises(GeomFDIError) as info:
        gf.verify_symbolic(exact_bank, plant, max_order=4)
    assert info.value.argument == "max_order"
    assert "max_order = 4" in str(info.value) and "order(generator) = 6" in str(info.value)
    with pytest.raises(GeomFDIError) as info:
        gf.verify_symbolic(exact_bank, plant, time_limit=1e-9)
    assert info.value.argument == "time_limit"
    for bad in (0, -1, float("nan")):
        with pytest.raises(GeomFDIError) as info:
            gf.verify_symbolic(exact_bank, plant, rtol=bad)
        assert info.value.argument == "rtol"


def test_dense_float_plant_is_proven_with_progress(capsys):
    rng = np.random.default_rng(1)
    n = 8
    p = gf.Plant(
        rng.normal(size=(n, n)) - 3 * np.eye(n), rng.normal(size=(n, 2)), rng.normal(size=(3, n))
    )
    bank = gf.design_sensor_bank(p)
    rep = gf.verify_symbolic(bank, p, progress=True)
    assert rep.ok and rep.rounding_level < 1e-12
    assert "exact proof" in capsys.readouterr().err  # progress on stderr
    assert rep.seconds < 30


def test_float_tf_equals_scipy_ss2tf():
    """The numerator/denominator of the readable transfer are those of ``ss2tf`` (bitwise)."""
    import scipy.signal

    from geomfdi.verification.symbolic import _float_tf

    rng = np.random.default_rng(0)
    for n in range(1, 7):
        A = rng.standard_normal((n, n))
        b, c, d = rng.standard_normal(n), rng.standard_normal(n), float(rng.standard_normal())
        num, den = _float_tf(A, b, c, d)
        ref_num, ref_den = scipy.signal.ss2tf(A, b[:, None], c[None, :], np.array([[d]]))
        np.testing.assert_array_equal(num, np.trim_zeros(ref_num[0], "f"))
        np.testing.assert_array_equal(den, ref_den)
    num, den = _float_tf(np.zeros((0, 0)), np.zeros(0), np.zeros(0), 2.0)
    assert num.tolist() == [2.0] and den.tolist() == [1.0]
