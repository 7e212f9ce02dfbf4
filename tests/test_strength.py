"""Strength verdicts that do not depend on units; default poles from the plant's time scale;
per-row poles; ``strength="weak"``."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.synthesis.least_order.poles import plant_scale
from geomfdi.synthesis.strength import reference_sizes


def _tank_rows():
    rows = [r for r in itertools.product([0, 1], repeat=6) if 1 <= sum(r) <= 5]
    return np.array(rows)


def _rescaled_tank(cu: float, cy: np.ndarray):
    """The three-tank with inputs in units of ``cu`` m³/s and level i in units of
    ``1 / cy[i]`` m (the same physical plant)."""
    p, faults = gf.three_tank_model()
    Cy = np.diag(cy)
    p2 = gf.Plant(p.A, p.B * cu, Cy @ p.C)
    f2 = [
        gf.SensorFault(f.i, name=f.name)
        if isinstance(f, gf.SensorFault)
        else gf.ActuatorFault(f.signatures(3, 3)[0][:, 0] * cu, name=f.name)
        for f in faults
    ]
    return p2, f2


def _verdicts(bank):
    return [
        None if g is None else d.startswith("weak")
        for g, d in zip(bank.generators, bank.diagnostics, strict=True)
    ]


@pytest.mark.slow
def test_three_tank_verdicts_do_not_depend_on_units():
    """Same bank with inputs in m³/s, in 1e-4 m³/s and with the levels in mm / cm: the
    same rows, the same weak/strong verdicts (per unit fault, the m³/s model flagged
    every row weak and the 1e-4 m³/s one only a few)."""
    S = _tank_rows()
    p, faults = gf.three_tank_model()
    ref = gf.design_bank(p, faults, S)
    compared = 0
    for cu, cy in ((1e-4, np.ones(3)), (1.0, np.array([1e3, 1e2, 1.0]))):
        p2, f2 = _rescaled_tank(cu, cy)
        bank = gf.design_bank(p2, f2, S)
        assert _verdicts(bank) == _verdicts(ref)
        for g, g2 in zip(ref.generators, bank.generators, strict=True):
            if g is None or g.info["least_order"]["parity_dims"][-1] != 1:
                continue  # a row chosen in a space of several: units may pick another
            compared += 1
            s1, s2 = g.info["target_strength"], g2.info["target_strength"]
            for j in s1:
                assert s2[j]["dc"] == pytest.approx(s1[j]["dc"], rel=1e-4, abs=1e-9)
                assert s2[j]["mid_band"] == pytest.approx(s1[j]["mid_band"], rel=1e-4, abs=1e-9)
    assert compared >= 10
    # no row is weak because of units: a weak verdict means a DC gain below 1 %
    assert sum(v is False for v in _verdicts(ref)) > 0


def test_reference_sizes_follow_the_units():
    p, faults = gf.three_tank_model()
    sigs = [f.signatures(3, 3) for f in faults]
    om = plant_scale(p.A, 0.0)
    s1 = reference_sizes(p, faults, sigs, om)
    p2, f2 = _rescaled_tank(1e-4, np.array([10.0, 1.0, 1.0]))
    s2 = reference_sizes(p2, f2, [f.signatures(3, 3) for f in f2], om)
    # up to one common factor (which no verdict sees): a fault of the new unit is 1e-4
    # of the old one, and sensor 0 is read in units 10 times smaller
    ratio = s2 / (s1 * np.array([1e4, 1e4, 1e4, 10.0, 1.0, 1.0]))
    assert np.allclose(ratio, ratio[0], rtol=1e-9)
    # an explicit size is used as given
    f3 = [*faults[:3], gf.SensorFault(0, size=0.02), *faults[4:]]
    assert reference_sizes(p, f3, sigs, om)[3] == 0.02


def test_explicit_size_decides_the_verdict():
    """A target given a tiny reference size (a fault that small must be detected) is seen
    weakly by a row that sees it strongly at the default size."""
    p, faults = gf.three_tank_model()
    g = gf.design_residual_generator(p, faults, target=[2, 3, 4, 5], decouple=[0, 1])
    dc = g.info["target_strength"][3]["dc"]
    assert dc > 0.01 and g.info["weak_targets"] == []
    small = [*faults[:3], gf.SensorFault(0, size=1e-6 * g.info["reference_sizes"][3]), *faults[4:]]
    g2 = gf.design_residual_generator(p, small, target=[2, 3, 4, 5], decouple=[0, 1])
    assert 3 in g2.info["weak_targets"]


@pytest.mark.parametrize("bad", [0, -1.0, float("nan"), "x"])
def test_size_is_validated(bad):
    for make in (
        lambda: gf.SensorFault(0, size=bad),
        lambda: gf.ActuatorFault([1.0, 0.0], size=bad),
        lambda: gf.Fault([1.0, 0.0], size=bad),
    ):
        with pytest.raises(gf.errors.GeomFDIError) as err:
            make()
        assert err.value.argument == "size"


def test_default_poles_follow_the_plant_time_scale():
    """A slow plant gets slow residual poles: the default spectrum scales with time."""
    p, faults = gf.three_tank_model()
    om = plant_scale(p.A, 0.0)
    lam = np.abs(np.linalg.eigvals(p.A))
    assert lam.min() <= om <= lam.max()  # inside the plant's own time scales
    g = gf.design_residual_generator(p, faults, target=[0], decouple=[1, 2])
    assert np.all(-10 * om <= g.poles.real) and np.all(g.poles.real <= -om / 10)
    fast = gf.Plant(p.A * 1e3, p.B * 1e3, p.C)
    g2 = gf.design_residual_generator(fast, faults, target=[0], decouple=[1, 2])
    assert np.allclose(np.sort(g2.poles.real), 1e3 * np.sort(g.poles.real), rtol=1e-6)
    # a stiff plant (fast actuators, slow rigid body): ω between its slowest and fastest
    ac = gf.flight_actuator_case_study().plant
    mod = np.abs(np.linalg.eigvals(ac.A))
    assert 0.05 * mod.max() < plant_scale(ac.A, 0.0) < mod.max()
    # an unstable plant: never slower than its fastest unstable mode (here 1 + √2, while
    # the geometric mean of |λ| = 1, 1 ± √2 is 1)
    seed = np.array([[1.0, 1, 1], [0, 1, 0], [2, 0, 1]])
    assert plant_scale(seed, 0.0) == pytest.approx(1 + np.sqrt(2))


@pytest.mark.filterwarnings("ignore::geomfdi.errors.IsolabilityWarning")  # two rows: expected
def test_per_row_poles_and_a_list_that_does_not_fit_names_the_row():
    cs = gf.flight_actuator_case_study()
    S = cs.structure[[3, 5]]  # least orders 6 and 4
    six, four = [-1.1, -2.1, -3.1, -4.1, -5.1, -6.1], [-0.7, -1.3, -2.9, -3.7]
    bank = gf.design_bank(cs.plant, cs.faults, S, poles=[six, four])
    assert np.allclose(np.sort(bank.generators[0].poles.real), np.sort(six))
    assert np.allclose(np.sort(bank.generators[1].poles.real), np.sort(four))
    with pytest.raises(gf.errors.DesignError, match="row 1") as err:
        gf.design_bank(cs.plant, cs.faults, S, poles=[six, four[:2]])
    assert err.value.argument == "poles"


def test_strength_option_is_validated():
    p, faults = gf.three_tank_model()
    with pytest.raises(gf.errors.DesignError) as err:
        gf.design_bank(p, faults, [[1, 0, 0, 0, 0, 0]], strength="medium")
    assert err.value.argument == "strength"
