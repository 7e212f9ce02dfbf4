"""gf.simulate on the Hou-Wen-Chen example (Hou, Wen & Chen 2011, §4)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hwc_bank import K_FB, P_PAPER, X0, hand_generator, leaky_bank, v_ext

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.evaluation.decision import NO_ALARM

T = np.arange(0, 20.0005, 1e-3)


def paper_generator(plant, j):
    """The Hou-Wen-Chen residual j with F = -2, M = 1, row P = p_j (built by hand)."""
    decoupled = tuple(i for i in range(3) if i != j)
    return hand_generator(
        plant, P_PAPER[j : j + 1], target=(j,), decoupled=decoupled, method="paper"
    )


def paper_bank(plant):
    return leaky_bank([paper_generator(plant, j) for j in range(3)], method="paper")


def test_hand_built_generators_satisfy_the_identities(seed001):
    for j in range(3):
        g = paper_generator(seed001, j)
        P = P_PAPER[j : j + 1]
        assert np.allclose(g.F @ P, P @ seed001.A + g.E @ seed001.C, atol=1e-12)
        assert np.allclose(g.M @ P, g.H @ seed001.C, atol=1e-12)


@pytest.mark.parametrize(
    ("fault", "expected"),
    [
        (gf.GainFault(0, start=8.0, gain=1.5, bias=0.02), (0.145, 0.213, 0.319)),
        (gf.BiasFault(0, start=8.0, bias=0.02), (0.020, 0.040, 0.060)),
    ],
)
def test_reference_peaks_paper_design(seed001, fault, expected):
    res = gf.simulate(
        seed001,
        paper_bank(seed001),
        T,
        v_ext,
        faults=[fault],
        x0=X0,
        controller=K_FB,
        threshold=0.06,
    )
    peaks = res.max_abs(8.0, 20.0)
    assert np.allclose(peaks, expected, rtol=0.02)
    # consistent initial state: no start-up transient on healthy data
    assert np.max(np.abs(res.residuals[:, T < 8.0])) < 1e-10
    assert max(res.info["init_mismatch"].values()) < 1e-12
    # the applied input is the state feedback's
    assert np.allclose(res.u, v_ext(T) - K_FB @ res.x, atol=1e-12)


def test_bias_leaks_decay_to_zero(seed001):
    res = gf.simulate(
        seed001,
        paper_bank(seed001),
        T,
        v_ext,
        faults=[gf.BiasFault(0, start=8.0, bias=0.02)],
        x0=X0,
        controller=K_FB,
    )
    # r1 = -(s-1)/(s+2) * 0.02 -> +0.01 steady state; r2, r3 leak with zero DC gain
    late = T > 18
    assert np.allclose(res.residuals[0, late], 0.01, atol=1e-6)
    assert np.max(np.abs(res.residuals[1:, late])) < 1e-4
    assert res.residuals[0, int(np.searchsorted(T, 8.0))] == pytest.approx(-0.02, abs=1e-9)


def test_alarm_isolation_and_delays(seed001):
    res = gf.simulate(
        seed001,
        paper_bank(seed001),
        T,
        v_ext,
        faults=[gf.GainFault(0, start=8.0, gain=1.5, bias=0.02)],
        x0=X0,
        controller=K_FB,
        threshold=0.06,
    )
    assert not res.alarms[:, T < 8.0].any() and res.false_alarm_rate() == 0.0
    ev = res.events[0]
    assert ev.onset == pytest.approx(8.0) and ev.detection_delay == pytest.approx(0.0)
    # the achieved structure has r2, r3 seeing every sensor: isolation of sensor 0 needs
    # the pattern (1, 1, 1) ... which is the column of all faults, hence ambiguous
    assert res.isolated[T < 8.0].tolist() == [NO_ALARM] * int(np.sum(T < 8.0))
    assert set(ev.residuals) == {0, 1, 2}
    text = res.summary()
    assert "gain 1.5" in text and "r[2]" in text


def test_synthesised_paper_bank_reproduces_reference(seed001):
    if not hasattr(gf, "design_sensor_bank"):
        pytest.skip("synthesis not available")
    bank = gf.design_sensor_bank(seed001, method="paper", poles=[-2])
    gens = []
    for j, g in enumerate(bank.generators):
        P = np.asarray(g.info["P"], dtype=float).ravel()
        k = int(np.argmax(np.abs(P_PAPER[j])))
        alpha = P[k] / P_PAPER[j, k]
        assert np.allclose(P / alpha, P_PAPER[j], atol=1e-9)
        # r = M (w - P x): rescale so that the row is the paper's p_j with M = 1
        gens.append(g.scaled(1.0 / (float(g.M[0, 0]) * alpha)))
    scaled = gf.ResidualBank(
        gens, bank.requested, bank.structure, bank.isolable, bank.diagnostics, bank.faults
    )
    res = gf.simulate(
        seed001,
        scaled,
        T,
        v_ext,
        faults=[gf.GainFault(0, start=8.0, gain=1.5, bias=0.02)],
        x0=X0,
        controller=K_FB,
    )
    assert np.allclose(res.max_abs(8.0), (0.145, 0.213, 0.319), rtol=0.02)


@pytest.mark.parametrize("sensor", [0, 1, 2])
def test_exact_design_leakage_is_rounding(seed001, sensor):
    if not hasattr(gf, "design_sensor_bank"):
        pytest.skip("synthesis not available")
    bank = gf.design_sensor_bank(seed001)
    res = gf.simulate(
        seed001,
        bank,
        T[::5],
        v_ext,
        faults=[gf.GainFault(sensor, start=8.0, gain=1.5, bias=0.02)],
        x0=X0,
        controller=K_FB,
        threshold=0.06,
    )
    peaks = res.max_abs(8.0)
    others = [j for j in range(3) if j != sensor]
    assert peaks[sensor] > 0.05
    assert np.all(peaks[others] < 1e-10 * peaks[sensor] + 1e-11)
    assert np.max(np.abs(res.residuals[:, res.t < 8.0])) < 1e-10
    assert res.events[0].isolation_time is not None  # exact bank isolates every sensor


@pytest.mark.parametrize(
    "F, decoupled",
    [
        ([[-3.0, 1.0], [0.0, -0.5]], True),  # simulated as w - Pi x, driven by u and f only
        ([[-1.0, 2.0], [-2.0, -1.0]], False),  # the plant's poles: no Pi, driven by x too
    ],
)
def test_open_loop_matches_forced_response_of_composite(F, decoupled):
    """Open loop, a bias fault: the composite [plant; generator] through forced_response."""
    import control

    plant = gf.Plant([[-1.0, 2.0], [-2.0, -1.0]], [[1.0], [0.5]], [[1.0, 0.0], [1.0, 1.0]])
    rng = np.random.default_rng(4)
    g = gf.ResidualGenerator(
        F,
        rng.standard_normal((2, 2)),
        rng.standard_normal((2, 1)),
        rng.standard_normal((1, 2)),
        rng.standard_normal((1, 2)),
        rng.standard_normal((1, 1)),
    )
    t = np.arange(0, 10, 0.01)
    u = np.sin(t)[None]
    ramp = lambda s: 0.3 * np.clip(s - 4.0, 0, 1)  # noqa: E731  continuous: FOH-exact
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gf.InitialStateWarning)  # random g: not decoupled
        res = gf.simulate(
            plant,
            g,
            t,
            u,
            faults=[gf.BiasFault(1, start=4.0, bias=ramp)],
            x0=[1.0, -1.0],
            consistent_init=False,
        )
    A, B, C = plant.A, plant.B, plant.C
    As = np.block([[A, np.zeros((2, 2))], [-g.E @ C, g.F]])
    Bs = np.block([[B, np.zeros((2, 2))], [g.G, -g.E]])
    Cs = np.hstack([-g.H @ C, g.M])
    Ds = np.hstack([g.K, -g.H])
    f = np.zeros((2, t.size))
    f[1] = ramp(t)
    ref = control.forced_response(
        control.ss(As, Bs, Cs, Ds), t, np.vstack([u, f]), X0=[1.0, -1.0, 0.0, 0.0]
    )
    assert np.max(np.abs(res.residuals[0] - ref.outputs)) < 1e-10 * np.max(np.abs(ref.outputs))
    assert res.info["plant_state_decoupled"] is decoupled


def test_zoh_hold_differs_from_foh_by_order_dt(seed001):
    kw = dict(faults=[gf.GainFault(0, start=8.0, gain=1.5, bias=0.02)], x0=X0, controller=K_FB)
    a = gf.simulate(seed001, paper_bank(seed001), T[::10], v_ext, **kw)
    b = gf.simulate(seed001, paper_bank(seed001), T[::10], v_ext, hold="zoh", **kw)
    d = np.max(np.abs(a.residuals - b.residuals))
    assert 1e-6 < d < 0.05 * np.max(np.abs(a.residuals))
    assert b.info["hold"] == "zoh"


def test_single_generator_missing_rows_and_vector_residuals(seed001):
    g0 = paper_generator(seed001, 0)
    res = gf.simulate(
        seed001,
        g0,
        T[::20],
        v_ext,
        faults=[gf.BiasFault(0, start=8.0, bias=0.02)],
        x0=X0,
        controller=K_FB,
        threshold=0.015,
    )
    assert res.residuals.shape == (1, T[::20].size)
    # detected; a lone generator carries no fault list, so no isolation column is known
    assert res.events[0].detection_delay == pytest.approx(0.0)
    assert res.events[0].index is None and res.events[0].isolation_time is None
    assert res.structure.tolist() == [[True, False, False]]
    bank = paper_bank(seed001)
    bank.generators[1] = None
    res = gf.simulate(
        seed001,
        bank,
        T[::20],
        v_ext,
        faults=[gf.BiasFault(0, start=8.0, bias=0.02)],
        x0=X0,
        controller=K_FB,
        threshold=0.01,
    )
    assert np.all(res.residuals[1] == 0) and not res.alarms[1].any()
    assert res.residual_vectors[1] is None
    # a two-output generator contributes the norm of its components
    g2 = paper_generator(seed001, 2)
    two = gf.ResidualGenerator(
        g2.F, g2.E, g2.G, np.vstack([g2.M, 2 * g2.M]), np.vstack([g2.H, 2 * g2.H]), np.zeros((2, 3))
    )
    res2 = gf.simulate(
        seed001,
        two,
        T[::20],
        v_ext,
        faults=[gf.BiasFault(0, start=8.0, bias=0.02)],
        x0=X0,
        controller=K_FB,
    )
    ref = gf.simulate(
        seed001,
        g2,
        T[::20],
        v_ext,
        faults=[gf.BiasFault(0, start=8.0, bias=0.02)],
        x0=X0,
        controller=K_FB,
    )
    assert np.allclose(res2.residuals[0], np.sqrt(5) * np.abs(ref.residuals[0]), atol=1e-13)


def test_inconsistent_generator_warns_and_zero_start_gives_transient(seed001):
    g = paper_generator(seed001, 1)
    bad = gf.ResidualGenerator(g.F, g.E, g.G + 0.1, g.M, g.H, g.K)  # not decoupled from u
    with pytest.warns(gf.InitialStateWarning, match="generator 0"):
        gf.simulate(seed001, bad, T[::50], v_ext, x0=X0, controller=K_FB)
    res = gf.simulate(seed001, g, T[::50], v_ext, x0=X0, controller=K_FB, consistent_init=False)
    assert np.max(np.abs(res.residuals[0, :20])) > 0.01  # start-up transient w0 = 0


def test_measurement_noise_is_seeded_and_reproducible(seed001):
    bank = paper_bank(seed001)
    kw = dict(x0=X0, controller=K_FB, noise=gf.Noise(measurement=[1e-3, 2e-3, 0.0], seed=7))
    a = gf.simulate(seed001, bank, T[::10], v_ext, **kw)
    b = gf.simulate(seed001, bank, T[::10], v_ext, **kw)
    assert np.array_equal(a.residuals, b.residuals)
    noise = a.y - (seed001.C @ a.x)
    assert np.std(noise[0]) == pytest.approx(1e-3, rel=0.05)
    assert np.std(noise[1]) == pytest.approx(2e-3, rel=0.05)
    assert np.all(noise[2] == 0)
    c = gf.simulate(
        seed001,
        bank,
        T[::10],
        v_ext,
        x0=X0,
        controller=K_FB,
        noise=gf.Noise(measurement=1e-3, seed=8),
    )
    assert not np.allclose(a.residuals, c.residuals)


def test_stuck_sensor_freezes_noisy_reading(seed001):
    res = gf.simulate(
        seed001,
        paper_bank(seed001),
        T[::10],
        v_ext,
        x0=X0,
        controller=K_FB,
        faults=[gf.StuckFault(1, start=5.0)],
        noise=gf.Noise(measurement=1e-3, seed=1),
    )
    k = int(np.searchsorted(res.t, 5.0))
    assert np.all(res.y[1, k:] == res.y_healthy[1, k])
    assert np.array_equal(res.y[0], res.y_healthy[0])


def test_process_noise_enters_through_bw():
    plant = gf.Plant([[-1.0]], [[1.0]], [[1.0]], dt=0.1)
    # P = 1: F P = P A + E C gives E = 1.5, G = P B = 1, M P = H C gives H = 1
    g = gf.ResidualGenerator([[0.5]], [[1.5]], [[1.0]], [[1.0]], [[1.0]], [[0.0]], dt=0.1)
    t = np.arange(20000) * 0.1
    res = gf.simulate(plant, g, t, noise=gf.Noise(process=0.2, seed=3))
    # x[k+1] = -x[k] + w[k]: stationary variance 0.04 / (1 - 1) would diverge; use the
    # identity x[k+1] + x[k] = w[k] instead
    w = res.x[0, 1:] + res.x[0, :-1]
    assert np.std(w) == pytest.approx(0.2, rel=0.03)
    assert abs(np.corrcoef(w[1:], w[:-1])[0, 1]) < 0.03
    # the residual is the estimation error e = w - P x: e[k+1] = F e[k] - P w[k]
    r = res.residuals[0]
    assert np.allclose(r[1:], 0.5 * r[:-1] - w, atol=1e-10)


def test_plot_and_png_export(seed001, tmp_path):
    from matplotlib.figure import Figure

    res = gf.simulate(
        seed001,
        paper_bank(seed001),
        T[::20],
        v_ext,
        x0=X0,
        controller=K_FB,
        faults=[gf.GainFault(0, start=8.0, gain=1.5, bias=0.02)],
        threshold=0.06,
    )
    fig = res.plot(title="seed 001")
    assert isinstance(fig, Figure) and len(fig.axes) == 3
    ax = fig.axes[0]
    short = [line for line in ax.get_lines() if len(line.get_xdata()) == 2]
    assert any(np.allclose(line.get_ydata(), [0.06, 0.06]) for line in short)
    assert any(np.allclose(line.get_ydata(), [-0.06, -0.06]) for line in short)
    assert any(np.allclose(line.get_xdata(), [8.0, 8.0]) for line in short)
    path = gf.save_png(fig, tmp_path / "sub" / "residuals")
    assert path.suffix == ".png" and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bank = paper_bank(seed001)
    fig2 = gf.plot_structure(bank)
    assert len(fig2.axes) == 2 and fig2.axes[1].get_title() == "achieved"
    red = [p for p in fig2.axes[1].patches if p.get_edgecolor()[:3] == (1.0, 0.0, 0.0)]
    assert len(red) == 4  # r2, r3 see sensors they should ignore
    fig3 = gf.plot_residuals(
        res.t, res.residuals, threshold=gf.Threshold(np.full(3, 0.01), statistic="rms", window=100)
    )
    assert len(fig3.axes[0].get_lines()) >= 3
    with pytest.raises(GeomFDIError, match="fig"):
        gf.save_png("not a figure", tmp_path / "x.png")


def test_bad_arguments_name_themselves(seed001):
    bank = paper_bank(seed001)
    with pytest.raises(GeomFDIError, match="plant"):
        gf.simulate("plant", bank, T)
    with pytest.raises(GeomFDIError, match="bank"):
        gf.simulate(seed001, [1, 2], T)
    with pytest.raises(ShapeError, match="u"):
        gf.simulate(seed001, bank, T, np.zeros((2, T.size)))
    with pytest.raises(ShapeError, match="controller"):
        gf.simulate(seed001, bank, T, controller=np.ones((2, 3)))
    with pytest.raises(ShapeError, match="x0"):
        gf.simulate(seed001, bank, T, x0=[1.0, 2.0])
    with pytest.raises(GeomFDIError, match="noise"):
        gf.simulate(seed001, bank, T, noise=0.1)
    with pytest.raises(ShapeError, match="noise.measurement"):
        gf.simulate(seed001, bank, T, noise=gf.Noise(measurement=[1.0, 2.0]))
    with pytest.raises(GeomFDIError, match="noise.process"):
        gf.simulate(seed001, bank, T, noise=gf.Noise(process=-np.eye(3)))
    with pytest.raises(GeomFDIError, match="sensor"):
        gf.simulate(seed001, bank, T, faults=[gf.BiasFault(3, start=1.0, bias=1.0)])
    with pytest.raises(GeomFDIError, match="u"):
        gf.simulate(seed001, bank, T, lambda t: 1 / 0)
    d = gf.ResidualGenerator(
        [[0.5]], [[1, 0, 0]], [[0, 0, 0]], [[1.0]], [[0, 0, 0]], [[0, 0, 0]], dt=0.1
    )
    with pytest.raises(GeomFDIError, match="bank"):
        gf.simulate(seed001, d, T)


def closed_loop_with_states(plant, bank, sensor):
    """The paper's closed loop, a bias on ``sensor`` at 8 s, generator states kept."""
    return gf.simulate(
        plant,
        bank,
        T[::10],
        v_ext,
        x0=X0,
        controller=K_FB,
        faults=[gf.BiasFault(sensor, start=8.0, bias=0.02)],
        keep_states=True,
    )


