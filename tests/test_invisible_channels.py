"""Channels that cannot reach any output (a fault direction inside ker C and an A-invariant
subspace, an unobservable unstable mode) are decoupled by every generator: their rounding-level
response is never read as a leak."""

from __future__ import annotations

import warnings

import numpy as np

import geomfdi as gf

# A v = 0 and C v = 0 for v = (1, 1): the actuator fault along v never reaches y, and the
# marginal mode λ = 0 along v is unobservable; λ = 3 is observable through y1.
A = np.array([[2.0, -2.0], [-1.0, 1.0]])
B = np.zeros((2, 1))
C = np.array([[0.0, 0.0], [-2.0, 2.0]])
FAULTS = [gf.SensorFault(0), gf.SensorFault(1), gf.ActuatorFault([-1.0, -1.0])]


def _bank():
    plant = gf.Plant(A, B, C)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return plant, gf.design_bank(plant, FAULTS, [[1, 1, 0], [0, 1, 0], [1, 0, 0]])


def test_invisible_fault_is_decoupled_by_the_least_order_rows():
    plant, bank = _bank()
    # delivered (the strength verdict of row 0 depends on the faults' reference sizes)
    assert all(d == "ok" or d.startswith("weak") for d in bank.diagnostics), bank.diagnostics
    assert [g.order for g in bank.generators] == [1, 1, 0]
    assert all(g.info["synthesis"] == "least_order" for g in bank.generators)
    # the rows read y1 through (s − 3)/(s + a): the unstable mode is cancelled
    g = bank.generators[1]
    Gy1 = -(g.M @ np.linalg.solve(3.0 * np.eye(g.order) - g.F, g.E) + g.H)[0, 1]
    assert abs(Gy1) < 1e-9


def test_verify_ignores_unobservable_modes_and_invisible_channels():
    plant, bank = _bank()
    rep = gf.verify(bank, plant, FAULTS)
    assert rep.ok, rep.details
    assert np.all(rep.unstable_leakage < 1e-9)
    # an observable unstable mode that is not cancelled is still reported
    bad = gf.ResidualGenerator(
        [[-1.0]], [[0.0, -1.0]], [[0.0]], [[1.0]], [[0.0, 0.0]], [[0.0]], target=(1,),
        decoupled=(0, 2),
    )  # fmt: skip
    rep = gf.verify(bad, plant, FAULTS)
    assert not rep.ok and rep.unstable_leakage[0] > 0.1
