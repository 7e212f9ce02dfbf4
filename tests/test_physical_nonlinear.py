"""Nonlinear plants in simulation, and runs that diverge."""

from __future__ import annotations

import pickle

import control
import numpy as np
import pytest

import geomfdi as gf
from geomfdi.data.three_tank import (
    three_tank_model,
    three_tank_operating_point,
    three_tank_system,
)
from geomfdi.errors import GeomFDIError
from geomfdi.evaluation.decision import NO_ALARM


def _unstable(t, x, u, params):
    return x + u[:1]


def _two_sensors(t, x, u, params):
    return np.array([x[0], x[0]])


def _loop():
    """``x' = x + u``, two sensors of ``x``, stabilised by ``u = -2 y0``."""
    sys = control.nlsys(_unstable, _two_sensors, inputs=["u"], outputs=["a", "b"], states=["x"])
    plant = gf.Plant.linearize(sys, [0.0], [0.0])
    bank = gf.design_sensor_bank(plant)
    ctrl = control.ss([], [], [], [[-2.0, 0.0]])
    return sys, plant, bank, ctrl


@pytest.mark.parametrize("nonlinear", [False, True], ids=["linear", "nonlinear"])
def test_a_destabilising_fault_stops_the_run_without_decisions_after_it(nonlinear):
    sys, plant, bank, ctrl = _loop()
    t = np.arange(0.0, 20.0, 0.01)
    u = np.full((1, t.size), 0.1)  # x = 0.1 is the loop's equilibrium: a steady start
    flip = gf.GainFault("a", start=5.0, gain=-1.0)  # the loop now has x' = 3 x
    with pytest.warns(gf.DivergenceWarning, match="diverged"):
        res = gf.simulate(sys if nonlinear else plant, bank, t, u, x0=[0.1], faults=[flip],
                          controller=ctrl, threshold=1e-3)  # fmt: skip
    assert res.info["diverged"] and 5.0 < res.info["diverged_at"] < 15.0
    k = int(np.searchsorted(t, res.info["diverged_at"]))
    assert np.isnan(res.residuals[:, k:]).all()
    assert not res.alarms[:, k:].any() and np.all(res.isolated[k:] == NO_ALARM)
    assert res.alarms[:, 500:k].any()  # detected while it still ran
    assert not res.alarms[:, :500].any()
    healthy = gf.simulate(sys if nonlinear else plant, bank, t, u, x0=[0.1], controller=ctrl)
    assert not healthy.info["diverged"] and np.isfinite(healthy.residuals).all()


def test_the_three_tank_system_pickles_and_linearises_at_its_levels():
    sys = three_tank_system()
    again = pickle.loads(pickle.dumps(sys))
    h, Q = three_tank_operating_point()
    np.testing.assert_allclose(again.dynamics(0.0, h, [*Q, 0.0]), 0.0, atol=1e-15)
    lin = gf.Plant.linearize(again, h, [*Q, 0.0])
    assert lin.inputs == ("Q1", "Q2", "leak") and np.allclose(lin.y_op, h)


def _linear_tanks():
    """The nonlinear three-tank system, its levels at rest, its linearisation (pumps and
    leak as inputs) and the linear plant of the pumps alone at that operating point."""
    sys = three_tank_system()
    h, Q = three_tank_operating_point()
    lin = gf.Plant.linearize(sys, h, [*Q, 0.0])
    plant = gf.Plant(lin.A, lin.B[:, :2], lin.C, inputs=lin.inputs[:2], outputs=lin.outputs,
                     x_op=h, u_op=Q, y_op=h)  # fmt: skip
    return sys, h, lin, plant


def test_a_nonlinear_leak_matches_the_linear_simulation_for_a_small_leak():
    sys, h, lin, plant = _linear_tanks()
    leak = gf.ActuatorFault(lin.B[:, 2], name="leak")
    faults = [gf.ActuatorFault(plant.B[:, 0], name="pump 1"), leak]
    bank = gf.design_bank(plant, faults, [[0, 1], [1, 0]])
    t = np.arange(0.0, 600.0, 1.0)
    kw = {"threshold": 1e-4, "persistence": (3, 5)}
    small = gf.AdditiveFault(leak, start=200.0, size=1e-7)
    res = gf.simulate(sys, bank, t, faults=[small], **kw)
    by_input = gf.simulate(sys, bank, t, d={"leak": lambda s: 1e-7 * (s >= 200.0)}, **kw)
    ref = gf.simulate(plant, bank, t, faults=[small], **kw)
    assert not res.info["diverged"]
    np.testing.assert_allclose(res.residuals, by_input.residuals, atol=1e-12)
    scale = np.abs(ref.residuals).max()
    assert np.abs(res.residuals - ref.residuals).max() < 0.05 * scale  # linear regime
    np.testing.assert_allclose(res.y[:, 0], h, atol=1e-12)  # physical levels, at rest
    assert res.events[0].index == 1


