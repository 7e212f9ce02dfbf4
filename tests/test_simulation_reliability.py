"""Reliability of the simulator: scale-invariant initial states, validated options."""

import warnings

import numpy as np
import pytest
import scipy.signal

import geomfdi as gf
from geomfdi.errors import GeomFDIError, NonFiniteError

A = np.array([[1.0, 1, 1], [0, 1, 0], [2, 0, 1]])
B = np.array([[1.0, 0, 1], [0, 1, 1], [0, 1, 0]])
C = np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 2]])
K = np.array([[5, -1.5, 3], [2, 0, 2], [-2, 2.5, -2]])
X0 = np.array([0.5, -0.3, 0.2])
T = np.arange(0.0, 3.0, 0.002)
U = np.vstack([np.sin(0.5 * T), np.cos(0.3 * T), 0.2 + 0 * T])


def _lsim_residuals(plant, bank, Kfb, x0, w0s, u):
    """Residuals of the composite [closed-loop plant; generator] by scipy.signal.lsim."""
    Acl = plant.A - plant.B @ Kfb
    out = []
    for k, g in enumerate(bank.generators):
        if g is None:
            out.append(np.zeros(T.size))
            continue
        n, nw = plant.n, g.order
        Ac = np.block([[Acl, np.zeros((n, nw))], [-g.E @ plant.C - g.G @ Kfb, g.F]])
        Bc = np.vstack([plant.B, g.G])
        Cc = np.hstack([-g.H @ plant.C - g.K @ Kfb, g.M])
        _, y, _ = scipy.signal.lsim((Ac, Bc, Cc, g.K), u.T, T, X0=np.concatenate([x0, w0s[k]]))
        out.append(np.reshape(y, (T.size, -1))[:, 0])
    return np.array(out)


def _scaled(plant, scales):
    Tm = np.diag(scales)
    Ti = np.diag(1.0 / np.asarray(scales))
    return gf.Plant(Tm @ plant.A @ Ti, Tm @ plant.B, plant.C @ Ti), Tm, Ti


@pytest.mark.slow
def test_healthy_residual_equals_lsim_in_scaled_coordinates():
    # the Hou-Wen-Chen (2011) plant in T = diag(1e-4, 1, 1e4) (the bank designed there is not the
    # unscaled one), and random plants in diag(10^k), k in [-6, 6]: whatever the bank,
    # the simulated residual is the true one, from the initial state simulate reports
    rng = np.random.default_rng(5)
    cases = [(gf.Plant(A, B, C), [1e-4, 1.0, 1e4], K)]
    for _ in range(4):
        Ar = rng.standard_normal((3, 3)) - 2 * np.eye(3)
        Br = rng.standard_normal((3, 2))
        cases.append((gf.Plant(Ar, Br, np.eye(3)), 10.0 ** rng.integers(-6, 7, 3), None))
    checked = 0
    for plant, scales, Kfb in cases:
        P, Tm, Ti = _scaled(plant, scales)
        bank = gf.design_sensor_bank(P)
        Kt = np.zeros((P.m, P.n)) if Kfb is None else Kfb @ Ti
        u = U[: P.m]
        for consistent_init in (True, False):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", gf.InitialStateWarning)
                res = gf.simulate(
                    P,
                    bank,
                    T,
                    u,
                    x0=Tm @ X0,
                    controller=None if Kfb is None else Kt,
                    consistent_init=consistent_init,
                )
            ref = _lsim_residuals(P, bank, Kt, Tm @ X0, res.info["w0"], u)
            scale = max(1.0, float(np.max(np.abs(ref))))
            for k, g in enumerate(bank.generators):
                # a nearly defective F (eigenvector condition > 1e4, a scaled design gone
                # wrong) limits any two integrators' agreement; those rows are not compared
                if g is None or np.linalg.cond(np.linalg.eig(g.F)[1]) > 1e4:
                    continue
                np.testing.assert_allclose(res.residuals[k], ref[k], atol=1e-9 * scale)
                checked += 1
    assert checked >= 8, checked


