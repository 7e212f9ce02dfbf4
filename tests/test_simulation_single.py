"""The compiled single-run recursion against its definition, the numpy path and python-control;
the reused memory of the returned arrays."""

from __future__ import annotations

import gc
import mmap
import shutil
import sys

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import BackendFallbackWarning, GeomFDIError
from geomfdi.simulation import compiled_single as cs
from geomfdi.simulation import result_memory as rm
from geomfdi.simulation.initial_state import InitialStateWarning
from geomfdi.simulation.lifting import Drive, block_recursion

needs_cc = pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler (cc)")


pytestmark = pytest.mark.usefixtures("c_cache")


def _reference(blocks, W, drives, x0, outputs, N, direct=None):
    """``x[k+1] = A x[k] + W d[k]``, ``y = C x + D direct`` sample by sample (one run)."""
    sizes = [b.shape[0] for b in blocks]
    nS = sum(sizes)
    A = np.zeros((nS, nS))
    starts = np.cumsum([0] + sizes)
    for b, blk in enumerate(blocks):
        A[starts[b] : starts[b + 1], starts[b] : starts[b + 1]] = blk
    x = np.array(x0[:, 0], dtype=float)
    outs = [[np.zeros((C.shape[0], 1, N)) for C in o] for o in outputs]
    for k in range(N):
        for b, o in enumerate(outputs):
            for j, C in enumerate(o):
                y = C @ x[starts[b] : starts[b + 1]]
                if direct is not None and direct[1][b][j] is not None:
                    y = y + direct[1][b][j] @ np.concatenate([a[:, 0, k] for a in direct[0]])
                outs[b][j][:, 0, k] = y
        if k < N - 1:
            x = A @ x + W @ np.concatenate([d.window(k, 1)[:, 0, 0] for d in drives])
    return outs, x[:, None]


def _blocks(rng, kinds):
    """Stable blocks: ``real`` (diagonalisable, real modes), ``complex`` (pairs),
    ``jordan`` (defective: kept in its own coordinates)."""
    out = []
    for kind in kinds:
        if kind == "real":
            Q = np.linalg.qr(rng.standard_normal((4, 4)))[0]
            out.append(Q @ np.diag(rng.uniform(-0.9, 0.9, 4)) @ Q.T)
        elif kind == "complex":
            A = rng.standard_normal((5, 5))
            out.append(0.9 * A / np.max(np.abs(np.linalg.eigvals(A))))
        else:
            out.append(np.array([[0.7, 1.0, 0.0], [0.0, 0.7, 1.0], [0.0, 0.0, 0.7]]))
    return out


def _system(seed, kinds, N, *, scaled=True, with_direct=True, states=True, rows=2):
    rng = np.random.default_rng(seed)
    blocks = _blocks(rng, kinds)
    nS = sum(b.shape[0] for b in blocks)
    e = rng.standard_normal((3, 1, N))  # read at shifts 0 and 1 (first-order hold)
    other = rng.standard_normal((2, 1, N))
    drives = [Drive(e), Drive(e, 1), Drive(other)]
    if scaled:
        drives.append(Drive(other[:1], 0, rng.standard_normal((1, 1, N - 1))))
    W = rng.standard_normal((nS, sum(d.arr.shape[0] for d in drives)))
    x0 = rng.standard_normal((nS, 1))
    outputs = [
        [rng.standard_normal((rows, b.shape[0]))] + ([np.eye(b.shape[0])] if states else [])
        for b in blocks
    ]
    direct = None
    if with_direct:
        sig = [rng.standard_normal((4, 1, N)), e]
        direct = (sig, [[rng.standard_normal((rows, 7))] + [None] * states for _ in blocks])
    return blocks, W, drives, x0, outputs, direct


def _close(a, b, rtol=1e-11):
    assert a.shape == b.shape
    scale = max(float(np.max(np.abs(b))), 1e-300) if b.size else 1.0
    assert float(np.max(np.abs(a - b), initial=0.0)) <= rtol * scale