def test_generator_states_track_p_x_on_healthy_data(seed001):
    res = closed_loop_with_states(seed001, paper_bank(seed001), 2)
    healthy = res.t < 8.0
    for j in range(3):
        assert np.allclose(res.w[j][0, healthy], P_PAPER[j] @ res.x[:, healthy], atol=1e-10)
    # after the fault the estimation error e = w - P x obeys e' = -2 e + p_j C^-1 e_2 f
    e = res.w[0][0] - P_PAPER[0] @ res.x
    assert np.max(np.abs(e)) < 1e-10  # r1's row p_1 C^-1 ignores sensor 2
    assert gf.simulate(seed001, paper_bank(seed001), T[::10], v_ext).w[0] is None


def test_consistent_start_of_a_bank_with_shared_and_distinct_spectra(seed001):
    """The paper generators (F = -2, an eigenvalue of the closed loop: least-squares
    start) and generators with spectra apart from it (one joint Sylvester solve) in one
    bank: every residual starts at rest and stays there until the fault."""
    A, B, C = seed001.A, seed001.B, seed001.C
    Ci = np.linalg.inv(C)
    rng = np.random.default_rng(5)
    gens = [paper_generator(seed001, j) for j in range(3)]
    Ps = []
    for _ in range(3):
        Q = np.linalg.qr(rng.standard_normal((2, 2)))[0]
        F = Q @ np.diag(-rng.uniform(3.0, 6.0, 2)) @ Q.T
        P = rng.standard_normal((2, 3))
        M = rng.standard_normal((1, 2))
        gens.append(
            gf.ResidualGenerator(F, (F @ P - P @ A) @ Ci, P @ B, M, M @ P @ Ci, np.zeros((1, 3)))
        )
        Ps.append(P)
    S = np.ones((6, 3), dtype=bool)
    bank = gf.ResidualBank(
        gens, S, S, np.zeros(3, bool), ["ok"] * 6, [gf.SensorFault(i) for i in range(3)]
    )
    res = closed_loop_with_states(seed001, bank, 1)
    healthy = res.t < 8.0
    scale = np.max(np.abs(res.x))
    assert np.max(np.abs(res.residuals[:, healthy])) < 1e-10 * scale
    for j in range(3):  # w = P x: the invariant subspace of each generator
        assert np.max(np.abs(res.w[j][0, healthy] - P_PAPER[j] @ res.x[:, healthy])) < 1e-10
        assert np.max(np.abs(res.w[3 + j][:, healthy] - Ps[j] @ res.x[:, healthy])) < 1e-10
    # every residual but r1 (decoupled from sensor 2 by design) sees the bias
    assert np.min(np.max(np.abs(res.residuals[1:, ~healthy]), axis=1)) > 1e-3
    assert max(res.info["init_mismatch"].values()) < 1e-12


