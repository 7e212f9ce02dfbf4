"""Diagnosability of designed residual banks (the plant of Hou, Wen & Chen 2011)."""

from __future__ import annotations

import doctest

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import GeomFDIError

A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
B = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]
C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]
OFF = ~np.eye(3, dtype=bool)


@pytest.fixture(scope="module")
def plant():
    return gf.Plant(A, B, C)


@pytest.fixture(scope="module")
def tables(plant):
    out = {}
    for method in ("exact", "paper"):
        bank = gf.design_sensor_bank(plant, method=method)
        out[method] = gf.bank_diagnosability(bank, plant, measurement_noise=0.01, dt=0.1, window=40)
    return out


def test_exact_bank_isolates_every_sensor_fault(tables):
    d = tables["exact"]
    assert (d.kl.isolability[OFF] > 0).all()
    # its structure is diagonal: no other sensor fault explains any part of a signature
    assert np.allclose(d.isolable_fraction[OFF], 1.0, atol=1e-9)
    assert (d.probability.isolability[OFF] > 0.5).all()


def test_paper_bank_leak_lowers_the_isolability(tables):
    ex, pa = tables["exact"].isolable_fraction, tables["paper"].isolable_fraction
    # the paper residuals for sensors 2 and 3 leak sensors 1-3: those pairs are confounded
    assert pa[1, 2] < 0.3 and pa[2, 1] < 0.3
    assert (pa[OFF] < ex[OFF] - 1e-6).all()
    # sensor 1's residual is exact in both designs (reads y1 and u only)
    assert pa[0, 1] > 0.5


def test_window_sweep_matches_single_windows(plant):
    bank = gf.design_sensor_bank(plant, method="exact")
    cont = gf.bank_diagnosability(bank, plant, measurement_noise=0.01, dt=0.1, window=20)
    sweep = gf.bank_window_sweep(bank, plant, [10, 20, 40], measurement_noise=0.01, dt=0.1)
    assert sorted(sweep) == [10, 20, 40]
    np.testing.assert_allclose(sweep[20].kl.values, cont.kl.values, rtol=1e-10)
    fd = [sweep[w].kl.detectability[1] for w in (10, 20, 40)]
    assert fd[0] < fd[1] < fd[2]  # longer windows see more of a unit step fault


def test_bank_diagnosability_validates_its_inputs(plant):
    bank = gf.design_sensor_bank(plant, method="exact")
    with pytest.raises(GeomFDIError, match="dt"):
        gf.bank_diagnosability(bank, plant, measurement_noise=0.01)
    with pytest.raises(GeomFDIError, match="measurement_noise"):
        gf.bank_diagnosability(bank, plant, measurement_noise=-1.0, dt=0.1)
    with pytest.raises(GeomFDIError, match="bank"):
        gf.bank_diagnosability("bank", plant, measurement_noise=0.01, dt=0.1)


def test_docstring_example():
    import geomfdi.diagnosability.bank as mod

    res = doctest.testmod(mod, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert res.attempted > 0 and res.failed == 0


@pytest.fixture(scope="module")
def structured(plant):
    out = {}
    for method in ("exact", "paper"):
        bank = gf.design_sensor_bank(plant, method=method)
        for st in ("requested", "achieved"):
            out[method, st] = gf.bank_structured_isolability(
                bank, plant, measurement_noise=0.01, dt=0.1, window=40, structure=st
            )
    return out


def test_exact_bank_isolates_on_its_dedicated_residuals(structured):
    for st in ("requested", "achieved"):
        d = structured["exact", st]
        # residual i is blind to every j != i: FI(i, j) = FD(i) > 0 on it
        assert (d.fi[OFF] > 0).all()
        np.testing.assert_allclose(d.fi[OFF], d.fd[OFF], rtol=1e-9)
        assert all(d.residual_sets[i, j] == (i,) for i in range(3) for j in range(3) if i != j)


def test_paper_bank_leak_annuls_the_isolability_on_the_dedicated_residual(structured):
    ex, req = structured["exact", "requested"], structured["paper", "requested"]
    leak = [(1, 0), (1, 2), (2, 0), (2, 1)]  # r2 and r3 leak the other two sensors
    for i, j in leak:
        # the scalar residual r_i sees f_j through a transfer with a feedthrough: every
        # signature of f_i is a response to some profile of f_j -> FI = 0 < FD
        assert req.fd[i, j] > 1.0 and req.fi[i, j] == 0.0
        assert ex.fi[i, j] > 1.0  # the exact bank keeps these pairs apart
    # r1 is exact in both designs: FI = FD > 0 (a rounding-level route of f2, f3 into r1
    # must not be amplified by the minimisation over all profiles of f_j)
    for j in (1, 2):
        assert req.fi[0, j] > 100 and req.fi[0, j] == pytest.approx(req.fd[0, j], rel=1e-9)
    # with the structure verified on the physical model the leaking pairs have no
    # dedicated residual at all
    ach = structured["paper", "achieved"]
    assert all(ach.residual_sets[i, j] == () and ach.fi[i, j] == 0.0 for i, j in leak)


def test_joint_indices_reflect_information_not_structure(plant, tables):
    # the paper bank (orders 1, 1, 1) is a complete set of parity relations of the
    # three-state plant: its joint residual keeps 3 * 40 - 3 dimensions; the exact bank
    # (orders 1, 3, 3) eliminates the initial state from single sensors and keeps fewer,
    # hence its lower joint FD/FI per unit step fault
    assert tables["paper"].model.residual_dim == 117
    assert tables["exact"].model.residual_dim == 113
    assert (tables["paper"].kl.isolability[OFF] > tables["exact"].kl.isolability[OFF]).all()
    with pytest.raises(GeomFDIError, match="residuals"):
        gf.bank_diagnosability(
            gf.design_sensor_bank(plant, method="mvw"),
            plant,
            measurement_noise=0.01,
            dt=0.1,
            residuals=[1],
        )
    with pytest.raises(GeomFDIError, match="structure"):
        gf.bank_structured_isolability(
            gf.design_sensor_bank(plant), plant, measurement_noise=0.01, dt=0.1, structure="x"
        )


def test_a_bank_that_reads_the_raw_outputs_has_the_plants_own_indices(plant):
    # residual r = y (order 0, not blind to the state): the full plant + bank composite
    # is used; it must equal the window model of the sampled plant with sensor faults
    from types import SimpleNamespace

    from scipy.linalg import expm

    exact = gf.design_sensor_bank(plant)
    raw = SimpleNamespace(
        generators=[
            SimpleNamespace(
                F=np.zeros((0, 0)), E=np.zeros((0, 3)), M=np.zeros((3, 0)), H=-np.eye(3), order=0
            )
        ],
        dt=0.0,
        faults=exact.faults,
        structure=np.ones((1, 3), dtype=bool),
    )
    d = gf.bank_diagnosability(raw, plant, measurement_noise=0.01, dt=0.1, window=12)
    ref = gf.WindowModel(
        expm(np.array(A, float) * 0.1),
        None,
        C,
        Bf=np.zeros((3, 3)),
        Df=np.eye(3),
        Bw=np.zeros((3, 1)),
        Qw=0.0,
        Rv=0.01,
        window=12,
    )
    np.testing.assert_allclose(
        d.kl.values, gf.diagnosability_table(ref, np.ones(12), "kl").values, rtol=1e-8
    )