@pytest.mark.slow
def test_the_nonlinear_three_tank_example_runs(tmp_path):
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "three_tank_nonlinear.py"
    spec = importlib.util.spec_from_file_location("three_tank_nonlinear", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    rows = mod.main(str(tmp_path), 1)
    big = {r[1]: r for r in rows if r[0] == 1e-5}
    assert big["nonlinear"][2] == 1.0 and big["linear"][2] == 1.0  # detected
    assert abs(big["nonlinear"][5] - big["linear"][5]) < 10.0  # isolation delays close
    for name in ("leak_nonlinear_residuals.png", "pump_nonlinear_residuals.png", "campaign.png"):
        assert (tmp_path / name).stat().st_size > 5000


def test_a_campaign_marks_runs_that_diverge():
    _, plant, bank, ctrl = _loop()
    t = np.arange(0.0, 20.0, 0.01)
    camp = gf.Campaign(
        plant,
        bank,
        [gf.Scenario.sensor("gain", 0, sizes=[0.0, -2.0], onsets=[5.0])],  # gain 1 and -1
        gf.Noise(measurement=1e-4, seed=1),
        t=t,
        runs=2,
        test=gf.AbsTest(np.full(2, 1e-3)),
        u=np.full((1, t.size), 0.1),
        x0=[0.1],
        controller=ctrl,
        detection_window=4.0,
    )
    with pytest.warns(gf.DivergenceWarning, match="2 of 4 runs diverged"):
        res = camp.run()
    bank_rows = res.table[res.table["residual"] == "bank"]
    flipped = bank_rows["size"] == -2.0
    assert (
        bank_rows.loc[flipped, "diverged"].all() and not bank_rows.loc[~flipped, "diverged"].any()
    )
    assert bank_rows.loc[flipped, "detected"].all()  # detected before it diverged


def test_cut_divergent_zeroes_the_statistic_from_the_first_bad_sample():
    from geomfdi.campaign.runner import cut_divergent

    stat = np.ones((3, 2, 6))
    stat[1, 0, 3] = 5e6  # beyond 1e6 thresholds
    stat[2, 1, 4] = np.nan
    out, div = cut_divergent(stat, [1.0, 1.0])
    assert div.tolist() == [False, True, True]
    assert np.all(out[0] == 1) and np.all(out[1, :, 3:] == 0) and np.all(out[1, :, :3] == 1)
    assert np.all(out[2, :, 4:] == 0) and np.all(out[2, :, :4] == 1)


@pytest.mark.parametrize("seed", range(6))
def test_cut_divergent_equals_its_element_wise_definition(seed):
    """The quick check for no divergence and the element-wise cut agree on statistics
    with and without infinities, nan, negative values, huge values and infinite
    thresholds (a residual that never alarms)."""
    from geomfdi.campaign.runner import DIVERGED_RATIO, cut_divergent

    rng = np.random.default_rng(seed)
    stat = rng.standard_normal((5, 3, 40)) * 10 ** rng.uniform(0, 7 if seed else 3, (5, 3, 1))
    if seed % 2:
        stat[rng.integers(5), rng.integers(3), rng.integers(40)] = [np.inf, -np.inf, np.nan][
            seed % 3
        ]
    thr = np.array([1.0, 2.0, np.inf if seed > 2 else 3.0])
    lim = np.where(np.isfinite(thr), DIVERGED_RATIO * thr, np.inf)[:, None]
    bad = (~np.isfinite(stat) | (np.abs(stat) > lim)).any(axis=1)
    first = np.where(bad.any(-1), np.argmax(bad, -1), 40)
    want = np.where(np.arange(40)[None, None, :] >= first[:, None, None], 0.0, stat)
    out, div = cut_divergent(stat, thr)
    np.testing.assert_array_equal(div, bad.any(-1))
    np.testing.assert_array_equal(out, want)


def _leak_faults(size, onset):
    _, faults = three_tank_model()
    return [gf.AdditiveFault(faults[2], start=onset, size=size)]


def test_a_campaign_over_the_nonlinear_three_tank_system():
    sys, _, _, plant = _linear_tanks()
    _, tank_faults = three_tank_model()
    bank = gf.design_bank(plant, [tank_faults[0], tank_faults[2]], [[0, 1], [1, 0]])
    t = np.arange(0.0, 400.0, 1.0)
    args = ([gf.Scenario("leak", _leak_faults, sizes=[0.0, 1e-5], onsets=[150.0])],
            gf.Noise(measurement=1e-4, seed=5))  # fmt: skip
    kw = {"t": t, "runs": 2, "test": gf.AbsTest(np.full(2, 2e-5)), "detection_window": 200.0}
    camp = gf.Campaign(sys, bank, *args, **kw)
    pickle.dumps(camp._job())  # ships to process and Dask workers
    res = camp.run()
    tb = res.table[res.table["residual"] == "bank"]
    assert tb.loc[tb["size"] > 0, "detected"].all() and not tb["diverged"].any()
    one = gf.simulate(sys, bank, t, faults=_leak_faults(1e-5, 150.0), threshold=2e-5)
    assert one.events[0].detection_delay is not None
    assert tb.loc[tb["size"] > 0, "delay"].max() < 30.0
    with pytest.raises(GeomFDIError, match="uncertainty"):
        gf.Campaign(sys, bank, *args, **kw, uncertainty=gf.Uncertainty(relative=0.01, samples=2))
