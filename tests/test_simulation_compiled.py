"""The compiled bank recursion of batch simulations against its definition and the numpy path."""

from __future__ import annotations

import shutil
import warnings

import numpy as np
import pytest

import geomfdi as gf
from geomfdi._cbuild import forget_kernels
from geomfdi.errors import BackendFallbackWarning, GeomFDIError
from geomfdi.simulation import compiled_recursion as cr
from geomfdi.simulation.lifting import Drive, block_recursion

needs_cc = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler (cc)")


pytestmark = pytest.mark.usefixtures("c_cache")


def _reference(blocks, W, drives, x0, outputs, N, direct=None):
    """The recursion sample by sample, as its docstring states it (dense matrices)."""
    sizes = [b.shape[0] for b in blocks]
    nS = sum(sizes)
    R = max([d.runs for d in drives] + [x0.shape[1]] + [a.shape[1] for a in (direct or [[]])[0]])
    A = np.zeros((nS, nS))
    i0 = 0
    for b, n in zip(blocks, sizes, strict=True):
        A[i0 : i0 + n, i0 : i0 + n] = b
        i0 += n
    x = np.array(np.broadcast_to(x0, (nS, R)), dtype=float)
    outs = [[np.zeros((C.shape[0], R, N)) for C in o] for o in outputs]
    starts = np.cumsum([0] + sizes)
    for k in range(N):
        for b, o in enumerate(outputs):
            for j, C in enumerate(o):
                y = C @ x[starts[b] : starts[b + 1]]
                if direct is not None and direct[1][b][j] is not None:
                    sig = np.concatenate(
                        [np.broadcast_to(a[:, :, k], (a.shape[0], R)) for a in direct[0]]
                    )
                    y = y + direct[1][b][j] @ sig
                outs[b][j][:, :, k] = y
        if k == N - 1:
            break
        d = np.concatenate(
            [np.broadcast_to(dr.window(k, 1)[..., 0], (dr.arr.shape[0], R)) for dr in drives]
        )
        x = A @ x + W @ d
    return outs, x


def _system(seed: int, sizes: list[int], R: int, N: int, scaled: bool = True):
    rng = np.random.default_rng(seed)
    blocks = []
    for n in sizes:
        A = rng.standard_normal((n, n))
        if n:
            A *= 0.95 / max(np.max(np.abs(np.linalg.eigvals(A))), 1e-9)
        blocks.append(A)
    nS = sum(sizes)
    own = rng.standard_normal((2, R, N))  # per run, read at shifts 0 and 1
    shared = rng.standard_normal((3, 1, N))  # shared, read at shifts 0 and 1
    drives = [Drive(own), Drive(own, 1), Drive(shared), Drive(shared, 1)]
    if scaled:  # a shared signal scaled per run, and a per-run signal scaled by a shared one
        drives += [Drive(shared, 0, rng.standard_normal((1, R, N - 1)))]
        drives += [Drive(own[:1], 0, rng.standard_normal((1, 1, N - 1)))]
    nz = sum(d.arr.shape[0] for d in drives)
    W = rng.standard_normal((nS, nz))
    W[:, 1] = 0.0  # a channel nothing reads
    x0 = rng.standard_normal((nS, 1))
    outputs = [[rng.standard_normal((2, n)), np.eye(n)] for n in sizes]  # states kept too
    sig = [rng.standard_normal((2, R, N)), rng.standard_normal((3, 1, N))]
    dm = [[rng.standard_normal((2, 5)), None] for _ in sizes]
    dm[0][0][:, 0] = 0.0
    return blocks, W, drives, x0, outputs, (sig, dm)


def _close(a, b, rtol=1e-12):
    assert a.shape == b.shape
    if b.size == 0:
        return
    scale = max(float(np.max(np.abs(b))), 1e-300)
    assert float(np.max(np.abs(a - b))) <= rtol * scale, float(np.max(np.abs(a - b))) / scale


