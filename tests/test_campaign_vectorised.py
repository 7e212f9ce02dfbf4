"""Monte-Carlo work vectorised over runs equals the run-by-run definitions, bit for bit.

Fault profiles of a sweep composed for all runs at once (runs of another structure, or
with callable or held values, composed one by one), structure columns matched once per
channel, the campaign's scores and isolation, the per-run summaries of a batch, the
persistence stages with their short-window shortcuts, and noise drawn into reused
buffers: each is compared with a direct per-run (or per-sample) computation on random
data.
"""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.campaign.runner import evaluate_runs, isolate_runs
from geomfdi.evaluation.decision import AMBIGUOUS, MULTIPLE, NO_ALARM, UNEXPLAINED
from geomfdi.evaluation.persistence import (
    Persistence,
    held_pattern,
    k_of_n,
    pattern_decisions,
    pattern_table,
    settle,
)
from geomfdi.simulation.noise import NoiseStream
from geomfdi.simulation.profiles import fault_profiles, profile_groups, structure_key
from geomfdi.simulation.signals import fault_profile

Q = 4


def _random_list(rng: np.random.Generator, t: np.ndarray, kind: int) -> list:
    """A fault list of one of a few structures; sizes (and callables) drawn at random."""
    on, off = float(t[rng.integers(5, 30)]), float(t[rng.integers(35, 60)])
    z = float(rng.normal())
    if kind == 0:  # a sweep of biases
        return [gf.BiasFault(1, start=float(t[12]), bias=z)]
    if kind == 1:  # gain then bias on one sensor, a stuck value on another, with an end
        return [
            gf.GainFault(2, start=float(t[20]), gain=1 + z, bias=0.5 * z, end=float(t[50])),
            gf.BiasFault(2, start=float(t[31]), bias=-z),
            gf.StuckFault(0, start=float(t[40]), value=z),
        ]
    if kind == 2:  # no fault
        return []
    if kind == 3:  # a random window (its own structure)
        return [gf.GainFault(3, start=on, gain=2 + z, end=off)]
    if kind == 4:  # a callable bias: composed alone
        return [gf.BiasFault(1, start=on, bias=lambda tt, z=z: z * (tt - on))]
    return [gf.StuckFault(2, start=on), gf.BiasFault(2, start=off, bias=z)]  # held: alone


@pytest.mark.parametrize("seed", range(6))
def test_fault_profiles_equal_the_per_run_composition(seed):
    rng = np.random.default_rng(seed)
    t = np.arange(64) * 0.05
    R = 9
    kinds = rng.integers(0, 6, R) if seed else np.zeros(R, dtype=int)
    lists = [_random_list(rng, t, int(k)) for k in kinds]
    y0 = rng.standard_normal((R, Q, t.size))
    holds = [{} for _ in range(R)]
    holds_ref = [{} for _ in range(R)]
    groups = profile_groups(lists)
    assert sorted(groups.alone) == [r for r in range(R) if structure_key(lists[r]) is None]
    # windows straddling the onsets, ends and held readings, states carried across them
    cuts = [0, *sorted(rng.choice(np.arange(1, 63), 4, replace=False)), 64]
    for k0, k1 in zip(cuts[:-1], cuts[1:], strict=True):
        k1e = min(k1 + 1, 64)
        eta, eta_l, lam, lam_l = fault_profiles(
            lists, t, y0[..., k0:k1e], q=Q, k0=k0, k1=k1e, holds=holds,
            sensors=range(Q), y0_start=k0, groups=groups if seed % 2 else None,
        )  # fmt: skip
        for r in range(R):
            ref = fault_profile(
                lists[r], t, y0[r : r + 1, :, k0:k1e], q=Q, k0=k0, k1=k1e,
                holds=holds_ref[r], sensors=range(Q), y0_start=k0,
            )  # fmt: skip
            np.testing.assert_array_equal(eta[:, r], ref.eta)
            np.testing.assert_array_equal(eta_l[:, r], ref.eta_left)
            np.testing.assert_array_equal(lam[:, r], ref.lam[-1])
            np.testing.assert_array_equal(lam_l[:, r], ref.lam_left[-1])
    if seed == 0:  # one structure: no run composed alone, and the sizes do differ
        assert not groups.alone and len(groups.groups) == 1
        assert np.unique(lam[1, :, -1]).size == R


