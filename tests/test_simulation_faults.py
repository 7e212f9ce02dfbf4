"""Every fault kind in simulate / simulate_batch: actuator, general additive, disturbances."""

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import GeomFDIError

A = np.array([[1.0, 1, 1], [0, 1, 0], [2, 0, 1]])
B = np.array([[1.0, 0, 1], [0, 1, 1], [0, 1, 0]])
C = np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 2]])
K = np.array([[5, -1.5, 3], [2, 0, 2], [-2, 2.5, -2]])
T = np.arange(0.0, 8.0, 0.002)
U = np.vstack([np.sin(0.5 * T), np.cos(0.3 * T), 0.2 + 0 * T])
EYE = np.eye(3, dtype=bool)


@pytest.fixture(scope="module")
def plant():
    return gf.Plant(A, B, C)


@pytest.fixture(scope="module")
def actuator_bank(plant):
    faults = [gf.ActuatorFault(B[:, i], name=f"actuator {i}") for i in range(3)]
    return gf.design_bank(plant, faults, EYE)


def test_actuator_fault_bank_isolates_gain_bias_and_stuck_actuators(plant, actuator_bank):
    lists = [
        [gf.ActuatorGainFault(0, start=4.0, gain=0.5)],
        [gf.ActuatorBiasFault(1, start=4.0, bias=0.3)],
        [gf.ActuatorStuckFault(2, start=4.0, value=1.0)],
    ]
    batch = gf.simulate_batch(
        plant, actuator_bank, T, U, faults=lists, x0=[0.1, 0, 0], threshold=0.01, store="all"
    )
    healthy = T < 4.0
    assert np.max(np.abs(batch.residuals[:, :, healthy])) < 1e-9
    for j in range(3):
        (ev,) = batch.events[j]
        assert ev.index == j and ev.outcome == "correct" and ev.isolation_delay < 0.1
        # only the residual of the faulty actuator reacts
        peaks = np.max(np.abs(batch.residuals[j][:, ~healthy]), axis=1)
        assert peaks[j] > 0.03 and np.all(np.delete(peaks, j) < 1e-4 * peaks[j])
    np.testing.assert_array_equal(batch.metrics().confusion[:, :3], np.diag([1, 1, 1]))
    # the bank reads the commanded input; the plant got the faulty one: x from a
    # simulation of the plant with u_0 halved after the onset
    u_applied = U.copy()
    u_applied[0, ~healthy] *= 0.5
    x, _ = gf.simulate_lti(A, B, C, None, u_applied, T, x0=[0.1, 0, 0])
    np.testing.assert_allclose(batch.x[0], x, atol=1e-9)
    np.testing.assert_allclose(batch.u[0], U, atol=0)


def test_stuck_actuator_holds_the_commanded_input_at_onset(plant, actuator_bank):
    res = gf.simulate(plant, actuator_bank, T, U, faults=[gf.ActuatorStuckFault(0, start=4.0)])
    k0 = int(np.searchsorted(T, 4.0))
    phi = gf.ActuatorStuckFault(0, start=4.0).values(T, U)
    np.testing.assert_allclose(phi[0, k0:], U[0, k0] - U[0, k0:], atol=0)
    assert np.max(np.abs(res.residuals[0, k0 + 100 :])) > 1e-3


def test_actuator_bias_works_under_feedback(plant, actuator_bank):
    # (gain and stuck actuators under feedback: tests/test_simulation_feedback.py)
    res = gf.simulate(
        plant,
        actuator_bank,
        T,
        U,
        controller=K,
        threshold=0.01,
        faults=[gf.ActuatorBiasFault(1, start=4.0, bias=0.3)],
    )
    assert np.max(np.abs(res.residuals[:, T < 4.0])) < 1e-9
    assert res.events[0].outcome == "correct" and res.events[0].index == 1