@needs_cc
@pytest.mark.parametrize("R", [2, 7, 8, 13, 19])
def test_compiled_recursion_equals_its_definition_and_the_numpy_path(R):
    sizes, N = [1, 3, 2, 4, 1], 700
    blocks, W, drives, x0, outputs, direct = _system(R, sizes, R, N)
    got, xf = cr.compiled_block_recursion(
        blocks, W, drives, x0, outputs, N, direct=direct, final=True
    )
    ref, xr = _reference(blocks, W, drives, x0, outputs, N, direct)
    num, xn = block_recursion(blocks, W, drives, x0, outputs, N, direct=direct, final=True)
    for g, r, m in zip(sum(got, []), sum(ref, []), sum(num, []), strict=True):
        assert g.shape == r.shape == (r.shape[0], R, N)
        _close(g, r)
        _close(g, m)
    _close(xf, xr)
    _close(xf, xn)


@needs_cc
def test_zero_order_blocks_and_per_run_initial_states():
    sizes, R, N = [2, 0, 3], 5, 300
    blocks, W, drives, _, outputs, direct = _system(3, sizes, R, N, scaled=False)
    outputs[1] = [np.zeros((2, 0)), np.eye(0)]  # a generator without states: feedthrough only
    direct[1][1][0] = np.ones((2, 5))
    x0 = np.random.default_rng(4).standard_normal((sum(sizes), R))
    got, xf = cr.compiled_block_recursion(
        blocks, W, drives, x0, outputs, N, direct=direct, final=True
    )
    ref, xr = _reference(blocks, W, drives, x0, outputs, N, direct)
    for g, r in zip(sum(got, []), sum(ref, []), strict=True):
        _close(g, r)
    _close(xf, xr)
    assert np.any(got[1][0] != 0)  # the feedthrough of the stateless block is there


@needs_cc
def test_strided_destinations_and_chunks_carrying_the_state():
    """Outputs written into strided views of one (R, rows, N) array, over consecutive
    calls whose windows overlap by one sample (the engine's chunking): the same as one
    call over the whole record."""
    sizes, R, N = [1, 3, 2], 11, 900
    blocks, W, drives, x0, outputs, direct = _system(5, sizes, R, N, scaled=False)
    outputs = [[o[0][:1]] for o in outputs]  # one row per generator
    dm = [[m[0][:1]] for m in direct[1]]
    whole = block_recursion(blocks, W, drives, x0, outputs, N, direct=(direct[0], dm))
    rows = np.full((R, len(sizes), N), np.nan)
    x = x0
    for s, e1 in [(0, 301), (300, 650), (649, N)]:
        part = [
            Drive(d.arr[..., s:e1], d.shift, None if d.scale is None else d.scale[..., s:e1])
            for d in drives
        ]
        sig = [a[:, :, s:e1] for a in direct[0]]
        dests = [[rows[:, k : k + 1, s:e1].transpose(1, 0, 2)] for k in range(len(sizes))]
        res, x = cr.compiled_block_recursion(
            blocks, W, part, x, outputs, e1 - s, direct=(sig, dm), out=dests, final=True
        )
        assert res[0][0].base is not None and np.shares_memory(res[0][0], rows)
    for k in range(len(sizes)):
        _close(rows[:, k], whole[k][0][0])


@needs_cc
def test_bank_recursion_keeps_numpy_for_one_run_and_when_asked(monkeypatch):
    sizes, N = [2, 3], 200
    blocks, W, drives, x0, outputs, direct = _system(6, sizes, 1, N, scaled=False)
    one = cr.bank_recursion(blocks, W, drives, x0, outputs, N, direct=direct)
    ref = block_recursion(blocks, W, drives, x0, outputs, N, direct=direct)
    for a, b in zip(sum(one, []), sum(ref, []), strict=True):
        assert np.array_equal(a, b)  # R == 1: the numpy path itself
    blocks, W, drives, x0, outputs, direct = _system(6, sizes, 4, N, scaled=False)
    calls = []
    monkeypatch.setattr(cr, "_compiled", lambda *a: calls.append(1))
    cr.bank_recursion(blocks, W, drives, x0, outputs, N, direct=direct)
    assert calls == [1]
    monkeypatch.setenv("GEOMFDI_SIM_BACKEND", "numpy")
    cr.bank_recursion(blocks, W, drives, x0, outputs, N, direct=direct)
    assert calls == [1] and cr.batch_runs() == 1


