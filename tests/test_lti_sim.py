"""The loop-free LTI simulator against python-control and scipy."""

from __future__ import annotations

import control
import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.simulation.lti import discretize, linear_recursion, simulate_lti


def _rel(a, b):
    return np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)


def _compare_forced(A, B, C, D, t, u, x0, dt=0):
    sys = control.ss(A, B, C, D, dt)
    ref = control.forced_response(sys, t, u, X0=x0)
    x, y = simulate_lti(A, B, C, D, u, t, x0=x0, dt=dt)
    return _rel(y, np.atleast_2d(ref.outputs)), _rel(x, np.atleast_2d(ref.states))


SYSTEMS = {
    # stiff-ish: time constants from 1e-3 s to 10 s, non-normal coupling
    "stiff": (
        np.array([[-1000.0, 50.0, 0.0], [0.0, -1.0, 3.0], [0.0, 0.0, -0.1]]),
        np.array([[1.0], [0.5], [1.0]]),
    ),
    # lightly damped oscillator pair (complex Schur form)
    "oscillatory": (
        np.array(
            [[-0.02, 6.0, 0.0, 0.0], [-6.0, -0.02, 1.0, 0.0], [0, 0, -0.5, 2.0], [0, 0, -2.0, -0.5]]
        ),
        np.array([[0.0], [1.0], [0.0], [1.0]]),
    ),
    # repeated, defective eigenvalue -1 (Jordan block of size 3) plus a double real one
    "jordan": (
        np.array(
            [
                [-1.0, 1.0, 0.0, 0.0, 0.0],
                [0.0, -1.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, -1.0, 0.0, 0.0],
                [0.0, 0.0, 0.0, -2.0, 0.0],
                [0.0, 0.0, 0.0, 0.0, -2.0],
            ]
        ),
        np.ones((5, 1)),
    ),
    # unstable mode (the Hou-Wen-Chen plant, open loop)
    "unstable": (
        np.array([[1.0, 1, 1], [0, 1, 0], [2, 0, 1]]),
        np.array([[1.0, 0, 1], [0, 1, 1], [0, 1, 0]]),
    ),
}


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_continuous_matches_forced_response(name):
    A, B = SYSTEMS[name]
    n, m = B.shape
    rng = np.random.default_rng(1)
    C = rng.standard_normal((2, n))
    D = rng.standard_normal((2, m))
    t = np.linspace(0.0, 5.0, 2001)
    u = rng.standard_normal((m, t.size))
    x0 = rng.standard_normal(n)
    ey, ex = _compare_forced(A, B, C, D, t, u, x0)
    assert ey < 1e-9 and ex < 1e-9


def test_discrete_matches_forced_response():
    rng = np.random.default_rng(2)
    A = np.array([[0.9, 0.2, 0.0], [-0.2, 0.9, 0.0], [0.0, 0.0, 0.5]])
    A[0, 2] = 1.0
    B = rng.standard_normal((3, 2))
    C = rng.standard_normal((2, 3))
    D = rng.standard_normal((2, 2))
    t = np.arange(3000) * 0.1
    u = rng.standard_normal((2, t.size))
    ey, ex = _compare_forced(A, B, C, D, t, u, rng.standard_normal(3), dt=0.1)
    assert ey < 1e-9 and ex < 1e-9


def test_zoh_matches_scipy_cont2discrete_and_dlsim():
    A, B = SYSTEMS["oscillatory"]
    C = np.eye(4)
    D = np.zeros((4, 1))
    t = np.arange(500) * 0.01
    u = np.sign(np.sin(3 * t))[None]
    Ad, Bd, *_ = scipy.signal.cont2discrete((A, B, C, D), 0.01, method="zoh")
    _, _, xs = scipy.signal.dlsim((Ad, Bd, C, D, 0.01), u.T, t, x0=np.ones(4))
    x, _ = simulate_lti(A, B, C, D, u, t, x0=np.ones(4), hold="zoh")
    assert _rel(x, xs.T) < 1e-10


def test_free_response_is_matrix_exponential():
    A = SYSTEMS["jordan"][0]
    t = np.linspace(0, 3, 301)
    x, _ = simulate_lti(A, np.zeros((5, 0)), np.eye(5), None, None, t, x0=np.arange(1.0, 6.0))
    from scipy.linalg import expm

    assert np.allclose(x[:, -1], expm(3 * A) @ np.arange(1.0, 6.0), rtol=1e-11, atol=1e-13)


