"""gf.evaluate on recorded data, bank.discretize, and the `geomfdi evaluate` command."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from deploy_banks import seed_bank
from scipy.signal import cont2discrete

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError, TimeGridError
from geomfdi.evaluation.decision import MULTIPLE
from geomfdi.io.cli import main

ROOT = Path(__file__).resolve().parents[1]
A = np.array([[1.0, 1, 1], [0, 1, 0], [2, 0, 1]])
B = np.array([[1.0, 0, 1], [0, 1, 1], [0, 1, 0]])
C = np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 2]])
K = np.array([[5, -1.5, 3], [2, 0, 2], [-2, 2.5, -2]])
DT = 0.01


@pytest.fixture(scope="module")
def cbank() -> gf.ResidualBank:
    return seed_bank()


@pytest.fixture(scope="module")
def dplant() -> gf.Plant:
    Ad, Bd, Cd, _, _ = cont2discrete((A, B, C, np.zeros((3, 3))), DT)
    return gf.Plant(Ad, Bd, Cd, dt=DT)


@pytest.fixture(scope="module")
def dbank(cbank: gf.ResidualBank) -> gf.ResidualBank:
    """A well-conditioned discrete bank: the continuous design sampled (zoh)."""
    return cbank.discretize(DT)


def _signals(N: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(N) * DT
    y = np.vstack([np.sin(t * (1 + i)) for i in range(3)]) + 0.1 * rng.normal(size=(3, N))
    u = np.vstack([np.cos(0.5 * t * (1 + j)) for j in range(3)])
    return t, y, u


def _naive(bank: gf.ResidualBank, y: np.ndarray, u: np.ndarray, w0: list) -> np.ndarray:
    """Per-sample loop over every generator: the definition of the discrete recursion."""
    out = np.zeros((bank.n_residuals, y.shape[1]))
    for k, g in enumerate(bank.generators):
        w = np.array(w0[k], dtype=float)
        for i in range(y.shape[1]):
            r = g.M @ w - g.H @ y[:, i] + g.K @ u[:, i]
            w = g.F @ w - g.E @ y[:, i] + g.G @ u[:, i]
            out[k, i] = r[0] if r.size == 1 else np.linalg.norm(r)
    return out


def test_continuous_bank_matches_forced_response(cbank: gf.ResidualBank) -> None:
    import control

    t, y, u = _signals(2001)
    res = gf.evaluate(cbank, y, u, t, initial="zero")
    ref = control.forced_response(cbank.to_statespace(), t, np.vstack([y, u])).outputs
    assert res.info["hold"] == "foh"
    assert np.max(np.abs(res.residuals - ref)) < 1e-9 * max(1.0, np.max(np.abs(ref)))


def test_discrete_bank_equals_the_recursion(dbank: gf.ResidualBank) -> None:
    t, y, u = _signals(400)
    rng = np.random.default_rng(3)
    w0 = [rng.normal(size=g.order) for g in dbank.generators]
    res = gf.evaluate(dbank, y, u, t, initial=np.concatenate(w0))
    assert np.max(np.abs(res.residuals - _naive(dbank, y, u, w0))) < 1e-12
    zero = gf.evaluate(dbank, y, u, dt=DT, initial="zero")
    ref = _naive(dbank, y, u, [np.zeros(g.order) for g in dbank.generators])
    assert np.max(np.abs(zero.residuals - ref)) < 1e-12


def test_steady_start_has_no_transient(dplant: gf.Plant, dbank: gf.ResidualBank) -> None:
    # plant at rest at an equilibrium: x = Ad x + Bd u0
    u0 = np.array([0.3, -0.2, 0.1])
    x = np.linalg.solve(np.eye(3) - dplant.A, dplant.B @ u0)
    N = 3000
    y = np.tile((dplant.C @ x)[:, None], N)
    u = np.tile(u0[:, None], N)
    steady = gf.evaluate(dbank, y, u, dt=DT, initial="steady")
    zero = gf.evaluate(dbank, y, u, dt=DT, initial="zero")
    assert np.max(np.abs(steady.residuals)) < 1e-12
    assert np.max(np.abs(zero.residuals[:, 0])) > 1e-3  # the start-up transient
    assert np.max(np.abs(zero.residuals[:, -1])) < 1e-10  # ... decays


def test_nan_samples_are_masked_and_restart(dbank: gf.ResidualBank) -> None:
    t, y, u = _signals(600)
    y = y.copy()
    y[1, 200:205] = np.nan
    u = u.copy()
    u[2, 400] = np.inf
    res = gf.evaluate(dbank, y, u, t, threshold=0.5)
    masked = np.zeros(600, dtype=bool)
    masked[200:205] = masked[400] = True
    np.testing.assert_array_equal(res.masked, masked)
    assert res.gaps == [(t[200], t[204]), (t[400], t[400])]
    assert np.all(np.isnan(res.residuals[:, masked]))
    assert np.all(np.isfinite(res.residuals[:, ~masked]))
    assert not res.alarms[:, masked].any()
    # each valid segment is the recursion restarted at the steady state of its first sample
    seg = gf.evaluate(dbank, y[:, 205:400], u[:, 205:400], t[205:400], initial="steady")
    np.testing.assert_allclose(res.residuals[:, 205:400], seg.residuals, atol=1e-12)


@pytest.mark.parametrize(
    ("t", "message"),
    [
        (np.r_[np.arange(50) * DT, 0.3], "not strictly increasing"),
        (np.r_[np.arange(50) * DT, 0.5 + 1e-3] + 0, "not uniformly spaced"),
        (np.r_[np.arange(50) * DT, np.nan], "non-finite time"),
    ],
)
def test_bad_time_raises_named_errors(dbank: gf.ResidualBank, t: np.ndarray, message: str) -> None:
    _, y, u = _signals(51)
    with pytest.raises(TimeGridError, match=message) as info:
        gf.evaluate(dbank, y, u, t)
    assert info.value.argument == "t"


def test_mismatched_lengths_and_steps(dbank: gf.ResidualBank, cbank: gf.ResidualBank) -> None:
    t, y, u = _signals(100)
    with pytest.raises(ShapeError, match="u: has 99 samples"):
        gf.evaluate(dbank, y, u[:, :99], t)
    with pytest.raises(ShapeError, match="t: has 99 samples"):
        gf.evaluate(dbank, y, u, t[:99])
    with pytest.raises(ShapeError, match=r"y: expected \(3, N\)"):
        gf.evaluate(dbank, y[:2], u, t)
    with pytest.raises(TimeGridError, match="differs from the discrete bank"):
        gf.evaluate(dbank, y, u, 2 * t)
    with pytest.raises(GeomFDIError, match="sample times t or the sampling period"):
        gf.evaluate(cbank, y, u)


def test_dataframe_with_named_columns(dbank: gf.ResidualBank) -> None:
    pd = pytest.importorskip("pandas")
    t, y, u = _signals(300)
    ref = gf.evaluate(dbank, y, u, t, threshold=0.3)
    df = pd.DataFrame({"time": t, **{f"u{j}": u[j] for j in range(3)}})
    for i in (2, 0, 1):  # any column order
        df[f"y[{i}]"] = y[i]
    res = gf.evaluate(dbank, df, threshold=0.3)
    np.testing.assert_array_equal(res.residuals, ref.residuals)
    np.testing.assert_array_equal(res.alarms, ref.alarms)
    named = pd.DataFrame({"p": y[0], "q": y[1], "s": y[2], "a": u[0], "b": u[1], "c": u[2]})
    res2 = gf.evaluate(dbank, named, outputs=["p", "q", "s"], inputs=["a", "b", "c"], dt=DT)
    np.testing.assert_array_equal(res2.residuals, ref.residuals)
    with pytest.raises(ShapeError, match="not in the DataFrame"):
        gf.evaluate(dbank, named, outputs=["p", "q", "x"], inputs=["a", "b", "c"], dt=DT)


def test_persistence_is_k_of_n(dbank: gf.ResidualBank) -> None:
    t, y, u = _signals(800, seed=5)
    thr = 0.25
    plain = gf.evaluate(dbank, y, u, t, threshold=thr)
    res = gf.evaluate(dbank, y, u, t, threshold=thr, persistence=(2, 4))
    raw = plain.alarms
    assert raw.any() and not raw.all()
    np.testing.assert_array_equal(res.raw_alarms, raw)
    for k in range(800):
        window = raw[:, max(0, k - 3) : k + 1].sum(axis=1)
        np.testing.assert_array_equal(res.alarms[:, k], window >= 2)
    iso = gf.Persistence(2, 4).isolation(res.alarms, dbank.structure)
    np.testing.assert_array_equal(res.isolated, iso.isolated)
    np.testing.assert_array_equal(res.suspects, iso.suspects)
    # the held pattern only grows (no reset): once isolated, a decision is never a
    # momentary "no alarm" again
    first = int(np.argmax(res.isolated >= 0))
    assert res.isolated[first] >= 0 and not np.any(res.isolated[first:] == -1)
    momentary = gf.evaluate(dbank, y, u, t, threshold=thr, persistence=gf.Persistence(2, 4, False))
    assert np.any(momentary.isolated[first:] == -1)
    plain = gf.isolate(res.alarms, dbank.structure).isolated
    np.testing.assert_array_equal(momentary.isolated == -1, plain == -1)
    dur = gf.evaluate(dbank, y, u, t, threshold=thr, persistence=3)
    assert dur.persistence == gf.Persistence(3, 3)


def test_rms_threshold_on_recorded_data(dbank: gf.ResidualBank) -> None:
    t, y, u = _signals(500)
    thr = gf.Threshold(np.full(3, 0.2), statistic="rms", window=10)
    res = gf.evaluate(dbank, y, u, t, threshold=thr)
    stat = thr.statistic_of(res.residuals)
    np.testing.assert_array_equal(res.alarms, stat > 0.2)


def test_discretize_keeps_metadata(cbank: gf.ResidualBank) -> None:
    for method in ("zoh", "tustin"):
        d = cbank.discretize(DT, method=method)
        assert d.dt == DT and all(g.dt == DT for g in d.generators)
        assert d.faults == cbank.faults and d.diagnostics == cbank.diagnostics
        np.testing.assert_array_equal(d.structure, cbank.structure)
        np.testing.assert_array_equal(d.requested, cbank.requested)
        np.testing.assert_array_equal(d.isolable, cbank.isolable)
        assert d.info["sampled"] == {"dt": DT, "method": method}
        for g, h in zip(cbank.generators, d.generators, strict=True):
            assert (h.target, h.decoupled, h.method) == (g.target, g.decoupled, g.method)
            expected = (
                np.exp(g.poles * DT)
                if method == "zoh"
                else (1 + g.poles * DT / 2) / (1 - g.poles * DT / 2)
            )
            np.testing.assert_allclose(
                np.sort_complex(h.poles), np.sort_complex(expected), rtol=1e-9
            )
    # the sampled bank tracks the continuous one on smooth data
    t, y, u = _signals(3000)
    y = np.vstack([np.sin(t * (1 + i)) for i in range(3)])
    c = gf.evaluate(cbank, y, u, t, initial="zero").residuals
    for method in ("zoh", "tustin"):
        d = gf.evaluate(cbank.discretize(DT, method), y, u, t, initial="zero").residuals
        assert np.max(np.abs(d - c)) < 0.05 * np.max(np.abs(c))
    with pytest.raises(GeomFDIError, match="already discrete"):
        cbank.discretize(DT).discretize(DT)
    with pytest.raises(GeomFDIError, match="method"):
        cbank.discretize(DT, method="euler")


def _toml_matrix(M: np.ndarray) -> str:
    return "[" + ", ".join("[" + ", ".join(repr(float(x)) for x in r) + "]" for r in M) + "]"


def _round_trip_model(tmp: Path, dplant: gf.Plant) -> Path:
    fmt = _toml_matrix
    text = f"""name = "sampled seed 001"
