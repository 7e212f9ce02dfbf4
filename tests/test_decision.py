"""Thresholds, alarms, isolation from the structure matrix, detection delays."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.evaluation.decision import (
    AMBIGUOUS,
    NO_ALARM,
    UNEXPLAINED,
    Threshold,
    as_threshold,
    decision_statistic,
    detection_events,
    isolate,
)


@given(window=st.integers(1, 12), seed=st.integers(0, 1000))
@settings(max_examples=25)
def test_rms_statistic_is_the_causal_moving_rms(window, seed):
    r = np.random.default_rng(seed).standard_normal((2, 40))
    s = decision_statistic(r, "rms", window)
    naive = np.array(
        [
            [np.sqrt(np.mean(r[j, max(0, k - window + 1) : k + 1] ** 2)) for k in range(40)]
            for j in range(2)
        ]
    )
    assert np.allclose(s, naive, rtol=1e-10, atol=1e-12)
    assert np.array_equal(decision_statistic(r, "abs"), np.abs(r))


def test_calibrated_threshold_reaches_the_false_alarm_rate():
    rng = np.random.default_rng(0)
    train = rng.standard_normal((3, 200_000)) * np.array([[1.0], [2.0], [0.5]])
    thr = Threshold.from_residuals(train, 0.01)
    # Gaussian: |r| > 2.5758 sigma with probability 1 %
    assert np.allclose(thr.values, 2.5758 * np.array([1.0, 2.0, 0.5]), rtol=0.02)
    test = rng.standard_normal((3, 200_000)) * np.array([[1.0], [2.0], [0.5]])
    rate = thr.alarms(test).mean(axis=1)
    assert np.all(np.abs(rate - 0.01) < 0.0015)
    # the "any residual" version controls the rate of the union (Bonferroni)
    thr_any = Threshold.from_residuals(train, 0.01, per="any")
    union = thr_any.alarms(test).any(axis=0).mean()
    assert union <= 0.0115 and union > 0.008
    assert thr_any.info["alpha_per_residual"] == pytest.approx(0.01 / 3)


def test_calibration_ignores_dead_rows_and_refuses_too_few_samples():
    r = np.vstack([np.random.default_rng(1).standard_normal(5000), np.zeros(5000)])
    thr = Threshold.from_residuals(r, 0.05)
    assert np.isfinite(thr.values[0]) and thr.values[1] == np.inf
    with pytest.raises(GeomFDIError, match="false_alarm_rate"):
        Threshold.from_residuals(r, 1e-5)
    with pytest.raises(GeomFDIError, match="false_alarm_rate"):
        Threshold.from_residuals(r, 1.5)


def test_rms_threshold_trades_delay_for_noise():
    rng = np.random.default_rng(2)
    noise = rng.standard_normal((1, 100_000))
    t_abs = Threshold.from_residuals(noise, 0.001)
    t_rms = Threshold.from_residuals(noise, 0.001, statistic="rms", window=50)
    sig = rng.standard_normal((1, 4000))
    sig[0, 2000:] += 1.5  # a step of 1.5 sigma
    a_abs = t_abs.alarms(sig)[0, 2000:].mean()
    a_rms = t_rms.alarms(sig)[0, 2000:].mean()
    assert a_rms > 0.9 > 0.3 > a_abs  # averaging detects the small step reliably


def test_isolation_decisions():
    S = np.array([[1, 0, 1, 0], [0, 1, 1, 0], [0, 0, 0, 0]], dtype=bool)
    S = np.hstack([S, S[:, :1]])  # fault 4 has the same column as fault 0
    a = np.array(
        [
            [0, 0, 1, 1, 1, 0],
            [0, 1, 0, 1, 1, 0],
            [0, 0, 0, 0, 1, 1],
        ],
        dtype=bool,
    )
    iso = isolate(a, S)
    assert iso.isolated.tolist() == [NO_ALARM, 1, AMBIGUOUS, 2, UNEXPLAINED, UNEXPLAINED]
    assert iso.candidates[:, 2].tolist() == [True, False, False, False, True]
    # suspects: non-zero columns covered by the alarm pattern
    assert iso.suspects[:, 3].tolist() == [True, True, True, False, True]
    assert not iso.suspects[3].any()  # fault 3 is seen by no residual


def test_isolation_vectorised_over_runs():
    S = np.eye(3, dtype=bool)
    a = np.zeros((4, 3, 5), dtype=bool)
    a[1, 2, 3] = True
    a[2, :, 1] = True
    iso = isolate(a, S)
    assert iso.isolated.shape == (4, 5)
    assert iso.isolated[1, 3] == 2 and iso.isolated[2, 1] == UNEXPLAINED
    assert np.all(iso.isolated[0] == NO_ALARM)


@given(seed=st.integers(0, 10_000), nr=st.integers(1, 6), nf=st.integers(1, 5))
@settings(max_examples=60, deadline=None)
def test_isolation_matches_the_per_sample_definition(seed, nr, nf):
    """Candidates: fault columns equal to the alarm pattern; suspects: non-zero columns
    covered by it; the decision: the single candidate, else ambiguous / unexplained."""
    rng = np.random.default_rng(seed)
    S = rng.random((nr, nf)) < 0.5
    a = rng.random((2, nr, 9)) < 0.4
    iso = isolate(a, S)
    for r in range(2):
        for k in range(9):
            pat = a[r, :, k]
            cand = [bool(np.array_equal(pat, S[:, j]) and pat.any()) for j in range(nf)]
            sus = [bool(S[:, j].any() and np.all(pat[S[:, j]])) for j in range(nf)]
            assert iso.candidates[r, :, k].tolist() == cand
            assert iso.suspects[r, :, k].tolist() == sus
            if not pat.any():
                expect = NO_ALARM
            elif sum(cand) == 1:
                expect = cand.index(True)
            else:
                expect = AMBIGUOUS if sum(cand) > 1 else UNEXPLAINED
            assert iso.isolated[r, k] == expect


def test_detection_events_delays():
    t = np.arange(0, 10.01, 0.5)
    alarms = np.zeros((2, t.size), dtype=bool)
    alarms[1, 10:] = True  # from 5 s
    alarms[0, 12:] = True  # from 6 s
    iso = isolate(alarms, np.array([[1, 0], [1, 1]], dtype=bool)).isolated
    f0 = gf.BiasFault(0, start=4.0, bias=1.0)
    f1 = gf.BiasFault(1, start=3.0, bias=1.0)
    f2 = gf.BiasFault(1, start=20.0, bias=1.0)  # never starts on the grid
    ev = detection_events(t, alarms, iso, [f0, f1, f2], [0, 1, None])
    assert len(ev) == 2
    assert ev[0].onset == 4.0 and ev[0].detection_delay == 1.0
    assert ev[0].isolation_time == 6.0 and ev[0].isolation_delay == 2.0
    assert ev[1].isolation_time == 5.0 and ev[1].residuals == (0, 1)
    assert ev[0].detected and ev[0].isolated


def test_as_threshold_conversions():
    thr = as_threshold(0.06, 3, present=[0, 2])
    assert thr.values.tolist() == [0.06, np.inf, 0.06]
    assert as_threshold(None, 3) is None
    assert as_threshold([0.1, 0.2], 2).values.tolist() == [0.1, 0.2]
    with pytest.raises(ShapeError, match="threshold"):
        as_threshold([0.1, 0.2], 3)
    with pytest.raises(GeomFDIError, match="threshold"):
        as_threshold(-1.0, 3)
    with pytest.raises(ShapeError, match="threshold"):
        as_threshold(Threshold(np.ones(2)), 3)
    with pytest.raises(GeomFDIError, match="statistic"):
        decision_statistic(np.ones(3), "max")


def test_calibrate_threshold_from_noise_only_simulation():
    plant = gf.Plant([[-1.0, 0.5], [0.0, -2.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 1.0]])
    # a generator decoupled from u: F P = P A + E C, M P = H C with P = [1, 0]
    P = np.array([[1.0, 0.0]])
    F = np.array([[-3.0]])
    E = F @ P - P @ plant.A
    gen = gf.ResidualGenerator(F, E, P @ plant.B, [[1.0]], P, [[0.0]])
    t = np.arange(0, 20, 0.01)
    noise = gf.Noise(measurement=0.01, seed=5)
    thr = gf.calibrate_threshold(
        plant, gen, t, noise=noise, false_alarm_rate=0.02, runs=4, u=np.sin(t)[None]
    )
    assert thr.false_alarm_rate == 0.02 and thr.values[0] > 0
    fresh = gf.simulate_batch(
        plant,
        gen,
        t,
        np.sin(t)[None],
        runs=4,
        noise=gf.Noise(measurement=0.01, seed=99),
        threshold=thr,
        progress=False,
    )
    assert abs(fresh.false_alarm_rate() - 0.02) < 0.01
    with pytest.raises(GeomFDIError, match="noise"):
        gf.calibrate_threshold(plant, gen, t, noise=None, false_alarm_rate=0.02)


def test_evaluation_and_plotting_do_not_import_the_simulator():
    # the decision layer is below the simulator: no import (even in a function) goes up
    import ast
    import pathlib

    root = pathlib.Path(gf.__file__).parent
    for sub in ("evaluation", "plotting"):
        for path in (root / sub).glob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                mods = []
                if isinstance(node, ast.ImportFrom) and node.module:
                    mods = [node.module]
                elif isinstance(node, ast.Import):
                    mods = [a.name for a in node.names]
                for mod in mods:
                    assert not mod.startswith("geomfdi.simulation"), f"{path.name} imports {mod}"
    assert gf.calibrate_threshold.__module__ == "geomfdi.simulation.calibration"


# ------------------------------------------------------------ persistence and metrics
from geomfdi.evaluation.decision import MULTIPLE, fault_hypotheses  # noqa: E402
from geomfdi.evaluation.metrics import detection_metrics, false_alarms  # noqa: E402
from geomfdi.evaluation.persistence import (  # noqa: E402
    Persistence,
    as_persistence,
    held_pattern,
    k_of_n,
)


def test_k_of_n_persistence_by_hand():
    raw = np.array([1, 0, 1, 1, 0, 0, 1, 0, 1, 1, 1], dtype=bool)
    # windows of 3 ending at each sample hold 1,1,2,2,2,1,1,1,2,2,3 raw alarms
    assert k_of_n(raw, 2, 3).astype(int).tolist() == [0, 0, 1, 1, 1, 0, 0, 0, 1, 1, 1]
    assert k_of_n(raw, 3, 3).astype(int).tolist() == [0] * 10 + [1]
    assert Persistence.from_duration(0.1, 0.002) == Persistence(50, 50)
    assert as_persistence(4) == Persistence(4, 4) and as_persistence((2, 5)) == Persistence(2, 5)
    assert as_persistence(None) is None
    for bad in ((3, 2), (0, 1), "x", 1.5):
        with pytest.raises(GeomFDIError, match="persistence"):
            as_persistence(bad)


def test_isolation_needs_a_held_pattern():
    S = np.eye(2, dtype=bool)
    # r0 alarms throughout; r1 drops out for two samples (a coincidental single pattern)
    a = np.array([[1] * 8, [1, 1, 1, 0, 0, 1, 1, 1]], dtype=bool)
    assert isolate(a, S).isolated.tolist() == [-2, -2, -2, 0, 0, -2, -2, -2]
    # memoryless rule: the two-sample pattern never settles ...
    free = Persistence(3, 3, latch=False)
    assert free.isolation(a, S).isolated.tolist() == [-2, -2, MULTIPLE, -2, -2, -2, -2, MULTIPLE]
    # ... but a three-sample one is decided at its third sample, although r1 had alarmed
    b = np.array([[1] * 8, [1, 1, 0, 0, 0, 0, 1, 1]], dtype=bool)
    assert free.isolation(b, S).isolated.tolist() == [-2, -2, -2, -2, 0, 0, -2, -2]
    # the held pattern keeps r1: both faults, at every sample (settled after 3 samples)
    for al in (a, b):
        iso = Persistence(3, 3).isolation(al, S)
        assert iso.isolated.tolist() == [-2, -2] + [MULTIPLE] * 6
        assert iso.suspects[:, 2:].all()
    # an episode ends after `reset` quiet samples: a later single alarm is isolated
    c = np.array([[1, 1, 0, 0, 0, 0, 0, 0, 0], [1, 1, 0, 0, 0, 1, 1, 1, 1]], dtype=bool)
    assert Persistence(2, 2).isolation(c, S).isolated.tolist() == [-2] + [MULTIPLE] * 8
    iso = Persistence(2, 2, reset=3).isolation(c, S).isolated
    assert iso.tolist() == [-2, MULTIPLE, MULTIPLE, MULTIPLE, -1, -2, 1, 1, 1]


def test_held_pattern_against_a_loop():
    rng = np.random.default_rng(4)
    a = rng.random((3, 2, 60)) < 0.08
    for reset in (None, 1, 3, 7):
        out = held_pattern(a, reset)
        for r in range(3):
            held = np.zeros(2, dtype=bool)
            quiet = 10**9
            for k in range(60):
                if a[r, :, k].any():
                    if reset is not None and quiet >= reset:
                        held[:] = False
                    held |= a[r, :, k]
                    quiet = 0
                else:
                    quiet += 1
                    if reset is not None and quiet >= reset:
                        held[:] = False
                assert out[r, :, k].tolist() == held.tolist(), (reset, r, k)


def test_multiple_fault_hypotheses():
    S = np.array([[1, 0, 1, 0], [0, 1, 1, 0], [0, 0, 0, 1]], dtype=bool)
    assert fault_hypotheses([1, 1, 0], S) == [(2,), (0, 1)]
    assert fault_hypotheses([1, 1, 1], S) == [(2, 3), (0, 1, 3)]
    assert fault_hypotheses([1, 0, 1], S) == [(0, 3)]
    assert fault_hypotheses([0, 0, 0], S) == []
    # no set of faults gives r0 and r2 without r1 if fault 0 is absent
    assert fault_hypotheses([1, 0, 1], S[:, 1:]) == []
    assert fault_hypotheses([1, 1, 1], S, max_faults=2) == [(2, 3)]
    # the decision rule: a held pattern that is a union of suspects' columns is MULTIPLE,
    # one that is not is UNEXPLAINED
    al = np.zeros((3, 6), dtype=bool)
    al[0, 1:] = True
    al[2, 3:] = True
    iso = Persistence(1, 1).isolation(al, S[:, [0, 1, 3]]).isolated
    assert iso.tolist() == [-1, 0, 0, MULTIPLE, MULTIPLE, MULTIPLE]
    assert Persistence(1, 1).isolation(al, S[:, [1, 3]]).isolated.tolist()[3] == UNEXPLAINED
    with pytest.raises(ShapeError, match="pattern"):
        fault_hypotheses([1, 1], S)


def test_persistence_removes_the_coincidental_isolation_of_three_simultaneous_faults():
    """Three simultaneous sensor-gain faults of Hou, Wen & Chen (2011, sec. 4).

    Every residual alarms at the onset; afterwards the gain faults' effects pass through
    zero with the closed-loop outputs they multiply, so single residuals alarm alone for
    seconds (r2 alone around 9.3-10.2 s, r0 alone around 12.9-14.7 s for the full-quotient
    bank) and the momentary pattern equals one fault's signature.  No isolation may be
    decided at any time of the run: the decision is "multiple faults" naming all three.
    """
    from pathlib import Path

    from geomfdi.io.modelfile import load_model

    spec = load_model(Path(__file__).parents[1] / "examples" / "hou_wen_chen.toml")
    (sc,) = [s for s in spec.scenarios if s.name.startswith("gain steps on all three")]
    kw = dict(faults=sc.faults, x0=spec.x0, controller=spec.K, threshold=spec.threshold)
    full = gf.design_bank(spec.plant, spec.faults, spec.structure, method="full")
    (opt,) = [o for o in spec.methods if o.method == "exact"]
    example = gf.design_bank(spec.plant, spec.faults, spec.structure, poles=opt.poles)
    example = example.normalized(opt.normalize)
    k0 = int(np.searchsorted(spec.t, 8.0))
    for bank in (full, example):
        # per-sample decisions: "fault 0 isolated" 76-116 ms after the onset
        raw = gf.simulate(spec.plant, bank, spec.t, spec.u, **kw)
        assert all(ev.detection_delay == 0.0 for ev in raw.events)
        assert raw.events[0].outcome == "correct" and raw.events[0].isolation_delay < 0.12
        # a 50 ms minimum duration on the momentary pattern: still single-fault decisions
        free = gf.simulate(
            spec.plant, bank, spec.t, spec.u, persistence=gf.Persistence(25, 25, latch=False), **kw
        )
        assert np.any(free.isolated[k0:] >= 0)
        # the same confirmation with the held pattern: never a single fault, all run long
        res = gf.simulate(spec.plant, bank, spec.t, spec.u, persistence=25, **kw)
        assert not np.any(res.isolated >= 0)
        assert not np.any(res.alarms[:, :k0])
        decided = res.isolated[k0:] == MULTIPLE
        assert decided.any() and decided[int(np.argmax(decided)) :].all()
        assert np.all(res.suspects[:, k0:][:, decided])  # the hypothesis: faults 0, 1, 2
        assert [ev.outcome for ev in res.events] == ["multiple"] * 3
        assert all(ev.hypothesis == (0, 1, 2) and not ev.isolated for ev in res.events)
        assert all(ev.detected and ev.detection_delay < 0.06 for ev in res.events)
        m = res.metrics()
        assert m.isolation["multiple"] == 1.0
        assert m.confusion.tolist() == [[0, 0, 0, 1, 0]] * 3
    # the single-fault scenario of the same file is still isolated under the same rule
    (one,) = [s for s in spec.scenarios if s.name.startswith("sensor 0 gain")]
    res = gf.simulate(
        spec.plant, example, spec.t, spec.u, persistence=25, **{**kw, "faults": one.faults}
    )
    assert res.events[0].outcome == "correct" and res.events[0].isolation_delay < 0.2
    assert set(np.unique(res.isolated)) <= {NO_ALARM, UNEXPLAINED, 0}


def _hand_runs(window=None):
    t = np.arange(10) * 0.5
    S = np.eye(2, dtype=bool)
    z = np.zeros((2, 10), dtype=bool)
    a = z.copy()  # run A, fault 0 at t=2.5: false alarms at k=1,2 and 4; r0 from k=7
    a[0, [1, 2, 4, 7, 8, 9]] = True
    b = z.copy()  # run B, fault 1 at t=2.5: r0 at k=6 (a wrong decision), r1 from k=8
    b[0, 6] = True
    b[1, 8:] = True
    c = z.copy()  # run C, fault 0 at t=2.5: nothing
    faults = [gf.BiasFault(0, start=2.5, bias=1.0), gf.BiasFault(1, start=2.5, bias=1.0)]
    evs, fas = [], []
    for al, f, j in ((a, faults[0], 0), (b, faults[1], 1), (c, faults[0], 0)):
        iso = isolate(al, S).isolated
        evs.append(detection_events(t, al, iso, [f], [j], window=window))
        fas.append(false_alarms(al, 5))
    return evs, fas


def test_every_metric_against_a_hand_computed_case():
    evs, fas = _hand_runs()
    assert [(fa.samples, fa.alarm_samples, fa.events) for fa in fas] == [(5, 3, 2), (5, 0, 0)] + [
        (5, 0, 0)
    ]
    m = detection_metrics(evs, fas, 0.5, 2)
    assert m.far_per_sample == pytest.approx(3 / 15)
    assert m.far_per_run == pytest.approx(1 / 3)
    assert m.far_per_hour == pytest.approx(2 / (15 * 0.5 / 3600))  # 960 per hour
    assert m.detection_rate == pytest.approx(2 / 3)
    assert m.missed_detection_rate == pytest.approx(1 / 3)
    # detection delays 1.0 (A) and 0.5 (B)
    assert m.detection_delay["mean"] == pytest.approx(0.75)
    assert m.detection_delay["p50"] == pytest.approx(0.75)
    assert m.detection_delay["p90"] == pytest.approx(0.95)
    # isolation delays 1.0 (A, correct) and 1.5 (B: r1 alone from k=8)
    assert m.isolation_delay["mean"] == pytest.approx(1.25)
    assert m.isolation == pytest.approx(
        {"correct": 1 / 3, "wrong": 1 / 3, "multiple": 0.0, "none": 1 / 3}
    )
    # rows: true fault; columns: first decision (fault 0, fault 1, multiple, none)
    assert m.confusion.tolist() == [[1, 0, 0, 1], [1, 0, 0, 0]]
    assert "P_d 0.6667" in m.summary()


def test_detection_window_excludes_late_alarms():
    evs, fas = _hand_runs(window=1.0)  # samples 5..7 only
    a, b, c = (e[0] for e in evs)
    assert (a.detection_delay, a.isolation_delay, a.outcome) == (1.0, 1.0, "correct")
    assert (b.detection_delay, b.isolation_delay, b.outcome) == (0.5, None, "wrong")
    assert b.window_end == 3.5 and not c.detected
    m = detection_metrics(evs, fas, 0.5, 2)
    assert m.isolation_delay["mean"] == pytest.approx(1.0)
    # the metrics of one fault position only
    with pytest.raises(GeomFDIError, match="which"):
        detection_metrics(evs, fas, 0.5, 2, which=3)


def test_pattern_decisions_decide_each_distinct_pattern_once_like_sample_by_sample():
    from geomfdi.evaluation.persistence import _decide_patterns, pattern_decisions

    rng = np.random.default_rng(7)
    for trial in range(24):
        nres, nf = int(rng.integers(1, 8)), int(rng.integers(1, 8))
        S = rng.random((nres, nf)) < 0.5
        lead = [(), (3,), (2, 2)][trial % 3]
        pat = rng.random((*lead, nres, int(rng.integers(300, 900)))) < rng.uniform(0.05, 0.6)
        fast, ref = pattern_decisions(pat, S), _decide_patterns(pat, S)
        assert fast.isolated.shape == ref.isolated.shape
        assert np.array_equal(fast.isolated, ref.isolated)
        assert np.array_equal(fast.candidates, ref.candidates)
        assert np.array_equal(fast.suspects, ref.suspects)