def test_structure_key_separates_what_the_profile_depends_on():
    a = gf.GainFault(1, start=1.0, gain=2.0)
    assert structure_key([a]) == structure_key([gf.GainFault(1, start=1.0, gain=3.0, bias=1)])
    for other in (
        gf.GainFault(0, start=1.0, gain=2.0),
        gf.GainFault(1, start=1.5, gain=2.0),
        gf.GainFault(1, start=1.0, gain=2.0, end=3.0),
        gf.BiasFault(1, start=1.0, bias=2.0),
    ):
        assert structure_key([other]) != structure_key([a])
    assert structure_key([gf.GainFault(1, start=1.0, gain=lambda tt: 1 + tt)]) is None
    assert structure_key([gf.StuckFault(1, start=1.0)]) is None
    assert structure_key([gf.StuckFault(1, start=1.0, value=0.0)]) is not None


def test_structure_columns_cached_per_channel_equal_the_matched_ones():
    from geomfdi.simulation.schedule import structure_columns

    plant = gf.Plant(-np.eye(3), np.eye(3)[:, :2], np.eye(3))
    design = [gf.SensorFault(2), gf.SensorFault(0), gf.ActuatorFault(plant.B[:, 1])]
    cache: dict = {}
    lists = [
        [gf.BiasFault(0, start=1.0, bias=z), gf.ActuatorBiasFault(1, start=2.0, bias=z)]
        for z in (0.1, 0.2)
    ] + [[gf.BiasFault(1, start=1.0, bias=0.3)], [gf.ActuatorBiasFault(0, start=1.0, bias=1)]]
    lists += [[gf.AdditiveFault(design[k], start=1.0, size=z)] for k in (0, 2) for z in (1, 2)]
    for fl in lists:
        assert structure_columns(fl, design, plant, cache) == structure_columns(fl, design, plant)
    assert structure_columns(lists[0], design, plant, cache) == [1, 2]
    assert structure_columns(lists[2], design, plant, cache) == [None]
    got = [structure_columns(fl, design, plant, cache) for fl in lists[4:]]
    assert got == [[0], [0], [2], [2]]