def test_backend_variable_is_checked(monkeypatch):
    monkeypatch.setenv("GEOMFDI_SIM_BACKEND", "fortran")
    with pytest.raises(GeomFDIError, match="GEOMFDI_SIM_BACKEND"):
        cr.sim_backend()


def test_no_compiler_falls_back_with_one_warning(monkeypatch, tmp_path):
    monkeypatch.setenv("CC", "no-such-compiler-xyz")
    monkeypatch.setenv("GEOMFDI_CACHE_DIR", str(tmp_path))
    sizes, N = [2, 3], 200
    blocks, W, drives, x0, outputs, direct = _system(7, sizes, 3, N, scaled=False)
    with pytest.warns(BackendFallbackWarning, match="compiler"):
        got = cr.bank_recursion(blocks, W, drives, x0, outputs, N, direct=direct)
    ref = block_recursion(blocks, W, drives, x0, outputs, N, direct=direct)
    for a, b in zip(sum(got, []), sum(ref, []), strict=True):
        assert np.array_equal(a, b)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once per process: no second warning
        cr.bank_recursion(blocks, W, drives, x0, outputs, N, direct=direct)
    with pytest.raises(GeomFDIError, match="compiler"):
        cr.compiled_block_recursion(blocks, W, drives, x0, outputs, N, direct=direct)
    assert list(tmp_path.glob("*.so")) == []


@needs_cc
def test_library_is_built_once_and_cached(monkeypatch, tmp_path):
    monkeypatch.setenv("GEOMFDI_CACHE_DIR", str(tmp_path))
    assert cr._library() is not None
    libs = list(tmp_path.glob("gfsim_*.so"))
    assert len(libs) == 1
    mtime = libs[0].stat().st_mtime_ns
    forget_kernels()  # a new process: found in the cache, not rebuilt
    assert cr._library() is not None
    assert list(tmp_path.glob("gfsim_*.so")) == libs and libs[0].stat().st_mtime_ns == mtime


# ------------------------------------------------------------------ simulate_batch

A = np.array([[1.0, 1, 1], [0, 1, 0], [2, 0, 1]])
B = np.array([[1.0, 0, 1], [0, 1, 1], [0, 1, 0]])
C = np.array([[0.0, 1, 0], [0, 0, 1], [1, 0, 2]])
K_FB = np.array([[5, -1.5, 3], [2, 0, 2], [-2, 2.5, -2]])
X0 = np.array([0.5, -0.3, 0.2])
T = np.arange(0, 6.0, 0.01)


def _bank():
    P = np.array([[0.0, 1, 0], [-2, 2, 1], [-3, 3, 1]])
    Ci = np.linalg.inv(C)
    gens = []
    for j in range(3):
        F = np.array([[-2.0 - j]])
        Pj = P[j : j + 1]
        gens.append(
            gf.ResidualGenerator(
                F, (F @ Pj - Pj @ A) @ Ci, Pj @ B, np.eye(1), Pj @ Ci, np.zeros((1, 3))
            )
        )
    S = np.array([[1, 0, 0], [1, 1, 1], [1, 1, 1]], dtype=bool)
    faults = [gf.SensorFault(i) for i in range(3)]
    return gf.ResidualBank(
        gens, np.eye(3, dtype=bool), S, np.array([1, 0, 0], bool), ["ok"] * 3, faults
    )


def _u(t):
    return np.vstack([np.sin(0.5 * t), np.cos(0.3 * t), 0.2 * np.ones_like(t)])