def test_runs_axis_equals_separate_runs():
    A, B = SYSTEMS["oscillatory"]
    C = np.ones((1, 4))
    rng = np.random.default_rng(3)
    t = np.linspace(0, 2, 401)
    u = rng.standard_normal((6, 1, t.size))
    x0 = rng.standard_normal((6, 4))
    X, Y = simulate_lti(A, B, C, None, u, t, x0=x0)
    assert X.shape == (6, 4, t.size) and Y.shape == (6, 1, t.size)
    for r in range(6):
        x, y = simulate_lti(A, B, C, None, u[r], t, x0=x0[r])
        assert np.allclose(X[r], x, rtol=1e-13, atol=1e-14)


def test_linear_recursion_broadcasts_shared_forcing():
    Ad = np.array([[0.5, 1.0], [0.0, 0.5]])  # defective, discrete
    f = np.ones((1, 2, 9))
    x0 = np.array([[0.0, 0.0], [1.0, -1.0]])
    X = linear_recursion(Ad, f, x0)
    for r in range(2):
        x = x0[r].copy()
        for k in range(9):
            x = Ad @ x + f[0, :, k]
            assert np.allclose(X[r, :, k + 1], x, rtol=1e-13)


def test_discretize_foh_reproduces_linear_input_exactly():
    # x' = -x + u with u(t) = t is solved exactly by the first-order hold
    d = discretize([[-1.0]], [[1.0]], 0.5, "foh")
    t = np.arange(0, 5.5, 0.5)
    x = linear_recursion(d.Ad, d.forcing(t[None]), [0.0])[0, 0]
    exact = t - 1 + np.exp(-t)
    assert np.allclose(x, exact, rtol=0, atol=1e-13)


@given(
    n=st.integers(1, 5),
    seed=st.integers(0, 10_000),
    discrete=st.booleans(),
)
@settings(max_examples=15)
def test_random_systems_match_forced_response(n, seed, discrete):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    if discrete:
        A = 0.95 * A / max(np.max(np.abs(np.linalg.eigvals(A))), 1e-3)
    else:
        A = A - (np.max(np.linalg.eigvals(A).real) + 0.3) * np.eye(n)
    B = rng.standard_normal((n, 2))
    C = rng.standard_normal((1, n))
    t = np.arange(400) * 0.05
    u = rng.standard_normal((2, t.size))
    ey, _ = _compare_forced(
        A, B, C, np.zeros((1, 2)), t, u, rng.standard_normal(n), dt=0.05 if discrete else 0
    )
    assert ey < 1e-9


def test_bad_inputs_name_the_argument():
    t = np.linspace(0, 1, 11)
    with pytest.raises(ShapeError, match="u"):
        simulate_lti([[-1.0]], [[1.0]], [[1.0]], None, np.zeros((2, 11)), t)
    with pytest.raises(GeomFDIError, match="equally spaced"):
        simulate_lti([[-1.0]], [[1.0]], [[1.0]], None, None, np.array([0, 0.1, 0.3]))
    with pytest.raises(GeomFDIError, match="sampling period"):
        simulate_lti([[0.5]], [[1.0]], [[1.0]], None, None, t, dt=0.2)
    with pytest.raises(GeomFDIError, match="hold"):
        simulate_lti([[-1.0]], [[1.0]], [[1.0]], None, None, t, hold="cubic")
    with pytest.raises(ShapeError, match="x0"):
        simulate_lti([[-1.0]], [[1.0]], [[1.0]], None, None, t, x0=[1.0, 2.0])


