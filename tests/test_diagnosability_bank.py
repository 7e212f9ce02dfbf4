"""Diagnosability of designed residual banks (seed 001 plant of Hou, Wen & Chen 2011)."""

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
