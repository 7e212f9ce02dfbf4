"""numpy's PCG64 normals drawn by the compiled loop: the same bits and the same final
generator state as ``Generator.standard_normal``, rejections included, and numpy's own
draws wherever the loop does not apply."""

from __future__ import annotations

import ctypes
import threading

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.simulation import pcg64_normal as pn
from geomfdi.simulation.noise import NoiseStream


@pytest.fixture
def compiled(c_cache):
    if not pn.compiled():
        pytest.skip("no C compiler")


def bits(a):
    return np.ascontiguousarray(a).view(np.uint64)


def draw_both(seed, shape):
    a, b = np.random.default_rng(seed), np.random.default_rng(seed)
    theirs = a.standard_normal(shape)
    mine = pn.standard_normal(b, np.empty(shape))
    return a, b, theirs, mine


@pytest.mark.parametrize("seed", [0, 7, 2**40 + 3, np.random.SeedSequence(99)])
def test_the_normals_and_the_state_are_numpys(compiled, seed):
    a, b, theirs, mine = draw_both(seed, (3, 200_001))
    np.testing.assert_array_equal(bits(mine), bits(theirs))
    assert a.bit_generator.state == b.bit_generator.state
    # the generator goes on as numpy's would, for normals and for anything else
    np.testing.assert_array_equal(a.standard_normal(5000), pn.standard_normal(b, np.empty(5000)))
    np.testing.assert_array_equal(a.integers(0, 2**62, 9), b.integers(0, 2**62, 9))


def test_the_rejection_steps_are_taken_and_agree(compiled):
    """About 1.5 % of the draws leave the fast path (the wedges, the tail of layer 0,
    all of layer 1): a million draws take every kind many times, the tail beyond
    ``r = 3.654`` included, and all of them agree with numpy."""
    _, _, theirs, mine = draw_both(5, 10**6)
    np.testing.assert_array_equal(bits(mine), bits(theirs))
    assert np.sum(np.abs(theirs) > 3.6541528853610088) > 100  # the tail
    # layer 1 (no fast path) is numpy's: its draws equal too (checked above); the
    # table of the fast path rejects every m there
    lib = pn._kernel()
    fill = lib[0]
    st = np.array([1, 2, 3, 5], dtype=np.uint64)
    out = np.empty(10**5)
    slow = fill(lib[1], st.ctypes.data, out.size, out.ctypes.data)
    assert 0.01 < slow / out.size < 0.02


def test_a_kernel_one_ulp_off_is_refused_at_load(compiled):
    """The check at load compares with numpy bit for bit: a fast path off by one ulp in
    one draw, or leaving the generator one step behind, fails it (and the library
    loader then lets numpy draw, with a warning)."""
    fill, fn = pn._kernel()
    assert pn._agrees((fill, fn))

    def ulp_off(f, st, n, out):
        r = fill(f, st, n, out)
        x = np.frombuffer((ctypes.c_double * n).from_address(out), dtype=float)
        x[n // 2] = np.nextafter(x[n // 2], np.inf)
        return r

    def behind(f, st, n, out):
        return fill(f, st, n - 1, out) + fill(f, (ctypes.c_uint64 * 4)(), 1, out + 8 * (n - 1))

    assert not pn._agrees((ulp_off, fn))
    assert not pn._agrees((behind, fn))


def test_a_numpy_without_the_function_draws_itself(monkeypatch):
    def missing():
        raise AttributeError("random_standard_normal")

    monkeypatch.setattr(pn, "_numpy_normal", missing)
    with pytest.warns(gf.BackendFallbackWarning, match="not found"):
        assert pn._bind(None) is None


def test_where_the_loop_does_not_apply_numpy_draws(compiled):
    # another bit generator, an out in Fortran order, a short draw: numpy's values
    for rng_of in (
        lambda: np.random.Generator(np.random.Philox(3)),
        lambda: np.random.Generator(np.random.PCG64DXSM(3)),
    ):
        a, b = rng_of(), rng_of()
        np.testing.assert_array_equal(
            a.standard_normal(10**4), pn.standard_normal(b, np.empty(10**4))
        )
    a, b = np.random.default_rng(4), np.random.default_rng(4)
    fortran = pn.standard_normal(b, np.empty((4, 5000), order="F"))  # numpy's memory order
    np.testing.assert_array_equal(fortran, a.standard_normal(out=np.empty((4, 5000), order="F")))
    a, b = np.random.default_rng(4), np.random.default_rng(4)
    np.testing.assert_array_equal(
        pn.standard_normal(b, np.empty(pn.MIN_DRAWS - 1)), a.standard_normal(pn.MIN_DRAWS - 1)
    )
    assert a.bit_generator.state == b.bit_generator.state


def test_the_numpy_backend_draws_with_numpy(compiled, monkeypatch):
    monkeypatch.setenv("GEOMFDI_SIM_BACKEND", "numpy")
    assert not pn.compiled()
    a, b, theirs, mine = draw_both(3, 10**4)
    np.testing.assert_array_equal(mine, theirs)


def test_without_a_compiler_numpy_draws_with_a_warning(compiled, tmp_path, monkeypatch):
    monkeypatch.setenv("GEOMFDI_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    with pytest.warns(gf.BackendFallbackWarning, match="numpy draws them"):
        _, _, theirs, mine = draw_both(3, 10**4)
    np.testing.assert_array_equal(mine, theirs)


def test_threads_drawing_from_their_own_generators_agree(compiled):
    seeds = range(8)
    want = [np.random.default_rng(s).standard_normal(3 * 10**5) for s in seeds]
    got = [None] * len(want)

    def work(i):
        got[i] = pn.standard_normal(np.random.default_rng(i), np.empty(3 * 10**5))

    threads = [threading.Thread(target=work, args=(i,)) for i in seeds]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for w, g in zip(want, got, strict=True):
        np.testing.assert_array_equal(g, w)


def test_noise_streams_draw_numpys_blocks(compiled):
    """The measurement and process blocks of a :class:`NoiseStream` are what
    ``rng.standard_normal((rows, L))`` gives, block after block."""
    N = 150_000
    st = NoiseStream(np.random.default_rng(12), 3, 2, N)
    zv, zw = st.take(0, N)
    ref = np.random.default_rng(12)
    want_v, want_w = [], []
    for s in range(0, N, st.block):
        L = min(st.block, N - s)
        want_v.append(ref.standard_normal((3, L)))
        want_w.append(ref.standard_normal((2, L)))
    np.testing.assert_array_equal(zv, np.hstack(want_v))
    np.testing.assert_array_equal(zw, np.hstack(want_w))
