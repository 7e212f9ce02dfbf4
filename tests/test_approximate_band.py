"""The gap design with a frequency band: β as the H₋ index over the band."""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import DesignError

BAND = (5.0, 20.0)


def _plant():
    """Three sensors of three lags (0.1, 1, 10 rad/s); the fault is strongest at low
    frequency through the slow lag and flat up to 10 rad/s through the fast one, so the
    best single row for the H∞ gap and the best one over the band differ."""
    A = np.diag([-0.1, -1.0, -10.0])
    B = np.array([[1.0], [0.0], [0.0]])
    p = gf.Plant(A, B, np.eye(3), Bw=np.zeros((3, 3)), Dw=0.1 * np.eye(3))
    return p, [gf.ActuatorFault(np.array([1.0, 1.0, 10.0]))]


def test_band_design_beats_the_full_band_design_over_the_band():
    p, faults = _plant()
    full = gf.design_residual_generator(p, faults, [0], residual_dim=1)
    band = gf.design_residual_generator(p, faults, [0], residual_dim=1, band=BAND)
    full_in_band = gf.fault_to_noise_gap(full, p, faults, band=BAND).gap[0]
    band_in_band = gf.fault_to_noise_gap(band, p, faults, band=BAND).gap[0]
    # the two objectives choose different rows here ...
    assert band_in_band > 2.0 * full_in_band
    # ... and each design is the better one for its own objective
    assert (
        gf.fault_to_noise_gap(full, p, faults).gap[0]
        >= (gf.fault_to_noise_gap(band, p, faults).gap[0])
    )
    # the claimed band gap is the independently measured one; γ is the full H∞ norm
    assert band.info["band"] == BAND
    assert band.info["gap"] == pytest.approx(band_in_band, rel=1e-2)
    assert band.info["gamma"] == pytest.approx(
        gf.fault_to_noise_gap(band, p, faults).gamma[0], rel=1e-2
    )
    assert band.info["leak_u"] < 1e-9 * band.info["beta"]
    assert np.all(band.poles.real < 0)


def test_band_in_a_bank_row():
    p, faults = _plant()
    bank = gf.design_bank(p, faults, [[1]], residual_dim=1, band=BAND)
    g = bank.generators[0]
    assert g.info["band"] == BAND
    assert g.info["gap"] == pytest.approx(
        gf.fault_to_noise_gap(g, p, faults, band=BAND).gap[0], rel=1e-2
    )


@pytest.mark.parametrize(
    "kwargs",
    [
        {"band": (20.0, 5.0)},
        {"band": (-1.0, 5.0)},
        {"band": "low"},
        {"band": BAND, "objective": "decoupling"},
    ],
)
def test_bad_band_is_refused_naming_the_argument(kwargs):
    p, faults = _plant()
    with pytest.raises(DesignError) as info:
        gf.design_residual_generator(p, faults, [0], residual_dim=1, **kwargs)
    assert info.value.argument == "band"


def test_band_with_models_is_refused():
    p, faults = _plant()
    with pytest.raises(DesignError) as info:
        gf.design_residual_generator(p, faults, [0], models=[p, p], band=BAND)
    assert info.value.argument == "band"