def test_inexact_consistent_state_is_not_used():
    # a generator whose F shares its eigenvalue with the plant and is coupled to it:
    # F Pi - Pi A = -Sigma has no solution, so the start is zero (warned), not a guess
    plant = gf.Plant([[-1.0]], [[1.0]], [[1.0]])
    g = gf.ResidualGenerator([[-1.0]], [[-1.0]], [[0.0]], [[1.0]], [[0.0]], [[0.0]])
    t = np.linspace(0.0, 2.0, 201)
    with pytest.warns(gf.InitialStateWarning, match="starts at zero"):
        res = gf.simulate(plant, g, t, x0=[1.0])
    assert res.info["initial_state"][0] == "zero"
    np.testing.assert_array_equal(res.info["w0"][0], [0.0])
    # w' = -w + x with x = e^-t, w(0) = 0: w = t e^-t
    np.testing.assert_allclose(res.residuals[0], t * np.exp(-t), atol=1e-12)


def test_inexact_start_is_warned_only_from_a_non_zero_state():
    """The same generator as above: from x0 = 0 the zero start is the consistent one
    (w0 = Pi 0 for any Pi), so nothing is warned and the residual is exactly zero; a
    batch whose later runs start away from zero warns once, when it meets them."""
    plant = gf.Plant([[-1.0]], [[1.0]], [[1.0]])
    g = gf.ResidualGenerator([[-1.0]], [[-1.0]], [[0.0]], [[1.0]], [[0.0]], [[0.0]])
    t = np.linspace(0.0, 2.0, 201)
    with warnings.catch_warnings():
        warnings.simplefilter("error", gf.InitialStateWarning)
        res = gf.simulate(plant, g, t, x0=[0.0])
    assert res.info["initial_state"][0] == "zero"
    np.testing.assert_array_equal(res.residuals[0], 0.0)
    x0 = np.zeros((40, 1))
    x0[-1] = 1.0  # the last run only: in a later chunk of runs
    with pytest.warns(gf.InitialStateWarning, match="starts at zero") as caught:
        batch = gf.simulate_batch(plant, g, t, runs=40, x0=x0, chunk_size=8, progress=False)
    assert sum(issubclass(w.category, gf.InitialStateWarning) for w in caught) == 1
    np.testing.assert_array_equal(batch.residuals[:-1], 0.0)
    np.testing.assert_allclose(batch.residuals[-1, 0], t * np.exp(-t), atol=1e-12)


def test_seeds_of_none_draw_fresh_entropy_per_run():
    plant = gf.Plant([[-1.0]], [[1.0]], [[1.0]])
    g = gf.ResidualGenerator([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], [[1.0]], [[0.0]])
    t = np.linspace(0.0, 1.0, 101)
    noise = gf.Noise(measurement=0.1)
    res = gf.simulate_batch(plant, g, t, runs=2, noise=noise, seeds=[None, None])
    r = res.residuals
    assert r.shape[0] == 2 and np.all(np.isfinite(r))
    assert not np.array_equal(r[0], r[1])  # two independent noise realisations


@pytest.mark.parametrize("dt", [-0.01, float("nan"), float("inf")])
def test_simulate_lti_refuses_a_bad_dt(dt):
    with pytest.raises(GeomFDIError) as err:
        gf.simulate_lti([[-1.0]], [[1.0]], [[1.0]], None, None, np.linspace(0, 1, 11), dt=dt)
    assert err.value.argument == "dt"


def test_options_are_validated_with_named_errors():
    plant = gf.Plant([[-1.0]], [[1.0]], [[1.0]])
    g = gf.ResidualGenerator([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], [[1.0]], [[0.0]])
    t = np.linspace(0.0, 1.0, 11)
    noise = gf.Noise(measurement=0.1, seed=1)
    cases = [
        (lambda: gf.simulate_batch(plant, g, t, runs=2, noise=noise, seeds=["abc", 1]), "seeds"),
        (lambda: gf.simulate_batch(plant, g, t, runs=2, noise=noise, seeds=[-1, 1]), "seeds"),
        (lambda: gf.simulate_batch(plant, g, t, runs=2, noise=noise, seeds=[1]), "seeds"),
        (lambda: gf.simulate_batch(plant, g, t, runs=2, seeds=[1, 2]), "seeds"),
        (lambda: gf.Noise(measurement=0.1, seed="abc"), "noise.seed"),
        (lambda: gf.Noise(measurement=0.1, seed=-1), "noise.seed"),
        (lambda: gf.simulate(plant, g, t, persistence=(3, 2)), "persistence"),
        (lambda: gf.simulate(plant, g, t, detection_window=-1.0), "detection_window"),
        (lambda: gf.simulate(plant, g, t, detection_window=float("nan")), "detection_window"),
        (lambda: gf.simulate(plant, g, t, faults="oops"), "faults"),
        (lambda: gf.simulate_batch(plant, g, t, runs=0), "runs"),
    ]
    for call, arg in cases:
        with pytest.raises(GeomFDIError) as err:
            call()
        assert err.value.argument == arg, (arg, err.value)
    # a NaN matrix is refused when the generator is built, naming the matrix ...
    with pytest.raises(NonFiniteError) as err:
        gf.ResidualGenerator([[np.nan]], [[-1.0]], [[1.0]], [[1.0]], [[1.0]], [[0.0]])
    assert err.value.argument == "F"
    # ... and one that became non-finite afterwards is refused by the simulator
    bad = gf.ResidualGenerator([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], [[1.0]], [[0.0]])
    bad.F = np.array([[np.nan]])
    with pytest.raises(NonFiniteError, match="generator 0") as err:
        gf.simulate(plant, bad, t)
    assert err.value.argument == "bank"
    # valid seeds still work and reproduce
    a = gf.simulate_batch(plant, g, t, runs=2, noise=noise, seeds=[3, 4])
    b = gf.simulate_batch(plant, g, t, runs=2, noise=noise, seeds=[3, 4])
    np.testing.assert_array_equal(a.residuals, b.residuals)


