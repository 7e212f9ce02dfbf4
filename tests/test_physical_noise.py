"""Physical plants with noise inputs: names and operating point together with ``Bw``, ``Dw``."""

from __future__ import annotations

import control
import numpy as np
import pytest
import sympy

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.io.modelfile import parse_model

A = [[-1.0, 0.5], [0.0, -2.0]]
BALL = [[1.0, 0.0, 0.3, 0.1], [0.0, 1.0, 0.0, 0.2]]  # [u (2); d (1); w (1)]
DALL = [[0.0, 0.0, 0.0, 0.05], [0.0, 0.0, 0.1, 0.0]]
C = [[1.0, 0.0], [0.0, 1.0]]


def _named_sys():
    return control.ss(A, BALL, C, DALL, inputs=["Q1", "Q2", "gust", "jitter"],
                      outputs=["level 1", "level 2"], states=["h1", "h2"])  # fmt: skip


def test_statespace_names_every_input_group_and_round_trips():
    p = gf.Plant.from_statespace(_named_sys(), n_disturbances=1, n_noise=1, y_op=[0.5, 0.3])
    assert (p.m, p.nd, p.nw) == (2, 1, 1)
    assert p.inputs == ("Q1", "Q2") and p.disturbances == ("gust",) and p.noise == ("jitter",)
    assert p.outputs == ("level 1", "level 2") and p.named
    np.testing.assert_array_equal(p.Bw, np.array(BALL)[:, 3:])
    np.testing.assert_array_equal(p.Dd, np.array(DALL)[:, 2:3])
    ss = p.to_statespace()
    assert ss.input_labels == ["Q1", "Q2", "gust", "jitter"]
    back = gf.Plant.from_statespace(ss, n_disturbances=1, n_noise=1)
    assert back.noise == p.noise and back.disturbances == p.disturbances
    for name in ("B", "D", "Bd", "Dd", "Bw", "Dw"):
        np.testing.assert_array_equal(getattr(back, name), getattr(p, name))
    # given names replace the system's
    q = gf.Plant.from_statespace(_named_sys(), n_disturbances=1, n_noise=1, noise=["v"])
    assert q.noise == ("v",) and q.inputs == ("Q1", "Q2")
    # the whole system as known inputs
    assert gf.Plant(_named_sys()).inputs == ("Q1", "Q2", "gust", "jitter")
    with pytest.raises(GeomFDIError) as exc:
        gf.Plant(_named_sys(), Bw=[[1.0], [0.0]])
    assert exc.value.argument == "B"


def test_default_names_of_disturbances_and_noise_inputs():
    bare = gf.Plant(A, np.array(BALL)[:, :2], C, Bd=np.array(BALL)[:, 2:3], Bw=[[0.1], [0.2]])
    assert bare.to_statespace().input_labels == ["u[0]", "u[1]", "d[0]", "w[0]"]
    assert not gf.Plant.from_statespace(bare.to_statespace(), n_disturbances=1, n_noise=1).named
    named = gf.Plant(A, np.array(BALL)[:, :2], C, Bd=np.array(BALL)[:, 2:3],
                     Bw=[[0.1], [0.2]], inputs=["Q1", "Q2"])  # fmt: skip
    assert named.disturbances == ("d0",) and named.noise == ("w0",)
    assert named.to_statespace().input_labels == ["Q1", "Q2", "d0", "w0"]
    with pytest.raises(ShapeError) as exc:
        gf.Plant(A, C=C, Bw=[[0.1], [0.2]], noise=["a", "b"])
    assert exc.value.argument == "noise"


def _tank(t, x, u, params):
    return np.array([u[0] - np.sqrt(x[0]) + 0.5 * u[1] + u[2] ** 2 + 0.2 * u[2]])


def test_linearize_splits_disturbances_and_noise_inputs():
    sys = control.nlsys(_tank, lambda t, x, u, p: x, inputs=["Q", "leak", "w"],
                        outputs=["level"], states=["h"])  # fmt: skip
    p = gf.Plant.linearize(sys, [4.0], [2.0, 0.0, 1.0], n_disturbances=1, n_noise=1)
    assert (p.m, p.nd, p.nw) == (1, 1, 1)
    assert p.inputs == ("Q",) and p.disturbances == ("leak",) and p.noise == ("w",)
    np.testing.assert_allclose(p.A, [[-0.25]], rtol=1e-6)
    np.testing.assert_allclose(p.Bd, [[0.5]], rtol=1e-6)
    np.testing.assert_allclose(p.Bw, [[2.2]], rtol=1e-6)  # d/dw (w^2 + 0.2 w) at w = 1
    assert p.u_op.tolist() == [2.0] and p.y_op.tolist() == [4.0]
    with pytest.raises(GeomFDIError) as exc:
        gf.Plant.linearize(sys, [4.0], [2.0, 0.0, 1.0], n_disturbances=1, n_noise=4)
    assert exc.value.argument == "n_noise"