def test_general_fault_bank_isolates_step_ramp_and_function_signals(plant):
    faults = [
        gf.Fault(Bf=[[1.0], [0], [0]], name="leak"),
        gf.Fault(Df=[[0.0], [1], [1]], name="d1"),
    ]
    bank = gf.design_bank(plant, faults, np.eye(2, dtype=bool))
    signals = [
        gf.AdditiveFault(faults[0], start=4.0, size=0.5),
        gf.AdditiveFault(faults[1], start=4.0, size=0.0, slope=0.2),
        gf.AdditiveFault(faults[1], start=4.0, signal=lambda s: 0.3 * np.sin(3 * s)),
    ]
    batch = gf.simulate_batch(
        plant, bank, T, U, controller=K, faults=[[s] for s in signals], threshold=0.01
    )
    assert np.max(np.abs(batch.residuals[:, :, T < 4.0])) < 1e-9
    assert [ev[0].index for ev in batch.events] == [0, 1, 1]
    assert all(ev[0].outcome == "correct" for ev in batch.events)
    # a ramp from zero: the residual grows linearly, so detection takes a while
    assert batch.events[1][0].detection_delay > batch.events[2][0].detection_delay
    # the ramp enters only the readings (Bf = 0): the state is the healthy one and the
    # reading is C x + Df * 0.2 (t - 4) after the onset
    run = gf.simulate(plant, bank, T, U, controller=K, faults=[signals[1]])
    ref = gf.simulate(plant, bank, T, U, controller=K)
    np.testing.assert_allclose(run.x, ref.x, atol=1e-12)
    ramp = np.where(T >= 4.0, 0.2 * (T - 4.0), 0.0)
    np.testing.assert_allclose(run.y_healthy - C @ run.x, np.outer([0, 1, 1], ramp), atol=1e-9)


def test_additive_signal_values_and_validation():
    f = gf.Fault(Bf=np.eye(3)[:, :2], name="two")
    s = gf.AdditiveFault(f, start=1.0, size=[1.0, 2.0], slope=[0.0, 1.0], end=3.0)
    t = np.array([0.0, 1.0, 2.0, 3.0])
    np.testing.assert_allclose(s.values(t, np.zeros((0, 4))), [[0, 1, 1, 0], [0, 2, 3, 0]])
    with pytest.raises(GeomFDIError, match="size"):
        gf.AdditiveFault(f, start=1.0, size=[1.0, 2.0, 3.0])
    with pytest.raises(GeomFDIError, match="fault"):
        gf.AdditiveFault("leak", start=1.0)
    with pytest.raises(GeomFDIError, match="signal"):
        gf.AdditiveFault(f, start=0.0, signal=lambda s: s[:1]).values(t, np.zeros((0, 4)))
    with pytest.raises(TypeError):
        gf.ActuatorGainFault(0, 1.0, 0.5)
    with pytest.raises(GeomFDIError, match="actuator"):
        gf.simulate(
            gf.Plant(A, B, C),
            gf.design_bank(gf.Plant(A, B, C), [gf.SensorFault(0)], [[1]]),
            T[:10],
            faults=[gf.ActuatorBiasFault(5, start=0.0, bias=1.0)],
        )


def test_disturbance_signal_is_rejected_by_decoupled_residuals():
    plant = gf.Plant(A, B, C, Bd=[[0.0], [1.0], [0.0]])
    S = np.array([[0, 1, 1], [1, 0, 1], [1, 1, 0]], dtype=bool)
    bank = gf.design_bank(plant, [gf.SensorFault(i) for i in range(3)], S)
    assert all(g is not None for g in bank.generators)
    d = lambda s: 2.0 * np.sin(2 * s) + 0.5  # noqa: E731
    res = gf.simulate(
        plant,
        bank,
        T,
        U,
        d=d,
        controller=K,
        threshold=0.01,
        faults=[gf.BiasFault(1, start=6.0, bias=0.1)],
    )
    # the disturbance moves the plant (it is not a no-op) ...
    ref = gf.simulate(plant, bank, T, U, controller=K)
    assert np.max(np.abs(res.x - ref.x)) > 0.1
    # ... and no residual sees it, while the sensor fault is isolated
    assert np.max(np.abs(res.residuals[:, T < 6.0])) < 1e-9
    assert res.events[0].outcome == "correct" and res.events[0].index == 1


def test_summary_of_actuator_faults(plant, actuator_bank):
    res = gf.simulate(
        plant,
        actuator_bank,
        T,
        U,
        threshold=0.01,
        faults=[gf.ActuatorBiasFault(1, start=4.0, bias=0.3)],
    )
    (row,) = res.summary_rows()
    assert row["actuator"] == 1 and row["sensor"] is None and row["isolation"] == "correct"
    assert "actuator 1" in res.summary()
    assert res.metrics().isolation["correct"] == 1.0