def test_simulate_limits_blas_to_one_thread_unless_opted_out():
    from threadpoolctl import threadpool_info

    from geomfdi._threads import limit_blas_threads

    blas = [p for p in threadpool_info() if p["user_api"] == "blas"]
    if not blas:
        pytest.skip("no BLAS library reported by threadpoolctl")

    @limit_blas_threads
    def inside() -> list[int]:
        return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]

    assert inside() and all(n == 1 for n in inside())
    before = [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]
    old = gf.get_blas_threads()
    gf.set_blas_threads(None)
    try:
        assert inside() == before
    finally:
        gf.set_blas_threads(old)


def test_blas_limit_covers_a_blas_library_loaded_after_the_first_limited_call():
    """scipy's OpenBLAS is a library of its own, loaded with ``scipy.linalg``: a limited
    call made before it was loaded must not leave it out of the later limits."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    script = (
        "import numpy\n"
        "from threadpoolctl import threadpool_info\n"
        "from geomfdi._threads import limit_blas_threads\n"
        "counts = lambda: {p['filepath']: p['num_threads'] for p in threadpool_info()\n"
        "                  if p['user_api'] == 'blas'}\n"
        "f = limit_blas_threads(counts)\n"
        "first = f()\n"
        "import scipy.linalg\n"
        "before = counts()\n"
        "inside = f()\n"
        "print((len(first), sorted(before.values()), sorted(inside.values()),\n"
        "       sorted(counts().values())))\n"
    )
    root = str(Path(__file__).resolve().parents[1])
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "2", "GEOMFDI_BLAS_THREADS": "1"}
    env["PYTHONPATH"] = os.pathsep.join([root, env.get("PYTHONPATH", "")])
    out = subprocess.run(
        [sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    n_first, before, inside, after = eval(out.stdout.strip().splitlines()[-1])
    if len(before) <= n_first or max(before) < 2:
        pytest.skip("scipy shares numpy's BLAS here, or the BLAS runs one thread only")
    assert inside == [1] * len(before)
    assert before == after == [2] * len(before)  # set back on return


def test_a_diverging_linear_run_is_cut_at_the_bound():
    """max |x| beyond ``bound`` (either sign) from the first such sample: no residuals,
    alarms or decisions after it, and the time reported."""
    p = gf.Plant([[1.0, 0.0], [0.0, 0.5]], [[0.0], [0.0]], np.eye(2))
    g = gf.ResidualGenerator([[-2.0]], [[-1.0, 0.0]], [[0.0]], [[1.0]], [[1.0, 0.0]], [[0.0]])
    t = np.linspace(0.0, 10.0, 1001)
    with pytest.warns(gf.DivergenceWarning, match="diverged"):
        res = gf.simulate(p, g, t, x0=[-1.0, 0.0], threshold=0.5, bound=1e3)
    k = int(np.argmax(np.abs(res.x).max(axis=0) > 1e3))
    assert k > 0 and res.info["diverged"] and res.info["diverged_at"] == t[k]
    assert np.isnan(res.residuals[:, k:]).all() and np.isfinite(res.residuals[:, :k]).all()
    assert not res.alarms[:, k:].any()
