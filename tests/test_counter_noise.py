"""The counter noise generator: Philox4x32-10 known answers, C = numpy bit for bit,
statistics of the normals, and the same draws whatever the chunking, threads and runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.stats

import geomfdi as gf
from geomfdi._cbuild import load_kernel
from geomfdi.errors import GeomFDIError
from geomfdi.simulation import counter_normal as cn
from geomfdi.simulation.context import prepare
from geomfdi.simulation.noise import CounterSource, CounterStream
from geomfdi.simulation.simulate import noise_streams, noise_window

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

# Random123's known-answer vectors for Philox4x32-10 (its tests/kat_vectors):
# counter (4 words), key (2 words) -> output (4 words)
KAT = [
    ((0, 0, 0, 0), (0, 0), (0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8)),
    ((0xFFFFFFFF,) * 4, (0xFFFFFFFF,) * 2, (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)),
    (
        (0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344),
        (0xA4093822, 0x299F31D0),
        (0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1),
    ),
]


def philox_by_hand(ctr, key, rounds=10):
    """Salmon et al. (2011), Philox4x32: Python integers, one counter."""
    x0, x1, x2, x3 = ctr
    k0, k1 = key
    for _ in range(rounds):
        p0, p1 = 0xD2511F53 * x0, 0xCD9E8D57 * x2
        x0, x1, x2, x3 = (
            (p1 >> 32) ^ x1 ^ k0,
            p1 & 0xFFFFFFFF,
            (p0 >> 32) ^ x3 ^ k1,
            p0 & 0xFFFFFFFF,
        )
        k0, k1 = (k0 + 0x9E3779B9) & 0xFFFFFFFF, (k1 + 0xBB67AE85) & 0xFFFFFFFF
    return (x0, x1, x2, x3)


@pytest.fixture
def compiled(c_cache):
    if not cn.compiled():
        pytest.skip("no C compiler")


def keys_of(seeds):
    return np.stack([cn.run_key(s) for s in seeds])


def normals(keys, stream, s, e, rows=1, row0=0):
    out = np.empty((len(keys), rows, e - s))
    return cn.fill_normals(keys, stream, row0, s, e, out)


# ------------------------------------------------------------------ Philox
@pytest.mark.parametrize(("ctr", "key", "want"), KAT)
def test_philox_known_answers(compiled, ctr, key, want):
    assert tuple(cn.philox4x32(np.array(ctr), np.array(key)).tolist()) == want
    assert tuple(cn.compiled_philox(np.array(ctr), np.array(key)).tolist()) == want
    assert philox_by_hand(ctr, key) == want


def test_philox_equals_the_definition_on_random_counters(compiled):
    rng = np.random.default_rng(3)
    ctr = rng.integers(0, 2**32, (200, 4), dtype=np.uint64).astype(np.uint32)
    key = rng.integers(0, 2**32, (200, 2), dtype=np.uint64).astype(np.uint32)
    want = np.array(
        [
            philox_by_hand(tuple(map(int, c)), tuple(map(int, k)))
            for c, k in zip(ctr, key, strict=True)
        ]
    )
    np.testing.assert_array_equal(cn.philox4x32(ctr, key), want)
    np.testing.assert_array_equal(cn.compiled_philox(ctr, key), want)


def test_the_normals_are_the_documented_function_of_the_counter():
    """Sample 2j and 2j+1 of (key, stream, row) from Philox of (j, row, 4 tag + stream)."""
    key = cn.run_key(77)
    j, row, stream = 5, 2, 1
    ctr = (j, 0, row, ((int(key[2]) << 2) & 0xFFFFFFFF) | stream)
    x = philox_by_hand(ctr, (int(key[0]), int(key[1])))
    u = (((x[1] << 32 | x[0]) >> 11) + 1) / 2.0**53
    v = (((x[3] << 32 | x[2]) >> 11) + 1) / 2.0**53
    rho = np.sqrt(-2 * np.log(u))
    z = cn.numpy_normals(key[None], stream, row, 2 * j, 2 * j + 2, np.empty((1, 1, 2)))
    np.testing.assert_allclose(z[0, 0], [rho * np.cos(2 * np.pi * v), rho * np.sin(2 * np.pi * v)],
                               rtol=1e-14, atol=1e-15)  # fmt: skip


# ------------------------------------------------------------- C = numpy
@pytest.mark.parametrize(
    ("s", "e"),
    [(0, 4000), (7, 1008), (1, 2), (2, 3), (5, 5), (0, 1), (3, 130), (2**33 - 301, 2**33 + 77)],
)  # the last: pairs j across 2^32 (the counter's second word)
def test_compiled_and_numpy_normals_are_the_same_bits(compiled, s, e):
    keys = keys_of([0, 1, 2**40, np.random.SeedSequence(9).spawn(3)[2]])
    for stream in (0, 1, 2):
        c = normals(keys, stream, s, e, rows=3, row0=4)
        ref = cn.numpy_normals(keys, stream, 4, s, e, np.empty((4, 3, e - s)))
        np.testing.assert_array_equal(c.view(np.uint64), ref.view(np.uint64))


def test_the_kernel_without_avx2_gives_the_same_bits(compiled, monkeypatch):
    """The portable loops (no AVX2: ``-mno-avx2`` after ``-march=native``) against numpy,
    on a tile's worth of pairs and across the counter's second word."""
    lib = load_kernel(
        "gfnoise_plain", cn._SOURCE, cn._bind, flags=("-fno-math-errno", *cn._DEFINES, "-mno-avx2")
    )
    if lib is None:
        pytest.skip("the compiler refuses -mno-avx2")
    monkeypatch.setattr(cn, "_library", lambda: lib)
    keys = keys_of([3, 2**33])
    for s, e in [(0, 1100), (2**33 - 40, 2**33 + 41)]:
        c = normals(keys, 1, s, e, rows=2, row0=1)
        ref = cn.numpy_normals(keys, 1, 1, s, e, np.empty((2, 2, e - s)))
        np.testing.assert_array_equal(c.view(np.uint64), ref.view(np.uint64))


def test_extreme_words_are_the_same_bits(compiled):
    """Words that give u = 2^-53 and u = 1, and angles on quarter turns (through the
    numpy functions on chosen words, against the compiled fill on its own counters)."""
    w = np.array([0, 2**64 - 1, 2**11 - 1, 2**62, 2**63, 3 * 2**62, 2**61 + 2**10], dtype=np.uint64)
    u = ((w >> np.uint64(11)) + np.uint64(1)).astype(float) * 2.0**-53
    assert u.min() == 2.0**-53 and u.max() == 1.0
    lg = cn.log_unit(u)
    np.testing.assert_allclose(lg, np.log(u), rtol=2.3e-16, atol=0)
    c, s = cn.quarter_sincos(w)
    v = u
    np.testing.assert_allclose(c, np.cos(2 * np.pi * v), atol=3e-16)
    np.testing.assert_allclose(s, np.sin(2 * np.pi * v), atol=3e-16)
    assert np.array_equal(np.signbit(c[[1, 4]]), [False, True])  # cos(2 pi), cos(pi)


def test_log_sin_cos_are_accurate_to_a_few_ulp():
    rng = np.random.default_rng(0)
    u = np.concatenate([rng.random(200_000), 1 - rng.random(10_000) * 1e-9,
                        2.0 ** -rng.uniform(1, 53, 50_000)])  # fmt: skip
    u = u[u > 0]
    ulp = np.abs(cn.log_unit(u) - np.log(u)) / np.spacing(np.abs(np.log(u)))
    assert ulp.max() <= 2
    w = rng.integers(0, 2**64, 200_000, dtype=np.uint64)
    v = ((w >> np.uint64(11)) + np.uint64(1)).astype(float) * 2.0**-53
    c, s = cn.quarter_sincos(w)
    assert np.max(np.abs(c - np.cos(2 * np.pi * v))) < 1e-15
    assert np.max(np.abs(s - np.sin(2 * np.pi * v))) < 1e-15
    assert np.max(np.abs(c**2 + s**2 - 1)) <= 4.5e-16 * 2


# -------------------------------------------------------------- statistics
@pytest.fixture(scope="module")
def sample():
    """4 runs x 3 rows x 2^19 samples of the measurement stream (C or numpy)."""
    keys = keys_of(np.random.SeedSequence(2024).spawn(4))
    return keys, normals(keys, 0, 0, 2**19, rows=3)


def test_moments(sample):
    z = sample[1].ravel()
    n = z.size
    assert abs(z.mean()) < 5 / np.sqrt(n)
    assert abs(z.var() - 1) < 5 * np.sqrt(2 / n)
    assert abs(scipy.stats.skew(z)) < 5 * np.sqrt(6 / n)
    assert abs(scipy.stats.kurtosis(z)) < 5 * np.sqrt(24 / n)


def test_kolmogorov_smirnov_and_tails(sample):
    z = sample[1].ravel()
    assert scipy.stats.kstest(z[:400_000], "norm").pvalue > 1e-3
    for k in (3.0, 4.0):
        p = 2 * scipy.stats.norm.sf(k)
        hits = np.count_nonzero(np.abs(z) > k)
        assert abs(hits - p * z.size) < 5 * np.sqrt(p * z.size), (k, hits, p * z.size)
    # chi-square of 100 bins of equal probability
    edges = scipy.stats.norm.ppf(np.linspace(0, 1, 101))
    counts = np.histogram(z, edges)[0]
    assert scipy.stats.chisquare(counts).pvalue > 1e-3


def test_no_correlation_between_samples_rows_runs_and_streams(sample):
    keys, z = sample
    n = z.shape[-1]
    bound = 5 / np.sqrt(n)

    def corr(a, b):
        return np.corrcoef(a, b)[0, 1]

    for lag in (1, 2, 3):  # lag 1 within and across Box-Muller pairs
        assert abs(corr(z[0, 0, :-lag], z[0, 0, lag:])) < 5 / np.sqrt(n - lag)
    assert abs(corr(z[0, 0], z[0, 1])) < bound and abs(corr(z[0, 1], z[0, 2])) < bound
    assert abs(corr(z[0, 0], z[1, 0])) < bound and abs(corr(z[2, 2], z[3, 2])) < bound
    other = normals(keys[:1], 1, 0, n)  # the process stream of the same run and row
    assert abs(corr(z[0, 0], other[0, 0])) < bound
    inputs = normals(keys[:1], 2, 0, n)
    assert abs(corr(other[0, 0], inputs[0, 0])) < bound


def test_box_muller_pairs_are_independent(sample):
    z = sample[1][:, :, :].reshape(-1, 2)  # (z(2j), z(2j+1))
    a, b = z[:, 0], z[:, 1]
    m = a.size
    assert abs(np.corrcoef(a**2, b**2)[0, 1]) < 5 / np.sqrt(m)
    assert abs(np.corrcoef(np.abs(a), np.abs(b))[0, 1]) < 5 / np.sqrt(m)
    # radius^2 exponential with mean 2, angle uniform
    assert scipy.stats.kstest((a**2 + b**2)[:300_000], "expon", args=(0, 2)).pvalue > 1e-3
    ang = np.arctan2(b, a)[:300_000]
    assert scipy.stats.kstest(ang, "uniform", args=(-np.pi, 2 * np.pi)).pvalue > 1e-3


# ------------------------------------------- the same draws, however they are cut
def test_ranges_of_any_size_give_the_same_normals(compiled):
    keys = keys_of([5, 6, 7])
    whole = normals(keys, 1, 0, 5000, rows=2)
    cuts = [0, 1, 2, 65, 1000, 1001, 4097, 5000]
    parts = [normals(keys, 1, a, b, rows=2) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    np.testing.assert_array_equal(np.concatenate(parts, axis=-1), whole)
    # one run at a time, one row at a time
    np.testing.assert_array_equal(normals(keys[1:2], 1, 0, 5000, rows=1, row0=1)[0, 0], whole[1, 1])


def test_the_numpy_backend_draws_the_same_noise(compiled, monkeypatch):
    keys = keys_of([11, 12])
    c = normals(keys, 0, 3, 2000, rows=2)
    monkeypatch.setenv("GEOMFDI_SIM_BACKEND", "numpy")
    assert not cn.compiled()
    np.testing.assert_array_equal(normals(keys, 0, 3, 2000, rows=2), c)


def test_without_a_compiler_the_numpy_path_warns_and_draws_the_same(
    compiled, tmp_path, monkeypatch
):
    keys = keys_of([3])
    c = normals(keys, 2, 0, 999, rows=2)
    monkeypatch.setenv("GEOMFDI_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    with pytest.warns(gf.BackendFallbackWarning, match="numpy"):
        z = normals(keys, 2, 0, 999, rows=2)
    np.testing.assert_array_equal(z, c)


def _ctx(noise):
    plant = gf.Plant(np.diag([0.5, 0.8, -0.3]), np.eye(3)[:, :1], np.eye(3), dt=0.1)
    bank = gf.design_sensor_bank(plant)
    return prepare(
        plant, bank, np.arange(3000) * 0.1, None, None, noise, None, "zoh", True, False, None
    ), plant


def test_noise_windows_do_not_depend_on_chunks_threads_or_runs(compiled):
    cov = np.diag([1.0, 2.0, 0.5]) @ np.ones((3, 3)) @ np.diag([1.0, 2.0, 0.5]) * 0.01
    noise = gf.Noise(
        measurement=[0.1, 0.2, 0.3], process=cov + np.eye(3) * 1e-3, seed=4, generator="counter"
    )  # a full process covariance: scaled run by run
    ctx, plant = _ctx(noise)
    seeds = np.random.SeedSequence(4).spawn(9)
    kp = noise.process_rows(plant)
    N = ctx.N

    def windows(cuts, parts, idx):
        streams = noise_streams(ctx, [noise.source(seeds[i], kp) for i in idx])
        vs, ws = [], []
        for a, b in zip(cuts[:-1], cuts[1:], strict=True):
            v, w = noise_window(ctx, streams, a, b, parts=parts)
            vs.append(v.copy())
            ws.append(w.copy())
        return np.concatenate(vs, axis=-1), np.concatenate(ws, axis=-1)

    v0, w0 = windows([0, N], 1, range(9))
    v1, w1 = windows([0, 17, 1000, 2999, N], 2, range(9))
    np.testing.assert_array_equal(v0, v1)
    np.testing.assert_array_equal(w0, w1)
    for i in (0, 7):  # one run alone: what gf.simulate of that seed draws
        vi, wi = windows([0, 500, N], 1, [i])
        np.testing.assert_array_equal(vi[:, 0], v0[:, i])
        np.testing.assert_array_equal(wi[:, 0], w0[:, i])
    assert np.all(np.abs(np.corrcoef(v0[0])[np.triu_indices(9, 1)]) < 0.1)


def test_simulate_draws_the_counter_normals_of_its_seed(compiled):
    plant = gf.Plant(np.diag([0.5, 0.8, -0.3]), np.eye(3)[:, :1], np.eye(3), dt=0.1)
    bank = gf.design_sensor_bank(plant)
    t = np.arange(2000) * 0.1
    sig = np.array([0.1, 0.2, 0.3])
    noisy = gf.simulate(
        plant, bank, t, noise=gf.Noise(measurement=sig, seed=8, generator="counter")
    )
    clean = gf.simulate(plant, bank, t)
    z = normals(cn.run_key(8)[None], 0, 0, t.size, rows=3)[0]
    np.testing.assert_allclose(noisy.y - clean.y, sig[:, None] * z, rtol=0, atol=1e-13)
    numpy_gen = gf.simulate(plant, bank, t, noise=gf.Noise(measurement=sig, seed=8))
    assert not np.allclose(numpy_gen.y, noisy.y)


def test_batch_equals_a_loop_of_simulate(compiled):
    plant = gf.Plant(np.diag([0.5, 0.8, -0.3]), np.eye(3)[:, :1], np.eye(3), dt=0.1)
    bank = gf.design_sensor_bank(plant)
    t = np.arange(1500) * 0.1
    noise = gf.Noise(measurement=0.1, process=0.05, seed=21, generator="counter")
    kw = dict(noise=noise, threshold=0.3, store="all", progress=False)
    a = gf.simulate_batch(plant, bank, t, runs=6, **kw)
    b = gf.simulate_batch(plant, bank, t, runs=6, chunk_size=2, **kw)
    np.testing.assert_array_equal(a.y, b.y)
    for i in (0, 5):
        noise_i = gf.Noise(measurement=0.1, process=0.05, seed=a.seeds[i], generator="counter")
        one = gf.simulate(plant, bank, t, noise=noise_i, threshold=0.3)
        np.testing.assert_allclose(a.residuals[i], one.residuals, rtol=1e-10, atol=1e-13)
        np.testing.assert_array_equal(a.alarms[i], one.alarms)
        np.testing.assert_allclose(a.y[i], one.y, rtol=1e-12, atol=1e-13)


def test_noise_inputs_are_a_stream_of_their_own(compiled):
    A, B = np.diag([0.5, 0.8]), np.eye(2)[:, :1]
    plant = gf.Plant(A, B, np.eye(2), Bw=np.eye(2), Dw=np.zeros((2, 2)), dt=0.1)
    base = dict(process=0.1, seed=3, generator="counter")
    ctx1, _ = _ctx_for(plant, gf.Noise(**base))
    ctx2, _ = _ctx_for(plant, gf.Noise(inputs=0.2, **base))
    src = [gf.Noise(**base).source(3, gf.Noise(**base).process_rows(plant))]
    _, w1 = noise_window(ctx1, noise_streams(ctx1, src), 0, 200)
    _, w2 = noise_window(ctx2, noise_streams(ctx2, src), 0, 200)
    np.testing.assert_array_equal(w2[:2], w1)  # the process rows are unchanged
    assert w2.shape[0] == 4
    assert abs(np.corrcoef(w2[0, 0], w2[2, 0])[0, 1]) < 0.3  # inputs row 0 != process row 0


def _ctx_for(plant, noise):
    bank = gf.design_sensor_bank(plant)
    return prepare(
        plant, bank, np.arange(200) * 0.1, None, None, noise, None, "zoh", True, False, None
    ), plant


def test_counter_stream_take_and_source():
    st = CounterStream(CounterSource(cn.run_key(1), -1), 2, 3, 100)
    zv, zw = st.take(10, 40)
    zv2, zw2 = st.take(0, 100)  # any order
    np.testing.assert_array_equal(zv, zv2[:, 10:40])
    np.testing.assert_array_equal(zw, zw2[:, 10:40])
    with pytest.raises(GeomFDIError):
        st.take(50, 200)


def test_unknown_generator_is_an_error():
    with pytest.raises(GeomFDIError, match="noise.generator") as err:
        gf.Noise(measurement=0.1, generator="mt19937")
    assert err.value.argument == "noise.generator"


# ------------------------------------------------------------------ campaigns
def test_campaign_with_the_counter_generator_is_the_same_for_any_grouping(c_cache):
    from geomfdi.io.cli import design_all
    from geomfdi.io.modelfile import load_model

    spec = load_model(EXAMPLES / "hou_wen_chen.toml")
    bank = design_all(spec)["exact"]
    noise = gf.Noise(measurement=[0.01, 0.02, 0.005], seed=42, generator="counter")
    models = gf.residual_noise_models(spec.plant, bank, noise, step=0.002, controller=spec.K)
    test = gf.ChiSquareTest.design(models, 25, 1e-3)

    def run(block_size, **kw):
        c = gf.Campaign(
            spec.plant, bank,
            scenarios=[gf.Scenario.sensor("bias", 0, sizes=[0.0, 0.02], onsets=[2.5])],
            noise=noise, t=spec.t[:1501], runs=6, test=test, u=spec.u, controller=spec.K,
            x0=spec.x0, block_size=block_size,
        )  # fmt: skip
        return c.run("serial", **kw).table

    a = run(12)
    pd.testing.assert_frame_equal(a, run(4, blocks_per_task=2), check_exact=True)
    numpy_noise = gf.Campaign(
        spec.plant, bank,
        scenarios=[gf.Scenario.sensor("bias", 0, sizes=[0.0, 0.02], onsets=[2.5])],
        noise=gf.Noise(measurement=[0.01, 0.02, 0.005], seed=42), t=spec.t[:1501], runs=6,
        test=test, u=spec.u, controller=spec.K, x0=spec.x0, block_size=12,
    ).run("serial").table  # fmt: skip
    assert not np.array_equal(a["score_pre"].to_numpy(), numpy_noise["score_pre"].to_numpy())


def test_model_files_accept_the_generator(tmp_path):
    from geomfdi.errors import ModelFileError
    from geomfdi.io.modelfile import load_model

    text = (EXAMPLES / "discrete_disturbance.toml").read_text()
    assert "[simulation.noise]" in text
    good = text.replace("[simulation.noise]", '[simulation.noise]\ngenerator = "counter"')
    (tmp_path / "m.toml").write_text(good)
    spec = load_model(tmp_path / "m.toml")
    assert spec.noise["generator"] == "counter"
    assert gf.Noise(**spec.noise).generator == "counter"
    (tmp_path / "bad.toml").write_text(good.replace('"counter"', '"pcg"'))
    with pytest.raises(ModelFileError, match="generator"):
        load_model(tmp_path / "bad.toml")


def test_nonlinear_simulation_draws_the_counter_normals_of_its_seed(compiled):
    from geomfdi.data.three_tank import three_tank_operating_point, three_tank_system

    sys = three_tank_system()
    h, Q = three_tank_operating_point()
    lin = gf.Plant.linearize(sys, h, [*Q, 0.0])
    plant = gf.Plant(lin.A, lin.B[:, :2], lin.C, x_op=h, u_op=Q, y_op=h)
    faults = [gf.ActuatorFault(plant.B[:, 0], name="pump 1"), gf.ActuatorFault(lin.B[:, 2])]
    bank = gf.design_bank(plant, faults, [[0, 1], [1, 0]])
    t = np.arange(0.0, 300.0, 1.0)
    noise = gf.Noise(measurement=1e-3, seed=5, generator="counter")
    noisy = gf.simulate(sys, bank, t, noise=noise)
    clean = gf.simulate(sys, bank, t)
    z = normals(cn.run_key(5)[None], 0, 0, t.size, rows=plant.q)[0]
    np.testing.assert_allclose(noisy.y - clean.y, 1e-3 * z, rtol=0, atol=1e-12)
