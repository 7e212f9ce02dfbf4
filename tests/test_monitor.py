"""gf.Monitor: step-by-step, chunked and recorded evaluation agree; state and errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from deploy_banks import DT, sampled_bank, seed_bank, vector_row_bank
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.evaluation.decision import MULTIPLE, NO_ALARM
from geomfdi.evaluation.persistence import decisions, held_pattern


@pytest.fixture(scope="module")
def bank() -> gf.ResidualBank:
    return sampled_bank()


def _data(q: int, m: int, N: int, seed: int, gaps: bool = True) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(N) * DT
    Y = np.vstack([np.sin((i + 1) * t) for i in range(q)]) + 0.3 * rng.normal(size=(q, N))
    U = np.vstack([np.cos((j + 1) * 0.7 * t) for j in range(m)]) + 0.1 * rng.normal(size=(m, N))
    if gaps and N > 50:
        Y[rng.integers(q), rng.integers(10, N - 10)] = np.nan
        Y[0, N // 2 : N // 2 + 3] = np.inf
    return Y, U


def _stepwise(mon: gf.Monitor, Y: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, ...]:
    out = [mon.step(Y[:, k], U[:, k]) for k in range(Y.shape[1])]
    R = np.array([o.residuals for o in out]).T
    Al = np.array([o.alarms for o in out]).T
    iso = np.array([o.isolated for o in out])
    return R, Al, iso


def _chunked(mon: gf.Monitor, Y: np.ndarray, U: np.ndarray, rng: np.random.Generator) -> tuple:
    Rs, As, Is = [], [], []
    k, N = 0, Y.shape[1]
    while k < N:
        if rng.random() < 0.3:  # mix single steps into the chunks
            o = mon.step(Y[:, k], U[:, k])
            Rs.append(o.residuals[:, None])
            As.append(o.alarms[:, None])
            Is.append([o.isolated])
            k += 1
            continue
        L = int(rng.integers(0, 97))
        o = mon.feed(Y[:, k : k + L], U[:, k : k + L])
        Rs.append(o.residuals)
        As.append(o.alarms)
        Is.append(o.isolated)
        k += L
    return np.hstack(Rs), np.hstack(As), np.concatenate(Is)


def _agree(
    res: gf.deployment.EvaluationResult, R: np.ndarray, Al: np.ndarray, iso: np.ndarray
) -> None:
    np.testing.assert_array_equal(np.isnan(R), np.isnan(res.residuals))
    scale = max(1.0, float(np.nanmax(np.abs(res.residuals))))
    assert np.nanmax(np.abs(R - res.residuals)) <= 1e-12 * scale
    np.testing.assert_array_equal(Al, res.alarms)
    np.testing.assert_array_equal(iso, res.isolated)


@pytest.mark.parametrize(
    "persistence",
    [None, (2, 3), 4, gf.Persistence(2, 3, reset=20), gf.Persistence(1, 2, False, 5)],
)
def test_step_chunks_and_evaluate_agree(bank: gf.ResidualBank, persistence: object) -> None:
    Y, U = _data(3, 3, 3000, seed=1)
    kw = {"threshold": 0.35, "persistence": persistence}
    res = gf.evaluate(bank, Y, U, dt=DT, **kw)
    assert res.alarms.any() and (res.isolated >= 0).any() and res.masked.sum() == 4
    mon = gf.Monitor(bank, **kw)
    _agree(res, *_stepwise(mon, Y, U))
    rng = np.random.default_rng(7)
    for _ in range(3):
        mon.reset()
        _agree(res, *_chunked(mon, Y, U, rng))


def test_continuous_bank_with_dt(bank: gf.ResidualBank) -> None:
    cbank = seed_bank()
    Y, U = _data(3, 3, 800, seed=2)
    res = gf.evaluate(cbank, Y, U, dt=DT, threshold=0.35, initial="zero")
    mon = gf.Monitor(cbank, dt=DT, threshold=0.35, initial="zero")
    _agree(res, *_stepwise(mon, Y, U))
    with pytest.raises(GeomFDIError, match="dt: a continuous bank needs"):
        gf.Monitor(cbank)
    with pytest.raises(GeomFDIError, match="differs from the discrete bank"):
        gf.Monitor(bank, dt=0.02)


def test_vector_residuals_and_missing_rows() -> None:
    bank = vector_row_bank()
    Y, U = _data(2, 1, 600, seed=3)
    res = gf.evaluate(bank, Y, U, dt=DT, threshold=[1.5, 1.0, 1.0], persistence=(2, 2))
    valid = ~res.masked
    assert np.all(res.residuals[1, valid] == 0)
    np.testing.assert_allclose(
        res.residuals[0, valid], np.linalg.norm(res.components[:2, valid], axis=0), rtol=1e-15
    )
    mon = gf.Monitor(bank, threshold=[1.5, 1.0, 1.0], persistence=(2, 2))
    _agree(res, *_stepwise(mon, Y, U))
    mon.reset()
    _agree(res, *_chunked(mon, Y, U, np.random.default_rng(1)))


def test_state_is_serialisable_and_restores(bank: gf.ResidualBank) -> None:
    Y, U = _data(3, 3, 1000, seed=5)
    mon = gf.Monitor(bank, threshold=0.35, persistence=(2, 3))
    full = _stepwise(mon, Y, U)
    mon.reset()
    mon.feed(Y[:, :400], U[:, :400])
    mon.step(Y[:, 400], U[:, 400])
    state = json.loads(json.dumps(mon.state))
    assert state["samples"] == 401 and len(state["ring"]) == 3
    other = gf.Monitor(bank, threshold=0.35, persistence=(2, 3))
    other.state = state
    rest = _stepwise(other, Y[:, 401:], U[:, 401:])
    assert np.nanmax(np.abs(rest[0] - full[0][:, 401:])) <= 1e-12
    np.testing.assert_array_equal(rest[1], full[1][:, 401:])
    np.testing.assert_array_equal(rest[2], full[2][401:])
    with pytest.raises(ShapeError, match="ring"):
        other.state = {**state, "ring": [[0, 1, 2]]}


def test_step_errors_and_reset(bank: gf.ResidualBank) -> None:
    mon = gf.Monitor(bank, threshold=0.35)
    with pytest.raises(ShapeError, match="y: expected 3 values"):
        mon.step([1.0, 2.0], [0.0, 0.0, 0.0])
    with pytest.raises(ShapeError, match="u: expected 3 values"):
        mon.step([1.0, 2.0, 3.0], None)
    with pytest.raises(ShapeError, match="U: expected"):
        mon.feed(np.zeros((3, 5)), np.zeros((2, 5)))
    with pytest.raises(GeomFDIError, match="moving-RMS"):
        gf.Monitor(bank, threshold=gf.Threshold(np.ones(3), statistic="rms", window=5))
    first = mon.step([1.0, 2.0, 3.0], [0.1, 0.2, 0.3]).residuals.copy()
    mon.step([5.0, 2.0, 3.0], [0.1, 0.2, 0.3])
    mon.reset()
    np.testing.assert_array_equal(mon.step([1.0, 2.0, 3.0], [0.1, 0.2, 0.3]).residuals, first)


@st.composite
def _random_case(draw: st.DrawFn) -> tuple:
    seed = draw(st.integers(0, 2**31 - 1))
    n = draw(st.integers(2, 3))
    q = draw(st.integers(2, 3))
    m = draw(st.integers(1, 2))
    k = draw(st.integers(1, 3))
    nn = draw(st.integers(k, 4))
    latch = draw(st.booleans())
    reset = draw(st.one_of(st.none(), st.integers(1, 30)))
    chunk_seed = draw(st.integers(0, 2**31 - 1))
    return seed, n, q, m, gf.Persistence(k, nn, latch, reset), chunk_seed


@pytest.mark.slow
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_random_case())
def test_property_random_banks(case: tuple) -> None:
    seed, n, q, m, persistence, chunk_seed = case
    rng = np.random.default_rng(seed)
    plant = gf.Plant(rng.normal(size=(n, n)), rng.normal(size=(n, m)), rng.normal(size=(q, n)))
    faults = [gf.SensorFault(i) for i in range(q)]
    try:
        cbank = gf.design_bank(plant, faults, np.eye(q, dtype=bool))
    except GeomFDIError:
        assume(False)
    assume(cbank.present)
    dbank = cbank.discretize(DT, method=("zoh", "tustin")[seed % 2])
    order = sum(g.order for g in dbank.generators if g is not None)
    # residuals on the test data are O(1): keep designs whose states stay moderate
    assume(all(np.linalg.norm(g.F, 2) < 10 for g in dbank.generators if g is not None))
    Y, U = _data(q, m, 400, seed)
    res0 = gf.evaluate(dbank, Y, U, dt=DT)
    # thresholds between samples (a sample exactly at a threshold is decided by rounding)
    thr = np.nanquantile(np.abs(res0.residuals), 0.8, axis=1) * (1 + 1e-7)
    thr[thr <= 0] = 1.0
    res = gf.evaluate(dbank, Y, U, dt=DT, threshold=thr, persistence=persistence)
    mon = gf.Monitor(dbank, threshold=thr, persistence=persistence)
    _agree(res, *_stepwise(mon, Y, U))
    after_steps = mon.state
    mon.reset()
    _agree(res, *_chunked(mon, Y, U, np.random.default_rng(chunk_seed)))
    state = mon.state  # the same state whatever the chunking (xi to rounding)
    np.testing.assert_allclose(state.pop("xi"), after_steps.pop("xi"), rtol=1e-12, atol=1e-12)
    assert state == after_steps
    assert order == res.info["xi"].size
    # the decisions are gf.simulate's rule on these residuals and alarms
    r0 = np.nan_to_num(res.residuals)  # a masked sample never alarms
    alarms, iso = decisions(r0, gf.Threshold(thr), dbank.structure, persistence)
    np.testing.assert_array_equal(alarms, res.alarms)
    np.testing.assert_array_equal(iso.isolated, res.isolated)


def test_pattern_table_decides_like_isolate() -> None:
    from geomfdi.deployment.decide import PatternTable

    rng = np.random.default_rng(11)
    seen = False
    for rows, nf in [(1, 1), (3, 4), (6, 8), (10, 10)]:
        S = rng.random((rows, nf)) < 0.5
        S[:, 0] = False  # a fault no residual sees
        if nf > 2:
            S[:, 2] = S[:, 1]  # two faults with one signature: ambiguous
        # patterns: random ones, every column's own pattern, and no alarm
        A = np.hstack([rng.random((rows, 300)) < 0.4, S, np.zeros((rows, 2), bool)])
        got = PatternTable.of(S).decide(A)
        want = gf.isolate(A, S).isolated
        np.testing.assert_array_equal(got, want)
        # with MULTIPLE: the pattern decisions of the persistence rule
        multi = PatternTable.of(S, multiple=True).decide(A)
        np.testing.assert_array_equal(multi, gf.Persistence(1, 1, False).isolation(A, S).isolated)
        seen |= MULTIPLE in multi
        assert {-1, -2}.issubset(set(got.tolist())) or rows == 1
        if nf > 2 and S[:, 1].any():
            assert -3 in got
    assert seen


@pytest.mark.parametrize("k, n", [(1, 2), (2, 3), (5, 16), (3, 17), (20, 40)])
def test_confirm_is_the_k_of_n_count(k: int, n: int) -> None:
    from geomfdi.deployment.decide import confirm
    from geomfdi.evaluation.persistence import Persistence

    rng = np.random.default_rng(n)
    raw = rng.random((4, 120)) < 0.6
    hist = rng.random((4, n - 1)) < 0.6
    ext = np.hstack([hist, raw]).astype(int)
    want = np.array([[ext[r, j : j + n].sum() >= k for j in range(120)] for r in range(4)])
    np.testing.assert_array_equal(confirm(raw, Persistence(k, n), hist), want)


@pytest.mark.parametrize("reset", [None, 1, 3, 7])
def test_held_chunk_continues_held_pattern(reset: int | None) -> None:
    from geomfdi.deployment.decide import held_chunk

    rng = np.random.default_rng(3)
    alarms = rng.random((4, 400)) < 0.03
    alarms[:, 150:200] = False  # a long quiet stretch: episodes end
    want = held_pattern(alarms, reset)
    for cuts in ([0, 400], [0, 1, 2, 150, 151, 199, 200, 400], sorted(rng.integers(0, 400, 30))):
        held, quiet, parts = np.zeros(4, dtype=bool), 0, []
        edges = [0, *cuts, 400]
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            pat, held, quiet = held_chunk(alarms[:, a:b], reset, held, quiet)
            parts.append(pat)
        np.testing.assert_array_equal(np.hstack(parts), want)
    if reset is not None:
        assert not want[:, 199].any() and want.any()


def test_monitor_reports_multiple_and_restores_the_held_pattern() -> None:
    g = [
        gf.ResidualGenerator([[0.0]], -h[None], [[0.0]], [[0.0]], h[None], [[0.0]], dt=DT)
        for h in (np.array([1.0, 0.0]), np.array([0.0, 1.0]))
    ]
    S = np.eye(2, dtype=bool)
    bank = gf.ResidualBank(g, S, S, np.ones(2, bool), ["ok", "ok"], [], DT)
    Y, U = np.zeros((2, 80)), np.zeros((1, 80))
    Y[0, 10:40] = 1.0  # fault 0
    Y[1, 20:25] = 1.0  # fault 1 briefly: the held pattern keeps it until the episode ends
    rule = gf.Persistence(2, 3, reset=10)
    kw = {"threshold": 0.5, "persistence": rule, "initial": "zero"}
    res = gf.evaluate(bank, Y, U, dt=DT, **kw)
    assert res.isolated[12] == 0 and res.isolated[30] == MULTIPLE
    # the alarm of fault 0 is confirmed until 40: the episode ends 10 quiet samples later
    assert res.isolated[49] == MULTIPLE and res.isolated[50] == NO_ALARM
    mon = gf.Monitor(bank, **kw)
    R, Al, iso = _stepwise(mon, Y[:, :30], U[:, :30])
    state = json.loads(json.dumps(mon.state))
    assert state["held"] == [1, 1] and state["quiet"] == 0 and len(state["decisions"]) == 2
    other = gf.Monitor(bank, **kw)
    other.state = state
    rest = other.feed(Y[:, 30:], U[:, 30:])
    np.testing.assert_array_equal(np.concatenate([iso, rest.isolated]), res.isolated)
    with pytest.raises(GeomFDIError, match="quiet"):
        other.state = {**state, "quiet": 10}
    with pytest.raises(GeomFDIError, match="decisions"):
        other.state = {**state, "decisions": [0, 7]}


def test_saved_rule_and_legacy_monitor_files(bank: gf.ResidualBank, tmp_path) -> None:
    from geomfdi.generators.bankfile import _checksum

    Y, U = _data(3, 3, 900, seed=8)
    rule = gf.Persistence(2, 3, reset=9)
    mon = gf.Monitor(bank, threshold=0.35, persistence=rule)
    ref = mon.feed(Y, U)
    mon.reset()
    mon.feed(Y[:, :300], U[:, :300])
    assert mon.state["held"] != [0, 0, 0]
    back = gf.load_monitor(mon.save(tmp_path / "m.json"))
    assert back.persistence == rule and back.state == mon.state
    rest = back.feed(Y[:, 300:], U[:, 300:])
    np.testing.assert_array_equal(rest.isolated, ref.isolated[300:])
    np.testing.assert_array_equal(rest.alarms, ref.alarms[:, 300:])
    # a file that stores the rule as [k, n] (before the held pattern): the old k-of-n
    # confirmation with momentary isolation, whose decisions now settle
    old = gf.Monitor(bank, threshold=0.35, persistence=gf.Persistence(2, 3, latch=False))
    want = old.feed(Y, U)
    old.reset()
    old.feed(Y[:, :300], U[:, :300])
    path = old.save(tmp_path / "old.json")
    doc = json.loads(path.read_text())
    doc["payload"]["persistence"] = [2, 3]
    for key in ("held", "quiet", "decisions"):
        del doc["payload"]["state"][key]
    doc["checksum"] = _checksum(doc["payload"])
    path.write_text(json.dumps(doc))
    legacy = gf.load_monitor(path)
    assert legacy.persistence == gf.Persistence(2, 3, latch=False)
    got = legacy.feed(Y[:, 300:], U[:, 300:])
    np.testing.assert_array_equal(got.alarms, want.alarms[:, 300:])
    # the decision history starts afresh: equal once n - 1 samples have passed
    np.testing.assert_array_equal(got.isolated[2:], want.isolated[302:])
    doc["payload"]["persistence"] = {"k": 2, "n": 3, "latch": True}
    doc["checksum"] = _checksum(doc["payload"])
    path.write_text(json.dumps(doc))
    with pytest.raises(gf.errors.BankFileError, match="persistence"):
        gf.load_monitor(path)
