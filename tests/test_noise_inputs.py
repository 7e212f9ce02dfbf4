"""Noise inputs of the plant: Plant(..., Bw=, Dw=), conversions, model files, simulation."""

from __future__ import annotations

import numpy as np
import pytest
import sympy

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.evaluation.covariance import residual_noise_model
from geomfdi.io.modelfile import parse_model

A = [[0.0, 1.0], [-2.0, -3.0]]
B = [[0.0], [1.0]]
C = [[1.0, 0.0], [0.0, 1.0]]


def _bank(plant):
    faults = [gf.SensorFault(0), gf.SensorFault(1)]
    return gf.design_bank(plant, faults, [[1, 0], [0, 1]], objective="decoupling")


def test_plant_noise_inputs_shapes_and_defaults():
    p = gf.Plant(A, B, C, Bw=[[0.0], [1.0]], Dw=[[0.1], [0.0]])
    assert (p.nw, p.Bw.shape, p.Dw.shape) == (1, (2, 1), (2, 1))
    assert "nw=1" in repr(p)
    q = gf.Plant(A, B, C)
    assert (q.nw, q.Bw.shape, q.Dw.shape) == (0, (2, 0), (2, 0)) and "nw" not in repr(q)
    only_d = gf.Plant(A, B, C, Dw=[[1.0], [0.0]])
    assert only_d.nw == 1 and not np.any(only_d.Bw)
    with pytest.raises(ShapeError) as exc:
        gf.Plant(A, B, C, Bw=[[0.0], [1.0]], Dw=np.zeros((2, 2)))
    assert exc.value.argument == "Dw"
    with pytest.raises(ShapeError) as exc:
        gf.Plant(A, B, C, Bw=np.zeros((3, 1)))
    assert exc.value.argument == "Bw"


def test_statespace_round_trip_and_subs():
    p = gf.Plant(A, B, C, Bd=[[1.0], [0.0]], Bw=[[0.0, 1.0], [1.0, 0.0]], Dw=[[0, 0.1], [0.2, 0]])
    ss = p.to_statespace()
    assert ss.ninputs == 4 and ss.input_labels[-2:] == ["w[0]", "w[1]"]
    back = gf.Plant.from_statespace(ss, n_disturbances=1, n_noise=2)
    for name in ("B", "Bd", "Dd", "Bw", "Dw"):
        assert np.array_equal(getattr(back, name), getattr(p, name)), name
    with pytest.raises(GeomFDIError) as exc:
        gf.Plant.from_statespace(ss, n_disturbances=3, n_noise=2)
    assert exc.value.argument == "n_disturbances"
    k = sympy.Symbol("k", positive=True)
    pp = gf.Plant([[-k]], [[1]], [[1]], Bw=[[k]], Dw=[[2 * k]])
    assert pp.nw == 1 and pp.is_parametric
    num = pp.subs({k: 3})
    assert num.Bw[0, 0] == 3.0 and num.Dw[0, 0] == 6.0


def test_noise_input_signal_is_simulated_like_a_disturbance():
    p = gf.Plant(A, B, C, Bw=[[0.0], [1.0]], Dw=[[0.1], [0.0]])
    bank = _bank(p)
    t = np.linspace(0, 5, 501)
    sig = lambda t: np.sin(2 * t)[None]  # noqa: E731
    r_w = gf.simulate(p, bank, t, w=sig)
    as_d = gf.Plant(A, B, C, Bd=p.Bw, Dd=p.Dw)
    r_d = gf.simulate(as_d, bank, t, d=sig)
    assert np.max(np.abs(r_w.residuals)) > 1e-3  # the bank does not decouple w
    assert np.allclose(r_w.residuals, r_d.residuals, rtol=1e-12, atol=1e-14)
    assert np.max(np.abs(gf.simulate(p, bank, t).residuals)) < 1e-12
    with pytest.raises(GeomFDIError) as exc:
        gf.simulate(as_d, bank, t, w=sig)
    assert exc.value.argument == "w"


