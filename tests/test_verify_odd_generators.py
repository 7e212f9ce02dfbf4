"""``gf.verify`` reports on any generator it is given, never raising a linear-algebra
error: unstable ones (a pole on an unstable plant pole makes the transfer singular
there), defective, static, huge or vanishing matrices."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import geomfdi as gf

A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]  # eigenvalues 1 and 1 +- sqrt(2): unstable
B = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]
C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]
PLANT = gf.Plant(A, B, C)
GEN = gf.design_sensor_bank(PLANT).generators[0]
N = GEN.order
FAULTS = [gf.SensorFault(i) for i in range(3)]

ODD_F = {
    "pole on the plant pole 1": np.eye(N),
    "unstable, shifted": GEN.F + 5 * np.eye(N),
    "Jordan block at 1": np.eye(N) + np.eye(N, k=1),
    "zero": np.zeros((N, N)),
    "huge": 1e200 * np.eye(N),
    "vanishing": -1e-300 * np.eye(N),
}
ODD_REST = {
    "": {},
    "E = 0": {"E": 0 * GEN.E},
    "zero residual": {"M": 0 * GEN.M, "H": 0 * GEN.H, "K": 0 * GEN.K},
    "huge H": {"H": 1e300 * np.ones_like(GEN.H)},
}


def _odd(F: np.ndarray, rest: dict) -> gf.ResidualGenerator:
    mats = {"F": F, "E": GEN.E, "G": GEN.G, "M": GEN.M, "H": GEN.H, "K": GEN.K, **rest}
    return gf.ResidualGenerator(**mats)


def test_unstable_generator_is_reported_not_raised() -> None:
    """The reported case: a hand-made generator with a pole at the plant's pole 1."""
    g = _odd(np.eye(N), {})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        report = gf.verify(g, PLANT, FAULTS)
    assert not report.ok
    assert not report.stable[0]
    assert any("unstable generator" in d for d in report.details)
    # the measures are still computed: the pole at the plant's unstable pole 1 keeps
    # that mode in the residual (the largest angle), the fault gains are finite
    assert np.isfinite(report.gain).all()
    assert report.unstable_leakage[0] == 1.0


@pytest.mark.parametrize("fname", list(ODD_F))
@pytest.mark.parametrize("rname", list(ODD_REST))
@pytest.mark.parametrize("method", ["points", "krylov"])
def test_odd_generators_give_a_report(fname: str, rname: str, method: str) -> None:
    g = _odd(ODD_F[fname], ODD_REST[rname])
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        report = gf.verify(g, PLANT, FAULTS, method=method)
    unstable = fname in ("pole on the plant pole 1", "unstable, shifted", "Jordan block at 1")
    if unstable or fname == "zero":  # a pole at 0 is not asymptotically stable
        assert not report.stable[0] and not report.ok
    if fname == "huge" or rname == "huge H":
        assert not report.ok  # not verified: stated in the details
        assert report.details
    assert report.ok == (not report.details)


def test_discrete_unstable_generator_is_reported() -> None:
    plant = gf.Plant(np.eye(3) + 0.01 * np.array(A), B, C, dt=0.1)
    g = gf.ResidualGenerator(2 * np.eye(N), GEN.E, GEN.G, GEN.M, GEN.H, GEN.K, dt=0.1)
    report = gf.verify(g, plant, FAULTS)
    assert not report.ok and not report.stable[0]
