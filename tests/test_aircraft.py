"""The 32-state aircraft model: 8 dedicated residuals, gusts decoupled, every row delivered.

Leakage is measured by the test's own angle check (``leak_angle`` of
tests/test_synthesis_least_order.py: numpy only, random points) on the physical model.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_synthesis_least_order import leak_angle

import geomfdi as gf
from geomfdi.data.aircraft import AIRCRAFT_FAULTS, AIRCRAFT_OUTPUTS, AIRCRAFT_STATES
from geomfdi.model.faults import fault_matrices


def test_model_shape_and_scaling():
    p, faults = gf.aircraft_model()
    assert (p.n, p.m, p.q, p.nd, len(faults)) == (32, 6, 14, 3, 8)
    assert len(AIRCRAFT_STATES) == p.n and len(AIRCRAFT_OUTPUTS) == p.q
    assert [f.name for f in faults] == list(AIRCRAFT_FAULTS)
    lam = np.linalg.eigvals(p.A)
    assert np.all(lam.real < 0)  # open-loop stable (slow phugoid and spiral included)
    nz = np.abs(p.A[p.A != 0])
    assert nz.max() / nz.min() > 1e8  # badly scaled, as real models are
    assert np.max(np.abs(lam)) / np.min(np.abs(lam)) > 1e3  # stiff


@pytest.mark.slow
def test_dedicated_bank_decouples_gusts_and_isolates_every_fault():
    p, faults = gf.aircraft_model()
    bank = gf.design_bank(p, faults, np.eye(8, dtype=int))
    sigs = fault_matrices(faults, p.n, p.q)
    args = (p.A, p.B, p.C, p.D)
    for r, g in enumerate(bank.generators):
        assert g is not None, bank.diagnostics[r]
        assert g.info["synthesis"] == "least_order"
        assert np.all(np.linalg.eigvals(g.F).real < 0)
        for j, (Bf, Df) in enumerate(sigs):
            angle = leak_angle(g, *args, Bf, Df, False, 0.0)
            if j == r:
                assert angle > 1e-7, (r, angle)
            else:
                assert angle < 1e-9, (r, j, angle)
        assert leak_angle(g, *args, p.Bd, p.Dd, False, 0.0) < 1e-9
        assert leak_angle(g, *args, p.B, p.D, True, 0.0) < 1e-9
    assert bank.structure.astype(int).tolist() == np.eye(8, dtype=int).tolist()
    assert bank.isolable.all()
    assert gf.verify(bank, p).ok
