"""Generated C, generated Python, ``Monitor.step`` and ``Monitor.feed`` agree sample by
sample on random banks fed with ``nan``, ``+-inf`` and huge samples.

Fifty random banks (discrete, and continuous ones sampled with ``bank.discretize``;
vector rows, missing generators, static generators without states, banks without
inputs, random thresholds, persistence rules and start-up rules) in five batches of ten.
Each batch is compiled once, as one C program driving all ten monitors over binary
files, with AddressSanitizer and UndefinedBehaviorSanitizer when the compiler supports
them (otherwise without, and the test says so in a warning).
"""

from __future__ import annotations

import functools
import importlib.util
import os
import shutil
import subprocess
import warnings
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.deployment.program import SAMPLE_LIMIT

CC = shutil.which("cc")
BASE_FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O0"]
SAN_FLAGS = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all"]
SAN_ENV = {"ASAN_OPTIONS": "detect_leaks=0:abort_on_error=0", "UBSAN_OPTIONS": "halt_on_error=1"}
BATCHES, PER_BATCH, SAMPLES = 5, 10, 48
SPECIAL = [np.nan, np.inf, -np.inf, 1e308, -1e308, 1e155, SAMPLE_LIMIT * 1.0000001]
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler (cc) on this system")


@functools.cache
def sanitizer_flags() -> tuple[str, ...]:
    """The sanitizer flags when a sanitized program compiles and runs here, else ()."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        src, exe = Path(tmp, "t.c"), Path(tmp, "t")
        src.write_text("int main(void) { return 0; }\n")
        built = subprocess.run(
            [CC, *SAN_FLAGS, "-o", str(exe), str(src)], capture_output=True, text=True
        )
        if built.returncode == 0:
            ran = subprocess.run([str(exe)], env={**os.environ, **SAN_ENV}, capture_output=True)
            if ran.returncode == 0:
                return tuple(SAN_FLAGS)
    return ()


# ------------------------------------------------------------------ random banks
def _stable(rng: np.random.Generator, n: int, continuous: bool) -> np.ndarray:
    """A random stable ``F`` (Hurwitz, or spectral radius below 0.95)."""
    F = rng.normal(size=(n, n))
    if n == 0:
        return F
    if continuous:
        return F - (np.max(np.linalg.eigvals(F).real) + rng.uniform(0.3, 2.0)) * np.eye(n)
    rho = np.max(np.abs(np.linalg.eigvals(F)))
    return F * rng.uniform(0.2, 0.95) / rho


def random_bank(seed: int) -> gf.ResidualBank:
    """A random discrete bank (continuous ones sampled at ``dt = 0.05``)."""
    rng = np.random.default_rng(seed)
    continuous = seed % 3 == 0
    q = int(rng.integers(1, 4))
    m = int(rng.choice([0, 0, 1, 2]))  # a third of the banks without inputs
    rows = int(rng.integers(1, 5))
    nf = int(rng.integers(0, 4))
    gens: list[gf.ResidualGenerator | None] = []
    for _ in range(rows):
        if rows > 1 and rng.random() < 0.2:
            gens.append(None)  # a residual that does not exist
            continue
        nw = int(rng.choice([0, 1, 2, 3]))  # order 0: a static generator
        nr = int(rng.choice([1, 1, 2, 3]))  # vector rows: the norm of the components
        gens.append(
            gf.ResidualGenerator(
                _stable(rng, nw, continuous),
                rng.normal(size=(nw, q)),
                rng.normal(size=(nw, m)),
                rng.normal(size=(nr, nw)),
                rng.normal(size=(nr, q)),
                rng.normal(size=(nr, m)),
                dt=0.0 if continuous else 0.05,
            )
        )
    if all(g is None for g in gens):
        gens[0] = gf.ResidualGenerator(
            np.zeros((0, 0)), np.zeros((0, q)), np.zeros((0, m)), np.zeros((1, 0)),
            np.ones((1, q)), np.zeros((1, m)), dt=0.0 if continuous else 0.05,
        )  # fmt: skip
    S = rng.random((rows, nf)) < 0.5
    S[[g is None for g in gens]] = False
    iso = np.array([S[:, j].any() and (S[:, j] != np.delete(S, j, 1).T).any(1).all()
                    for j in range(nf)], dtype=bool)  # fmt: skip
    diags = ["ok" if g is not None else "none" for g in gens]
    faults = [gf.SensorFault(j % q) for j in range(nf)]
    bank = gf.ResidualBank(gens, S.copy(), S, iso, diags, faults, 0.0 if continuous else 0.05)
    return bank.discretize(0.05) if continuous else bank


def random_monitor(seed: int) -> gf.Monitor:
    rng = np.random.default_rng(10_000 + seed)
    bank = random_bank(seed)
    rule = [None, 2, (2, 3), gf.Persistence(2, 3, latch=True, reset=3),
            gf.Persistence(1, 2, latch=True, reset=None)][seed % 5]  # fmt: skip
    nw = sum(g.order for g in bank.generators if g is not None)
    initial = ["steady", "zero", rng.normal(size=nw)][seed % 3]
    thr = rng.uniform(0.5, 3.0, size=bank.n_residuals)
    return gf.Monitor(bank, threshold=thr, persistence=rule, initial=initial)


def random_data(seed: int, q: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    """``Y`` (q, L), ``U`` (m, L): noise, a step, and special values; clean at the end."""
    rng = np.random.default_rng(20_000 + seed)
    Y = rng.normal(size=(q, SAMPLES))
    U = rng.normal(size=(m, SAMPLES))
    Y[:, SAMPLES // 3 :] += rng.uniform(-4, 4, size=(q, 1))  # alarms to decide on
    Y[rng.integers(q), 2] = SAMPLE_LIMIT  # the largest valid value
    for value in SPECIAL:
        for _ in range(2):
            k = int(rng.integers(0, SAMPLES - 10))
            if m and rng.random() < 0.3:
                U[rng.integers(m), k] = value
            else:
                Y[rng.integers(q), k] = value
    return Y, U


def _out_of_range(Y: np.ndarray, U: np.ndarray) -> np.ndarray:
    Z = np.vstack([Y, U])
    return ~(np.abs(Z) <= SAMPLE_LIMIT).all(axis=0)


# ------------------------------------------------------------------ the C driver
def _driver(names: list[str], sizes: list[tuple[int, int, int]]) -> str:
    """``main(in, out)``: for every monitor, read ``Y`` and ``U``, run, write ``R, A, I``."""
    heads = "".join(f'#include "{n}.h"\n' for n in names)
    body = []
    for n, (q, m, r) in zip(names, sizes, strict=True):
        L = SAMPLES
        body.append(f"""    {{
        static {n}_state s;
        static double Y[{L * q}], U[{max(L * m, 1)}], R[{L * r}];
        static int A[{L * r}], I[{L}];
        if (fread(Y, sizeof(double), {L * q}, fi) != {L * q}) return 2;
        if ({L * m} && fread(U, sizeof(double), {L * m}, fi) != {L * m}) return 2;
        {n}_init(&s);
        {n}_run(&s, {L}, Y, U, R, A, I);
        fwrite(R, sizeof(double), {L * r}, fo);
        fwrite(A, sizeof(int), {L * r}, fo);
        fwrite(I, sizeof(int), {L}, fo);
    }}""")
    return f"""#include <stdio.h>
{heads}
int main(int argc, char **argv)
{{
    FILE *fi, *fo;
    if (argc != 3) return 1;
    fi = fopen(argv[1], "rb");
    fo = fopen(argv[2], "wb");
    if (!fi || !fo) return 1;
{chr(10).join(body)}
    fclose(fi);
    fclose(fo);
    return 0;
}}
"""


def _run_c(mons: list[gf.Monitor], data: list[tuple], tmp: Path) -> list[tuple]:
    names = [f"mon{i:02d}" for i in range(len(mons))]
    sources = [str(gf.codegen.c(mon, n, tmp)[1]) for mon, n in zip(mons, names, strict=True)]
    sizes = [(mon.program.q, mon.program.m, mon.n_residuals) for mon in mons]
    (tmp / "driver.c").write_text(_driver(names, sizes))
    flags = list(sanitizer_flags())
    if not flags:
        warnings.warn("the C compiler has no working sanitizers here: built without", stacklevel=1)
    exe = tmp / "driver"
    built = subprocess.run(
        [CC, *BASE_FLAGS, *flags, "-I", str(tmp), "-o", str(exe), str(tmp / "driver.c"),
         *sources, "-lm"], capture_output=True, text=True,
    )  # fmt: skip
    assert built.returncode == 0, built.stderr
    with open(tmp / "in.bin", "wb") as f:
        for Y, U in data:
            f.write(np.ascontiguousarray(Y.T).tobytes())
            f.write(np.ascontiguousarray(U.T).tobytes())
    ran = subprocess.run(
        [str(exe), str(tmp / "in.bin"), str(tmp / "out.bin")],
        env={**os.environ, **SAN_ENV}, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert ran.returncode == 0, ran.stderr[-3000:]  # a sanitizer report fails here
    raw = (tmp / "out.bin").read_bytes()
    out, pos = [], 0
    for _, _, r in sizes:
        L = SAMPLES
        R = np.frombuffer(raw, np.float64, L * r, pos).reshape(L, r).T
        pos += 8 * L * r
        A = np.frombuffer(raw, np.intc, L * r, pos).reshape(L, r).T.astype(bool)
        pos += 4 * L * r
        iso = np.frombuffer(raw, np.intc, L, pos).astype(int)
        pos += 4 * L
        out.append((R, A, iso))
    assert pos == len(raw)
    return out


def _load(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _same(label: str, ref: tuple, got: tuple) -> None:
    R0, A0, I0 = ref
    R, A, iso = got
    np.testing.assert_array_equal(np.isnan(R), np.isnan(R0), err_msg=f"{label}: missing samples")
    ok = ~np.isnan(R0)
    np.testing.assert_allclose(R[ok], R0[ok], rtol=1e-9, atol=1e-9, err_msg=f"{label}: residuals")
    np.testing.assert_array_equal(A, A0, err_msg=f"{label}: alarms")
    np.testing.assert_array_equal(iso, I0, err_msg=f"{label}: decisions")


def _monitor_paths(mon: gf.Monitor, Y: np.ndarray, U: np.ndarray) -> tuple[tuple, tuple]:
    """(``step`` sample by sample, ``feed`` in three uneven chunks) from a fresh state."""
    mon.reset()
    steps = [mon.step(Y[:, k], U[:, k]) for k in range(SAMPLES)]
    ref = (
        np.array([s.residuals for s in steps]).T,
        np.array([s.alarms for s in steps]).T,
        np.array([s.isolated for s in steps]),
    )
    mon.reset()
    parts = [mon.feed(Y[:, a:b], U[:, a:b]) for a, b in ((0, 7), (7, 30), (30, SAMPLES))]
    fed = tuple(np.concatenate([getattr(p, k) for p in parts], axis=-1)
                for k in ("residuals", "alarms", "isolated"))  # fmt: skip
    return ref, fed


@needs_cc
@pytest.mark.slow
@pytest.mark.parametrize("batch", range(BATCHES))
def test_generated_code_equals_monitor_on_random_banks(batch: int, tmp_path: Path) -> None:
    seeds = range(batch * PER_BATCH, (batch + 1) * PER_BATCH)
    mons = [random_monitor(s) for s in seeds]
    data = [
        random_data(s, mon.program.q, mon.program.m) for s, mon in zip(seeds, mons, strict=True)
    ]
    c_out = _run_c(mons, data, tmp_path)
    for s, mon, (Y, U), c_res in zip(seeds, mons, data, c_out, strict=True):
        py = _load(gf.codegen.python(mon, f"mon{s:02d}_py", tmp_path))
        ref, fed = _monitor_paths(mon, Y, U)
        py_res = py.run(Y.T, U.T if mon.program.m else None)
        _same(f"bank {s}, feed", ref, fed)
        _same(f"bank {s}, C", ref, c_res)
        _same(f"bank {s}, Python", ref, (py_res[0].T, py_res[1].T, py_res[2]))
        # the rule itself: out-of-range samples are missing, clean samples are not, and
        # nothing stays nan after the special values (the last ten samples are clean)
        gone = _out_of_range(Y, U)
        assert gone.sum() >= 6
        missing = np.isnan(ref[0]).any(axis=0)
        np.testing.assert_array_equal(missing, gone)
        assert np.isfinite(ref[0][:, -10:]).all()


def test_random_banks_cover_the_shapes() -> None:
    """The fifty banks hold every kind the acceptance asks for."""
    banks = [random_bank(s) for s in range(BATCHES * PER_BATCH)]
    gens = [g for b in banks for g in b.generators if g is not None]
    assert sum(b.info.get("sampled_from") is not None or s % 3 == 0
               for s, b in enumerate(banks)) >= 15  # fmt: skip
    assert any(g.n_outputs > 1 for g in gens) and any(g.order == 0 for g in gens)
    assert any(None in b.generators for b in banks)
    assert sum(b.generators[0] is not None and _m(b) == 0 for b in banks) >= 10
    assert any(b.structure.shape[1] == 0 for b in banks)


def _m(bank: gf.ResidualBank) -> int:
    return next(g.m for g in bank.generators if g is not None)