@needs_cc
@pytest.mark.parametrize(
    "kinds",
    [["real"], ["complex"], ["jordan"], ["real", "complex", "jordan", "real"], ["real"] * 5],
    ids=lambda k: "+".join(k),
)
@pytest.mark.parametrize("with_direct", [True, False])
@pytest.mark.parametrize("states", [True, False], ids=["states", "rows"])
def test_single_recursion_equals_its_definition_and_the_numpy_path(kinds, with_direct, states):
    N = 400
    rows = 1 if len(kinds) == 5 else 2  # one residual per block
    blocks, W, drives, x0, outputs, direct = _system(
        len(kinds), kinds, N, with_direct=with_direct, states=states, rows=rows
    )
    cs._SETUPS.clear()
    got, xf = cs.single_recursion(blocks, W, drives, x0, outputs, N, direct=direct, final=True)
    (st,) = cs._SETUPS.values()
    if not states:  # outputs of two rows: the modal form is cheaper where it exists
        assert (st.ca.size > 0) == ("complex" in kinds)
        padded = 4 * st.ilp - 20 if st.ilp else 0  # interleaved: rows of 8 modes, 3 unused
        assert 2 * st.ca.size + st.ar.size - padded == 4 * kinds.count("real") + 5 * kinds.count(
            "complex"
        )
        assert st.bs.sum() == 3 * kinds.count("jordan")
    if with_direct:  # the first-order hold of e folded (e is a feedthrough signal)
        assert len(st.folds) == 1
    # scalar residuals of five real blocks: the modes interleaved (2 vectors of outputs)
    assert st.ilp == (8 if kinds == ["real"] * 5 and not states else 0)
    ref, xr = _reference(blocks, W, drives, x0, outputs, N, direct)
    num, xn = block_recursion(blocks, W, drives, x0, outputs, N, direct=direct, final=True)
    for g, r, m in zip(sum(got, []), sum(ref, []), sum(num, []), strict=True):
        _close(g, r)
        _close(g, m)
    _close(xf, xr)
    _close(xf, xn)


@needs_cc
@pytest.mark.parametrize("N", [1, 2, 3])
def test_single_recursion_of_a_few_samples(N):
    blocks, W, drives, x0, outputs, direct = _system(9, ["complex", "real"], N, scaled=False)
    got, xf = cs.single_recursion(blocks, W, drives, x0, outputs, N, direct=direct, final=True)
    ref, xr = _reference(blocks, W, drives, x0, outputs, N, direct)
    for g, r in zip(sum(got, []), sum(ref, []), strict=True):
        _close(g, r)
    _close(xf, xr)


@needs_cc
def test_single_recursion_writes_strided_destinations_and_carries_the_state():
    """Consecutive windows overlapping by one sample, the outputs written into rows of
    one array (the engine's chunks): the same as one call over the record."""
    kinds, N = ["real", "complex"], 700
    blocks, W, drives, x0, outputs, direct = _system(3, kinds, N)
    outputs = [[o[0][:1]] for o in outputs]
    dm = [[m[0][:1]] for m in direct[1]]
    whole, _ = _reference(blocks, W, drives, x0, outputs, N, (direct[0], dm))
    rows = np.full((1, len(kinds), N), np.nan)
    x = x0
    for s, e1 in [(0, 251), (250, 480), (479, N)]:
        part = [
            Drive(d.arr[..., s:e1], d.shift, None if d.scale is None else d.scale[..., s:e1])
            for d in drives
        ]
        sig = [a[:, :, s:e1] for a in direct[0]]
        dests = [[rows[:, k : k + 1, s:e1].transpose(1, 0, 2)] for k in range(len(kinds))]
        res, x = cs.single_recursion(
            blocks, W, part, x, outputs, e1 - s, direct=(sig, dm), out=dests, final=True
        )
        assert np.shares_memory(res[0][0], rows)
    for k in range(len(kinds)):
        _close(rows[:, k], whole[k][0][0])