def test_lifted_bank_matches_forced_response():
    """A bank large enough for the lifted recursion (complex generator poles, state
    feedback, a bias ramp) against forced_response on the composite system."""
    import control

    from geomfdi.simulation.lifting import _lift_factor

    rng = np.random.default_rng(11)
    A = np.array([[0.0, 1.0, 0.0], [-2.0, -0.5, 1.0], [0.0, 0.0, -1.0]])
    B = np.array([[0.0], [1.0], [0.5]])
    C = np.eye(3)
    K = np.array([[1.0, 0.5, 0.2]])
    gens = []
    for _ in range(8):
        w = rng.uniform(1.0, 4.0)
        F = np.array([[-rng.uniform(0.5, 3.0), w], [-w, -rng.uniform(0.5, 3.0)]])
        gens.append(
            gf.ResidualGenerator(
                F,
                rng.standard_normal((2, 3)),
                rng.standard_normal((2, 1)),
                rng.standard_normal((1, 2)),
                rng.standard_normal((1, 3)),
                rng.standard_normal((1, 1)),
            )
        )
    S = np.zeros((8, 3), dtype=bool)
    bank = gf.ResidualBank(
        gens, S, S, np.zeros(3, bool), ["ok"] * 8, [gf.SensorFault(i) for i in range(3)]
    )
    # 16 generator states, 8 outputs, 9 drive rows: lifting is chosen
    assert _lift_factor(16, 8, 9, True) > 1
    t = np.arange(5003) * 2e-3
    v = np.sin(t)[None]
    ramp = lambda s: 0.2 * np.clip(s - 4.0, 0, 1)  # noqa: E731
    x0 = np.array([0.3, -0.2, 0.1])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gf.InitialStateWarning)  # random generators
        res = gf.simulate(
            gf.Plant(A, B, C),
            bank,
            t,
            v,
            faults=[gf.BiasFault(2, start=4.0, bias=ramp)],
            x0=x0,
            controller=K,
            consistent_init=False,
        )
    Acl = A - B @ K
    nw = 16
    As = np.zeros((3 + nw, 3 + nw))
    Bs = np.zeros((3 + nw, 4))
    Cs = np.zeros((8, 3 + nw))
    Ds = np.zeros((8, 4))
    As[:3, :3], Bs[:3, :1] = Acl, B
    for k, g in enumerate(gens):
        i = 3 + 2 * k
        As[i : i + 2, :3] = -g.E @ C - g.G @ K
        As[i : i + 2, i : i + 2] = g.F
        Bs[i : i + 2, :1], Bs[i : i + 2, 1:] = g.G, -g.E
        Cs[k, :3] = -g.H @ C - g.K @ K
        Cs[k, i : i + 2] = g.M
        Ds[k, :1], Ds[k, 1:] = g.K, -g.H
    f = np.zeros((3, t.size))
    f[2] = ramp(t)
    ref = control.forced_response(
        control.ss(As, Bs, Cs, Ds), t, np.vstack([v, f]), X0=np.r_[x0, np.zeros(nw)]
    ).outputs
    assert np.max(np.abs(res.residual_vectors[3] - ref[3:4])) < 1e-10 * np.max(np.abs(ref))
    assert np.max(np.abs(res.residuals - ref)) < 1e-10 * np.max(np.abs(ref))


