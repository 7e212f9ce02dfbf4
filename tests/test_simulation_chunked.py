"""Long records in time chunks: chunked == unchunked, and memory proportional to the chunk.

``gf.limits.limits(chunk_memory=...)`` sets the working-memory budget of one chunk; a
tiny budget cuts a short record into many chunks of a few dozen samples, so that fault
onsets, held readings, persistence windows and noise blocks all straddle chunk
boundaries.  The results must not depend on it (1e-12, same decisions and events).
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from hwc_bank import K_FB, P_PAPER, X0, A, B, C, hand_generator, leaky_bank, v_ext

import geomfdi as gf
from geomfdi.errors import GeomFDIError
from geomfdi.evaluation.decision import MULTIPLE
from geomfdi.simulation.noise import NoiseStream
from geomfdi.simulation.streaming import MIN_CHUNK, chunk_plan, time_chunks

TINY = 3e4  # bytes: chunks of a few dozen samples


def setup(vector: bool = False, dt: float = 0.0):
    """The Hou-Wen-Chen plant and three generators ``F P = P A + E C``, ``M P = H C`` (continuous),
    or a stable discrete plant with the same construction (``dt > 0``)."""
    Ap = A if dt == 0 else 0.3 * A / max(abs(np.linalg.eigvals(A)))
    plant = gf.Plant(Ap, B, C, dt=dt)
    f = -2.0 if dt == 0 else 0.5
    gens = [hand_generator(plant, P_PAPER[j : j + 1], f) for j in range(3)]
    if vector:  # a generator with two residual components (rows of two paper generators)
        gens[2] = hand_generator(gf.Plant(A, B, C), P_PAPER[:2])
    return plant, leaky_bank(gens)


FAULTS = [
    gf.BiasFault(1, start=1.234, bias=0.05),  # onsets off the chunk grid
    gf.GainFault(0, start=2.017, gain=1.4, bias=0.01, end=3.5),
    gf.StuckFault(2, start=3.003),  # holds the (noisy) reading at its start
    gf.GainFault(1, start=4.1, gain=lambda s: 1.0 + 0.2 * (s - 4.1)),  # time-varying
]


def close(a, b, tol=1e-12):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape
    scale = max(1.0, float(np.max(np.abs(b))) if b.size else 1.0)
    assert np.max(np.abs(a - b), initial=0.0) <= tol * scale


def same_events(ea, eb):
    assert len(ea) == len(eb)
    for a, b in zip(ea, eb, strict=True):
        assert a.fault is b.fault and a.index == b.index and a.onset == b.onset
        assert a.detection_time == b.detection_time and a.isolation_time == b.isolation_time
        assert a.decided == b.decided and a.residuals == b.residuals
        assert a.hypothesis == b.hypothesis


def assert_same_result(a, b):
    for name in ("x", "y", "y_healthy", "u", "residuals"):
        close(getattr(a, name), getattr(b, name))
    for name in ("alarms", "isolated", "candidates", "suspects"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    for ra, rb in zip(a.residual_vectors, b.residual_vectors, strict=True):
        assert (ra is None) == (rb is None)
        if ra is not None:
            close(ra, rb)
    for wa, wb in zip(a.w, b.w, strict=True):
        assert (wa is None) == (wb is None)
        if wa is not None:
            close(wa, wb)
    same_events(a.events, b.events)


def test_chunk_plan_follows_the_budget():
    with gf.limits.limits(chunk_memory=1e6):
        assert chunk_plan(10**6, 1, 100.0) == (1, 10**4)
        assert chunk_plan(100, 50, 100.0) == (50, 100)  # whole records of all runs fit
        assert chunk_plan(10**6, 8, 100.0, runs_per_chunk=4) == (4, 2500)
    with gf.limits.limits(chunk_memory=1.0):
        assert chunk_plan(10**6, 1, 100.0) == (1, MIN_CHUNK)
    chunks = time_chunks(1000, 64)
    assert chunks[0] == (0, 64, 65) and chunks[-1][1:] == (1000, 1000)
    assert all(b[0] == a[1] for a, b in zip(chunks[:-1], chunks[1:], strict=True))
    with pytest.raises(GeomFDIError) as err:
        gf.limits.set_limits(chunk_memory=0)
    assert err.value.argument == "chunk_memory"


def test_noise_stream_is_independent_of_the_ranges_asked():
    N, block = 1000, 128
    full = NoiseStream(np.random.default_rng(5), 2, 1, N, block=block).take(0, N)
    st = NoiseStream(np.random.default_rng(5), 2, 1, N, block=block)
    cuts = [0, 7, 128, 129, 300, 555, 999, 1000]
    for s, e in zip(cuts[:-1], cuts[1:], strict=True):
        zv, zw = st.take(s, min(e + 1, N))  # overlapping by one sample, like the chunks
        np.testing.assert_array_equal(zv, full[0][:, s : min(e + 1, N)])
        np.testing.assert_array_equal(zw, full[1][:, s : min(e + 1, N)])
    # one block: exactly numpy's (rows, N) draw, measurement rows first
    rng = np.random.default_rng(5)
    zv, zw = NoiseStream(np.random.default_rng(5), 2, 1, 100, block=block).take(0, 100)
    np.testing.assert_array_equal(zv, rng.standard_normal((2, 100)))
    np.testing.assert_array_equal(zw, rng.standard_normal((1, 100)))
    with pytest.raises(GeomFDIError):
        st.take(0, 10)  # the past is gone


RULES = [  # (latch, reset): held pattern to the end / with episodes / memoryless
    (True, None),
    (True, 4),
    (False, None),
]


@pytest.mark.parametrize("seed", range(3))
def test_decision_table_equals_isolate_on_the_whole_record(seed):
    """Without a rule, :meth:`DecisionStream.decide` reads each sample's decision from
    the table of the alarm patterns: equal to :func:`isolate` on the whole record (every
    kind of decision occurs), the alarms written into ``out``; the summaries fed with
    the chunk peaks equal :func:`detection_events`; a nan still raises."""
    from geomfdi.evaluation.decision import (
        AMBIGUOUS,
        NO_ALARM,
        UNEXPLAINED,
        detection_events,
        isolate,
    )
    from geomfdi.simulation.streaming import DecisionStream, RunSummary

    rng = np.random.default_rng(seed)
    N, R, n = 500, 3, 5
    t = np.arange(N) * 0.01
    res = rng.standard_normal((R, n, N)) * np.linspace(0.2, 1.5, N)
    S = np.array(
        [[1, 0, 1, 1], [0, 1, 1, 1], [1, 1, 0, 0], [0, 0, 1, 1], [0, 0, 0, 0]], dtype=bool
    )  # columns 2 and 3 equal: ambiguous; row 4: a missing generator
    values = rng.uniform(0.6, 1.4, n)
    values[4] = np.inf
    thr = gf.Threshold(values)
    al = thr.alarms(res)
    iso = isolate(al, S)
    faults = [[gf.BiasFault(0, start=1.0 + r, bias=1.0)] for r in range(R)]
    ds = DecisionStream(thr, S, None)
    summ = RunSummary(t, faults, [[0]] * R, n, None)
    cuts = np.unique(np.concatenate([[0, N], rng.integers(1, N, 7)]))
    for s, e in zip(cuts[:-1], cuts[1:], strict=True):
        chunk = res[..., s:e]
        absr = np.abs(chunk)
        peaks = absr.max(axis=-1)
        out = np.empty(chunk.shape, dtype=bool)
        a, isolated, sus = ds.decide(chunk, absolute=absr, peaks=peaks, out=out)
        assert a is out and sus is None
        np.testing.assert_array_equal(a, al[..., s:e])
        np.testing.assert_array_equal(isolated, iso.isolated[..., s:e])
        summ.update(int(s), chunk, a, isolated, 0, sus, peaks=peaks)
    kinds = set(np.unique(iso.isolated).tolist())
    assert {NO_ALARM, UNEXPLAINED, AMBIGUOUS} <= kinds and max(kinds) >= 0
    np.testing.assert_array_equal(summ.peak, np.max(np.abs(res), axis=-1))
    for r in range(R):
        same_events(summ.events(r), detection_events(t, al[r], iso.isolated[r], faults[r], [0]))
    bad = res[..., :50].copy()
    bad[0, 1, 7] = np.nan
    absr = np.abs(bad)
    with pytest.raises(GeomFDIError):
        DecisionStream(thr, S, None).decide(bad, absolute=absr, peaks=absr.max(axis=-1))


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize(("latch", "reset"), RULES)
def test_decision_stream_and_run_summary_equal_the_whole_record(seed, latch, reset):
    """Random residuals cut at random points: the chunked decisions (moving RMS, the
    k-of-n confirmation, the pattern held over alarm episodes and the settling of the
    decisions all looking back across the cuts) and the accumulated events (with the
    hypothesis of a MULTIPLE decision), peaks and false alarms equal those of the whole
    record (:func:`decisions` and :func:`detection_events`)."""
    from geomfdi.evaluation.decision import detection_events
    from geomfdi.evaluation.metrics import false_alarms
    from geomfdi.evaluation.persistence import Persistence, decisions
    from geomfdi.simulation.streaming import DecisionStream, RunSummary

    rng = np.random.default_rng(seed)
    N, R = 400, 3
    t = np.arange(N) * 0.01
    res = rng.standard_normal((R, 3, N)) * np.linspace(0.5, 2.0, N)
    S = np.array([[1, 0, 1], [0, 1, 1], [1, 1, 0]], dtype=bool)
    thr = gf.Threshold(np.array([1.2, 1.5, 1.0]), statistic="rms", window=1 + seed)
    rule = Persistence(2, 3 + seed, latch=latch, reset=reset)
    faults = [
        [gf.BiasFault(0, start=1.0 + r, bias=1.0), gf.BiasFault(1, start=2.5, bias=1.0)]
        for r in range(R)
    ]
    cols = [[0, 1]] * R
    window = None if seed % 2 else 0.7
    al, iso = decisions(res, thr, S, rule)
    ds = DecisionStream(thr, S, rule)
    summ = RunSummary(t, faults, cols, 3, window)
    cuts = np.unique(np.concatenate([[0, N], rng.integers(1, N, 9)]))
    for s, e in zip(cuts[:-1], cuts[1:], strict=True):
        a, i = ds.step(res[..., s:e])
        np.testing.assert_array_equal(a, al[..., s:e])
        np.testing.assert_array_equal(i.isolated, iso.isolated[..., s:e])
        np.testing.assert_array_equal(i.candidates, iso.candidates[..., s:e])
        np.testing.assert_array_equal(i.suspects, iso.suspects[..., s:e])
        summ.update(int(s), res[..., s:e], a, i.isolated, 0, i.suspects)
    np.testing.assert_array_equal(summ.peak, np.max(np.abs(res), axis=-1))
    for r in range(R):
        ref = detection_events(
            t, al[r], iso.isolated[r], faults[r], cols[r], window=window, suspects=iso.suspects[r]
        )
        same_events(summ.events(r), ref)
        first = min(1.0 + r, 2.5)  # the healthy part ends at the first onset
        assert summ.false_alarms(r) == false_alarms(al[r], int(np.searchsorted(t, first - 1e-12)))
    assert al.any() and not al.all()
    # the rule is not trivial here: the held pattern gives MULTIPLE decisions, and the
    # memory changes the decisions
    assert np.any(iso.isolated == MULTIPLE) or not latch
    other = Persistence(2, 3 + seed, latch=not latch, reset=reset)
    assert not np.array_equal(decisions(res, thr, S, other)[1].isolated, iso.isolated)


def test_held_pattern_episode_across_every_chunk_boundary():
    """An alarm episode whose pattern grows, pauses (fewer quiet samples than ``reset``),
    ends and restarts: for every single cut point, and for cuts at every sample, the
    chunked decisions equal the whole record's; the held residual of the first part
    makes the second part MULTIPLE, where the memoryless rule decides a single fault."""
    from geomfdi.evaluation.persistence import Persistence, decisions
    from geomfdi.simulation.streaming import DecisionStream

    S = np.array([[1, 0], [0, 1]], dtype=bool)
    N = 40
    r = np.zeros((1, 2, N))
    r[0, 0, 3:9] = 1.0  # fault 0's residual ...
    r[0, 1, 11:20] = 1.0  # ... then fault 1's after 2 quiet samples (same episode)
    r[0, 1, 30:37] = 1.0  # a new episode after 10 quiet samples: fault 1 alone
    thr = gf.Threshold(np.array([0.5, 0.5]))
    for rule in (Persistence(2, 3, reset=5), Persistence(2, 3), Persistence(2, 3, latch=False)):
        al, iso = decisions(r, thr, S, rule)
        cut_sets = [[c] for c in range(1, N)] + [list(range(1, N))]
        for cuts in cut_sets:
            ds = DecisionStream(thr, S, rule)
            got = [ds.step(r[..., s:e]) for s, e in zip([0, *cuts], [*cuts, N], strict=True)]
            np.testing.assert_array_equal(np.concatenate([a for a, _ in got], -1), al)
            for name in ("isolated", "candidates", "suspects"):
                np.testing.assert_array_equal(
                    np.concatenate([getattr(i, name) for _, i in got], -1), getattr(iso, name)
                )
        dec = iso.isolated[0]
        if not rule.latch:
            assert dec[16] == 1 and dec[34] == 1
        elif rule.reset is None:  # the first episode never ends
            assert dec[16] == MULTIPLE and dec[34] == MULTIPLE
        else:  # it ends 5 quiet samples after sample 20: fault 1 alone in the next one
            assert dec[16] == MULTIPLE and dec[34] == 1


def test_seed001_three_faults_multiple_chunked():
    """The scenario of three simultaneous sensor-gain faults (Hou, Wen & Chen
    2011, sec. 4) under the held-pattern rule: in chunks of a few dozen samples the
    decisions are MULTIPLE with the hypothesis (0, 1, 2), as on the whole record, in
    simulate and in a summary-only batch."""
    from pathlib import Path

    from geomfdi.io.modelfile import load_model

    spec = load_model(Path(__file__).parents[1] / "examples" / "hou_wen_chen.toml")
    (sc,) = [s for s in spec.scenarios if s.name.startswith("gain steps on all three")]
    bank = gf.design_bank(spec.plant, spec.faults, spec.structure, method="full")
    kw = dict(
        faults=sc.faults,
        x0=spec.x0,
        controller=spec.K,
        threshold=spec.threshold,
        persistence=25,
    )
    ref = gf.simulate(spec.plant, bank, spec.t, spec.u, **kw)
    with gf.limits.limits(chunk_memory=TINY):
        chunked = gf.simulate(spec.plant, bank, spec.t, spec.u, **kw)
        summ = gf.simulate_batch(
            spec.plant, bank, spec.t, spec.u, store="summary", progress=False, **kw
        )
    assert_same_result(chunked, ref)
    assert [ev.outcome for ev in chunked.events] == ["multiple"] * 3
    assert all(ev.hypothesis == (0, 1, 2) for ev in chunked.events)
    assert not np.any(chunked.isolated >= 0)
    same_events(summ.events[0], ref.events)


@pytest.mark.parametrize("vector", [False, True])
def test_simulate_chunked_equals_unchunked_with_noise_faults_and_persistence(vector):
    plant, bank = setup(vector)
    t = np.arange(0, 6.0, 0.01)
    noise = gf.Noise(measurement=[2e-3, 1e-3, 3e-3], process=[0.0, 1e-2, 0.0], seed=3)
    kw = dict(
        faults=FAULTS,
        x0=X0,
        controller=K_FB,
        noise=noise,
        threshold=0.03,
        persistence=(3, 5),
        detection_window=1.5,
        keep_states=True,
    )
    ref = gf.simulate(plant, bank, t, v_ext, **kw)
    with gf.limits.limits(chunk_memory=TINY):
        _, L = chunk_plan(t.size, 1, 1.0e3)
        assert L < 60  # many chunks
        chunked = gf.simulate(plant, bank, t, v_ext, **kw)
    assert_same_result(chunked, ref)
    assert ref.alarms.any() and any(ev.detected for ev in ref.events)
    # the persistence rule changed something across the record (not a trivial check)
    raw = gf.simulate(plant, bank, t, v_ext, **{**kw, "persistence": None})
    assert not np.array_equal(raw.alarms, ref.alarms)


def test_rms_statistic_and_discrete_plant_chunked():
    plant, bank = setup()
    dplant, dbank = setup(dt=0.01)
    t = np.arange(0, 4.0, 0.01)
    thr = gf.Threshold(np.full(3, 0.01), statistic="rms", window=7)
    for p, b, ctrl in ((plant, bank, K_FB), (dplant, dbank, None)):
        kw = dict(
            faults=[gf.BiasFault(0, start=1.505, bias=0.05), gf.StuckFault(1, start=2.5)],
            controller=ctrl,
            noise=gf.Noise(measurement=1e-3, seed=9),
            threshold=thr,
            persistence=2,
        )
        ref = gf.simulate(p, b, t, v_ext, **kw)
        with gf.limits.limits(chunk_memory=TINY):
            chunked = gf.simulate(p, b, t, v_ext, **kw)
        assert_same_result(chunked, ref)
        assert ref.alarms.any()


def test_noise_blocks_cross_chunk_boundaries():
    """A record longer than one noise block: the same draws whatever the chunks."""
    plant, bank = setup()
    t = np.arange(70_000) * 1e-3
    kw = dict(controller=K_FB, noise=gf.Noise(measurement=1e-3, seed=4), threshold=0.01)
    ref = gf.simulate(plant, bank, t, v_ext, **kw)
    with gf.limits.limits(chunk_memory=4e6):
        chunked = gf.simulate(plant, bank, t, v_ext, **kw)
    close(chunked.y_healthy, ref.y_healthy)
    close(chunked.residuals, ref.residuals)
    np.testing.assert_array_equal(chunked.alarms, ref.alarms)


@pytest.mark.parametrize("store", ["summary", "residuals", "all"])
def test_batch_chunked_equals_unchunked_and_single_runs(store):
    plant, bank = setup()
    t = np.arange(0, 6.0, 0.01)
    fault_lists = [
        [gf.BiasFault(0, start=2.0 + 0.137 * i, bias=0.02 * (i + 1)), gf.StuckFault(2, start=4.2)]
        for i in range(4)
    ]
    kw = dict(
        faults=fault_lists,
        x0=X0,
        controller=K_FB,
        noise=gf.Noise(measurement=2e-3, process=[0.0, 1e-2, 0.0], seed=8),
        threshold=0.04,
        persistence=(2, 3),
        detection_window=2.0,
        store=store,
        progress=False,
    )
    ref = gf.simulate_batch(plant, bank, t, v_ext, **kw)
    with gf.limits.limits(chunk_memory=TINY):
        chunked = gf.simulate_batch(plant, bank, t, v_ext, **kw)
        two = gf.simulate_batch(plant, bank, t, v_ext, chunk_size=2, **kw)
    for other in (chunked, two):
        close(other.peak, ref.peak)
        np.testing.assert_array_equal(other.false_alarm_counts, ref.false_alarm_counts)
        np.testing.assert_array_equal(other.healthy_samples, ref.healthy_samples)
        np.testing.assert_array_equal(other.false_alarm_events, ref.false_alarm_events)
        for ea, eb in zip(other.events, ref.events, strict=True):
            same_events(ea, eb)
        if store != "summary":
            close(other.residuals, ref.residuals)
            np.testing.assert_array_equal(other.alarms, ref.alarms)
            np.testing.assert_array_equal(other.isolated, ref.isolated)
    assert 0 < sum(ev.detected for e in ref.events for ev in e)
    # every run equals a single simulate with its seed (events through the whole-record
    # detection_events, peaks and false alarms through the result's own methods)
    for i in (0, 3):
        single = gf.simulate(
            plant,
            bank,
            t,
            v_ext,
            faults=fault_lists[i],
            x0=X0,
            controller=K_FB,
            noise=gf.Noise(measurement=2e-3, process=[0.0, 1e-2, 0.0], seed=ref.seeds[i]),
            threshold=0.04,
            persistence=(2, 3),
            detection_window=2.0,
        )
        same_events(chunked.events[i], single.events)
        close(chunked.peak[i], np.max(np.abs(single.residuals), axis=1))
        fa = single._false_alarms()
        assert chunked.healthy_samples[i] == fa.samples
        assert chunked.false_alarm_counts[i] == fa.alarm_samples
        assert chunked.false_alarm_events[i] == fa.events


def test_output_feedback_chunked_equals_unchunked():
    """Output feedback: the piecewise-LTI segments are cut at the chunk boundaries too
    (loop state, held readings and the stepped time-varying gain carried over)."""
    import control

    plant, bank = setup()
    t = np.arange(0, 4.5, 0.01)  # the time-varying gain stepped over its first 0.4 s
    ctrl = control.ss(-np.eye(3), np.eye(3), -0.5 * np.eye(3), np.zeros((3, 3)))
    kw = dict(
        faults=FAULTS,
        x0=X0,
        controller=ctrl,
        noise=gf.Noise(measurement=1e-3, process=[0.0, 1e-2, 0.0], seed=6),
        threshold=0.02,
        persistence=(2, 4),
    )
    ref = gf.simulate(plant, bank, t, v_ext, **kw)
    with gf.limits.limits(chunk_memory=TINY):
        chunked = gf.simulate(plant, bank, t, v_ext, **kw)
    assert_same_result(chunked, ref)
    close(chunked.xc, ref.xc)
    assert ref.info["stepped_samples"] == chunked.info["stepped_samples"] > 0
    assert ref.info["segments"] == chunked.info["segments"]


def test_output_feedback_batch_summary_matches_stored_residuals():
    import control

    plant, bank = setup()
    t = np.arange(0, 4.0, 0.01)
    ctrl = control.ss(-np.eye(3), np.eye(3), -0.5 * np.eye(3), np.zeros((3, 3)))
    kw = dict(
        runs=3,
        faults=[gf.BiasFault(0, start=2.0, bias=0.1)],
        controller=ctrl,
        noise=gf.Noise(measurement=1e-3, seed=2),
        threshold=0.02,
        progress=False,
    )
    full = gf.simulate_batch(plant, bank, t, **kw)
    with gf.limits.limits(chunk_memory=TINY):
        summ = gf.simulate_batch(plant, bank, t, store="summary", **kw)
    close(summ.peak, np.max(np.abs(full.residuals), axis=-1))
    for ea, eb in zip(summ.events, full.events, strict=True):
        same_events(ea, eb)


def _traced_peak(fn):
    tracemalloc.start()
    try:
        out = fn()
        return out, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


@pytest.mark.slow
def test_memory_is_proportional_to_the_chunk_not_the_record():
    """3e5-sample records with an 8 MiB chunk budget.

    The summary batch (2 runs) peaks at a few budgets plus the fixed work arrays of the
    recursion (about 8 MiB), not at a whole record of one run's signals (about 150 MB
    before chunking); a single record peaks at its returned arrays plus that (before
    chunking: about 2.9 times the returned arrays).
    """
    plant, bank = setup()
    N = 3 * 10**5
    t = np.arange(N) * 1e-3
    u = v_ext(t)
    budget = 8 * 2**20
    kw = dict(
        faults=[gf.BiasFault(0, start=200.0, bias=0.02)],
        controller=K_FB,
        noise=gf.Noise(measurement=2e-4, seed=1),
        threshold=0.01,
        persistence=(2, 3),
    )
    gf.simulate_batch(plant, bank, t[:500], u[:, :500], runs=2, store="summary", **kw)
    with gf.limits.limits(chunk_memory=budget):  # (modules imported above, not traced)
        batch, peak = _traced_peak(
            lambda: gf.simulate_batch(
                plant, bank, t, u, runs=2, store="summary", progress=False, **kw
            )
        )
        assert peak < 6 * budget, peak / 2**20
        assert all(e[0].detected for e in batch.events)
        res, peak = _traced_peak(lambda: gf.simulate(plant, bank, t, u, **kw))
    arrays = (res.x, res.y, res.y_healthy, res.u, res.residuals, res.alarms, res.isolated)
    arrays += (res.candidates, res.suspects)
    returned = sum(a.nbytes for a in arrays)
    assert peak < returned + 4 * budget, (peak / 2**20, returned / 2**20)


ACTUATOR_FAULTS = [
    gf.ActuatorGainFault(0, start=1.0, gain=0.6),  # onsets at chunk starts (L = 50) ...
    gf.ActuatorStuckFault(1, start=2.0),  # ... the held input is the carried left limit
    gf.ActuatorStuckFault(2, start=2.517, value=0.3, end=3.2),
    gf.ActuatorGainFault(2, start=3.61, gain=lambda s: 1.0 - 0.3 * (s - 3.61)),  # stepped
    gf.BiasFault(1, start=1.234, bias=0.02),
]


@pytest.mark.parametrize("feedback", ["state", "output"])
def test_closed_loop_actuator_faults_chunked_equals_unchunked(feedback, monkeypatch):
    """Actuator gain and stuck faults inside the loop: the piecewise-LTI segments are cut
    at the chunk boundaries too, the loop state, the commanded input at the boundary (a
    stuck actuator starting there holds it) and the stepped time-varying gain carried
    over; simulate and a batch of per-run fault lists give the unchunked results."""
    import importlib

    import control

    sim = importlib.import_module("geomfdi.simulation.simulate")  # the module, not the function
    plant, bank = setup()
    t = np.arange(0, 4.5, 0.01)
    ctrl = (
        K_FB
        if feedback == "state"
        else control.ss(-np.eye(3), np.eye(3), -0.5 * np.eye(3), np.zeros((3, 3)))
    )
    kw = dict(
        faults=ACTUATOR_FAULTS,
        x0=X0,
        controller=ctrl,
        noise=gf.Noise(measurement=1e-3, process=[0.0, 1e-2, 0.0], seed=2),
        threshold=0.02,
        persistence=gf.Persistence(2, 4, reset=20),
    )
    ref = gf.simulate(plant, bank, t, v_ext, **kw)
    with gf.limits.limits(chunk_memory=TINY):
        chunked = gf.simulate(plant, bank, t, v_ext, **kw)
    with monkeypatch.context() as mp:  # chunks of exactly 50 samples: onsets at their starts
        mp.setattr(sim, "chunk_plan", lambda N, runs, width, **_: (1, 50))
        fixed = gf.simulate(plant, bank, t, v_ext, **kw)
    for other in (chunked, fixed):
        assert_same_result(other, ref)
        assert other.info["stepped_samples"] == ref.info["stepped_samples"] > 0
    # the faults act inside the loop: the commanded input leaves the healthy loop's
    healthy = gf.simulate(plant, bank, t, v_ext, **{**kw, "faults": []})
    after = t >= 1.0
    assert np.max(np.abs(ref.u[:, after] - healthy.u[:, after])) > 1e-3
    close(ref.u[:, ~after], healthy.u[:, ~after], 1e-9)  # the open-loop engine, rounding
    assert ref.alarms.any()
    # a batch of per-run lists (the loop differs per run), in chunks
    lists = [ACTUATOR_FAULTS[:2], ACTUATOR_FAULTS[2:]]
    bkw = {**kw, "faults": lists, "store": "residuals", "progress": False}
    bref = gf.simulate_batch(plant, bank, t, v_ext, **bkw)
    with gf.limits.limits(chunk_memory=TINY):
        bch = gf.simulate_batch(plant, bank, t, v_ext, **bkw)
    close(bch.residuals, bref.residuals)
    np.testing.assert_array_equal(bch.isolated, bref.isolated)
    for ea, eb in zip(bch.events, bref.events, strict=True):
        same_events(ea, eb)


def test_actuator_gain_faults_are_not_exogenous_channels_under_feedback():
    """Under feedback the engines take actuator gain/stuck faults into the loop; building
    them as exogenous input channels (computed from ``u_ext``) is refused."""
    from geomfdi.simulation.closed_loop import split_actuator_faults
    from geomfdi.simulation.context import prepare, with_input_faults
    from geomfdi.simulation.schedule import fault_schedule

    plant, bank = setup()
    t = np.arange(0, 1.0, 0.01)
    sched = fault_schedule(ACTUATOR_FAULTS, plant)
    ctx = prepare(plant, bank, t, v_ext, None, None, K_FB, "foh", True, False)
    with pytest.raises(GeomFDIError, match="inside the loop") as err:
        with_input_faults(ctx, [sched])
    assert err.value.argument == "faults"
    rest, inside = split_actuator_faults(sched)
    assert inside == ACTUATOR_FAULTS[:4] and not rest.needs_input
    assert with_input_faults(ctx, [rest]) is ctx  # no additive input fault left
    open_ctx = prepare(plant, bank, t, v_ext, None, None, None, "foh", True, False)
    assert with_input_faults(open_ctx, [sched]).plant.nd == plant.nd + 3  # open loop: channels