@needs_cc
@pytest.mark.parametrize("kind", ["jordan", "complex"])
def test_single_recursion_of_a_plant_whose_outputs_are_its_states(kind):
    blocks, W, drives, x0, outputs, _ = _system(5, [kind], 333, with_direct=False)
    n = blocks[0].shape[0]
    outputs = [[np.eye(n)]]
    cs._SETUPS.clear()
    got, xf = cs.single_recursion(blocks, W, drives, x0, outputs, 333, final=True)
    (st,) = cs._SETUPS.values()
    assert st.ilp == -1 and st.bs.sum() == n  # its own coordinates, the state copied out
    ref, xr = _reference(blocks, W, drives, x0, outputs, 333)
    _close(got[0][0], ref[0][0])
    _close(xf, xr)


@needs_cc
def test_single_recursion_with_a_block_of_order_zero():
    blocks, W, drives, x0, outputs, direct = _system(8, ["real", "complex"], 300, states=False)
    blocks.insert(1, np.zeros((0, 0)))  # a generator without states: feedthrough only
    outputs.insert(1, [np.zeros((2, 0))])
    direct[1].insert(1, [np.ones((2, 7))])
    got, xf = cs.single_recursion(blocks, W, drives, x0, outputs, 300, direct=direct, final=True)
    ref, xr = _reference(blocks, W, drives, x0, outputs, 300, direct)
    for g, r in zip(sum(got, []), sum(ref, []), strict=True):
        _close(g, r)
    _close(xf, xr)
    assert np.any(got[1][0] != 0)


def test_single_recursion_refuses_several_runs():
    blocks, W, drives, x0, outputs, _ = _system(1, ["real"], 50, scaled=False)
    with pytest.raises(GeomFDIError, match="one run"):
        cs.single_recursion(blocks, W, drives, np.hstack([x0, x0]), outputs, 50)


@needs_cc
def test_run_recursion_uses_the_single_kernel_for_one_run_only(monkeypatch):
    blocks, W, drives, x0, outputs, direct = _system(2, ["real"], 300)
    calls = []
    real = cs._single
    monkeypatch.setattr(cs, "_single", lambda *a, **k: calls.append(1) or real(*a, **k))
    cs.run_recursion(blocks, W, drives, x0, outputs, 300, direct=direct)
    assert calls == [1]
    cs.run_recursion(blocks, W, drives, np.hstack([x0, x0]), outputs, 300, direct=direct)
    assert calls == [1]  # two runs: the batch kernel or numpy
    monkeypatch.setenv("GEOMFDI_SIM_BACKEND", "numpy")
    got = cs.run_recursion(blocks, W, drives, x0, outputs, 300, direct=direct)
    ref = block_recursion(blocks, W, drives, x0, outputs, 300, direct=direct)
    assert calls == [1]
    for a, b in zip(sum(got, []), sum(ref, []), strict=True):
        assert np.array_equal(a, b)


def test_run_recursion_without_a_compiler_is_the_numpy_path(monkeypatch, tmp_path):
    monkeypatch.setenv("CC", "no-such-compiler-xyz")
    monkeypatch.setenv("GEOMFDI_CACHE_DIR", str(tmp_path))
    blocks, W, drives, x0, outputs, direct = _system(4, ["real", "complex"], 200)
    with pytest.warns(BackendFallbackWarning, match="compiler"):
        got = cs.run_recursion(blocks, W, drives, x0, outputs, 200, direct=direct)
    ref = block_recursion(blocks, W, drives, x0, outputs, 200, direct=direct)
    for a, b in zip(sum(got, []), sum(ref, []), strict=True):
        assert np.array_equal(a, b)
    with pytest.raises(GeomFDIError, match="compiler"):
        cs.single_recursion(blocks, W, drives, x0, outputs, 200, direct=direct)


# ------------------------------------------------------------------ simulate


