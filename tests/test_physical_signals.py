"""Physical plants: signal names from python-control to generated code, operating points."""

from __future__ import annotations

import shutil

import control
import numpy as np
import pandas as pd
import pytest
from generated_c import compile_c, run_c
from script_loader import load_script

import geomfdi as gf
from geomfdi.data.three_tank import three_tank_model, three_tank_operating_point
from geomfdi.errors import GeomFDIError

CC = shutil.which("cc")
OUTPUTS = ["level 1", "level 2", "level-3 (m)"]  # a name that is no C identifier
INPUTS = ["Q1", "Q2"]
DT = 1.0


def _named_plant():
    lin, _ = three_tank_model()
    h, Q = three_tank_operating_point()
    sysc = control.ss(lin.A, lin.B, lin.C, 0, inputs=INPUTS, outputs=OUTPUTS,
                      states=["h1", "h2", "h3"])  # fmt: skip
    return gf.Plant(sysc.sample(DT), x_op=h, u_op=Q, y_op=h), h, Q


def test_a_python_control_system_is_a_plant_with_its_names():
    plant, h, Q = _named_plant()
    assert plant.outputs == tuple(OUTPUTS) and plant.inputs == tuple(INPUTS)
    assert plant.states == ("h1", "h2", "h3") and plant.named and plant.dt == DT
    np.testing.assert_array_equal(plant.y_op, h)
    assert plant.output_index("level 2") == 1 and plant.input_index("Q2") == 1
    with pytest.raises(GeomFDIError, match="no output named 'level 4'"):
        plant.output_index("level 4")
    unnamed = gf.Plant(control.ss(-np.eye(2), np.eye(2), np.eye(2), 0))
    assert not unnamed.named and unnamed.outputs == ("y0", "y1")
    again = gf.Plant.from_statespace(plant.to_statespace())
    assert again.outputs == plant.outputs and again.inputs == plant.inputs
    with pytest.raises(GeomFDIError, match="repeated names"):
        gf.Plant(-np.eye(2), np.eye(2), np.eye(2), outputs=["a", "a"])


@pytest.mark.skipif(CC is None, reason="no C compiler (cc)")
def test_names_round_trip_from_python_control_to_generated_code(tmp_path, monkeypatch):
    monkeypatch.setenv("GEOMFDI_CACHE_DIR", str(tmp_path / "cache"))
    plant, h, Q = _named_plant()
    faults = [gf.SensorFault(name) for name in OUTPUTS]
    bank = gf.design_bank(plant, faults, 1 - np.eye(3))
    assert [f.name for f in bank.faults] == OUTPUTS
    # a recorded run, written and read back by name, in physical units
    t = np.arange(0.0, 800.0 + DT / 2, DT)
    u = np.vstack([2e-6 * (1 - np.cos(0.02 * t)), 1e-6 * (1 - np.cos(0.01 * t))])
    sim = gf.simulate(plant, bank, t, u, faults=[gf.BiasFault("level 2", start=400.0, bias=0.01)])
    frame = sim.to_frame()
    assert list(frame.columns) == ["t", *OUTPUTS, *INPUTS]
    np.testing.assert_allclose(frame["level 1"].iloc[0], h[0], rtol=1e-3)  # physical level
    frame = frame[["t", "Q2", *OUTPUTS[::-1], "Q1"]]  # any column order: read by name
    frame.to_csv(tmp_path / "run.csv", index=False)
    back = pd.read_csv(tmp_path / "run.csv")
    peak = np.abs(sim.residuals[:, 450:]).max(axis=1)
    assert peak[1] < 1e-9 * peak.max()  # row 1 decouples level 2
    thr = 0.3 * min(peak[0], peak[2])
    res = gf.evaluate(bank, back, threshold=thr, persistence=(2, 3))
    # the same residuals once the recorded start-up ("steady" at the first sample) decays
    np.testing.assert_allclose(res.residuals[:, 100:], sim.residuals[:, 100:], atol=1e-9)
    assert res.alarms[:, 400:].any() and not res.alarms[:, 100:400].any()
    assert res.episodes[0].fault == 1  # level 2
    # the Monitor reads samples by name, physical values
    mon = gf.Monitor(bank, threshold=thr, persistence=(2, 3))
    steps = [mon.step(dict(row)) for row in back.drop(columns="t").to_dict("records")]
    np.testing.assert_array_equal(np.array([s.alarms for s in steps]).T, res.alarms)
    # generated C: names as sanitised identifiers, the operating point subtracted inside
    (c_file, h_file) = sorted(gf.codegen.c(mon, "tank_monitor", tmp_path / "c"), key=str)[:2]
    head = (tmp_path / "c" / "tank_monitor.h").read_text()
    assert "#define TANK_MONITOR_Y_LEVEL_3_M 2" in head
    assert "#define TANK_MONITOR_U_Q2 1" in head and "#define TANK_MONITOR_F_LEVEL_2 1" in head
    lib = compile_c(tmp_path / "c" / "tank_monitor.c", tmp_path)
    Y, U = back[OUTPUTS].to_numpy().T, back[INPUTS].to_numpy().T
    R, Al, iso = run_c(lib, "tank_monitor", Y, U, 3)
    np.testing.assert_array_equal(Al, res.alarms)
    np.testing.assert_array_equal(iso, res.isolated)
    np.testing.assert_allclose(R, res.residuals, atol=1e-12)
    # the compiled Monitor: the same decisions from named samples and from float64
    # vectors in physical units (the operating point subtracted before the C step)
    monc = gf.Monitor(bank, threshold=thr, persistence=(2, 3), backend="c")
    assert monc.backend == "c"
    named = [monc.step(dict(row)).alarms for row in back[[*OUTPUTS, *INPUTS]].to_dict("records")]
    monc.reset()
    vectors = [monc.step(Y[:, k].copy(), U[:, k].copy()).alarms for k in range(Y.shape[1])]
    np.testing.assert_array_equal(np.array(named).T, res.alarms)
    np.testing.assert_array_equal(np.array(vectors).T, res.alarms)
    monc.reset()
    np.testing.assert_array_equal(monc.feed(Y, U).alarms, res.alarms)
    monc.reset()
    fed = monc.feed({name: back[name].to_numpy() for name in [*OUTPUTS, *INPUTS]})
    np.testing.assert_array_equal(fed.isolated, res.isolated)
    # generated Python: the same
    path = gf.codegen.python(mon, "tank_monitor_py", tmp_path / "py")
    mod = load_script(path, "tank_monitor_py")
    assert mod.OUTPUTS == OUTPUTS and mod.Y_LEVEL_3_M == 2
    st = mod.init()
    al = np.array([mod.step(st, Y[:, k], U[:, k])[1] for k in range(Y.shape[1])]).T
    np.testing.assert_array_equal(al, res.alarms)
    # a saved bank keeps names and operating point
    bank.save(tmp_path / "bank.json")
    again = gf.load_bank(tmp_path / "bank.json")
    res2 = gf.evaluate(again, back, threshold=thr, persistence=(2, 3))
    np.testing.assert_array_equal(res2.alarms, res.alarms)