# ------------------------------------------------------------------ evaluation
def _random_statistic(rng, R, n, N):
    """Chi-square-like statistics: mostly below 1, with alarm episodes after the onset."""
    s = rng.chisquare(2, (R, n, N)) / 12
    for r in range(R):
        k = rng.integers(N // 3, N)
        s[r, rng.random(n) < 0.6, k:] *= rng.uniform(1, 10)
    return s


def _per_run_scores(t, stat, thr, onsets, window, eval_start):
    """The scores and delays of each run from its masks (the definition)."""
    tol = 1e-9 * max(1.0, float(np.abs(t).max()))
    out = {k: [] for k in ("score_pre", "score_post", "delay")}
    for r, on in enumerate(onsets):
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(np.isfinite(thr)[:, None], stat[r] / thr[:, None], 0.0)
        z = np.vstack([z, z.max(axis=0)])
        post = (t >= on - tol) & (t < on + window - tol)
        pre = (t < on - tol) & (t >= max(eval_start, on - window) - tol)
        out["score_pre"].append(np.where(pre, z, -np.inf).max(axis=1))
        out["score_post"].append(np.where(post, z, -np.inf).max(axis=1))
        hit = post & (z > 1)
        out["delay"].append(np.where(hit.any(1), t[np.argmax(hit, 1)] - on, np.nan))
    return {k: np.array(v) for k, v in out.items()}


@pytest.mark.parametrize("seed", range(4))
def test_campaign_scores_equal_the_per_run_masks(seed):
    rng = np.random.default_rng(seed)
    t = np.arange(300) * 0.01
    R, n = 12, 3
    stat = _random_statistic(rng, R, n, t.size)
    thr = np.array([1.0, 0.8, np.inf if seed % 2 else 1.2])
    onsets = rng.choice([0.8, 1.5, 2.95], R)  # the last: a detection window cut short
    got = evaluate_runs(t, stat, thr, onsets, 0.5, 0.2)
    ref = _per_run_scores(t, stat, thr, onsets, 0.5, 0.2)
    for k in ref:
        np.testing.assert_array_equal(got[k], ref[k])
    assert np.isfinite(got["delay"]).any() and np.isnan(got["delay"]).any()


def _per_run_isolation(t, stat, thr, S, rule, truth, sets, onsets, window, eval_start):
    """Isolation of each run through :meth:`Persistence.isolation` (the definition)."""
    tol = 1e-9 * max(1.0, float(np.abs(t).max()))
    out = {k: [] for k in ("decision", "outcome", "iso_delay")}
    for r, on in enumerate(onsets):
        al = (stat[r] > thr[:, None]) & (t >= eval_start - tol)
        iso = rule.isolation(rule.apply(al), S) if rule else gf.isolate(al, S)
        dec = iso.isolated
        post = (t >= on - tol) & (t < on + window - tol)
        made = np.flatnonzero(post & ((dec >= 0) | (dec == MULTIPLE)))
        if truth[r] == MULTIPLE:
            want = np.isin(np.arange(S.shape[1]), list(sets[r]))
            right = (dec == MULTIPLE) & np.all(iso.suspects == want[:, None], axis=0)
        else:
            right = (dec == truth[r]) & (truth[r] >= 0)
        right = np.flatnonzero(right & post)
        out["decision"].append(dec[made[0]] if made.size else -1)
        ok = made.size and right.size and right[0] == made[0] and truth[r] != -1
        out["outcome"].append(2 if not made.size else 0 if ok else 1)
        out["iso_delay"].append(t[right[0]] - on if right.size else np.nan)
    return {k: np.array(v) for k, v in out.items()}


RULES = [Persistence(2, 3), Persistence(3, 12, reset=7), Persistence(1, 1), None]


@pytest.mark.parametrize("rule", [*RULES, Persistence(2, 2, latch=False)])
def test_campaign_isolation_equals_the_per_run_rule(rule):
    rng = np.random.default_rng(7)
    t = np.arange(400) * 0.01
    S = np.array([[1, 0, 1, 0], [0, 1, 1, 0], [1, 1, 0, 1]], dtype=bool)
    R = 16
    stat = _random_statistic(rng, R, 3, t.size)
    thr = np.array([1.0, 0.9, 1.1])
    truth = rng.choice([0, 1, 2, 3, -1, -2, MULTIPLE], R)
    truth[:3] = MULTIPLE
    sets = [frozenset({0, 1}) if tr == MULTIPLE else frozenset() for tr in truth]
    sets[1] = frozenset({1, 3})
    onsets = rng.choice([1.0, 2.0], R)
    got = isolate_runs(t, stat, thr, S, rule, truth, sets, onsets, 1.0, 0.3)
    ref = _per_run_isolation(t, stat, thr, S, rule, truth, sets, onsets, 1.0, 0.3)
    for k in ref:
        np.testing.assert_array_equal(got[k], ref[k])
    np.testing.assert_array_equal(got["truth"], truth)
    assert set(got["outcome"]) >= {1, 2}


# ------------------------------------------------------------------ persistence
@pytest.mark.parametrize("n", [1, 2, 3, 8, 9, 20])
def test_k_of_n_and_settle_equal_their_windowed_counts(n):
    rng = np.random.default_rng(n)
    f = rng.random((2, 3, 60)) < 0.4
    raw = rng.choice([NO_ALARM, UNEXPLAINED, AMBIGUOUS, MULTIPLE, 0, 1, 2, 7], (2, 60))
    for k in sorted({1, max(1, n // 2), n}):
        c = np.array([f[..., max(0, j - n + 1) : j + 1].sum(-1) for j in range(60)])
        np.testing.assert_array_equal(k_of_n(f, k, n), np.moveaxis(c, 0, -1) >= k)
        out = settle(raw, k, n, 3)
        for i in np.ndindex(raw.shape):
            d, j = raw[i], i[-1]
            win = raw[i[:-1]][max(0, j - n + 1) : j + 1]
            if d in (NO_ALARM, AMBIGUOUS):
                assert out[i] == d
            elif (0 <= d < 3 or d == MULTIPLE) and np.sum(win == d) >= k:
                assert out[i] == d
            else:
                assert out[i] == UNEXPLAINED
        assert out.dtype == np.int64


def test_held_pattern_without_reset_is_the_running_or():
    rng = np.random.default_rng(3)
    a = rng.random((4, 3, 50)) < 0.05
    a[0] = False
    np.testing.assert_array_equal(held_pattern(a), np.logical_or.accumulate(a, axis=-1))
    assert held_pattern(a[..., :0]).shape == (4, 3, 0)


@pytest.mark.parametrize("nres", [3, 8, 10, 25])
def test_pattern_table_decides_each_sample_as_its_pattern(nres):
    rng = np.random.default_rng(nres)
    S = np.zeros((nres, 5), dtype=bool)
    S[[0, 2], 0] = S[[0, 2], 1] = True  # two faults share a column: AMBIGUOUS
    S[[0, 1], 2] = S[2, 3] = S[[1, nres - 1], 4] = True
    pattern = rng.random((3, nres, 200)) < 0.3
    pattern[..., ::7] = S[:, 0:1]  # patterns equal to a column
    pattern[..., 1::7] = S[:, 2:3] | S[:, 3:4]  # the union of two: MULTIPLE
    index, table = pattern_table(pattern, S)
    iso = pattern_decisions(pattern, S)
    for r, j in [(0, 0), (1, 7), (2, 8), (0, 199), (2, 15)]:
        one = pattern_decisions(pattern[r, :, j : j + 1], S)  # decided alone
        assert iso.isolated[r, j] == one.isolated[0] == table.isolated[index[r, j]]
        np.testing.assert_array_equal(iso.suspects[r, :, j], one.suspects[:, 0])
        np.testing.assert_array_equal(iso.candidates[r, :, j], one.candidates[:, 0])
    small = pattern_decisions(pattern[0, :, :50], S)  # the per-sample path (no table)
    np.testing.assert_array_equal(iso.isolated[0, :50], small.isolated)
    np.testing.assert_array_equal(iso.suspects[0, :, :50], small.suspects)
    assert {MULTIPLE, AMBIGUOUS, UNEXPLAINED} <= set(np.unique(iso.isolated))


# ------------------------------------------------------------------ batch summaries
def test_run_summaries_of_chunks_of_runs_equal_the_whole_record():
    from geomfdi.evaluation.decision import detection_events
    from geomfdi.evaluation.metrics import false_alarms
    from geomfdi.evaluation.persistence import decisions
    from geomfdi.simulation.streaming import DecisionStream, RunSummary

    rng = np.random.default_rng(11)
    N, R = 300, 7
    t = np.arange(N) * 0.01
    res = rng.standard_normal((R, 3, N)) * np.linspace(0.5, 2.5, N)
    S = np.array([[1, 0, 1], [0, 1, 1], [1, 1, 0]], dtype=bool)
    thr = gf.Threshold(np.array([1.4, 1.6, 1.2]))
    rule = Persistence(2, 3)
    faults = [
        [gf.BiasFault(0, start=0.5 + 0.3 * r, bias=1.0), gf.BiasFault(1, start=2.0, bias=1.0)]
        if r % 3
        else [gf.BiasFault(2, start=1.0, bias=1.0)] * (r % 2)
        for r in range(R)
    ]
    cols = [[0, None][: len(fl)] if r % 3 else [2] * len(fl) for r, fl in enumerate(faults)]
    al, iso = decisions(res, thr, S, rule)
    summ = RunSummary(t, faults, cols, 3, 0.8)
    quiet = RunSummary(t, faults, cols, 3, 0.8)
    for a, b in ((0, 3), (3, 7)):  # chunks of runs, each cut in time
        ds = DecisionStream(thr, S, rule)
        for s, e in ((0, 70), (70, 71), (71, 200), (200, N)):
            x, i = ds.step(res[a:b, :, s:e])
            summ.update(s, res[a:b, :, s:e], x, i.isolated, a, i.suspects)
            quiet.update(s, res[a:b, :, s:e], None, None, a)
    np.testing.assert_array_equal(summ.peak, np.max(np.abs(res), axis=-1))
    np.testing.assert_array_equal(quiet.peak, summ.peak)
    for r in range(R):
        ref = detection_events(
            t, al[r], iso.isolated[r], faults[r], cols[r], window=0.8, suspects=iso.suspects[r]
        )
        got = summ.events(r)
        assert [(e.detection_time, e.isolation_time, e.decided, e.residuals, e.hypothesis)
                for e in got] == [(e.detection_time, e.isolation_time, e.decided, e.residuals,
                                   e.hypothesis) for e in ref]  # fmt: skip
        healthy = int(np.searchsorted(t, min([f.start for f in faults[r]], default=9) - 1e-9))
        assert summ.false_alarms(r) == false_alarms(al[r], healthy)
        assert quiet.false_alarms(r) == false_alarms(np.zeros_like(al[r]), healthy)
        assert all(e.detection_time is None and e.decided is None for e in quiet.events(r))
    assert any(e.detection_time is not None for r in range(R) for e in summ.events(r))


# ------------------------------------------------------------------ noise
def test_noise_streams_sharing_buffers_draw_what_each_generator_draws():
    seeds = np.random.SeedSequence(5).spawn(4)
    N, block = 700, 256
    pool: list = []
    for chunk in (seeds[:2], seeds[2:]):  # the second chunk of runs reuses the buffers
        streams = [NoiseStream(np.random.default_rng(s), 2, 1, N, block, pool) for s in chunk]
        got = [([], []) for _ in chunk]
        for s, e in ((0, 100), (99, 300), (299, 520), (519, 700)):
            for st, g in zip(streams, got, strict=True):
                zv, zw = st.take(s, e)  # used before the next stream's take
                g[0].append(zv[:, : e - s - (e < N)].copy())
                g[1].append(zw[:, : e - s - (e < N)].copy())
        for st in streams:
            st.release()
        for sd, (gv, gw) in zip(chunk, got, strict=True):
            rng = np.random.default_rng(sd)
            ref_v, ref_w = [], []
            for b0 in range(0, N, block):  # the draws of each block: measurement, process
                Lb = min(block, N - b0)
                ref_v.append(rng.standard_normal((2, Lb)))
                ref_w.append(rng.standard_normal((1, Lb)))
            np.testing.assert_array_equal(np.hstack(gv), np.hstack(ref_v))
            np.testing.assert_array_equal(np.hstack(gw), np.hstack(ref_w))
    assert pool  # the released blocks are kept for the next runs


@pytest.mark.parametrize("diagonal", [True, False])
def test_noise_scaling_equals_the_matrix_product(diagonal):
    from geomfdi.simulation.simulate import _scaling

    rng = np.random.default_rng(2)
    Lf = np.diag(rng.uniform(1e-3, 2.0, 4)) if diagonal else np.tril(rng.normal(size=(4, 4)))
    z = rng.standard_normal((4, 5000))
    out = np.empty((4, 2, 5000))[:, 1]  # a strided destination, as in a window of runs
    _scaling(Lf)(z, out=out)
    np.testing.assert_array_equal(out, Lf @ z)