def test_subs_and_repr_keep_names_operating_point_and_noise_inputs():
    k = sympy.Symbol("k", positive=True)
    pp = gf.Plant([[-k]], [[1]], [[1]], Bw=[[k]], Dw=[[2 * k]], inputs=["Q"],
                  outputs=["level"], noise=["ripple"], u_op=[2.0], y_op=[4.0])  # fmt: skip
    assert pp.noise == ("ripple",) and "nw=1" in repr(pp) and "parameters" in repr(pp)
    num = pp.subs({k: 3})
    assert num.Bw[0, 0] == 3.0 and num.Dw[0, 0] == 6.0
    assert num.noise == ("ripple",) and num.outputs == ("level",) and num.inputs == ("Q",)
    assert num.u_op.tolist() == [2.0] and num.y_op.tolist() == [4.0]
    assert repr(num) == "Plant(n=1, m=1, q=1, nd=0, nw=1, continuous)"


def test_model_file_names_operating_point_and_noise_inputs():
    spec = parse_model(
        {
            "plant": {
                "A": A, "B": np.array(BALL)[:, :2].tolist(), "C": C,
                "Bd": [[0.3], [0.0]], "Bw": [[0.1], [0.2]], "Dw": [[0.05], [0.0]],
                "inputs": ["Q1", "Q2"], "outputs": ["level 1", "level 2"],
                "disturbances": ["gust"], "noise": ["jitter"],
                "y_op": [0.5, 0.3], "u_op": [1.0, 2.0],
            },
            "simulation": {"t_end": 1.0, "step": 0.01, "noise": {"inputs": 0.1, "seed": 1}},
        }
    )  # fmt: skip
    p = spec.plant
    assert (p.nd, p.nw) == (1, 1) and p.Dw[0, 0] == 0.05
    assert p.noise == ("jitter",) and p.disturbances == ("gust",) and p.inputs == ("Q1", "Q2")
    assert p.y_op.tolist() == [0.5, 0.3] and p.u_op.tolist() == [1.0, 2.0]
    assert spec.noise["inputs"] == 0.1
    with pytest.raises(GeomFDIError, match="noise"):
        parse_model({"plant": {"A": A, "C": C, "Bw": [[0.1], [0.2]], "noise": ["a", "b"]}})


def test_a_named_plant_with_an_operating_point_simulates_its_noise_inputs_like_a_bare_one():
    kw = dict(Bd=[[0.3], [0.0]], Bw=[[0.1], [0.2]], Dw=[[0.05], [0.0]])
    bare = gf.Plant(A, np.array(BALL)[:, :2], C, **kw)
    named = gf.Plant(A, np.array(BALL)[:, :2], C, **kw, inputs=["Q1", "Q2"],
                     outputs=["level 1", "level 2"], noise=["jitter"], y_op=[0.5, 0.3],
                     u_op=[1.0, 2.0])  # fmt: skip
    faults = [gf.SensorFault("level 1"), gf.SensorFault("level 2")]
    bank = gf.design_bank(named, faults, [[1, 0], [0, 1]])
    t = np.linspace(0, 5, 501)
    w = lambda t: np.sin(3 * t)[None]  # noqa: E731
    r_named = gf.simulate(named, bank, t, w=w)
    r_bare = gf.simulate(bare, bank, t, w=w)
    assert np.max(np.abs(r_named.residuals)) > 1e-4  # the noise input is not decoupled
    np.testing.assert_allclose(r_named.residuals, r_bare.residuals, rtol=1e-12, atol=1e-14)
    assert r_named.info["signals"]["outputs"] == ["level 1", "level 2"]
    gap, gap_bare = gf.fault_to_noise_gap(bank, named), gf.fault_to_noise_gap(bank, bare)
    assert np.max(gap.gamma) > 1e-3
    np.testing.assert_allclose(gap.gamma, gap_bare.gamma, rtol=1e-9, atol=1e-12)


def _tank_w(t, x, u, params):
    return np.array([u[0] - np.sqrt(x[0]) + u[1]])


def _two_levels(t, x, u, params):
    return np.array([x[0], x[0]])


def test_a_nonlinear_system_takes_its_noise_inputs_in_d():
    sys = control.nlsys(_tank_w, _two_levels, inputs=["Q", "w"], outputs=["a", "b"],
                        states=["h"])  # fmt: skip
    p = gf.Plant.linearize(sys, [4.0], [2.0, 0.0], n_noise=1)
    assert p.noise == ("w",) and p.nw == 1
    bank = gf.design_sensor_bank(p)
    t = np.linspace(0, 2, 201)
    with pytest.raises(GeomFDIError) as exc:
        gf.simulate(sys, bank, t, w=np.zeros((1, t.size)))
    assert exc.value.argument == "w"
    with pytest.raises(GeomFDIError) as exc:
        gf.simulate(sys, bank, t, noise=gf.Noise(inputs=0.1, seed=1))
    assert exc.value.argument == "noise.inputs"
    quiet = gf.simulate(sys, bank, t)
    noisy = gf.simulate(sys, bank, t, d={"w": lambda t: 0.1 * np.sin(5 * t)})
    assert np.max(np.abs(quiet.residuals)) < 1e-6 < np.max(np.abs(noisy.residuals))