def _twelve_states(nb=4, n=12, m=3, seed=1):
    rng = np.random.default_rng(seed)
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    A = Q @ np.diag(-rng.uniform(0.2, 3.0, n)) @ Q.T + 0.3 * rng.standard_normal((n, n))
    B = rng.standard_normal((n, m))
    C = np.eye(n) + 0.1 * rng.standard_normal((n, n))
    Ci = np.linalg.inv(C)
    gens = []
    for _ in range(nb):
        Qj = np.linalg.qr(rng.standard_normal((n, n)))[0]
        F = Qj @ np.diag(-rng.uniform(0.5, 5.0, n)) @ Qj.T
        P = rng.standard_normal((n, n))
        M = rng.standard_normal((1, n))
        gens.append(gf.ResidualGenerator(F, (F @ P - P @ A) @ Ci, P @ B, M, M @ P @ Ci, 0 * B[:1]))
    S = np.zeros((nb, n), dtype=bool)
    bank = gf.ResidualBank(gens, S, S, np.zeros(n, bool), ["ok"] * nb, [gf.SensorFault(0)])
    return gf.Plant(A, B, C), bank


@needs_cc
@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"faults": [gf.BiasFault(2, start=1.0, bias=0.3)], "threshold": 0.05},
        {"faults": [gf.GainFault(1, start=0.7, gain=1.5)], "keep_states": True},
        {"noise": gf.Noise(measurement=1e-3, seed=4), "x0": np.linspace(-1, 1, 12)},
    ],
    ids=["healthy", "bias", "gain+states", "noise"],
)
def test_simulate_compiled_equals_numpy_path(kw, monkeypatch):
    plant, bank = _twelve_states()
    t = np.arange(1500) * 2e-3
    u = np.vstack([np.sin(3 * t), np.cos(2 * t), 0.2 * np.ones_like(t)])
    got = gf.simulate(plant, bank, t, u, **kw)
    monkeypatch.setenv("GEOMFDI_SIM_BACKEND", "numpy")
    ref = gf.simulate(plant, bank, t, u, **kw)
    scale = max(1.0, float(np.max(np.abs(ref.residuals))))
    assert np.max(np.abs(got.residuals - ref.residuals)) <= 1e-10 * scale
    assert np.max(np.abs(got.x - ref.x)) <= 1e-10 * max(1.0, float(np.max(np.abs(ref.x))))
    for a, b in [(got.y, ref.y), (got.y_healthy, ref.y_healthy), (got.u, ref.u)]:
        assert np.max(np.abs(a - b)) <= 1e-10 * max(1.0, float(np.max(np.abs(b))))
    assert np.array_equal(got.alarms, ref.alarms)
    if kw.get("keep_states"):
        for a, b in zip(got.w, ref.w, strict=True):
            assert np.max(np.abs(a - b)) <= 1e-10 * max(1.0, float(np.max(np.abs(b))))


@needs_cc
def test_simulate_short_record_equals_forced_response():
    control = pytest.importorskip("control")
    plant, bank = _twelve_states(nb=3)
    n, m = plant.n, plant.m
    t = np.arange(2000) * 1e-3
    u = np.vstack([np.sin(5 * t), np.cos(3 * t), 0.2 * np.ones_like(t)])
    x0 = np.linspace(-1.0, 1.0, n)
    Cy = np.vstack([plant.C, np.zeros((m, n))])
    aug = control.ss(plant.A, plant.B, Cy, np.vstack([0 * plant.B, np.eye(m)]))
    ref = control.forced_response(aug, t, u, X0=x0)
    res = gf.simulate(plant, bank, t, u, x0=x0)
    assert np.max(np.abs(res.x - ref.states)) <= 1e-9 * np.max(np.abs(ref.states))
    assert np.max(np.abs(res.y - ref.outputs[:n])) <= 1e-9 * np.max(np.abs(ref.outputs[:n]))
    assert np.max(np.abs(res.residuals)) <= 1e-9  # consistent start: healthy residuals vanish


# ------------------------------------------------------------------ result memory


def _address(a):
    return a.__array_interface__["data"][0]