@pytest.mark.parametrize("lift", [None, 1, 2, 3, 5, 8, 64])
def test_block_recursion_chunks_and_blocks_are_exact(lift):
    """Plain and lifted recursions, whole and chunked (chunk lengths that are and are not
    multiples of the lifting factor), against the naive loop."""
    from geomfdi.simulation.lifting import Drive, block_recursion

    rng = np.random.default_rng(5)
    A1 = np.array([[0.9, 0.3], [-0.3, 0.9]])  # complex pair
    A2 = np.array([[0.5, 1.0, 0.0], [0.0, 0.5, 1.0], [0.0, 0.0, 0.5]])  # Jordan block
    W = rng.standard_normal((5, 3))
    d = rng.standard_normal((2, 3, 50))  # 3 runs
    scale = rng.standard_normal((1, 3, 49))
    d0 = d[:1]
    # d0 at two shifts (a first-order hold: one source, M + 1 samples per block)
    drives = [Drive(d0), Drive(d[1:], 1, scale), Drive(d0, 1)]
    x0 = rng.standard_normal((5, 3))
    C1 = rng.standard_normal((1, 2))
    outs = [[C1, np.eye(2)], [np.eye(3)]]
    full = block_recursion([A1, A2], W, drives, x0, outs, 50, lift=lift)
    chunked = block_recursion([A1, A2], W, drives, x0, outs, 50, chunk=7, lift=lift)
    direct = rng.standard_normal((2, 1, 50))
    Dm = rng.standard_normal((1, 2))
    with_direct = block_recursion(
        [A1, A2],
        W,
        drives,
        x0,
        outs,
        50,
        chunk=12,
        lift=lift,
        direct=([direct], [[Dm, None], [None]]),
    )
    # naive loop
    x = x0.copy()
    Ab = np.zeros((5, 5))
    Ab[:2, :2], Ab[2:, 2:] = A1, A2
    traj = [x.copy()]
    for k in range(49):
        f = np.vstack([d[0:1, :, k], scale[0, :, k] * d[1:2, :, k + 1], d[0:1, :, k + 1]])
        x = Ab @ x + W @ f
        traj.append(x.copy())
    traj = np.stack(traj, axis=-1)  # (5, 3, 50)
    for res in (full, chunked):
        assert np.allclose(res[0][1], traj[:2], rtol=1e-12, atol=1e-12)
        assert np.allclose(res[0][0], np.einsum("ij,jrk->irk", C1, traj[:2]), atol=1e-12)
        assert np.allclose(res[1][0], traj[2:], rtol=1e-12, atol=1e-12)
    expect = np.einsum("ij,jrk->irk", C1, traj[:2]) + np.einsum("ij,jrk->irk", Dm, direct)
    assert np.allclose(with_direct[0][0], expect, atol=1e-12)
    assert np.allclose(with_direct[1][0], traj[2:], atol=1e-12)


def test_block_recursion_runs_come_from_scales_too():
    from geomfdi.simulation.lifting import Drive, block_recursion

    d = np.ones((1, 1, 6))
    scale = np.arange(3.0)[None, :, None] * np.ones((1, 3, 5))
    out = block_recursion(
        [np.array([[0.5]])],
        np.ones((1, 1)),
        [Drive(d, 0, scale)],
        np.zeros((1, 1)),
        [[np.eye(1)]],
        6,
    )[0][0]
    assert out.shape == (1, 3, 6)
    # x[k+1] = 0.5 x[k] + s: run r converges to 2 r
    assert np.allclose(out[0, :, -1], np.arange(3.0) * 2 * (1 - 0.5**5))


@pytest.mark.parametrize("lift", [1, 3, 8])
@pytest.mark.parametrize("N", [2, 9, 50, 53])
def test_block_recursion_final_state_and_record_end(lift, N):
    """The last chunk ends the record whatever its length against the lifting factor
    (a partial last block): outputs and the final state of the naive loop."""
    from geomfdi.simulation.lifting import Drive, block_recursion

    rng = np.random.default_rng(N)
    A = np.array([[0.9, 0.3, 0.0], [-0.3, 0.9, 0.1], [0.0, 0.0, 0.5]])
    W = rng.standard_normal((3, 3))
    d = rng.standard_normal((1, 2, N))
    scale = rng.standard_normal((1, 2, N - 1))
    drives = [Drive(d), Drive(d, 1), Drive(d, 0, scale)]
    x0 = rng.standard_normal((3, 2))
    x, traj = x0.copy(), [x0.copy()]
    for k in range(N - 1):
        x = A @ x + W @ np.vstack([d[:, :, k], d[:, :, k + 1], scale[:, :, k] * d[:, :, k]])
        traj.append(x.copy())
    traj = np.stack(traj, axis=-1)
    for chunk in (None, 6):
        (out,), last = block_recursion(
            [A], W, drives, x0, [[np.eye(3)]], N, chunk=chunk, lift=lift, final=True
        )
        np.testing.assert_allclose(out[0], traj, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(last, traj[:, :, -1], rtol=1e-12, atol=1e-12)