CASES = {
    "open loop, bias": dict(faults=[gf.BiasFault(1, start=2.0, bias=0.05)]),
    "state feedback, gain": dict(
        faults=[gf.GainFault(0, start=3.0, gain=1.4, bias=0.02)], controller=K_FB
    ),
    "state feedback, stuck": dict(faults=[gf.StuckFault(2, start=2.5)], controller=K_FB),
    "per-run lists": dict(
        faults=[
            [gf.GainFault(0, start=2.0, gain=g)] if g else [gf.StuckFault(1, start=3.0)]
            for g in (1.2, 0.0, 1.5, 2.0, 0.0, 1.1, 1.3, 0.7, 1.9)
        ],
        controller=K_FB,
    ),
}


@needs_cc
@pytest.mark.parametrize("case", sorted(CASES), ids=str)
def test_simulate_batch_compiled_equals_numpy_path(case, monkeypatch):
    plant, bank = gf.Plant(A, B, C), _bank()
    kw = dict(CASES[case])
    runs = len(kw["faults"]) if isinstance(kw["faults"][0], list) else 11
    noise = gf.Noise(measurement=[1e-3, 2e-3, 1e-3], process=[0.0, 5e-3, 0.0], seed=3)
    common = dict(x0=X0, noise=noise, threshold=0.05, store="all", progress=False, runs=runs)
    res, calls, kernel = {}, [], cr._compiled
    monkeypatch.setattr(cr, "_compiled", lambda *a: calls.append(a[0]) or kernel(*a))
    for backend in ("numpy", "c"):
        monkeypatch.setenv("GEOMFDI_SIM_BACKEND", backend)
        res[backend] = gf.simulate_batch(plant, bank, T, _u, **common, **kw)
    assert calls  # the compiled kernel ran (with the "c" backend only)
    a, b = res["c"], res["numpy"]
    # to rounding relative to the data: the residuals of the unstable open loop are
    # differences of readings that grow to ~1e6
    tol = 1e-9 * np.max(np.abs(b.residuals)) + 1e-14 * np.max(np.abs(b.y))
    assert np.max(np.abs(a.residuals - b.residuals)) <= tol
    _close(a.y, b.y, rtol=1e-12)
    assert not np.allclose(a.residuals[0], a.residuals[1])  # the runs differ (noise)
    near = np.abs(np.abs(b.residuals) - 0.05) < 1e-9  # decisions at the threshold may flip
    assert np.array_equal(a.alarms[~near], b.alarms[~near])
    if not near.any():
        assert np.array_equal(a.isolated, b.isolated)
        assert [e for e in a.events] == [e for e in b.events]


@needs_cc
def test_runs_that_differ_only_by_their_initial_states():
    """No per-run drive or feedthrough channel (the kernel's channel lists are empty)."""
    sizes, R, N = [2, 3], 6, 250
    blocks, W, drives, _, outputs, _ = _system(9, sizes, 1, N, scaled=False)
    x0 = np.random.default_rng(2).standard_normal((sum(sizes), R))
    got, xf = cr.compiled_block_recursion(blocks, W, drives, x0, outputs, N, final=True)
    ref, xr = _reference(blocks, W, drives, x0, outputs, N)
    for g, r in zip(sum(got, []), sum(ref, []), strict=True):
        _close(g, r)
    _close(xf, xr)
    assert not np.allclose(got[0][0][:, 0], got[0][0][:, 1])


def test_chunk_plan_cuts_long_records_in_time_for_several_runs():
    from geomfdi.limits import get_limits
    from geomfdi.simulation.streaming import MIN_RUN_SAMPLES, chunk_plan

    budget, width, N = get_limits().chunk_memory, 1000.0, 10**6
    assert chunk_plan(N, 100, width)[0] == 1  # one run at a time, the record cut in time
    Rc, L = chunk_plan(N, 100, width, min_runs=32)
    assert Rc == 32 and L >= MIN_RUN_SAMPLES and Rc * L * width <= budget
    assert chunk_plan(N, 5, width, min_runs=32)[0] == 5  # no more runs than there are
    # short records: as many whole records as the budget holds (more than min_runs)
    assert chunk_plan(1000, 100, width, min_runs=32) == (int(budget // width) // 1000, 1000)
