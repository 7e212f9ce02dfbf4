"""The compiled pass of per-sample decisions (alarm-pattern table) against numpy."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from hwc_bank import K_FB, P_PAPER, X0, A, B, C, hand_generator, leaky_bank, v_ext

import geomfdi as gf
from geomfdi.evaluation.decision import isolate
from geomfdi.evaluation.persistence import every_pattern
from geomfdi.simulation.compiled_decisions import table_decisions
from geomfdi.simulation.streaming import DecisionStream

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")


def _numpy(res, v, table):
    absr = np.abs(res)
    al = absr > v[:, None]
    code = (al * (2 ** np.arange(res.shape[1]))[None, :, None]).sum(axis=1)
    return al, table[code], al.any(axis=1), absr.max(axis=-1)


@pytest.mark.parametrize("n", [1, 3, 5])
@pytest.mark.parametrize("plain", [False, True])
def test_table_decisions_equal_the_numpy_passes_through_strides(monkeypatch, n, plain):
    if plain:  # the loops of a compiler without vector types
        from geomfdi.simulation import compiled_decisions

        monkeypatch.setattr(compiled_decisions, "_FLAGS", ("-DGFD_NO_VECTOR_EXT",))
    rng = np.random.default_rng(n)
    S = rng.random((n, n + 1)) < 0.5
    table = np.ascontiguousarray(isolate(every_pattern(n), S).isolated, dtype=np.int64)
    v = rng.uniform(0.5, 1.5, n)
    big = rng.standard_normal((7, n + 2, 301))
    big[:, :n, ::17] = v[None, :, None]  # exactly at the threshold: no alarm
    big[:, :n, 5::23] = -v[None, :, None]
    big[:, :n, 9::31] = 0.0
    res = big[1:6, :n, 3:290:2]  # strided in every axis
    rec_al = np.zeros((9, n, 400), dtype=bool)
    rec_iso = np.full((9, 400), -5, dtype=np.int64)
    al, iso = rec_al[2:7, :, 10 : 10 + res.shape[2]], rec_iso[2:7, 10 : 10 + res.shape[2]]
    anyal = np.zeros((5, res.shape[2]), dtype=bool)
    peaks = table_decisions(res, v, table, al, iso, anyal)
    want_al, want_iso, want_any, want_peaks = _numpy(res, v, table)
    assert peaks is not None
    assert np.array_equal(al, want_al) and np.array_equal(iso, want_iso)
    assert np.array_equal(anyal, want_any) and np.array_equal(peaks, want_peaks)
    assert want_al.any() and not want_al.all()  # both outcomes occur
    assert not rec_al[:2].any() and np.all(rec_iso[:2] == -5)  # nothing outside the views
    assert np.all(rec_iso[2:7, :10] == -5)
    # contiguous rows (four samples at a time), a length that leaves a remainder
    res = np.ascontiguousarray(big[:, :n, :299])
    al, iso = np.zeros(res.shape, bool), np.zeros((7, 299), np.int64)
    anyal = np.zeros((7, 299), dtype=bool)
    peaks = table_decisions(res, v, table, al, iso, anyal)
    want_al, want_iso, want_any, want_peaks = _numpy(res, v, table)
    assert peaks is not None
    assert np.array_equal(al, want_al) and np.array_equal(iso, want_iso)
    assert np.array_equal(anyal, want_any) and np.array_equal(peaks, want_peaks)


@pytest.mark.parametrize("bad", [np.nan, np.inf, 1e301])
@pytest.mark.parametrize("where", [7, 49])  # in the vector loop, in its remainder
def test_table_decisions_decline_non_finite_or_huge_residuals(bad, where):
    res = np.ones((2, 2, 50))
    res[1, 0, where] = bad
    table = np.arange(4, dtype=np.int64)
    out = table_decisions(
        res, np.ones(2), table, np.empty(res.shape, bool), np.empty((2, 50), np.int64),
        np.empty((2, 50), bool),
    )  # fmt: skip
    assert out is None


def test_table_decisions_decline_wrong_dtypes_and_the_numpy_backend(monkeypatch):
    res = np.ones((2, 2, 5))
    args = (np.ones(2), np.arange(4, dtype=np.int64), np.empty(res.shape, bool))
    iso, anyal = np.empty((2, 5), np.int64), np.empty((2, 5), bool)
    assert table_decisions(res, *args, iso.astype(np.int32), anyal) is None
    assert table_decisions(res.astype(np.float32), *args, iso, anyal) is None
    assert table_decisions(res, *args, iso, anyal) is not None
    monkeypatch.setenv("GEOMFDI_SIM_BACKEND", "numpy")
    assert table_decisions(res, *args, iso, anyal) is None


@pytest.mark.parametrize("store", ["residuals", "summary"])
def test_batch_decisions_are_those_of_the_numpy_passes(monkeypatch, store):
    plant = gf.Plant(A, B, C)
    bank = leaky_bank([hand_generator(plant, P_PAPER[j : j + 1]) for j in range(3)])
    t = np.arange(0, 12.0, 0.01)
    kw = dict(
        runs=5,
        faults=[gf.BiasFault(1, start=5.0, bias=0.05)],
        x0=X0,
        controller=K_FB,
        noise=gf.Noise(measurement=2e-2, seed=4),
        threshold=0.03,
        progress=False,
        store=store,
        chunk_size=2,
    )
    calls = []
    real = DecisionStream.decide_compiled

    def counted(self, *a):
        calls.append(1)
        return real(self, *a)

    monkeypatch.setattr(DecisionStream, "decide_compiled", counted)
    fast = gf.simulate_batch(plant, bank, t, v_ext, **kw)
    assert calls  # the compiled pass ran
    monkeypatch.setattr(DecisionStream, "decide_compiled", lambda self, *a: None)
    slow = gf.simulate_batch(plant, bank, t, v_ext, **kw)
    if store == "residuals":
        assert np.array_equal(fast.alarms, slow.alarms)
        assert np.array_equal(fast.isolated, slow.isolated)
        assert fast.alarms.any()
    assert np.array_equal(fast.peak, slow.peak)
    assert np.array_equal(fast.false_alarm_counts, slow.false_alarm_counts)
    assert np.array_equal(fast.false_alarm_events, slow.false_alarm_events)
    assert fast.false_alarm_counts.any()  # noise large enough for false alarms
    for ef, es in zip(fast.events, slow.events, strict=True):
        assert [(e.detection_time, e.isolation_time, e.decided, e.residuals) for e in ef] == [
            (e.detection_time, e.isolation_time, e.decided, e.residuals) for e in es
        ]