def test_result_memory_is_reused_only_when_dropped(monkeypatch):
    monkeypatch.setattr(rm._LOCAL, "blocks", [], raising=False)
    a = rm.empty((40, 1000))
    assert a.shape == (40, 1000) and a.flags.c_contiguous and a.flags.writeable
    a[...] = 1.0
    where = _address(a)
    b = rm.empty((40, 1000))
    assert not np.shares_memory(a, b)  # a is alive: another block
    del a
    gc.collect()
    c = rm.empty((40, 1000))
    assert _address(c) == where  # a was dropped: its block again
    view = c[:, 0]
    del c
    d = rm.empty((40, 1000))
    assert not np.shares_memory(view, d)  # a view keeps its block
    small = rm.empty((3,), dtype=bool)
    assert small.base is None  # small arrays: plain numpy


def test_result_memory_budget(monkeypatch):
    monkeypatch.setattr(rm, "_POOL_BYTES", 2**20)
    monkeypatch.setattr(rm._LOCAL, "blocks", [], raising=False)
    keep = [rm.empty((2**16,)) for _ in range(3)]  # 1.5 MiB: the third one is plain
    assert keep[0].base is not None and keep[1].base is not None and keep[2].base is None
    del keep
    gc.collect()
    again = rm.empty((2**17,))  # the freed blocks are dropped to make room
    assert again.base is not None and len(rm._LOCAL.blocks) == 1


def _mapping(a):
    """The mmap object at the end of ``a``'s chain of bases (None: numpy's own memory)."""
    while a is not None and not isinstance(a, mmap.mmap):
        a = getattr(a, "base", None) if isinstance(a, np.ndarray) else getattr(a, "obj", None)
    return a


@pytest.mark.skipif(not hasattr(mmap, "MAP_POPULATE"), reason="no MAP_POPULATE here")
def test_mapped_arrays_are_populated_mappings_with_numpy_semantics(monkeypatch):
    big = rm.mapped((3, 50_000), int, fill=-7)  # 1.2 MB: a mapping
    assert _mapping(big) is not None and big.shape == (3, 50_000) and big.dtype == int
    assert big.flags.c_contiguous and big.flags.writeable and np.all(big == -7)
    zeros = rm.mapped((2**20,), bool)
    assert _mapping(zeros) is not None and not zeros.any()
    small = rm.mapped((10, 10))
    assert _mapping(small) is None and not small.any()  # plain numpy under 1 MiB
    other = rm.mapped((3, 50_000), int)
    assert not np.shares_memory(big, other) and not other.any()
    # the pool's overflow and arrays of 4 MiB and more are mapped too
    monkeypatch.setattr(rm, "_POOL_BYTES", 2**20)
    monkeypatch.setattr(rm._LOCAL, "blocks", [], raising=False)
    keep = [rm.empty((2**17,)) for _ in range(2)]  # 1 MiB each: the second overflows
    assert _mapping(keep[1]) is not None
    assert _mapping(rm.empty((2**19,))) is not None
    gc.collect()


def _resident_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * mmap.PAGESIZE


@pytest.mark.skipif(
    not sys.platform.startswith("linux") or not hasattr(mmap, "MAP_POPULATE"),
    reason="Linux's resident set and MAP_POPULATE",
)
@pytest.mark.parametrize("threads", [1, 2])
def test_large_mapped_arrays_are_resident_before_their_first_use(monkeypatch, threads):
    # populated by one MAP_POPULATE, or by two threads' madvise (MADV_POPULATE_WRITE),
    # each a half: every page is in memory when mapped returns, and reads as the fill
    from geomfdi._threads import using_work_threads

    monkeypatch.setattr(rm, "_PARALLEL_BYTES", 2**22)
    shape = (2, 2**21)  # 32 MiB of float64
    before = _resident_bytes()
    with using_work_threads(threads):
        a = rm.mapped(shape, fill=None)
    grown = _resident_bytes() - before
    assert grown >= 0.95 * a.nbytes, (grown, a.nbytes)
    assert _mapping(a) is not None and not a.any()
    with using_work_threads(threads):
        b = rm.mapped((2**22,), np.int64, fill=-3)
    assert np.all(b == -3) and not np.shares_memory(a, b)