def test_random_noise_inputs_match_process_and_measurement_noise():
    # Dw = 0: noise inputs are process noise through Bw (same draws, same seed)
    p = gf.Plant(A, B, C, Bw=[[0.0], [1.0]])
    bank = _bank(p)
    t = np.linspace(0, 5, 501)
    a = gf.simulate(p, bank, t, noise=gf.Noise(inputs=0.3, seed=4))
    b = gf.simulate(p, bank, t, noise=gf.Noise(process=0.3, process_input=p.Bw, seed=4))
    assert np.max(np.abs(a.residuals)) > 1e-4
    assert np.allclose(a.residuals, b.residuals, rtol=1e-12, atol=1e-15)
    # discrete plant, Bw = 0, Dw = I: noise inputs are measurement noise (same draws)
    pd = gf.Plant([[0.5, 0.1], [0.0, 0.3]], B, C, dt=0.1, Dw=np.eye(2))
    bd = _bank(pd)
    td = 0.1 * np.arange(300)
    a = gf.simulate(pd, bd, td, noise=gf.Noise(inputs=[0.1, 0.2], seed=2))
    b = gf.simulate(pd, bd, td, noise=gf.Noise(measurement=[0.1, 0.2], seed=2))
    assert np.allclose(a.residuals, b.residuals, rtol=1e-12, atol=1e-15)
    with pytest.raises(GeomFDIError) as exc:
        gf.simulate(gf.Plant(A, B, C), _bank(gf.Plant(A, B, C)), t, noise=gf.Noise(inputs=0.1))
    assert exc.value.argument == "noise.inputs"


def test_residual_noise_covariance_includes_noise_inputs():
    pw = gf.Plant(A, B, C, Dw=np.eye(2))
    g = _bank(pw).generators[0]
    via_inputs = residual_noise_model(pw, g, gf.Noise(inputs=0.2), step=0.01).variance()
    via_meas = residual_noise_model(pw, g, gf.Noise(measurement=0.2), step=0.01).variance()
    assert via_inputs > 0 and via_inputs == pytest.approx(via_meas, rel=1e-10)


def test_model_file_noise_inputs():
    spec = parse_model(
        {
            "plant": {"A": A, "B": B, "C": C, "Bw": [[0.0], [1.0]], "Dw": [[0.1], [0.0]]},
            "simulation": {"t_end": 1.0, "step": 0.01, "noise": {"inputs": 0.1, "seed": 1}},
        }
    )
    assert spec.plant.nw == 1 and spec.plant.Dw[0, 0] == 0.1
    assert spec.noise["inputs"] == 0.1
    with pytest.raises(GeomFDIError, match="Dw"):
        parse_model({"plant": {"A": A, "C": C, "Bw": [[0.0], [1.0]], "Dw": [[0.1, 0], [0, 0]]}})
    with pytest.raises(GeomFDIError, match="no noise inputs"):
        parse_model(
            {
                "plant": {"A": A, "C": C},
                "simulation": {"t_end": 1.0, "step": 0.01, "noise": {"inputs": 0.1}},
            }
        )


def test_threshold_calibration_on_noise_inputs_alone():
    p = gf.Plant(A, B, C, Bw=[[0.0], [1.0]], Dw=[[0.05], [0.0]])
    bank = _bank(p)
    t = np.linspace(0, 5, 501)
    thr = gf.calibrate_threshold(
        p, bank, t, noise=gf.Noise(inputs=0.1, seed=1), false_alarm_rate=0.05, runs=2
    )
    assert np.all(np.asarray(thr.values) > 0)


def test_random_noise_inputs_under_output_feedback():
    import control

    pd = gf.Plant([[0.5, 0.1], [0.0, 0.3]], B, C, dt=0.1, Dw=np.eye(2))
    bank = _bank(pd)
    K = control.ss([[0.2]], [[0.1, 0.05]], [[-0.3]], [[-0.1, 0.0]], 0.1)
    td = 0.1 * np.arange(300)
    a = gf.simulate(pd, bank, td, noise=gf.Noise(inputs=[0.1, 0.2], seed=2), controller=K)
    b = gf.simulate(pd, bank, td, noise=gf.Noise(measurement=[0.1, 0.2], seed=2), controller=K)
    assert np.max(np.abs(a.residuals)) > 1e-3
    assert np.allclose(a.residuals, b.residuals, rtol=1e-12, atol=1e-15)
    assert np.allclose(a.u, b.u, rtol=1e-12, atol=1e-15)