def test_a_physical_gain_fault_equals_the_deviation_form():
    """``GainFault(s, gain=0.9)`` on a plant at ``y_op`` scales the whole reading: the
    residuals are those of the deviation form ``gain=0.9, bias=-0.1 y_op`` on the same
    plant without operating point."""
    lin, faults = three_tank_model()
    h, _ = three_tank_operating_point()
    phys = gf.Plant(lin.A, lin.B, lin.C, y_op=h, outputs=OUTPUTS)
    bank = gf.design_bank(lin, faults[3:], 1 - np.eye(3))
    t = np.linspace(0.0, 600.0, 601)
    u = np.vstack([1e-6 * np.sin(0.01 * t), np.zeros_like(t)])
    dev = gf.simulate(
        lin, bank, t, u, faults=[gf.GainFault(1, start=200, gain=0.9, bias=-0.1 * h[1])]
    )
    got = gf.simulate(phys, bank, t, u, faults=[gf.GainFault("level 2", start=200, gain=0.9)])
    plain = gf.simulate(lin, bank, t, u, faults=[gf.GainFault(1, start=200, gain=0.9)])
    scale = np.abs(dev.residuals).max()
    assert np.abs(got.residuals - dev.residuals).max() <= 1e-10 * scale
    assert np.abs(plain.residuals - dev.residuals).max() > 0.1 * scale  # not the same fault
    # a stuck reading is physical too
    s1 = gf.simulate(phys, bank, t, u, faults=[gf.StuckFault(0, start=200, value=h[0] + 0.01)])
    s0 = gf.simulate(lin, bank, t, u, faults=[gf.StuckFault(0, start=200, value=0.01)])
    np.testing.assert_allclose(s1.residuals, s0.residuals, atol=1e-12)


def test_a_pump_gain_fault_scales_the_physical_flow():
    """``ActuatorGainFault(i, gain=0.8)`` on a plant at ``u_op`` loses 20 % of the whole
    flow: the deviation form is ``gain=0.8, bias=-0.2 u_op``; by name as well."""
    lin, faults = three_tank_model()
    h, Q = three_tank_operating_point()
    phys = gf.Plant(lin.A, lin.B, lin.C, u_op=Q, y_op=h, inputs=INPUTS)
    bank = gf.design_bank(lin, faults[:3], 1 - np.eye(3))
    t = np.linspace(0.0, 600.0, 601)
    dev = gf.ActuatorGainFault(0, start=100, gain=0.8, bias=-0.2 * Q[0])
    ref = gf.simulate(lin, bank, t, faults=[dev])
    got = gf.simulate(phys, bank, t, faults=[gf.ActuatorGainFault("Q1", start=100, gain=0.8)])
    scale = np.abs(ref.residuals).max()
    assert scale > 0 and np.abs(got.residuals - ref.residuals).max() <= 1e-10 * scale