def test_simulate_results_do_not_share_memory():
    plant, bank = _twelve_states(nb=2)
    t = np.arange(3000) * 1e-3
    u = np.vstack([np.sin(3 * t), np.cos(2 * t), 0.2 * np.ones_like(t)])
    r1 = gf.simulate(plant, bank, t, u, threshold=1.0)
    r2 = gf.simulate(plant, bank, t, 2 * u, threshold=1.0)
    arrays = [r1.x, r1.y, r1.y_healthy, r1.u, r1.residuals, r1.alarms, r1.isolated]
    for a in arrays:
        for b in [r2.x, r2.y, r2.y_healthy, r2.u, r2.residuals, r2.alarms, r2.isolated]:
            assert not np.shares_memory(a, b)
    for i, a in enumerate(arrays):
        for b in arrays[i + 1 :]:
            assert not np.shares_memory(a, b)
    assert np.allclose(r2.x, 2 * r1.x, atol=1e-12)  # r1 kept its values


@needs_cc
@pytest.mark.parametrize("kw", [{}, {"faults": [gf.BiasFault(0, start=0.5, bias=0.2)]}])
def test_discrete_plant_compiled_equals_numpy_path(kw, monkeypatch):
    import warnings

    import scipy.linalg

    plant, bank = _twelve_states(nb=4)
    dt, n, m = 1e-2, plant.n, plant.m
    E = scipy.linalg.expm(np.block([[plant.A, plant.B], [np.zeros((m, n + m))]]) * dt)
    dplant = gf.Plant(E[:n, :n], E[:n, n:], plant.C, dt=dt)
    dbank = bank.discretize(dt)
    t = np.arange(800) * dt
    u = np.vstack([np.sin(3 * t), np.cos(2 * t), 0.2 * np.ones_like(t)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the sampled bank is not exactly consistent
        got = gf.simulate(dplant, dbank, t, u, **kw)
        monkeypatch.setenv("GEOMFDI_SIM_BACKEND", "numpy")
        ref = gf.simulate(dplant, dbank, t, u, **kw)
    for a, b in [(got.residuals, ref.residuals), (got.x, ref.x), (got.y, ref.y)]:
        assert np.max(np.abs(a - b)) <= 1e-10 * max(1.0, float(np.max(np.abs(b))))


@needs_cc
def test_vector_residual_compiled_equals_numpy_path(monkeypatch):
    plant, bank = _twelve_states(nb=4)
    g = bank.generators[0]
    rng = np.random.default_rng(3)
    M2 = np.vstack([g.M, rng.standard_normal((1, g.order))])
    # a second residual component that the healthy loop drives (no consistent start)
    H2 = np.vstack([g.H, rng.standard_normal((1, plant.q))])
    g2 = gf.ResidualGenerator(g.F, g.E, g.G, M2, H2, np.zeros((2, 3)))
    gens = [g2] + list(bank.generators[1:])
    S = np.zeros((4, 12), dtype=bool)
    vbank = gf.ResidualBank(gens, S, S, np.zeros(12, bool), ["ok"] * 4, [gf.SensorFault(0)])
    t = np.arange(1200) * 2e-3
    u = np.vstack([np.sin(3 * t), np.cos(2 * t), 0.2 * np.ones_like(t)])
    kw = dict(faults=[gf.BiasFault(3, start=1.0, bias=0.4)], keep_states=True)
    with pytest.warns(InitialStateWarning):
        got = gf.simulate(plant, vbank, t, u, **kw)
    monkeypatch.setenv("GEOMFDI_SIM_BACKEND", "numpy")
    with pytest.warns(InitialStateWarning):
        ref = gf.simulate(plant, vbank, t, u, **kw)
    assert got.residual_vectors[0].shape == (2, t.size)
    for a, b in [
        (got.residuals, ref.residuals),
        (got.residual_vectors[0], ref.residual_vectors[0]),
    ]:
        assert np.max(np.abs(a - b)) <= 1e-10 * max(1.0, float(np.max(np.abs(b))))
    for a, b in zip(got.w, ref.w, strict=True):
        assert np.max(np.abs(a - b)) <= 1e-10 * max(1.0, float(np.max(np.abs(b))))
