"""Output feedback on the faulty readings, time-varying gains, discrete plants."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hwc_bank import K_FB, P_PAPER, X0, A, B, C, hand_generator, v_ext
from scipy.integrate import solve_ivp

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError

KY = K_FB @ np.linalg.inv(C)  # static output feedback equivalent to K_FB when healthy


def bank(plant):
    gens = [hand_generator(plant, P_PAPER[j : j + 1]) for j in range(3)]
    S = np.ones((3, 3), dtype=bool)
    return gf.ResidualBank(
        gens, S, S, np.zeros(3, bool), ["ok"] * 3, [gf.SensorFault(i) for i in range(3)]
    )


# PI-like dynamic controller on the measured y: xc' = -xc + y, u = -KY y - 0.5 xc
CTRL = control.ss(-np.eye(3), np.eye(3), -0.5 * np.eye(3), -KY)


def reference(t, faulty_y, x0):
    """Continuous closed loop with the generators, by a tight ODE solver.

    The external input is interpolated linearly between samples, as in gf.simulate.
    """
    plant = gf.Plant(A, B, C)
    gens = bank(plant).generators
    uext = v_ext(t)

    def ui(s):
        return np.array([np.interp(s, t, uext[i]) for i in range(3)])

    def rhs(s, z):
        x, xc, w = z[:3], z[3:6], z[6:]
        y = faulty_y(s, C @ x)
        u = ui(s) - 0.5 * xc - KY @ y
        dw = [g.F @ w[i : i + 1] - g.E @ y + g.G @ u for i, g in enumerate(gens)]
        return np.concatenate([A @ x + B @ u, -xc + y, *dw])

    z0 = np.concatenate([x0, np.zeros(3), P_PAPER @ x0])
    sol = solve_ivp(
        rhs, (t[0], t[-1]), z0, t_eval=t, rtol=1e-10, atol=1e-12, method="DOP853", max_step=0.01
    )
    X = sol.y
    r = np.empty((3, t.size))
    for k in range(t.size):
        x, xc = X[:3, k], X[3:6, k]
        y = faulty_y(t[k], C @ x)
        u = uext[:, k] - 0.5 * xc - KY @ y
        for i, g in enumerate(gens):
            r[i, k] = (g.M @ X[6 + i : 7 + i, k] - g.H @ y + g.K @ u)[0]
    return X[:3], r


def test_output_feedback_piecewise_lti_is_exact():
    plant = gf.Plant(A, B, C)
    t = np.arange(0, 5.0001, 5e-3)
    faults = [
        gf.GainFault(0, start=1.5, gain=1.5, bias=0.02),
        gf.StuckFault(2, start=2.5, end=3.0),
        gf.BiasFault(1, start=3.5, bias=0.05, end=4.5),
    ]
    res = gf.simulate(plant, bank(plant), t, v_ext, faults=faults, x0=X0, controller=CTRL)
    assert res.info["mode"] == "output feedback" and res.info["stepped_samples"] == 0
    assert res.info["segments"] == 6
    k = int(np.searchsorted(t, 2.5))
    hold = res.y_healthy[2, k]
    assert np.allclose(res.y[2, k : int(np.searchsorted(t, 3.0))], hold, rtol=1e-13, atol=0)

    def faulty(s, y):
        y = y.copy()
        if s >= 1.5:
            y[0] = 1.5 * y[0] + 0.02
        if 2.5 <= s < 3.0:
            y[2] = hold
        if 3.5 <= s < 4.5:
            y[1] += 0.05
        return y

    x_ref, r_ref = reference(t, faulty, X0)
    scale = np.max(np.abs(r_ref))
    assert np.max(np.abs(res.residuals - r_ref)) < 1e-6 * scale
    assert np.max(np.abs(res.x - x_ref)) < 1e-6 * np.max(np.abs(x_ref))
    # the loop sees the faulty readings: u is computed from y, not from x
    assert np.allclose(res.u, v_ext(t) - 0.5 * res.xc - KY @ res.y, atol=1e-9)


def test_output_feedback_time_varying_gain_steps():
    plant = gf.Plant(A, B, C)
    t = np.arange(0, 2.5001, 5e-3)
    gain = lambda s: 1 + 2.0 * (s - 1.5)  # noqa: E731
    faults = [gf.GainFault(0, start=1.5, gain=gain, end=2.0)]
    res = gf.simulate(
        plant, bank(plant), t, v_ext, faults=faults, x0=X0, controller=CTRL, progress=False
    )
    assert res.info["stepped_samples"] == 100

    def faulty(s, y):
        y = y.copy()
        if 1.5 <= s < 2.0:
            y[0] = gain(s) * y[0]
        return y

    _, r_ref = reference(t, faulty, X0)
    err = np.max(np.abs(res.residuals - r_ref))
    assert err < 1e-4 * np.max(np.abs(r_ref))  # O(dt^2): frozen gain per interval
    assert np.max(np.abs(res.residuals[:, t < 1.5])) < 1e-10


def test_healthy_output_feedback_equals_state_feedback():
    plant = gf.Plant(A, B, C)
    t = np.arange(0, 6.0, 0.01)
    static = control.ss([], [], [], -KY)  # u = v - KY y = v - K x when y = C x
    a = gf.simulate(plant, bank(plant), t, v_ext, x0=X0, controller=static)
    b = gf.simulate(plant, bank(plant), t, v_ext, x0=X0, controller=K_FB)
    assert np.allclose(a.x, b.x, rtol=1e-9, atol=1e-10)
    assert np.max(np.abs(a.residuals)) < 1e-10 and np.max(np.abs(b.residuals)) < 1e-10
    # with a sensor gain fault they differ: the feedback sees it, the state feedback not
    f = [gf.GainFault(0, start=3.0, gain=1.2)]
    c = gf.simulate(plant, bank(plant), t, v_ext, x0=X0, controller=static, faults=f)
    d = gf.simulate(plant, bank(plant), t, v_ext, x0=X0, controller=K_FB, faults=f)
    assert np.allclose(c.x[:, t < 3], d.x[:, t < 3], atol=1e-9)
    assert np.max(np.abs(c.x[:, -1] - d.x[:, -1])) > 1e-3


def discrete_plant():
    """A discrete plant with a disturbance, and a generator decoupled from u and d."""
    Ad = np.array([[0.9, 0.1, 0.0], [0.0, 0.8, 0.2], [0.1, 0.0, 0.7]])
    Bd = np.array([[1.0], [0.0], [0.5]])
    Cd = np.eye(3)
    Bdist = np.array([[0.0], [1.0], [0.0]])
    return gf.Plant(Ad, Bd, Cd, Bd=Bdist, dt=0.1)


def discrete_generator(plant):
    # P with P Bd = 0 (decouples d); F P = P A + E C with C = I: E = F P - P A
    P = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    F = np.diag([0.3, 0.2])
    E = F @ P - P @ plant.A
    return gf.ResidualGenerator(F, E, P @ plant.B, np.eye(2)[:1], P[:1], [[0.0]], dt=0.1)


def test_discrete_plant_with_disturbance_open_and_output_feedback():
    plant = discrete_plant()
    g = discrete_generator(plant)
    t = np.arange(300) * 0.1
    d = lambda s: np.sin(0.7 * s)  # noqa: E731
    u = np.cos(0.2 * t)[None]
    ol = gf.simulate(
        plant, g, t, u, d=d, x0=[1.0, -1.0, 0.5], faults=[gf.BiasFault(0, start=15.0, bias=0.1)]
    )
    assert np.max(np.abs(ol.residuals[0, t < 15])) < 1e-12  # decoupled from u and d
    # recursion by hand for the faulty part: r = M e with e[k+1] = F e[k] - E f[k]
    k0 = int(np.searchsorted(t, 15.0))
    assert ol.residuals[0, k0] == pytest.approx(-0.1, abs=1e-12)  # -H f at the onset
    ctrl = control.ss([[0.5]], [[0.1, 0.0, 0.0]], [[-1.0]], [[-0.2, 0.0, 0.0]], 0.1)
    fb = gf.simulate(
        plant,
        g,
        t,
        u,
        d=d,
        x0=[1.0, -1.0, 0.5],
        controller=ctrl,
        faults=[gf.GainFault(0, start=15.0, gain=0.5)],
    )
    assert np.max(np.abs(fb.residuals[0, t < 15])) < 1e-12
    assert np.max(np.abs(fb.residuals[0, t >= 15])) > 1e-3
    # plain discrete loop by hand
    x = np.array([1.0, -1.0, 0.5])
    xc = np.zeros(1)
    for k in range(t.size):
        y = plant.C @ x
        if t[k] >= 15.0 - 1e-9:
            y[0] *= 0.5
        uk = u[:, k] + (-1.0 * xc + np.array([[-0.2, 0, 0]]) @ y)
        assert np.allclose(fb.u[:, k], uk, atol=1e-10)
        x = plant.A @ x + plant.B @ uk + plant.Bd[:, 0] * d(t[k])
        xc = 0.5 * xc + np.array([[0.1, 0, 0]]) @ y
    # time-varying gain in a discrete loop: stepping is exact
    fb2 = gf.simulate(
        plant,
        g,
        t[:100],
        u[:, :100],
        d=d,
        controller=ctrl,
        progress=False,
        faults=[gf.GainFault(1, start=5.0, gain=lambda s: 1 + 0.1 * (s - 5))],
    )
    assert fb2.info["stepped_samples"] > 0


def test_discrete_grid_must_match_dt():
    plant = discrete_plant()
    g = discrete_generator(plant)
    with pytest.raises(GeomFDIError, match="sampling period"):
        gf.simulate(plant, g, np.arange(10) * 0.05)
    with pytest.raises(GeomFDIError, match="controller"):
        gf.simulate(
            plant,
            g,
            np.arange(10) * 0.1,
            controller=control.ss([[-1.0]], [[1, 0, 0]], [[1.0]], [[0, 0, 0]]),
        )
    with pytest.raises(ShapeError, match="controller"):
        gf.simulate(
            plant, g, np.arange(10) * 0.1, controller=control.ss([], [], [], np.ones((2, 3)), 0.1)
        )


def test_ill_posed_algebraic_loop_is_refused():
    plant = gf.Plant([[-1.0]], [[1.0]], [[1.0]], [[1.0]])
    g = gf.ResidualGenerator([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], [[1.0]], [[1.0]])
    with pytest.raises(GeomFDIError, match="algebraic loop"):
        gf.simulate(plant, g, np.linspace(0, 1, 11), controller=control.ss([], [], [], [[1.0]]))


# ------------------------------------------------------------ actuator faults in the loop
def _actuator_bank(plant):
    faults = [gf.ActuatorFault(B[:, i], name=f"actuator {i}") for i in range(3)]
    return gf.design_bank(plant, faults, np.eye(3, dtype=bool))


@pytest.mark.parametrize("feedback", ["state", "output"])
def test_closed_loop_actuator_gain_and_stuck_faults_are_isolated(feedback):
    plant = gf.Plant(A, B, C)
    abank = _actuator_bank(plant)
    ctrl = K_FB if feedback == "state" else CTRL
    t = np.arange(0.0, 6.0, 0.002)
    lists = [
        [gf.ActuatorGainFault(0, start=3.0, gain=0.5)],  # loss of effectiveness
        [gf.ActuatorStuckFault(1, start=3.0)],  # holds the commanded input at the onset
        [gf.ActuatorStuckFault(2, start=3.0, value=1.0)],
    ]
    kw = dict(x0=[0.1, 0, 0], controller=ctrl, threshold=0.01)
    batch = gf.simulate_batch(
        plant, abank, t, v_ext, faults=lists, store="all", persistence=5, progress=False, **kw
    )
    healthy = gf.simulate(plant, abank, t, v_ext, **kw)
    before = t < 3.0
    scale = np.max(np.abs(batch.residuals))
    # before the onset: the healthy loop, residuals zero
    dev = np.abs(batch.residuals[:, :, before] - healthy.residuals[None, :, before])
    assert np.max(dev) < 1e-12 * scale
    assert np.max(np.abs(healthy.residuals)) < 1e-12 * scale
    pre = np.broadcast_to(healthy.x[:, before], batch.x[:, :, before].shape)
    np.testing.assert_allclose(batch.x[:, :, before], pre, rtol=0, atol=1e-12)
    for j in range(3):
        (ev,) = batch.events[j]
        assert ev.index == j and ev.outcome == "correct" and ev.isolation_delay < 1.0
        peaks = np.max(np.abs(batch.residuals[j][:, ~before]), axis=1)
        assert peaks[j] > 0.05 and np.all(np.delete(peaks, j) < 1e-9 * peaks[j])
        # the controller reacts to the fault: its (commanded) output leaves the healthy one
        assert np.max(np.abs(batch.u[j][:, ~before] - healthy.u[:, ~before])) > 1e-3
    np.testing.assert_array_equal(batch.metrics().confusion[:, :3], np.eye(3, dtype=int))
    # the recorded u is the commanded input (from x, or from the faulty loop's y); the
    # plant got the applied one
    one = gf.simulate(plant, abank, t, v_ext, faults=lists[0], **kw)
    np.testing.assert_array_equal(one.u, batch.u[0])
    if feedback == "state":
        np.testing.assert_allclose(one.u, v_ext(t) - K_FB @ one.x, atol=1e-9)
    else:
        np.testing.assert_allclose(one.u, v_ext(t) - 0.5 * one.xc - KY @ one.y, atol=1e-9)
        return
    # the stuck actuator holds the commanded input at the onset (continuous there, D = 0)
    held = batch.u[1][1, int(np.searchsorted(t, 3.0))]
    ref = _closed_loop_x(t, 1, gain=0.0, bias=held, x0=[0.1, 0, 0])
    np.testing.assert_allclose(batch.x[1], ref, rtol=0, atol=1e-6 * np.max(np.abs(ref)))


def _closed_loop_x(t, i, gain, bias, x0, onset=3.0):
    """State feedback with actuator i faulty from the onset, by a tight ODE solver."""
    uext = v_ext(t)

    def rhs(s, x):
        u = np.array([np.interp(s, t, uext[k]) for k in range(3)]) - K_FB @ x
        if s >= onset:
            u[i] = gain * u[i] + bias
        return A @ x + B @ u

    kw = dict(rtol=1e-10, atol=1e-12, method="DOP853")
    first = solve_ivp(rhs, (t[0], onset), x0, t_eval=t[t < onset], dense_output=True, **kw)
    second = solve_ivp(rhs, (onset, t[-1]), first.sol(onset), t_eval=t[t >= onset], **kw)
    return np.hstack([first.y, second.y])


def test_closed_loop_actuator_faults_match_the_closed_form():
    """x' = a x + b u^a, u = -k x; residual r = w - y of the observer w' = f w + (a - f) y
    + b u (F = f, E = f - a, G = b, M = H = 1).  Loss of effectiveness u^a = gamma u from
    t0: x = x(t0) e^{lam tau} (lam = a - b gamma k, tau = t - t0) and
    r = -b k (1 - gamma) x(t0) (e^{lam tau} - e^{f tau}) / (lam - f).  Stuck at s:
    x = (x(t0) + b s / a) e^{a tau} - b s / a and r = int e^{f(tau-s')} b (u - s) ds'."""
    a, b, k, f = -1.0, 2.0, 1.5, -3.0
    gam, t0, x0 = 0.4, 1.0, 0.8
    plant = gf.Plant([[a]], [[b]], [[1.0]])
    g = gf.ResidualGenerator([[f]], [[f - a]], [[b]], [[1.0]], [[1.0]], [[0.0]])
    t = np.arange(0, 3.0 + 1e-9, 0.01)
    tau = np.maximum(t - t0, 0.0)
    xt0 = x0 * np.exp((a - b * k) * t0)
    pre = np.where(t < t0, x0 * np.exp((a - b * k) * t), 0.0)
    res = gf.simulate(
        plant, g, t, controller=[[k]], x0=[x0], faults=gf.ActuatorGainFault(0, start=t0, gain=gam)
    )
    lam = a - b * gam * k
    x = np.where(t < t0, pre, xt0 * np.exp(lam * tau))
    r = np.where(t < t0, 0.0, -b * k * (1 - gam) * xt0 * (np.exp(lam * tau) - np.exp(f * tau)))
    r = r / (lam - f)
    np.testing.assert_allclose(res.x[0], x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.residuals[0], r, rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.u[0], -k * x, rtol=0, atol=1e-9)  # commanded input
    assert res.info["mode"] == "state feedback" and res.info["segments"] == 2
    s = 0.3
    res = gf.simulate(
        plant, g, t, controller=[[k]], x0=[x0], faults=gf.ActuatorStuckFault(0, start=t0, value=s)
    )
    c1, c2 = xt0 + b * s / a, -b * s / a
    x = np.where(t < t0, pre, c1 * np.exp(a * tau) + c2)
    eps = -k * c1 * (np.exp(a * tau) - np.exp(f * tau)) / (a - f)
    eps = b * (eps + (-k * c2 - s) * (1 - np.exp(f * tau)) / (-f))
    np.testing.assert_allclose(res.x[0], x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.residuals[0], np.where(t < t0, 0.0, eps), rtol=0, atol=1e-9)


def test_closed_loop_progressive_actuator_loss_is_stepped():
    """A loss of effectiveness growing with time under state feedback: stepped with the
    gain frozen over each interval, O(dt^2) against a tight ODE solution."""
    plant = gf.Plant(A, B, C)
    t = np.arange(0.0, 2.0001, 5e-3)
    gain = lambda s: 1.0 - 0.5 * (s - 1.0)  # noqa: E731
    res = gf.simulate(
        plant,
        _actuator_bank(plant),
        t,
        v_ext,
        x0=X0,
        controller=K_FB,
        faults=gf.ActuatorGainFault(2, start=1.0, gain=gain),
        progress=False,
    )
    assert res.info["stepped_samples"] == 200
    uext = v_ext(t)

    def rhs(s, x):
        u = np.array([np.interp(s, t, uext[k]) for k in range(3)]) - K_FB @ x
        if s >= 1.0:
            u[2] = gain(s) * u[2]
        return A @ x + B @ u

    kw = dict(rtol=1e-10, atol=1e-12, method="DOP853", max_step=5e-3)
    ref = solve_ivp(rhs, (0.0, 2.0), X0, t_eval=t, **kw).y
    assert np.max(np.abs(res.x - ref)) < 1e-4 * np.max(np.abs(ref))
    assert np.max(np.abs(res.residuals[:2])) < 1e-9 * np.max(np.abs(res.residuals[2]))