def test_state_feedback_gain_does_not_import_python_control():
    """A gain matrix as controller needs no python-control import (about 0.3 s)."""
    import subprocess
    import sys

    code = (
        "import sys, numpy as np, geomfdi as gf\n"
        "p = gf.Plant([[-1.0]], [[1.0]], [[1.0]])\n"
        "g = gf.ResidualGenerator([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], [[1.0]], [[0.0]])\n"
        "gf.simulate(p, g, np.linspace(0, 4, 401), controller=[[0.5]])\n"
        "print('control' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _vector_residual_result():
    # r = y = [x; 2x] (a generator with two residual components), x' = -x + u, u = 1
    plant = gf.Plant([[-1.0]], [[1.0]], [[1.0], [2.0]])
    g = gf.ResidualGenerator(
        [[-1.0]], [[0.0, 0.0]], [[0.0]], [[0.0], [0.0]], -np.eye(2), [[0.0], [0.0]]
    )
    t = np.linspace(0.0, 3.0, 301)
    return gf.simulate(plant, g, t, np.ones((1, t.size)), threshold=0.5, consistent_init=False)


def test_vector_residual_norm_is_plotted_against_a_positive_threshold_only():
    res = _vector_residual_result()
    x = 1 - np.exp(-res.t)
    np.testing.assert_allclose(res.residuals[0], np.sqrt(5) * x, atol=1e-12)
    assert res.norm_rows() == [True]
    fig = res.plot()
    (ax,) = fig.axes
    levels = [ln.get_ydata()[0] for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    assert levels == [0.5]  # no -0.5 line under a norm that cannot be negative
    # a scalar residual still gets both lines
    fig2 = gf.plot_residuals(res.t, res.residuals[0] - 1.0, threshold=0.5)
    levels2 = sorted(
        ln.get_ydata()[0] for ln in fig2.axes[0].get_lines() if ln.get_linestyle() == "--"
    )
    assert levels2 == [-0.5, 0.5]


def test_false_alarm_rate_is_a_method_like_detection_rate():
    res = _vector_residual_result()
    assert callable(res.false_alarm_rate)
    # no fault: every sample is fault-free; |r| > 0.5 once sqrt(5) x > 0.5
    expect = np.mean(np.sqrt(5) * (1 - np.exp(-res.t)) > 0.5)
    assert res.false_alarm_rate() == pytest.approx(expect)
