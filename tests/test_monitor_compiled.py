"""Monitor(..., backend="c"): the compiled generated code agrees with the numpy path."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from deploy_banks import DT, sampled_bank, seed_bank, vector_row_bank

import geomfdi as gf
from geomfdi.deployment import compiled
from geomfdi.errors import GeomFDIError

needs_cc = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler (cc)")


pytestmark = pytest.mark.usefixtures("c_cache")


def _data(q: int, m: int, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    Y = np.vstack([np.sin((i + 1) * 0.3 * t) for i in range(q)]) + 0.3 * rng.normal(size=(q, n))
    U = np.vstack([np.cos((j + 1) * 0.2 * t) for j in range(m)])
    Y[1, n // 20 : n // 20 + 4] = np.nan  # missing samples restart the generators
    Y[0, 3 * n // 10 : 3 * n // 10 + 300] += 2.0  # a fault-like step
    Y[2, 6 * n // 10 :] += 1.5
    return Y, U


def _threshold(bank: gf.ResidualBank, Y: np.ndarray, U: np.ndarray) -> np.ndarray:
    """Per-row 90 % quantiles of |r|: alarms and decisions of every kind occur."""
    r = gf.Monitor(bank).feed(Y, U).residuals
    return np.nanquantile(np.abs(r), 0.9, axis=1)


@needs_cc
@pytest.mark.parametrize("persistence", [None, 3, (2, 4), gf.Persistence(2, 3, latch=True)])
def test_feed_and_step_agree_with_numpy(persistence):
    bank = sampled_bank()
    Y, U = _data(3, 3, 3000)
    thr = _threshold(bank, Y, U)
    mn = gf.Monitor(bank, threshold=thr, persistence=persistence)
    mc = gf.Monitor(bank, threshold=thr, persistence=persistence, backend="c")
    assert mc.backend == "c"
    a, b = mn.feed(Y, U), mc.feed(Y, U)
    assert a.alarms.any() and len(set(a.isolated.tolist())) > 2  # the data exercise the decisions
    np.testing.assert_array_equal(a.alarms, b.alarms)
    np.testing.assert_array_equal(a.raw_alarms, b.raw_alarms)
    np.testing.assert_array_equal(a.isolated, b.isolated)
    np.testing.assert_array_equal(a.masked, b.masked)
    np.testing.assert_array_equal(np.isnan(a.residuals), np.isnan(b.residuals))
    ok = ~np.isnan(a.residuals)
    np.testing.assert_allclose(b.residuals[ok], a.residuals[ok], rtol=1e-9, atol=1e-9)
    # step by step after a reset: the same decisions sample by sample
    mn.reset()
    mc.reset()
    for k in range(0, 1200):
        sa, sb = mn.step(Y[:, k], U[:, k]), mc.step(Y[:, k], U[:, k])
        assert sa.isolated == sb.isolated
        np.testing.assert_array_equal(sa.alarms, sb.alarms)
        np.testing.assert_array_equal(sa.alarms, a.alarms[:, k])


@needs_cc
def test_chunks_continue_the_state():
    bank = sampled_bank()
    Y, U = _data(3, 3, 2000, seed=3)
    thr = _threshold(bank, Y, U)
    whole = gf.Monitor(bank, threshold=thr, persistence=3, backend="c").feed(Y, U)
    mc = gf.Monitor(bank, threshold=thr, persistence=3, backend="c")
    parts = [mc.feed(Y[:, s : s + 700], U[:, s : s + 700]) for s in range(0, 2000, 700)]
    np.testing.assert_array_equal(np.hstack([p.alarms for p in parts]), whole.alarms)
    np.testing.assert_array_equal(np.concatenate([p.isolated for p in parts]), whole.isolated)


@needs_cc
def test_isolation_off_and_state_guard():
    bank = sampled_bank()
    mc = gf.Monitor(bank, threshold=1.0, isolation=False, backend="c")
    out = mc.step(np.zeros(3), np.zeros(3))
    assert out.isolated is None
    assert mc.feed(np.zeros((3, 5)), np.zeros((3, 5))).isolated is None
    with pytest.raises(GeomFDIError, match="backend"):
        _ = mc.state


def test_continuous_bank_falls_back_with_a_warning():
    with pytest.warns(RuntimeWarning, match="discrete"):
        mon = gf.Monitor(seed_bank(), dt=DT, threshold=1.0, backend="c")
    assert mon.backend == "numpy"
    assert mon.step(np.zeros(3), np.zeros(3)).alarms.shape == (mon.n_residuals,)


def test_no_compiler_falls_back_with_a_warning(monkeypatch, tmp_path):
    monkeypatch.setenv("CC", "no-such-compiler-xyz")
    monkeypatch.setenv("GEOMFDI_CACHE_DIR", str(tmp_path))
    with pytest.warns(RuntimeWarning, match="compiler"):
        mon = gf.Monitor(sampled_bank(), threshold=1.0, backend="c")
    assert mon.backend == "numpy"


def test_backend_is_checked():
    with pytest.raises(GeomFDIError, match="backend"):
        gf.Monitor(sampled_bank(), backend="fortran")


@needs_cc
def test_library_is_cached_by_source(tmp_path, monkeypatch):
    monkeypatch.setenv("GEOMFDI_CACHE_DIR", str(tmp_path))
    gf.Monitor(sampled_bank(), threshold=1.0, backend="c")
    libs = list(tmp_path.glob("*.so"))
    assert len(libs) == 1
    mtime = libs[0].stat().st_mtime_ns
    gf.Monitor(sampled_bank(), threshold=1.0, backend="c")  # same source: no rebuild
    assert list(tmp_path.glob("*.so")) == libs and libs[0].stat().st_mtime_ns == mtime
    gf.Monitor(sampled_bank(), threshold=2.0, backend="c")  # other tables: another library
    assert len(list(tmp_path.glob("*.so"))) == 2
    assert compiled.cache_dir() == tmp_path


@needs_cc
def test_vector_rows_missing_generator_and_explicit_start_agree():
    bank = vector_row_bank()
    rng = np.random.default_rng(5)
    L = 1500
    Y = rng.normal(size=(2, L))
    U = rng.normal(size=(1, L))
    Y[0, 700:] += 3.0
    Y[1, 300:303] = np.nan
    thr = np.maximum(_threshold(bank, Y, U), 1.0)  # the missing generator's row: 0
    x0 = rng.normal(size=gf.Monitor(bank).program.nw)
    kw = dict(threshold=thr, persistence=(2, 3), initial=x0)
    a = gf.Monitor(bank, **kw).feed(Y, U)
    b = gf.Monitor(bank, backend="c", **kw).feed(Y, U)
    assert a.alarms.any()
    np.testing.assert_array_equal(a.alarms, b.alarms)
    np.testing.assert_array_equal(a.isolated, b.isolated)
    ok = ~np.isnan(a.residuals)
    np.testing.assert_array_equal(ok, ~np.isnan(b.residuals))
    np.testing.assert_allclose(b.residuals[ok], a.residuals[ok], rtol=1e-9, atol=1e-9)


@needs_cc
@pytest.mark.parametrize("calls", ["python", "ctypes", "cffi"])
def test_every_way_of_calling_the_step_agrees_on_any_input_kind(calls, monkeypatch):
    """The step called through the library's builtin function, ctypes or cffi, on float64
    vectors (contiguous or columns of a record), lists, float32 and byte-swapped arrays:
    the decisions of the numpy path sample by sample; bad samples refused alike."""
    monkeypatch.setattr(compiled, "STEP_CALLS", calls)
    bank = sampled_bank()
    Y, U = _data(3, 3, 600, seed=5)
    thr = _threshold(bank, Y, U)
    mn = gf.Monitor(bank, threshold=thr, persistence=3)
    mc = gf.Monitor(bank, threshold=thr, persistence=3, backend="c")
    assert mc.backend == "c"
    kinds = [
        lambda v: v,  # a column of the record: strided
        np.ascontiguousarray,
        lambda v: v.tolist(),
        lambda v: v.astype(">f8"),
        lambda v: np.asarray(v, dtype=np.float32).astype(float),
    ]
    seen = set()
    for k in range(Y.shape[1]):
        kind = kinds[k % len(kinds)]
        y, u = kind(Y[:, k]), kind(U[:, k])
        sa, sb = mn.step(y, u), mc.step(y, u)
        assert type(sb) is type(sa) and sb.alarms.dtype == bool
        assert sa.isolated == sb.isolated
        np.testing.assert_array_equal(sa.alarms, sb.alarms)
        np.testing.assert_array_equal(np.isnan(sa.residuals), np.isnan(sb.residuals))
        seen.add(sa.isolated)
    assert len(seen) > 2
    out = mc.step(Y[:, 0].copy(), U[:, 0].copy())
    out.residuals[:] = 7.0  # a fresh array: the next step does not write into it
    assert not np.any(mc.step(Y[:, 1].copy(), U[:, 1].copy()).residuals == 7.0)
    with pytest.raises(GeomFDIError, match="u"):
        mc.step(Y[:, 0].copy())
    with pytest.raises(GeomFDIError, match="y"):
        mc.step(np.zeros(4), np.zeros(3))


@needs_cc
def test_generated_step_sums_every_entry_in_its_dense_row_order():
    """The generated step updates several rows per vector instruction (columns outside,
    rows inside) but sums each entry as the dense row does: from 0.0, the block's columns,
    then the inputs.  Reproduced here with Python floats (IEEE doubles, no fused
    multiply-add), sample by sample from a zero start: the residuals agree bit for bit."""
    from geomfdi.deployment.codegen._spec import monitor_spec

    bank = sampled_bank()
    Y, U = _data(3, 3, 2000, seed=5)
    Y, U = Y[:, :60], U[:, :60]  # before the missing samples
    mon = gf.Monitor(bank, initial="zero", backend="c")
    got = mon.feed(Y, U).residuals
    spec = monitor_spec(gf.Monitor(bank, initial="zero"))
    A, B, C, D = (np.asarray(a, dtype=float).tolist() for a in (spec.A, spec.B, spec.C, spec.D))
    blocks, o = [], 0
    comps = [sl for sl in spec.rows if sl is not None]
    for n, (c0, c1) in zip(spec.orders, comps, strict=True):
        blocks.append((o, n, c0, c1))
        o += n

    def dense_row(Mx: list[float], Mz: list[float], states: range, x, z) -> float:
        acc = 0.0  # from 0.0: the block's columns in order, then the inputs
        for j in states:
            acc += Mx[j] * x[j]
        for j in range(len(z)):
            acc += Mz[j] * z[j]
        return acc

    x = [0.0] * spec.nw
    want = np.empty((spec.nc, Y.shape[1]))
    for k in range(Y.shape[1]):
        z = [float(v) for v in (*Y[:, k], *U[:, k])]
        c, xn = [0.0] * spec.nc, [0.0] * spec.nw
        for o, n, c0, c1 in blocks:
            states = range(o, o + n)
            for i in range(c0, c1):
                c[i] = dense_row(C[i], D[i], states, x, z)
            for i in states:
                xn[i] = dense_row(A[i], B[i], states, x, z)
        want[:, k] = c
        x = xn
    scalar = [r for r, sl in enumerate(spec.rows) if sl is not None and sl[1] - sl[0] == 1]
    assert scalar, "the bank has scalar rows to compare"
    for r in scalar:
        np.testing.assert_array_equal(got[r], want[spec.rows[r][0]])
    assert np.all(np.abs(got[scalar]).max(axis=1) > 0)  # the residuals are not all zero