[plant]
A = {fmt(dplant.A)}
B = {fmt(dplant.B)}
C = {fmt(dplant.C)}
dt = {DT!r}
[simulation]
t_end = 1.0
step = {DT!r}
threshold = 0.05
"""
    path = tmp / "model.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "cli_rule, rule",
    [(None, None), ("1/2/50", gf.Persistence(1, 2, reset=50)), ("1/2", gf.Persistence(1, 2))],
)
def test_cli_evaluate_round_trip(
    tmp_path: Path, dplant: gf.Plant, cli_rule: str | None, rule: gf.Persistence | None
) -> None:
    model = _round_trip_model(tmp_path, dplant)
    bank = gf.design_bank(dplant, [gf.SensorFault(i) for i in range(3)], np.eye(3, dtype=bool))
    t = np.arange(0.0, 12.0 + DT / 2, DT)
    u = np.vstack([np.sin(0.5 * t), np.cos(0.3 * t), np.full(t.size, 0.2)])
    faults = [gf.GainFault(0, start=6.0, gain=1.5, bias=0.02), gf.BiasFault(2, start=9.0, bias=0.1)]
    sim = gf.simulate(
        dplant, bank, t, u, controller=K, faults=faults, threshold=0.05, persistence=rule
    )
    data = tmp_path / "data.csv"
    with data.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "y0", "y1", "y2", "u0", "u1", "u2"])
        for k in range(t.size):
            w.writerow([repr(float(v)) for v in (t[k], *sim.y[:, k], *sim.u[:, k])])
    out = tmp_path / "out"
    args = ["evaluate", str(model), str(data), "--out", str(out), "--initial", "zero", "--quiet"]
    code = main(args + (["--persistence", cli_rule] if cli_rule else []))
    assert code == 0
    r = np.genfromtxt(out / "residuals.csv", delimiter=",", skip_header=1)
    a = np.genfromtxt(out / "alarms.csv", delimiter=",", skip_header=1, dtype=int)
    np.testing.assert_allclose(r[:, 0], t, rtol=0, atol=1e-12)
    assert np.max(np.abs(r[:, 1:].T - sim.residuals)) < 1e-9
    np.testing.assert_array_equal(a[:, 1:4].T.astype(bool), sim.alarms)
    np.testing.assert_array_equal(a[:, 4], sim.isolated)
    # same detection events: the first alarm after each onset
    any_alarm = a[:, 1:4].any(axis=1)
    for ev in sim.events:
        k = int(np.searchsorted(t, ev.onset - 1e-9))
        first = t[k + np.flatnonzero(any_alarm[k:])[0]]
        assert first == pytest.approx(ev.detection_time, abs=1e-12)
    report = (out / "report.md").read_text()
    assert "Alarm episodes" in report and "sensor 0" in report
    assert (out / "residuals.png").stat().st_size > 1000
    # the library call with the known faults reproduces simulate's events
    res = gf.evaluate(
        bank, sim.y, sim.u, t, threshold=0.05, initial="zero", faults=faults, persistence=rule
    )
    assert len(res.events) == len(sim.events) == 2
    for e1, e2 in zip(res.events, sim.events, strict=True):
        assert (e1.detection_time, e1.isolation_time) == (e2.detection_time, e2.isolation_time)
        assert (e1.decided, e1.hypothesis, e1.residuals) == (
            e2.decided,
            e2.hypothesis,
            e2.residuals,
        )
    assert sim.events[0].outcome == "correct"
    if rule is not None and rule.reset is None:  # the second fault adds to the held pattern
        assert sim.events[1].outcome == "multiple" and sim.events[1].hypothesis == (0, 2)
        assert "| several: sensor 0, sensor 2 |" in report
    else:  # a new episode after 50 quiet samples: isolated alone
        assert sim.events[1].outcome == "correct" and "several" not in report


def test_cli_evaluate_errors(
    tmp_path: Path, dplant: gf.Plant, capsys: pytest.CaptureFixture
) -> None:
    model = _round_trip_model(tmp_path, dplant)
    bad = tmp_path / "bad.csv"
    bad.write_text("t,y0,y1,u0,u1,u2\n0,1,2,3,4,5\n")
    assert main(["evaluate", str(model), str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "3 outputs" in capsys.readouterr().err
    bad.write_text("t,y0,y1,y2,u0,u1,u2\n0,1,2,3,4,5,6\n0.02,1,2,3,4,5,6\n0.03,1,2,3,4,5,6\n")
    assert main(["evaluate", str(model), str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "uniformly spaced" in capsys.readouterr().err


@pytest.mark.slow
def test_example_evaluate_recorded(tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "evaluate_recorded.py"), str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert "first alarm 8.0" in proc.stdout
    for name in ("residuals.png", "isolation.png", "recorded.csv", "bank.json"):
        assert (tmp_path / name).stat().st_size > 500
    assert (tmp_path / "c" / "hou_wen_chen_monitor.c").exists()


def test_alarm_episodes_match_their_definition() -> None:
    from geomfdi.deployment.recorded import alarm_episodes

    rng = np.random.default_rng(0)
    for _ in range(100):
        N, R = int(rng.integers(1, 60)), int(rng.integers(1, 4))
        alarms = rng.random((R, N)) < rng.random()
        iso = np.where(alarms.any(axis=0), rng.integers(-4, 3, N), -1)
        t = np.arange(N) * 0.1
        got = alarm_episodes(t, alarms, iso)
        on = np.r_[False, alarms.any(axis=0), False]
        starts = np.flatnonzero(on[1:] & ~on[:-1])
        stops = np.flatnonzero(~on[1:] & on[:-1])
        assert len(got) == starts.size
        for ep, s, e in zip(got, starts, stops, strict=True):
            assert (ep.start, ep.stop) == (t[s], t[e - 1])
            assert ep.residuals == tuple(np.flatnonzero(alarms[:, s:e].any(axis=1)).tolist())
            ok = np.flatnonzero((iso[s:e] >= 0) | (iso[s:e] == MULTIPLE))
            assert ep.first_fault == (int(iso[s + ok[0]]) if ok.size else None)
            assert ep.first_isolated_at == (t[s + ok[0]] if ok.size else None)
            if not ok.size:
                assert ep.fault is None and ep.isolated_at is None
                continue
            # settled: the decision on most decided samples, the later one on a tie
            seq = iso[s:e][ok].tolist()
            best = max(set(seq), key=lambda d: (seq.count(d), max(ok[np.array(seq) == d])))
            assert ep.fault == best
            assert ep.isolated_at == t[s + ok[seq.index(best)]]
            assert ep.share == pytest.approx(seq.count(best) / len(seq))


def test_an_episode_reports_its_settled_decision_not_its_first() -> None:
    """A start-up transient isolates another fault for a few samples; the episode reports
    the decision the pattern settles on (96 % of the samples), and keeps the first one."""
    from geomfdi.deployment.recorded import alarm_episodes

    t = np.arange(120) * 0.5
    alarms = np.zeros((2, 120), dtype=bool)
    alarms[0, 10:110] = True
    iso = np.full(120, -1)
    iso[10:14] = 3  # the level sensor, briefly
    iso[14:110] = 2  # the leak, from then on
    (ep,) = alarm_episodes(t, alarms, iso)
    assert (ep.fault, ep.isolated_at, ep.share) == (2, t[14], pytest.approx(0.96))
    assert (ep.first_fault, ep.first_isolated_at) == (3, t[10])


def _odd_bank() -> gf.ResidualBank:
    """Discrete generators with complex poles, a non-normal block, one state and a
    two-component residual: every case of the Schur-coordinate recursion."""
    rng = np.random.default_rng(5)
    c, s = 0.97 * np.cos(0.3), 0.97 * np.sin(0.3)
    Fs = [
        np.array([[c, -s, 0.2], [s, c, 0.0], [0.0, 0.0, 0.5]]),  # complex pair
        np.array([[0.9, 4.0, 0.0], [0.0, 0.9, 3.0], [0.0, 0.0, 0.9]]),  # defective
        np.array([[-0.6]]),
        np.diag([0.3, 0.8]),
    ]
    gens = [
        gf.ResidualGenerator(
            F,
            rng.normal(size=(len(F), 3)),
            rng.normal(size=(len(F), 2)),
            rng.normal(size=(2 if k == 3 else 1, len(F))),
            rng.normal(size=(2 if k == 3 else 1, 3)),
            rng.normal(size=(2 if k == 3 else 1, 2)),
            dt=DT,
        )
        for k, F in enumerate(Fs)
    ]
    S = np.eye(4, dtype=bool)
    return gf.ResidualBank(gens, S, S, np.ones(4, bool), ["ok"] * 4, [], DT)


@pytest.mark.parametrize("lift", [None, 1, 4])
def test_lifted_recursion_equals_the_sample_loop(lift: int | None) -> None:
    import dataclasses

    from geomfdi.deployment.program import build_program, run_program
    from geomfdi.simulation.recursion import lifted_maps

    program = build_program(_odd_bank())
    lifted = program.lifted
    assert np.iscomplexobj(lifted.Hz) and lifted.M > 1
    if lift is not None:  # the same system on blocks of another length
        T, Zu = lifted.powers[1], program.basis
        maps = lifted_maps(program.A, program.B, program.C, program.D, T, Zu, lift, lifted.stops)
        program = dataclasses.replace(program, lifted=maps)
    M = program.lifted.M
    rng = np.random.default_rng(6)
    # one partial block, whole blocks, a few blocks (doubling scan), many blocks (lfilter)
    for L in (1, M - 1 or 1, 3 * M, 7 * M + 3, 400 * M + M - 1):
        Z = rng.normal(size=(program.nz, L))
        xi0 = rng.normal(size=program.nw)
        comp, valid, xi, _ = run_program(program, Z, xi0, None, "steady")
        want = np.empty((program.nc, L))
        x = xi0.copy()
        for k in range(L):
            want[:, k] = program.C @ x + program.D @ Z[:, k]
            x = program.A @ x + program.B @ Z[:, k]
        assert valid.all()
        scale = max(1.0, np.abs(want).max())
        assert np.abs(comp - want).max() <= 1e-12 * scale
        assert np.abs(xi - x).max() <= 1e-12 * max(1.0, np.abs(x).max())


def test_cli_saved_bank_per_residual_thresholds_and_progress(
    tmp_path: Path, dplant: gf.Plant, capsys: pytest.CaptureFixture
) -> None:
    """``--bank FILE`` evaluates a saved bank (not the model's design), ``--threshold``
    takes one value per residual, ``--progress`` reports on stderr."""
    model = _round_trip_model(tmp_path, dplant)
    bank = gf.design_bank(dplant, [gf.SensorFault(i) for i in range(3)], np.eye(3, dtype=bool))
    bank.save(tmp_path / "bank.json")
    t = np.arange(0.0, 12.0 + DT / 2, DT)
    u = np.vstack([np.sin(0.5 * t), np.cos(0.3 * t), np.full(t.size, 0.2)])
    faults = [gf.BiasFault(0, start=4.0, bias=0.1), gf.BiasFault(2, start=8.0, bias=0.1)]
    sim = gf.simulate(dplant, bank, t, u, controller=K, faults=faults)
    data = tmp_path / "data.csv"
    sim.to_frame().to_csv(data, index=False)
    thr = [0.05, 0.05, 1e9]  # the third residual never alarms
    out = tmp_path / "out"
    args = ["evaluate", str(model), str(data), "--out", str(out), "--initial", "zero"]
    args += ["--bank", str(tmp_path / "bank.json"), "--threshold", *map(str, thr)]
    assert main([*args, "--progress", "--no-plots"]) == 0
    err = capsys.readouterr().err
    assert "loading the bank" in err and "designing" not in err
    a = np.genfromtxt(out / "alarms.csv", delimiter=",", skip_header=1, dtype=int)
    ref = gf.evaluate(bank, sim.y, sim.u, t, threshold=thr, initial="zero")
    np.testing.assert_array_equal(a[:, 1:4].T.astype(bool), ref.alarms)
    assert a[:, 1].any() and not a[:, 3].any()
    assert main([*args[:-4], "--threshold", "0.1", "0.2", "--quiet"]) == 2
    assert "one value or 3" in capsys.readouterr().err
    code = ["codegen", str(model), "--lang", "python", "--out", str(tmp_path / "py")]
    assert main([*code, "--bank", str(tmp_path / "bank.json"), "--progress", "--quiet"]) == 0


def test_the_fused_program_is_kept_by_the_banks_values(dbank: gf.ResidualBank) -> None:
    """A bank evaluated again reuses its fused form (read-only arrays); a matrix changed
    in place gives another form and the residuals of a fresh bank with that matrix."""
    from dataclasses import replace

    from geomfdi.deployment.program import build_program

    rng = np.random.default_rng(3)
    g0 = next(g for g in dbank.generators if g is not None)
    Y, U = rng.normal(size=(g0.q, 50)), rng.normal(size=(g0.m, 50))
    gens = [None if g is None else replace(g, E=g.E.copy()) for g in dbank.generators]
    bank = replace(dbank, generators=gens)
    p1 = build_program(bank)
    assert build_program(bank) is p1 and not p1.A.flags.writeable
    before = gf.evaluate(bank, Y, U, dt=bank.dt).residuals
    g = next(g for g in gens if g is not None)
    g.E[0, 0] += 0.5
    assert build_program(bank) is not p1
    after = gf.evaluate(bank, Y, U, dt=bank.dt).residuals
    fresh = replace(bank, generators=[None if h is None else replace(h) for h in gens])
    np.testing.assert_array_equal(after, gf.evaluate(fresh, Y, U, dt=bank.dt).residuals)
    assert not np.allclose(before, after)
